"""A robot whose physics this project did not write: robot-b's logs, a reduced subset.

``tests/fixtures/robot_b`` (see its README) holds 12 training missions (their first 120 s)
and 2 whole test missions of a quadruped's field logs, with the map they walked. There is
no true power, only the battery, as on a real robot. ``discover`` runs on the training
missions (one step); with the model it writes, the energy of each test mission's logged
poses (``follow.walked_path`` priced by ``energy.path_energy`` with the poses' times, as
``energy --waypoints`` prices them) is compared with the battery energy the mission
measured. ``benchmarks/bench_field_logs.py``
runs the full logs (12 + 12 missions).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _benchmarks import load_benchmark
from hypothesis import given, settings
from hypothesis import strategies as st

FIXTURE = Path(__file__).parent / "fixtures" / "robot_b"

#: Largest |predicted / measured - 1| allowed for a test mission's logged-pose energy.
#: Measured: on the full logs (discover on 12 missions, 12 held out) the errors lie within
#: -1.9 % .. +1.3 % (median -0.2 %, p90 1.8 %) with the base model alone; with the model
#: discover writes on this subset (the cross-slope term added), m009 +0.4 % and m011
#: -1.4 % (the base model fitted alone on this subset: m011 -3.0 %). The failures it must
#: catch are larger: the odometry's 7 % short reading left unrepaired puts both missions
#: at +3.5 .. +4.7 %, and every 10 Hz logged pose priced with its repeats (the
#: localisation is held at 2.5 Hz) at +4 % on the full logs.
TOLERANCE = 0.025


@pytest.fixture(scope="module")
def discovered():
    """``ep.discover`` on the fixture's training missions (data checks and repairs included),
    one step, with the model it writes."""
    import energy_planner as ep

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return ep.discover(FIXTURE / "train", max_steps=1, progress=False)


def _mission(name: str) -> pd.DataFrame:
    return pd.read_parquet(FIXTURE / "test" / f"{name}.parquet").sort_values("t")


def test_odometry_scale_is_measured_as_the_logs_show(discovered):
    """The repair's slip equals the odometry's distance against the pose's, summed by hand."""
    found = {f.name: f.to_dict() for f in discovered.data_findings}
    scale = found["odometry_scale"]
    assert scale["finding"] and scale["repaired"]
    slips = []
    for f in sorted((FIXTURE / "train").glob("*.parquet")):
        g = pd.read_parquet(f).sort_values("t")
        dt = np.diff(g["t"].to_numpy(float))
        odo = np.sum(np.hypot(g["vx"], g["vy"]).to_numpy(float)[1:] * dt)
        pose = np.sum(np.hypot(np.diff(g["x"].to_numpy(float)), np.diff(g["y"].to_numpy(float))))
        slips.append(1.0 - odo / pose)
    # path lengths, not the check's net displacements: the same slip within a point
    assert scale["evidence"]["slip_mean"] == pytest.approx(np.mean(slips), abs=0.01)
    assert 0.05 < np.mean(slips) < 0.09


@pytest.mark.parametrize("name", ["m009", "m011"])
def test_logged_pose_energy_matches_the_battery(discovered, name):
    """Energy of a held-out mission's logged poses against the battery energy it measured."""
    from energy_planner.energy import path_energy
    from energy_planner.follow import walked_path
    from energy_planner.measurements import run_energies
    from energy_planner.terrain import load_dem
    from energy_planner.uncertainty import domain_report, predict_interval

    model = discovered.model
    terrain = load_dem(FIXTURE / "ridge.tif")
    g = _mission(name)
    wp = walked_path(g)
    e = path_energy(terrain, model, wp.xy, yaw=wp.yaw_rad, t=wp.t)
    p = g["voltage"].to_numpy(float) * g["current"].to_numpy(float)
    by_hand = float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(g["t"].to_numpy(float))))
    measured = float(run_energies(g)["measured_j"].iloc[0])
    assert measured == pytest.approx(by_hand, rel=1e-9)
    assert e.duration_s == pytest.approx(g["t"].iloc[-1] - g["t"].iloc[0], abs=0.5)
    assert abs(e.energy_j / measured - 1.0) <= TOLERANCE
    dom = domain_report(model, e.table, {}, e.poses, {})
    iv = predict_interval(
        model, e.energy_j, outside_share=dom["outside_share"], duration_s=e.duration_s
    )
    assert iv is not None
    assert math.isfinite(iv.low_j) and math.isfinite(iv.high_j)
    assert 0 < iv.low_j <= e.energy_j <= iv.high_j


