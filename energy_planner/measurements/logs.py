"""Load canonical robot logs from CSV, Parquet, ROS bags or folders of them.

A log holds one run per file (the run id is the file stem when there is no ``run``
column) or several runs in one file with a ``run`` column. ROS 1 bags (``*.bag``) and
ROS 2 bags (folders with ``metadata.yaml``) are read by
:func:`energy_planner.measurements.rosbag.load_rosbag` with its default topics.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogError, LogIOError
from energy_planner.measurements.schema import (
    CANONICAL_COLUMNS,
    MAX_GAP_S,
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    VOLTAGE_RANGE,
    ValidationReport,
    check_columns,
    check_time,
    validate_log,
)

log = logging.getLogger(__name__)

TABLE_SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


@dataclass
class LoadReport:
    """What :func:`load_logs` read.

    Attributes
    ----------
    files : list of dict
        One entry per file or bag: ``path``, ``format`` (csv, parquet, rosbag1, rosbag2),
        ``rows``, ``runs``.
    n_rows : int
        Rows in the returned table.
    runs : list of str
        Run identifiers, sorted.
    columns, extra_columns : list of str
        All columns returned; the non-canonical ones among them (kept as they are).
    validation : ValidationReport
        NaN, absurd-voltage and gap counts (nothing dropped yet: preprocessing does).
    current_sign_flipped : bool
        True when a ROS ``BatteryState`` current (negative while discharging) was negated
        to the canonical sign (positive while discharging).
    dropped : dict
        Samples dropped while reading (ROS bags only: clock samples outside the common
        time span of all topics or too far from a source message), reason -> count.
    notes : list of str
        Anything else worth knowing (resampling method, conversions).
    skipped : list of dict
        Tables found by scanning a folder that have none of the log columns (e.g. a
        ``runs.csv`` list of runs), with the reason. A table named explicitly, or one
        with some but not all required columns, is an error instead.
    """

    files: list[dict[str, Any]] = field(default_factory=list)
    n_rows: int = 0
    runs: list[str] = field(default_factory=list)
    columns: list[str] = field(default_factory=list)
    extra_columns: list[str] = field(default_factory=list)
    validation: ValidationReport | None = None
    current_sign_flipped: bool = False
    dropped: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    skipped: list[dict[str, str]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (for ``--json``)."""
        return {
            "files": [dict(f) for f in self.files],
            "n_rows": self.n_rows,
            "runs": list(self.runs),
            "columns": list(self.columns),
            "extra_columns": list(self.extra_columns),
            "validation": self.validation.to_dict() if self.validation else None,
            "current_sign_flipped": self.current_sign_flipped,
            "dropped": dict(self.dropped),
            "notes": list(self.notes),
            "skipped": [dict(k) for k in self.skipped],
        }

    def __str__(self) -> str:
        lines = [f"read {len(self.files)} file(s), {self.n_rows} samples, "
                 f"{len(self.runs)} run(s)"]
        for f in self.files:
            lines.append(f"  {f['format']:<8} {f['rows']:>8} rows  {f['path']}")
        for k in self.skipped:
            lines.append(f"  skipped  {k['path']}: {k['reason']}")
        if self.extra_columns:
            lines.append(f"extra columns kept: {', '.join(self.extra_columns)}")
        v = self.validation
        if v is not None:
            if v.n_nan:
                lines.append("non-finite values (dropped by preprocess): " + ", ".join(
                    f"{k}={n}" for k, n in v.n_nan.items()))
            if v.n_bad_voltage:
                lines.append(f"voltage outside {v.voltage_range[0]:g}..{v.voltage_range[1]:g} V "
                             f"(dropped by preprocess): {v.n_bad_voltage}")
            if v.n_bad_quaternion:
                lines.append(f"IMU quaternions far from unit norm (dropped by preprocess): "
                             f"{v.n_bad_quaternion}")
            if v.gaps:
                lines.append(f"time gaps > {v.max_gap:g} s (runs split there): {len(v.gaps)}")
        if self.current_sign_flipped:
            lines.append("battery current negated: ROS BatteryState is negative while "
                         "discharging, canonical is positive")
        for k, n in self.dropped.items():
            lines.append(f"dropped while reading: {n} ({k})")
        lines.extend(self.notes)
        return "\n".join(lines)


