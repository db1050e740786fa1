"""Sweep cases: robot logs as robots write them (units, time forms, crashed loggers, gaps).

Every log holds the same campaign where it can: a small simulated campaign
(``simulate --small --seed 7``) written in canonical units. A log in other units or time
forms must give the same model as the canonical one: the model fitted to it prices a
walk over the bundled hill within :data:`TOL` of the model fitted to the canonical logs
(the reference, fitted once). Refusals must name the cause.
"""

from __future__ import annotations

import shutil
import tempfile
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd
from _sweep import Run, Verdict, case, expect_error, run

TOPIC = "logs"
#: Largest relative difference of the priced walk from the reference model's (a refit of
#: the same samples differs by the held-out check's choice of repairs only).
TOL = 0.01
WAYPOINTS = "x,y\n500058,5000046\n500070,5000060\n500058,5000084\n"
_KEEP = Path(tempfile.mkdtemp(prefix="sweep_logs_"))  # the campaign and reference, shared


@cache
def _campaign_at(root: str) -> Path:
    """The canonical campaign, written once per checkout (``root`` keys the cache)."""
    out = _KEEP / f"camp_{abs(hash(root))}"
    r = run(_KEEP, "simulate", "--out", out, "--small", "--seed", "7")
    if r.rc != 0:
        raise RuntimeError(f"simulate failed: {r.error}")
    return out


def campaign() -> Path:
    """The canonical campaign's folder (simulated with the checkout under test)."""
    import _sweep

    return _campaign_at(str(_sweep.ROOT))


def logs(camp: Path) -> list[Path]:
    """The per-run logs of a campaign folder (not its run table)."""
    return sorted(p for p in camp.glob("*.csv") if p.name != "runs.csv")


def rewrite(tmp: Path, change, suffix: str = ".csv", every: int = 1) -> Path:
    """A copy of the campaign's logs with ``change(df, i) -> df | None`` applied.

    Writes CSV, or Parquet for ``suffix=".parquet"``; only every ``every``-th log is
    changed. ``change`` may write the file itself and return None.
    """
    out = tmp / "logs"
    out.mkdir()
    for i, p in enumerate(logs(campaign())):
        df = pd.read_csv(p)
        dest = out / (p.stem + suffix)
        new = change(df, i, dest) if i % every == 0 else df
        if new is None:
            continue
        if suffix == ".parquet":
            new.to_parquet(dest, index=False)
        else:
            new.to_csv(dest, index=False)
    return out


def _priced(tmp: Path, model: Path) -> tuple[Run, float | None]:
    import _sweep

    hill = _hill()
    (tmp / "wp.csv").write_text(WAYPOINTS)
    r = run(tmp, "energy", "--dem", hill, "--waypoints", tmp / "wp.csv", "--model", model,
            json_out=True)  # fmt: skip
    del _sweep
    return r, (r.data or {}).get("energy_j") if r.rc == 0 else None


@cache
def _hill() -> str:
    import _sweep

    p = Path(_sweep.ROOT) / "energy_planner" / "data" / "maps" / "hill.tif"
    return str(p)


@cache
def _reference_at(root: str) -> float:
    tmp = _KEEP / f"ref_{abs(hash(root))}"
    tmp.mkdir(exist_ok=True)
    r = run(tmp, "fit", campaign(), "--out", tmp / "m.json")
    if r.rc != 0:
        raise RuntimeError(f"reference fit failed: {r.error}")
    _, e = _priced(tmp, tmp / "m.json")
    if e is None:
        raise RuntimeError("reference energy failed")
    return float(e)


def reference() -> float:
    """Energy (J) of the walk priced by the model fitted to the canonical logs."""
    import _sweep

    return _reference_at(str(_sweep.ROOT))


