"""Windows (hand-computed means), motion classes and measured run energies."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from energy_planner.errors import LogError
from energy_planner.measurements import (
    MOTIONS,
    classify_motion,
    imu_slope_heading,
    make_windows,
    preprocess,
    run_energies,
)


def log(t, run="r", **over):
    t = np.asarray(t, dtype=float)
    d = {
        "run": run,
        "t": t,
        "qw": 1.0,
        "qx": 0.0,
        "qy": 0.0,
        "qz": 0.0,
        "vx": 0.3,
        "vy": 0.0,
        "wz": 0.0,
        "voltage": 50.0,
        "current": 6.0,
    }
    d.update(over)
    return pd.DataFrame(d)


def test_classify_motion_each_class():
    vx = [0.3, -0.3, 0.0, 0.0, 0.0, 0.0, 0.3, 0.0]
    vy = [0.05, 0.0, 0.2, -0.2, 0.0, 0.0, 0.2, 0.0]
    wz = [0.0, 0.1, 0.0, 0.0, 0.5, -0.5, 0.0, 0.0]
    assert classify_motion(vx, vy, wz).tolist() == [
        "forward",
        "backward",
        "lateral_left",
        "lateral_right",
        "turn_left",
        "turn_right",
        "mixed",
        "mixed",
    ]
    # arc: 0.3 m/s with 0.4 rad/s -> 0.5 m * 0.4 = 0.2 > 0.3 * 0.3 -> mixed
    assert classify_motion(0.3, 0.0, 0.4).tolist() == ["mixed"]
    assert classify_motion(0.3, 0.0, 0.4, ratio=0.7).tolist() == ["forward"]


@settings(max_examples=100, deadline=None)
@given(vx=st.floats(-1, 1), vy=st.floats(-1, 1), wz=st.floats(-2, 2))
def test_classify_motion_mirror_symmetry(vx, vy, wz):
    # mirroring left/right swaps left and right classes, keeps the others
    a = classify_motion(vx, vy, wz)[0]
    b = classify_motion(vx, -vy, -wz)[0]
    swap = {
        "lateral_left": "lateral_right",
        "lateral_right": "lateral_left",
        "turn_left": "turn_right",
        "turn_right": "turn_left",
    }
    assert a in MOTIONS and b == swap.get(a, a)


def test_window_means_equal_hand_computed():
    # 0.25 s steps; run r: 3 s forward on a 10 deg pitch (nose up), power ramps;
    # then 1 s of turning in place
    t = 0.25 * np.arange(16)
    h = np.radians(-10.0) / 2
    vx = np.r_[np.full(12, 0.3), np.zeros(4)]
    wz = np.r_[np.zeros(12), np.full(4, 0.8)]
    cur = 1.0 + np.arange(16.0)
    surface = ["grass"] * 5 + ["mud"] * 11
    df = log(
        t,
        vx=vx,
        wz=wz,
        current=cur,
        qw=np.cos(h),
        qy=np.sin(h),
        payload_kg=np.arange(16.0),
        surface=pd.Categorical(surface),
    )
    w = make_windows(df, duration=1.0)
    tab = w.table
    assert list(tab["motion"]) == ["forward"] * 3 + ["turn_left"]
    assert list(tab["n"]) == [4, 4, 4, 4]
    np.testing.assert_allclose(tab["t_start"], [0.0, 1.0, 2.0, 3.0])
    # every sample stands for 0.25 s (the last one of a block for the previous step)
    np.testing.assert_allclose(tab["duration"], 1.0)
    np.testing.assert_allclose(tab["t_end"], [1.0, 2.0, 3.0, 4.0])
    # hand-computed: power = 50 * current; window 0 has currents 1, 2, 3, 4
    np.testing.assert_allclose(tab["power"], 50 * np.array([2.5, 6.5, 10.5, 14.5]))
    np.testing.assert_allclose(tab["energy_j"], 0.25 * 50 * np.array([10, 26, 42, 58]))
    np.testing.assert_allclose(tab["alpha"], np.radians(10.0))
    np.testing.assert_allclose(tab["gamma"], 0.0, atol=1e-12)
    np.testing.assert_allclose(tab["vx"], [0.3, 0.3, 0.3, 0.0])
    np.testing.assert_allclose(tab["wz"], [0, 0, 0, 0.8])
    np.testing.assert_allclose(tab["speed"], [0.3, 0.3, 0.3, 0.0])
    np.testing.assert_allclose(tab["payload_kg"], [1.5, 5.5, 9.5, 13.5])
    assert list(tab["surface"].astype(str)) == ["grass", "mud", "mud", "mud"]
    # per-sample rows carry the id; the table is their mean
    s = w.samples
    assert list(s["window"]) == list(np.repeat(np.arange(4), 4))
    np.testing.assert_allclose(s.groupby("window")["power"].mean(), tab["power"])
    for c in ("power", "alpha", "gamma", "speed", "ax", "ay", "motion", "window"):
        assert c in s.columns
    assert w.to_dict()["by_motion"] == {"forward": 3, "turn_left": 1}


def test_gamma_is_a_circular_mean():
    # headings just either side of +-pi: an arithmetic mean would give ~0 (uphill)
    a = np.radians(15.0)
    gam = np.array([np.pi - 0.1, -np.pi + 0.1, np.pi - 0.05, -np.pi + 0.05])
    # on a slope with uphill azimuth 0, a robot yawed by g about the slope normal:
    # R = R_y(-a) (tilt the plane up towards +x) then yaw g about the normal
    R = Rotation.from_euler("y", -a) * Rotation.from_euler("z", gam[:, None])
    qx, qy, qz, qw = R.as_quat().T
    np.testing.assert_allclose(imu_slope_heading(qw, qx, qy, qz)[1], gam, atol=1e-12)
    df = log(0.25 * np.arange(4), qw=qw, qx=qx, qy=qy, qz=qz)
    w = make_windows(df, duration=1.0)
    assert abs(abs(w.table["gamma"].iloc[0]) - np.pi) < 1e-9
    assert w.table["alpha"].iloc[0] == pytest.approx(a)


def test_windows_do_not_cross_gaps_motion_changes_or_runs_and_drop_short_tails():
    t = np.r_[0.1 * np.arange(15), 3.0 + 0.1 * np.arange(25)]  # gap of 1.6 s
    vx = np.r_[np.full(30, 0.3), np.full(10, -0.3)]  # reverse at row 30
    a = log(t, vx=vx)
    b = log(0.1 * np.arange(12), run="s")
    w = make_windows(pd.concat([a, b], ignore_index=True), duration=1.0)
    tab = w.table
    # run r: block 1 rows 0-14 (1.5 s) -> [0, 1) and 0.5 s tail (kept: >= 0.5 s);
    # block 2 rows 15-29 forward (1.5 s) -> 1 s + 0.5 s; block 3 rows 30-39 backward 1 s;
    # run s: 1.2 s -> 1 s + 0.2 s tail (dropped)
    assert list(tab["run"]) == ["r"] * 5 + ["s"]
    assert list(tab["motion"]) == ["forward"] * 4 + ["backward", "forward"]
    assert list(tab["n"]) == [10, 5, 10, 5, 10, 10]
    np.testing.assert_allclose(tab["t_start"], [0.0, 1.0, 3.0, 4.0, 4.5, 0.0])
    assert w.dropped == {"window shorter than 0.5 s or 3 samples": 2}
    for _, g in w.samples.groupby("window"):
        assert g["run"].nunique() == 1 and g["motion"].nunique() == 1
        assert np.diff(g["t"]).max() < 0.5


def test_windows_respect_preprocess_segments_and_energy_adds_up():
    t = 0.02 * np.arange(1000)
    df = log(t, current=6.0 + 0.5 * np.sin(t))
    clean, _ = preprocess(df)
    w = make_windows(clean, duration=2.0)
    assert len(w) == 10 and (w.table["n"] == 100).all()
    # energies of consecutive windows add up to the energy of the whole run (same
    # rectangle rule): sum(power_i dt_i)
    e_all = float(
        np.sum(clean["power"].to_numpy()[:-1] * np.diff(clean["t"]))
        + clean["power"].iloc[-1] * 0.02
    )
    assert w.table["energy_j"].sum() == pytest.approx(e_all, rel=1e-12)


def test_make_windows_errors_and_empty():
    with pytest.raises(LogError, match="duration"):
        make_windows(log([0.0, 1.0]), duration=0.0)
    w = make_windows(log([]), duration=1.0)
    assert len(w) == 0 and len(w.samples) == 0


def test_run_energies_analytic_and_additive():
    t = 0.01 * np.arange(1001)  # 10 s
    df = log(t, voltage=48.0, current=2.0 + 0.3 * t)  # P = 96 + 14.4 t
    e = run_energies(df)
    assert list(e.columns[:3]) == ["run", "duration_s", "measured_j"]
    assert e["duration_s"].iloc[0] == pytest.approx(10.0)
    assert e["measured_j"].iloc[0] == pytest.approx(96 * 10 + 7.2 * 100, rel=1e-12)
    # splitting the run at a sample gives two runs whose energies add up
    a = df.iloc[:400].assign(run="a")
    b = df.iloc[399:].assign(run="b")
    parts = run_energies(pd.concat([a, b]))
    assert parts["measured_j"].sum() == pytest.approx(e["measured_j"].iloc[0], rel=1e-12)


def test_run_energies_never_bridges_a_gap():
    df = log([0.0, 0.1, 0.2, 5.0, 5.1], voltage=50.0, current=2.0)
    e = run_energies(df).iloc[0]
    assert e["measured_j"] == pytest.approx(100.0 * 0.3)
    assert e["n_gaps"] == 1 and e["gap_s"] == pytest.approx(4.8)
    assert run_energies(df, max_gap=math.inf)["measured_j"].iloc[0] == pytest.approx(510.0)
    with pytest.raises(LogError, match="current"):
        run_energies(df.drop(columns="current"))


@settings(max_examples=40, deadline=None)
@given(
    dts=st.lists(st.floats(0.01, 0.7), min_size=5, max_size=120),
    duration=st.floats(0.5, 3.0),
    seed=st.integers(0, 2**16),
)
def test_window_invariants_on_irregular_sampling(dts, duration, seed):
    rng = np.random.default_rng(seed)
    t = np.concatenate([[0.0], np.cumsum(dts)])
    n = t.size
    vx = rng.choice([0.3, -0.3, 0.0], n)
    wz = np.where(vx == 0.0, 0.5, 0.0)
    df = log(t, vx=vx, wz=wz, current=rng.uniform(2, 10, n))
    w = make_windows(df, duration=duration, max_gap=0.5)
    s, tab = w.samples, w.table
    # every input sample is in one window or counted as dropped
    assert len(s) + sum(w.dropped.values()) == n
    assert s["t"].is_unique and np.isin(s["t"], t).all()
    for win, g in s.groupby("window"):
        row = tab.loc[tab["window"] == win].iloc[0]
        assert g["motion"].nunique() == 1 and g["motion"].iloc[0] == row["motion"]
        assert np.diff(g["t"]).max(initial=0.0) <= 0.5
        assert g["t"].iloc[-1] - g["t"].iloc[0] < duration + 1e-9
        assert row["duration"] <= duration + 0.5 + 1e-9
        assert row["power"] == pytest.approx(g["power"].mean())
        assert row["t_start"] == g["t"].iloc[0] and row["n"] == len(g)
