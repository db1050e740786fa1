"""Calibration end to end on simulated campaigns (simulator -> measurements -> fit).

Tolerances come from the simulator's sensor model (``SensorConfig`` defaults):

* Odometry slip ``s = slip_mean + slip_per_sin_slope * sin(alpha)`` makes the measured
  twist ``1 - s`` times the true one while the battery pays for the true motion, so the
  forces the logs show are ``F_true / (1 - s)``. With only ``slip_mean = 0.02`` (no slope
  term, no run-to-run spread, no IMU bias) the truth stays inside the base model and
  every coefficient should come out as ``c_true / 0.98``.
* Twist noise (0.01 m/s, smoothed by the 0.2 s EMA of preprocessing to ~0.004 m/s) is
  rectified by ``abs``/``pos`` in the terms: a turn in place shows ``E|vy| ~ 0.003 m/s``
  of sideways "motion", which the model prices at ``lat_const * 0.003 + ...`` ~ 4 W of
  the ~125 W of a turn (3.5 %), so the joint fit lowers turn_const by that much; for
  straight motion the same effect is ~1.3 %. Hence the 5 % tolerance on coefficients
  (4 % errors-in-variables bias + a few standard errors).
"""

from __future__ import annotations

import numpy as np
import pytest

from energy_planner.calibration import cross_validate, fit_forces, fit_model, force_estimates
from energy_planner.calibration.figures import (
    plot_force_slope,
    plot_superposition,
    plot_yaw_torque,
    run_energy,
    superposition_table,
)
from energy_planner.measurements import make_windows, preprocess
from energy_planner.model import BASE_TERMS, EnergyModel
from energy_planner.simulate import (
    BASE_COEFFICIENTS,
    EFFECTS,
    CampaignConfig,
    SensorConfig,
    simulate_campaign,
)

#: Sensors whose only systematic effect is a constant slip: truth inside the base model.
INSIDE = SensorConfig(slip_per_sin_slope=0.0, slip_std=0.0, imu_bias_deg=0.0)


def _windows(camp):
    clean, _ = preprocess(camp.logs)
    return make_windows(clean, duration=2.0)


@pytest.fixture(scope="module")
def inside():
    camp = simulate_campaign(seed=0, config=CampaignConfig.small(sensors=INSIDE))
    return camp, _windows(camp)


@pytest.fixture(scope="module")
def inside_fit(inside):
    return fit_model(inside[1], n_splits=5, seed=0)


@pytest.fixture(scope="module")
def default_small():
    camp = simulate_campaign(seed=1, config=CampaignConfig.small())
    return camp, _windows(camp)


def test_base_fit_recovers_forces(inside, inside_fit):
    slip = INSIDE.slip_mean
    for name, true in BASE_COEFFICIENTS.items():
        expect = true / (1 - slip)
        got = inside_fit.coefficients[name]
        assert got == pytest.approx(expect, rel=0.05), (name, got, expect)
    assert inside_fit.n_runs == len(inside[0].runs) - 3  # the 3 standing runs have no windows
    assert inside_fit.warnings == []


def test_heldout_run_energies_within_3_percent(inside_fit):
    cv = inside_fit.heldout
    err = cv.runs["rel_error"].abs()
    assert err.mean() < 0.015
    assert np.percentile(err, 95) < 0.03
    assert abs(cv.energy_total_rel) < 0.005
    assert cv.r2 > 0.98


def test_per_motion_force_fit_recovers_forces(inside):
    """The paper's per-motion force fit (P / v per window, then per motion) agrees too."""
    res = fit_forces(inside[1])
    for name, true in BASE_COEFFICIENTS.items():
        assert res.coefficients[name] == pytest.approx(true / 0.98, rel=0.06), name
    assert set(res.per_kind["kind"]) == {"forward", "backward", "lateral", "turning"}


