"""Intervals beyond the logs: the domain counted per metre, the error growth beyond a range
measured by holding out the most extreme runs, and no battery decision where it cannot be.

The per-metre share is checked on a surface whose slope grows along the path (``z = a x^2
/ 2``: the slope crosses the limit at ``x* = tan(limit) / a``), against the surface length
beyond ``x*`` integrated by scipy. The growth is measured on window tables made by hand from
a "true" power with a term the model lacks (so the fit extrapolates wrongly), not from the
model's own formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from energy_planner.calibration.fit import extrapolation_growth
from energy_planner.model import EnergyModel
from energy_planner.terrain import Terrain
from energy_planner.uncertainty import (
    ExtrapolationError,
    battery_decision,
    path_trust,
    predict_interval,
)
from energy_planner.uncertainty.domain import path_samples, report_against
from energy_planner.uncertainty.errormodel import ErrorModel

A = 0.02  # z = A x^2 / 2: the slope is atan(A x)
N = 120


def _bowl() -> Terrain:
    x = np.arange(N, dtype=float)  # cell centres at x = 0.5 .. N - 0.5 (origin 0)
    z = 0.5 * A * (x + 0.5) ** 2
    return Terrain.from_array(np.tile(z, (N, 1)), resolution=1.0, origin=(0.0, 0.0))


def _dom(max_slope: float) -> dict:
    return {"max_slope_deg": max_slope, "speed_m_s": [0.2, 0.4], "max_turn_rate_rad_s": 0.5,
            "gaits": {"forward": {"windows": 9, "rel_heading_deg": [0.0, 180.0]}},
            "channels": {}}  # fmt: skip


@settings(max_examples=15, deadline=None)
@given(limit=st.floats(20.0, 50.0))
def test_share_counts_the_metres_beyond_the_limit_on_one_segment(limit):
    """One segment from x = 10 to 110 m; the slope passes ``limit`` at x*."""
    x0, x1, y = 10.0, 110.0, 60.0
    xs = math.tan(math.radians(limit)) / A
    ground = lambda a, b: quad(lambda x: math.sqrt(1 + (A * x) ** 2), a, b)[0]  # noqa: E731
    total = ground(x0, x1)
    want = ground(min(max(xs, x0), x1), x1) / total
    over = quad(lambda x: max(math.degrees(math.atan(A * x)) - limit, 0.0)
                * math.sqrt(1 + (A * x) ** 2), x0, x1)[0] / total  # fmt: skip
    poses = np.array([[x0, y, 0.0], [x1, y, 0.0]])
    along = path_samples(_bowl(), poses, n_segments=1)
    seg = {"duration_s": [total / 0.3], "distance_m": [total], "turn_deg": [0.0],
           "max_slope_deg": [float(np.max(along["slope_deg"][0]))]}  # fmt: skip
    rep = report_against(_dom(limit), seg, along=along)
    # half-metre pieces: the crossing piece is the only one counted wrongly
    assert rep["shares"]["slope"] == pytest.approx(want, abs=0.5 / total + 1e-4)
    assert rep["excess"]["slope"] == pytest.approx(over, rel=0.02, abs=1e-3)
    # per segment (without the samples) the whole segment was outside
    assert report_against(_dom(limit), seg)["shares"]["slope"] == (1.0 if want > 0 else 0.0)


def _runs(quadratic: float, slopes=(0.0, 5.0, 10.0, 15.0, 20.0), per=6, seed=0, load=None):
    """Windows of runs on ramps: the model is ``c0 + c1 sin(alpha)``, the truth adds
    ``quadratic * sin(alpha)^2`` and 1 % noise per run."""
    rng = np.random.default_rng(seed)
    rows = []
    for s in slopes:
        for k in range(per):
            run_noise = 1.0 + rng.normal(0.0, 0.01)
            for _ in range(5):
                a = np.radians(s + rng.normal(0.0, 0.3))
                p = (150.0 + 400.0 * np.sin(a) + quadratic * np.sin(a) ** 2) * run_noise
                rows.append({"run": f"s{s:g}_{k}", "alpha": a, "speed": 0.3, "vx": 0.3,
                             "vy": 0.0, "wz": 0.0, "gamma": 0.0, "kind": "forward",
                             "duration": 2.0, "power": p,
                             "load_kg": 5.0 if load is None else load})  # fmt: skip
    t = pd.DataFrame(rows)
    X = np.column_stack([np.ones(len(t)), np.sin(t["alpha"].to_numpy())])
    return t, X, t["power"].to_numpy(), t["duration"].to_numpy()


EM = ErrorModel(0.0, 1e-4, 0.0, None, np.linspace(-1.645, 1.645, 199), mean_power_w=250.0)


def test_growth_is_positive_and_finite_when_the_fit_misses_a_term():
    t, X, y, w = _runs(quadratic=3000.0)
    model = _two_terms()
    got = extrapolation_growth(model, t, X, y, w, EM)
    g = got["slope"]["growth_per_unit"]
    assert g is not None and 0.0 < g < 1.0 and math.isfinite(g)
    assert got["slope"]["held_out_runs"] == 6  # the 20 deg level, kept whole
    lo, hi = got["slope"]["excess"]
    assert 3.0 < lo <= hi < 6.0  # 20 deg beyond the rest's 15 deg (+ noise)
    # a bigger missing term grows faster; a model of the truth's family does not grow
    t2, X2, y2, w2 = _runs(quadratic=6000.0)
    assert extrapolation_growth(model, t2, X2, y2, w2, EM)["slope"]["growth_per_unit"] > g
    t0, X0, y0, w0 = _runs(quadratic=0.0)
    assert extrapolation_growth(model, t0, X0, y0, w0, EM)["slope"]["growth_per_unit"] < 0.1 * g


def _two_terms() -> EnergyModel:
    from energy_planner.model.terms import Term

    ts = [Term("c0", "1", unit="W"), Term("c1", "sin(alpha)", unit="W")]
    return EnergyModel(ts, {"c0": 150.0, "c1": 400.0})


def test_nothing_to_hold_out_refuses_a_battery_decision_beyond_the_range():
    """One load in every run: its range cannot be left in a held-out test, so a path with
    a heavier load gets an interval marked not calibrated and no battery decision."""
    t, X, y, w = _runs(quadratic=3000.0, load=5.0)
    got = extrapolation_growth(_two_terms(), t, X, y, w, EM)
    assert got["speed"]["growth_per_unit"] is None and "too" in got["speed"]["why"]
    few, Xf, yf, wf = _runs(quadratic=3000.0, slopes=(0.0, 20.0), per=1)  # 2 runs
    assert extrapolation_growth(_two_terms(), few, Xf, yf, wf, EM)["slope"][
        "growth_per_unit"] is None  # fmt: skip
    unmeasured = {"growth_per_unit": None, "why": "one value in the logs"}
    em = ErrorModel(0.0, 1e-4, 0.0, None, EM.scores, 250.0,
                    extrapolation={**got, "channel load_kg": unmeasured})  # fmt: skip
    model = EnergyModel(["idle_power"], {"idle_power": 250.0},
                        metadata={"fit": {"error_model": em.to_dict()}})  # fmt: skip
    beyond = {"shares": {"slope": 0.3, "channel load_kg": 1.0},
              "excess": {"slope": 2.0, "channel load_kg": 13.0}}  # fmt: skip
    iv = predict_interval(model, 1e5, domain=beyond)
    assert not iv.calibrated and "load_kg" in iv.text() and "one value" in iv.text()
    with pytest.raises(ExtrapolationError, match="load_kg"):
        battery_decision(model, 1e5, battery_wh=100.0, domain=beyond)
    tr = path_trust(model, 1e5, domain=beyond, battery_wh=100.0)
    assert tr.battery is None and "load_kg" in tr.battery_refused
    assert tr.to_dict()["battery"] is None
    # the slope alone is covered by its measured growth: calibrated, decided, wider
    slope_only = {"shares": {"slope": 0.3}, "excess": {"slope": 2.0}}
    iv2 = predict_interval(model, 1e5, domain=slope_only)
    inside = predict_interval(model, 1e5, domain={"shares": {}, "excess": {}})
    assert iv2.calibrated and iv2.high_j - iv2.low_j > inside.high_j - inside.low_j
    assert battery_decision(model, 1e5, battery_wh=100.0, domain=slope_only).probability > 0.9


def test_error_model_keeps_its_growth_in_the_model_file():
    em = ErrorModel(0.0, 1e-4, 0.0, None, EM.scores, 250.0,
                    extrapolation={"slope": {"growth_per_unit": 0.004, "unit": "deg"}})  # fmt: skip
    back = ErrorModel.from_dict(em.to_dict())
    assert back.extrapolation == em.extrapolation
    out = back.outside({"shares": {"slope": 0.5}, "excess": {"slope": 5.0}})
    assert out.extra_rel_var == pytest.approx((0.004 * 5.0) ** 2) and out.share == 0.0
