"""Planned paths as ROS 2 bags: ``nav_msgs/msg/Path`` in a named map frame, and back.

A robot running ROS 2 (Nav2's ``FollowPath``, RViz, ``ros2 bag play``) takes a plan as a
``nav_msgs/msg/Path``: a header (frame, stamp) and one ``geometry_msgs/msg/PoseStamped``
per vertex. :func:`write_path_bag` writes one Path message per topic into a ROS 2 bag
folder (MCAP by default, or sqlite3), without a ROS installation (``rosbags``);
:func:`read_path_bag` reads a Path (or a stream of ``Odometry`` / ``PoseStamped``
messages) back as :class:`~energy_planner.io.path_format.Waypoints`, which
``energy --waypoints BAG`` prices.

The frame (:class:`MapFrame`)
    REP 105's ``map`` frame (world-fixed; the name is ``frame``, default ``"map"``) with
    REP 103's axes: x east (the +x axis of the working CRS, a projected CRS in metres:
    the DEM's own, or the UTM zone of a longitude/latitude DEM), y north, z up. It is
    that CRS translated by ``origin`` (no rotation, no scale): ``x_crs = x + origin_x``,
    ``y_crs = y + origin_y``; z is the DEM's height. The default origin is the south-west
    corner of the DEM's working grid, so every output of one DEM shares the frame.
    Orientation: the planned body yaw as a quaternion about +z (REP 103: radians
    counter-clockwise from +x, 0 facing east).
    The bag states the frame in its metadata (``custom_data["energy_planner.frame"]``,
    JSON: :meth:`MapFrame.to_dict`); the commands put the same dict in their JSON.
Stamps
    The time at which the robot reaches each pose (:func:`energy_planner.energy.path.vertex_times`:
    the timing the plan's energy was integrated over), from ``start_s`` (default 0:
    times relative to the start). The Path's header and its bag time are the first
    pose's stamp.

Reading back gives the written poses (positions to float rounding, yaw exactly, times to
the nanosecond), so a bag read by ``energy --waypoints`` prices the plan's energy.

Examples
--------
>>> import tempfile, pathlib
>>> from energy_planner.terrain import Terrain
>>> ter = Terrain.from_function(lambda x, y: 0 * x, size=(10, 10))
>>> x0, y0 = ter.grid[:2]
>>> st = np.array([[x0 + 1, y0 - 1, 0.5], [x0 + 4, y0 - 1, 0.5]])
>>> bag = pathlib.Path(tempfile.mkdtemp()) / "plan"
>>> frame = write_path_bag(bag, {"/plan": (st, [0.0, 10.0])}, ter)
>>> w = read_path_bag(bag)
>>> w.declared_crs, np.allclose(w.xy, st[:, :2]), w.yaw_rad.tolist(), w.t.tolist()
('EPSG:32631', True, [0.5, 0.5], [0.0, 10.0])
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import WaypointError, WaypointIOError
from energy_planner.io.bag import (
    decoder,
    open_reader,
    open_writer,
    quaternion_yaw,
    ros_time,
    topics_listing,
    typestore,
)
from energy_planner.io.path_format import YAW_FRAME, Waypoints, is_bag

__all__ = [
    "FRAME_KEY",
    "PATH_TYPE",
    "MapFrame",
    "is_bag",
    "map_frame",
    "read_path_bag",
    "write_path_bag",
]

#: The message type written.
PATH_TYPE = "nav_msgs/msg/Path"
#: Message types :func:`read_path_bag` reads as a path (one Path, or one pose per message).
POSE_TYPES = ("nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseStamped")
#: ``custom_data`` key of the bag's metadata holding :meth:`MapFrame.to_dict` as JSON.
FRAME_KEY = "energy_planner.frame"
#: ``custom_data`` key holding what each topic is (energy, distance, duration), as JSON.
TOPICS_KEY = "energy_planner.topics"


@dataclass(frozen=True)
class MapFrame:
    """A ROS map frame: the working CRS translated by ``origin`` (see the module notes).

    Attributes
    ----------
    frame : str
        The frame id (``header.frame_id``), e.g. ``"map"``.
    crs : str or None
        The projected CRS the frame is a translation of (None: local metres).
    origin : (float, float)
        The frame's origin in that CRS, metres.
    """

    frame: str
    crs: str | None
    origin: tuple[float, float]

    def to_frame(self, xy: Any) -> np.ndarray:
        """Working-CRS coordinates (n, 2) -> frame coordinates."""
        return np.asarray(xy, dtype=float) - np.asarray(self.origin, dtype=float)

    def from_frame(self, xy: Any) -> np.ndarray:
        """Frame coordinates (n, 2) -> the CRS's coordinates."""
        return np.asarray(xy, dtype=float) + np.asarray(self.origin, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        """The transform and conventions, JSON-ready (the bag's metadata, the commands' JSON)."""
        return {
            "frame": self.frame,
            "crs": self.crs,
            "origin": [float(self.origin[0]), float(self.origin[1]), 0.0],
            "transform": "x_crs = x + origin[0], y_crs = y + origin[1], z = height in the "
            "DEM's vertical datum (a translation: no rotation, no scale)",
            "axes": "REP 103: x east (the CRS's +x), y north (the CRS's +y), z up; "
            "right-handed; metres",
            "yaw": "REP 103: radians counter-clockwise about +z from +x (0 = facing +x); "
            "orientation = quaternion about z of the planned body yaw",
            "frame_convention": "REP 105: a world-fixed map frame",
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> MapFrame:
        """Inverse of :meth:`to_dict` (``WaypointError`` when a member is missing)."""
        try:
            o = d["origin"]
            return cls(str(d["frame"]), d.get("crs"), (float(o[0]), float(o[1])))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise WaypointError(
                f"the bag's frame metadata {dict(d)!r} has no usable frame and origin ({exc})",
                value=dict(d),
                expected="frame, crs and origin [x, y, z]",
            ) from exc


def map_frame(terrain: Any, frame: str = "map", origin: Sequence[float] | None = None) -> MapFrame:
    """The map frame of a terrain: its working CRS, origin at the grid's south-west corner.

    Parameters
    ----------
    terrain : Terrain
        Gives the working CRS and grid.
    frame : str
        The frame id.
    origin : (x, y), optional
        Another origin, in the working CRS.

    Raises
    ------
    WaypointError
        An empty frame name or a non-finite origin.
    """
    from energy_planner.io.geojson import crs_name

    if not isinstance(frame, str) or not frame.strip():
        raise WaypointError(
            f"frame {frame!r} is not a frame name", value=frame, expected="a non-empty name"
        )
    if origin is None:
        left, bottom = terrain.bounds[0], terrain.bounds[1]
        origin = (float(left), float(bottom))
    o = (float(origin[0]), float(origin[1]))
    if not all(math.isfinite(v) for v in o):
        raise WaypointError(f"origin {o!r} is not finite", value=o, expected="finite x, y")
    return MapFrame(frame.strip(), crs_name(getattr(terrain, "crs", None)), o)


def write_path_bag(
    path: str | Path,
    paths: Mapping[str, tuple[Any, Any]],
    terrain: Any,
    *,
    frame: str = "map",
    origin: Sequence[float] | None = None,
    start_s: float = 0.0,
    storage: str = "mcap",
    info: Mapping[str, Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """Write paths as ``nav_msgs/msg/Path`` messages, one topic each, into a ROS 2 bag.

    Parameters
    ----------
    path : str or pathlib.Path
        The bag folder to create (must not exist). Written atomically: into a private
        folder on the same file system, renamed when complete.
    paths : mapping
        Topic -> ``(states, times)``: poses ``x, y, yaw`` (n, 3) in the working CRS
        (metres, radians) and the time of each pose (n,), s.
    terrain : Terrain
        The map: the frame (:func:`map_frame`) and the heights (``z``).
    frame, origin
        The frame id and its origin in the working CRS (default the grid's south-west
        corner).
    start_s : float
        Added to the times for the stamps (seconds since the epoch; default 0).
    storage : {"mcap", "sqlite3"}
        The ROS 2 storage plugin.
    info : mapping, optional
        Topic -> JSON-ready facts (energy, distance, ...), stored in the metadata.

    Returns
    -------
    dict
        :meth:`MapFrame.to_dict` plus ``topics`` (the topics written) and ``storage``.

    Raises
    ------
    WaypointIOError
        ``path`` exists, or its folder cannot be written.
    WaypointError
        Bad poses or times (shapes, non-finite, times not increasing, negative stamps),
        a bad topic name or storage.
    """
    from energy_planner.io.atomic import atomic_path

    if storage not in ("mcap", "sqlite3"):
        raise WaypointError(
            f"storage={storage!r} is not valid", value=storage, expected="'mcap' or 'sqlite3'"
        )
    if not paths:
        raise WaypointError("no path to write", expected="at least one topic")
    mf = map_frame(terrain, frame, origin)
    checked = {topic: _checked(topic, *pair, start_s) for topic, pair in paths.items()}
    p = Path(path)
    if p.exists():
        raise WaypointIOError(
            f"ROS bag {str(p)!r} exists already; not overwriting it (remove it or choose "
            "another name)",
            path=p,
            expected="a new folder name",
        )
    meta = {FRAME_KEY: json.dumps(mf.to_dict())}
    if info:
        meta[TOPICS_KEY] = json.dumps({k: dict(v) for k, v in info.items()})
    try:
        with atomic_path(p, create=False) as tmp:
            _write(tmp, checked, terrain, mf, storage, meta)
    except OSError as exc:
        raise WaypointIOError(f"cannot write ROS bag {str(p)!r}: {exc}", path=p) from exc
    return {**mf.to_dict(), "topics": list(checked), "storage": storage}


def _checked(topic: str, states: Any, times: Any, start_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Poses (n, 3) and stamps (n,) in ns, checked (``WaypointError`` naming the topic)."""
    if not isinstance(topic, str) or not topic.startswith("/") or topic.endswith("/"):
        raise WaypointError(
            f"topic {topic!r} is not a ROS topic name", value=topic, expected="'/name'"
        )
    s = np.asarray(states, dtype=float)
    t = np.asarray(times, dtype=float)
    n = s.shape[0] if s.ndim == 2 else -1
    if s.ndim != 2 or s.shape[1] != 3 or n < 2 or not np.isfinite(s).all():
        raise WaypointError(
            f"{topic}: poses must be a finite (n >= 2, 3) array of x, y, yaw; got {s.shape}",
            value=s.shape,
            expected="(n >= 2, 3)",
        )
    if t.shape != (n,) or not np.isfinite(t).all() or np.any(np.diff(t) < 0):
        raise WaypointError(
            f"{topic}: times must be {n} finite, non-decreasing values; got shape {t.shape}",
            value=t.shape,
            expected=f"{n} non-decreasing times",
        )
    ns = np.round((t + float(start_s)) * 1e9).astype(np.int64)
    if ns[0] < 0:
        raise WaypointError(
            f"{topic}: the first stamp is {t[0] + start_s:g} s; bag times cannot be negative",
            value=float(t[0] + start_s),
            expected="start_s + times >= 0",
        )
    return s, ns


def _write(tmp: Path, checked, terrain, mf: MapFrame, storage: str, meta: dict) -> None:
    ts = typestore(2)
    T = ts.types
    Header, Pose = T["std_msgs/msg/Header"], T["geometry_msgs/msg/Pose"]
    Point, Quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    with open_writer(tmp, 2, storage) as w:
        for k, v in meta.items():
            w.set_custom_data(k, v)
        for topic, (s, ns) in checked.items():
            conn = w.add_connection(topic, PATH_TYPE, typestore=ts)
            xy = mf.to_frame(s[:, :2])
            z = np.asarray(terrain.sample(s[:, 0], s[:, 1]).elevation, dtype=float)
            z = np.where(np.isfinite(z), z, 0.0)
            poses = [
                T["geometry_msgs/msg/PoseStamped"](
                    header=Header(stamp=ros_time(T, int(ns[i])), frame_id=mf.frame),
                    pose=Pose(
                        position=Point(x=float(xy[i, 0]), y=float(xy[i, 1]), z=float(z[i])),
                        orientation=Quat(
                            x=0.0, y=0.0, z=math.sin(s[i, 2] / 2), w=math.cos(s[i, 2] / 2)
                        ),
                    ),
                )
                for i in range(s.shape[0])
            ]
            msg = T[PATH_TYPE](
                header=Header(stamp=ros_time(T, int(ns[0])), frame_id=mf.frame), poses=poses
            )
            w.write(conn, int(ns[0]), ts.serialize_cdr(msg, PATH_TYPE))


def read_path_bag(path: str | Path, topic: str | None = None) -> Waypoints:
    """Read a path from a ROS bag: one ``nav_msgs/Path``, or Odometry / PoseStamped messages.

    Parameters
    ----------
    path : str or pathlib.Path
        A ROS 2 bag folder (or a ROS 1 ``.bag`` file).
    topic : str, optional
        The topic to read. Default: the bag's only ``nav_msgs/msg/Path`` topic, else its
        only Odometry or PoseStamped topic.

    Returns
    -------
    Waypoints
        Poses in the frame's CRS (``declared_crs``) when the bag states its frame
        (:data:`FRAME_KEY`, as :func:`write_path_bag` writes it), else the frame
        coordinates taken in the DEM's CRS (a note says so); yaw from the orientation
        (about +z); times from the stamps (s from the first pose), or None when they do
        not increase (a note says so). A Path topic with several messages gives its last.

    Raises
    ------
    WaypointIOError
        The bag does not exist or cannot be opened.
    WaypointError
        No such topic, no path topic or several (the message lists them), a topic of
        another type, no messages, or fewer than 2 poses.
    """
    p = Path(path)
    if not p.exists():
        raise WaypointIOError(
            f"ROS bag {str(p)!r} does not exist (expected a ROS 2 bag folder)",
            path=p,
            expected="a ROS 2 bag folder",
        )
    reader, is2 = open_reader(p, False, WaypointIOError)
    try:
        reader.open()
    except Exception as err:  # rosbags raises its own error classes
        raise WaypointIOError(f"cannot open ROS bag {str(p)!r}: {err}", path=p) from err
    try:
        conn = _topic(reader, p, topic)
        custom = _custom_data(reader)
        dec = decoder(conn, is2)
        msgs = [
            (bag_ns, dec(raw) if dec else reader.deserialize(raw, conn.msgtype))
            for _, bag_ns, raw in reader.messages(connections=[conn])
        ]
    finally:
        reader.close()
    where = f"ROS bag {str(p)!r}, topic {conn.topic!r}"
    if not msgs:
        raise WaypointError(f"{where} has no messages", path=p, expected="a path")
    notes: list[str] = []
    if conn.msgtype == PATH_TYPE:
        if len(msgs) > 1:
            notes.append(f"{conn.topic}: {len(msgs)} Path messages; the last one read")
        rows = [(_stamp(ps.header), ps.pose) for ps in msgs[-1][1].poses]
        frames = {ps.header.frame_id or msgs[-1][1].header.frame_id for ps in msgs[-1][1].poses}
    else:
        rows = [(_stamp(m.header), m.pose.pose if hasattr(m.pose, "pose") else m.pose)
                for _, m in msgs]  # fmt: skip
        frames = {m.header.frame_id for _, m in msgs}
    if len(rows) < 2:
        raise WaypointError(
            f"{where}: {len(rows)} pose(s); a path needs at least 2",
            path=p,
            value=len(rows),
            expected="at least 2 poses",
        )
    xy = np.array([[r[1].position.x, r[1].position.y] for r in rows], dtype=float)
    yaw = np.array([quaternion_yaw(o.w, o.x, o.y, o.z) for o in (r[1].orientation for r in rows)])
    ns = np.array([r[0] for r in rows], dtype=np.int64)
    t = None
    if np.all(np.diff(ns) > 0):
        t = (ns - ns[0]) / 1e9
    else:
        notes.append(f"{conn.topic}: stamps do not increase; times not used")
    declared, note = None, f"{where}: x, y taken in the DEM's CRS (no frame metadata)"
    if FRAME_KEY in custom:
        mf = MapFrame.from_dict(_json(custom[FRAME_KEY], where, p))
        other = sorted(f for f in frames if f and f != mf.frame)
        if other:
            raise WaypointError(
                f"{where}: poses in frame(s) {other}, but the bag's metadata describes "
                f"frame {mf.frame!r}",
                path=p,
                value=other,
                expected=f"frame {mf.frame!r}",
            )
        xy = mf.from_frame(xy)
        declared = mf.crs
        note = f"{where}: frame {mf.frame!r} = {mf.crs} shifted by {list(mf.origin)}"
    return Waypoints(
        xy=xy,
        yaw_rad=yaw,
        t=t,
        crs_note=note,
        declared_crs=declared,
        notes=notes,
        path=p,
        yaw_frame=YAW_FRAME,
        properties={"topic": conn.topic, "msgtype": conn.msgtype},
    )


def _stamp(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _topic(reader: Any, p: Path, topic: str | None) -> Any:
    """The connection to read (see :func:`read_path_bag`)."""
    conns = list(reader.connections)
    if topic is not None:
        found = [c for c in conns if c.topic == topic]
        if not found:
            raise WaypointError(
                f"ROS bag {str(p)!r} has no topic {topic!r}; topics: {topics_listing(reader)}",
                path=p,
                value=topic,
                expected="one of the bag's topics",
            )
        if found[0].msgtype not in (PATH_TYPE, *POSE_TYPES):
            raise WaypointError(
                f"ROS bag {str(p)!r}: topic {topic!r} carries {found[0].msgtype}, not a path "
                f"({PATH_TYPE}, {', '.join(POSE_TYPES)})",
                path=p,
                value=found[0].msgtype,
                expected=PATH_TYPE,
            )
        return found[0]
    for kinds in ((PATH_TYPE,), POSE_TYPES):
        found = [c for c in conns if c.msgtype in kinds]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            raise WaypointError(
                f"ROS bag {str(p)!r} has {len(found)} path topics "
                f"({', '.join(c.topic for c in found)}); name one (--bag-topic)",
                path=p,
                value=[c.topic for c in found],
                expected="one topic",
            )
    raise WaypointError(
        f"ROS bag {str(p)!r} has no {PATH_TYPE}, Odometry or PoseStamped topic; topics: "
        f"{topics_listing(reader) or 'none'}",
        path=p,
        expected=PATH_TYPE,
    )


def _custom_data(reader: Any) -> dict[str, str]:
    """The bag's ``custom_data`` (ROS 2 metadata), {} for a ROS 1 bag or none."""
    for r in getattr(reader, "readers", [reader]):
        # rosbags 0.11 keeps the metadata on the storage reader, 0.10 on the reader
        for holder in (getattr(r, "storage", None), r):
            custom = getattr(getattr(holder, "metadata", None), "custom", None)
            if custom:
                return dict(custom)
    return {}


def _json(text: str, where: str, p: Path) -> dict[str, Any]:
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise WaypointError(
            f"{where}: the frame metadata is not JSON ({exc})", path=p, expected="JSON"
        ) from exc
    if not isinstance(d, dict):
        raise WaypointError(f"{where}: the frame metadata is not an object", path=p)
    return d
