"""Robot logs as loggers write them: units in column names or metadata, time in any form.

The canonical log is in SI units with ``t`` in seconds (:mod:`~energy_planner.measurements
.schema`). Loggers differ: a battery message in millivolts and milliamperes, a time stamp
in integer nanoseconds or as ISO text, a Parquet field that declares its unit. This module
turns a table read from one file into canonical units, saying what it converted, and
refuses magnitudes that only a wrong unit explains (a "voltage" of 48000) with the fix:

* a unit in the column name: ``voltage_mv``, ``voltage_v``, ``voltage_kv``, ``current_ma``,
  ``current_a``, ``t_ms``, ``t_us``, ``t_ns``, ``t_s`` (used when the canonical column is
  absent; converted and renamed);
* a unit in a Parquet field's metadata (key ``unit`` or ``units``: ``mV``, ``mA``, ``ns``,
  ...);
* a time column as datetimes (a Parquet timestamp, ISO 8601 text) or as integer epoch
  nanoseconds, microseconds or milliseconds (told by their magnitude): seconds since the
  epoch;
* otherwise the magnitudes are checked: a median battery voltage above
  :data:`~energy_planner.measurements.schema.VOLTAGE_RANGE`'s top that is plausible in
  volts once divided by 1000 is "voltage in mV?", one below its bottom that is plausible
  once multiplied by 1000 is "voltage in kV?", and a median current above
  :data:`MAX_CURRENT_A` is "current in mA?" (:class:`~energy_planner.errors.LogError`
  naming the file, the median and the fix).

Examples
--------
>>> import pandas as pd
>>> df = pd.DataFrame({"t_ns": [1_700_000_000_000_000_000, 1_700_000_000_020_000_000],
...                    "voltage_mv": [48000.0, 48010.0], "current_ma": [5000.0, 5100.0]})
>>> out, notes = to_canonical_units(df, "a.csv")
>>> out["t"].tolist(), out["voltage"].tolist(), out["current"].tolist()
([1700000000.0, 1700000000.02], [48.0, 48.01], [5.0, 5.1])
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from energy_planner.errors import LogError
from energy_planner.measurements.schema import VOLTAGE_RANGE, float_values

__all__ = ["MAX_CURRENT_A", "UNITS", "check_magnitudes", "parquet_units", "to_canonical_units"]

#: Known units of the columns that have one: name -> factor to the canonical unit.
UNITS: dict[str, dict[str, float]] = {
    "voltage": {"v": 1.0, "mv": 1e-3, "kv": 1e3},
    "current": {"a": 1.0, "ma": 1e-3},
    "t": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9},
}
#: The largest plausible median battery current of a legged robot, A (a B1-class robot
#: draws 5 to 15 A; 500 A at 50 V would be 25 kW).
MAX_CURRENT_A = 500.0
#: Integer or float epoch times larger than these are in ms, us, ns (epoch seconds are
#: about 1.7e9 today; relative seconds far less).
_EPOCH_SCALES = ((1e17, "ns"), (1e14, "us"), (1e11, "ms"))


def parquet_units(path) -> dict[str, str]:
    """Units a Parquet file's fields declare (metadata ``unit`` or ``units``), lower case.

    Returns an empty dict when the file declares none (or the schema cannot be read:
    reading the table reports that).
    """
    try:
        import pyarrow.parquet as pq

        schema = pq.read_schema(path)
    except Exception:  # noqa: BLE001 - the table read names the problem
        return {}
    out: dict[str, str] = {}
    for f in schema:
        md = f.metadata or {}
        for key in (b"unit", b"units"):
            if key in md:
                out[f.name] = md[key].decode(errors="replace").strip().lower()
                break
    return out


def _unit_error(source: str, column: str, unit: str) -> LogError:
    return LogError(
        f"log {source}: column {column!r} declares the unit {unit!r}; expected one of "
        f"{', '.join(UNITS[column])}",
        path=source,
        column=column,
        value=unit,
        expected=", ".join(UNITS[column]),
    )


def _time_seconds(col: pd.Series, source: str, notes: list[str], name: str) -> pd.Series:
    """``col`` (datetimes, ISO text, epoch ns/us/ms integers) as seconds; else as it is."""
    if isinstance(col.dtype, pd.DatetimeTZDtype) or pd.api.types.is_datetime64_any_dtype(col):
        ts = pd.to_datetime(col, utc=True)
        notes.append(f"{source}: {name!r} read as datetimes; t = seconds since 1970 (UTC)")
        return _epoch_seconds(ts, source, name)
    if col.dtype == object or pd.api.types.is_string_dtype(col):
        num = pd.to_numeric(col, errors="coerce")
        if num.notna().sum() >= 0.5 * col.notna().sum():
            col = num
        else:
            try:
                ts = pd.to_datetime(col, utc=True, format="ISO8601")
            except (ValueError, TypeError):
                return col  # check_time names the first value that is not a time
            notes.append(f"{source}: {name!r} read as ISO 8601 times; t = seconds since 1970 (UTC)")
            return _epoch_seconds(ts, source, name)
    if pd.api.types.is_numeric_dtype(col) and not pd.api.types.is_bool_dtype(col):
        v = pd.to_numeric(col, errors="coerce")
        med = float(np.nanmedian(np.abs(v.to_numpy(float)))) if v.notna().any() else 0.0
        for limit, unit in _EPOCH_SCALES:
            if med > limit:
                notes.append(
                    f"{source}: {name!r} read as epoch {unit} (median {med:.4g}); "
                    "t = seconds since 1970"
                )
                return _scaled_time(v, UNITS["t"][unit])
    return col


def _epoch_seconds(ts: pd.Series, source: str, name: str) -> pd.Series:
    """UTC datetimes (any resolution) as float seconds since 1970.

    Raises
    ------
    LogError
        A time outside the years 1678-2261 (nanoseconds since 1970 in 64 bits): no robot
        logged it; the column is most likely not a time.
    """
    try:
        ns = ts.dt.as_unit("ns").astype("int64").to_numpy()
    except pd.errors.OutOfBoundsDatetime:
        lo, hi = pd.Timestamp.min.tz_localize("UTC"), pd.Timestamp.max.tz_localize("UTC")
        bad = ts[(ts < lo) | (ts > hi)]
        value = bad.iloc[0] if len(bad) else ts.dropna().iloc[0]
        raise LogError(
            f"log {source}: column {name!r} holds the time {value}, outside the years "
            "1678-2261; expected times of the log (datetimes, ISO 8601 text, or epoch "
            "seconds/ms/us/ns)",
            path=source,
            column=name,
            value=str(value),
            expected="a time between the years 1678 and 2261",
        ) from None
    out = pd.Series(_ns_to_s(ns), index=ts.index)
    out[ts.isna().to_numpy()] = np.nan
    return out


def _ns_to_s(ns: np.ndarray) -> np.ndarray:
    """Integer nanoseconds to float seconds, exact to the float's resolution."""
    whole = ns // 1_000_000_000
    return whole.astype(float) + (ns - whole * 1_000_000_000).astype(float) * 1e-9