def same_model(tmp: Path, folder: Path, warn: str | None = None) -> Verdict:
    """Handled: ``fit`` on ``folder`` works and its model prices the walk as the reference."""
    r = run(tmp, "fit", folder, "--out", tmp / "m.json")
    if r.traceback:
        return Verdict(r.error or "traceback", False, "traceback")
    if r.rc != 0:
        return Verdict(r.error, False, "refused: expected the reference model")
    if warn is not None:
        hits = [w for w in r.warnings if warn.lower() in w.lower()]
        if not hits:
            return Verdict(r.error or "(no warning)", False, f"no warning naming {warn!r}")
    rp, e = _priced(tmp, tmp / "m.json")
    if e is None:
        return Verdict(rp.error, False, "the fitted model could not price the walk")
    ref = reference()
    rel = e / ref - 1
    answer = f"walk priced {e:.0f} J (reference {ref:.0f} J, {100 * rel:+.2f} %)"
    if warn is not None:
        answer += f"; {hits[0][:120]}"
    return Verdict(answer, abs(rel) <= TOL, "" if abs(rel) <= TOL else "a different model")


# ---------------------------------------------------------------------------- units


@case(TOPIC, "battery voltage in mV under the usual column name 'voltage'")
def voltage_in_mv(tmp: Path) -> Verdict:
    folder = rewrite(tmp, lambda d, i, p: d.assign(voltage=d.voltage * 1000))
    return expect_error(
        run(tmp, "fit", folder, "--out", tmp / "m.json"), "voltage in mV?", "voltage_mv"
    )


@case(TOPIC, "battery current in mA under the usual column name 'current'")
def current_in_ma(tmp: Path) -> Verdict:
    folder = rewrite(tmp, lambda d, i, p: d.assign(current=d.current * 1000))
    return expect_error(
        run(tmp, "fit", folder, "--out", tmp / "m.json"), "current in mA?", "current_ma"
    )


@case(TOPIC, "battery voltage in kV (0.05) under 'voltage'")
def voltage_in_kv(tmp: Path) -> Verdict:
    folder = rewrite(tmp, lambda d, i, p: d.assign(voltage=d.voltage / 1000))
    return expect_error(run(tmp, "fit", folder, "--out", tmp / "m.json"), "voltage in kV?")


@case(TOPIC, "columns named with their units: voltage_mv, current_ma")
def named_units(tmp: Path) -> Verdict:
    def change(d, i, p):
        d = d.assign(voltage=d.voltage * 1000, current=d.current * 1000)
        return d.rename(columns={"voltage": "voltage_mv", "current": "current_ma"})

    return same_model(tmp, rewrite(tmp, change))


@case(TOPIC, "Parquet whose voltage field declares the unit 'mV' in its metadata")
def parquet_unit_metadata(tmp: Path) -> Verdict:
    import pyarrow as pa
    import pyarrow.parquet as pq

    def change(d, i, p):
        t = pa.Table.from_pandas(d.assign(voltage=d.voltage * 1000), preserve_index=False)
        k = t.schema.get_field_index("voltage")
        t = t.cast(t.schema.set(k, t.schema.field(k).with_metadata({"unit": "mV"})))
        pq.write_table(t, p)

    return same_model(tmp, rewrite(tmp, change, ".parquet"))


# ----------------------------------------------------------------------------- time


@case(TOPIC, "time as integer epoch nanoseconds (ROS header stamps)")
def time_ns(tmp: Path) -> Verdict:
    def change(d, i, p):
        return d.assign(t=((1_700_000_000 + d.t) * 1e9).round().astype("int64"))

    return same_model(tmp, rewrite(tmp, change))


@case(TOPIC, "time as ISO 8601 text with a time zone")
def time_iso(tmp: Path) -> Verdict:
    def change(d, i, p):
        when = pd.to_datetime(((1_700_000_000 + d.t) * 1e9).round().astype("int64"), utc=True)
        return d.assign(t=when.map(lambda x: x.isoformat()))

    return same_model(tmp, rewrite(tmp, change))


@case(TOPIC, "time as Parquet timestamps (pandas datetimes)")
def time_datetime_parquet(tmp: Path) -> Verdict:
    def change(d, i, p):
        return d.assign(t=pd.to_datetime(((1_700_000_000 + d.t) * 1e9).round().astype("int64")))

    return same_model(tmp, rewrite(tmp, change, ".parquet"))


