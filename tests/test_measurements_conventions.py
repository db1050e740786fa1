"""Robot logs as loggers write them: units, time forms, crashed loggers, gaps.

Every conversion is checked against the same log written in canonical units (the
reference), never against the converter's own formulas.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.errors import LogError, LogIOError
from energy_planner.measurements import load_logs, make_windows, preprocess, run_energies
from energy_planner.measurements.datacheck import _runs, check_data, odometry_ratios
from energy_planner.measurements.schema import time_gaps, validate_log

EPOCH = 1_700_000_000


def _log(run: str = "a", n: int = 200, seed: int = 0, rate_hz: float = 50.0) -> pd.DataFrame:
    """A robot walking east at 0.3 m/s on flat ground, 50 Hz, with its pose."""
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(n) / rate_hz, 6)
    return pd.DataFrame(
        {
            "run": run,
            "t": t,
            "qw": 1.0,
            "qx": 0.0,
            "qy": 0.0,
            "qz": 0.0,
            "vx": 0.3,
            "vy": 0.0,
            "wz": 0.0,
            "voltage": np.round(48.0 + rng.normal(0, 0.1, n), 4),
            "current": np.round(5.0 + rng.normal(0, 0.2, n), 4),
            "x": 0.3 * t,
            "y": 0.0,
        }
    )


def _load(path, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        samples, rep = load_logs(path, report=True, **kw)
    return samples, rep, [str(w.message) for w in caught]


# ------------------------------------------------------------------------------ units


@pytest.mark.parametrize(
    ("columns", "scale"),
    [
        ({"voltage": "voltage_mv", "current": "current_ma"}, {"voltage": 1e3, "current": 1e3}),
        ({"voltage": "voltage_v", "current": "current_a"}, {"voltage": 1.0, "current": 1.0}),
        ({"voltage": "voltage_kv"}, {"voltage": 1e-3}),
    ],
)
def test_a_unit_in_the_column_name_is_converted(tmp_path, columns, scale):
    ref = _log()
    raw = ref.assign(**{c: ref[c] * k for c, k in scale.items()}).rename(columns=columns)
    raw.to_csv(tmp_path / "a.csv", index=False)
    got, rep, _ = _load(tmp_path / "a.csv")
    for c in ("voltage", "current"):
        np.testing.assert_allclose(got[c], ref[c], rtol=1e-12)
    assert any(f"{columns['voltage']!r} read as 'voltage'" in n for n in rep.notes)


def test_a_parquet_fields_unit_metadata_is_honoured(tmp_path):
    ref = _log()
    table = pa.Table.from_pandas(ref.assign(voltage=ref.voltage * 1000), preserve_index=False)
    i = table.schema.get_field_index("voltage")
    table = table.cast(table.schema.set(i, table.schema.field(i).with_metadata({"unit": "mV"})))
    pq.write_table(table, tmp_path / "a.parquet")
    got, rep, _ = _load(tmp_path / "a.parquet")
    np.testing.assert_allclose(got["voltage"], ref["voltage"], rtol=1e-12)
    assert any("'voltage' in mV converted to V" in n for n in rep.notes)


def test_an_unknown_declared_unit_is_an_error(tmp_path):
    table = pa.Table.from_pandas(_log(), preserve_index=False)
    i = table.schema.get_field_index("current")
    table = table.cast(
        table.schema.set(i, table.schema.field(i).with_metadata({"unit": "furlong"}))
    )
    pq.write_table(table, tmp_path / "a.parquet")
    with pytest.raises(LogError, match="'current' declares the unit 'furlong'"):
        load_logs(tmp_path / "a.parquet")


@pytest.mark.parametrize(
    ("column", "factor", "message", "fix"),
    [
        ("voltage", 1000.0, "voltage in mV?", "voltage_mv"),
        ("voltage", 0.001, "voltage in kV?", "voltage_kv"),
        ("current", 1000.0, "current in mA?", "current_ma"),
    ],
)
def test_a_magnitude_only_another_unit_explains_is_named_with_the_fix(
    tmp_path, column, factor, message, fix
):
    ref = _log()
    ref.assign(**{column: ref[column] * factor}).to_csv(tmp_path / "a.csv", index=False)
    with pytest.raises(LogError, match=message) as err:
        load_logs(tmp_path / "a.csv")
    assert fix in str(err.value) and "a.csv" in str(err.value)
    assert err.value.column == column


# ------------------------------------------------------------------------------- time


def _time_forms(ref: pd.DataFrame) -> dict[str, pd.DataFrame]:
    ns = ((EPOCH + ref["t"]) * 1e9).round().astype("int64")
    return {
        "ns integers": ref.assign(t=ns),
        "ms integers": ref.assign(t=(ns // 1_000_000)),
        "ISO 8601 text": ref.assign(
            t=pd.to_datetime(ns, unit="ns", utc=True).map(lambda x: x.isoformat())
        ),
        "t_ns column": ref.drop(columns="t").assign(t_ns=ns),
        "timestamp column": ref.drop(columns="t").assign(
            timestamp=pd.to_datetime(ns, unit="ns", utc=True).map(lambda x: x.isoformat())
        ),
    }


@pytest.mark.parametrize("form", list(_time_forms(_log())))
def test_time_in_the_forms_loggers_write_it(tmp_path, form):
    ref = _log()
    _time_forms(ref)[form].to_csv(tmp_path / "a.csv", index=False)
    got, _, _ = _load(tmp_path / "a.csv")
    np.testing.assert_allclose(got["t"] - EPOCH, ref["t"], atol=2e-6)


def test_parquet_datetimes_are_seconds_since_the_epoch(tmp_path):
    ref = _log()
    when = pd.to_datetime(((EPOCH + ref["t"]) * 1e9).round().astype("int64"), unit="ns")
    ref.assign(t=when).to_parquet(tmp_path / "a.parquet")
    got, rep, _ = _load(tmp_path / "a.parquet")
    np.testing.assert_allclose(got["t"] - EPOCH, ref["t"], atol=2e-6)
    assert any("datetimes" in n for n in rep.notes)


def test_a_time_no_robot_logged_is_named_not_a_pandas_overflow(tmp_path):
    # ISO text of the year 779 parses (pandas keeps it at second resolution) but has no
    # nanoseconds since 1970 in 64 bits: found by tests/test_fuzz_loaders.py
    p = tmp_path / "a.csv"
    p.write_text("t,qw,qx,qy,qz,vx,vy,wz,voltage,current\n0779-6\n")
    with pytest.raises(LogError, match=r"column 't' holds the time 0779-06-01.*1678-2261") as e:
        load_logs(p)
    assert str(p) in str(e.value)


@settings(max_examples=30, deadline=None)
@given(
    unit=st.sampled_from(["s", "ms", "us", "ns"]),
    start=st.integers(1_000_000_000, 2_000_000_000),
    period_ms=st.integers(5, 100),
)
def test_epoch_times_in_any_unit_come_back_as_the_same_seconds(unit, start, period_ms):
    from energy_planner.measurements.conventions import to_canonical_units

    k = {"s": 1, "ms": 10**3, "us": 10**6, "ns": 10**9}[unit]
    if unit == "s":  # seconds come as floats
        ticks = start + np.arange(20) * period_ms / 1000
    else:
        ticks = start * k + np.arange(20, dtype=np.int64) * (period_ms * k // 1000)
    df = pd.DataFrame({f"t_{unit}": ticks})
    out, _ = to_canonical_units(df, "x.csv")
    expect = start + np.arange(20) * period_ms / 1000
    np.testing.assert_allclose(out["t"].to_numpy(float), expect, rtol=0, atol=1e-6)


# ---------------------------------------------------------------- crashed loggers


def test_a_last_line_cut_short_is_dropped_with_a_note(tmp_path):
    ref = _log()
    p = tmp_path / "a.csv"
    ref.to_csv(p, index=False)
    p.write_bytes(p.read_bytes()[:-30])  # the logger died in the middle of the last row
    got, rep, _ = _load(p)
    assert len(got) == len(ref) - 1
    np.testing.assert_allclose(got["current"], ref["current"].iloc[:-1])
    assert any("cut short" in n for n in rep.notes)


@pytest.mark.parametrize("what", ["zero bytes", "header only", "truncated parquet"])
def test_what_a_crashed_logger_leaves_is_skipped_with_a_note(tmp_path, what):
    _log("good").to_csv(tmp_path / "good.csv", index=False)
    if what == "zero bytes":
        bad = tmp_path / "crashed.csv"
        bad.write_bytes(b"")
        reason = "empty file (0 bytes)"
    elif what == "header only":
        bad = tmp_path / "crashed.csv"
        _log().iloc[:0].to_csv(bad, index=False)
        reason = "a header but no samples"
    else:
        bad = tmp_path / "crashed.parquet"
        _log("crashed").to_parquet(bad)
        bad.write_bytes(bad.read_bytes()[:-200])
        reason = "truncated Parquet"
    got, rep, warned = _load(tmp_path)
    assert list(got["run"].unique()) == ["good"]
    assert rep.skipped == [{"path": str(bad), "reason": rep.skipped[0]["reason"]}]
    assert reason in rep.skipped[0]["reason"] and "crashed" in rep.skipped[0]["reason"]
    assert any(reason in w and str(bad) in w for w in warned)
    # named alone: the error lists it
    with pytest.raises(LogIOError, match=re.escape(reason)):
        load_logs(bad)


# ------------------------------------------------------------------------------- gaps


def _paused(ref: pd.DataFrame, at: int, pause_s: float) -> pd.DataFrame:
    """``ref`` with the robot standing ``pause_s`` seconds before sample ``at`` (no logs)."""
    out = ref.copy()
    out.loc[at:, "t"] += pause_s
    return out


def test_a_gap_splits_the_run_for_every_check():
    ref = _log(n=400)
    code, names = _runs(_paused(ref, 200, 600.0))
    assert code.tolist() == [0] * 200 + [1] * 200
    assert names.tolist() == ["a (part 1)", "a (part 2)"]


@pytest.mark.parametrize("rate_hz", [10.0, 50.0])
def test_odometry_is_not_measured_across_a_ten_minute_pause(rate_hz):
    ref = pd.concat(
        [_log(f"r{i}", n=400, seed=i, rate_hz=rate_hz) for i in range(6)], ignore_index=True
    )
    paused = pd.concat(
        [_paused(g, g.index[200], 600.0) for _, g in ref.groupby("run")], ignore_index=True
    )
    code, names = _runs(paused)  # two stretches per run
    assert len(names) == 12 and names[:2].tolist() == ["r0 (part 1)", "r0 (part 2)"]
    # the odometry agrees with the pose, paused or not (before: 12000 % long)
    ratios = odometry_ratios(paused).ratio
    np.testing.assert_allclose(ratios, 1.0, rtol=1e-9)
    found = {f.name: f for f in check_data(paused)[0]}
    assert not found["odometry_scale"].finding, found["odometry_scale"].summary
    # preprocessing says how many gaps split which run
    note = preprocess(paused)[1].step("split_segments").note
    assert note.startswith("6 time gap(s) (a step longer than 5 sample periods): run r0 split")
    assert f"run r5 split in 2 at 1 gap (> {5 / rate_hz:.3g} s); 12 segment(s)" in note


@pytest.mark.parametrize("rate_hz", [0.5, 1.0])
def test_a_slow_log_is_never_split_at_every_sample(rate_hz):
    """A 1 Hz or 0.5 Hz logger (sample steps of 1-2 s, with jitter) keeps its run whole."""
    rng = np.random.default_rng(3)
    log = _log(n=120, rate_hz=rate_hz)
    log["t"] = np.cumsum(np.r_[0.0, rng.uniform(0.7, 1.3, 119) / rate_hz])
    log["x"] = 0.3 * log["t"]
    gaps = time_gaps(log["run"], log["t"])
    assert gaps.n_gaps == {} and gaps.threshold["a"] == pytest.approx(5 / rate_hz, rel=0.1)
    assert _runs(log)[1].tolist() == ["a"]
    assert run_energies(log)["n_gaps"].tolist() == [0]
    assert validate_log(log).gaps == []
    clean, rep = preprocess(log)
    assert clean["segment"].max() == 0 and rep.step("split_segments").note.startswith("no time gap")
    np.testing.assert_allclose(odometry_ratios(log).ratio, 1.0, rtol=1e-9)


def test_a_100hz_log_with_a_03s_hole_splits_in_two():
    log = _paused(_log(n=300, rate_hz=100.0), 150, 0.3)  # the step there: 0.31 s
    gaps = time_gaps(log["run"], log["t"])
    assert gaps.n_gaps == {"a": 1} and gaps.threshold["a"] == pytest.approx(0.05)
    assert np.flatnonzero(gaps.step).tolist() == [149]
    code, names = _runs(log)
    assert names.tolist() == ["a (part 1)", "a (part 2)"] and (code == (log.index >= 150)).all()
    e = run_energies(log).iloc[0]  # the hole is not integrated
    assert e["n_gaps"] == 1 and e["gap_s"] == pytest.approx(0.31)
    assert e["duration_s"] == pytest.approx(2.98)
    clean = preprocess(log)[0]
    assert (clean["segment"] == (clean["t"] > 1.6)).all() and clean["segment"].max() == 1
    w = make_windows(log, duration=0.5)  # windows start again after the hole
    assert w.table["t_start"].round(6).tolist() == [0.0, 0.5, 1.0, 1.8, 2.3, 2.8]
    # the fixed threshold a caller may still give: a 0.5 s one bridges the hole
    assert time_gaps(log["run"], log["t"], max_gap=0.5).n_gaps == {}


def _split(ref: pd.DataFrame, at: int) -> pd.DataFrame:
    """``ref``'s run ``a`` cut at row ``at`` into two runs ``a1`` and ``a2``."""
    out = ref.copy()
    a = (out["run"] == "a").to_numpy()
    out.loc[a, "run"] = np.where(np.arange(len(out))[a] < at, "a1", "a2")
    return out


