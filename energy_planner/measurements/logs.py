"""Load canonical robot logs from CSV, Parquet, ROS bags or folders of them.

A log holds one run per file (the run id is the file stem when there is no ``run``
column) or several runs in one file with a ``run`` column. ROS 1 bags (``*.bag``) and
ROS 2 bags (folders with ``metadata.yaml``) are read by
:func:`energy_planner.measurements.rosbag.load_rosbag` with its default topics.
"""

from __future__ import annotations

import logging
import os
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogError, LogIOError
from energy_planner.measurements.conventions import (
    check_magnitudes,
    parquet_units,
    to_canonical_units,
)
from energy_planner.measurements.schema import (
    CANONICAL_COLUMNS,
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    VOLTAGE_RANGE,
    ValidationReport,
    check_columns,
    check_runs,
    check_time,
    float_values,
    validate_log,
)

log = logging.getLogger(__name__)

#: Samples "in motion" for the current-sign check: speed (m/s) or |yaw rate| (rad/s) at
#: least this.
MOTION_THRESHOLD = 0.05
#: The current is taken as ROS-signed when at least this share of the samples in motion
#: is negative (and there are at least ``SIGN_MIN_SAMPLES`` of them).
SIGN_NEGATIVE_SHARE = 0.8
SIGN_MIN_SAMPLES = 10
#: Values of ``load_logs(table_current=...)``.
TABLE_CURRENT = ("auto", "discharge_positive", "ros")

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
    current_negated_files : list of dict
        Tables whose current was negated (``table_current="auto"`` found it negative in
        most samples in motion, or ``"ros"``): ``path``, ``negative_share``,
        ``median_current_a`` (as read), ``n_motion``.
    current_kept_negative_files : list of dict
        Tables read with ``table_current="discharge_positive"`` whose current is yet
        negative in most samples in motion (kept as read), with the same keys.
    dropped : dict
        Samples dropped while reading (ROS bags only: clock samples outside the common
        time span of all topics or too far from a source message), reason -> count.
    notes : list of str
        Anything else worth knowing (resampling method, conversions).
    skipped : list of dict
        Tables found by scanning a folder that have none of the log columns (e.g. a
        ``runs.csv`` list of runs), and files a crashed logger left without samples (zero
        bytes, a header only, a Parquet file without its footer), each with the reason
        (``path``, ``reason``). A table named explicitly that is not a log, or one with
        some but not all required columns, is an error instead.
    """

    files: list[dict[str, Any]] = field(default_factory=list)
    n_rows: int = 0
    runs: list[str] = field(default_factory=list)
    columns: list[str] = field(default_factory=list)
    extra_columns: list[str] = field(default_factory=list)
    validation: ValidationReport | None = None
    current_sign_flipped: bool = False
    current_negated_files: list[dict[str, Any]] = field(default_factory=list)
    current_kept_negative_files: list[dict[str, Any]] = field(default_factory=list)
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
            "current_negated_files": [dict(f) for f in self.current_negated_files],
            "current_kept_negative_files": [dict(f) for f in self.current_kept_negative_files],
            "dropped": dict(self.dropped),
            "notes": list(self.notes),
            "skipped": [dict(k) for k in self.skipped],
        }

    def __str__(self) -> str:
        lines = [f"read {len(self.files)} file(s), {self.n_rows} samples, {len(self.runs)} run(s)"]
        for f in self.files:
            lines.append(f"  {f['format']:<8} {f['rows']:>8} rows  {f['path']}")
        for k in self.skipped:
            lines.append(f"  skipped  {k['path']}: {k['reason']}")
        if self.extra_columns:
            lines.append(f"extra columns kept: {', '.join(self.extra_columns)}")
        v = self.validation
        if v is not None:
            if v.n_nan:
                lines.append(
                    "non-finite values (dropped by preprocess): "
                    + ", ".join(f"{k}={n}" for k, n in v.n_nan.items())
                )
            if v.n_bad_voltage:
                lines.append(
                    f"voltage outside {v.voltage_range[0]:g}..{v.voltage_range[1]:g} V "
                    f"(dropped by preprocess): {v.n_bad_voltage}"
                )
            if v.n_bad_quaternion:
                lines.append(
                    f"IMU quaternions far from unit norm (dropped by preprocess): "
                    f"{v.n_bad_quaternion}"
                )
            if v.gaps:
                lines.append(f"{v.gap_text} (preprocessing splits the runs there)")
        if self.current_sign_flipped:
            lines.append(
                "battery current negated: ROS BatteryState is negative while "
                "discharging, canonical is positive"
            )
        for f in self.current_negated_files:
            lines.append(
                f"  negated in {f['path']} (negative in {f['negative_share']:.0%} of "
                f"{f['n_motion']} samples in motion)"
            )
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
            raise LogIOError(
                f"log path {str(p)!r} does not exist; expected a CSV/Parquet file, "
                "a ROS bag or a folder of them",
                path=p,
                expected="a CSV/Parquet file, a ROS bag or a folder of them",
            )
        if p.is_dir() and not is_ros2_bag(p):
            found = sorted(
                q
                for q in p.iterdir()
                if (q.is_file() and (q.suffix.lower() in TABLE_SUFFIXES or q.suffix == ".bag"))
                or is_ros2_bag(q)
            )
            if not found:
                raise LogIOError(
                    f"folder {str(p)!r} holds no robot log; expected *.csv, *.parquet, *.pq, "
                    "*.bag files or ROS 2 bag folders",
                    path=p,
                    expected="*.csv, *.parquet, *.pq, *.bag files or ROS 2 bag folders",
                )
            out.extend((q, True) for q in found)
        elif p.is_dir() or p.suffix == ".bag" or p.suffix.lower() in TABLE_SUFFIXES:
            out.append((p, False))
        else:
            raise LogIOError(
                f"cannot read {str(p)!r}: unknown suffix {p.suffix!r}; expected one of "
                f"{', '.join(sorted(TABLE_SUFFIXES))}, .bag or a ROS 2 bag folder",
                path=p,
                value=p.suffix,
                expected=", ".join(sorted(TABLE_SUFFIXES)),
            )
    return out


def _read_table(path: Path) -> tuple[pd.DataFrame | None, list[str], str | None]:
    """The table in ``path``, notes on it, and why it was skipped (None when read).

    What a logger that crashed leaves behind is skipped with the reason (a zero-byte
    file, a header without samples, a Parquet file without its footer); a CSV whose last
    line has no line end was cut short mid-write: that line is dropped, with a note.
    Anything else unreadable raises :class:`LogIOError`.
    """
    fmt = TABLE_SUFFIXES[path.suffix.lower()]
    crashed = "a logger that crashed, or was stopped, before writing it?"
    try:
        size = path.stat().st_size
    except OSError as err:
        raise LogIOError(
            f"cannot read {fmt} log {str(path)!r}: {err}", path=path, expected=f"a {fmt} table"
        ) from err
    if size == 0:
        return None, [], f"empty file (0 bytes): {crashed}"
    notes: list[str] = []
    try:
        if fmt == "csv":
            try:
                df = pd.read_csv(path)
            except pd.errors.EmptyDataError:
                return None, [], f"no header and no samples: {crashed}"
            with open(path, "rb") as f:
                f.seek(-1, os.SEEK_END)
                cut = f.read(1) not in (b"\n", b"\r")
            if cut and len(df):
                df = df.iloc[:-1]
                notes.append(
                    f"{path}: the last line has no line end (cut short: a logger that "
                    "crashed mid-write?); dropped"
                )
        else:
            df = pd.read_parquet(path)
    except (OSError, ValueError, pd.errors.ParserError) as err:
        if fmt == "parquet" and not _has_parquet_footer(path):
            return (
                None,
                [],
                (
                    f"truncated Parquet ({size} bytes, no footer: a logger that crashed before "
                    "closing the file?)"
                ),
            )
        raise LogIOError(
            f"cannot read {fmt} log {str(path)!r}: {err}", path=path, expected=f"a {fmt} table"
        ) from err
    if len(df) == 0:
        return None, notes, f"a header but no samples: {crashed}"
    return df, notes, None


def _has_parquet_footer(path: Path) -> bool:
    """True if ``path`` starts and ends with Parquet's magic bytes (a complete file)."""
    try:
        with open(path, "rb") as f:
            head = f.read(4)
            f.seek(-4, os.SEEK_END)
            return head == b"PAR1" and f.read(4) == b"PAR1"
    except OSError:
        return False