@case(TOPIC, "a 10-minute pause in logging (robot standing) in every third run")
def ten_minute_gap(tmp: Path) -> Verdict:
    def change(d, i, p):
        d = d.copy()
        d.loc[len(d) // 2 :, "t"] += 600.0
        return d

    return same_model(tmp, rewrite(tmp, change, every=3))


@case(TOPIC, "time going backwards in one run")
def time_backwards(tmp: Path) -> Verdict:
    def change(d, i, p):
        d = d.copy()
        d.loc[10, "t"] = d.loc[5, "t"]
        d.loc[10, "t"] -= 0.001
        return d

    folder = rewrite(tmp, change, every=1000)
    return expect_error(
        run(tmp, "fit", folder, "--out", tmp / "m.json"), "goes backwards", "row 10"
    )


@case(TOPIC, "a repeated time stamp (a logger writing one sample twice)")
def duplicate_timestamps(tmp: Path) -> Verdict:
    def change(d, i, p):
        return pd.concat([d.iloc[:20], d.iloc[19:]], ignore_index=True)

    folder = rewrite(tmp, change, every=1000)
    return expect_error(run(tmp, "fit", folder, "--out", tmp / "m.json"), "repeats", "row 20")


# ------------------------------------------------------------------- crashed loggers


@case(TOPIC, "the last line of every log cut short (logger killed mid-write)")
def truncated_csv(tmp: Path) -> Verdict:
    def change(d, i, p):
        d.to_csv(p, index=False)
        p.write_bytes(p.read_bytes()[:-17])

    return same_model(tmp, rewrite(tmp, change))


@case(TOPIC, "one log is a zero-byte file (logger crashed at start)")
def empty_file(tmp: Path) -> Verdict:
    def change(d, i, p):
        p.write_bytes(b"")

    return _one_bad(tmp, change, ".csv", "empty file (0 bytes)")


@case(TOPIC, "one Parquet log cut short (no footer: logger crashed before closing)")
def truncated_parquet(tmp: Path) -> Verdict:
    def change(d, i, p):
        d.to_parquet(p, index=False)
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])

    return _one_bad(tmp, change, ".parquet", "truncated Parquet")


def _one_bad(tmp: Path, change, suffix: str, needle: str) -> Verdict:
    """The campaign with its first log replaced by what ``change`` writes: skipped, named."""
    folder = rewrite(tmp, change, suffix, every=1000)
    r = run(tmp, "fit", folder, "--out", tmp / "m.json")
    if r.traceback or r.rc != 0:
        return Verdict(r.error or "traceback", False, "refused: expected the file skipped")
    hits = [w for w in r.warnings if needle.lower() in w.lower()]
    if not hits:
        return Verdict("(fitted without a word)", False, f"no warning naming {needle!r}")
    return Verdict(hits[0][:160], True)


@case(TOPIC, "every log a zero-byte file")
def all_empty(tmp: Path) -> Verdict:
    folder = tmp / "logs"
    folder.mkdir()
    for p in logs(campaign())[:3]:
        (folder / p.name).write_bytes(b"")
    return expect_error(run(tmp, "fit", folder, "--out", tmp / "m.json"), "empty file (0 bytes)")


@case(TOPIC, "a log without its 'current' column")
def missing_column(tmp: Path) -> Verdict:
    folder = rewrite(tmp, lambda d, i, p: d.drop(columns="current"), every=1000)
    return expect_error(run(tmp, "fit", folder, "--out", tmp / "m.json"), "'current'", "lacks")


@case(TOPIC, "a battery monitor that reads 0 V in every sample")
def every_sample_implausible(tmp: Path) -> Verdict:
    folder = rewrite(tmp, lambda d, i, p: d.assign(voltage=np.zeros(len(d))))
    return expect_error(
        run(tmp, "fit", folder, "--out", tmp / "m.json"), "voltage outside 5..1000 V"
    )


def _cleanup() -> None:  # pragma: no cover - at exit
    shutil.rmtree(_KEEP, ignore_errors=True)


import atexit  # noqa: E402

atexit.register(_cleanup)