def test_walked_path_takes_each_pose_at_the_time_it_was_logged():
    """The localisation is slower than the 10 Hz log (held 1-3 samples): waypoints are new poses."""
    from energy_planner.follow import walked_path

    g = _mission("m009").reset_index(drop=True)
    t = g["t"].to_numpy(float) - float(g["t"].iloc[0])
    code = pd.Series(list(zip(g["x"], g["y"], g["yaw"], strict=True))).factorize()[0]
    first_t = pd.Series(t).groupby(code).min().to_numpy()
    moving = (np.hypot(g["vx"], g["vy"]) >= 0.05).to_numpy() | (np.abs(g["wz"]) >= 0.05).to_numpy()
    assert np.mean(code[1:][moving[1:]] == code[:-1][moving[1:]]) > 0.25  # the log repeats poses
    wp = walked_path(g, every_s=0.1)
    i = np.searchsorted(t, wp.t)
    assert np.allclose(t[i], wp.t)
    walk = i[1:-1][moving[i[1:-1]]]  # the last sample is kept as it is; at rest, repeats stay
    assert walk.size > 0.9 * (len(wp.t) - 2)
    assert np.allclose(first_t[code[walk]], t[walk])  # the time the pose was first logged
    assert len(wp.t) < 0.75 * len(g)  # one waypoint per pose update, not per sample


@settings(max_examples=40, deadline=None)
@given(
    holds=st.lists(st.integers(1, 6), min_size=2, max_size=40),
    resting=st.lists(st.booleans(), min_size=40, max_size=40),
)
def test_fresh_poses_keeps_each_pose_once_while_moving(holds, resting):
    """A pose held for ``h`` samples: kept once while moving, every sample at rest."""
    from energy_planner.follow import fresh_poses

    block = np.repeat(np.arange(len(holds)), holds)
    rest = np.asarray(resting[: len(holds)])[block]
    n = block.size
    s = pd.DataFrame(
        {
            "t": 0.1 * np.arange(n),
            "x": 0.12 * block,
            "y": 5.0,
            "yaw": 0.3 + 0.01 * block,
            "vx": np.where(rest, 0.0, 0.3),
            "vy": 0.0,
            "wz": 0.0,
        }
    )
    want = np.r_[True, block[1:] != block[:-1]] | rest
    if n >= 3:
        want[-1] = True
    else:
        want[:] = True
    assert fresh_poses(s).tolist() == want.tolist()


def test_battery_noise_is_white_so_the_floor_from_the_logs_is_fair():
    """The noise floor ``discover`` estimates from the logs (``diagnosis.metrics.noise_floor``)
    takes the battery power's noise as white: a window mean of ``n`` samples carries
    ``sd^2 / n``, ``sd`` from successive differences. Robot-b's noise is: the differences
    of white noise correlate -1/2 at lag 1 and 0 beyond (a slowly varying noise would
    show a lag-1 correlation above -1/2, and its window means more than ``sd^2 / n``), and
    within 4 robust sd they are Gaussian (kurtosis near 0; the rarer spikes are the
    outliers the cleaning drops). So a final RMSE far above that floor on these logs is
    an effect the model lacks, not noise the floor missed."""
    acf, kurt = [], []
    for f in sorted((FIXTURE / "train").glob("*.parquet")):
        g = pd.read_parquet(f).sort_values("t")
        d = np.diff((g["voltage"] * g["current"]).to_numpy(float))
        mad = 1.4826 * np.median(np.abs(d - np.median(d)))
        d = d[np.abs(d - np.median(d)) < 4 * mad]
        d = d - d.mean()
        acf.append([np.mean(d[:-k] * d[k:]) / np.mean(d * d) for k in (1, 2, 3, 5)])
        kurt.append(np.mean(d**4) / np.mean(d**2) ** 2 - 3.0)
    acf = np.mean(acf, axis=0)
    assert acf[0] == pytest.approx(-0.5, abs=0.05)
    assert np.abs(acf[1:]).max() < 0.05
    assert abs(np.mean(kurt)) < 0.5


