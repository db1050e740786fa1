"""Each preprocessing step on a crafted signal, and the report."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.errors import LogError
from energy_planner.measurements import (
    PreprocessParams,
    PreprocessReport,
    body_accelerations,
    consistency_bound,
    discard_low_speed,
    drop_invalid,
    ema,
    ema_smooth,
    hampel_filter,
    hampel_mask,
    mechanical_lower_bound,
    preprocess,
    split_segments,
)


def log(n=200, dt=0.02, run="r", **over):
    t = dt * np.arange(n)
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


P = PreprocessParams()


# ------------------------------------------------------------------ drop_invalid


def test_drop_invalid_counts_each_reason_once():
    df = log(10)
    df.loc[1, "vx"] = np.nan
    df.loc[2, "current"] = np.inf
    df.loc[3, "voltage"] = 0.0
    df.loc[4, "voltage"] = 1500.0
    df.loc[5, ["qw", "voltage"]] = [np.nan, 0.0]  # first reason only: non-finite qw
    out, rec = drop_invalid(df, P)
    assert rec.removed == {
        "non-finite qw": 1,
        "non-finite vx": 1,
        "non-finite current": 1,
        "voltage outside 5..1000 V": 2,
    }
    assert rec.n_removed == 5 and len(out) == 5
    assert list(out["t"]) == list(df["t"].iloc[[0, 6, 7, 8, 9]])


# ------------------------------------------------------------------ split_segments


def test_gap_splits_run_into_segments_and_is_counted():
    df = log(10, dt=0.1)
    df.loc[5:, "t"] += 1.0  # 1.1 s step between rows 4 and 5
    df2 = log(4, dt=0.1, run="s")
    out, rec = split_segments(pd.concat([df, df2], ignore_index=True), P)
    assert list(out["segment"]) == [0] * 5 + [1] * 5 + [0] * 4
    assert rec.n_removed == 0
    assert rec.note == (
        "1 time gap(s) (a step longer than 5 sample periods): "
        "run r split in 2 at 1 gap (> 0.5 s); 3 segment(s)"
    )


# ------------------------------------------------------------------ Hampel


def test_hampel_removes_a_spike_and_keeps_a_constant():
    x = np.full(50, 300.0)
    assert not hampel_mask(x, 5, 3.0).any()
    x[20] = 900.0
    assert np.flatnonzero(hampel_mask(x, 5, 3.0)).tolist() == [20]
    df = log(50, current=x / 50.0)
    df["power"] = x
    out, rec = hampel_filter(df, P)
    assert len(out) == 49 and out["power"].max() == 300.0
    assert list(rec.removed.values()) == [1]


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    lengths=st.lists(st.integers(1, 40), min_size=1, max_size=8),
    half=st.integers(1, 6),
    n_sigma=st.sampled_from([3.0, 0.5, -1.0]),
    min_scale=st.sampled_from([0.0, 5.0, 1e6]),
)
def test_segment_hampel_mask_is_hampel_mask_segment_by_segment(
    seed, lengths, half, n_sigma, min_scale
):
    """All segments at once: the mask of hampel_mask on each segment alone, bit for bit,
    on noise with spikes, repeated values (ties), missing and infinite values and constant
    segments, with the same warnings (none for an infinite value)."""
    from energy_planner.measurements.preprocess import segment_hampel_mask

    rng = np.random.default_rng(seed)
    ends = np.cumsum(lengths)
    segments = [slice(int(a), int(b)) for a, b in zip(np.r_[0, ends[:-1]], ends, strict=True)]
    x = np.round(rng.normal(300.0, 20.0, ends[-1]), rng.integers(-1, 2))
    x[rng.random(x.size) < 0.1] *= 4.0  # spikes
    x[rng.random(x.size) < 0.05] = np.nan
    x[rng.random(x.size) < 0.02] = np.inf
    if len(segments) > 1:
        x[segments[1]] = 250.0  # a constant segment
    if len(segments) > 2:
        x[segments[2]] = np.inf  # no finite value
    with warnings.catch_warnings(record=True) as before:
        warnings.simplefilter("always")
        want = np.concatenate([hampel_mask(x[sl], half, n_sigma, min_scale) for sl in segments])
    with warnings.catch_warnings(record=True) as now:
        warnings.simplefilter("always")
        got = segment_hampel_mask(x, segments, half, n_sigma, min_scale)
    assert got.tolist() == want.tolist()
    assert {str(w.message) for w in now} == {str(w.message) for w in before}


def test_hampel_keeps_a_ramp_and_a_step():
    ramp = np.linspace(100.0, 400.0, 80)
    assert not hampel_mask(ramp, 10, 4.0).any()
    step = np.r_[np.full(40, 200.0), np.full(40, 500.0)]  # a real change of gait
    assert not hampel_mask(step, 10, 4.0).any()


def test_hampel_min_scale_floor():
    x = np.full(30, 300.0)
    x[10] = 300.5  # quantisation-level wiggle: MAD = 0
    assert hampel_mask(x, 5, 3.0, 0.0)[10]
    assert not hampel_mask(x, 5, 3.0, 1.0).any()


def test_hampel_per_segment_does_not_cross_a_gap():
    # a lone 800 W sample at the end of segment 0 is an outlier there; if the window
    # bridged the gap into segment 1 (all 800 W) it would look normal
    df = log(40)
    df["power"] = np.r_[np.full(19, 100.0), np.full(21, 800.0)]
    df["segment"] = np.r_[np.zeros(20, int), np.ones(20, int)]
    params = PreprocessParams(hampel_half_window=5)
    out, _ = hampel_filter(df, params)
    assert len(out) == 39 and 19 not in out["t"].div(0.02).round().astype(int).tolist()
    out, _ = hampel_filter(df.drop(columns="segment"), params)
    assert len(out) == 40


# ------------------------------------------------------------------ EMA


@settings(max_examples=50, deadline=None)
@given(dts=st.lists(st.floats(0.001, 0.1), min_size=2, max_size=60), tau=st.floats(0.05, 1.0))
def test_ema_step_response_is_one_minus_exp(dts, tau):
    t = np.concatenate([[0.0], np.cumsum(dts)])
    x = np.ones_like(t)
    x[0] = 0.0  # step right after t = 0
    np.testing.assert_allclose(ema(x, t, tau), 1.0 - np.exp(-t / tau), atol=1e-12)


def test_ema_constant_unchanged_and_disabled():
    t = np.cumsum(np.r_[0.0, np.full(20, 0.03)])
    np.testing.assert_array_equal(ema(np.full(21, 7.0), t, 0.2), 7.0)
    x = np.sin(t)
    np.testing.assert_array_equal(ema(x, t, 0.0), x)


def test_ema_smooth_per_segment_and_columns():
    df = log(40, dt=0.05, vx=np.r_[np.zeros(20), np.full(20, 0.4)])
    df["power"] = 100.0
    df["segment"] = np.r_[np.zeros(20, int), np.ones(20, int)]
    out, rec = ema_smooth(df, PreprocessParams(ema_tau=0.2))
    # new segment restarts the filter: its first sample is the input, no lag from seg 0
    np.testing.assert_array_equal(out["vx"].to_numpy()[20:], 0.4)
    np.testing.assert_array_equal(out["power"], 100.0)
    assert "tau = 0.2 s" in rec.note
    # within one segment the same signal lags like the analytic step response
    df["segment"] = 0
    out, _ = ema_smooth(df, PreprocessParams(ema_tau=0.2))
    tt = df["t"].to_numpy()[20:] - df["t"].to_numpy()[19]
    np.testing.assert_allclose(out["vx"].to_numpy()[20:], 0.4 * (1 - np.exp(-tt / 0.2)))


# ------------------------------------------------------------------ accelerations


def test_body_accelerations_of_a_linear_ramp_and_irregular_dt():
    t = np.cumsum(np.r_[0.0, np.random.default_rng(3).uniform(0.01, 0.05, 60)])
    df = log(61, t=t, vx=0.2 + 0.5 * t, vy=-0.1 * t)
    out, _ = body_accelerations(df, P)
    np.testing.assert_allclose(out["ax"], 0.5, atol=1e-9)
    np.testing.assert_allclose(out["ay"], -0.1, atol=1e-9)
    df["segment"] = np.r_[np.zeros(60, int), [1]]  # one-sample segment -> 0
    out, _ = body_accelerations(df, P)
    assert out["ax"].iloc[-1] == 0.0


# ------------------------------------------------------------------ low speed


def test_low_speed_discard_keeps_turns_in_place():
    df = log(
        5,
        vx=[0.3, 0.01, 0.0, 0.0, 0.03],
        vy=[0.0, 0.0, 0.0, 0.06, 0.0],
        wz=[0.0, 0.0, 0.6, 0.0, -0.01],
    )
    out, rec = discard_low_speed(df, P)
    assert list(out.index) == [0, 1, 2]
    assert list(out["t"]) == list(df["t"].iloc[[0, 2, 3]])  # forward, turn, lateral
    assert list(rec.removed.values()) == [2]


# ------------------------------------------------------------------ consistency


def pitched(alpha_deg):
    h = np.radians(-alpha_deg) / 2  # nose up by alpha, facing uphill
    return {"qw": np.cos(h), "qy": np.sin(h)}


def test_mechanical_lower_bound_is_m_g_v_sin_alpha_uphill_and_zero_downhill():
    df = log(2, vx=[0.3, -0.3], **pitched(20.0))
    lb = mechanical_lower_bound(df, 50.0)
    assert lb[0] == pytest.approx(50.0 * 9.81 * 0.3 * np.sin(np.radians(20.0)))
    assert lb[1] == 0.0


def test_consistency_bound_rejects_impossible_power():
    # climbing 20 deg at 0.3 m/s with 50 kg needs >= 50.3 W of mechanical power
    df = log(4, vx=0.3, **pitched(20.0))
    df["power"] = [300.0, 30.0, -5.0, 9000.0]
    out, rec = consistency_bound(df, P)
    assert list(out["power"]) == [300.0]
    assert rec.removed == {
        "power < 0 W": 1,
        "power > 5000 W": 1,
        "power < 1 x m g v_up (m = 50 kg)": 1,
    }
    out, _ = consistency_bound(df, PreprocessParams(min_mech_ratio=0.0))
    assert list(out["power"]) == [300.0, 30.0]


# ------------------------------------------------------------------ whole pipeline


def test_preprocess_report_accounts_for_every_sample():
    rng = np.random.default_rng(0)
    n = 1000
    df = log(n, current=6.0 + rng.normal(0, 0.05, n), **pitched(10.0))
    df.loc[100, "current"] = 60.0  # spike
    df.loc[200, "voltage"] = np.nan  # NaN
    df.loc[300, "voltage"] = 2.0  # absurd
    df.loc[400:449, "vx"] = 0.0  # standing still 1 s
    df.loc[600:, "t"] += 3.0  # gap
    clean, rep = preprocess(df)
    assert isinstance(rep, PreprocessReport)
    assert rep.n_input == n and rep.n_output == len(clean)
    assert sum(rep.removed.values()) == n - len(clean)
    assert rep.step("drop_invalid").removed == {
        "non-finite voltage": 1,
        "voltage outside 5..1000 V": 1,
    }
    assert rep.removed["hampel_filter"] >= 1
    assert 100 not in set(np.round(clean["t"] / 0.02).astype(int))
    # standing still 50 samples: the smoothed speed 0.3 exp(-k dt / tau) falls below
    # 0.05 m/s after k = 18 samples (tau ln 6 = 0.36 s) and is back above it 2 samples
    # after the robot restarts: 50 - 18 + 1 = 33 samples (one more if Hampel shifted one)
    assert 33 <= rep.removed["discard_low_speed"] <= 34
    assert sorted(clean["segment"].unique()) == [0, 1]
    np.testing.assert_allclose(clean["alpha"], np.radians(10.0))
    for c in ("power", "alpha", "gamma", "speed", "ax", "ay", "segment"):
        assert c in clean.columns
    d = json.loads(json.dumps(rep.to_dict()))
    assert [s["name"] for s in d["steps"]][0] == "drop_invalid"
    assert d["n_output"] == len(clean)
    text = str(rep)
    assert "hampel_filter" in text and f"kept {len(clean)} of {n}" in text


def test_preprocess_keeps_input_unchanged_and_checks_columns():
    df = log(20)
    before = df.copy()
    preprocess(df)
    pd.testing.assert_frame_equal(df, before, check_exact=True)
    with pytest.raises(LogError, match="lacks required column.*'wz'"):
        preprocess(df.drop(columns="wz"))
    bad = df.copy()
    bad.loc[5, "t"] = 0.0
    with pytest.raises(LogError, match="goes backwards in run 'r' at row 5"):
        preprocess(bad)


def test_zero_quaternion_is_dropped_and_counted():
    df = log(6)
    df.loc[2, ["qw", "qx", "qy", "qz"]] = 0.0  # driver without orientation
    out, rec = drop_invalid(df, P)
    assert rec.removed == {"IMU quaternion norm off 1 by more than 0.1": 1}
    assert len(out) == 5


@pytest.mark.parametrize(
    "field,value",
    [
        ("ema_tau", -1.0),
        ("hampel_half_window", 0),
        ("voltage_min", 2000.0),
        ("max_gap", 0.0),
        ("robot_mass_kg", 0.0),
    ],
)
def test_params_out_of_range_name_the_field(field, value):
    with pytest.raises(LogError, match=rf"PreprocessParams\.{field}="):
        PreprocessParams(**{field: value})


def test_heading_convention_is_a_parameter():
    from scipy.spatial.transform import Rotation

    # 25 deg slope, uphill along +x, in-plane heading 45 deg
    R = Rotation.from_euler("y", -np.radians(25.0)) * Rotation.from_euler("z", np.pi / 4)
    qx, qy, qz, qw = R.as_quat()
    df = log(5, qw=qw, qx=qx, qy=qy, qz=qz)
    plane = preprocess(df)[0]["gamma"]
    yaw = preprocess(df, PreprocessParams(heading="yaw"))[0]["gamma"]
    np.testing.assert_allclose(np.degrees(plane), 45.0)
    np.testing.assert_allclose(np.degrees(yaw), np.degrees(np.arctan2(1, np.cos(np.radians(25)))))
    with pytest.raises(LogError, match="heading"):
        PreprocessParams(heading="compass")


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.one_of(st.floats(-1e3, 1e3), st.just(float("nan"))), min_size=1, max_size=40),
    st.integers(1, 6),
)
def test_the_hampel_windows_median_is_numpys_nanmedian(values, w):
    """The Hampel filter's row medians (one sort) equal numpy.nanmedian's, exactly."""
    import warnings

    from energy_planner.measurements.preprocess import _row_nanmedian

    x = np.array(values)
    pad = np.concatenate([np.full(w, np.nan), x, np.full(w, np.nan)])
    win = np.lib.stride_tricks.sliding_window_view(pad, 2 * w + 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN window: NaN
        want = np.nanmedian(win, axis=1)
    np.testing.assert_array_equal(_row_nanmedian(win), want)
