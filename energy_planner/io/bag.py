"""ROS bags with the ``rosbags`` package: the readers, writers and message helpers shared.

Two kinds of bag go through here, with no ROS installation: robot logs
(:mod:`energy_planner.measurements.rosbag`: Imu, Odometry, BatteryState) and planned
paths (:mod:`energy_planner.io.ros2`: ``nav_msgs/msg/Path``). Both open a bag with
:func:`open_reader` and decode a connection's messages with :func:`decoder` (the cached
standard typestore when the bag's type definition is the standard one, else the bag's
own definitions), and write with :func:`open_writer`.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

__all__ = [
    "decoder",
    "open_reader",
    "open_writer",
    "quaternion_yaw",
    "ros_time",
    "topics_listing",
    "type_definition",
    "typestore",
]


@functools.lru_cache(maxsize=2)
def typestore(version: int) -> Any:
    """The rosbags typestore of ROS 1 Noetic (``version=1``) or ROS 2 Humble (cached).

    Cached: its message serializers compile on first use.
    """
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if version == 1 else Stores.ROS2_HUMBLE)


@functools.lru_cache(maxsize=64)
def type_definition(msgtype: str) -> tuple[str, str]:
    """``(msgdef, rihs01)`` of a ROS 2 message type of :func:`typestore` ``(2)`` (cached).

    What a ROS 2 writer's ``add_connection`` derives from the typestore for every
    connection of every bag (the definition's text and its hash: a few ms each); given
    once, a campaign's bags skip it.
    """
    ts = typestore(2)
    return ts.generate_msgdef(msgtype, ros_version=2)[0], ts.hash_rihs01(msgtype)


def topics_listing(reader: Any) -> str:
    """``"/a (type), /b (type)"``: a bag's topics and their types, for messages."""
    return ", ".join(
        f"{c.topic} ({c.msgtype})" for c in sorted(reader.connections, key=lambda c: c.topic)
    )


def open_reader(path: Path, fast: bool, error: type[Exception]) -> tuple[Any, bool]:
    """Open a bag: a plain rosbag1/rosbag2 reader or an AnyReader, and whether it is ROS 2.

    Parameters
    ----------
    path : pathlib.Path
        A ROS 2 bag folder or a ROS 1 ``.bag`` file.
    fast : bool
        True: the plain reader, standard types decoded by the cached typestore
        (:func:`decoder`). False: an AnyReader (types from the bag's own definitions).
    error : type
        The project error raised when the bag cannot be opened (``LogIOError``,
        ``WaypointIOError``).

    Returns
    -------
    reader, is2
        The reader (not opened yet) and whether the bag is ROS 2.
    """
    try:
        if not fast:
            from rosbags.highlevel import AnyReader

            reader = AnyReader([path], default_typestore=typestore(2))
            return reader, reader.is2
        if path.is_dir():
            from rosbags.rosbag2 import Reader as Reader2

            return Reader2(path), True
        from rosbags.rosbag1 import Reader as Reader1

        return Reader1(path), False
    except Exception as err:  # rosbags raises its own error classes
        raise error(f"cannot open ROS bag {str(path)!r}: {err}") from err


def decoder(conn: Any, is2: bool) -> Any:
    """Deserializer from the cached standard typestore, or None for a non-standard type.

    Used when the bag's definition of the type is the standard one (same digest); with
    None the reader's own typestore, built from the bag's embedded definitions, decodes
    it (``AnyReader.deserialize``: slower, always right).
    """
    ts = typestore(2 if is2 else 1)
    if conn.msgtype not in ts.types or not conn.digest:
        return None
    try:
        digest = type_definition(conn.msgtype)[1] if is2 else ts.generate_msgdef(conn.msgtype)[1]
    except Exception:  # noqa: BLE001 - any failure: use the reader's definitions
        return None
    if digest != conn.digest:
        return None
    if is2:
        return functools.partial(_decode, ts.deserialize_cdr, conn.msgtype)
    return functools.partial(_decode, ts.deserialize_ros1, conn.msgtype)


def _decode(fn: Any, msgtype: str, raw: Any) -> Any:
    return fn(raw, msgtype)


def open_writer(path: Path, version: int, storage: str) -> Any:
    """A rosbags writer: ROS 1 (``version=1``) or ROS 2 with ``"mcap"``/``"sqlite3"`` storage.

    ``path`` must not exist (rosbags refuses to overwrite).
    """
    if version == 1:
        from rosbags.rosbag1 import Writer

        return Writer(path)
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    try:
        return Writer(path, version=9, storage_plugin=plugin)
    except TypeError:  # rosbags 0.10 has no version argument
        return Writer(path, storage_plugin=plugin)


def ros_time(types: Any, ns: int) -> Any:
    """A ``builtin_interfaces/msg/Time`` of ``ns`` nanoseconds (``types``: a typestore's)."""
    return types["builtin_interfaces/msg/Time"](
        sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000)
    )


def quaternion_yaw(qw: float, qx: float, qy: float, qz: float) -> float:
    """Yaw (radians, about +z, REP 103) of a quaternion: the Z of its Z-Y-X Euler angles.

    >>> round(quaternion_yaw(math.cos(0.6), 0.0, 0.0, math.sin(0.6)), 12)
    1.2
    """
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