@settings(max_examples=20, deadline=None)
@given(
    rate_hz=st.sampled_from([0.5, 1.0, 10.0, 50.0, 100.0]),
    n=st.integers(40, 160),
    at=st.floats(0.15, 0.85),
    pause_periods=st.floats(6.0, 1e5),
    seed=st.integers(0, 2**16),
)
def test_a_long_pause_only_splits_the_run(rate_hz, n, at, pause_periods, seed):
    """Inserting a long pause into a run changes nothing but splitting it there.

    Every per-run quantity of the paused log (measured energy, windows, cleaned power,
    the odometry against the pose) equals that of the same log cut into two runs at the
    pause; the other run is untouched.
    """
    rng = np.random.default_rng(seed)
    a = _log("a", n=n, seed=seed, rate_hz=rate_hz)
    a["t"] = np.cumsum(np.r_[0.0, rng.uniform(0.8, 1.2, n - 1) / rate_hz])
    a["vx"] = rng.choice([0.3, 0.25, -0.3], n)
    a["x"] = np.r_[0.0, np.cumsum(a["vx"].to_numpy()[1:] * np.diff(a["t"]))]
    ref = pd.concat([a, _log("b", n=60, seed=seed + 1, rate_hz=20.0)], ignore_index=True)
    k = int(at * n)
    paused = _paused(ref, k, pause_periods / rate_hz)
    paused.loc[paused["run"] == "b", "t"] = ref.loc[ref["run"] == "b", "t"]
    split = _split(paused, k)
    assert time_gaps(paused["run"], paused["t"]).n_gaps == {"a": 1}
    assert time_gaps(split["run"], split["t"]).n_gaps == {}
    # measured energy: the parts' sum
    ep, es = run_energies(paused).set_index("run"), run_energies(split).set_index("run")
    for col in ("measured_j", "duration_s"):
        assert ep.loc["a", col] == pytest.approx(es.loc[["a1", "a2"], col].sum(), rel=1e-12)
        assert ep.loc["b", col] == es.loc["b", col]
    # windows: the same ones, with the same energies
    wp, ws = (make_windows(x.drop(columns=["x", "y"]), 1.5).table for x in (paused, split))
    cols = ["t_start", "duration", "n", "power", "energy_j", "motion"]
    pd.testing.assert_frame_equal(wp[cols], ws[cols], check_exact=True)
    # cleaned samples: the same ones, with the same power
    cp, cs = (preprocess(x.drop(columns=["x", "y"]))[0] for x in (paused, split))
    np.testing.assert_array_equal(cp["power"], cs["power"])
    np.testing.assert_array_equal(cp["t"], cs["t"])
    # the data checks: the same stretches, the same odometry ratios
    assert (_runs(paused)[0] == _runs(split)[0]).all()
    np.testing.assert_array_equal(odometry_ratios(paused).ratio, odometry_ratios(split).ratio)


def test_when_preprocessing_leaves_nothing_the_error_lists_each_removal():
    ref = _log()
    ref.loc[:99, "voltage"] = 0.0  # a battery monitor that read nothing
    ref.loc[100:, "vx"] = 0.0  # then the robot stood still
    with pytest.raises(LogError, match="removed every one of the 200 samples") as err:
        preprocess(ref)
    text = str(err.value)
    assert "drop_invalid: voltage outside 5..1000 V: 100" in text
    assert "discard_low_speed: speed < 0.05 m/s" in text and ": 100" in text
