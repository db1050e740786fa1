"""Direct climb versus detour (the paper's Fig. 1): three routes between two points.

* ``direct``: the straight line, walked facing the goal (turns in place at the ends if
  a start/goal yaw is given). If it breaks a limit it is reported as infeasible with
  the reason, and its energy is still given when it stays on the map.
* ``shortest``: the shortest feasible path - the lattice searched with edge length as
  the weight, under the same limits.
* ``energy_optimal``: :func:`energy_planner.planning.plan` (default ``auto``).

Every energy is :func:`energy_planner.energy.path_energy` of the route's poses with the
same :class:`~energy_planner.energy.MotionCost`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import EnergyPlannerError

__all__ = ["Route", "RouteComparison", "compare_routes", "ROUTE_NAMES"]

#: Route names, in report order.
ROUTE_NAMES = ("direct", "shortest", "energy_optimal")


@dataclass
class Route:
    """One route of a comparison (poses in the working CRS, radians)."""

    name: str
    states: np.ndarray | None
    energy_j: float | None
    distance_m: float | None
    duration_s: float | None
    max_slope_deg: float | None
    feasible: bool
    reason: str | None = None
    saving_vs_direct: float | None = None

    @property
    def energy_wh(self) -> float | None:
        """Energy in Wh."""
        return None if self.energy_j is None else self.energy_j / 3600.0

    def to_dict(self, terrain=None) -> dict[str, Any]:
        """JSON-ready dict (``waypoints`` in the DEM's CRS when ``terrain`` is given)."""
        out: dict[str, Any] = {
            "name": self.name,
            "energy_j": self.energy_j,
            "energy_wh": self.energy_wh,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "max_slope_deg": self.max_slope_deg,
            "feasible": self.feasible,
            "saving_vs_direct": self.saving_vs_direct,
        }
        if self.reason is not None:
            out["reason"] = self.reason
        if terrain is not None and self.states is not None:
            x, y = terrain.from_work(self.states[:, 0], self.states[:, 1])
            out["waypoints"] = [
                {"x": float(a), "y": float(b), "yaw_deg": float(math.degrees(c))}
                for a, b, c in zip(
                    np.atleast_1d(x), np.atleast_1d(y), self.states[:, 2], strict=True
                )
            ]
        return out


@dataclass
class RouteComparison:
    """The three routes and what produced them."""

    routes: list[Route]
    start: tuple[float, float, float | None]
    goal: tuple[float, float, float | None]
    limits: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    def route(self, name: str) -> Route:
        """The route called ``name`` (one of :data:`ROUTE_NAMES`)."""
        for r in self.routes:
            if r.name == name:
                return r
        raise KeyError(f"no route {name!r}; routes: {', '.join(r.name for r in self.routes)}")

    def to_dict(self, terrain=None) -> dict[str, Any]:
        """JSON-ready dict with ``routes`` (one entry per route) and ``limits``."""
        return {
            "routes": [r.to_dict(terrain) for r in self.routes],
            "limits": self.limits,
            "info": self.info,
        }

    def table(self) -> str:
        """A plain-text table of the routes."""

        def f(v, fmt):
            return "-" if v is None else format(v, fmt)

        lines = [
            f"{'route':<15} {'energy J':>10} {'Wh':>7} {'dist m':>8} {'time s':>8} "
            f"{'max slope':>9} {'saving':>7}  feasible"
        ]
        for r in self.routes:
            saving = None if r.saving_vs_direct is None else 100 * r.saving_vs_direct
            lines.append(
                f"{r.name:<15} {f(r.energy_j, '10.0f')} {f(r.energy_wh, '7.2f')} "
                f"{f(r.distance_m, '8.1f')} {f(r.duration_s, '8.0f')} "
                f"{f(r.max_slope_deg, '8.1f')}\u00b0 {f(saving, '6.1f')}%  "
                f"{'yes' if r.feasible else 'no: ' + str(r.reason)}"
            )
        return "\n".join(lines)

    def plot(self, terrain, path: str | Path, title: str | None = None) -> Path:
        """Draw the routes over a hillshade with heading marks; write a PNG."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        path = Path(path)
        x0, y0, dx, dy = terrain.grid
        rows, cols = np.shape(terrain.elevation)
        extent = (x0 - dx / 2, x0 + (cols - 0.5) * dx, y0 + (rows - 0.5) * dy, y0 - dy / 2)
        fig, ax = plt.subplots(figsize=(8, 7))
        try:
            shade = terrain.hillshade()
        except Exception:  # a terrain without hillshade: plain elevation
            shade = terrain.elevation
        ax.imshow(shade, cmap="gray", extent=extent, origin="upper", alpha=0.9)
        cs = ax.contour(
            np.linspace(extent[0], extent[1], cols),
            np.linspace(extent[3], extent[2], rows),
            terrain.elevation,
            levels=12,
            colors="k",
            linewidths=0.4,
            alpha=0.5,
        )
        ax.clabel(cs, fontsize=6, fmt="%.0f")
        colors = {"direct": "tab:blue", "shortest": "tab:green", "energy_optimal": "tab:red"}
        span = max(extent[1] - extent[0], extent[3] - extent[2])
        for r in self.routes:
            if r.states is None:
                continue
            s = r.states
            label = r.name.replace("_", " ")
            if r.energy_j is not None:
                label += f": {r.energy_j / 1000:.1f} kJ, {r.distance_m:.0f} m"
            if not r.feasible:
                label += " (infeasible)"
            widths = {"direct": 2.0, "shortest": 4.5, "energy_optimal": 2.0}
            ax.plot(
                s[:, 0],
                s[:, 1],
                color=colors.get(r.name, "k"),
                lw=widths.get(r.name, 2.0),
                ls="--" if not r.feasible else "-",
                alpha=0.6 if r.name == "shortest" else 1.0,
                label=label,
            )
            # heading marks every ~1/25 of the map
            from energy_planner.planning.refine import densify

            d = densify(s, span / 25)
            ax.quiver(
                d[:, 0],
                d[:, 1],
                np.cos(d[:, 2]),
                np.sin(d[:, 2]),
                color=colors.get(r.name, "k"),
                scale=35,
                width=0.004,
                alpha=0.8,
            )
        ax.plot(*self.start[:2], "o", color="white", mec="k", ms=9, label="start")
        ax.plot(*self.goal[:2], "*", color="gold", mec="k", ms=14, label="goal")
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal")
        ax.ticklabel_format(useOffset=False, style="plain")
        ax.set_xlabel("x (working CRS, m)")
        ax.set_ylabel("y (working CRS, m)")
        ax.set_title(title or "Direct climb vs detour (arrows: robot heading)")
        ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
        return path


def _route_from_states(name, states, terrain, model, cost, direct_energy=None) -> Route:
    from energy_planner.energy import path_energy

    pe = path_energy(terrain, model, states[:, :2], yaw=states[:, 2], cost=cost)
    return Route(
        name=name,
        states=states,
        energy_j=pe.energy_j,
        distance_m=pe.distance_m,
        duration_s=pe.duration_s,
        max_slope_deg=float(pe.segments["max_slope_deg"].max()),
        feasible=True,
    )


def _face_along(states: np.ndarray, start, goal) -> np.ndarray:
    """Poses that walk forward along each segment of ``states`` and turn at corners.

    The shortest path's lattice headings are arbitrary (turning is free for a distance
    metric); a robot taking the shortest route walks it facing forward.
    """
    from energy_planner.planning.lattice import simplify_states

    xy = simplify_states(np.column_stack([states[:, :2], np.zeros(len(states))]))[:, :2]
    xy = xy[np.r_[True, np.any(np.diff(xy, axis=0) != 0, axis=1)]]
    if len(xy) < 2:
        return states
    from energy_planner.energy.path import face_along_poses

    poses = face_along_poses(xy)
    if start[2] is not None:
        poses = np.vstack([[xy[0, 0], xy[0, 1], math.remainder(start[2], 2 * math.pi)], poses])
    if goal[2] is not None:
        poses = np.vstack([poses, [xy[-1, 0], xy[-1, 1], math.remainder(goal[2], 2 * math.pi)]])
    return simplify_states(poses)


def _direct_states(start, goal) -> np.ndarray:
    heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
    poses = []
    if start[2] is not None and abs(math.remainder(start[2] - heading, 2 * math.pi)) > 1e-12:
        poses.append((start[0], start[1], math.remainder(start[2], 2 * math.pi)))
    poses += [(start[0], start[1], heading), (goal[0], goal[1], heading)]
    if goal[2] is not None and abs(math.remainder(goal[2] - heading, 2 * math.pi)) > 1e-12:
        poses.append((goal[0], goal[1], math.remainder(goal[2], 2 * math.pi)))
    return np.array(poses, dtype=float)


def compare_routes(
    terrain,
    model,
    start: Sequence[float],
    goal: Sequence[float],
    *,
    planner: str = "auto",
    time: float = 5.0,
    seed: int = 0,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    speed: float = 0.3,
    yaw_rate: float = 0.5,
    step: float | None = None,
    progress: bool = True,
) -> RouteComparison:
    """Compare the direct line, the shortest feasible path and the energy-optimal path.

    Parameters
    ----------
    terrain : Terrain
        The map.
    model : EnergyModel
        A fitted model.
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the working CRS (metres, radians).
    planner, time, seed, step, progress
        Passed to :func:`energy_planner.planning.plan` for the energy-optimal route
        (``step`` also sets the shortest-path lattice).
    max_slope_deg, max_cross_slope_deg, keep_out
        Limits, applied to all three routes.
    speed, yaw_rate : float
        Nominal walking speed (m/s) and turning rate (rad/s).

    Returns
    -------
    RouteComparison
        ``routes`` in the order ``direct``, ``shortest``, ``energy_optimal``;
        ``saving_vs_direct`` is ``(E_direct - E) / E_direct``.
    """
    from energy_planner.energy import MotionCost
    from energy_planner.model import EnergyModel
    from energy_planner.planning.lattice import lattice_plan
    from energy_planner.planning.limits import check_endpoint, keep_out_violation, make_motion_cost
    from energy_planner.planning.plan import _pose, plan
    from energy_planner.planning.refine import refine_path

    s = _pose(start, "start")
    g = _pose(goal, "goal")
    cost, geoms = make_motion_cost(
        terrain,
        model,
        speed=speed,
        yaw_rate=yaw_rate,
        max_slope_deg=max_slope_deg,
        max_cross_slope_deg=max_cross_slope_deg,
        keep_out=keep_out,
    )
    check_endpoint(cost, terrain, "start", s, geoms)
    check_endpoint(cost, terrain, "goal", g, geoms)
    routes: list[Route] = []

    # direct line
    d_states = _direct_states(s, g)
    try:
        bad = keep_out_violation(d_states, geoms)
        if bad is not None:
            raise EnergyPlannerError(bad)
        direct = _route_from_states("direct", d_states, terrain, model, cost)
    except EnergyPlannerError as exc:
        reason = _direct_reason(cost, d_states, str(exc))
        free = MotionCost(terrain, model, speed, yaw_rate)
        try:
            direct = _route_from_states("direct", d_states, terrain, model, free)
        except EnergyPlannerError:
            direct = Route("direct", d_states, None, None, None, None, False)
        direct.feasible = False
        if direct.max_slope_deg is not None and max_slope_deg is not None:
            reason += f" (the line reaches {direct.max_slope_deg:.1f} deg)"
        direct.reason = reason
    routes.append(direct)

    # shortest feasible path: the distance lattice, then refined off the lattice under a
    # "model" whose energy is the ground distance (power = speed), with the same limits
    try:
        lat = lattice_plan(cost, terrain, s, g, step=step, metric="distance")
        short = _route_from_states("shortest", _face_along(lat.states, s, g), terrain, model, cost)
        dist_cost, _ = make_motion_cost(
            terrain, EnergyModel(["speed"], {"speed": 1.0}), speed=speed, yaw_rate=yaw_rate,
            max_slope_deg=max_slope_deg, max_cross_slope_deg=max_cross_slope_deg,
            keep_out=keep_out,
        )  # fmt: skip
        dist_cost.compile()  # before the refinement's time budget starts
        refined, _ = refine_path(
            dist_cost, short.states, budget=min(2.0, max(time / 4, 0.5)), seed=seed
        )
        try:
            cand = _route_from_states("shortest", _face_along(refined, s, g), terrain, model, cost)
            if keep_out_violation(cand.states, geoms) is None and (
                cand.distance_m < short.distance_m
            ):
                short = cand
        except EnergyPlannerError:
            pass  # facing along the refined path breaks a limit: keep the lattice path
        routes.append(short)
    except EnergyPlannerError as exc:
        routes.append(Route("shortest", None, None, None, None, None, False, str(exc)))

    # energy-optimal path
    try:
        res = plan(
            terrain, model, s, g, planner=planner, time=time, seed=seed, progress=progress,
            step=step, cost=cost, speed=speed, yaw_rate=yaw_rate,
        )  # fmt: skip
        bad = keep_out_violation(res.states, geoms)
        if bad is not None:
            raise EnergyPlannerError(f"the {planner} path enters a keep-out area: {bad}")
        opt = _route_from_states("energy_optimal", res.states, terrain, model, cost)
        info = {"planner": res.planner, "time_s": res.time_s, **res.info}
        # a second start: the shortest route, refined under the energy cost. Local
        # refinement keeps the homotopy class of its start, and the shortest route can
        # lie in a cheaper one than the energy lattice found at its resolution.
        short = routes[-1]
        if short.feasible and short.states is not None:
            alt, _ = refine_path(cost, short.states, budget=min(2.0, max(time / 4, 0.5)), seed=seed)
            cand = _route_from_states("energy_optimal", alt, terrain, model, cost)
            if cand.energy_j < opt.energy_j and keep_out_violation(alt, geoms) is None:
                opt = cand
                info["start"] = "shortest route, refined"
    except EnergyPlannerError as exc:
        opt = Route("energy_optimal", None, None, None, None, None, False, str(exc))
        info = {"planner": planner}
    routes.append(opt)
    # "shortest" is the shortest feasible path found: the energy-optimal one can be
    # shorter than the distance lattice's when the latter could not be refined (refining
    # it off the lattice can hug a slope limit that the face-along yaws then break)
    short = routes[1]
    if (
        opt.feasible
        and short.feasible
        and opt.distance_m is not None
        and short.distance_m is not None
        and opt.distance_m < short.distance_m
    ):
        routes[1] = dataclasses.replace(opt, name="shortest")

    if direct.energy_j:
        for r in routes:
            if r.energy_j is not None:
                r.saving_vs_direct = (direct.energy_j - r.energy_j) / direct.energy_j
    return RouteComparison(
        routes=routes,
        start=s,
        goal=g,
        limits={
            "max_slope_deg": max_slope_deg,
            "max_cross_slope_deg": max_cross_slope_deg,
            "keep_out_areas": len(geoms),
        },
        info=info,
    )


def _direct_reason(cost, states: np.ndarray, fallback: str) -> str:
    """Name the limit the straight line breaks first, with its value."""
    d = np.asarray(states)
    for a, b in zip(d[:-1], d[1:], strict=True):
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(2, int(length / (0.25 * abs(cost.terrain.grid[2]))) + 1)
        for f in np.linspace(0, 1, n):
            x, y = a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])
            v = cost.violation(x, y, b[2])
            if v is not None:
                from energy_planner.planning.limits import fmt_xy

                return f"{v} at {fmt_xy(cost.terrain, x, y)}, {f * length:.1f} m along"
    return fallback