def is_ros2_bag(path: Path) -> bool:
    """True if ``path`` is a ROS 2 bag folder (has ``metadata.yaml``)."""
    return path.is_dir() and (path / "metadata.yaml").is_file()


def _expand(paths: str | Path | Iterable[str | Path]) -> list[tuple[Path, bool]]:
    """Files to read, each with True when it was found by scanning a folder."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    out: list[tuple[Path, bool]] = []
    for p in map(Path, paths):
        if not p.exists():
            raise LogIOError(f"log path {str(p)!r} does not exist; expected a CSV/Parquet file, "
                             "a ROS bag or a folder of them")
        if p.is_dir() and not is_ros2_bag(p):
            found = sorted(
                q for q in p.iterdir()
                if (q.is_file() and (q.suffix.lower() in TABLE_SUFFIXES or q.suffix == ".bag"))
                or is_ros2_bag(q)
            )
            if not found:
                raise LogIOError(
                    f"folder {str(p)!r} holds no robot log; expected *.csv, *.parquet, *.pq, "
                    "*.bag files or ROS 2 bag folders")
            out.extend((q, True) for q in found)
        elif p.is_dir() or p.suffix == ".bag" or p.suffix.lower() in TABLE_SUFFIXES:
            out.append((p, False))
        else:
            raise LogIOError(
                f"cannot read {str(p)!r}: unknown suffix {p.suffix!r}; expected one of "
                f"{', '.join(sorted(TABLE_SUFFIXES))}, .bag or a ROS 2 bag folder")
    return out


def _read_table(path: Path) -> pd.DataFrame:
    fmt = TABLE_SUFFIXES[path.suffix.lower()]
    try:
        if fmt == "csv":
            return pd.read_csv(path)
        return pd.read_parquet(path)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        raise LogIOError(f"cannot read {fmt} log {str(path)!r}: {err}") from err


def canonicalize(df: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    """Cast to canonical dtypes and order: float64 numerics, ``run`` str, sorted by run, t.

    Canonical columns that are not numeric raise :class:`LogError`. Extra columns are
    kept: numeric ones as they are, text ones as pandas ``category``.
    """
    out = pd.DataFrame(index=df.index)
    out["run"] = df["run"].astype(str)
    for c in REQUIRED_COLUMNS + OPTIONAL_COLUMNS:
        if c not in df.columns:
            continue
        col = df[c]
        if not (pd.api.types.is_numeric_dtype(col) or col.isna().all()):
            num = pd.to_numeric(col, errors="coerce")
            bad = num.isna() & col.notna()
            if bad.any():
                row = int(np.flatnonzero(bad.to_numpy())[0])
                raise LogError(
                    f"log{(' ' + source) if source else ''}: column {c!r} is not numeric at "
                    f"row {row} (value {col.iloc[row]!r}); expected a number in SI units")
            col = num
        out[c] = col.astype("float64")
    for c in df.columns:
        if c in CANONICAL_COLUMNS:
            continue
        col = df[c]
        if pd.api.types.is_numeric_dtype(col) or isinstance(col.dtype, pd.CategoricalDtype):
            out[c] = col
        else:
            out[c] = col.astype("string").astype(object).astype("category")
    out = out.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    return out


def load_logs(
    paths,
    *,
    report: bool = False,
    voltage_range: tuple[float, float] = VOLTAGE_RANGE,
    max_gap: float = MAX_GAP_S,
    **bag_options: Any,
) -> pd.DataFrame | tuple[pd.DataFrame, LoadReport]:
    """Load robot logs into the canonical sample table.

    Parameters
    ----------
    paths : path or iterable of paths
        Files (``.csv``, ``.parquet``/``.pq``, ``.bag``), ROS 2 bag folders, or folders
        holding any of these (not recursive beyond one level). One file per run (run id
        = file stem) unless the file has a ``run`` column.
    report : bool
        Also return a :class:`LoadReport`.
    voltage_range, max_gap
        Thresholds for the validation counts (see
        :func:`~energy_planner.measurements.schema.validate_log`).
    **bag_options
        Passed to :func:`~energy_planner.measurements.rosbag.load_rosbag` for bags
        (topics, clock, ...).

    Returns
    -------
    samples : pandas.DataFrame
        Canonical table: ``run`` (str), float64 canonical columns, extra columns kept
        (numeric as they are, text as ``category``), sorted by run then t.
    report : LoadReport
        Only when ``report=True``.

    Raises
    ------
    LogIOError
        A path does not exist or cannot be read.
    LogError
        Missing required column, non-numeric value, time not increasing within a run,
        a run id found in two files.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> pd.DataFrame({"t": [0.0, 0.1], "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
    ...     "vx": 0.3, "vy": 0.0, "wz": 0.0, "voltage": 50.0, "current": 5,
    ...     "surface": "grass"}).to_csv(os.path.join(d, "ramp1.csv"), index=False)
    >>> s = load_logs(d)
    >>> list(s["run"]), s["current"].dtype.name, s["surface"].dtype.name
    (['ramp1', 'ramp1'], 'float64', 'category')
    """
    files = _expand(paths)
    rep = LoadReport()
    frames: list[pd.DataFrame] = []
    owner: dict[str, str] = {}
    for path, scanned in files:
        if path.suffix.lower() in TABLE_SUFFIXES:
            df = _read_table(path)
            fmt = TABLE_SUFFIXES[path.suffix.lower()]
            if scanned and not set(REQUIRED_COLUMNS) & set(df.columns):
                # a table in the folder that is not a log at all (e.g. a run list)
                rep.skipped.append({"path": str(path), "reason": "no log column (t, qw, ..., "
                                    "current): not a robot log"})
                log.info("skipped %s: it has none of the log columns", path)
                continue
            check_columns(df.columns, str(path), need_run=False)
            if "run" not in df.columns:
                df.insert(0, "run", path.stem)
            else:
                df["run"] = df["run"].astype(str)
            check_time(df, str(path))
            df = canonicalize(df, str(path))
        else:
            from energy_planner.measurements.rosbag import load_rosbag

            df, brep = load_rosbag(path, report=True, **bag_options)
            fmt = brep.files[0]["format"]
            rep.current_sign_flipped |= brep.current_sign_flipped
            for k, n in brep.dropped.items():
                rep.dropped[k] = rep.dropped.get(k, 0) + n
            rep.notes.extend(brep.notes)
        runs = sorted(df["run"].unique())
        for r in runs:
            if r in owner:
                raise LogError(f"run id {r!r} found in both {owner[r]!r} and {str(path)!r}; "
                               "run ids must be unique (rename a file or its 'run' values)")
            owner[r] = str(path)
        rep.files.append({"path": str(path), "format": fmt, "rows": len(df), "runs": runs})
        frames.append(df)
    if not frames:
        raise LogIOError(f"no robot log among {', '.join(str(p) for p, _ in files)}; "
                         "expected tables with the columns " + ", ".join(REQUIRED_COLUMNS))
    samples = pd.concat(frames, ignore_index=True) if len(frames) > 1 else frames[0]
    for c in samples.columns:
        col = samples[c]
        if c not in CANONICAL_COLUMNS and not (pd.api.types.is_numeric_dtype(col)
                                               or isinstance(col.dtype, pd.CategoricalDtype)):
            samples[c] = col.astype("category")
    samples = samples.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    rep.validation = validate_log(samples, voltage_range=voltage_range, max_gap=max_gap)
    rep.n_rows = len(samples)
    rep.runs = rep.validation.runs
    rep.columns = list(samples.columns)
    rep.extra_columns = [c for c in samples.columns if c not in CANONICAL_COLUMNS]
    log.info("loaded %d samples in %d run(s) from %d file(s)", len(samples), len(rep.runs),
             len(frames))
    return (samples, rep) if report else samples
