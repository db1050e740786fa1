"""Issue 20 point 4: an odometry scale error is repaired; a repair never costs accuracy.

The odometry's scale is checked against the pose (analytic logs, and the simulator's
missions, whose per-run slip is known); the repair guard of ``prepare_logs`` is checked
with a repair known to destroy information and one known to restore it.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.calibration.prepare import prepare_logs
from energy_planner.measurements import datacheck
from energy_planner.measurements.datacheck import (
    DataFinding,
    check_current_sign,
    check_data,
    check_odometry_scale,
    odometry_ratios,
)
from energy_planner.simulate import MissionConfig, SensorConfig, simulate_missions


def _walks(scale: float, n_runs: int = 6, heading: float = 0.3) -> pd.DataFrame:
    """Runs walking a circle arc at 0.3 m/s, odometry reading ``scale`` of the distance."""
    t = np.arange(0, 30, 0.1)
    yaw = heading + 0.02 * t  # turning at 0.02 rad/s: the path curves
    v, w = 0.3, 0.02
    x = v / w * (np.sin(yaw) - np.sin(heading))
    y = -v / w * (np.cos(yaw) - np.cos(heading))
    runs = []
    for r in range(n_runs):
        runs.append(
            pd.DataFrame(
                {"run": f"r{r}", "t": t, "qw": np.cos(yaw / 2), "qx": 0.0, "qy": 0.0,
                 "qz": np.sin(yaw / 2), "vx": v * scale, "vy": 0.0, "wz": w * scale,
                 "voltage": 50.0, "current": 4.0, "x": x + 10 * r, "y": y}
            )
        )  # fmt: skip
    return pd.concat(runs, ignore_index=True)


@settings(max_examples=20, deadline=None)
@given(scale=st.floats(0.9, 1.1), heading=st.floats(-np.pi, np.pi))
def test_odometry_ratio_is_the_scale_of_the_twist(scale, heading):
    """Whatever the heading, the ratio is the odometry's scale (the arc's chord both ways)."""
    m = odometry_ratios(_walks(scale, heading=heading))
    assert m.use.all()
    np.testing.assert_allclose(m.ratio, scale, rtol=2e-3)


@settings(max_examples=10, deadline=None)
@given(scale=st.floats(0.9, 0.985) | st.floats(1.015, 1.1))
def test_a_constant_scale_is_found_and_divided_out(scale):
    found, fixed = check_odometry_scale(_walks(scale))
    assert found.finding and found.repaired
    assert found.evidence["slip_mean"] == pytest.approx(1 - scale, abs=2e-3)
    np.testing.assert_allclose(odometry_ratios(fixed).ratio, 1.0, rtol=2e-3)
    np.testing.assert_allclose(fixed["vx"], 0.3, rtol=2e-3)  # the pose's speed


def test_an_exact_odometry_is_no_finding():
    found, fixed = check_odometry_scale(_walks(1.0))
    assert not found.finding and not found.repaired
    pd.testing.assert_frame_equal(fixed, _walks(1.0), check_exact=True)
    found, _ = check_odometry_scale(_walks(0.97).drop(columns=["x", "y"]))
    assert not found.finding and found.summary.startswith("not checked")


#: Reduced missions: 12 x 45 s at 10 Hz, the odometry 3 % short on every slope.
CONSTANT_SLIP = SensorConfig(slip_mean=0.03, slip_per_sin_slope=0.0, slip_std=0.005)


@pytest.fixture(scope="module")
def short_odometry():
    cfg = MissionConfig.varied(missions=12, duration_s=45.0, rate_hz=10.0, sensors=CONSTANT_SLIP)
    return simulate_missions(seed=2, config=cfg)


def test_missions_constant_slip_is_measured_against_the_simulators(short_odometry):
    camp = short_odometry
    found = {f.name: f for f in check_data(camp.logs)[0]}
    slip, scale = found["odometry_slip"], found["odometry_scale"]
    # the slip does not grow with slope: the slope check leaves it, the scale check takes it
    assert not slip.finding
    assert scale.finding and scale.repaired
    true = camp.runs["slip"].to_numpy(float)  # the slip the simulator drew for each run
    assert scale.evidence["slip_mean"] == pytest.approx(true.mean(), abs=0.003)


def test_scale_is_repaired_per_run_as_the_simulator_drew_it(short_odometry):
    camp = short_odometry
    logs = camp.logs.assign(run=camp.logs["run"].astype(str))
    logs = logs.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    _, fixed = check_odometry_scale(logs)
    truth = camp.true_samples.assign(run=camp.true_samples["run"].astype(str))
    truth = truth.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    # mean forward speed of each run: the repaired odometry reads the true one
    walk = np.abs(truth["vx"].to_numpy()) > 0.1
    by = logs["run"][walk]
    raw = logs["vx"][walk].abs().groupby(by).mean() / truth["vx"][walk].abs().groupby(by).mean()
    rep = fixed["vx"][walk].abs().groupby(by).mean() / truth["vx"][walk].abs().groupby(by).mean()
    assert np.abs(raw - 1).mean() > 0.02
    assert np.abs(rep - 1).max() < 0.01, rep


def test_default_sensors_slip_is_repaired_by_the_slope_check_alone():
    cfg = MissionConfig.varied(missions=12, duration_s=45.0, rate_hz=10.0,
                               sensors=SensorConfig(slip_per_sin_slope=0.6))  # fmt: skip
    found = {f.name: f for f in check_data(simulate_missions(seed=2, config=cfg).logs)[0]}
    assert found["odometry_slip"].repaired
    assert not found["odometry_scale"].finding  # nothing left after the slope repair
    assert abs(found["odometry_scale"].evidence["slip_mean"]) < 1e-3


# --------------------------------------------------------------------------- the guard
@pytest.fixture(scope="module")
def clean_missions():
    cfg = MissionConfig.varied(missions=14, duration_s=40.0, rate_hz=10.0,
                               sensors=SensorConfig.ideal())  # fmt: skip
    return simulate_missions(seed=1, config=cfg).logs


def _flattened_speed(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """A "repair" that destroys information: each run's twist replaced by its mean."""
    fixed = samples.copy()
    for c in ("vx", "vy", "wz"):
        fixed[c] = fixed.groupby("run")[c].transform("mean")
    return DataFinding("flatten", True, "twist flattened", {}, repaired=True), fixed


