"""Tests of the field-campaign simulator against independent physics and geometry."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.errors import EnergyPlannerError, ModelError
from energy_planner.model import BASE_TERMS, EnergyModel
from energy_planner.simulate import (
    BASE_COEFFICIENTS,
    CHANNELS,
    EFFECTS,
    LOG_COLUMNS,
    CampaignConfig,
    ConfigError,
    SensorConfig,
    plan_runs,
    simulate_campaign,
    truth_model,
)
from energy_planner.simulate.kinematics import twist_profile

IDEAL = CampaignConfig.small(sensors=SensorConfig.ideal())
C = BASE_COEFFICIENTS


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
    assert noisy.logs["surface"].dtype.name == "category"
    for col in ("run", "kind", "motion", "slope_deg", "uphill_azimuth_deg", "heading_deg",
                "speed", "yaw_rate", "duration_s", "composite", "part", "true_energy_j"):
        assert col in noisy.runs.columns
    assert set(noisy.logs["run"]) == set(noisy.runs["run"])
    assert isinstance(noisy.truth, EnergyModel)
    # time increases within every run and on the campaign clock
    assert (noisy.logs.groupby("run", observed=True)["t"].diff().dropna() > 0).all()
    assert np.all(np.diff(noisy.logs["t"].to_numpy()) > 0)
    # extra channels vary between runs although no effect is on
    per_run = noisy.logs.groupby("run", observed=True)[["payload_kg", "temperature_c"]].nunique()
    assert (per_run == 1).all().all()
    assert noisy.runs["payload_kg"].nunique() == 4
    assert set(noisy.runs["surface"]) == {"grass", "gravel", "mud", "asphalt"}
    assert noisy.runs["temperature_c"].between(0, 30).all()
    assert noisy.runs["grass_height_m"].between(0, 0.4).all()
    # discharging: current positive while walking
    walking = noisy.true_samples["speed"] > 0.1
    assert np.median(noisy.logs.loc[walking, "current"]) > 0


def test_default_campaign_is_a_few_hundred_runs_of_20_30_s():
    plan = plan_runs(CampaignConfig())
    assert 300 <= len(plan) <= 800
    kinds = {r.kind for r in plan}
    assert kinds == {"straight", "turn", "arc", "stand", "composite"}
    assert {r.slope_deg for r in plan} >= {0, 5, 10, 15, 20, 25}


# --------------------------------------------------------------------------- truth


def test_truth_without_effects_is_the_base_model(ideal):
    assert truth_model().term_names == list(BASE_TERMS)
    # a least-squares fit of the base model on the noise-free truth recovers it exactly
    f = ideal.features()
    fitted = EnergyModel(BASE_TERMS).fit(f, ideal.true_samples["power"].to_numpy())
    for name, value in C.items():
        assert fitted.coefficients[name] == pytest.approx(value, rel=1e-8), name
    assert np.allclose(fitted.power(f), ideal.true_samples["power"], atol=1e-6)


def test_an_effect_is_outside_the_base_model():
    camp = simulate_campaign(seed=3, effects=("cold_joints",), config=IDEAL)
    f = camp.features()
    p = camp.true_samples["power"].to_numpy()
    base = EnergyModel(BASE_TERMS).fit(f, p)
    full = EnergyModel([*BASE_TERMS, EFFECTS["cold_joints"].term]).fit(f, p)
    assert np.sqrt(np.mean((base.power(f) - p) ** 2)) > 5.0  # W
    assert full.coefficients["cold_joints"] == pytest.approx(4.0, rel=1e-8)


@settings(max_examples=200, deadline=None)
@given(
    alpha=st.floats(0, math.radians(30)),
    gamma=st.floats(-math.pi, math.pi),
    vx=st.floats(-0.6, 0.6),
    vy=st.floats(-0.6, 0.6),
    wz=st.floats(-1.0, 1.0),
    ax=st.floats(-1, 1),
    ay=st.floats(-1, 1),
    payload=st.floats(0, 20),
    temp=st.floats(-10, 40),
    grass=st.floats(0, 0.5),
    surface=st.sampled_from(["mud", "grass"]),
)
def test_truth_power_is_never_negative_up_to_30_degrees(
    alpha, gamma, vx, vy, wz, ax, ay, payload, temp, grass, surface
):
    model = truth_model(tuple(EFFECTS))
    f = {"alpha": np.array([alpha]), "gamma": np.array([gamma]), "vx": np.array([vx]),
         "vy": np.array([vy]), "wz": np.array([wz]), "ax": np.array([ax]),
         "ay": np.array([ay]), "payload_kg": np.array([payload]),
         "temperature_c": np.array([temp]), "grass_height_m": np.array([grass]),
         "surface": np.array([surface])}
    raw = model.design_matrix(f) @ model.coef_array()
    assert raw[0] >= 0.0


def test_truth_model_rejects_unknown_names():
    with pytest.raises(ModelError, match="valid effects: .*cold_joints"):
        truth_model(("no_such_effect",))
    with pytest.raises(ModelError, match="fwd_cost"):
        truth_model(fwd_cost=3.0)
    with pytest.raises(EnergyPlannerError, match="unknown effect 'x'"):
        simulate_campaign(effects=("x",), config=IDEAL)


# --------------------------------------------------------------------------- energies


def test_noise_free_logs_reproduce_the_true_energies(ideal):
    for run, df in ideal.logs.groupby("run", sort=False, observed=True):
        t = df["t"].to_numpy()
        measured = _trapz(df["voltage"].to_numpy() * df["current"].to_numpy(), t)
        true = ideal.runs.set_index("run").loc[run, "true_energy_j"]
        assert measured == pytest.approx(true, rel=1e-9, abs=1e-9), run


def test_true_energies_match_the_analytic_work_of_the_base_wrench(ideal):
    """E = force * distance (straight) and torque * angle (turns), from the wrench."""
    runs = ideal.runs
    checked = 0
    for r in runs.itertuples():
        a, g = math.radians(r.slope_deg), math.radians(r.heading_deg)
        if r.kind == "straight":
            force = {
                "forward": C["fwd_const"] + C["fwd_grade"] * math.sin(a) * math.cos(g),
                "backward": C["bwd_const"] - C["bwd_grade"] * math.sin(a) * math.cos(g),
                "left": C["lat_const"] - C["lat_grade"] * math.sin(a) * math.sin(g),
                "right": C["lat_const"] + C["lat_grade"] * math.sin(a) * math.sin(g),
            }[r.motion]
            distance = r.speed * (IDEAL.run_s - IDEAL.ramp_s)
            expected = force * distance
        elif r.kind == "turn":
            angle = IDEAL.yaw_rate * (IDEAL.run_s - IDEAL.ramp_s)
            expected = (C["turn_const"] + C["turn_slope"] * math.sin(a)) * angle
        elif r.kind == "stand":
            expected = 0.0
        else:
            continue
        assert r.true_energy_j == pytest.approx(expected, rel=1e-9, abs=1e-9), r.run
        checked += 1
    assert checked > 50


def test_superposition_of_composite_paths(ideal):
    """Energies of concatenated segments add; (a) C equals A + B in the base model."""
    comp = ideal.runs[ideal.runs["kind"] == "composite"]
    assert len(comp) > 0
    for cid, g in comp.groupby("composite"):
        e = g.set_index("part")["true_energy_j"]
        assert e["AB"] == pytest.approx(e["A"] + e["B"], rel=1e-9), cid
        if cid.startswith("supa"):
            assert e["C"] == pytest.approx(e["A"] + e["B"], rel=1e-9), cid
        else:  # an arc is a different motion: same pose change, different energy
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
    segs = [(d * dt, values[i % 4], values[(i + 1) % 4], values[(i + 2) % 4])
            for i, d in enumerate(durations)]
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
        return (r.kind, motion, r.slope_deg, (heading + 180) % 360 - 180, r.speed, r.part,
                r.repeat, family)

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


# --------------------------------------------------------------------------- effects

_EXPECTED = {
    "idle_power": lambda f: np.ones_like(f["vx"]),
    "speed_dependence": lambda f: f["vx"] ** 2 + f["vy"] ** 2,
    "joule_heating": lambda f: np.sin(f["alpha"]) ** 2,
    "downhill_braking": lambda f: np.maximum(
        -np.sin(f["alpha"]) * (f["vx"] * np.cos(f["gamma"]) - f["vy"] * np.sin(f["gamma"])), 0),
    "cross_slope_roll": lambda f: np.hypot(f["vx"], f["vy"]) * np.sin(f["alpha"])
    * np.abs(np.sin(f["gamma"])),
    "turn_while_walking": lambda f: np.abs(f["wz"]) * np.hypot(f["vx"], f["vy"]),
    "acceleration": lambda f: np.maximum(f["ax"] * f["vx"] + f["ay"] * f["vy"], 0),
    "surface_type": lambda f: np.hypot(f["vx"], f["vy"]) * (f["surface"] == "mud"),
    "payload": lambda f: f["payload_kg"] * np.hypot(f["vx"], f["vy"]),
    "cold_joints": lambda f: np.maximum(15 - f["temperature_c"], 0),
    "vegetation_drag": lambda f: f["grass_height_m"] * np.hypot(f["vx"], f["vy"]),
}


def test_every_effect_has_an_independent_expectation():
    assert set(_EXPECTED) == set(EFFECTS)
    catalog_free = [n for n, e in EFFECTS.items() if not e.catalog]
    assert {"cold_joints", "vegetation_drag"} <= set(catalog_free)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_effect_changes_power_only_where_its_variables_say(ideal, name):
    camp = simulate_campaign(seed=3, effects=(name,), config=IDEAL)
    # same seed: same runs, channels, twist and orientation with and without the effect
    same = ["run", "t", "qw", "qx", "qy", "qz", "vx", "vy", "wz", "x", "y", *CHANNELS]
    pd.testing.assert_frame_equal(camp.logs[same], ideal.logs[same])
    f = ideal.features()
    added = camp.true_samples["power"].to_numpy() - ideal.true_samples["power"].to_numpy()
    expected = EFFECTS[name].coefficient * _EXPECTED[name](f)
    assert np.allclose(added, expected, atol=1e-9)
    assert expected.max() > 1.0  # the small campaign exercises every effect
    acts = expected > 1e-9
    assert not acts.all() or name == "idle_power"
    # where an effect acts it is a clear share of the base power (not absurd)
    share = added[acts].sum() / ideal.true_samples["power"].to_numpy()[acts].sum()
    assert 0.03 < share < 0.6, share


def test_effect_shares_table(noisy):
    shares = noisy.effect_shares().set_index("effect")
    assert set(shares.index) == set(EFFECTS)
    assert shares.loc["idle_power", "active_fraction"] == 1.0
    assert shares.loc["turn_while_walking", "active_fraction"] < 0.2


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
    a = simulate_campaign(seed=5, effects=("payload",), config=CampaignConfig.small())
    b = simulate_campaign(seed=5, effects=("payload",), config=CampaignConfig.small())
    c = simulate_campaign(seed=6, effects=("payload",), config=CampaignConfig.small())
    pd.testing.assert_frame_equal(a.logs, b.logs)
    pd.testing.assert_frame_equal(a.runs, b.runs)
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
    for col in ("t", "vx", "current", "voltage", "qw", "temperature_c"):
        assert np.allclose(loaded[col], ref[col], rtol=1e-9, atol=1e-9), col
    runs = pd.read_csv(tmp_path / "runs.csv", keep_default_na=False)
    assert list(runs["run"]) == list(camp.runs["run"])
    truth = EnergyModel.load(tmp_path / "truth.json")
    assert truth.coefficients == camp.truth.coefficients


def test_write_ros2_bags(tmp_path):
    from energy_planner.measurements import load_rosbag

    cfg = CampaignConfig.small(slopes_deg=(10.0,), headings_deg=(0.0,), motions=("forward",),
                               turn_headings_deg=(), arcs=False, stand=False,
                               composite_slopes_deg=())
    camp = simulate_campaign(seed=2, config=cfg)
    files = camp.write(tmp_path, bag=True)
    bags = [p for p in files if p.parent.name == "bags"]
    assert len(bags) == len(camp.runs) == 1
    back = load_rosbag(bags[0])
    assert len(back) == len(camp.logs)
    assert np.allclose(back["current"], camp.logs["current"], rtol=1e-6, atol=1e-5)
    with pytest.raises(EnergyPlannerError, match="already holds bags"):
        camp.write(tmp_path, bag=True)


def test_cost_table_is_the_wrench_along_the_fall_line(ideal, tmp_path):
    """Force-equivalent cost along the fall line: const +- grade * sin(alpha)."""
    table = ideal.cost_table()
    assert set(table["direction"]) == {"uphill", "downhill"}
    const = {"forward": C["fwd_const"], "backward": C["bwd_const"], "lateral": C["lat_const"]}
    grade = {"forward": C["fwd_grade"], "backward": C["bwd_grade"], "lateral": C["lat_grade"]}
    for r in table.itertuples():
        sign = 1.0 if r.direction == "uphill" else -1.0
        expected = const[r.motion] + sign * grade[r.motion] * math.sin(math.radians(r.slope_deg))
        assert r.true_cost_n == pytest.approx(expected, rel=1e-9), r.run
        assert r.measured_cost_n == pytest.approx(expected, rel=1e-9), r.run  # ideal sensors
    png = ideal.plot(tmp_path / "cost.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@settings(max_examples=100, deadline=None)
@given(
    alpha=st.floats(0, math.radians(30)),
    gamma=st.floats(-math.pi, math.pi),
    vx=st.floats(-0.6, 0.6),
    vy=st.floats(-0.6, 0.6),
    wz=st.floats(-1.0, 1.0),
    ax=st.floats(-1, 1),
    ay=st.floats(-1, 1),
)
def test_truth_is_mirror_symmetric(alpha, gamma, vx, vy, wz, ax, ay):
    """P(a, g, vx, vy, w) = P(a, -g, vx, -vy, -w) (design notes), every effect on."""
    model = truth_model(tuple(EFFECTS))
    channels = {"payload_kg": np.array([5.0]), "temperature_c": np.array([3.0]),
                "grass_height_m": np.array([0.2]), "surface": np.array(["mud"])}

    def p(g, y, w, acc_y):
        return model.power({"alpha": np.array([alpha]), "gamma": np.array([g]),
                            "vx": np.array([vx]), "vy": np.array([y]), "wz": np.array([w]),
                            "ax": np.array([ax]), "ay": np.array([acc_y]), **channels})[0]

    assert p(gamma, vy, wz, ay) == pytest.approx(p(-gamma, -vy, -wz, -ay), rel=1e-12, abs=1e-9)


def test_negative_truth_power_is_flagged_and_floored():
    cfg = CampaignConfig.small(slopes_deg=(20.0,), composite_slopes_deg=())
    weak = truth_model(fwd_const=100.0)  # forward downhill: 100 - 1000 sin 20 < 0
    with pytest.warns(UserWarning, match="negative power"):
        camp = simulate_campaign(seed=0, config=cfg, truth=weak)
    assert camp.truth is weak
    assert (camp.true_samples["power"] >= 0).all()
    assert (camp.true_samples["power"] == 0).any()
