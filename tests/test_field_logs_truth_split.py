"""``benchmarks/field_logs_truth_split.py``: a mission's energy error split against the truth.

Its parts are checked on cases whose answer is known without the script: a model of
constant power (its energy over any motion is the power times the time), a truth that the
model's terms express exactly (least squares recovers the coefficients), and motions
built by hand.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from _benchmarks import load_benchmark

split = load_benchmark("field_logs_truth_split")


def test_motion_of_names_each_motion_by_the_true_twist():
    """Standing, turning in place, a ramp, and forward / backward / sideways walking."""
    f = {
        "vx": np.array([0.0, 0.0, 0.2, 0.3, -0.3, 0.05, 0.04]),
        "vy": np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.3, 0.0]),
        "wz": np.array([0.01, 0.5, 0.0, 0.2, 0.0, 0.0, 0.0]),
        "ax": np.array([0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0]),
        "ay": np.zeros(7),
    }
    assert split.motion_of(f).tolist() == ["stand", "turn", "ramp", "fwd", "bwd", "lat", "stand"]


@pytest.fixture(scope="module")
def missions():
    from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem

    terrain = synthetic_dem(0, size_m=100.0)
    cfg = MissionConfig.varied(missions=2, duration_s=30.0, loads_kg=(0.0, 9.0))
    return simulate_missions(seed=0, effects=("load",), config=cfg, terrain=terrain), terrain


def test_a_constant_power_costs_its_power_times_the_time(missions):
    """A model of 150 W everywhere: on the true motion and along the logged poses alike the
    mission costs 150 W x its duration; the truth's part and the battery's come from the
    simulator as logged, and the three parts add up to the error."""
    from energy_planner.model import EnergyModel

    camp, terrain = missions
    model = EnergyModel(["idle_power"], {"idle_power": 150.0})
    t = split.split_missions(camp, terrain, model).set_index("run")
    dur = camp.true_samples.groupby("run")["t"].agg(lambda s: s.iloc[-1] - s.iloc[0])
    np.testing.assert_allclose(t["model_true"], 150.0 * dur.reindex(t.index), rtol=1e-9)
    np.testing.assert_allclose(t["predicted"], 150.0 * dur.reindex(t.index), rtol=1e-6)
    true = camp.true_samples.groupby("run").apply(
        lambda g: np.trapezoid(g["power_expected"], g["t"]), include_groups=False
    )
    np.testing.assert_allclose(t["true"], true.reindex(t.index), rtol=1e-7)
    # the model part by motion sums to the model part
    parts = t[[f"model_{m}" for m in split.MOTIONS]].sum(axis=1)
    np.testing.assert_allclose(parts, t["model_true"] - t["true"], rtol=1e-6)
    np.testing.assert_allclose(t[[f"share_{m}" for m in split.MOTIONS]].sum(axis=1), 1.0)
    b = split.by_load(t.reset_index())
    np.testing.assert_allclose(b["error"], b["noise"] + b["model"] + b["path"], atol=1e-9)


class _Truth:
    """A campaign stand-in whose true power is the given terms' sum with known coefficients."""

    def __init__(self, model, coef, loads):
        rng = np.random.default_rng(1)
        n = 400
        self.f = {
            "alpha": rng.uniform(0, 0.3, n),
            "gamma": rng.uniform(-np.pi, np.pi, n),
            "vx": rng.uniform(-0.4, 0.5, n),
            "vy": rng.uniform(-0.2, 0.2, n),
            "wz": rng.uniform(-0.5, 0.5, n),
            "ax": np.zeros(n),
            "ay": np.zeros(n),
            "load_kg": np.repeat(loads, n // len(loads)),
        }
        y = model.design_matrix(self.f) @ coef
        self.true_samples = pd.DataFrame({"power_expected": y})

    def features(self):
        return self.f


def test_family_fits_recover_coefficients_the_truth_is_made_of():
    """A truth made of the model's own terms: the joint fit and the fit anchored at load 0
    both return its coefficients, and every load's energy error is 0."""
    from energy_planner.model import EnergyModel

    terms = ["idle_power", "fwd_const", "fwd_up", "turn_const", "load_kg * speed", "load_kg ** 2"]
    coef = np.array([60.0, 170.0, 600.0, 90.0, 4.0, 0.05])
    model = EnergyModel(terms, dict(zip(terms, coef * 0.9, strict=True)))
    camp = _Truth(model, coef, [0.0, 9.0, 27.0, 18.0])
    fits = split.family_fits(model, camp)
    np.testing.assert_allclose(fits["joint"], coef, rtol=1e-8)
    np.testing.assert_allclose(fits["load 0 base"], coef, rtol=1e-8)
    err = split.family_errors(model, camp, fits)
    np.testing.assert_allclose(err.loc[["joint", "load 0 base"]].to_numpy(), 0.0, atol=1e-8)
    # the written coefficients (0.9 of the truth) price every load 10 % low
    np.testing.assert_allclose(err.loc["written"].to_numpy(), -10.0, atol=1e-8)
