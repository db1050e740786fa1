"""Tests of the field-campaign simulator against independent physics and geometry."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.errors import EnergyPlannerError, RemovedAPIError
from energy_planner.simulate import (
    CHANNELS,
    LOG_COLUMNS,
    CampaignConfig,
    ConfigError,
    Physics,
    SensorConfig,
    plan_runs,
    simulate_campaign,
)
from energy_planner.simulate.kinematics import twist_profile

IDEAL = CampaignConfig.small(sensors=SensorConfig.ideal())


@pytest.fixture(scope="module")
def ideal():
    return simulate_campaign(seed=3, config=IDEAL)


@pytest.fixture(scope="module")
def noisy():
    return simulate_campaign(seed=3, config=CampaignConfig.small())


def _trapz(y: np.ndarray, t: np.ndarray) -> float:
    return float(np.sum((y[1:] + y[:-1]) * np.diff(t) / 2))


def _quat_to_matrix(qw, qx, qy, qz):
    """Rotation matrices from unit quaternions (Hamilton, scalar first), written here."""
    n = np.sqrt(qw**2 + qx**2 + qy**2 + qz**2)
    w, x, y, z = qw / n, qx / n, qy / n, qz / n
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


# --------------------------------------------------------------------------- contract


def test_logs_and_runs_follow_the_contract(noisy):
    for col in (*LOG_COLUMNS, *CHANNELS):
        assert col in noisy.logs.columns
    assert noisy.logs["ground"].dtype.name == "category"
    for col in (
        "run",
        "kind",
        "motion",
        "slope_deg",
        "uphill_azimuth_deg",
        "heading_deg",
        "speed",
        "yaw_rate",
        "duration_s",
        "composite",
        "part",
        "true_energy_j",
    ):
        assert col in noisy.runs.columns
    assert set(noisy.logs["run"]) == set(noisy.runs["run"])
    assert isinstance(noisy.physics, Physics)
    # time increases within every run and on the campaign clock
    assert (noisy.logs.groupby("run", observed=True)["t"].diff().dropna() > 0).all()
    assert np.all(np.diff(noisy.logs["t"].to_numpy()) > 0)
    # extra channels vary between runs although no effect is on
    per_run = noisy.logs.groupby("run", observed=True)[["load_kg", "air_temp_c"]].nunique()
    assert (per_run == 1).all().all()
    assert noisy.runs["load_kg"].nunique() == 4
    assert set(noisy.runs["ground"]) == {"meadow", "gravel", "mud", "asphalt"}
    assert noisy.runs["air_temp_c"].between(-5, 30).all()
    assert noisy.runs["grass_height_m"].between(0, 0.4).all()
    # the windings warm up during a run, from 25-55 C at its start
    warm = noisy.logs.groupby("run", observed=True)["motor_temp"].agg(["first", "last"])
    assert (warm["last"] >= warm["first"]).all() and warm["first"].between(25, 75).all()
    # discharging: current positive while walking
    walking = noisy.true_samples["speed"] > 0.1
    assert np.median(noisy.logs.loc[walking, "current"]) > 0


def test_default_campaign_is_a_few_hundred_runs_of_20_30_s():
    plan = plan_runs(CampaignConfig())
    assert 300 <= len(plan) <= 800
    kinds = {r.kind for r in plan}
    assert kinds == {"straight", "turn", "arc", "stand", "composite"}
    assert {r.slope_deg for r in plan} >= {0, 5, 10, 15, 20, 25}


# --------------------------------------------------------------------------- energies


def test_noise_free_logs_reproduce_the_true_energies(ideal):
    for run, df in ideal.logs.groupby("run", sort=False, observed=True):
        t = df["t"].to_numpy()
        measured = _trapz(df["voltage"].to_numpy() * df["current"].to_numpy(), t)
        true = ideal.runs.set_index("run").loc[run, "true_energy_j"]
        assert measured == pytest.approx(true, rel=1e-9, abs=1e-9), run


def test_superposition_of_composite_paths(ideal):
    """Energies of concatenated segments add up to the ramps: A and B walked apart take
    one ramp (``ramp_s``) longer than AB, so AB = A + B minus about one ramp's energy;
    an arc (b, C) is a different motion from yaw + chord."""
    comp = ideal.runs[ideal.runs["kind"] == "composite"]
    assert len(comp) > 0
    for cid, g in comp.groupby("composite"):
        e = g.set_index("part")["true_energy_j"]
        p = g.set_index("part")["true_mean_power_w"]
        one_ramp = IDEAL.ramp_s * p[["A", "B"]].max()
        gap = e["A"] + e["B"] - e["AB"]
        if cid.startswith("supa"):  # no stop between A and B in AB
            assert 0 < gap < 1.2 * one_ramp, cid
        else:  # AB stops for one ramp between the yaw and the chord: same duration
            assert abs(gap) < 0.2 * one_ramp, cid
        if cid.startswith("supb"):
            assert e["C"] > 0 and e["C"] != pytest.approx(e["A"] + e["B"], rel=1e-3)


def test_composite_paths_share_their_end_pose(ideal):
    comp = ideal.runs[ideal.runs["kind"] == "composite"]
    for cid, g in comp.groupby("composite"):
        p = g.set_index("part")
        for part in ("AB", "C"):
            assert p.loc[part, "end_x"] == pytest.approx(p.loc["B", "end_x"], abs=2e-3), cid
            assert p.loc[part, "end_y"] == pytest.approx(p.loc["B", "end_y"], abs=2e-3), cid
            dyaw = math.remainder(p.loc[part, "end_yaw_deg"] - p.loc["B", "end_yaw_deg"], 360)
            assert abs(dyaw) < 1e-6, cid
        assert p.loc["B", "start_x"] == pytest.approx(p.loc["A", "end_x"])


@settings(max_examples=150, deadline=None)
@given(
    durations=st.lists(st.integers(1, 40), min_size=1, max_size=4),
    values=st.lists(st.floats(-1, 1), min_size=4, max_size=4),
    ramp=st.integers(0, 10),
)
def test_ramps_keep_distance_and_angle(durations, values, ramp):
    dt = 0.05
    segs = [
        (d * dt, values[i % 4], values[(i + 1) % 4], values[(i + 2) % 4])
        for i, d in enumerate(durations)
    ]
    t, vx, vy, wz, ax, _ = twist_profile(segs, ramp * dt, dt)
    assert t[-1] == pytest.approx(sum(s[0] for s in segs) + ramp * dt)
    for k, v in zip((1, 2, 3), (vx, vy, wz), strict=True):
        assert _trapz(v, t) == pytest.approx(sum(s[0] * s[k] for s in segs), abs=1e-9)
    assert vx[0] == (0.0 if ramp else segs[0][1])
    # acceleration is the derivative of the (piecewise-linear) speed profile
    if ramp:
        assert np.allclose(ax[1:-1], (vx[2:] - vx[:-2]) / (2 * dt), atol=1e-9)
    else:
        assert not ax.any()


# --------------------------------------------------------------------------- geometry


def test_quaternion_gives_back_slope_and_heading(ideal):
    """alpha = arccos(u_z), gamma = -atan2(u_y, u_x) with u = R^T (0, 0, 1)."""
    logs = ideal.logs
    R = _quat_to_matrix(*(logs[c].to_numpy() for c in ("qw", "qx", "qy", "qz")))
    u = R[:, 2, :]  # third row of R = R^T e_z
    alpha = np.degrees(np.arccos(np.clip(u[:, 2], -1, 1)))
    gamma = np.degrees(-np.arctan2(u[:, 1], u[:, 0]))
    runs = ideal.runs.set_index("run")
    run = logs["run"].to_numpy()
    assert np.allclose(alpha, runs.loc[run, "slope_deg"].to_numpy(), atol=1e-9)
    straight = (runs.loc[run, "kind"] == "straight").to_numpy() & (alpha > 1)
    expect = runs.loc[run, "heading_deg"].to_numpy()[straight]
    diff = (gamma[straight] - expect + 180) % 360 - 180
    assert np.abs(diff).max() < 1e-6
    # logged yaw is the horizontal heading of body x
    yaw = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    assert np.allclose(np.cos(yaw - logs["yaw"]), 1.0, atol=1e-12)
    # and the robot walks where body x points: forward runs move along the yaw
    fwd = ideal.runs[ideal.runs["motion"] == "forward"]
    heading = np.arctan2(fwd["end_y"] - fwd["start_y"], fwd["end_x"] - fwd["start_x"])
    assert np.allclose(np.cos(heading - np.radians(fwd["end_yaw_deg"])), 1.0, atol=1e-9)


def test_noisy_imu_stays_close_to_the_slope(noisy):
    logs = noisy.logs
    R = _quat_to_matrix(*(logs[c].to_numpy() for c in ("qw", "qx", "qy", "qz")))
    alpha = np.degrees(np.arccos(np.clip(R[:, 2, 2], -1, 1)))
    slope = noisy.runs.set_index("run").loc[logs["run"].to_numpy(), "slope_deg"].to_numpy()
    err = alpha - slope
    assert 0.01 < np.std(err[slope > 0]) < 1.5  # biased and noisy, but within ~1 deg


def test_campaign_design_is_mirror_symmetric(ideal):
    """For every run there is its mirror image (gamma -> -gamma, left <-> right) and the
    truth, which obeys P(a, g, vx, vy, w) = P(a, -g, vx, -vy, -w), gives it the same energy."""

    def mirror(text: str) -> str:
        return text.replace("left", "#").replace("right", "left").replace("#", "right")

    def key(r, motion: str, heading: float, family: str):
        return (
            r.kind,
            motion,
            r.slope_deg,
            (heading + 180) % 360 - 180,
            r.speed,
            r.part,
            r.repeat,
            family,
        )

    runs = list(ideal.runs.itertuples())
    family = {r.run: "_".join(r.composite.split("_")[:2]) for r in runs}  # e.g. supa_left
    energy = {key(r, r.motion, r.heading_deg, family[r.run]): r.true_energy_j for r in runs}
    assert len(energy) == len(runs)
    for r in runs:
        k = key(r, mirror(r.motion), -r.heading_deg, mirror(family[r.run]))
        assert k in energy, f"no mirror image of {r.run}"
        assert energy[k] == pytest.approx(r.true_energy_j, rel=1e-9), r.run


# --------------------------------------------------------------------------- battery


def test_battery_power_charge_and_voltage_sag(ideal):
    ts = ideal.true_samples
    assert np.allclose(ts["voltage"] * ts["current"], ts["power"], rtol=1e-12, atol=1e-9)
    assert (ts["current"] >= 0).all()
    bat = IDEAL.battery
    # terminal voltage = OCV(soc) - R I: sags with current ...
    sag = bat.ocv(ts["soc"]) - ts["voltage"]
    assert np.allclose(sag, bat.internal_resistance_ohm * ts["current"], atol=1e-9)
    # ... and with charge drawn: per run, soc falls by the integral of the current
    for r in ideal.runs.itertuples():
        d = ts[ts["run"] == r.run]
        charge_ah = _trapz(d["current"].to_numpy(), d["t"].to_numpy()) / 3600
        assert r.soc_start - r.soc_end == pytest.approx(charge_ah / bat.capacity_ah, rel=1e-9)
    first, last = ideal.runs.iloc[0], ideal.runs.iloc[-1]
    assert last.soc_end < first.soc_start


def test_battery_is_swapped_when_empty():
    from energy_planner.simulate import BatteryConfig

    cfg = IDEAL.replace(battery=BatteryConfig(capacity_ah=0.3, soc_swap=0.3))
    camp = simulate_campaign(seed=0, config=cfg)
    assert camp.runs["battery_pack"].max() >= 1
    assert (camp.runs["soc_end"] > 0).all()


# --------------------------------------------------------------------------- sensors


def test_odometry_slip_and_noise(noisy):
    logs, ts = noisy.logs, noisy.true_samples
    runs = noisy.runs.set_index("run")
    fwd = runs[(runs["motion"] == "forward") & (runs["slope_deg"] == 20)].index
    for run in fwd:
        m = (logs["run"] == run).to_numpy() & (ts["vx"] > 0.2).to_numpy()
        ratio = logs.loc[m, "vx"].mean() / ts.loc[m, "vx"].mean()
        assert ratio == pytest.approx(1 - runs.loc[run, "slip"], abs=0.01)
    assert 0 < runs["slip"].mean() < 0.2
    # current noise and rare spikes
    resid = logs["current"].to_numpy() - ts["current"].to_numpy()
    spikes = np.abs(resid) > 5
    assert 0 < spikes.mean() < 0.01
    assert np.std(resid[~spikes]) == pytest.approx(0.1, rel=0.1)


def test_seed_determinism():
    a = simulate_campaign(seed=5, effects=("load",), config=CampaignConfig.small())
    b = simulate_campaign(seed=5, effects=("load",), config=CampaignConfig.small())
    c = simulate_campaign(seed=6, effects=("load",), config=CampaignConfig.small())
    pd.testing.assert_frame_equal(a.logs, b.logs, check_exact=True)
    pd.testing.assert_frame_equal(a.runs, b.runs, check_exact=True)
    assert not np.allclose(a.logs["current"], c.logs["current"])


def test_bad_parameters_are_named():
    with pytest.raises(ConfigError, match="speeds"):
        CampaignConfig(speeds=())
    with pytest.raises(ConfigError, match="motions.*forward"):
        CampaignConfig(motions=("sideways",))
    with pytest.raises(ConfigError, match="run_s"):
        CampaignConfig(run_s=1.0, ramp_s=2.0)
    with pytest.raises(ConfigError, match="twice"):
        plan_runs(CampaignConfig.small(headings_deg=(0.0, 360.0)))


# --------------------------------------------------------------------------- files


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_write_and_load_back(tmp_path, fmt):
    from energy_planner.measurements import load_logs

    cfg = CampaignConfig.small(slopes_deg=(10.0,), composite_slopes_deg=())
    camp = simulate_campaign(seed=1, config=cfg)
    files = camp.write(tmp_path, fmt=fmt)
    logs = [p for p in files if p.suffix == f".{fmt}" and p.name != "runs.csv"]
    assert len(logs) == len(camp.runs)
    loaded = load_logs(logs)
    assert len(loaded) == len(camp.logs)
    ref = camp.logs.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    for col in ("t", "vx", "current", "voltage", "qw", "air_temp_c", "motor_temp"):
        assert np.allclose(loaded[col], ref[col], rtol=1e-9, atol=1e-9), col
    runs = pd.read_csv(tmp_path / "runs.csv", keep_default_na=False)
    assert list(runs["run"]) == list(camp.runs["run"])
    doc = json.loads((tmp_path / "physics.json").read_text())
    assert (
        doc["effects"] == [] and {"name": "mass_kg", "value": 50.0, "unit": "kg"} in doc["params"]
    )
    with pytest.raises(RemovedAPIError, match="true_path_energy"):
        camp.truth  # noqa: B018


def test_write_ros2_bags(tmp_path):
    from energy_planner.measurements import load_rosbag

    cfg = CampaignConfig.small(
        slopes_deg=(10.0,),
        headings_deg=(0.0,),
        motions=("forward",),
        turn_headings_deg=(),
        arcs=False,
        stand=False,
        composite_slopes_deg=(),
    )
    camp = simulate_campaign(seed=2, config=cfg)
    files = camp.write(tmp_path, bag=True)
    bags = [p for p in files if p.parent.name == "bags"]
    assert len(bags) == len(camp.runs) == 1
    back = load_rosbag(bags[0])
    assert len(back) == len(camp.logs)
    assert np.allclose(back["current"], camp.logs["current"], rtol=1e-6, atol=1e-5)
    with pytest.raises(EnergyPlannerError, match="is not empty"):
        camp.write(tmp_path, bag=True)


def test_cost_table_has_the_shape_of_the_papers_fig4(ideal, tmp_path):
    """Fig. 4: uphill the cost rises with slope; downhill it falls only for forward
    motion; lateral motion stays dearer and worsens with slope both ways."""
    table = ideal.cost_table()
    assert set(table["direction"]) == {"uphill", "downhill"}
    # ideal sensors: the measured cost is the true one
    assert np.allclose(table["measured_cost_n"], table["true_cost_n"], rtol=1e-9)
    cost = table.groupby(["direction", "motion", "slope_deg"])["true_cost_n"].mean()
    slopes = sorted(table["slope_deg"].unique())
    assert len(slopes) == 3
    for motion in ("forward", "lateral", "backward"):
        up = cost.loc[("uphill", motion)].reindex(slopes).to_numpy()
        assert np.all(np.diff(up) > 0), motion
    assert np.all(np.diff(cost.loc[("downhill", "forward")].reindex(slopes).to_numpy()) < 0)
    for direction in ("uphill", "downhill"):
        lat = cost.loc[(direction, "lateral")].reindex(slopes).to_numpy()
        fwd = cost.loc[(direction, "forward")].reindex(slopes).to_numpy()
        assert np.all(lat > fwd), direction
    lat_down = cost.loc[("downhill", "lateral")].reindex(slopes).to_numpy()
    assert np.all(np.diff(lat_down) > 0)
    png = ideal.plot(tmp_path / "cost.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_removed_truth_api_names_its_replacement():
    import energy_planner.simulate as sim

    with pytest.raises(RemovedAPIError, match="Physics"):
        sim.truth_model()
    with pytest.raises(RemovedAPIError, match="RobotParams"):
        sim.BASE_COEFFICIENTS  # noqa: B018
    with pytest.raises(ImportError, match="BASE_COEFFICIENTS was removed"):
        exec("from energy_planner.simulate import BASE_COEFFICIENTS", {})