def test_default_sensors_give_slip_scaled_forces(default_small):
    """With slope-dependent slip, the fitted forces are the truth over (1 - s(alpha)).

    Slip spread between runs (1 %) and IMU tilt bias (0.3 deg -> 5 N of grade force)
    add scatter; 6 % covers them and the rectified twist noise (<= 1.5 % for straight
    motion). Turning in place carries 3.5 % of rectified noise (module docstring) and
    rests on only six turn runs in the small campaign: 8 %.
    """
    camp, w = default_small
    res = fit_model(w, n_splits=5)
    truth = EnergyModel(BASE_TERMS, BASE_COEFFICIENTS)
    s = SensorConfig()
    alpha = np.radians([0.0, 10.0, 20.0])
    slip = s.slip_mean + s.slip_per_sin_slope * np.sin(alpha)
    cases = {  # (gamma, vx, vy, wz): travel up/down the fall line, turn in place
        "forward up": (0.0, 0.3, 0.0, 0.0),
        "forward down": (np.pi, 0.3, 0.0, 0.0),
        "backward up": (np.pi, -0.3, 0.0, 0.0),
        "lateral up": (-np.pi / 2, 0.0, 0.3, 0.0),
        "lateral down": (np.pi / 2, 0.0, 0.3, 0.0),
        "turn": (0.0, 0.0, 0.0, 0.5),
    }
    for label, (g, vx, vy, wz) in cases.items():
        f = {
            "alpha": alpha,
            "gamma": np.full(3, g),
            "vx": np.full(3, vx),
            "vy": np.full(3, vy),
            "wz": np.full(3, wz),
        }
        expect = truth.power(f) / (1 - slip)
        rtol = 0.08 if label == "turn" else 0.06
        np.testing.assert_allclose(res.model.power(f), expect, rtol=rtol, err_msg=label)
    cv = res.heldout
    assert cv.energy_mean_abs_rel < 0.03
    assert abs(cv.energy_total_rel) < 0.01


def test_cross_validation_trains_only_on_other_runs(inside):
    """Each fold's predictions equal a fit made on the windows of the other runs only."""
    w = inside[1]
    cv = cross_validate(BASE_TERMS, w, n_splits=4, seed=7)
    assert (cv.windows.groupby("run")["fold"].nunique() == 1).all()
    for i, test_runs in enumerate(cv.folds):
        train_ids = w.table.loc[~w.table["run"].isin(test_runs), "window"]
        s = w.samples[w.samples["window"].isin(train_ids)]
        t = w.table.set_index("window").loc[np.sort(train_ids.unique())]
        ref = EnergyModel(BASE_TERMS).fit(
            s, t["power"].to_numpy(), groups=s["window"], sample_weight=t["duration"].to_numpy()
        )
        got = cv.fold_coefficients.loc[i]
        for name in BASE_TERMS:
            assert got[name] == pytest.approx(ref.coefficients[name], rel=1e-6, abs=1e-6)


def test_single_speed_campaign_warns_for_speed_term(inside):
    res = fit_model(inside[1], [*BASE_TERMS, "speed_dependence"], n_splits=0)
    msgs = [m for m in res.warnings if "cruise at one speed" in m]
    assert len(msgs) == 1 and "'speed_dependence'" in msgs[0]


def test_channel_speed_terms_need_no_second_speed():
    """``speed * (surface == 'mud')`` is told apart by the surface varying between runs."""
    camp = simulate_campaign(
        seed=4, effects=("surface_type",), config=CampaignConfig.small(sensors=INSIDE)
    )
    term = "speed * (surface == 'mud')"
    res = fit_model(_windows(camp), [*BASE_TERMS, term, "payload"], n_splits=0)
    assert not any("one speed" in m for m in res.warnings), res.warnings
    true = camp.truth.coefficients[camp.truth.term_names[-1]]
    assert camp.truth.terms[-1].formula == term
    # a force like the others: slip 1/0.98, rectified noise and statistics within 6 %
    assert res.coefficients[term] == pytest.approx(true / 0.98, rel=0.06)
    # no payload effect in the truth: within 4 standard errors of 0, plus 1 N/kg of
    # errors-in-variables bias (at 15 kg and 0.3 m/s: 4.5 W, 2.5 % of walking power)
    assert abs(res.coefficients["payload"]) < 4 * res.stderr["payload"] + 1.0


