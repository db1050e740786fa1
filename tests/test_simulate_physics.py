"""The simulator's mechanistic truth against physical laws computed here by hand."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.errors import EnergyPlannerError, ModelError, OutsideMapError
from energy_planner.simulate import (
    CHANNELS,
    EFFECTS,
    FAULTS,
    CampaignConfig,
    MissionConfig,
    Physics,
    RobotParams,
    SensorConfig,
    critical_grade,
    simulate_campaign,
    simulate_missions,
    true_path_energy,
)

P = RobotParams()
IDEAL = CampaignConfig.small(sensors=SensorConfig.ideal())
ALL_CHANNELS = {
    "load_kg": 10.0,
    "ground": "mud",
    "motor_temp": 55.0,
    "air_temp_c": 3.0,
    "grass_height_m": 0.3,
}


@pytest.fixture(scope="module")
def ideal():
    return simulate_campaign(seed=3, config=IDEAL)


def _state(alpha=0.0, gamma=0.0, vx=0.0, vy=0.0, wz=0.0, ax=0.0, ay=0.0, **ch):
    f = {"alpha": alpha, "gamma": gamma, "vx": vx, "vy": vy, "wz": wz, "ax": ax, "ay": ay}
    return {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in f.items()} | {
        k: np.atleast_1d(np.asarray(v, dtype=object if isinstance(v, str) else float))
        for k, v in ch.items()
    }


# --------------------------------------------------------------------------- analytic


def test_level_walk_costs_the_analytic_power():
    """Level, straight, steady forward walk, term by term from the parameter table."""
    v, m, g = 0.3, P.mass_kg, P.gravity
    kappa_z = (
        P.winding_resistance_ohm
        * P.lever_support_m**2
        / (P.torque_constant_nm_a * P.gear_ratio) ** 2
    )
    # 4 legs share m g; each stance leg carries it 1/duty of the time, half-sine profile
    copper = kappa_z * (m * g) ** 2 / 4 * (math.pi**2 / 8) / P.duty_factor
    swing_lift = 4 * P.stride_frequency_hz * P.leg_mass_kg * g * P.step_clearance_m
    swing_kin = 4 * P.stride_frequency_hz * P.leg_mass_kg * (v / (1 - P.duty_factor)) ** 2
    expected = (
        P.electronics_w
        + copper
        + P.collision_forward * m * g * v / P.lift_efficiency
        + (swing_lift + swing_kin) / P.swing_efficiency
        + P.gearbox_friction_n * v
    )
    assert Physics().expected_power(_state(vx=v))[0] == pytest.approx(expected, rel=1e-12)
    # standing: all four legs, constant load, no gait
    stand = P.electronics_w + kappa_z * (m * g) ** 2 / 4
    assert Physics().expected_power(_state())[0] == pytest.approx(stand, rel=1e-12)


def test_level_run_energy_in_the_campaign(ideal):
    """The steady part of a level forward run: analytic power times its duration."""
    ts = ideal.true_samples
    runs = ideal.runs.set_index("run")
    run = runs[
        (runs["kind"] == "straight") & (runs["motion"] == "forward") & (runs["slope_deg"] == 0)
    ].index[0]
    d = ts[(ts["run"] == run) & np.isclose(ts["vx"], 0.3) & np.isclose(ts["ax"], 0)]
    assert len(d) > 50
    level = Physics().expected_power(_state(vx=0.3))[0]
    assert np.allclose(d["power_expected"], level, rtol=1e-12)
    steady = d["t"].iloc[-1] - d["t"].iloc[0]
    assert np.trapezoid(d["power_expected"], d["t"]) == pytest.approx(level * steady)


def test_gravity_work_and_direction_dependent_recovery():
    """Without copper losses the slope only adds gravity work: + m g v sin(a) / eta
    lifting, - recovery * m g v sin(a) lowering (forward 0.6, backward 0.2, lateral
    0.05 of what is released)."""
    cold = RobotParams(winding_resistance_ohm=1e-12)
    ph = Physics(cold)
    a, v, w = math.radians(15), 0.3, cold.mass_kg * cold.gravity
    lift = w * v * math.sin(a)
    for motion, (vx, vy), up_gamma, recovery in (
        ("forward", (v, 0), 0.0, cold.recovery_forward),
        ("backward", (-v, 0), math.pi, cold.recovery_backward),
        ("left", (0, v), -math.pi / 2, cold.recovery_lateral),
    ):
        level = ph.expected_power(_state(vx=vx, vy=vy))[0]
        up = ph.expected_power(_state(a, up_gamma, vx, vy))[0]
        down = ph.expected_power(_state(a, up_gamma + math.pi, vx, vy))[0]
        assert up - level == pytest.approx(lift / cold.lift_efficiency, abs=1e-6), motion
        assert level - down == pytest.approx(recovery * lift, abs=1e-6), motion


def test_copper_losses_scale_with_the_winding_resistance():
    f = _state(math.radians(20), 0.7, 0.3, 0.1, 0.2, 0.1, -0.1)
    base = Physics().components(f)
    double = Physics(P.replace(winding_resistance_ohm=2 * P.winding_resistance_ohm)).components(f)
    assert double["copper"][0] == pytest.approx(2 * base["copper"][0], rel=1e-12)
    for k in base:
        if k != "copper":
            assert double[k][0] == pytest.approx(base[k][0], rel=1e-12), k


def test_copper_losses_grow_with_the_square_of_the_leg_forces():
    """Standing: copper = kappa * (sum over legs of F^2); with a heavier robot the
    forces scale with the mass, so the losses scale with its square."""
    f = _state(math.radians(12), 1.0)
    c1 = Physics().components(f)["copper"][0]
    c2 = Physics(P.replace(mass_kg=2 * P.mass_kg)).components(f)["copper"][0]
    assert c2 == pytest.approx(4 * c1, rel=1e-12)


@settings(max_examples=150, deadline=None)
@given(
    alpha=st.floats(0, math.radians(30)),
    gamma=st.floats(-math.pi, math.pi),
    vx=st.floats(-0.6, 0.6),
    vy=st.floats(-0.6, 0.6),
    wz=st.floats(-1.0, 1.0),
    ax=st.floats(-1, 1),
    ay=st.floats(-1, 1),
    t=st.floats(0, 100),
)
def test_truth_is_mirror_symmetric_and_never_regenerates(alpha, gamma, vx, vy, wz, ax, ay, t):
    """P(a, g, vx, vy, w, ax, ay) = P(a, -g, vx, -vy, -w, ax, -ay) with every effect on;
    the power never falls below the electronics (lowering never charges the battery)."""
    ph = Physics(effects=tuple(EFFECTS))
    p = ph.power(_state(alpha, gamma, vx, vy, wz, ax, ay, t_gait=t, **ALL_CHANNELS))[0]
    q = ph.power(_state(alpha, -gamma, vx, -vy, -wz, ax, -ay, t_gait=t, **ALL_CHANNELS))[0]
    assert p == pytest.approx(q, rel=1e-12, abs=1e-9)
    e = ph.expected_power(_state(alpha, gamma, vx, vy, wz, ax, ay, **ALL_CHANNELS))[0]
    assert e >= ph.params.electronics_w - 1e-9
    assert p >= 0


def test_critical_grade_is_where_cost_per_height_is_least():
    """c(g)/g is least at the reported grade, checked on a grid computed here."""
    crit = critical_grade()
    assert 15 <= crit["slope_deg"] <= 22
    ph = Physics()
    deg = np.arange(2.0, 40.0, 0.25)
    a = np.radians(deg)
    cost = ph.expected_power(_state(a, np.zeros_like(a), np.full_like(a, 0.3))) / 0.3
    per_height = cost / np.sin(a)
    assert abs(deg[np.argmin(per_height)] - crit["slope_deg"]) <= 0.3
    # convex: the marginal cost of grade rises
    assert np.all(np.diff(cost, 2) > 0)


def test_ripple_averages_out_over_a_step_cycle():
    ph = Physics()
    step = 1.0 / (2 * P.stride_frequency_hz)
    t = np.linspace(0, step, 2001)
    f = _state(math.radians(10), 0.3, 0.3 + 0 * t, t_gait=t)
    p = ph.power(f)
    assert p.max() - p.min() > 10.0
    assert np.trapezoid(p, t) / step == pytest.approx(ph.expected_power(f)[0], rel=1e-6)


# --------------------------------------------------------------------------- effects

#: For each effect, samples where it must not change the power (features -> bool).
_UNCHANGED = {
    # cooling fans: off at or below 5 C of air
    "idle_power": lambda f: f["air_temp_c"] <= 5.0,
    "speed_dependence": lambda f: (
        np.isclose(np.hypot(f["vx"], f["vy"]), 0.3)
        | (np.hypot(f["vx"], f["vy"]) + np.abs(f["wz"]) == 0)
    ),
    "joule_heating": lambda f: np.zeros(len(f["vx"]), bool),
    # the descent mode: forward, more than 8 deg of downhill grade along the motion
    "downhill_braking": lambda f: (
        ~((f["vx"] > 0) & (-np.sin(f["alpha"]) * np.cos(f["gamma"]) > math.sin(math.radians(8.0))))
    ),
    "turn_while_walking": lambda f: (
        (np.abs(f["wz"]) < 1e-12) | (np.hypot(f["vx"], f["vy"]) < 1e-12)
    ),
    "acceleration": lambda f: (np.abs(f["ax"]) < 1e-12) & (np.abs(f["ay"]) < 1e-12),
    "load": lambda f: f["load_kg"] == 0,
    "ground": lambda f: f["ground"] == "asphalt",
    "motor_temp": lambda f: np.isclose(f["motor_temp"], P.reference_temp_c),
    "cold_joints": lambda f: np.isclose(f["air_temp_c"], P.gearbox_reference_c),
    "vegetation": lambda f: f["grass_height_m"] == 0,
}


def test_every_effect_says_where_it_acts():
    assert set(_UNCHANGED) == set(EFFECTS)
    channels = {e.channel for e in EFFECTS.values() if e.channel}
    assert channels <= set(CHANNELS) and len(channels) >= 3
    from energy_planner.model import CATALOG
    from energy_planner.model.formula import parse_formula

    read = set().union(*(parse_formula(t.formula).variables for t in CATALOG.values()))
    assert not channels & read  # the catalog reads none of them
    assert all(e.needs for e in EFFECTS.values())


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_effect_changes_only_the_power_and_only_where_it_should(ideal, name):
    camp = simulate_campaign(seed=3, effects=(name,), config=IDEAL)
    # same seed: same runs, channels, twist and orientation with and without the effect
    same = ["run", "t", "qw", "qx", "qy", "qz", "vx", "vy", "wz", "x", "y", *CHANNELS]
    pd.testing.assert_frame_equal(camp.logs[same], ideal.logs[same], check_exact=True)
    f = ideal.features()
    added = (
        camp.true_samples["power_expected"].to_numpy()
        - ideal.true_samples["power_expected"].to_numpy()
    )
    still = _UNCHANGED[name](f)
    assert np.allclose(added[still], 0.0, atol=1e-9)
    acts = np.abs(added) > 1e-6
    assert acts.any()
    share = np.abs(added[acts]).sum() / ideal.true_samples["power_expected"].to_numpy()[acts].sum()
    # acceleration is small by physics (rotors and legs: about 22 kg of kinetic mass)
    low = 0.002 if name == "acceleration" else 0.015
    assert low < share < 0.6, share


def test_effects_are_the_physics_they_describe():
    """Each effect equals the parameter change it claims, computed independently."""
    f = _state(
        math.radians(14),
        2.4,
        0.3,
        0.05,
        0.2,
        0.2,
        0.0,
        load_kg=12.0,
        motor_temp=60.0,
        air_temp_c=0.0,
        grass_height_m=0.2,
        ground="mud",
    )
    base = Physics().expected_power(f)[0]
    # load == a heavier robot
    assert Physics(effects=("load",)).expected_power(f)[0] == pytest.approx(
        Physics(P.replace(mass_kg=P.mass_kg + 12.0)).expected_power(f)[0], rel=1e-12
    )
    # motor_temp == the winding resistance at that temperature (+0.39 %/K)
    hot = P.winding_resistance_ohm * (1 + 0.0039 * (60.0 - P.reference_temp_c))
    assert Physics(effects=("motor_temp",)).expected_power(f)[0] == pytest.approx(
        Physics(P.replace(winding_resistance_ohm=hot)).expected_power(f)[0], rel=1e-12
    )
    # cold_joints: the gearbox loss grows by exp(0.05 * 20 K)
    gear = Physics().components(f)["gearbox"][0]
    assert Physics(effects=("cold_joints",)).expected_power(f)[0] - base == pytest.approx(
        gear * (math.exp(0.05 * 20) - 1), rel=1e-9
    )
    # idle_power: cooling fans, nothing at 0 C; 30 W at 30 C, (12.5 / 25)^3 of it at 17.5 C
    assert Physics(effects=("idle_power",)).expected_power(f)[0] == pytest.approx(base)
    for temp, fan in ((30.0, 30.0), (40.0, 30.0), (17.5, 30.0 / 8), (5.0, 0.0)):
        warm = {**f, "air_temp_c": np.array([temp])}
        added = Physics(effects=("idle_power",)).expected_power(warm) - Physics().expected_power(
            warm
        )
        assert added[0] == pytest.approx(fan, abs=1e-9)


def test_acceleration_pays_the_kinetic_energy_of_rotors_and_legs():
    """A level start from rest to v: the effect adds m_extra v^2 / 2 through the drive.

    m_extra from the rotor inertia and the joint kinematics (hip at v / h, knee at half),
    computed here from the parameter table, not from the simulator's helper.
    """
    v, ramp = 0.3, 1.0
    t = np.linspace(0.0, ramp, 20001)
    f = _state(0.0, 0.0, v * t / ramp, 0.0, 0.0, np.full(t.size, v / ramp), 0.0)
    added = Physics(effects=("acceleration",)).expected_power(f) - Physics().expected_power(f)
    j_n2 = 2e-3 * P.gear_ratio**2
    m_extra = 4 * j_n2 * (1 + 0.25) / P.com_height_m**2 + 4 * P.leg_mass_kg / 4
    assert 20 < m_extra < 25  # kg: half the robot's mass, not ten times it
    expected = m_extra * v**2 / 2 / P.lift_efficiency
    assert np.trapezoid(added, t) == pytest.approx(expected, rel=1e-6)
    # slowing down, the forward gait returns its share of that energy, as of the body's
    f_down = {**f, "ax": -f["ax"], "vx": f["vx"][::-1].copy()}
    down = Physics(effects=("acceleration",)).expected_power(f_down) - Physics().expected_power(
        f_down
    )
    returned = P.recovery_forward * m_extra * v**2 / 2
    assert np.trapezoid(down, t) == pytest.approx(-returned, rel=1e-3)


def test_any_two_effects_combine(ideal):
    f = ideal.features()
    base = Physics().expected_power(f)
    single = {n: Physics(effects=(n,)).expected_power(f) - base for n in EFFECTS}
    for a, b in itertools.combinations(sorted(EFFECTS), 2):
        both = Physics(effects=(a, b)).expected_power(f) - base
        assert np.isfinite(both).all()
        assert not np.allclose(both, single[a]) and not np.allclose(both, single[b]), (a, b)
    camp = simulate_campaign(seed=3, effects=("load", "ground"), config=IDEAL)
    assert camp.effects == ("load", "ground")


def test_unknown_names_and_missing_channels_are_named():
    with pytest.raises(ModelError, match="valid effects: .*cold_joints"):
        Physics(effects=("no_such_effect",))
    with pytest.raises(EnergyPlannerError, match="unknown effect 'x'"):
        simulate_campaign(effects=("x",), config=IDEAL)
    with pytest.raises(ModelError, match="valid faults"):
        simulate_campaign(faults=("gremlin",), config=IDEAL)
    with pytest.raises(ModelError, match="'load_kg'"):
        Physics(effects=("load",)).power(_state(vx=0.3))
    with pytest.raises(ModelError, match="unknown ground 'lava'"):
        Physics(effects=("ground",)).power(_state(vx=0.3, ground="lava"))


# --------------------------------------------------------------------------- faults


def test_sensor_faults():
    assert set(FAULTS) == {"slope_slip", "ros_current_sign", "clock_offset"}
    cfg = CampaignConfig.small(
        sensors=SensorConfig.ideal(), slopes_deg=(0.0, 20.0), composite_slopes_deg=()
    )
    clean = simulate_campaign(seed=1, config=cfg)
    sign = simulate_campaign(seed=1, config=cfg, faults=("ros_current_sign",))
    assert np.allclose(sign.logs["current"], -clean.logs["current"])
    lag = simulate_campaign(seed=1, config=cfg, faults=("clock_offset",))
    run = clean.runs.loc[clean.runs["kind"] == "straight", "run"].iloc[0]
    a = clean.logs.loc[clean.logs["run"] == run]
    b = lag.logs.loc[lag.logs["run"] == run]
    shifted = np.interp(a["t"] - 0.4, a["t"], a["current"])
    assert np.allclose(b["current"], shifted, atol=1e-9)
    slip = simulate_campaign(seed=1, config=cfg, faults=("slope_slip",))
    r = slip.runs.groupby("slope_deg")["slip"].mean()
    assert r.loc[20.0] - r.loc[0.0] == pytest.approx(0.6 * math.sin(math.radians(20)))


# --------------------------------------------------------------------------- noise floor


def test_noise_floor_is_the_rmse_of_measured_against_true_window_power():
    from energy_planner.measurements import make_windows, preprocess

    cfg = CampaignConfig.small(
        slopes_deg=(10.0,), composite_slopes_deg=(), arcs=False, turn_headings_deg=()
    )
    camp = simulate_campaign(seed=2, config=cfg)
    windows = make_windows(preprocess(camp.logs)[0])
    floor = camp.noise_floor(windows)
    # by hand: match every window sample to its log row, average the truth per window
    truth = {
        (r, round(t, 6)): p
        for r, t, p in zip(
            camp.true_samples["run"],
            camp.true_samples["t"],
            camp.true_samples["power_expected"],
            strict=True,
        )
    }
    sq = []
    for w, g in windows.samples.groupby("window"):
        true_w = np.mean([truth[(r, round(t, 6))] for r, t in zip(g["run"], g["t"], strict=True)])
        meas_w = windows.table.loc[windows.table["window"] == w, "power"].iloc[0]
        sq.append((meas_w - true_w) ** 2)
    assert floor.rmse_w == pytest.approx(math.sqrt(np.mean(sq)), rel=1e-12)
    assert floor.n_windows == len(windows.table) > 20
    assert 0.1 < floor.rmse_w < 20
    # perfect sensors and the instantaneous truth: the floor is zero
    ideal = simulate_campaign(seed=2, config=cfg.replace(sensors=SensorConfig.ideal()))
    w0 = make_windows(ideal.logs)
    assert ideal.noise_floor(w0, reference="instantaneous").rmse_w < 1e-9
    # preprocessing's smoothing lags at speed changes; smoothing the truth the same way
    # leaves (nearly) nothing with perfect sensors
    w1 = make_windows(preprocess(ideal.logs)[0])
    lag = ideal.noise_floor(w1, reference="instantaneous").rmse_w
    assert ideal.noise_floor(w1, reference="instantaneous", smoothing_tau_s=0.2).rmse_w < lag / 2
    other = simulate_campaign(seed=2, config=cfg.replace(slopes_deg=(5.0,)))
    with pytest.raises(EnergyPlannerError, match="not rows of this campaign"):
        other.noise_floor(windows)


# --------------------------------------------------------------------------- paths


def test_true_path_energy_on_a_plane_matches_the_per_sample_truth():
    from energy_planner.terrain import Terrain

    a = math.radians(12)
    plane = Terrain.from_function(lambda x, y: math.tan(a) * y, size=(60.0, 60.0), resolution=1.0)
    # 20 m (horizontal) straight up the fall line (+y), facing uphill
    e = true_path_energy(plane, [[30.0, 10.0, math.pi / 2], [30.0, 30.0, math.pi / 2]])
    surface = 20.0 / math.cos(a)
    assert e.distance_m == pytest.approx(surface, rel=1e-9)
    p = Physics().expected_power(_state(a, 0.0, 0.3))[0]
    assert e.energy_j == pytest.approx(p * surface / 0.3, rel=1e-9)
    # mirror: crossing the slope left-to-right or right-to-left costs the same
    e1 = true_path_energy(plane, [[10.0, 30.0], [50.0, 30.0]])
    e2 = true_path_energy(plane, [[50.0, 30.0], [10.0, 30.0]])
    assert e1.energy_j == pytest.approx(e2.energy_j, rel=1e-9)
    # a corner: turning in place at the yaw rate costs the in-place turning power
    e3 = true_path_energy(plane, [[10.0, 30.0], [30.0, 30.0], [30.0, 50.0]])
    assert e3.duration_s == pytest.approx(40.0 / 0.3 * 0 + e3.segments["duration_s"].sum())
    assert e3.segments["turn_rad"].abs().max() == pytest.approx(math.pi / 2)
    # channels: a load on, given as a constant
    heavy = true_path_energy(
        plane, [[30.0, 10.0], [30.0, 30.0]], effects=("load",), channels={"load_kg": 10.0}
    )
    assert heavy.energy_j > e.energy_j
    with pytest.raises(OutsideMapError):
        true_path_energy(plane, [[30.0, 10.0], [30.0, 90.0]])
    with pytest.raises(EnergyPlannerError, match="states"):
        true_path_energy(plane, [[30.0, 10.0]])


def _hills():
    from energy_planner.simulate import synthetic_dem

    return synthetic_dem(seed=7, size_m=60.0, resolution=1.0)


_HILLS = _hills()


@settings(max_examples=25, deadline=None)
@given(
    x0=st.floats(20, 40),  # the whole path (at most 16 m) stays on the 60 m map
    y0=st.floats(20, 40),
    heading=st.floats(-math.pi, math.pi),
    d1=st.floats(0.5, 8),
    d2=st.floats(0.5, 8),
)
def test_true_path_energy_adds_over_a_split_path(x0, y0, heading, d1, d2):
    """Walking A -> B -> C in one straight line costs A -> B plus B -> C (superposition)."""
    terrain = _HILLS
    c, s = math.cos(heading), math.sin(heading)
    a, b = (x0, y0, heading), (x0 + d1 * c, y0 + d1 * s, heading)
    end = (x0 + (d1 + d2) * c, y0 + (d1 + d2) * s, heading)
    whole = true_path_energy(terrain, [a, end], step_m=0.02).energy_j
    parts = (
        true_path_energy(terrain, [a, b], step_m=0.02).energy_j
        + true_path_energy(terrain, [b, end], step_m=0.02).energy_j
    )
    # equal up to the midpoint rule's discretisation of the sub-steps
    assert whole == pytest.approx(parts, rel=1e-5)


# --------------------------------------------------------------------------- missions


@pytest.fixture(scope="module")
def missions():
    return simulate_missions(seed=4, config=MissionConfig.small(sensors=SensorConfig.ideal()))


def test_missions_follow_the_dem(missions):
    ts, logs = missions.true_samples, missions.logs
    assert list(missions.runs["kind"].unique()) == ["mission"]
    for col in (
        "run",
        "t",
        "qw",
        "vx",
        "vy",
        "wz",
        "voltage",
        "current",
        "x",
        "y",
        "yaw",
        *CHANNELS,
    ):
        assert col in logs.columns
    # slope and heading change continuously; the robot stops, turns and changes speed
    d_alpha = ts.groupby("run")["alpha"].diff().abs().max()
    assert 0 < d_alpha < math.radians(1.0)
    assert ts["alpha"].max() - ts["alpha"].min() > math.radians(3)
    assert (ts["speed"] < 1e-6).any() and (ts["speed"] > 0.25).any()
    assert np.hypot(ts["wz"], 0).max() > 0.05
    # noise-free: the logged energy is the truth's, the IMU gives back the slope
    for run, df in logs.groupby("run", sort=False):
        e = np.trapezoid(df["voltage"] * df["current"], df["t"])
        assert e == pytest.approx(
            missions.runs.set_index("run").loc[run, "true_energy_j"], rel=1e-9
        )
    alpha = np.arccos(np.clip(1 - 2 * (logs["qx"] ** 2 + logs["qy"] ** 2), -1, 1))
    assert np.allclose(alpha, ts["alpha"], atol=1e-9)
    # the ground channel varies along the path
    assert logs["ground"].nunique() >= 1


def test_missions_same_seed_with_and_without_an_effect(missions):
    other = simulate_missions(
        seed=4, effects=("ground", "load"), config=MissionConfig.small(sensors=SensorConfig.ideal())
    )
    same = ["run", "t", "qw", "qx", "qy", "qz", "vx", "vy", "wz", "x", "y", *CHANNELS]
    pd.testing.assert_frame_equal(other.logs[same], missions.logs[same], check_exact=True)
    assert not np.allclose(other.true_samples["power"], missions.true_samples["power"])


def test_ground_map_as_a_raster_and_in_path_energy(tmp_path):
    import rasterio

    from energy_planner.simulate import ground_map, synthetic_dem

    terrain = synthetic_dem(seed=5, size_m=120.0)
    gm = ground_map(terrain, ("meadow", "gravel", "mud", "asphalt"), seed=5)
    tif, csv = gm.write(tmp_path / "ground.tif", tmp_path / "ground.csv")
    with rasterio.open(tif) as src:
        assert np.array_equal(src.read(1), gm.codes)
        assert src.transform == terrain.transform
    assert csv.read_text().splitlines()[:2] == ["code,ground", "1,meadow"]
    path = [[20.0, 20.0], [100.0, 30.0], [60.0, 100.0]]
    on = ("ground",)
    mixed = true_path_energy(terrain, path, effects=on, channels={"ground": gm}).energy_j
    paved = true_path_energy(terrain, path, effects=on, channels={"ground": "asphalt"}).energy_j
    mud = true_path_energy(terrain, path, effects=on, channels={"ground": "mud"}).energy_j
    assert paved < mixed < mud
    assert paved == pytest.approx(true_path_energy(terrain, path).energy_j, rel=1e-12)