#: An extra column whose non-missing values parse as numbers at least this often is a
#: numeric channel: its other values are an error, not categories.
NUMERIC_SHARE = 0.5


def _check_extra_column(col: pd.Series, name: str, runs: pd.Series, source: str | None) -> None:
    """Raise :class:`LogError` for a mostly-numeric extra column holding some text.

    A channel such as ``payload_kg`` with one value typed ``"ten"`` would otherwise become
    a categorical column, and every later step would treat it as one.
    """
    arr = col.to_numpy(dtype=object)
    present = np.asarray(pd.notna(arr), dtype=bool)
    n = int(present.sum())
    if n == 0:
        return
    num = pd.to_numeric(pd.Series(arr, dtype=object), errors="coerce").to_numpy(dtype=float)
    text = present & np.isnan(num)
    n_text = int(text.sum())
    if n_text == 0 or (1.0 - n_text / n) < NUMERIC_SHARE:
        return
    rows = [int(r) for r in np.flatnonzero(text)]
    bad = [arr[r] for r in rows]
    run_ids = runs.to_numpy()
    bad_runs = sorted({str(run_ids[r]) for r in rows})
    shown = ", ".join(
        f"{v!r} at row {r} (run {run_ids[r]!s})" for v, r in zip(bad[:5], rows[:5], strict=True)
    )
    more = f" and {n_text - 5} more" if n_text > 5 else ""
    raise LogError(
        f"log{(' ' + source) if source else ''}: extra column {name!r} is numeric in "
        f"{n - n_text} of {n} rows but not in {n_text}: {shown}{more}; "
        "expected a number in every row (leave a cell empty for a missing value); a "
        "categorical channel must be text in every row",
        path=source,
        column=name,
        value=bad[0],
        values=bad[:20],
        rows=rows[:20],
        runs=bad_runs,
        expected="a number (or an empty cell)",
    )


