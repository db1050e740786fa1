"""Nav2 Route Server graphs: sites as nodes, legs as directed edges priced in joules.

The Nav2 Route Server (``nav2_route``) plans over a graph read from a GeoJSON file (its
``GeoJsonGraphFileLoader``; samples in ``nav2_route/graphs/*.geojson`` of
ros-navigation/navigation2). :func:`write_route_graph` writes one:

- a ``FeatureCollection`` (``name``; ``energy_planner_frame``: the frame's transform,
  :meth:`energy_planner.io.ros2.MapFrame.to_dict`, which the loader ignores);
- a node per site: a ``Point`` feature with ``properties.id`` (an unsigned integer),
  ``properties.frame`` and ``properties.metadata`` (the site's name, ...); coordinates in
  that frame, metres;
- a directed edge per ordered pair: a ``MultiLineString`` feature (the leg's path in the
  frame) with ``properties.id``, ``startid``, ``endid`` (node ids), ``cost`` (a number:
  here the leg's energy in J), ``overridable: false`` (the route server's edge scorers
  keep the file's cost) and ``metadata`` (duration, interval, battery chance, ...).

Ids are unique across nodes and edges (nodes 0..n-1, edges from n on). The loader turns
metadata into numbers, booleans, strings, arrays of those and nested objects; it cannot
read ``null``, so a ``None`` value is left out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from energy_planner.errors import WaypointError, WaypointIOError

__all__ = ["route_graph_document", "write_route_graph"]


def _clean(meta: Mapping[str, Any], where: str) -> dict[str, Any]:
    """Metadata the loader reads: None left out, numbers finite, keys strings."""
    out: dict[str, Any] = {}
    for k, v in meta.items():
        if v is None:
            continue
        if isinstance(v, Mapping):
            out[str(k)] = _clean(v, f"{where}.{k}")
        elif isinstance(v, list | tuple):
            out[str(k)] = [_primitive(x, f"{where}.{k}") for x in v if x is not None]
        else:
            out[str(k)] = _primitive(v, f"{where}.{k}")
    return out


def _primitive(v: Any, where: str) -> Any:
    if isinstance(v, bool | str):
        return v
    if isinstance(v, int):
        return int(v)
    try:
        f = float(v)
    except (TypeError, ValueError) as exc:
        raise WaypointError(
            f"{where}: {v!r} is not a number, boolean or string", value=v,
            expected="a number, boolean or string",
        ) from exc  # fmt: skip
    if not math.isfinite(f):
        raise WaypointError(f"{where}: {v!r} is not finite", value=v, expected="a finite number")
    return f


def route_graph_document(
    nodes: Sequence[Mapping[str, Any]],
    edges: Sequence[Mapping[str, Any]],
    frame: Mapping[str, Any],
    *,
    name: str = "energy_planner_mission",
) -> dict[str, Any]:
    """The Nav2 route graph GeoJSON of nodes and directed edges (see the module notes).

    Parameters
    ----------
    nodes : sequence of mapping
        ``xy`` (x, y in the frame, metres) and optional ``metadata``. Node ``i`` gets id
        ``i``.
    edges : sequence of mapping
        ``start``, ``end`` (node indices), ``cost`` (a finite number), ``coordinates``
        (the edge's line in the frame, at least its two ends) and optional
        ``metadata``. Edge ``k`` gets id ``len(nodes) + k``.
    frame : mapping
        The frame (:meth:`energy_planner.io.ros2.MapFrame.to_dict`): its ``frame`` names
        every node's frame.
    name : str
        The collection's name.

    Returns
    -------
    dict

    Raises
    ------
    WaypointError
        No node or no edge (the loader refuses such a graph), an edge naming a node that
        does not exist, a non-finite cost or coordinate, or metadata it cannot read.
    """
    if not nodes or not edges:
        raise WaypointError(
            f"a route graph needs nodes and edges; got {len(nodes)} node(s) and "
            f"{len(edges)} edge(s)",
            value=(len(nodes), len(edges)),
            expected="at least one node and one edge",
        )
    fid = str(frame["frame"])
    features: list[dict[str, Any]] = []
    for i, n in enumerate(nodes):
        x, y = (_primitive(v, f"node {i} coordinates") for v in n["xy"])
        props = {"id": i, "frame": fid, "metadata": _clean(n.get("metadata", {}), f"node {i}")}
        features.append({"type": "Feature", "properties": props,
                         "geometry": {"type": "Point", "coordinates": [x, y]}})  # fmt: skip
    for k, e in enumerate(edges):
        eid = len(nodes) + k
        a, b = int(e["start"]), int(e["end"])
        if not (0 <= a < len(nodes) and 0 <= b < len(nodes)):
            raise WaypointError(
                f"edge {k} joins nodes {a} and {b}; there are {len(nodes)} nodes",
                value=(a, b),
                expected=f"node indices in 0..{len(nodes) - 1}",
            )
        cost = _primitive(e["cost"], f"edge {k} cost")
        line = [[_primitive(v, f"edge {k} coordinates") for v in p[:2]] for p in e["coordinates"]]
        props = {"id": eid, "startid": a, "endid": b, "cost": float(cost), "overridable": False,
                 "metadata": _clean(e.get("metadata", {}), f"edge {k}")}  # fmt: skip
        geometry = {"type": "MultiLineString", "coordinates": [line]}
        features.append({"type": "Feature", "properties": props, "geometry": geometry})
    return {
        "type": "FeatureCollection",
        "name": name,
        "energy_planner_frame": dict(frame),
        "features": features,
    }


def write_route_graph(
    path: str | Path,
    nodes: Sequence[Mapping[str, Any]],
    edges: Sequence[Mapping[str, Any]],
    frame: Mapping[str, Any],
    *,
    name: str = "energy_planner_mission",
) -> Path:
    """Write :func:`route_graph_document` to ``path`` atomically and return the path.

    Raises
    ------
    WaypointIOError
        The file cannot be written.
    """
    from energy_planner.io.atomic import write_json

    doc = route_graph_document(nodes, edges, frame, name=name)
    p = Path(path)
    try:
        return write_json(p, doc)
    except OSError as exc:
        raise WaypointIOError(f"cannot write route graph {str(p)!r}: {exc}", path=p) from exc