def test_several_speeds_recover_speed_effect():
    eff = EFFECTS["speed_dependence"]
    camp = simulate_campaign(
        seed=2,
        effects=("speed_dependence",),
        config=CampaignConfig.small(sensors=INSIDE, speeds=(0.2, 0.3, 0.45)),
    )
    res = fit_model(_windows(camp), [*BASE_TERMS, "speed_dependence"], n_splits=0)
    assert not any("one speed" in m for m in res.warnings)
    # speed**2 times c is a force too: slip scales it by 1/0.98, rectified noise ~4 %
    assert res.coefficients["speed_dependence"] == pytest.approx(eff.coefficient / 0.98, rel=0.12)


def test_figures_from_simulated_logs(inside, inside_fit, tmp_path):
    camp, w = inside
    est = force_estimates(w)
    s4 = plot_force_slope(est, inside_fit.model, tmp_path / "f4.png")
    s5 = plot_yaw_torque(est, inside_fit.model, tmp_path / "f5.png")
    table = superposition_table(run_energy(camp.logs), camp.runs)
    s3 = plot_superposition(table, tmp_path / "f3.png")
    for name in ("f3.png", "f4.png", "f5.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    # Fig. 4: uphill costs more than downhill; lateral more than forward (truth: 800 vs 600 N)
    assert s4["uphill_forward_median_n"] > s4["downhill_forward_median_n"]
    assert s4["downhill_lateral_median_n"] > s4["downhill_forward_median_n"]
    assert 500 < s4["uphill_forward_median_n"] < 1100
    # Fig. 5: yaw torque between the level (250) and 20-degree (353 N m) truths, / (1 - slip)
    assert 240 < s5["median_torque_nm"] < 370
    # Fig. 3: energies of A then B add up (the simulator's physics is additive)
    assert s3["n"] == len(camp.runs["composite"].replace("", np.nan).dropna().unique())
    assert s3["mean_abs_rel_ab"] < 0.05


def test_default_model_script_small(tmp_path, capsys):
    from energy_planner.calibration.default_model import main

    out = tmp_path / "b1.json"
    assert main(["--small", "--out", str(out)]) == 0
    m = EnergyModel.load(out)
    assert m.term_names == list(BASE_TERMS)
    assert m.metadata["campaign"]["seed"] == 0
    assert m.metadata["truth_coefficients"] == BASE_COEFFICIENTS
    assert "held-out by run" in capsys.readouterr().out


def test_bundled_default_model_comes_from_the_script():
    """The bundled model is the script's fit: forces = truth / (1 - slip) within 6 %
    (the slope terms absorb the slope-dependent slip, as in the default-sensor test)."""
    m = EnergyModel.default()
    meta = m.metadata
    assert "energy_planner.calibration.default_model" in meta["source"]
    assert meta["fit"]["n_runs"] > 500 and meta["fit"]["heldout_energy_mean_abs_rel_error"] < 0.03
    truth = EnergyModel(BASE_TERMS, BASE_COEFFICIENTS)
    s = SensorConfig()
    alpha = np.radians([0.0, 10.0, 20.0])
    slip = s.slip_mean + s.slip_per_sin_slope * np.sin(alpha)
    for g, vx, vy, wz in [
        (0.0, 0.3, 0, 0),
        (np.pi, 0.3, 0, 0),
        (-np.pi / 2, 0, 0.3, 0),
        (0.0, -0.3, 0, 0),
        (0.0, 0, 0, 0.5),
    ]:
        f = {
            "alpha": alpha,
            "gamma": np.full(3, g),
            "vx": np.full(3, vx),
            "vy": np.full(3, vy),
            "wz": np.full(3, wz),
        }
        np.testing.assert_allclose(m.power(f), truth.power(f) / (1 - slip), rtol=0.06)