def canonicalize(df: pd.DataFrame, source: str | None = None) -> pd.DataFrame:
    """Cast to canonical dtypes and order: float64 numerics, ``run`` str, sorted by run, t.

    Canonical columns that are not numeric raise :class:`LogError`. Extra columns are
    kept: numeric ones as they are, text ones as pandas ``category``. A text column whose
    values are numbers in at least half of the rows (:data:`NUMERIC_SHARE`) raises
    :class:`LogError` naming the column and the other values, their rows and runs.
    """
    return _canonical(df, source, categories=True)


def _canonical(df: pd.DataFrame, source: str | None, categories: bool) -> pd.DataFrame:
    """:func:`canonicalize`; with ``categories`` False, text extras stay text.

    :func:`load_logs` makes them categories once, after joining the files (a category per
    file cost a third of loading a campaign, and the join undid them).
    """
    check_runs(df, source)
    # columns gathered, then one frame built: assigning ~20 columns one by one into a
    # frame cost ~1.5 ms each (pandas' block manager), 2/3 of loading a campaign's files
    names = df.columns.tolist()  # plain str: membership and lookups without the Index
    present = set(names)
    run_in = df["run"]
    out: dict[str, Any] = {"run": run_in.astype(str)}
    # a table already canonical (a logger's file: float64, in order) is kept as it is
    # instead of being rebuilt column by column
    same = out["run"].dtype == run_in.dtype and len(present) == len(names)
    for c in REQUIRED_COLUMNS + OPTIONAL_COLUMNS:
        if c not in present:
            continue
        col = df[c]
        if not (pd.api.types.is_numeric_dtype(col) or col.isna().all()):
            num = pd.to_numeric(col, errors="coerce")
            bad = num.isna() & col.notna()
            if bad.any():
                row = int(np.flatnonzero(bad.to_numpy())[0])
                raise LogError(
                    f"log{(' ' + source) if source else ''}: column {c!r} is not numeric at "
                    f"row {row} (value {col.iloc[row]!r}); expected a number in SI units",
                    path=source,
                    column=c,
                    row=row,
                    value=col.iloc[row],
                    run=str(df["run"].iloc[row]),
                    expected="a number in SI units",
                )
            col = num
            same = False
        if col.dtype != np.float64:
            col = col.astype("float64")
            same = False
        out[c] = col
    for c in names:
        if c in CANONICAL_COLUMNS:
            continue
        col = df[c]
        if isinstance(col, pd.DataFrame):  # a repeated column name
            raise LogError(
                f"log{(' ' + source) if source else ''}: column {c!r} appears "
                f"{col.shape[1]} times; expected each column once",
                path=source,
                column=str(c),
                expected="each column once",
            )
        if pd.api.types.is_bool_dtype(col):
            out[c] = col
        elif pd.api.types.is_numeric_dtype(col):
            out[c] = col
        elif isinstance(col.dtype, pd.CategoricalDtype):
            _check_extra_column(col.astype(object), str(c), df["run"], source)
            out[c] = col
        else:
            _check_extra_column(col, str(c), df["run"], source)
            if not (isinstance(col.dtype, pd.StringDtype) and col.dtype.na_value is np.nan):
                col = col.astype("string").astype(object)  # each value as its text, in str
                same = False
            if categories:
                col = col.astype("category")
                same = False
            out[c] = col
    if same and list(out) == names:
        frame = df
    else:
        frame = pd.DataFrame(out, index=df.index, copy=False)
    run = out["run"].to_numpy(dtype=object)
    t = frame["t"].to_numpy(dtype=float) if "t" in frame.columns else None
    if t is not None and len(run) > 1:
        later = run[1:] > run[:-1]
        if np.all(later | ((run[1:] == run[:-1]) & (t[1:] >= t[:-1]))):
            return frame.reset_index(drop=True)  # in order already (a logger's file)
    return frame.sort_values(["run", "t"], kind="stable").reset_index(drop=True)


