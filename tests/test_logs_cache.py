"""Logs read and prepared again come back from the cache folder equal to the first time.

Each check compares a second ``load_logs`` / ``prepare_logs`` with the first (pandas'
``assert_frame_equal``, the reports and findings as documents) and shows where the
answer came from: pandas' CSV reader made to fail proves that a read came from the
cache; a counting reader proves that a changed file, option or environment variable
was read afresh. Reads that warn, corrupt entries and a cache folder that cannot be
written are checked too (:mod:`energy_planner.measurements.stored`).
"""

from __future__ import annotations

import json
import os
import time
import warnings

import numpy as np
import pandas as pd
import pytest

from energy_planner.calibration import prepare as prepare_mod
from energy_planner.calibration.prepare import prepare_logs
from energy_planner.measurements import load_logs, stored


def _run(name: str, seconds: float, current: float = 4.0, seed: int = 0) -> pd.DataFrame:
    """One straight walk at 20 Hz (level, 0.3 m/s) with a noisy discharge current."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.05)
    return pd.DataFrame(
        {
            "t": t,
            "qw": 1.0,
            "qx": 0.0,
            "qy": 0.0,
            "qz": 0.0,
            "vx": 0.3 + 0.01 * rng.standard_normal(t.size),
            "vy": 0.0,
            "wz": 0.0,
            "voltage": 50.0,
            "current": current + 0.2 * rng.standard_normal(t.size),
            "surface": "grass",
        }
    )


@pytest.fixture()
def folder(tmp_path, monkeypatch):
    """Three runs as CSV files, and a fresh cache folder."""
    monkeypatch.setenv("ENERGY_PLANNER_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv(stored.ENV_SWITCH, raising=False)
    logs = tmp_path / "logs"
    logs.mkdir()
    for i in range(3):
        _run(f"r{i}", 12.0 + i, seed=i).to_csv(logs / f"r{i}.csv", index=False)
        _written_before(logs / f"r{i}.csv")
    return logs


def _written_before(path) -> None:
    """Date ``path`` a minute back: files written just now are not kept (``SETTLED_S``)."""
    t = time.time_ns() - 60 * 10**9
    os.utime(path, ns=(t, t))


@pytest.fixture()
def reads(monkeypatch):
    """The files pandas' CSV reader opened, in order."""
    seen: list[str] = []
    real = pd.read_csv

    def counting(path, *args, **kwargs):
        seen.append(os.path.basename(str(path)))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(pd, "read_csv", counting)
    return seen


def _no_reader(monkeypatch) -> None:
    def fail(*args, **kwargs):
        raise AssertionError("read from the files, not from the cache")

    monkeypatch.setattr(pd, "read_csv", fail)


def _entries(kind: str) -> list[str]:
    where = stored.folder()
    return sorted(p.name for p in where.glob(f"{kind}_*.pkl")) if where.is_dir() else []


def _same_load(a, b) -> None:
    pd.testing.assert_frame_equal(a[0], b[0], check_exact=True)
    assert a[1].to_dict() == b[1].to_dict()
    assert str(a[1]) == str(b[1])


def test_a_second_load_is_the_first_read_back(folder, monkeypatch):
    first = load_logs(folder, report=True)
    assert len(_entries("load")) == 1
    _no_reader(monkeypatch)
    second = load_logs(folder, report=True)
    _same_load(first, second)
    assert second[0]["surface"].dtype.name == "category"  # the types too
    pd.testing.assert_frame_equal(
        load_logs(folder), first[0], check_exact=True
    )  # report=False: the samples


