"""The best speed of a motion: closed form against the analytic optimum of simple laws.

A model whose power is ``a v + b + c v^2`` costs ``a + b / v + c v`` per metre: least at
``sqrt(b / c)``. One whose power is ``a v + b + c v^3`` costs ``a + b / v + c v^2`` per
metre: least at ``(b / (2 c))^(1/3)``. Both clamped to the speed range. Calculus, not the
code, gives these numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from energy_planner.energy.speed import best_speed, speed_law
from energy_planner.model import EnergyModel

# one worker: every test here calls the parallel kernel laurent_argmin_batch, whose first
# compile (a fresh checkout's empty numba cache) takes ~15 CPU s; tests spread over two
# workers compiled it twice, side by side
pytestmark = pytest.mark.xdist_group("speed_choice")


def _model(a: float, b: float, c: float, degree: int) -> EnergyModel:
    """Power ``a v + b + c v^degree`` (terms ``speed``, ``1``, ``speed ** degree``)."""
    top = f"speed ** {degree}"
    return EnergyModel(["speed", "1", top], {"speed": a, "1": b, top: c})


def test_law_of_the_paper_model_and_of_a_swing_term():
    """Degrees come from the formulas: per-second 0, per-metre 1, swing losses 2."""
    law = speed_law(_model(100.0, 40.0, 30.0, 2))
    assert law.exponents == (-1, 0, 1)
    assert law.degrees == {"speed": 1, "1": 0, "speed ** 2": 2}
    assert law.polynomial
    base = speed_law(EnergyModel.default())
    assert base.degrees["idle_power"] == 0 and base.degrees["fwd_const"] == 1
    # the brake terms switch on below 0.05 m/s of forward speed: not homogeneous
    assert base.degrees["fwd_brake_sq"] is None


@pytest.mark.parametrize(
    ("b", "c", "lo", "hi"),
    [(40.0, 100.0, 0.1, 2.0), (40.0, 10.0, 0.1, 1.5), (40.0, 1000.0, 0.3, 1.5)],
)
def test_sqrt_b_over_c_on_a_plane(b, c, lo, hi):
    """Cost per metre a + b/v + c v: the chosen speed is sqrt(b/c) clamped, to 1 %."""
    m = _model(120.0, b, c, 2)
    alpha = np.zeros(3)
    gamma = np.array([0.0, 1.0, -2.0])
    got = best_speed(m, alpha, gamma, np.array([0.0, 0.5, math.pi]), speed_range=(lo, hi))
    want = min(max(math.sqrt(b / c), lo), hi)
    np.testing.assert_allclose(got.speed, want, rtol=0.01)
    assert got.closed_form.all()
    np.testing.assert_allclose(got.energy_per_metre, 120.0 + b / want + c * want, rtol=1e-9)


def test_cube_root_for_cubic_swing_losses():
    """Cost per metre a + b/v + c v^2: least at (b / 2c)^(1/3)."""
    m = _model(120.0, 40.0, 90.0, 3)
    got = best_speed(m, 0.0, 0.0, speed_range=(0.1, 3.0))
    assert float(got.speed) == pytest.approx((40.0 / 180.0) ** (1 / 3), rel=1e-6)


def test_time_weight_is_one_more_per_second_term():
    """Energy + lambda * time: the optimum moves to sqrt((b + lambda) / c)."""
    m = _model(120.0, 40.0, 100.0, 2)
    got = best_speed(m, 0.0, 0.0, speed_range=(0.1, 3.0), time_weight=60.0)
    assert float(got.speed) == pytest.approx(math.sqrt(100.0 / 100.0), rel=1e-6)


def test_kinked_model_falls_back_to_the_scalar_minimisation():
    """A term with a switch inside the range: the fit fails its check, golden section chooses."""
    m = EnergyModel(["1", "speed ** 2", "min(speed / 0.6, 1)"],
                    {"1": 40.0, "speed ** 2": 100.0, "min(speed / 0.6, 1)": 30.0})  # fmt: skip
    got = best_speed(m, 0.0, 0.0, speed_range=(0.2, 1.5))
    vs = np.linspace(0.2, 1.5, 20001)
    per_m = (40.0 + 100.0 * vs**2 + 30.0 * np.minimum(vs / 0.6, 1)) / vs
    assert not bool(got.closed_form)
    assert float(got.speed) == pytest.approx(vs[np.argmin(per_m)], abs=1e-3)


@settings(max_examples=40, deadline=None)
@given(
    b=st.floats(1.0, 200.0),
    c=st.floats(1.0, 500.0),
    lo=st.floats(0.05, 1.0),
    width=st.floats(0.0, 2.0),
)
@example(b=1.0, c=1.0, lo=1.0, width=3.783509259812634e-09)  # a range of a few nm/s
def test_clamped_and_monotone_in_b_over_c(b, c, lo, width):
    """Always inside the range, equal to the clamped optimum, and rising with b / c."""
    hi = lo + width
    m = _model(50.0, b, c, 2)
    v = float(best_speed(m, 0.0, 0.0, speed_range=(lo, hi)).speed)
    assert lo <= v <= hi
    assert v == pytest.approx(min(max(math.sqrt(b / c), lo), hi), rel=1e-6)
    v2 = float(best_speed(_model(50.0, 2 * b, c, 2), 0.0, 0.0, speed_range=(lo, hi)).speed)
    assert v2 >= v * (1 - 1e-9)
