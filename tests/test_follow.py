"""The mission follower: RLS with forgetting, remaining energy after a change, slope check."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

import energy_planner as ep
from energy_planner.follow import Follower, ForgettingRLS, path_term_energies, seed_covariance
from energy_planner.follow.core import imu_gradient
from energy_planner.model import EnergyModel
from energy_planner.simulate import simulate_missions
from energy_planner.simulate.config import MissionEvent


@given(
    lam=st.floats(0.8, 0.99),
    step=st.floats(-50.0, 50.0).filter(lambda v: abs(v) > 1e-3),
    m=st.integers(1, 60),
    x=st.floats(0.2, 3.0),
)
@settings(max_examples=60, deadline=None)
def test_rls_step_change_decays_as_lambda_to_the_m(lam, step, m, x):
    # At the steady state of a constant regressor (P = s2 (1 - lam) / x^2), RLS with
    # forgetting is an exponentially weighted mean: after a step d in the coefficient,
    # the error after m noise-free windows is exactly d lam^m.
    s2 = 4.0
    r = ForgettingRLS(np.array([10.0]), np.array([[s2 * (1 - lam) / x**2]]), s2, lam)
    for _ in range(m):
        r.update(np.array([x]), x * (10.0 + step))
    assert r.coef[0] - (10.0 + step) == pytest.approx(-step * lam**m, rel=1e-6, abs=1e-9)


def test_rls_recovers_a_step_in_one_coefficient_of_the_model_within_bounded_windows():
    # Rows of the bundled model's design matrix over synthetic windows (random slopes,
    # headings and forward speeds); a step of +30 % in fwd_up (a payload's gravity work)
    # after 200 windows. For one coefficient the error after m windows is step * lam^m
    # (test above); with memory 1 / (1 - lam) = 20 windows, 4 memories (80 windows) leave
    # lam^80 = 1.7 %. The 17 coupled terms share the correction, so the bound is 10 %:
    # on the predicted power of such windows and on the coefficient itself.
    rng = np.random.default_rng(0)
    m = ep.load_model()
    n = 300
    feats = {
        "alpha": rng.uniform(0, 0.4, n),
        "gamma": rng.uniform(-np.pi, np.pi, n),
        "vx": rng.uniform(0.15, 0.5, n),
        "vy": np.zeros(n),
        "wz": rng.normal(0, 0.05, n),
        "ax": np.zeros(n),
        "ay": np.zeros(n),
    }
    X = m.design_matrix(feats)
    c0 = m.coef_array()
    j = m.term_names.index("fwd_up")
    c1 = c0.copy()
    c1[j] *= 1.3
    cov, _ = seed_covariance(m)
    lam = 0.95
    cap = (0.5 * np.abs(c0) + 3 * np.sqrt(np.diag(cov))) ** 2
    r = ForgettingRLS(c0, cov, 6.0**2, lam, cap)
    step_rms = float(np.sqrt(np.mean((X[200:] @ (c1 - c0)) ** 2)))
    for i in range(n):
        r.update(X[i], float(X[i] @ (c0 if i < 200 else c1)))
        if i == 200 + 80:
            err_j = r.coef[j] - c1[j]
            pred_rms = float(np.sqrt(np.mean((X[200:] @ (r.coef - c1)) ** 2)))
    assert step_rms > 5.0  # W: the step is seen
    assert pred_rms < 0.1 * step_rms
    assert abs(err_j) < 0.1 * abs(c1[j] - c0[j])


def test_seed_covariance_says_when_it_is_a_diagonal():
    m = ep.load_model()
    cov, note = seed_covariance(m)
    assert np.allclose(cov, np.diag(np.diag(cov))) and "diagonal" in note
    se = m.metadata["fit"]["stderr_by_run"]
    assert cov[0, 0] == pytest.approx(se[m.term_names[0]] ** 2)


def test_term_energies_price_the_path_as_path_energy_does():
    t = ep.open_terrain(ep.map_path("hill"))
    m = ep.load_model()
    xy = np.array([[500058.0, 5000046.0], [500070.0, 5000060.0], [500058.0, 5000084.0]])
    pt = path_term_energies(t, m, xy)
    ref = ep.path_energy(t, xy, model=m)
    assert float((pt.energy @ m.coef_array()).sum()) == pytest.approx(ref.energy_j, rel=1e-9)
    # a model with other coefficients: the same integrals, re-priced
    c2 = dict(zip(m.term_names, m.coef_array() * 1.2, strict=True))
    m2 = EnergyModel(m.term_specs, c2)
    assert float((pt.energy @ m2.coef_array()).sum()) == pytest.approx(1.2 * ref.energy_j, rel=1e-9)


def _true_remaining(logs, u):
    t = logs["t"].to_numpy()
    p = (logs["voltage"] * logs["current"]).to_numpy()
    return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t))) - u.used_j


def test_follower_after_a_payload_pick_up_beats_the_static_prediction(
    follow_mission, make_follower
):
    logs = follow_mission([MissionEvent("payload", at=0.3, load_kg=15.0)])
    f = make_follower(logs)
    ups = f.replay(logs, chunk_s=1.0)
    t0, t1 = logs["t"].iloc[0], logs["t"].iloc[-1]
    for frac in (0.6, 0.75):
        u = min(ups, key=lambda u: abs(u.t - (t0 + frac * (t1 - t0))))
        true = _true_remaining(logs, u)
        err_upd, err_static = abs(u.remaining_j - true), abs(u.static_j - true)
        assert err_static > 0.1 * true  # the payload costs: the static plan is wrong
        assert err_upd < 0.5 * err_static
    assert [d["t"] for d in f.to_dict()["updates"]] == [u.t for u in ups]
    # the change is detected and said, after the pick-up (at 30 %) and with its place
    said = [e for e in f.events if "a change of conditions" in e]
    assert said
    t_said = float(said[0].split("t=")[1].split(" s")[0])
    assert t0 + 0.3 * (t1 - t0) <= t_said <= t0 + 0.3 * (t1 - t0) + 10.0


def test_slope_disagreement_reported_on_a_biased_stretch_and_not_on_a_clean_one(
    follow_mission, make_follower
):
    # stated threshold: 3 sd of the IMU's tilt error (0.3 deg bias per run, 0.05 deg per
    # sample) + 0.5 deg for the DEM's footprint: 1.4 deg; the DEM is 5 deg off over
    # 30-60 % of the mission, along the heading at the stretch's start.
    clean_logs = follow_mission()
    clean = make_follower(clean_logs)
    clean.replay(clean_logs)
    assert clean.slope_tol_deg == pytest.approx(1.4, abs=0.05)
    assert clean.findings == []
    logs = follow_mission([MissionEvent("dem_bias", at=0.3, until=0.6, slope_bias_deg=5.0)])
    f = make_follower(logs)
    f.replay(logs)
    assert len(f.findings) >= 1
    fd = f.findings[0]
    t0, t1 = logs["t"].iloc[0], logs["t"].iloc[-1]
    lo, hi = t0 + 0.3 * (t1 - t0), t0 + 0.6 * (t1 - t0)
    assert lo - 4.0 <= fd.t_start and fd.t_end <= hi + 4.0  # within the stretch (+-2 windows)
    assert fd.difference_deg > fd.threshold_deg
    # the place is where the log was at those times
    i = int(np.searchsorted(logs["t"].to_numpy(), fd.t_start))
    assert math.hypot(fd.x_start - logs["x"].iloc[i], fd.y_start - logs["y"].iloc[i]) < 2.0


def test_follow_cli_json_records(tmp_path, follow_config):
    from energy_planner.cli import main
    from energy_planner.io.geotiff import write_geotiff  # noqa: F401 (the writer exists)
    from energy_planner.io.path_format import write_path_from_work

    ter = ep.open_terrain(ep.map_path("hill"))
    cfg = follow_config.replace(duration_s=40.0)
    logs = simulate_missions(seed=2, config=cfg, terrain=ter).logs
    k = np.r_[np.arange(0, len(logs), 10), len(logs) - 1]
    states = logs[["x", "y", "yaw"]].to_numpy()[k]
    path = write_path_from_work(tmp_path / "plan.geojson", ter, states, t=logs["t"].to_numpy()[k])
    log = tmp_path / "run.csv"
    logs.to_csv(log, index=False)
    res = CliRunner().invoke(
        main,
        [
            "follow",
            str(log),
            "--dem",
            str(ep.map_path("hill")),
            "--path",
            str(path),
            "--battery-wh",
            "500",
            "--reserve-wh",
            "50",
            "--json",
        ],
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    keys = {
        "t",
        "distance_m",
        "remaining_j",
        "remaining_low_j",
        "remaining_high_j",
        "success_probability",
    }
    assert len(doc["updates"]) >= 15  # one per 2 s window of a 40 s log
    for u in doc["updates"]:
        assert keys <= set(u)
        assert u["remaining_low_j"] <= u["remaining_j"] <= u["remaining_high_j"]
        assert 0.0 <= u["success_probability"] <= 1.0
    d = [u["distance_m"] for u in doc["updates"]]
    assert d == sorted(d) and d[-1] > 0.8 * float(np.hypot(*np.diff(states[:, :2], axis=0).T).sum())
    # the bundled model: the interval is split-conformal on the bundled calibrated scores
    # of the update's group (state, adapting by its step; remaining share)
    from energy_planner.follow.calibrate import bundled_scores
    from energy_planner.uncertainty import interval

    assert any("split-conformal on the follower's own" in n for n in doc["notes"])
    sc = bundled_scores()
    assert sc.normalized  # scores in units of the follower's own spread at the checkpoint
    for u in doc["updates"]:
        assert u["remaining_high_j"] >= u["remaining_j"]
        z = sc.for_group(u["group"], u["remaining_share"], 0.9)
        sc_u = np.maximum(z * u["spread"], -0.9)
        iv = interval(u["model_remaining_j"], sc_u, 0.9)
        assert (u["remaining_low_j"], u["remaining_high_j"]) == pytest.approx(
            (max(iv.low_j, 0.0), iv.high_j), rel=1e-12
        )
        # the estimate: the median of the same predictive distribution
        assert u["remaining_j"] == pytest.approx(
            u["model_remaining_j"] / (1.0 + np.median(sc_u)), rel=1e-12
        )
    # a log without a pose is a data error (exit 1) that says what is missing
    logs.drop(columns=["x", "y"]).to_csv(tmp_path / "nopose.csv", index=False)
    res = CliRunner().invoke(
        main,
        [
            "follow",
            str(tmp_path / "nopose.csv"),
            "--dem",
            str(ep.map_path("hill")),
            "--path",
            str(path),
        ],
    )
    assert res.exit_code == 1 and "x, y" in res.output


def test_follower_replans_when_the_battery_chance_falls_and_says_so(follow_config):
    # a 40 m tilted plane (small: the replan's search is quick); the battery holds the
    # static plan with 10 % to spare, so a 15 kg payload at 30 % sinks the chance
    from energy_planner.terrain import Terrain

    x = np.arange(40.0)
    ter = Terrain.from_array(np.tile(0.15 * x, (40, 1)), resolution=1.0)
    cfg = follow_config.replace(
        duration_s=60.0,
        waypoint_spacing_m=4.0,
        events=(MissionEvent("payload", at=0.3, load_kg=15.0),),
    )
    logs = simulate_missions(seed=4, config=cfg, terrain=ter).logs
    k = np.r_[np.arange(0, len(logs) - 1, 10), len(logs) - 1]
    m = ep.load_model()
    args = (
        ter,
        m,
        logs[["x", "y"]].to_numpy()[k],
        logs["yaw"].to_numpy()[k],
        logs["t"].to_numpy()[k],
    )
    static = float(Follower(*args).path.energy.sum(axis=0) @ m.coef_array())
    f = Follower(*args, battery_wh=1.1 * static / 3600, reserve_wh=0.0, replan_time=0.5)
    ups = f.replay(logs)
    assert ups[0].probability >= 0.9  # the plan fits before the pick-up
    low = [u for u in ups if u.probability < 0.9]
    assert low and low[0].t > logs["t"].iloc[0] + 0.3 * 60.0
    said = [e for e in f.events if "chance the battery suffices" in e]
    assert said and ("replanned" in said[0] or "no replan fits" in said[0])
    assert [u.event for u in ups if u.event is not None] == said


@given(
    alpha=st.floats(0.01, 0.6),
    psi=st.floats(-math.pi, math.pi),
    yaw=st.floats(-math.pi, math.pi),
)
@settings(max_examples=50, deadline=None)
def test_imu_gradient_inverts_the_relative_heading_of_the_design_notes(alpha, psi, yaw):
    # design notes: tan(gamma) = tan(yaw - psi) cos(alpha) (gamma in the slope plane, in
    # the quadrant of yaw - psi); the gradient is tan(alpha) along the uphill azimuth psi
    d = yaw - psi
    gamma = math.atan2(math.sin(d) * math.cos(alpha), math.cos(d))
    g = imu_gradient([alpha], [gamma], [yaw])[0]
    want = math.tan(alpha) * np.array([math.cos(psi), math.sin(psi)])
    np.testing.assert_allclose(g, want, atol=1e-12)


@given(bx=st.floats(-0.1, 0.1), by=st.floats(-0.1, 0.1))
@settings(max_examples=4, deadline=None)
def test_repricing_with_a_slope_offset_is_the_energy_on_the_tilted_ground(bx, by):
    # The follower re-prices the path ahead on the DEM plus a measured gradient offset.
    # Independent reference: path_energy on a DEM built with that tilt in its elevation
    # (Horn's gradient of a plane is exact), over the same path with the same times.
    from energy_planner.follow.core import _Stretch
    from energy_planner.terrain import Terrain

    x = np.arange(60.0)
    z = 0.08 * x[None, :] + 0.03 * np.arange(60.0)[:, None] ** 1.5 / 8
    ter = Terrain.from_array(z, resolution=1.0)
    x0, y0, dx, dy = ter.grid
    xc, yc = ter.cell_centers()
    tilted = Terrain.from_array(z + bx * (xc - x0) + by * (yc - y0), resolution=1.0)
    s = np.linspace(0.0, 1.0, 41)
    xy = np.column_stack([x0 + 15 + 25 * s, y0 + dy * (20 + 10 * np.sin(3 * s))])
    t = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T) / 0.3)]
    yaw = np.r_[np.arctan2(*np.diff(xy, axis=0).T[::-1]), 0.0]
    yaw[-1] = yaw[-2]
    m = ep.load_model()
    f = Follower(ter, m, xy, yaw, t, bias_until_m=1e9)
    f._stretch = _Stretch(0.0, 1.0, (0, 0), (0, 0), imu=[1.0, 1.0], dem=[0.0, 0.0],
                          offset=[(bx, by)] * 2)  # fmt: skip
    r, _ = f._biased_remaining(0, 0.0, f.path.remaining(0, 0.0))
    ref = ep.path_energy(tilted, xy, yaw=yaw, t=t, model=m)
    assert float(r @ m.coef_array()) == pytest.approx(ref.energy_j, rel=1e-9)


def test_dem_bias_known_stretch_halves_the_error_inside_it():
    # 5 deg of DEM error over 30-60 % of 80 s missions on a plane of 10 % grade (the
    # model's own error is small and even there). At 50 % the static prediction misses
    # the rest of the stretch; told where it ends, the follower re-prices it with the
    # offset it measured: less than half the static error (median over the missions
    # where the stretch is found, i.e. the follower is in its "dem" state).
    from energy_planner.follow.calibrate import follow_simulated_mission
    from energy_planner.terrain import Terrain

    ter = Terrain.from_array(np.tile(0.1 * np.arange(120.0), (120, 1)), resolution=1.0)
    m = ep.load_model()
    upd, sta = [], []
    for seed in range(5):
        run = follow_simulated_mission(
            seed, "dem_bias", m, 80.0, 10.0, known_stretch=True, terrain=ter
        )
        i = int(np.argmin(np.abs(run["t"] - 0.5 * (run["t0"] + run["t1"]))))
        u, true = run["updates"][i], run["true"][i]
        if u.state == "dem":
            upd.append(abs(u.remaining_j / true - 1))
            sta.append(abs(u.static_j / true - 1))
    assert len(sta) >= 3
    assert np.median(sta) > 0.01  # the DEM error costs: the static prediction misses it
    assert np.median(upd) < 0.5 * np.median(sta)


def test_replans_share_one_kernel_whatever_the_coefficients(follow_mission, make_follower):
    # The replan's model carries the coefficients as run-time channel constants: its
    # kernel source is the same for any coefficients (one compilation), and its power is
    # the power of the model with those coefficients written in.
    from energy_planner.energy.channels import Channels

    f = make_follower(follow_mission())
    m1, r1 = f.replan_inputs()
    f.rls.coef = f.rls.coef * 1.3
    m2, r2 = f.replan_inputs()
    assert m1 is m2

    def source(req):
        ch = Channels(constants=req.channels.constants).resolve(m1)
        return m1.kernel_source(None, ch.kernel_layout(runtime=True))

    assert source(r1) == source(r2)
    rng = np.random.default_rng(0)
    n = 200
    feats = {
        "alpha": rng.uniform(0, 0.4, n), "gamma": rng.uniform(-np.pi, np.pi, n),
        "vx": rng.uniform(-0.5, 0.5, n), "vy": rng.uniform(-0.3, 0.3, n),
        "wz": rng.normal(0, 0.3, n), "ax": np.zeros(n), "ay": np.zeros(n),
    }  # fmt: skip
    feats["speed"] = np.hypot(feats["vx"], feats["vy"])
    with_coef = {**feats, **{k: np.full(n, v) for k, v in r2.channels.constants.items()}}
    np.testing.assert_allclose(m2.power(with_coef), f.current_model().power(feats), rtol=1e-12)


def test_current_spikes_are_not_a_change_of_conditions(follow_mission, make_follower):
    # Five isolated current spikes of 20 A (about 1 kW for one sample: +24 W on a 2 s
    # window's mean at 20 Hz, beyond the change detector's ~10 W) are sensor outliers,
    # which the fit's Hampel filter removed from its windows. The follower filters them
    # the same way: no change detected, the same predictions as without them; only the
    # energy spent (measured) keeps them.
    logs = follow_mission()
    spiked = logs.copy()
    rows = np.linspace(200, len(logs) - 200, 5).astype(int)
    spiked.loc[rows, "current"] += 20.0
    a, b = make_follower(logs), make_follower(spiked)
    ua, ub = a.replay(logs), b.replay(spiked)
    assert b.changes == [] and a.changes == []
    assert [u.model_j for u in ub] == pytest.approx([u.model_j for u in ua], rel=1e-12)
    # the estimate reads the calibrated errors in units of the follower's spread, whose
    # window means lose the spikes' samples: the same to 1e-4
    assert [u.remaining_j for u in ub] == pytest.approx([u.remaining_j for u in ua], rel=1e-4)
    assert ub[-1].used_j > ua[-1].used_j
