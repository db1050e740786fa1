"""Identifying the speed (and the gait) from logs across speeds, against the simulator's physics.

The simulator's gaits (``energy_planner.simulate.gaits``) give the truth a cost per metre
with an interior optimum speed from laws that are not model terms (stride frequency as a
power of the speed, duty factor falling with it, copper losses as 1 / duty); the fit
approximates them with the speed terms. The optimum speed of the fitted model is compared
with the physics' own, found numerically from ``Physics.expected_power``
(``true_optimum_speed``). The cost per metre is flat near its optimum (a 10 % change of
speed there costs well under 1 %), so the speed is judged within 10 % where the logs
bracket it well, and everywhere by what walking at the fitted optimum costs the truth.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from energy_planner.calibration import fit_model
from energy_planner.calibration._windows import aligned_table
from energy_planner.calibration.figures import plot_speed_cost
from energy_planner.calibration.fit import base_terms
from energy_planner.calibration.speed import cost_per_metre, optimum_speed
from energy_planner.cli import main
from energy_planner.measurements import make_windows, preprocess
from energy_planner.model import SPEED_TERMS
from energy_planner.simulate import (
    CampaignConfig,
    GaitSchedule,
    Physics,
    simulate_campaign,
    true_cost_per_metre,
    true_optimum_speed,
    true_path_energy,
)
from energy_planner.uncertainty import predict_interval
from energy_planner.uncertainty.domain import (
    domain_report,
    gait_speed_ranges,
    speed_range,
    stay_in_domain,
)


def _windows(camp):
    clean, _ = preprocess(camp.logs)
    return make_windows(clean, duration=2.0)


@pytest.fixture(scope="module")
def across():
    """A short campaign at 8 speeds 0.15-1.2 m/s, walking and trotting, and its fit."""
    camp = simulate_campaign(seed=0, config=CampaignConfig.across_speeds(small=True))
    w = _windows(camp)
    return camp, w, fit_model(w, n_splits=5, seed=0)


def test_physics_optimum_is_interior_and_moves_with_slope_heading_and_load():
    phys = Physics(effects=("load",), gaits=GaitSchedule())
    opt = {
        key: true_optimum_speed(phys, s, h, channels={"load_kg": kg})
        for key, (s, h, kg) in {
            "level": (0, 0, 0), "up10": (10, 0, 0), "up20": (20, 0, 0),
            "across20": (20, 90, 0), "loaded": (0, 0, 15),
        }.items()
    }  # fmt: skip
    assert all(o["interior"] and o["gait"] == "trot" for o in opt.values())
    v = {k: o["speed"] for k, o in opt.items()}
    assert 0.5 < v["level"] < v["up10"] < v["up20"] < 1.2
    assert v["across20"] > v["level"] * 1.05 and v["loaded"] > v["level"] * 1.05
    # the cost per metre falls to the optimum and rises beyond it (not a model formula)
    c = true_cost_per_metre(phys, [0.15, v["level"], 1.2], 0.0, channels={"load_kg": 0.0})
    assert c["cost_n"][1] < c["cost_n"][0] and c["cost_n"][1] < c["cost_n"][2]


def test_campaign_logs_the_gait_and_single_speed_logs_do_not(across):
    camp, _, _ = across
    by_gait = camp.logs.groupby("gait", observed=True)
    speed = np.hypot(camp.true_samples["vx"], camp.true_samples["vy"])
    assert set(camp.logs["gait"].astype(str)) == {"walk", "trot"}
    assert float(speed[camp.logs["gait"].to_numpy() == "trot"].min()) >= 0.5
    assert by_gait.size().min() > 1000
    plain = simulate_campaign(seed=0, config=CampaignConfig.small())
    assert "gait" not in plain.logs and plain.physics.gaits is None


def test_fit_recovers_the_optimum_speed_of_the_physics(across):
    camp, w, res = across
    floor = camp.noise_floor(w).rmse_w
    assert res.speed_terms.supported
    assert set(SPEED_TERMS) - {"bwd_speed_sq"} <= set(res.model.term_names)
    assert res.heldout.rmse_w <= 1.2 * floor, (res.heldout.rmse_w, floor)
    for slope, heading in [(0, 0), (10, 0), (10, 90), (10, 180), (20, 90)]:
        truth = true_optimum_speed(camp.physics, slope, heading)
        got = optimum_speed(res.model, slope, heading)
        assert got["interior"] and got["gait"] == "trot"
        assert abs(got["speed"] / truth["speed"] - 1) <= 0.10, (slope, heading, got, truth)
    for slope, heading in [(20, 0), (20, 180)]:  # flat optimum: judge the cost of it
        truth = true_optimum_speed(camp.physics, slope, heading)
        got = optimum_speed(res.model, slope, heading)
        paid = true_cost_per_metre(camp.physics, [got["speed"]], slope, heading)["cost_n"][0]
        assert paid <= 1.01 * truth["cost_n"], (slope, heading, got, truth)


def test_gait_channel_is_identified(across):
    _, _, res = across
    gait_terms = [n for n in res.model.term_names if "gait ==" in n]
    assert len(gait_terms) == 6 and all("'trot'" in n for n in gait_terms)
    assert res.speed_terms.reference_gait == "walk"
    ranges = gait_speed_ranges(res.model)
    assert ranges["walk"][1] < 0.5 <= ranges["trot"][1] and ranges["trot"][0] > 0.35
    # what the gaits' physics differ by: at 0.5 m/s, the cost per metre of trotting over
    # walking (the truth with each gait forced), up the fall line, to 20 J/m (~3 %)
    camp = across[0]
    for slope in (0.0, 10.0, 20.0):
        f = {"alpha": np.radians([slope] * 2), "gamma": np.zeros(2), "vx": np.full(2, 0.5),
             "vy": np.zeros(2), "wz": np.zeros(2), "gait": np.array(["walk", "trot"])}  # fmt: skip
        walk, trot = camp.physics.expected_power(f) / 0.5
        model = [cost_per_metre(res.model, [0.5], slope, gait=g)[0] for g in ("walk", "trot")]
        assert abs((model[1] - model[0]) - (trot - walk)) <= 20.0, (slope, model, walk, trot)
    with pytest.raises(Exception, match="gait"):
        cost_per_metre(res.model, [0.5], 0.0)


def test_single_speed_fit_says_the_speed_terms_are_unsupported():
    camp = simulate_campaign(seed=0, config=CampaignConfig.small())
    w = _windows(camp)
    assert not set(SPEED_TERMS) & set(base_terms(w))  # today's base model
    assert not [t for t in base_terms(w) if "gait ==" in t]
    res = fit_model(w, n_splits=0)
    assert not res.speed_terms.supported
    assert not set(SPEED_TERMS) & set(res.model.term_names)
    assert "speed terms: unsupported (steady walking 0.2" in res.summary()
    doc = res.to_dict()["speed_terms"]
    assert doc["supported"] is False and doc["terms"] == [] and "3x" in doc["reason"]
    assert res.model.metadata["fit"]["speed_terms"]["supported"] is False


def test_speed_outside_the_logged_range_is_outside_the_domain(across):
    _, _, res = across
    lo, hi = speed_range(res.model)
    assert 0.1 < lo < 0.15 and 1.15 < hi < 1.25

    def seg(speed):
        return pd.DataFrame({"distance_m": [speed * 10.0], "duration_s": [10.0],
                             "max_slope_deg": [5.0], "turn_deg": [0.0]})  # fmt: skip

    inside, fast = domain_report(res.model, seg(0.8)), domain_report(res.model, seg(1.6))
    assert inside["shares"]["speed"] == 0.0 and fast["shares"]["speed"] == 1.0
    assert math.isclose(fast["excess"]["speed"], 1.6 - hi, abs_tol=1e-6)
    a, b = (
        predict_interval(res.model, 5000.0, domain=inside),
        predict_interval(res.model, 5000.0, domain=fast),
    )
    assert (b.high_j - b.low_j) > (a.high_j - a.low_j)
    from energy_planner.request import Request

    req, notes = stay_in_domain(Request.make(speed=1.6), res.model)
    assert req.robot.speed == hi and any("clamped" in n for n in notes)


def test_speed_figure_marks_the_optimum(across, tmp_path):
    _, w, res = across
    got = plot_speed_cost(aligned_table(w), res.model, tmp_path / "s.png")
    assert (tmp_path / "s.png").stat().st_size > 10_000
    level = next(p for p in got["panels"] if p["label"] == "level")
    assert level["optimum_gait"] == "trot" and 0.6 < level["optimum_speed"] < 0.8


def test_simulate_cli_speed_range_and_gaits(tmp_path):
    out = tmp_path / "c"
    r = CliRunner().invoke(main, ["simulate", "--out", str(out), "--small", "--speeds",
                                  "0.2:1.0:3", "--gaits", "walk,trot", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    log = pd.read_csv(next(out.glob("straight_forward_*_v1_r0.csv")))
    assert set(log["gait"]) == {"walk", "trot"}  # walks on the ramps, trots at 1 m/s
    bad = CliRunner().invoke(main, ["simulate", "--out", str(tmp_path / "x"), "--speeds", "1:0.2"])
    assert bad.exit_code == 2 and "LOW:HIGH" in bad.output
    bad = CliRunner().invoke(main, ["simulate", "--out", str(tmp_path / "x"), "--gaits", "run"])
    assert bad.exit_code == 2 and "walk" in bad.output


def test_true_path_energy_walks_a_speed_profile_with_gaits():
    """The truth of a path at a speed per segment: each leg's energy is its length times
    the truth's cost per metre at that speed and gait (the same physics, per sample)."""
    from energy_planner.terrain import Terrain

    a = math.radians(10)
    plane = Terrain.from_function(lambda x, y: math.tan(a) * y, size=(60.0, 60.0), resolution=1.0)
    up = [[30.0, 5.0, math.pi / 2], [30.0, 25.0, math.pi / 2], [30.0, 45.0, math.pi / 2]]
    gaits = GaitSchedule()
    got = true_path_energy(plane, up, speed=[0.3, 0.9], gaits=gaits)
    phys = Physics(gaits=gaits)
    cost = true_cost_per_metre(phys, [0.3, 0.9], 10.0)["cost_n"]
    assert got.segments["energy_j"].to_numpy() == pytest.approx(cost * 20.0 / math.cos(a))
    assert got.duration_s == pytest.approx(20.0 / math.cos(a) * (1 / 0.3 + 1 / 0.9))
    with pytest.raises(Exception, match="one per segment"):
        true_path_energy(plane, up, speed=[0.3, 0.6, 0.9])
