"""Read and write robot logs as ROS 1 / ROS 2 bags with the ``rosbags`` package.

No ROS installation is needed. Three standard topics make a log:

* ``sensor_msgs/Imu`` (default ``/imu/data``): orientation ``qw, qx, qy, qz``;
* ``nav_msgs/Odometry`` (default ``/odom``): body twist ``vx, vy, wz`` and pose
  ``x, y, yaw``;
* ``sensor_msgs/BatteryState`` (default ``/battery_state``): ``voltage`` and ``current``.

Extra channels travel as ``std_msgs/Float64`` (numeric) or ``std_msgs/String``
(categorical) on topics ``/energy_planner/<column>``.

Resampling (:func:`load_rosbag`): every stream is brought onto one clock, the IMU's
(default) or the odometry's. Clock samples outside the time span common to all streams
are dropped (counted), as are clock samples whose bracketing messages in another
stream are more than ``max_interp_gap`` seconds apart (a stream drop-out is never
bridged). Twist, pose position, voltage, current and numeric extras are interpolated
linearly in time; yaw is unwrapped, interpolated, then wrapped; the IMU quaternion
(when the clock is the odometry) is interpolated by spherical linear interpolation
(``scipy.spatial.transform.Slerp``); text extras are held from the previous message.
Extras are missing (NaN) at clock times before their first (numeric: or after their
last) message.
At clock instants that coincide with source messages the values are exact.

Sign of the current: ROS ``BatteryState.current`` is *negative* while discharging; the
canonical log is positive while discharging, so the loader negates it (logged at INFO
and recorded as ``LoadReport.current_sign_flipped``). ``battery_current="discharge_positive"``
reads drivers that do not follow the ROS convention as they are.
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from energy_planner.angles import wrap
from energy_planner.errors import LogError, LogIOError
from energy_planner.io.bag import (
    decoder,
    open_reader,
    open_writer,
    quaternion_yaw,
    ros_time,
    topics_listing,
    type_definition,
    typestore,
)
from energy_planner.measurements.logs import LoadReport, canonicalize
from energy_planner.measurements.schema import CANONICAL_COLUMNS, REQUIRED_COLUMNS

log = logging.getLogger(__name__)

#: Default topics, role -> topic name.
DEFAULT_TOPICS: dict[str, str] = {
    "imu": "/imu/data",
    "odom": "/odom",
    "battery": "/battery_state",
}
#: Namespace of the extra-channel topics written by :func:`write_rosbag`.
EXTRA_NAMESPACE = "/energy_planner/"

MSGTYPES = {
    "imu": "sensor_msgs/msg/Imu",
    "odom": "nav_msgs/msg/Odometry",
    "battery": "sensor_msgs/msg/BatteryState",
}
#: A median current below minus this (A) after conversion triggers the sign warning.
SIGN_WARNING_A = 0.5
_FLOAT64 = "std_msgs/msg/Float64"
_STRING = "std_msgs/msg/String"


def _stamp_ns(msg, bag_ns: int, stamp: str) -> int:
    if stamp == "bag":
        return int(bag_ns)
    s = msg.header.stamp
    return int(s.sec) * 1_000_000_000 + int(s.nanosec)


class _NonStandardTypes(Exception):
    """A topic's type definition differs from the standard one: use AnyReader."""