def _check_extra_types(frames: list[pd.DataFrame], paths: list[str]) -> None:
    """Raise :class:`LogError` if an extra column is numeric in one file and text in another."""
    kinds: dict[str, dict[str, list[str]]] = {}
    for df, p in zip(frames, paths, strict=True):
        for c in df.columns:
            if c in CANONICAL_COLUMNS:
                continue
            k = "numeric" if pd.api.types.is_numeric_dtype(df[c]) else "text"
            kinds.setdefault(c, {}).setdefault(k, []).append(p)
    for c, by in kinds.items():
        if len(by) > 1:
            raise LogError(
                f"extra column {c!r} is numeric in {', '.join(by['numeric'][:3])} but text in "
                f"{', '.join(by['text'][:3])}; expected one type in every file (a number "
                "for a numeric channel, text for a categorical one)",
                column=c,
                path=by["text"][0],
                expected="the same type in every file",
                value={k: v[:10] for k, v in by.items()},
            )


def current_sign(df: pd.DataFrame) -> dict[str, Any]:
    """How negative the battery current is while the robot moves.

    Parameters
    ----------
    df : pandas.DataFrame
        Canonical columns ``vx, vy, wz, current`` (numeric).

    Returns
    -------
    dict
        ``n_motion`` (samples with speed or |yaw rate| >= :data:`MOTION_THRESHOLD` and a
        finite current), ``negative_share`` (share of them with current < 0),
        ``median_current_a``, and ``ros_sign``: True when there are at least
        :data:`SIGN_MIN_SAMPLES` such samples and at least :data:`SIGN_NEGATIVE_SHARE` of
        them are negative: a walking robot draws current, so the log uses the ROS
        ``BatteryState`` sign (negative while discharging), not the canonical one.

    Examples
    --------
    >>> df = pd.DataFrame({"vx": 0.3, "vy": 0.0, "wz": 0.0, "current": [-5.0] * 12})
    >>> current_sign(df)["ros_sign"]
    True
    """
    v = np.hypot(float_values(df["vx"]), float_values(df["vy"]))
    w = np.abs(float_values(df["wz"]))
    cur = float_values(df["current"])
    with np.errstate(invalid="ignore"):
        moving = ((v >= MOTION_THRESHOLD) | (w >= MOTION_THRESHOLD)) & np.isfinite(cur)
    c = cur[moving]
    share = float(np.mean(c < 0)) if c.size else 0.0
    return {
        "n_motion": int(c.size),
        "negative_share": share,
        "median_current_a": float(np.median(c)) if c.size else None,
        "ros_sign": bool(c.size >= SIGN_MIN_SAMPLES and share >= SIGN_NEGATIVE_SHARE),
    }