def test_a_changed_file_option_or_environment_is_read_afresh(folder, reads, monkeypatch):
    first = load_logs(folder)
    assert reads == ["r0.csv", "r1.csv", "r2.csv"]
    load_logs(folder)
    assert len(reads) == 3  # the same: from the cache

    st = os.stat(folder / "r1.csv")  # touched: same content, a new time
    os.utime(folder / "r1.csv", ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    pd.testing.assert_frame_equal(load_logs(folder), first, check_exact=True)
    assert reads[3:] == ["r0.csv", "r1.csv", "r2.csv"]

    changed = _run("r1", 13.0, current=5.0, seed=1)  # new content, same size class
    changed.to_csv(folder / "r1.csv", index=False)
    _written_before(folder / "r1.csv")
    again = load_logs(folder)
    assert reads[6:] == ["r0.csv", "r1.csv", "r2.csv"]
    np.testing.assert_allclose(
        again.loc[again["run"] == "r1", "current"].to_numpy(), changed["current"], rtol=1e-12
    )

    n = len(reads)
    load_logs(folder, max_gap=0.5)  # another option
    assert len(reads) == n + 3
    monkeypatch.setenv("ENERGY_PLANNER_SOMETHING", "1")  # another environment
    load_logs(folder, max_gap=0.5)
    assert len(reads) == n + 6
    load_logs(folder, max_gap=0.5)
    assert len(reads) == n + 6  # and that one kept in turn


def test_a_read_that_warns_is_done_again_and_warns_again(folder, reads):
    _run("ros", 12.0, current=-4.0).to_csv(folder / "ros.csv", index=False)  # ROS sign
    _written_before(folder / "ros.csv")
    for _ in range(2):
        with pytest.warns(UserWarning, match="mostly negative"):
            s = load_logs(folder)
        assert float(s.loc[s["run"] == "ros", "current"].mean()) > 0  # negated both times
    assert reads.count("ros.csv") == 2
    assert _entries("load") == []


def test_a_skipped_crash_file_warns_every_time(folder, reads):
    (folder / "crashed.csv").write_bytes(b"")
    _written_before(folder / "crashed.csv")
    for _ in range(2):
        with pytest.warns(UserWarning, match="hold no samples"):
            load_logs(folder)
    assert reads.count("r0.csv") == 2
    assert _entries("load") == []


def test_an_ignored_warning_still_keeps_the_read_out(folder, reads):
    """A warning the filters hide now is seen by the next process: the read is not kept."""
    _run("ros", 12.0, current=-4.0).to_csv(folder / "ros.csv", index=False)
    _written_before(folder / "ros.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        load_logs(folder)
    assert _entries("load") == []


@pytest.mark.parametrize("damage", ["truncated", "flipped", "garbage"])
def test_a_damaged_entry_is_ignored_and_written_again(folder, reads, damage):
    first = load_logs(folder, report=True)
    (entry,) = stored.folder().glob("load_*.pkl")
    data = entry.read_bytes()
    if damage == "truncated":
        entry.write_bytes(data[: len(data) // 2])
    elif damage == "flipped":
        i = len(data) // 2
        entry.write_bytes(data[:i] + bytes([data[i] ^ 0xFF]) + data[i + 1 :])
    else:
        entry.write_bytes(b"not an entry")
    second = load_logs(folder, report=True)
    _same_load(first, second)
    assert len(reads) == 6  # read from the files again
    assert entry.read_bytes() == data  # and the entry written again, whole
    load_logs(folder)
    assert len(reads) == 6


def test_a_file_written_just_now_is_read_again(folder, reads):
    """Its next write may fall in the same tick of the file system's clock: not kept."""
    _run("new", 12.0, seed=5).to_csv(folder / "new.csv", index=False)
    first = load_logs(folder)
    assert _entries("load") == []
    _written_before(folder / "new.csv")
    pd.testing.assert_frame_equal(load_logs(folder), first, check_exact=True)
    assert len(_entries("load")) == 1
    pd.testing.assert_frame_equal(load_logs(folder), first, check_exact=True)
    assert reads.count("new.csv") == 2


def test_an_unwritable_cache_folder_still_answers(folder, tmp_path, monkeypatch, reads):
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file where the cache folder would be")
    monkeypatch.setenv("ENERGY_PLANNER_CACHE", str(blocker / "cache"))
    first = load_logs(folder, report=True)
    second = load_logs(folder, report=True)
    _same_load(first, second)
    assert len(reads) == 6  # nothing kept, nothing failed
    samples = first[0]
    a = prepare_logs(samples)
    b = prepare_logs(samples)
    pd.testing.assert_frame_equal(a.windows.table, b.windows.table, check_exact=True)


def test_switched_off_nothing_is_kept(folder, reads, monkeypatch):
    monkeypatch.setenv(stored.ENV_SWITCH, "0")
    load_logs(folder)
    load_logs(folder)
    assert len(reads) == 6
    assert _entries("load") == []


def test_the_least_recently_used_entries_go_beyond_the_limits(folder):
    name = {}
    for gap in (0.5, 0.6, 0.7):
        before = set(_entries("load"))
        load_logs(folder, max_gap=gap)
        (name[gap],) = set(_entries("load")) - before
    for i, gap in enumerate((0.5, 0.6, 0.7)):  # used long ago, in this order
        os.utime(stored.folder() / name[gap], ns=(10**17, (i + 1) * 10**17))
    load_logs(folder, max_gap=0.5)  # read back: used now
    stored._prune(stored.folder(), keep=2)
    assert _entries("load") == sorted([name[0.5], name[0.7]])
    size = (stored.folder() / name[0.5]).stat().st_size
    stored._prune(stored.folder(), keep=10, max_bytes=size)
    assert _entries("load") == [name[0.5]]


# ---- prepare_logs -------------------------------------------------------------------------


def _doc(p) -> str:
    """Everything a command reports of prepared logs, as one JSON text."""
    w = p.windows
    return json.dumps(
        {
            "findings": p.findings_dicts(),
            "found": [f.name for f in p.found],
            "repair": p.repair,
            "preprocessing": p.preprocess_report.to_dict(),
            "text": str(p.preprocess_report),
            "windows": w.to_dict(),
            "dropped_runs": w.dropped_runs,
        },
        sort_keys=True,
        default=repr,
    )


def _same_prepared(a, b) -> None:
    assert _doc(a) == _doc(b)
    pd.testing.assert_frame_equal(a.windows.samples, b.windows.samples, check_exact=True)
    pd.testing.assert_frame_equal(a.windows.table, b.windows.table, check_exact=True)
    wa, wb = a.windows.whole_runs, b.windows.whole_runs
    pd.testing.assert_frame_equal(wa.runs, wb.runs, check_exact=True)
    pd.testing.assert_frame_equal(wa.rest, wb.rest, check_exact=True)
    assert (wa.twist, wa.paths) == (wb.twist, wb.paths)


@pytest.fixture()
def hits(monkeypatch):
    """What every cache read of prepared logs answered (None: computed afresh)."""
    seen: list[object] = []
    real = stored.read

    def recording(kind, key):
        out = real(kind, key)
        if kind == "prepare":
            seen.append(out)
        return out

    monkeypatch.setattr(stored, "read", recording)
    return seen


def test_a_second_prepare_is_the_first_read_back(folder, hits):
    samples = load_logs(folder)
    before = samples.copy(deep=True)
    first = prepare_logs(samples)
    second = prepare_logs(samples)
    assert hits[0] is None and hits[1] is not None
    _same_prepared(first, second)
    assert second is not first and second.windows.samples is not first.windows.samples
    pd.testing.assert_frame_equal(
        samples, before, check_exact=True
    )  # the caller's samples untouched
    # the raw samples with a ROS-signed current: a finding, repaired, read back the same
    ros = samples.assign(current=-samples["current"])
    a, b = prepare_logs(ros), prepare_logs(ros)
    sign = {f.name: f for f in a.found}["current_sign"]
    assert sign.repaired and bool(a.windows.samples["current"].mean() > 0)
    assert hits[2] is None and hits[3] is not None
    _same_prepared(a, b)


def test_changed_samples_arguments_or_settings_are_prepared_afresh(folder, hits, monkeypatch):
    samples = load_logs(folder)
    prepare_logs(samples)
    one = samples.copy()
    one.loc[5, "current"] += 0.25  # one value
    prepare_logs(one)
    prepare_logs(samples, window=3.0)
    prepare_logs(samples, repair=False)
    prepare_logs(samples, guard=False)
    assert hits == [None] * 5
    with monkeypatch.context() as m:
        m.setattr(prepare_mod, "MIN_STOP_S", 2.0)  # a setting changed at run time
        prepare_logs(samples)
    assert hits[-1] is None
    prepare_logs(samples)
    assert hits[-1] is not None


def test_a_prepare_that_warns_is_done_again_and_warns_again(folder, hits):
    samples = load_logs(folder)
    short = _run("short", 0.6).assign(run="short")  # too short for any window
    s = pd.concat([samples, short[samples.columns.drop("surface")]], ignore_index=True)
    s["surface"] = s["surface"].fillna("grass").astype("category")
    for _ in range(2):
        with pytest.warns(UserWarning, match="dropped"):
            prepare_logs(s)
    assert hits == [None, None]
    assert _entries("prepare") == []


def test_an_entry_past_the_cap_or_unpicklable_is_not_kept_and_leaves_nothing(folder, monkeypatch):
    """Streamed to its file: refused at the cap, with no partial entry or temporary file."""
    big = np.arange(200_000, dtype=float)  # 1.6 MB pickled
    monkeypatch.setattr(stored, "MAX_ENTRY_BYTES", 1 << 20)
    assert not stored.keep("test", "big", big)
    assert stored.read("test", "big") is None
    assert stored.keep("test", "small", big[:1000])
    np.testing.assert_array_equal(stored.read("test", "small"), big[:1000])
    assert not stored.keep("test", "lambda", lambda: 0)  # cannot be pickled
    left = sorted(p.name for p in stored.folder().iterdir())
    assert left == ["test_small.pkl"], left
