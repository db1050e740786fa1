"""Logs without altitude get it from the map, so the IMU's tilt is checked against the pose.

Field mission logs often hold the pose ``x, y`` of a map-referenced localisation and no
altitude. Given the map (``discover(..., terrain=)``, ``prepare_logs(..., terrain=)``), the
altitude under each pose is read from it and the ``imu_tilt`` check runs: the per-run tilt
it measures is checked against the tilt the simulator drew for each run (independent of
the check's own formula). Without the map it is not checked.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from energy_planner.calibration.prepare import altitude_from_map, prepare_logs
from energy_planner.measurements.datacheck import imu_tilt_bias
from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem


@pytest.fixture(scope="module")
def tilted_without_altitude():
    """Six short missions with the default sensors (0.3 deg IMU tilt per run), no z."""
    cfg = MissionConfig(missions=6, duration_s=60.0, rate_hz=10.0, stop_prob=0.6)
    terrain = synthetic_dem(3)
    camp = simulate_missions(seed=3, config=cfg, terrain=terrain)
    return camp, terrain


def test_the_altitude_read_from_the_map_is_the_logged_one(tilted_without_altitude):
    camp, terrain = tilted_without_altitude
    logs = camp.logs
    z = altitude_from_map(logs.drop(columns="z"), terrain)["z"].to_numpy()
    # the simulator logs the DEM under the robot; the map gives it back (bilinear, both)
    np.testing.assert_allclose(z, logs["z"].to_numpy(), atol=1e-6)
    assert altitude_from_map(logs, terrain) is logs  # a logged altitude is kept


def test_the_imu_tilt_is_measured_against_the_map(tilted_without_altitude):
    camp, terrain = tilted_without_altitude
    logs = camp.logs.drop(columns="z").assign(run=lambda d: d["run"].astype(str))
    logs = logs.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    est = imu_tilt_bias(altitude_from_map(logs, terrain)).set_index("run")
    truth = camp.runs.assign(run=camp.runs["run"].astype(str)).set_index("run")
    err = np.degrees(est["pitch"]) - truth.loc[est.index, "imu_pitch_bias_deg"]
    assert np.abs(err).max() < 0.05, err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = {f.name: f for f in prepare_logs(logs, terrain=terrain).findings}
        without = {f.name: f for f in prepare_logs(logs).findings}
    assert found["imu_tilt"].finding and found["imu_tilt"].repaired
    assert without["imu_tilt"].summary.startswith("not checked")