def _read_streams(
    path: Path,
    topics: Mapping[str, str],
    stamp: str,
    extra_topics: Mapping[str, str] | None,
    fast: bool = True,
):
    reader, is2 = open_reader(path, fast, LogIOError)
    try:
        reader.open()
    except Exception as err:  # rosbags raises its own error classes
        raise LogIOError(f"cannot open ROS bag {str(path)!r}: {err}") from err
    try:
        by_topic = {c.topic: c for c in reader.connections}
        for role, topic in topics.items():
            if topic not in by_topic:
                raise LogError(
                    f"ROS bag {str(path)!r} has no topic {topic!r} (for {MSGTYPES[role]}); "
                    f"topics in the bag: {topics_listing(reader)}"
                )
            if by_topic[topic].msgtype != MSGTYPES[role]:
                raise LogError(
                    f"ROS bag {str(path)!r}: topic {topic!r} carries "
                    f"{by_topic[topic].msgtype}, expected {MSGTYPES[role]}; topics in the "
                    f"bag: {topics_listing(reader)}"
                )
        extras = dict(extra_topics or {})
        if extra_topics is None:
            for c in reader.connections:
                if c.topic.startswith(EXTRA_NAMESPACE) and c.msgtype in (_FLOAT64, _STRING):
                    extras[c.topic[len(EXTRA_NAMESPACE) :]] = c.topic
        for col, topic in extras.items():
            if topic not in by_topic:
                raise LogError(
                    f"ROS bag {str(path)!r} has no topic {topic!r} (extra channel {col!r}); "
                    f"topics in the bag: {topics_listing(reader)}"
                )
        role_of = {t: r for r, t in topics.items()}
        col_of = {t: c for c, t in extras.items()}
        rows: dict[str, list] = {r: [] for r in topics}
        xrows: dict[str, list] = {c: [] for c in extras}
        conns = [by_topic[t] for t in (*topics.values(), *extras.values())]
        if fast:
            decoders = {c.id: decoder(c, is2) for c in conns}
            if any(d is None for d in decoders.values()):
                raise _NonStandardTypes
        else:
            decoders = {c.id: functools.partial(_reader_decode, reader, c.msgtype) for c in conns}
        for conn, bag_ns, raw in reader.messages(connections=conns):
            msg = decoders[conn.id](raw)
            if conn.topic in col_of:
                ns = (
                    bag_ns
                    if stamp == "bag" or not hasattr(msg, "header")
                    else _stamp_ns(msg, bag_ns, stamp)
                )
                xrows[col_of[conn.topic]].append((ns, msg.data))
                continue
            role = role_of[conn.topic]
            ns = _stamp_ns(msg, bag_ns, stamp)
            if role == "imu":
                o = msg.orientation
                rows[role].append((ns, o.w, o.x, o.y, o.z))
            elif role == "odom":
                tw = msg.twist.twist
                p = msg.pose.pose
                o = p.orientation
                rows[role].append(
                    (
                        ns,
                        tw.linear.x,
                        tw.linear.y,
                        tw.angular.z,
                        p.position.x,
                        p.position.y,
                        quaternion_yaw(o.w, o.x, o.y, o.z),
                    )
                )
            else:
                rows[role].append((ns, float(msg.voltage), float(msg.current)))
    except _NonStandardTypes:
        reader.close()
        return _read_streams(path, topics, stamp, extra_topics, fast=False)
    except BaseException:
        reader.close()
        raise
    reader.close()
    cols = {
        "imu": ["qw", "qx", "qy", "qz"],
        "odom": ["vx", "vy", "wz", "x", "y", "yaw"],
        "battery": ["voltage", "current"],
    }
    streams = {}
    for role, r in rows.items():
        if not r:
            raise LogError(f"ROS bag {str(path)!r}: topic {topics[role]!r} has no messages")
        arr = np.array(r, dtype=object)
        ns = arr[:, 0].astype(np.int64)
        streams[role] = (ns, {c: arr[:, i + 1].astype(float) for i, c in enumerate(cols[role])})
    xstreams = {}
    for col, r in xrows.items():
        if r:
            xstreams[col] = (np.array([a for a, _ in r], dtype=np.int64), [b for _, b in r])
    return streams, xstreams, is2


def _reader_decode(reader, msgtype: str, raw):
    return reader.deserialize(raw, msgtype)


def _sorted_unique(ns: np.ndarray) -> tuple[np.ndarray, int]:
    """Indices sorting ``ns`` with repeated stamps removed (first kept), and the count."""
    order = np.argsort(ns, kind="stable")
    keep = np.ones(order.size, bool)
    keep[1:] = np.diff(ns[order]) > 0
    return order[keep], int((~keep).sum())


