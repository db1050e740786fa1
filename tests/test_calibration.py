"""Calibration on synthetic windows built from a known model (independent of the simulator).

Samples come from a known base model: ``power = truth.power(features) + noise``; each run
walks one motion at one slope and heading, cut into windows. A least-squares fit must
recover the truth within a few standard errors, validation must hold out whole runs,
and the warnings must name what the data cannot support.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.calibration import (
    cross_validate,
    fit_forces,
    fit_model,
    force_estimates,
)
from energy_planner.calibration._windows import window_energy
from energy_planner.errors import FitError
from energy_planner.model import BASE_TERMS, EnergyModel
from energy_planner.stats import classify_motion

#: B1-class coefficients of the base model (N, N m, W).
TRUTH = {
    "fwd_const": 130.0,
    "fwd_up": 720.0,
    "fwd_down": -300.0,
    "bwd_const": 150.0,
    "bwd_up": 720.0,
    "bwd_down": -100.0,
    "lat_const": 230.0,
    "lat_up": 720.0,
    "lat_down": -20.0,
    "turn_const": 105.0,
    "turn_slope": 255.0,
    "idle_power": 137.0,
    "tilt_x_sq": 1760.0,
    "tilt_y_sq": 370.0,
    "fwd_brake_sq": -1660.0,
    "bwd_brake_sq": -1120.0,
    "lat_tilt_sq": 1510.0,
}
#: Largest power (W) per unit coefficient of each term on the campaign (<= 20 deg, 0.4 m/s).
S20 = np.sin(np.radians(20))
BASIS_MAX = {n: 0.4 * S20 for n in TRUTH}
BASIS_MAX.update(fwd_const=0.4, bwd_const=0.4, lat_const=0.4, turn_const=0.5)
BASIS_MAX.update(turn_slope=0.5 * S20, idle_power=1.0)
BASIS_MAX.update({n: S20**2 for n in TRUTH if n.endswith("_sq")})

# motion -> (vx, vy, wz) at unit rate, and the body direction of travel beta
_MOTIONS = {
    "forward": ((1, 0, 0), 0.0),
    "backward": ((-1, 0, 0), np.pi),
    "lateral_left": ((0, 1, 0), np.pi / 2),
    "lateral_right": ((0, -1, 0), -np.pi / 2),
    "turn_left": ((0, 0, 1), None),
    "turn_right": ((0, 0, -1), None),
}


class Windows:
    """Minimal stand-in for measurements.Windows (samples + table)."""

    def __init__(self, samples: pd.DataFrame, table: pd.DataFrame) -> None:
        self.samples = samples
        self.table = table


def make_windows(
    truth: EnergyModel,
    *,
    seed: int = 0,
    slopes_deg=(0, 5, 10, 15, 20),
    motions=tuple(_MOTIONS),
    speeds=(0.2, 0.4),
    yaw_rate: float = 0.5,
    run_s: float = 20.0,
    window_s: float = 5.0,
    rate_hz: float = 10.0,
    noise_w: float = 10.0,
    twist_noise: float = 1.0,
    extra: dict | None = None,
) -> Windows:
    """Runs of one motion each at every slope, travelling up, across and down, as windows."""
    rng = np.random.default_rng(seed)
    rows = []
    run_id = 0
    for slope in slopes_deg:
        for motion in motions:
            (ux, uy, uw), beta = _MOTIONS[motion]
            # travel uphill, across and downhill (turns: facing up and across)
            for climb_dir in (0.0, np.pi / 2, np.pi) if beta is not None else (0.0, np.pi / 2):
                for speed in speeds:
                    gamma = climb_dir - (beta or 0.0)
                    gamma = (gamma + np.pi) % (2 * np.pi) - np.pi
                    n = int(run_s * rate_hz)
                    t = np.arange(n) / rate_hz
                    vx = ux * speed + rng.normal(0, 0.005 * twist_noise, n)
                    vy = uy * speed + rng.normal(0, 0.005 * twist_noise, n)
                    wz = uw * yaw_rate + rng.normal(0, 0.01 * twist_noise, n)
                    alpha = np.full(n, np.radians(slope)) + rng.normal(0, np.radians(0.3), n)
                    alpha = np.abs(alpha)
                    g = np.full(n, gamma) + rng.normal(0, 0.02, n)
                    df = pd.DataFrame(
                        {
                            "run": f"r{run_id:03d}",
                            "t": t,
                            "vx": vx,
                            "vy": vy,
                            "wz": wz,
                            "alpha": alpha,
                            "gamma": g,
                            "ax": 0.0,
                            "ay": 0.0,
                        }
                    )
                    for k, v in (extra or {}).items():
                        df[k] = v(run_id) if callable(v) else v
                    df["speed"] = np.hypot(df.vx, df.vy)
                    df["power"] = truth.power(df) + rng.normal(0, noise_w, n)
                    df["window"] = (run_id * 1000 + t // window_s).astype(int)
                    rows.append(df)
                    run_id += 1
    samples = pd.concat(rows, ignore_index=True)
    g = samples.groupby("window")
    table = g.agg(
        run=("run", "first"),
        t_start=("t", "min"),
        t_end=("t", "max"),
        n=("t", "size"),
        alpha=("alpha", "mean"),
        gamma=("gamma", "mean"),
        vx=("vx", "mean"),
        vy=("vy", "mean"),
        wz=("wz", "mean"),
        speed=("speed", "mean"),
        power=("power", "mean"),
    ).reset_index()
    table["duration"] = table["t_end"] - table["t_start"] + 1 / rate_hz
    table["energy_j"] = table["power"] * table["duration"]
    table["motion"] = classify_motion(table.vx, table.vy, table.wz)
    return Windows(samples, table)


@pytest.fixture(scope="module")
def truth() -> EnergyModel:
    return EnergyModel(BASE_TERMS, TRUTH)


@pytest.fixture(scope="module")
def campaign(truth) -> Windows:
    return make_windows(truth)


def test_joint_fit_recovers_truth_within_stderr(campaign, truth):
    res = fit_model(campaign, n_splits=5)
    assert res.n_runs == 5 * 2 * (4 * 3 + 2 * 2) and res.n_windows == 4 * res.n_runs
    assert res.unidentified == {}
    for name, true in TRUTH.items():
        c, se = res.coefficients[name], res.stderr[name]
        # noise is white and the model exact: the estimate lies within 4 standard errors
        assert abs(c - true) < 4 * se + 1e-9, (name, c, se)
        # and the data pins every term's share of the power down to 2 % of a level walk
        assert se * BASIS_MAX[name] < 0.02 * 180, (name, se)
    # 10 W of white noise averages to ~10/sqrt(50) = 1.4 W per 5 s window
    assert res.residual_rms_w < 3.0
    assert res.heldout is not None
    # a run's measured energy carries the integrated noise: 10 W * 0.1 s * sqrt(200 samples)
    # = 14 J; held-out predictions must be within 4 of those plus 0.5 % of coefficient error
    runs = res.heldout.runs
    assert (runs.error_j.abs() < 4 * 14.1 + 0.005 * runs.measured_j).all()
    assert res.heldout.energy_mean_abs_rel < 0.01
    assert res.warnings == []


@pytest.fixture(scope="module")
def clean_twist(truth) -> Windows:
    return make_windows(truth, twist_noise=0.0)


def test_force_fit_matches_joint_fit(clean_twist):
    """Without twist noise both methods recover the truth and agree.

    (With noise, |vy| and |wz| of a forward window rectify their noise into a few W of
    lateral and turning power that the per-motion fit books as forward force: ~15 N on
    fwd_const with the default noise; the joint fit separates them.)
    """
    joint = fit_model(clean_twist, n_splits=0)
    per_motion = fit_forces(clean_twist)
    for name, true in TRUTH.items():
        assert abs(per_motion.coefficients[name] - true) < 4 * per_motion.stderr[name] + 1e-9
        assert per_motion.coefficients[name] == pytest.approx(
            joint.coefficients[name], rel=0.03, abs=10
        )


def test_force_estimates_are_power_over_rate(clean_twist):
    est = force_estimates(clean_twist)
    fwd = est[(est.kind == "forward") & (est.heading == "uphill")]
    # uphill forward at slope a (gamma = 0), speed v: F = P / v =
    # fwd_const + fwd_up sin a + (idle_power + tilt_x_sq sin^2 a) / v
    sa, v = np.sin(fwd.alpha), fwd.rate
    expect = (
        TRUTH["fwd_const"]
        + TRUTH["fwd_up"] * sa
        + (TRUTH["idle_power"] + TRUTH["tilt_x_sq"] * sa**2) / v
    )
    np.testing.assert_allclose(fwd.value, expect, rtol=0.03)
    turns = est[est.kind == "turning"]
    assert set(turns.unit) == {"N m"}
    st_, cg, sg = np.sin(turns.alpha), np.cos(turns.gamma), np.sin(turns.gamma)
    hold = TRUTH["tilt_x_sq"] * (st_ * cg) ** 2 + TRUTH["tilt_y_sq"] * (st_ * sg) ** 2
    expect = (
        TRUTH["turn_const"] + TRUTH["turn_slope"] * st_ + (TRUTH["idle_power"] + hold) / turns.rate
    )
    np.testing.assert_allclose(turns.value, expect, rtol=0.05)
    # lateral uphill climbs; heading classes follow the direction of travel
    lat = est[(est.kind == "lateral") & (est.alpha_deg > 3)]
    assert set(lat.heading) == {"uphill", "cross", "downhill"}


def test_cross_validation_never_mixes_runs(campaign):
    cv = cross_validate(BASE_TERMS, campaign, n_splits=4, seed=3)
    assert cv.n_splits == 4
    runs = [set(f) for f in cv.folds]
    assert sum(len(r) for r in runs) == len(set().union(*runs)) == 160
    # every window of a run is in the run's fold, and that fold held out exactly its runs
    by_run = cv.windows.groupby("run")["fold"].nunique()
    assert (by_run == 1).all()
    for i, fold_runs in enumerate(runs):
        assert set(cv.windows.loc[cv.windows.fold == i, "run"]) == fold_runs
    assert set(cv.runs.run) == set().union(*runs)


def test_cross_validation_holds_out_the_test_runs(truth):
    """A run whose power is off by +50 % must be predicted from the others only."""
    w = make_windows(truth, slopes_deg=(0, 10, 20), seed=2)
    odd = w.samples.run == "r000"
    w.samples.loc[odd, "power"] *= 1.5
    w.table.loc[w.table.run == "r000", "power"] *= 1.5
    cv = cross_validate(None, w, n_splits=48, seed=0)  # leave one run out
    row = cv.runs.set_index("run").loc["r000"]
    # trained without r000, the model predicts the truth: about -1/3 of the inflated energy
    assert row.rel_error == pytest.approx(1 / 1.5 - 1, abs=0.02)


def test_too_little_data_names_counts(truth):
    w = make_windows(truth, slopes_deg=(10,), motions=("forward",), run_s=5.0, speeds=(0.3,))
    w.samples, w.table = w.samples[w.samples.run != "r002"], w.table[w.table.run != "r002"]
    with pytest.raises(FitError, match=r"got 2 windows from 2 run\(s\); need at least \d+ windows"):
        fit_model(w)
    one_run = make_windows(truth, slopes_deg=(10,), motions=("forward",), run_s=60)
    one_run.samples = one_run.samples[one_run.samples.run == "r000"]
    one_run.table = one_run.table[one_run.table.run == "r000"]
    with pytest.raises(FitError, match=r"from 1 run\(s\).*from at least 2 runs"):
        fit_model(one_run, ["fwd_const", "fwd_up"])


def test_missing_motion_is_reported_not_fitted(truth):
    """No backward runs: the backward terms are named as unidentified, left out of the
    model (noise in vx would otherwise 'fit' them), and the rest is fitted as usual."""
    w = make_windows(truth, motions=("forward", "lateral_left", "turn_left"))
    res = fit_model(w, n_splits=3)
    bwd = [t for t in BASE_TERMS if t.startswith("bwd")]
    assert list(res.unidentified) == bwd
    assert "0 backward window(s) exercise it" in res.unidentified["bwd_const"]
    assert not set(bwd) & set(res.model.term_names)
    assert res.model.metadata["fit"]["unidentified"] == res.unidentified
    assert any("'bwd_up' cannot be identified" in m for m in res.warnings)
    assert "not identified by this campaign" in res.summary()
    assert [u["name"] for u in res.to_dict()["unidentified"]] == bwd
    # the backward terms of the truth are not quite 0 without backward runs (noise in vx
    # while side-stepping switches the backward braking term on a little): 10 % slack
    for name in ("fwd_up", "lat_up", "turn_slope"):
        c, se = res.coefficients[name], res.stderr[name]
        assert abs(c - TRUTH[name]) < 4 * se + 0.1 * abs(TRUTH[name]), name
    # forward runs only uphill: the downhill responses are not identified either
    up_only = make_windows(truth, motions=("forward", "turn_left"))
    keep = up_only.table.loc[
        ~((up_only.table.motion == "forward") & (np.cos(up_only.table.gamma) < -0.1)), "window"
    ]
    up_only = Windows(
        up_only.samples[up_only.samples.window.isin(keep)],
        up_only.table[up_only.table.window.isin(keep)],
    )
    res = fit_model(up_only, [t for t in BASE_TERMS if t[:3] in ("fwd", "tur")], n_splits=0)
    assert list(res.unidentified) == ["fwd_down", "fwd_brake_sq"]


def test_prior_holds_unidentified_terms_when_asked(truth):
    w = make_windows(truth, motions=("forward", "lateral_left", "turn_left"))
    prior = EnergyModel(BASE_TERMS, {**TRUTH, "bwd_const": 999.0})
    res = fit_model(w, n_splits=3, prior=prior)
    assert res.unidentified == {}
    assert res.held_at_prior["bwd_const"] == 999.0
    assert res.model.coefficients["bwd_const"] == 999.0
    assert res.model.term_names == list(BASE_TERMS)
    assert (res.heldout.fold_coefficients["bwd_const"] == 999.0).all()
    terms = {t["name"]: t for t in res.to_dict()["terms"]}
    assert terms["bwd_const"]["status"] == "prior" and terms["bwd_const"]["stderr"] is None


def test_single_speed_warns_for_speed_term(truth):
    one_speed = make_windows(truth, speeds=(0.3,))
    res = fit_model(one_speed, [*BASE_TERMS, "speed_dependence"], n_splits=0)
    msgs = "\n".join(res.warnings)
    assert "cruise at one speed (0.30 m/s" in msgs and "'speed_dependence'" in msgs
    assert "nearly in the span" in msgs  # and the VIF check names it too
    assert res.vif["speed_dependence"] > 30


def test_several_speeds_support_speed_term():
    truth = EnergyModel([*BASE_TERMS, "speed_dependence"], {**TRUTH, "speed_dependence": 400.0})
    w = make_windows(truth, speeds=(0.2, 0.4, 0.6), slopes_deg=(0, 10, 20))
    res = fit_model(w, [*BASE_TERMS, "speed_dependence"], n_splits=0)
    assert not any("one speed" in m for m in res.warnings)
    c, se = res.coefficients["speed_dependence"], res.stderr["speed_dependence"]
    assert abs(c - 400.0) < 4 * se and se < 40


def test_level_only_lateral_warns(truth):
    w = make_windows(truth, slopes_deg=(0, 10, 20), motions=("forward", "backward", "turn_left"))
    flat = make_windows(truth, slopes_deg=(0, 2), motions=("lateral_left",), seed=5)
    flat.samples = flat.samples.assign(
        run="f" + flat.samples.run, window=flat.samples.window + 10**6
    )
    flat.table = flat.table.assign(run="f" + flat.table.run, window=flat.table.window + 10**6)
    both = Windows(
        pd.concat([w.samples, flat.samples], ignore_index=True),
        pd.concat([w.table, flat.table], ignore_index=True),
    )
    res = fit_model(both, n_splits=0)
    msg = [m for m in res.warnings if m.startswith("no lateral windows on slopes")]
    assert len(msg) == 1 and "lat_const, lat_up" in msg[0], res.warnings
    # the squares of side-stepping are not identified from 2 deg slopes
    assert "lat_tilt_sq" in res.unidentified


def test_uphill_only_warns(truth):
    w = make_windows(truth)
    down = w.table.alpha.gt(np.radians(2)) & (w.table.motion == "forward")
    down &= np.cos(w.table.gamma) < 0
    keep = set(w.table.loc[~down, "window"])
    w2 = Windows(w.samples[w.samples.window.isin(keep)], w.table[w.table.window.isin(keep)])
    res = fit_model(w2, n_splits=0)
    assert any(m.startswith("forward windows on slopes include no downhill") for m in res.warnings)


def test_collinear_terms_are_reported(campaign):
    res = fit_model(campaign, [*BASE_TERMS, "2 * pos(vx) ** 2 / max(speed, 0.05)"], n_splits=0)
    assert res.unidentified == {
        "2 * pos(vx) ** 2 / max(speed, 0.05)": "a linear combination of fwd_const on these "
        "windows: the campaign does not vary what tells them apart"
    }


def test_heldout_power_matches_model_power(campaign):
    """The CV predictions equal EnergyModel.power with the fold coefficients."""
    cv = cross_validate(None, campaign, n_splits=3)
    fold0 = cv.folds[0]
    m = EnergyModel(BASE_TERMS, cv.fold_coefficients.loc[0].to_dict())
    s = campaign.samples[campaign.samples.run.isin(fold0)]
    p = pd.Series(m.power(s)).groupby(s.window.to_numpy()).mean()
    got = cv.windows.set_index("window").loc[p.index, "predicted_w"]
    np.testing.assert_allclose(got.to_numpy(), p.to_numpy())


@settings(max_examples=25, deadline=None)
@given(
    p=st.lists(st.floats(0, 1000), min_size=4, max_size=12),
    dt=st.floats(0.01, 1.0),
    cut=st.integers(1, 3),
)
def test_window_energy_adds_up(p, dt, cut):
    """Energies of windows cut at shared samples add up to the energy of the whole."""
    t = np.arange(len(p)) * dt
    whole = pd.DataFrame({"window": 0, "t": t, "power": p})
    a = whole.iloc[: cut + 1].assign(window=1)
    b = whole.iloc[cut:].assign(window=2)
    parts = window_energy(pd.concat([a, b]))
    assert parts.sum() == pytest.approx(window_energy(whole).iloc[0], rel=1e-9, abs=1e-9)
    assert window_energy(whole).iloc[0] == pytest.approx(np.trapezoid(p, t), abs=1e-9)


def test_fit_result_serialises(campaign, tmp_path):
    res = fit_model(campaign, n_splits=3)
    d = res.to_dict()
    assert [t["name"] for t in d["terms"]] == list(BASE_TERMS)
    assert d["heldout"]["n_splits"] == 3 and len(d["heldout"]["runs"]) == 160
    path = res.model.save(tmp_path / "m.json")
    back = EnergyModel.load(path)
    assert back.coefficients == pytest.approx(res.coefficients)
    assert back.metadata["fit"]["n_windows"] == res.n_windows
    assert "held-out by run" in res.summary()


def test_run_robust_stderr_ignores_duplicated_windows(campaign):
    """Copying every window of a run adds no information: the by-run standard error stays,
    the classical one (which takes windows as independent) shrinks by about sqrt(2)."""
    s2 = campaign.samples.assign(window=campaign.samples.window + 10**7)
    t2 = campaign.table.assign(window=campaign.table.window + 10**7)
    doubled = Windows(pd.concat([campaign.samples, s2]), pd.concat([campaign.table, t2]))
    a = fit_model(campaign, n_splits=0)
    b = fit_model(doubled, n_splits=0)
    for name in BASE_TERMS:
        assert b.coefficients[name] == pytest.approx(a.coefficients[name], rel=1e-9)
        assert b.stderr_by_run[name] == pytest.approx(a.stderr_by_run[name], rel=1e-9)
        assert b.stderr[name] == pytest.approx(a.stderr[name] / np.sqrt(2), rel=0.02)


def test_mirrored_campaign_gives_the_same_model(campaign):
    """Mirror symmetry (design notes): P(a, g, vx, vy, wz) = P(a, -g, vx, -vy, -wz), so the
    mirrored logs must give the same coefficients."""
    s = campaign.samples.assign(
        gamma=-campaign.samples.gamma, vy=-campaign.samples.vy, wz=-campaign.samples.wz
    )
    t = campaign.table.assign(
        gamma=-campaign.table.gamma,
        vy=-campaign.table.vy,
        wz=-campaign.table.wz,
        motion=classify_motion(campaign.table.vx, -campaign.table.vy, -campaign.table.wz),
    )
    a = fit_model(campaign, n_splits=3)
    b = fit_model(Windows(s, t), n_splits=3)
    for name in BASE_TERMS:
        assert b.coefficients[name] == pytest.approx(a.coefficients[name], rel=1e-9)
    assert b.heldout.rmse_w == pytest.approx(a.heldout.rmse_w, rel=1e-9)


def test_prepare_logs_cleans_each_state_of_the_samples_once(monkeypatch):
    """The repair guard cleans and cuts each state of the samples it scores; the checked
    samples' windows are the guard's own (cleaned once), the same as cutting the repaired
    samples afresh (``guard=False``: no score, every repair applied)."""
    import energy_planner.calibration.prepare as P

    monkeypatch.setenv("ENERGY_PLANNER_LOG_CACHE", "0")
    t = np.arange(0, 8, 0.05)  # the module's example: the current's sign is repaired
    s = pd.DataFrame({"run": np.repeat(["a", "b"], len(t) // 2), "t": np.r_[t[:80], t[:80]],
                      "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0, "vx": 0.3, "vy": 0.0,
                      "wz": 0.0, "voltage": 50.0,
                      "current": -4.0 + 0.1 * np.sin(7 * t)})  # fmt: skip
    cleaned = []
    real = P.clean_logs
    monkeypatch.setattr(P, "clean_logs", lambda x: cleaned.append(x) or real(x))
    got = P.prepare_logs(s)
    assert [f.name for f in got.found if f.repaired] == ["current_sign"]
    assert len(cleaned) == 2  # the samples without and with the repair, once each
    assert cleaned[0] is not cleaned[1]
    plain = P.prepare_logs(s, guard=False)
    assert len(cleaned) == 3  # no guard: the repaired samples cleaned by prepare_logs
    pd.testing.assert_frame_equal(got.windows.samples, plain.windows.samples, check_exact=True)
    pd.testing.assert_frame_equal(got.windows.table, plain.windows.table, check_exact=True)
    assert repr(got.preprocess_report) == repr(plain.preprocess_report)
