"""Serialize many ROS messages of one fixed layout at once (ROS 2 CDR or ROS 1).

A robot log writes the same message types thousands of times with the same frame ids
and empty arrays: every message has the same size and only a few numeric fields
change. :class:`FixedLayout` serializes a template message once with the typestore's
own serializer (``Typestore.serialize_cdr`` or ``serialize_ros1``), finds the byte
offsets of the varying fields from the type's field definitions, and fills those
fields for all messages with one numpy assignment each. The bytes are the ones the
typestore gives for each message (checked when the layout is built, and by tests over
random values).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["FixedLayout"]

#: Bytes of the CDR primitives and their numpy types (little endian).
_PRIMITIVES: dict[str, tuple[int, str]] = {
    "bool": (1, "?"),
    "byte": (1, "u1"),
    "char": (1, "u1"),
    "int8": (1, "i1"),
    "uint8": (1, "u1"),
    "int16": (2, "<i2"),
    "uint16": (2, "<u2"),
    "int32": (4, "<i4"),
    "uint32": (4, "<u4"),
    "int64": (8, "<i8"),
    "uint64": (8, "<u8"),
    "float32": (4, "<f4"),
    "float64": (8, "<f8"),
}
#: Size of the CDR encapsulation header before the payload (ROS 1 has none).
_CDR_HEADER = 4


class _NotFixedLayout(ValueError):
    """The message type has parts whose size varies, or the layout check failed."""


def _walk(ts: Any, msgtype: str, msg: Any, pos: int, prefix: str, out: dict, ros1: bool) -> int:
    """Payload offset after ``msg``; leaf fields' ``(offset, numpy type)`` into ``out``.

    CDR aligns each primitive to its size and ends strings with a NUL; ROS 1 does
    neither.
    """

    def _align(pos: int, size: int) -> int:
        return pos if ros1 else (pos + size - 1) // size * size

    for name, (node, spec) in ts.fielddefs[msgtype][1]:
        value = getattr(msg, name)
        path = prefix + name
        kind = getattr(node, "name", str(node))
        if kind == "NAME":
            pos = _walk(ts, spec, value, pos, path + ".", out, ros1)
        elif kind == "BASE":
            typ = spec[0]
            if typ == "string":
                pos = _align(pos, 4) + 4 + len(value.encode()) + (0 if ros1 else 1)
            elif typ in _PRIMITIVES:
                size, np_type = _PRIMITIVES[typ]
                pos = _align(pos, size)
                out[path] = (pos, np_type)
                pos += size
            else:
                raise _NotFixedLayout(f"{msgtype}.{name}: type {typ!r} not supported")
        elif kind in ("ARRAY", "SEQUENCE"):
            (enode, espec), length = spec
            if getattr(enode, "name", str(enode)) != "BASE" or espec[0] not in _PRIMITIVES:
                raise _NotFixedLayout(f"{msgtype}.{name}: arrays of {espec!r} not supported")
            if kind == "SEQUENCE":
                pos = _align(pos, 4) + 4
                length = len(value)
            size = _PRIMITIVES[espec[0]][0]
            if length:
                pos = _align(pos, size) + size * length
        else:
            raise _NotFixedLayout(f"{msgtype}.{name}: node {node!r} not supported")
    return pos


def _set_path(msg: Any, path: str, value: Any) -> None:
    *parents, leaf = path.split(".")
    for p in parents:
        msg = getattr(msg, p)
    setattr(msg, leaf, value)


class FixedLayout:
    """Serializer of many messages that differ from a template only in numeric fields.

    Parameters
    ----------
    ts : rosbags Typestore
        The typestore whose ``serialize_cdr`` (``ros1``: ``serialize_ros1``) defines the
        bytes.
    msgtype : str
        Message type, e.g. ``"sensor_msgs/msg/Imu"``.
    template : message
        An instance holding the constant parts (strings, arrays, constants).
    fields : sequence of str
        Dotted paths of the numeric fields that vary, e.g. ``"header.stamp.sec"``.
    ros1 : bool
        ROS 1 serialization (no alignment, no encapsulation header) instead of CDR.

    Raises
    ------
    _NotFixedLayout
        A field path is not a numeric leaf, the type holds parts this class does not
        lay out, or the bytes of a probe message differ from ``serialize_cdr``'s.
    """

    def __init__(
        self, ts: Any, msgtype: str, template: Any, fields: Sequence[str], ros1: bool = False
    ) -> None:
        self.msgtype = msgtype
        #: The typestore's serializer of one message (``serialize_cdr``/``serialize_ros1``).
        self.serializer = ts.serialize_ros1 if ros1 else ts.serialize_cdr
        head = 0 if ros1 else _CDR_HEADER
        raw = self.serializer(template, msgtype)
        self.template = np.frombuffer(bytes(raw), np.uint8)
        self.size = self.template.size
        leaves: dict[str, tuple[int, str]] = {}
        end = _walk(ts, msgtype, template, 0, "", leaves, ros1)
        if head + end != self.size:
            raise _NotFixedLayout(f"{msgtype}: computed size {head + end} != {self.size}")
        missing = [f for f in fields if f not in leaves]
        if missing:
            raise _NotFixedLayout(f"{msgtype}: not numeric fields {missing}")
        self.fields = tuple(fields)
        self.dtype = np.dtype(
            {
                "names": [f"f{i}" for i in range(len(fields))],
                "formats": [leaves[f][1] for f in fields],
                "offsets": [head + leaves[f][0] for f in fields],
                "itemsize": self.size,
            }
        )
        self._check(template)

    def _check(self, template: Any) -> None:
        """Probe values through both serializers: the same bytes or :class:`_NotFixedLayout`."""
        probe = copy.deepcopy(template)
        values = {}
        for i, f in enumerate(self.fields):
            kind = self.dtype.fields[f"f{i}"][0]
            v = kind.type(i % 2 == 0) if kind.kind == "b" else kind.type(i + 1)
            values[f] = np.array([v], kind)
            _set_path(probe, f, v.item())
        if self.serialize(values)[0] != bytes(self.serializer(probe, self.msgtype)):
            raise _NotFixedLayout(f"{self.msgtype}: probe bytes differ from the typestore's")

    def serialize(self, values: Mapping[str, Any]) -> list[bytes]:
        """The serialized bytes of each message (one per row of the value arrays).

        Parameters
        ----------
        values : mapping
            Field path -> array of the values, all of the same length; every field of
            the layout. Values are cast to the field's type as numpy does (the caller
            checks their range).

        Returns
        -------
        list of bytes
            One serialized message per row.
        """
        n = len(values[self.fields[0]])
        buf = np.tile(self.template, n)
        rec = buf.view(self.dtype)
        for i, f in enumerate(self.fields):
            rec[f"f{i}"] = values[f]
        data = buf.tobytes()
        size = self.size
        return [data[k : k + size] for k in range(0, n * size, size)]