def load_rosbag(
    path,
    *,
    imu_topic: str = DEFAULT_TOPICS["imu"],
    odom_topic: str = DEFAULT_TOPICS["odom"],
    battery_topic: str = DEFAULT_TOPICS["battery"],
    extra_topics: Mapping[str, str] | None = None,
    clock: Literal["imu", "odom"] = "imu",
    run: str | None = None,
    stamp: Literal["header", "bag"] = "header",
    battery_current: Literal["ros", "discharge_positive"] = "ros",
    max_interp_gap: float = 0.5,
    report: bool = False,
) -> pd.DataFrame | tuple[pd.DataFrame, LoadReport]:
    """Read a ROS 1 (``.bag``) or ROS 2 (folder) bag into the canonical sample table.

    Parameters
    ----------
    path : str or Path
        ROS 1 bag file or ROS 2 bag folder.
    imu_topic, odom_topic, battery_topic : str
        Topics of ``sensor_msgs/Imu``, ``nav_msgs/Odometry``, ``sensor_msgs/BatteryState``.
    extra_topics : mapping, optional
        Column name -> topic of ``std_msgs/Float64`` or ``std_msgs/String`` extra
        channels. Default: every such topic under ``/energy_planner/``.
    clock : {"imu", "odom"}
        Stream whose message times become the sample times (see module notes).
    run : str, optional
        Run id; default the bag's name (file stem or folder name).
    stamp : {"header", "bag"}
        Time source: message header stamps (default) or bag record times.
    battery_current : {"ros", "discharge_positive"}
        ``"ros"`` (default): the bag follows ROS (negative while discharging) and the
        current is negated. ``"discharge_positive"``: taken as it is.
    max_interp_gap : float
        Longest interval, s, between two messages of a stream that may be interpolated.
    report : bool
        Also return a :class:`~energy_planner.measurements.logs.LoadReport`.

    Returns
    -------
    samples : pandas.DataFrame
        Canonical table with ``t`` in seconds (stamp time).
    report : LoadReport
        Only when ``report=True``.

    Raises
    ------
    LogError
        A topic is missing (the message lists the bag's topics and types) or carries the
        wrong type, or a stream is empty, or no sample lies in the common time span.
    LogIOError
        The bag cannot be opened.
    """
    path = Path(path)
    if not path.exists():
        raise LogIOError(f"ROS bag {str(path)!r} does not exist")
    if clock not in ("imu", "odom"):
        raise LogError(f"clock={clock!r} is not valid; expected 'imu' or 'odom'")
    if battery_current not in ("ros", "discharge_positive"):
        raise LogError(
            f"battery_current={battery_current!r} is not valid; expected 'ros' "
            "or 'discharge_positive'"
        )
    topics = {"imu": imu_topic, "odom": odom_topic, "battery": battery_topic}
    streams, xstreams, is2 = _read_streams(path, topics, stamp, extra_topics)
    rep = LoadReport()
    dropped: dict[str, int] = {}
    clean = _dedupe_streams(streams, topics, stamp, path, dropped)
    keep = _clock_samples(clean, clock, topics, max_interp_gap, path, dropped)
    tc_ns = clean[clock][0][keep]
    tsec = tc_ns / 1e9
    out: dict[str, Any] = {"t": tsec}

    def interp(role: str, key: str) -> np.ndarray:
        ns, vals = clean[role]
        return np.interp(tsec, ns / 1e9, vals[key])

    out.update(_orientation(clean["imu"], clock, keep, tc_ns))
    for k in ("vx", "vy", "wz"):
        out[k] = clean["odom"][1][k][keep] if clock == "odom" else interp("odom", k)
    out["voltage"] = interp("battery", "voltage")
    out["current"] = _canonical_current(interp("battery", "current"), battery_current, path, rep)
    for k in ("x", "y"):
        out[k] = clean["odom"][1][k][keep] if clock == "odom" else interp("odom", k)
    if clock == "odom":
        out["yaw"] = clean["odom"][1]["yaw"][keep]
    else:
        ns, vals = clean["odom"]
        out["yaw"] = wrap(np.interp(tsec, ns / 1e9, np.unwrap(vals["yaw"])))
    out.update(_extra_columns(xstreams, tc_ns))
    name = run if run is not None else (path.stem if path.suffix == ".bag" else path.name)
    df = pd.DataFrame(out)
    df.insert(0, "run", str(name))
    df = canonicalize(df, str(path))
    _fill_report(rep, df, path, "rosbag2" if is2 else "rosbag1", str(name), topics, clock,
                 sorted(xstreams), dropped)  # fmt: skip
    return (df, rep) if report else df