def test_a_repair_that_raises_the_heldout_error_is_refused(clean_missions, monkeypatch):
    monkeypatch.setattr(datacheck, "CHECKS", (_flattened_speed,))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p = prepare_logs(clean_missions)
        unguarded = prepare_logs(clean_missions, guard=False)
    (f,) = p.findings
    check = f.evidence["heldout_check"]
    assert not f.repaired and not check["kept"]
    assert check["rmse_with_repair_w"] > check["rmse_without_repair_w"]
    assert check["p_worse"] < 0.05
    assert "NOT applied" in f.summary and f"{check['rmse_with_repair_w']:.3f}" in f.summary

    # the refused repair left the twist as logged; without the guard it was applied
    def within_runs(prepared):
        return prepared.windows.samples.groupby("run")["vx"].std().mean()

    assert within_runs(p) > 0.05 and within_runs(unguarded) < 1e-9


def test_a_repair_that_restores_the_power_is_kept(clean_missions, monkeypatch):
    monkeypatch.setattr(datacheck, "CHECKS", (check_current_sign,))
    flipped = clean_missions.assign(current=-clean_missions["current"])  # ROS sign
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p = prepare_logs(flipped)
    (f,) = p.findings
    check = f.evidence["heldout_check"]
    assert f.repaired and check["kept"]
    # a repair of units: judged by the run energies predicted from the pose
    assert check["yardstick"] == "run energy from the pose"
    # unrepaired, cleaning drops every sample (power below zero): no error to compare
    assert np.isnan(check["energy_error_without_repair"])
    assert 0 <= check["energy_error_with_repair"] < 0.2
    assert (p.windows.samples["power"] > 0).all()


def test_the_odometry_scale_repair_is_decided_alike_on_both_halves(monkeypatch):
    """Missions whose odometry reads 5.5 % short (sd 1 % per run), split in two halves:
    the repair is judged by the energies of held-out runs priced from the pose, where a
    unit error shows (window RMSE in odometry units cannot see it: on 2 x 20 such missions
    of 40 s it refused the repair on both halves, p 0.015 and 0.037), and is kept on both."""
    monkeypatch.setattr(datacheck, "CHECKS", (check_odometry_scale,))
    sens = SensorConfig(slip_mean=0.055, slip_per_sin_slope=0.0, slip_std=0.01)
    cfg = MissionConfig.varied(missions=24, duration_s=30.0, rate_hz=5.0, sensors=sens,
                               sideways_prob=0.0, backward_prob=0.0,
                               loads_kg=(0.0, 9.0, 18.0, 27.0))  # fmt: skip
    logs = simulate_missions(seed=0, effects=("load",), config=cfg).logs.drop(columns="z")
    runs = sorted(logs["run"].astype(str).unique())
    checks = []
    for half in (runs[::2], runs[1::2]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = prepare_logs(logs[logs["run"].astype(str).isin(half)])
        (f,) = p.findings
        assert f.finding
        checks.append(f.evidence["heldout_check"])
    assert [c["kept"] for c in checks] == [True, True], checks
    assert all(c["yardstick"] == "run energy from the pose" for c in checks)


def test_the_twist_dead_band_is_judged_by_the_energy_of_paths(monkeypatch):
    """The dead band changes what the odometry's speed means (its noise, rectified by
    ``abs()``/``pos()`` terms, read as motion): scored by the window power error in the
    odometry's own units it was refused on the varied load campaigns (seed 0: 21.60 ->
    22.56 W, p 0.0009) while the held-out missions' path energies lost a -1 % bias with it
    (``benchmarks/bench_field_logs.py``). It is judged as the repairs of units are: by the
    held-out runs' energies predicted from the pose against the battery."""
    monkeypatch.setattr(datacheck, "CHECKS", (datacheck.check_twist_noise,))
    cfg = MissionConfig.varied(missions=12, duration_s=30.0, rate_hz=5.0,
                               sensors=SensorConfig(imu_bias_deg=0.0))  # fmt: skip
    logs = simulate_missions(seed=0, config=cfg).logs.drop(columns="z")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p = prepare_logs(logs)
    (f,) = p.findings
    # the simulator's odometry noise (0.01 m/s, 0.01 rad/s): rectified 0.008 > 0.002
    assert f.finding
    assert f.evidence["noise_sd"]["vy"] == pytest.approx(0.01, rel=0.2)
    check = f.evidence["heldout_check"]
    assert check["yardstick"] == "run energy from the pose"
    assert check["runs"] == 12
    assert np.isfinite(check["energy_error_without_repair"])
    assert np.isfinite(check["energy_error_with_repair"])
    # the decision is the one the two numbers and the test give
    worse = check["energy_error_with_repair"] > check["energy_error_without_repair"]
    assert check["kept"] == (not (worse and check["p_worse"] < 0.05)) == f.repaired
