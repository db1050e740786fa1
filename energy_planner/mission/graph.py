"""A mission's sites and legs as a Nav2 route graph: every ordered pair a priced edge.

The route server then chooses its own routes over the sites with the energies as costs
(uphill and downhill differ, so both directions of a pair are edges with their own
costs). The legs of the mission's tour are reused; every other pair is planned with the
mission's planner (its energy, duration and path), so every edge carries the same facts.
The file format is :mod:`energy_planner.io.nav2`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["route_graph", "write_nav2_graph"]


def route_graph(
    problem: Any,
    result: Any,
    *,
    eps: float = 1.0,
    level: float = 0.9,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
    frame: str = "map",
    progress: bool = False,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], dict[str, Any]]:
    """The nodes, edges and frame of a mission's route graph.

    Parameters
    ----------
    problem : Problem
        The problem the mission was planned on (terrain, model, request).
    result : MissionResult
        The mission.
    eps : float
        The heuristic weight for the pairs outside the tour (as the mission's).
    level : float
        The prediction interval's level.
    battery_wh, reserve_wh, confidence
        With a battery, each edge's chance that a full battery covers it alone
        (:func:`energy_planner.uncertainty.assess.assess`, with the edge's domain report).
    frame : str
        The map frame (:func:`energy_planner.io.ros2.map_frame`).
    progress : bool
        Progress of the pair plans on stderr.

    Returns
    -------
    nodes, edges, frame
        As :func:`energy_planner.io.nav2.route_graph_document` takes them. Edge metadata:
        ``from``, ``to``, ``energy_j`` (= ``cost``), ``matrix_energy_j``, ``distance_m``,
        ``duration_s``, ``interval_j`` (low, high) and ``interval_level`` when the model
        carries run errors, ``battery_chance`` with a battery, ``tour_leg`` for the legs of
        the tour. A pair with no path (infinite matrix entry) has no edge.
    """
    from energy_planner.io.ros2 import map_frame
    from energy_planner.planning.plan import plan
    from energy_planner.progress import reporter
    from energy_planner.trust import Trust
    from energy_planner.uncertainty.assess import assess

    terrain, model = problem.terrain, problem.model
    mf = map_frame(terrain, frame)
    sites, names, E = result.sites, result.sites.names, result.matrix_j
    cx, cy = terrain.from_work(sites.xy[:, 0], sites.xy[:, 1])
    crs_xy = np.column_stack([np.atleast_1d(cx), np.atleast_1d(cy)])
    nodes = [
        {"xy": mf.to_frame(sites.xy[i]).tolist(),
         "metadata": {"name": names[i], "visit": result.order.index(i) if i in result.order
                      else None, "dem_crs_xy": crs_xy[i].tolist()}}
        for i in range(len(sites))
    ]  # fmt: skip
    tour = {(leg.a, leg.b): (k, leg) for k, leg in enumerate(result.legs)}
    pairs = [(a, b) for a in range(len(sites)) for b in range(len(sites))
             if a != b and math.isfinite(E[a, b])]  # fmt: skip
    planner = result.info.get("planner", "search")
    # each edge alone: its interval and the chance a full battery covers it, with the
    # edge's own domain report (the one assessment every result carries)
    want = Trust(level=level, battery_wh=battery_wh, reserve_wh=reserve_wh,
                 confidence=confidence)  # fmt: skip
    rep = reporter(progress)
    bar = rep.bar("graph edges", len(pairs), "pairs")
    edges = []
    try:
        for a, b in pairs:
            k, leg = tour.get((a, b), (None, None))
            if leg is not None:
                states, e_j, dist, dur = leg.states, leg.energy_j, leg.distance_m, leg.duration_s
                dom = leg.domain
            else:
                r = plan(problem, tuple(sites.xy[a]), tuple(sites.xy[b]), planner=planner,
                         eps=eps, progress=False)  # fmt: skip
                states, e_j, dist, dur = r.states, r.energy_j, r.distance_m, r.duration_s
                dom = r.domain
            verdict = assess(model, e_j, duration_s=dur, domain=dom, trust=want)
            iv = verdict.interval
            meta: dict[str, Any] = {
                "from": names[a], "to": names[b], "energy_j": float(e_j),
                "matrix_energy_j": float(E[a, b]), "distance_m": float(dist),
                "duration_s": float(dur), "tour_leg": k,
                "interval_j": None if iv is None else [float(iv.low_j), float(iv.high_j)],
                "interval_level": None if iv is None else float(level),
            }  # fmt: skip
            if verdict.battery is not None:
                meta.update(battery_chance=float(verdict.battery.probability),
                            battery_wh=float(battery_wh), reserve_wh=float(reserve_wh))  # fmt: skip
            elif verdict.battery_refused is not None:
                meta["battery_refused"] = verdict.battery_refused
            edges.append({"start": a, "end": b, "cost": float(e_j),
                          "coordinates": mf.to_frame(states[:, :2]).tolist(),
                          "metadata": meta})  # fmt: skip
            bar.update(1)
    finally:
        bar.close()
    return nodes, edges, mf.to_dict()


def write_nav2_graph(path: str | Path, problem: Any, result: Any, **options: Any) -> dict:
    """Write :func:`route_graph` (``options`` are its keywords) as a Nav2 route graph file.

    Returns
    -------
    dict
        ``path``, ``nodes`` and ``edges`` (counts) and ``frame`` (the frame's transform).
    """
    from energy_planner.io.nav2 import write_route_graph

    nodes, edges, frame = route_graph(problem, result, **options)
    write_route_graph(path, nodes, edges, frame)
    return {"path": str(path), "nodes": len(nodes), "edges": len(edges), "frame": frame}