def _scaled_time(v: pd.Series, factor: float) -> pd.Series:
    if pd.api.types.is_integer_dtype(v) and factor < 1:
        return pd.Series(_ns_to_s(v.to_numpy(np.int64) * round(factor / 1e-9)), index=v.index)
    return _times(v.astype(float), factor)


def _times(v: pd.Series, factor: float) -> pd.Series:
    """``v * factor``, dividing by the whole reciprocal of a small factor (exact decimals)."""
    return v / round(1 / factor) if factor < 1 else v * factor


def to_canonical_units(
    df: pd.DataFrame, source: str, declared: Mapping[str, str] | None = None
) -> tuple[pd.DataFrame, list[str]]:
    """Canonical units and time for one table read from ``source``; the notes of what changed.

    Parameters
    ----------
    df : pandas.DataFrame
        The table as read.
    source : str
        The file, for messages.
    declared : mapping, optional
        Units the file declares per column (:func:`parquet_units`).

    Returns
    -------
    df : pandas.DataFrame
        With ``t`` in seconds, ``voltage`` in V and ``current`` in A where a unit was
        named (a suffixed column renamed to the canonical name) or a time form found.
    notes : list of str
        One line per conversion.

    Raises
    ------
    LogError
        A declared unit that is not known for its column.
    """
    notes: list[str] = []
    declared = dict(declared or {})
    out = df
    for canon, units in UNITS.items():
        if canon not in out.columns:
            named = [(f"{canon}_{u}", u) for u in units if f"{canon}_{u}" in out.columns]
            if canon == "t" and not named:
                named = [(c, "") for c in ("time", "timestamp", "stamp") if c in out.columns][:1]
            if len(named) == 1:
                col, unit = named[0]
                out = out.rename(columns={col: canon})
                if col in declared:
                    declared.setdefault(canon, declared.pop(col))
                if unit and unit not in ("s", "v", "a"):
                    declared.setdefault(canon, unit)
                notes.append(
                    f"{source}: column {col!r} read as {canon!r}"
                    + (f" in {_SHOWN.get(unit, unit)}" if unit else "")
                )
        unit = declared.get(canon)
        if canon not in out.columns:
            continue
        if unit is not None:
            unit = {"µs": "us", "sec": "s", "second": "s", "seconds": "s"}.get(unit, unit)
            if unit not in units:
                raise _unit_error(source, canon, unit)
            if units[unit] != 1.0:
                col = out[canon]
                if canon == "t":
                    conv = _scaled_time(pd.to_numeric(col, errors="coerce"), units[unit])
                else:
                    conv = _times(pd.to_numeric(col, errors="coerce").astype(float), units[unit])
                out = out.assign(**{canon: conv})
                shown = _SHOWN.get(unit, unit)
                if not any(n.endswith(f"read as {canon!r} in {shown}") for n in notes):
                    notes.append(f"{source}: {canon!r} in {shown} converted to {_si(canon)}")
        if canon == "t" and unit is None:
            t = _time_seconds(out["t"], source, notes, "t")
            if t is not out["t"]:
                out = out.assign(t=t)
    return out, notes