def _apply_current_sign(df: pd.DataFrame, path: Path, mode: str, rep: LoadReport) -> pd.DataFrame:
    """Negate a table's current per ``table_current`` (see :func:`load_logs`).

    Records the file in ``rep`` (negated, or kept although mostly negative); the one
    warning per load for all such files is :func:`_warn_current_sign`'s.
    """
    sign = current_sign(df)
    entry = {
        "path": str(path),
        "negative_share": round(sign["negative_share"], 4),
        "median_current_a": sign["median_current_a"],
        "n_motion": sign["n_motion"],
    }
    if mode == "ros" or (mode == "auto" and sign["ros_sign"]):
        df = df.assign(current=-df["current"])
        rep.current_sign_flipped = True
        rep.current_negated_files.append(entry)
    elif sign["ros_sign"]:  # discharge_positive, yet mostly negative: say so
        rep.current_kept_negative_files.append(entry)
    return df


def _warn_skipped(rep: LoadReport) -> None:
    """One warning naming the files skipped because a crashed logger left them unreadable."""
    crashed = [k for k in rep.skipped if "not a robot log" not in k["reason"]]
    if not crashed:
        return
    from energy_planner.errors import EnergyPlannerWarning

    shown = "; ".join(f"{k['path']}: {k['reason']}" for k in crashed[:5])
    more = f"; and {len(crashed) - 5} more" if len(crashed) > 5 else ""
    msg = f"skipped {len(crashed)} log file(s) that hold no samples: {shown}{more}"
    warnings.warn(EnergyPlannerWarning(msg, paths=[k["path"] for k in crashed]), stacklevel=4)
    rep.notes.append(msg)


def _files_text(entries: list[dict[str, Any]], limit: int = 3) -> str:
    """``a.csv: negative in 100% of 113 samples in motion, median -3.66 A; ...``."""
    shown = "; ".join(
        f"{e['path']}: negative in {e['negative_share']:.0%} of {e['n_motion']} samples in "
        f"motion, "
        f"median {e['median_current_a']:.3g} A"
        for e in entries[:limit]
    )
    return shown + (f"; and {len(entries) - limit} more" if len(entries) > limit else "")