def test_discover_adds_the_cross_slope_holding_cost(discovered):
    """Robot-b's held-out window errors swing by +-25 W over minutes, and only on slopes:
    walking across a slope (|cos(gamma)| < 0.3) the base model (copper losses in the square
    of the sideways load, ``tilt_y_sq``) underprices gentle slopes by ~8 W (6-18 deg) and
    overprices steep ones by ~13-23 W (24-30 deg) on the full logs. A holding cost in
    proportion to the load (``tilt_y_abs`` = ``abs(sin(alpha) sin(gamma))``: driver losses
    that grow with the current, friction with the torque) is what the logs show: on the full
    logs it takes the held-out RMSE from 6.76 to 4.44 W (floor 3.59 W). On this subset
    discover must add it as its first step: the training folds of every fold choose it
    alone, it removes more than half the squared error, it is a cost (positive
    coefficient), and all 12 runs improve: the exact signed-rank p is then one sign
    pattern in ``2 ** 12`` (the normal approximation could not go below 0.0011)."""
    d = discovered
    r = d.rankings[0]
    best = r.suspects[0]
    assert best.name == "tilt_y_abs"
    assert d.added == [best.term] == ["abs(sin(alpha) * sin(gamma))"]
    assert best.error_explained > 0.5
    assert best.coefficient > 0
    assert r.choice is not None and r.choice.passed
    assert r.choice.chosen == [best.term] * 5
    assert r.choice.n_runs == 12 and r.choice.p_value == 2.0**-12
    assert d.table()[1]["heldout_rmse_w"] < 0.6 * d.table()[0]["heldout_rmse_w"]
    # the model written holds it with the coefficient the staircase fitted
    assert d.model.coefficients[best.term] == pytest.approx(best.coefficient, rel=0.05)


def test_bench_counts_the_missions_by_channel_value_and_beyond_the_training_power():
    """The bench's breakdown of coverage: worked by hand on four missions of 60 s.

    Half-width 100 J everywhere, so z = (measured - predicted) / (100 / 1.645).
    """
    b = load_benchmark("bench_field_logs")

    def m(load: float, meas: float, pred: float) -> object:
        return b.Mission(f"r{load}{meas}", meas, pred, pred - 100.0, pred + 100.0, 0.0, 60.0, 2,
                         channels={"load_kg": load})  # fmt: skip

    # 0 kg: one inside (z +0.8225), one under-predicted outside (z +3.29); 27 kg: one over,
    # outside (z -1.645 * 1.5 = -2.4675); 9 kg: exact (z 0)
    ms = [m(0.0, 1050.0, 1000.0), m(0.0, 1200.0, 1000.0), m(27.0, 29850.0, 30000.0),
          m(9.0, 2000.0, 2000.0)]  # fmt: skip
    by = b.by_channel(ms)["load_kg"]
    assert list(by) == ["0", "9", "27"]  # numeric order
    assert (by["0"]["n"], by["0"]["covered"]) == (2, 1)
    assert by["0"]["mean_error"] == pytest.approx((1000 / 1050 - 1 + 1000 / 1200 - 1) / 2)
    assert by["0"]["z_mean"] == pytest.approx((0.5 + 2.0) * 1.645 / 2)
    assert by["0"]["z_rms"] == pytest.approx(1.645 * math.sqrt((0.25 + 4.0) / 2))
    assert (by["27"]["covered"], by["9"]["covered"]) == (0, 1)
    assert by["27"]["z_mean"] == pytest.approx(-1.5 * 1.645)
    # mean powers 16.7, 16.7, 500, 33.3 W: only the 27 kg mission is beyond 400 W
    far = b.beyond_power(ms, 400.0)
    assert (far["n"], far["covered"], far["train_max_power_w"]) == (1, 0, 400.0)
    assert far["mean_error"] == pytest.approx(30000 / 29850 - 1)
    assert b.beyond_power(ms, float("nan"))["n"] == 0