#: Units as people write them.
_SHOWN = {"v": "V", "mv": "mV", "kv": "kV", "a": "A", "ma": "mA"}


def _si(canon: str) -> str:
    return {"voltage": "V", "current": "A", "t": "s"}[canon]


def check_magnitudes(df: pd.DataFrame, source: str) -> None:
    """Raise :class:`LogError` when the battery's magnitudes only fit another unit.

    A median voltage above the plausible range's top (1000 V) that is plausible once
    divided by 1000 ("voltage in mV?"), below its bottom (5 V) and plausible once
    multiplied by 1000 ("voltage in kV?"), or a median |current| above
    :data:`MAX_CURRENT_A` ("current in mA?"). Single wild samples are not this: the
    preprocessing drops and counts those.

    Examples
    --------
    >>> check_magnitudes(pd.DataFrame({"voltage": [48000.0], "current": [5.0]}), "a.csv")
    Traceback (most recent call last):
    ...
    energy_planner.errors.LogError: log a.csv: voltage in mV? ...
    """
    lo, hi = VOLTAGE_RANGE
    problems: list[str] = []
    fixes: list[str] = []
    bad_cols: list[str] = []
    values: dict[str, float] = {}
    for canon in ("voltage", "current"):
        if canon not in df.columns:
            continue
        v = float_values(df[canon])
        v = v[np.isfinite(v)]
        if not v.size:
            continue
        med = float(np.median(np.abs(v)))
        values[canon] = med
        if canon == "voltage" and med > hi and lo <= med / 1000 <= hi:
            problems.append(f"voltage in mV? (median {med:.6g}, {med / 1000:.4g} V if mV)")
            fixes.append(
                "rename the column to 'voltage_mv' (or declare the Parquet "
                "field's unit 'mV'), or divide it by 1000"
            )
            bad_cols.append(canon)
        elif canon == "voltage" and 0 < med < lo and lo <= med * 1000 <= hi:
            problems.append(f"voltage in kV? (median {med:.6g}, {med * 1000:.4g} V if kV)")
            fixes.append("rename the column to 'voltage_kv', or multiply it by 1000")
            bad_cols.append(canon)
        elif canon == "current" and med > MAX_CURRENT_A:
            problems.append(
                f"current in mA? (median |current| {med:.6g}, {med / 1000:.4g} A if mA; "
                f"a legged robot draws far less than {MAX_CURRENT_A:g} A)"
            )
            fixes.append(
                "rename the column to 'current_ma' (or declare the Parquet "
                "field's unit 'mA'), or divide it by 1000"
            )
            bad_cols.append(canon)
    if problems:
        raise LogError(
            f"log {source}: {'; '.join(problems)}; expected volts and amperes: {'; '.join(fixes)}",
            path=source,
            column=bad_cols[0],
            value={c: values[c] for c in bad_cols},
            expected="voltage in V (5..1000), current in A",
            hint="; ".join(fixes),
        )