def _warn_current_sign(rep: LoadReport, mode: str) -> None:
    """One warning for every table whose current sign was guessed or contradicts the mode."""
    from energy_planner.errors import EnergyPlannerWarning

    flipped, kept = rep.current_negated_files, rep.current_kept_negative_files
    if flipped and mode == "auto":
        n = len(flipped)
        msg = (
            f"the battery current is mostly negative while the robot moves in {n} "
            f"log{'s' if n > 1 else ''} ({_files_text(flipped)}): read as the ROS "
            "BatteryState sign (negative while discharging) and negated to the canonical "
            "sign (positive while discharging)."
        )
        warnings.warn(
            EnergyPlannerWarning(
                msg,
                api_hint="Pass table_current='discharge_positive' to keep it as it is.",
                paths=[e["path"] for e in flipped],
            ),
            stacklevel=4,
        )
        rep.notes.append(msg)
    if kept:
        n = len(kept)
        msg = (
            f"the battery current is mostly negative while the robot moves in {n} "
            f"log{'s' if n > 1 else ''} ({_files_text(kept)}) although "
            "table_current='discharge_positive' says positive while discharging; "
            "preprocessing will drop those samples (negative power)."
        )
        warnings.warn(
            EnergyPlannerWarning(
                msg,
                api_hint="If the logger uses the ROS BatteryState sign, load with "
                "table_current='ros' or 'auto'.",
                paths=[e["path"] for e in kept],
            ),
            stacklevel=4,
        )
        rep.notes.append(msg)