def _dedupe_streams(streams, topics, stamp, path: Path, dropped: dict[str, int]) -> dict:
    """Each stream sorted by stamp with repeated stamps dropped (counted in ``dropped``).

    Raises
    ------
    LogError
        More than half of a stream's stamps repeat.
    """
    clean = {}
    for role, (ns, vals) in streams.items():
        idx, ndup = _sorted_unique(ns)
        if ndup and ndup > ns.size // 2:
            raise LogError(
                f"ROS bag {str(path)!r}: {ndup} of {ns.size} messages on {topics[role]!r} "
                f"repeat a {stamp} stamp (a driver that does not stamp its messages?); "
                + (
                    "use stamp='bag' to take the bag record times"
                    if stamp == "header"
                    else "the bag times are unusable"
                )
            )
        if ndup:
            dropped[f"repeated stamp on {topics[role]}"] = ndup
        clean[role] = (ns[idx], {k: v[idx] for k, v in vals.items()})
    return clean


def _clock_samples(clean, clock, topics, max_interp_gap, path: Path, dropped) -> np.ndarray:
    """Mask of the clock stream's messages kept as samples.

    Kept: inside the time span common to all streams, and no other stream silent for
    more than ``max_interp_gap`` around them (the reasons counted in ``dropped``).

    Raises
    ------
    LogError
        No message is kept.
    """
    tc_ns = clean[clock][0]
    t0 = max(c[0][0] for c in clean.values())
    t1 = min(c[0][-1] for c in clean.values())
    inside = (tc_ns >= t0) & (tc_ns <= t1)
    if (~inside).any():
        dropped["outside the time span common to all topics"] = int((~inside).sum())
    keep = inside.copy()
    gap_ns = int(round(max_interp_gap * 1e9))
    for role, (ns, _) in clean.items():
        if role == clock:
            continue
        i = np.clip(np.searchsorted(ns, tc_ns), 1, max(ns.size - 1, 1))
        exact = np.isin(tc_ns, ns)
        span = ns[i] - ns[i - 1] if ns.size > 1 else np.zeros_like(tc_ns)
        bad = inside & ~exact & (span > gap_ns)
        if bad.any():
            dropped[f"{topics[role]} silent for more than {max_interp_gap:g} s"] = int(
                (bad & keep).sum()
            )
            keep &= ~bad
    if not keep.any():
        raise LogError(
            f"ROS bag {str(path)!r}: no {topics[clock]} message lies in the time "
            "span common to all topics; check the topics and their stamps"
        )
    return keep


