"""A formula gives the same number evaluated by numpy and compiled by numba.

The numpy evaluation (:meth:`Formula.evaluate`, used by fitting and diagnosis) and the
compiled kernel (:meth:`Formula.to_scalar_source`, used by planning and energy maps)
are two implementations of one formula; these tests hold them to the same number for
every input, NaN, infinities, negative numbers and zeros included. The reference
values of the named cases are IEEE 754 / C99 results (NaN in, NaN out; x / 0 = inf).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.model import EnergyModel
from energy_planner.model._codegen import compile_kernel
from energy_planner.model.formula import FUNCTIONS, parse_formula

ARGS = ("alpha", "gamma", "vx", "vy", "wz", "ax", "ay")

#: Every whitelisted function and operator, alone and nested; no subtraction of two
#: transcendental results (a last-bit difference between libm and numpy's SIMD
#: functions would be amplified by cancellation, which is not what is tested here).
FORMULAS = [
    "sin(alpha)",
    "cos(gamma)",
    "tan(alpha)",
    "abs(vx)",
    "sqrt(vx)",
    "exp(vy)",
    "log(vx)",
    "pos(vx)",
    "min(vx, vy)",
    "max(vx, vy)",
    "sign(vx)",
    "max(1.0, sqrt(vx))",
    "min(sqrt(vx), 1.0)",
    "sign(vx) + 1",
    "pos(-vx) * sin(alpha)",
    "1 / pos(vx)",
    "1 / sign(vx)",
    "1 / max(vx, vy)",
    "vx / vy",
    "vx ** vy",
    "vx ** 0.5",
    "vx ** 2",
    "wz ** -1",
    "(vx < vy) + 2 * (vx == vy) + 4 * (vx != vy) + 8 * (vx >= 0)",
    "g * pi * ax * (ay > vx)",
    "abs(vy) * cos(alpha) * exp(-abs(wz))",
    "max(pos(vx), min(vy, sign(wz)))",
]


def _kernel():
    body = ",\n        ".join(
        parse_formula(f).to_scalar_source({a: a for a in ARGS}, {}) for f in FORMULAS
    )
    src = f"def power({', '.join(ARGS)}):\n    return (\n        {body},\n    )\n"
    return compile_kernel(src)


@pytest.fixture(scope="module")
def kernel():
    return _kernel()


def _assert_same(numpy_value: float, kernel_value: float, formula: str, row) -> None:
    where = f"{formula!r} at {dict(zip(ARGS, row, strict=True))}"
    if math.isnan(numpy_value) or math.isnan(kernel_value):
        assert math.isnan(numpy_value) and math.isnan(kernel_value), (
            f"{where}: numpy {numpy_value!r}, kernel {kernel_value!r}"
        )
    elif math.isinf(numpy_value) or numpy_value == 0.0:
        # infinities and zeros exactly, the sign of a zero included (1/x tells them apart)
        assert numpy_value == kernel_value, f"{where}: numpy {numpy_value!r} != {kernel_value!r}"
        assert math.copysign(1, numpy_value) == math.copysign(1, kernel_value), where
    else:  # libm and numpy's SIMD transcendental functions may differ in the last bit
        assert kernel_value == pytest.approx(numpy_value, rel=1e-12, abs=0), (
            f"{where}: numpy {numpy_value!r}, kernel {kernel_value!r}"
        )


def _compare(kernel, rows: np.ndarray) -> None:
    feats = {a: rows[:, i] for i, a in enumerate(ARGS)}
    ref = [parse_formula(f).evaluate(feats) for f in FORMULAS]
    for r, row in enumerate(rows):
        got = kernel(*(float(v) for v in row))
        for k, f in enumerate(FORMULAS):
            _assert_same(float(ref[k][r]), got[k], f, row)


def test_the_formulas_call_every_whitelisted_function():
    used = set()
    for f in FORMULAS:
        used |= {name for name in FUNCTIONS if f"{name}(" in f}
    assert used == set(FUNCTIONS)


SPECIAL = [math.nan, math.inf, -math.inf, 0.0, -0.0, -1.0, 1.0, 0.5, -2.5, 1e308, -1e-310]


@pytest.mark.parametrize("x", SPECIAL)
@pytest.mark.parametrize("y", SPECIAL)
def test_edge_values_agree(kernel, x, y):
    rows = np.array([[x, y, x, y, y, x, y]], dtype=float)
    _compare(kernel, rows)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(*[st.floats(allow_nan=True, allow_infinity=True)] * len(ARGS)),
        min_size=1,
        max_size=8,
    )
)
def test_numpy_and_compiled_kernel_agree(kernel, rows):
    _compare(kernel, np.array(rows, dtype=float))


def test_the_issue_cases(kernel):
    """IEEE results: NaN propagates through max and sign; x / 0 is inf, not an error."""
    names = {f: k for k, f in enumerate(FORMULAS)}
    out = kernel(0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0)  # vx = -1, vy = 0
    assert math.isnan(out[names["max(1.0, sqrt(vx))"]])  # sqrt(-1) is NaN
    assert out[names["vx / vy"]] == -math.inf
    out = kernel(0.0, 0.0, math.nan, 0.0, 0.0, 0.0, 0.0)
    assert math.isnan(out[names["sign(vx) + 1"]])
    assert math.isnan(out[names["pos(vx)"]])


def test_a_nan_channel_constant_compiles_and_propagates():
    """``--set payload_kg=nan``: the kernel compiles and gives NaN, as numpy does."""
    term = "max(1.0, payload_kg) * speed"
    m = EnergyModel([term], {term: 2.0})
    power = m.power_kernel({"payload_kg": math.nan})
    total, _ = power(0.1, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0)
    row = (0.1, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0)
    feats = {a: np.array([v]) for a, v in zip(ARGS, row, strict=True)}
    feats["speed"] = np.array([0.3])
    feats["payload_kg"] = np.array([math.nan])
    assert math.isnan(total) and math.isnan(float(m.power(feats)[0]))
    # an infinite one too (repr(inf) is not a name either)
    total, _ = m.power_kernel({"payload_kg": math.inf})(0.1, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0)
    assert total == math.inf