def load_logs(
    paths,
    *,
    report: bool = False,
    voltage_range: tuple[float, float] = VOLTAGE_RANGE,
    max_gap: float | None = None,
    table_current: str = "auto",
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
    table_current : {"auto", "discharge_positive", "ros"}
        Sign of the current in CSV/Parquet tables. ``"auto"`` (default): a table whose
        current is negative in at least 80 % of the samples in motion
        (:func:`current_sign`) uses the ROS ``BatteryState`` sign and is negated, with a
        ``UserWarning`` naming the file (listed in ``LoadReport.current_negated_files``).
        ``"discharge_positive"``: canonical, taken as it is (a mostly negative current
        still warns). ``"ros"``: every table is negated. Bags have their own
        ``battery_current`` option (``**bag_options``).
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

    Notes
    -----
    A read of tables (no ROS bag) that gave no warning is kept in the project's cache
    folder (:mod:`energy_planner.measurements.stored`), keyed by each file's path, size,
    times and inode and the options: the same files read again come back from it (the
    same samples and report). ``ENERGY_PLANNER_LOG_CACHE=0`` switches it off.

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
    if table_current not in TABLE_CURRENT:
        raise LogError(
            f"table_current={table_current!r} is not valid; expected one of "
            f"{', '.join(map(repr, TABLE_CURRENT))}",
            value=table_current,
            param="table_current",
            expected=" or ".join(TABLE_CURRENT),
        )
    files = _expand(paths)
    from energy_planner.measurements import stored

    key = _load_key(files, voltage_range, max_gap, table_current, bag_options)
    hit = stored.read("load", key)
    if (
        isinstance(hit, tuple)
        and len(hit) == 2
        and isinstance(hit[0], pd.DataFrame)
        and isinstance(hit[1], LoadReport)
    ):
        samples, rep = hit
        for k in rep.skipped:  # the log lines of the read, but the warnings: none was kept
            if "not a robot log" in k["reason"]:
                log.info("skipped %s: it has none of the log columns", k["path"])
            else:
                log.info("skipped %s: %s", k["path"], k["reason"])
        log.info(
            "loaded %d samples in %d run(s) from %d file(s)",
            len(samples),
            len(rep.runs),
            len(rep.files),
        )
        return (samples, rep) if report else samples
    with stored.warnings_shown() as caught:
        samples, rep = _read_files(files, voltage_range, max_gap, table_current, bag_options)
    if not caught and not _warns(rep, table_current):
        again = _load_key(files, voltage_range, max_gap, table_current, bag_options)
        if again == key and _settled(files):  # not changed while read, nor just written
            stored.keep("load", key, (samples, rep))
    return (samples, rep) if report else samples


#: A file modified less than this long (s) before its read ended is not kept: a later
#: write within the same tick of the file system's clock (1-10 ms) could leave the same
#: size and times.
SETTLED_S = 0.2


def _settled(files: list[tuple[Path, bool]]) -> bool:
    """True when every file was last modified at least :data:`SETTLED_S` ago."""
    import time

    before = time.time_ns() - int(SETTLED_S * 1e9)
    try:
        return all(os.stat(p).st_mtime_ns < before for p, _ in files)
    except OSError:
        return False


def _load_key(
    files: list[tuple[Path, bool]],
    voltage_range: tuple[float, float],
    max_gap: float | None,
    table_current: str,
    bag_options: dict[str, Any],
) -> str | None:
    """The cache key of :func:`load_logs` of ``files`` (None: not kept, e.g. a ROS bag).

    Each file's path as given and resolved, its size, modification and change times,
    inode and device; the options (:mod:`energy_planner.measurements.stored` adds the
    code, the versions and the environment).
    """
    from energy_planner.measurements import stored

    if not stored.enabled():
        return None
    parts = [repr((tuple(voltage_range), max_gap, table_current, sorted(bag_options.items())))]
    for path, scanned in files:
        if path.suffix.lower() not in TABLE_SUFFIXES:
            return None
        try:
            real = path.resolve(strict=True)
            st = os.stat(real)
        except (OSError, RuntimeError):
            return None
        parts.append(
            f"{path}\0{scanned}\0{real}\0{st.st_size}:{st.st_mtime_ns}:{st.st_ctime_ns}:"
            f"{st.st_ino}:{st.st_dev}"
        )
    modules = (
        "energy_planner.measurements.logs",
        "energy_planner.measurements.conventions",
        "energy_planner.measurements.schema",
    )
    return stored.digest("load_logs", parts, modules)


def _warns(rep: LoadReport, table_current: str) -> bool:
    """True when reading these files warns (files a crash left empty, a current sign)."""
    crashed = any("not a robot log" not in k["reason"] for k in rep.skipped)
    flipped = bool(rep.current_negated_files) and table_current == "auto"
    return crashed or flipped or bool(rep.current_kept_negative_files)


def _read_files(
    files: list[tuple[Path, bool]],
    voltage_range: tuple[float, float],
    max_gap: float | None,
    table_current: str,
    bag_options: dict[str, Any],
) -> tuple[pd.DataFrame, LoadReport]:
    """:func:`load_logs` of the expanded ``files``: the samples and the report."""
    rep = LoadReport()
    frames: list[pd.DataFrame] = []
    owner: dict[str, str] = {}
    for path, scanned in files:
        if path.suffix.lower() in TABLE_SUFFIXES:
            fmt = TABLE_SUFFIXES[path.suffix.lower()]
            df, notes, skip = _read_table(path)
            rep.notes.extend(notes)
            if df is None:
                rep.skipped.append({"path": str(path), "reason": str(skip)})
                log.info("skipped %s: %s", path, skip)
                continue
            declared = parquet_units(path) if fmt == "parquet" else {}
            df, notes = to_canonical_units(df, str(path), declared)
            rep.notes.extend(notes)
            if scanned and not set(REQUIRED_COLUMNS) & set(df.columns):
                # a table in the folder that is not a log at all (e.g. a run list)
                rep.skipped.append(
                    {
                        "path": str(path),
                        "reason": "no log column (t, qw, ..., current): not a robot log",
                    }
                )
                log.info("skipped %s: it has none of the log columns", path)
                continue
            check_columns(df.columns, str(path), need_run=False)
            check_magnitudes(df, str(path))
            if "run" not in df.columns:
                df.insert(0, "run", path.stem)
            else:
                check_runs(df, str(path))
                df["run"] = df["run"].astype(str)
            check_time(df, str(path))
            df = _canonical(df, str(path), categories=False)  # categories once, below
            df = _apply_current_sign(df, path, table_current, rep)
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
                raise LogError(
                    f"run id {r!r} found in both {owner[r]!r} and {str(path)!r}; "
                    "run ids must be unique (rename a file or its 'run' values)",
                    path=path,
                    run=str(r),
                    value=[owner[r], str(path)],
                    expected="each run id in one file",
                )
            owner[r] = str(path)
        rep.files.append({"path": str(path), "format": fmt, "rows": len(df), "runs": runs})
        frames.append(df)
    if not frames:
        why = "; ".join(f"{k['path']}: {k['reason']}" for k in rep.skipped[:10])
        raise LogIOError(
            f"no robot log among {', '.join(str(p) for p, _ in files)}"
            + (f" (skipped {len(rep.skipped)}: {why})" if why else "")
            + "; expected tables with the columns "
            + ", ".join(REQUIRED_COLUMNS),
            path=str(files[0][0]),
            value=[k["path"] for k in rep.skipped],
            expected="tables with the columns " + ", ".join(REQUIRED_COLUMNS),
        )
    if rep.skipped:
        _warn_skipped(rep)
    _warn_current_sign(rep, table_current)
    _check_extra_types(frames, [f["path"] for f in rep.files])
    samples = pd.concat(frames, ignore_index=True) if len(frames) > 1 else frames[0]
    n_files = len(frames)
    del frames
    _release_arrow_memory()
    for c in samples.columns:
        col = samples[c]
        if c not in CANONICAL_COLUMNS and not (
            pd.api.types.is_numeric_dtype(col) or isinstance(col.dtype, pd.CategoricalDtype)
        ):
            samples[c] = col.astype("category")
    samples = samples.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    rep.validation = validate_log(samples, voltage_range=voltage_range, max_gap=max_gap)
    rep.n_rows = len(samples)
    rep.runs = rep.validation.runs
    rep.columns = list(samples.columns)
    rep.extra_columns = [c for c in samples.columns if c not in CANONICAL_COLUMNS]
    log.info("loaded %d samples in %d run(s) from %d file(s)", len(samples), len(rep.runs), n_files)
    return samples, rep


#: Files in a log folder that are not logs (the simulator's run table).
METADATA_FILES = frozenset({"runs.csv"})


def log_files(paths: Sequence[str | Path]) -> list[Path]:
    """Expand folders to their log files, leaving out metadata such as ``runs.csv``.

    ROS 2 bag folders (with ``metadata.yaml``) and files are passed through; other
    folders become the files and bag folders they hold, as ``load_logs`` would read
    them, minus :data:`METADATA_FILES`.
    """
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir() and not (p / "metadata.yaml").is_file():
            found = sorted(
                q
                for q in p.iterdir()
                if q.name not in METADATA_FILES
                and (
                    (q.is_file() and q.suffix.lower() in (".csv", ".parquet", ".pq", ".bag"))
                    or (q / "metadata.yaml").is_file()
                )
            )
            out.extend(found or [p])  # an empty folder: let load_logs name the problem
        else:
            out.append(p)
    return out


def _release_arrow_memory() -> None:
    """Give back to the system what pyarrow's allocator keeps after reading Parquet.

    Its pool holds on to freed pages: after a full campaign (572 files) 70 MB of the
    process's resident memory, which ``discover``'s peak counts (issue 21).
    """
    import sys

    pa = sys.modules.get("pyarrow")
    if pa is not None:
        pa.default_memory_pool().release_unused()
    # the C heap keeps the freed pages of the 572 parsed tables too: glibc gives them back
    # on malloc_trim (a full campaign: 410 -> 300 MB resident after loading; issue 21)
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL("libc.so.6").malloc_trim(0)
        except (OSError, AttributeError):  # not glibc (musl): nothing to give back this way
            pass