def _orientation(imu_stream, clock: str, keep: np.ndarray, tc_ns: np.ndarray) -> dict:
    """Quaternion columns at the sample times (Slerp when the clock is not the IMU's)."""
    from scipy.spatial.transform import Rotation, Slerp

    imu_ns, imu = imu_stream
    if clock == "imu":
        return {k: imu[k][keep] for k in ("qw", "qx", "qy", "qz")}
    tsec = tc_ns / 1e9
    quat = np.column_stack([imu["qx"], imu["qy"], imu["qz"], imu["qw"]])
    if imu_ns.size > 1:
        q = Slerp(imu_ns / 1e9, Rotation.from_quat(quat))(tsec).as_quat()
    else:
        q = quat[np.zeros(tsec.size, int)]
    near = quat[np.clip(np.searchsorted(imu_ns, tc_ns), 0, imu_ns.size - 1)]
    q *= np.where(np.sum(q * near, axis=1) < 0, -1.0, 1.0)[:, None]
    return {"qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]}


def _canonical_current(cur: np.ndarray, battery_current: str, path: Path, rep) -> np.ndarray:
    """Battery current positive while discharging; warn when it looks charging."""
    if battery_current == "ros":
        cur = -cur
        rep.current_sign_flipped = True
        log.info(
            "%s: battery current negated (ROS BatteryState is negative while "
            "discharging; canonical is positive)",
            path,
        )
    if cur.size and np.median(cur) < -SIGN_WARNING_A:
        other = "discharge_positive" if battery_current == "ros" else "ros"
        log.warning(
            "%s: median battery current %.3g A is negative (read with "
            "battery_current=%r): the robot would be charging while it walks; the "
            "driver may use the other sign convention (battery_current=%r)",
            path,
            float(np.median(cur)),
            battery_current,
            other,
        )
        rep.notes.append(f"warning: median current {float(np.median(cur)):.3g} A < 0")
    return cur


def _extra_columns(xstreams, tc_ns: np.ndarray) -> dict:
    """Extra channels at the sample times: numbers interpolated, text held (sample and hold).

    Outside a channel's own time span the value is unknown: NaN / missing.
    """
    tsec = tc_ns / 1e9
    out = {}
    for col, (ns, data) in xstreams.items():
        idx, _ = _sorted_unique(ns)
        xs = ns[idx]
        vals = [data[i] for i in idx]
        if isinstance(vals[0], str):
            j = np.searchsorted(xs, tc_ns, side="right") - 1
            out[col] = pd.Categorical([vals[i] if i >= 0 else None for i in j])
        else:
            out[col] = np.interp(
                tsec, xs / 1e9, np.asarray(vals, dtype=float), left=np.nan, right=np.nan
            )
    return out


def _fill_report(rep, df, path: Path, fmt, name, topics, clock, extra, dropped) -> None:
    """What was read, kept and dropped, in the :class:`LoadReport`."""
    rep.files.append(
        {
            "path": str(path),
            "format": fmt,
            "rows": len(df),
            "runs": [name],
            "topics": dict(topics),
            "extra_topics": extra,
        }
    )
    rep.n_rows = len(df)
    rep.runs = [name]
    rep.columns = list(df.columns)
    rep.extra_columns = [c for c in df.columns if c not in CANONICAL_COLUMNS]
    rep.dropped = dropped
    rep.notes.append(
        f"{fmt} {path.name}: resampled onto the {topics[clock]} clock (linear in time; "
        f"{'quaternion by Slerp; ' if clock == 'odom' else ''}yaw unwrapped)"
    )


def _header(T, ros1: bool, ns: int, frame: str, seq: int):
    if ros1:
        return T["std_msgs/msg/Header"](seq=seq, stamp=ros_time(T, ns), frame_id=frame)
    return T["std_msgs/msg/Header"](stamp=ros_time(T, ns), frame_id=frame)


def write_rosbag(
    samples: pd.DataFrame,
    path,
    version: Literal[1, 2] = 2,
    topics: Mapping[str, str] | None = None,
    *,
    extras: bool = True,
    storage: Literal["mcap", "sqlite3"] = "mcap",
) -> list[Path]:
    """Write canonical samples as ROS bag(s): Imu, Odometry and BatteryState per sample.

    Every sample becomes one message on each topic, stamped (header and bag time) with
    ``t`` (s, must be >= 0). The current is written with the ROS sign (negative while
    discharging). Numeric extra columns go to ``std_msgs/Float64`` and text/categorical
    ones to ``std_msgs/String`` on ``/energy_planner/<column>`` (``extras=False``: none).
    Missing pose columns are written as 0. :func:`load_rosbag` reads it back exactly at
    the sample times, up to float32 rounding of voltage and current (BatteryState fields
    are float32) and nanosecond rounding of ``t``.

    Parameters
    ----------
    samples : pandas.DataFrame
        Canonical table (one or more runs).
    path : str or Path
        Output. One run: the bag itself (ROS 2 folder, or ``.bag`` file for ROS 1; must
        not exist). Several runs: a folder that receives one bag per run, named by run.
    version : {1, 2}
        ROS 1 (``rosbags.rosbag1``) or ROS 2 (``rosbags.rosbag2``).
    topics : mapping, optional
        Role (``imu``, ``odom``, ``battery``) -> topic; defaults :data:`DEFAULT_TOPICS`.
    extras : bool
        Write extra columns.
    storage : {"mcap", "sqlite3"}
        ROS 2 storage plugin: MCAP (default; the ROS 2 default since Iron, and about
        0.02 s to create a bag against 0.3 s for sqlite3) or sqlite3 (the Humble default).

    Returns
    -------
    list of Path
        The bags written, one per run.
    """
    from energy_planner.measurements.schema import check_columns

    if version not in (1, 2):
        raise LogError(f"version={version!r} is not valid; expected 1 or 2")
    if storage not in ("mcap", "sqlite3"):
        raise LogError(f"storage={storage!r} is not valid; expected 'mcap' or 'sqlite3'")
    tops = {**DEFAULT_TOPICS, **dict(topics or {})}
    unknown = set(tops) - set(DEFAULT_TOPICS)
    if unknown:
        raise LogError(
            f"unknown topic role(s) {sorted(unknown)}; expected {sorted(DEFAULT_TOPICS)}"
        )
    samples = samples.copy()
    if "run" not in samples.columns:
        samples.insert(0, "run", "run")
    check_columns(samples.columns, "samples given to write_rosbag")
    if (samples["t"] < 0).any():
        raise LogError(
            "write_rosbag: t must be >= 0 s (bag times are unsigned); shift the "
            f"times (min t = {samples['t'].min()!r})"
        )
    path = Path(path)
    runs = sorted(samples["run"].astype(str).unique())
    if len(runs) == 1:
        targets = {runs[0]: path}
    else:
        path.mkdir(parents=True, exist_ok=True)
        targets = {r: path / (f"{r}.bag" if version == 1 else r) for r in runs}
    for r, target in targets.items():
        if target.exists():
            raise LogIOError(f"write_rosbag: {str(target)!r} exists already; not overwriting")
        from energy_planner.io import atomic_path

        with atomic_path(target, create=False) as tmp:  # a killed write leaves no bag
            _write_one(
                samples[samples["run"].astype(str) == r].sort_values("t"),
                tmp,
                version,
                tops,
                extras,
                storage,
            )
    return list(targets.values())


def _write_one(
    df: pd.DataFrame, path: Path, version: int, tops: Mapping[str, str], extras: bool, storage: str
) -> None:
    ts = typestore(version)
    ros1 = version == 1
    extra_cols = [c for c in df.columns if c not in CANONICAL_COLUMNS] if extras else []
    n = len(df)
    col = {c: df[c].to_numpy(dtype=float) for c in REQUIRED_COLUMNS}
    for c in ("x", "y", "yaw"):
        col[c] = df[c].to_numpy(dtype=float) if c in df.columns else np.zeros(n)
    stamps = np.round(col["t"] * 1e9).astype(np.int64)

    def add(w: Any, topic: str, msgtype: str) -> Any:
        if ros1:
            return w.add_connection(topic, msgtype, typestore=ts)
        msgdef, rihs01 = type_definition(msgtype)  # as the typestore gives it, once
        return w.add_connection(topic, msgtype, msgdef=msgdef, rihs01=rihs01)

    with open_writer(path, version, storage) as w:
        conn = {r: add(w, tops[r], MSGTYPES[r]) for r in MSGTYPES}
        xconn = []
        for c in extra_cols:
            numeric = pd.api.types.is_numeric_dtype(df[c])
            values = df[c].to_numpy(dtype=float) if numeric else df[c].astype(str).tolist()
            xconn.append(
                (add(w, EXTRA_NAMESPACE + c, _FLOAT64 if numeric else _STRING), numeric, values)
            )
        layouts = _layouts(version)
        if layouts is not None and _fits_layouts(col, stamps):
            _write_blocks(w, ts, layouts, conn, xconn, col, stamps)
        else:
            _write_messages(w, ts, ros1, conn, xconn, col, stamps)


#: Samples serialized together by :func:`_write_blocks` (bounds the memory held).
_BLOCK = 4096
_INT32 = np.iinfo(np.int32)
#: Varying fields of each message written by :func:`write_rosbag` (ROS 1 headers have
#: ``header.seq`` too).
_STAMP = ("header.stamp.sec", "header.stamp.nanosec")
_FIELDS = {
    "imu": (*_STAMP, "orientation.x", "orientation.y", "orientation.z", "orientation.w",
            "angular_velocity.z"),
    "odom": (*_STAMP, "pose.pose.position.x", "pose.pose.position.y",
             "pose.pose.orientation.z", "pose.pose.orientation.w", "twist.twist.linear.x",
             "twist.twist.linear.y", "twist.twist.angular.z"),
    "battery": (*_STAMP, "voltage", "current"),
    "float64": ("data",),
}  # fmt: skip


@functools.lru_cache(maxsize=2)
def _layouts(version: int) -> dict | None:
    """:class:`FixedLayout` of Imu, Odometry, BatteryState and Float64 (cached).

    None when a layout cannot be built (another rosbags' types): messages one by one.
    """
    from energy_planner.measurements._cdr import FixedLayout, _NotFixedLayout

    ros1 = version == 1
    ts = typestore(version)
    T = ts.types
    templates = {
        "imu": _imu(T, ros1, 0, 0.0, 0.0, 0.0, 1.0, 0.0),
        "odom": _odom(T, ros1, 0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
        "battery": _battery(T, ros1, 0, 0.0, 0.0),
        "float64": T[_FLOAT64](data=0.0),
    }
    types = {**MSGTYPES, "float64": _FLOAT64}
    seq = ("header.seq",) if ros1 else ()
    try:
        return {
            r: FixedLayout(ts, types[r], m, (*seq, *_FIELDS[r]) if r in MSGTYPES else _FIELDS[r],
                           ros1=ros1)
            for r, m in templates.items()
        }  # fmt: skip
    except _NotFixedLayout as err:
        log.debug("ROS %d messages serialized one by one: %s", version, err)
        return None


def _fits_layouts(col: Mapping[str, np.ndarray], stamps: np.ndarray) -> bool:
    """Whether every value fits its field (else the per-message path raises as it did)."""
    if stamps.size > np.iinfo(np.uint32).max:  # the ROS 1 header.seq
        return False
    sec = stamps // 1_000_000_000
    if sec.size and (sec.min() < _INT32.min or sec.max() > _INT32.max):
        return False
    with np.errstate(over="ignore"):
        for v in (col["voltage"], col["current"]):
            if (np.isinf(v.astype(np.float32)) & np.isfinite(v)).any():
                return False
    return True


def _write_blocks(w, ts, layouts, conn, xconn, col, stamps) -> None:
    """Serialize ``_BLOCK`` samples of each type at once, then write them in time order."""
    n = stamps.size
    sec = stamps // 1_000_000_000
    nsec = stamps % 1_000_000_000
    half = (0.5 * col["yaw"]).tolist()  # math.sin/cos: the per-message path's values
    qz = np.array([math.sin(h) for h in half], dtype=float)
    qw = np.array([math.cos(h) for h in half], dtype=float)
    arrays = {
        "imu": (sec, nsec, col["qx"], col["qy"], col["qz"], col["qw"], col["wz"]),
        "odom": (sec, nsec, col["x"], col["y"], qz, qw, col["vx"], col["vy"], col["wz"]),
        "battery": (sec, nsec, col["voltage"], -col["current"]),
    }
    ser = layouts["float64"].serializer  # the typestore's, of the bag's ROS version
    texts = {}
    for _, numeric, values in xconn:
        if not numeric:
            for v in set(values) - texts.keys():
                texts[v] = bytes(ser(ts.types[_STRING](data=v), _STRING))
    roles = list(MSGTYPES)
    for a in range(0, n, _BLOCK):
        b = min(a + _BLOCK, n)
        blocks = []
        seq = np.arange(a, b)
        for r in roles:
            values = {f: x[a:b] for f, x in zip(_FIELDS[r], arrays[r], strict=True)}
            if "header.seq" in layouts[r].fields:
                values["header.seq"] = seq
            blocks.append((conn[r], layouts[r].serialize(values)))
        for cn, numeric, values in xconn:
            if numeric:
                blocks.append((cn, layouts["float64"].serialize({"data": values[a:b]})))
            else:
                blocks.append((cn, [texts[v] for v in values[a:b]]))
        for i, ns in enumerate(stamps[a:b].tolist()):
            for cn, data in blocks:
                w.write(cn, ns, data[i])


def _write_messages(w, ts, ros1, conn, xconn, col, stamps) -> None:
    """Build and serialize each message on its own (ROS 1, or types without a layout)."""
    T = ts.types
    ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    for i in range(stamps.size):
        ns = int(stamps[i])
        imu = _imu(T, ros1, ns, col["qx"][i], col["qy"][i], col["qz"][i], col["qw"][i],
                   col["wz"][i], seq=i)  # fmt: skip
        h = 0.5 * col["yaw"][i]
        odom = _odom(T, ros1, ns, col["x"][i], col["y"][i], math.sin(h), math.cos(h),
                     col["vx"][i], col["vy"][i], col["wz"][i], seq=i)  # fmt: skip
        bat = _battery(T, ros1, ns, col["voltage"][i], -col["current"][i], seq=i)
        for role, msg in (("imu", imu), ("odom", odom), ("battery", bat)):
            w.write(conn[role], ns, ser(msg, MSGTYPES[role]))
        for cn, numeric, values in xconn:
            v = values[i]
            msg = T[_FLOAT64](data=float(v)) if numeric else T[_STRING](data=v)
            w.write(cn, ns, ser(msg, _FLOAT64 if numeric else _STRING))


def _imu(T, ros1: bool, ns: int, qx, qy, qz, qw, wz, seq: int = 0):
    """The ``sensor_msgs/Imu`` of one sample (frame ``imu_link``)."""
    Vec, Quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    return T["sensor_msgs/msg/Imu"](
        header=_header(T, ros1, ns, "imu_link", seq),
        orientation=Quat(x=qx, y=qy, z=qz, w=qw),
        orientation_covariance=np.zeros(9),
        angular_velocity=Vec(x=0.0, y=0.0, z=wz),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=Vec(x=0.0, y=0.0, z=0.0),
        linear_acceleration_covariance=np.full(9, 0.0),
    )


def _odom(T, ros1: bool, ns: int, x, y, qz, qw, vx, vy, wz, seq: int = 0):
    """The ``nav_msgs/Odometry`` of one sample (frames ``odom`` -> ``base_link``)."""
    Vec, Quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    return T["nav_msgs/msg/Odometry"](
        header=_header(T, ros1, ns, "odom", seq),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                orientation=Quat(x=0.0, y=0.0, z=qz, w=qw),
            ),
            covariance=np.zeros(36),
        ),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](
                linear=Vec(x=vx, y=vy, z=0.0),
                angular=Vec(x=0.0, y=0.0, z=wz),
            ),
            covariance=np.zeros(36),
        ),
    )


def _battery(T, ros1: bool, ns: int, voltage, current, seq: int = 0):
    """The ``sensor_msgs/BatteryState`` of one sample, ``current`` with the ROS sign."""
    nan = float("nan")
    return T["sensor_msgs/msg/BatteryState"](
        header=_header(T, ros1, ns, "battery", seq),
        voltage=voltage,
        temperature=nan,
        current=current,
        charge=nan,
        capacity=nan,
        design_capacity=nan,
        percentage=nan,
        power_supply_status=2,
        power_supply_health=0,
        power_supply_technology=0,
        present=True,
        cell_voltage=np.zeros(0, np.float32),
        cell_temperature=np.zeros(0, np.float32),
        location="",
        serial_number="",
    )
