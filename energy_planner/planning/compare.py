"""Direct climb versus detour (the paper's Fig. 1): three routes between two points.

* ``direct``: the straight line, walked facing the goal (turns in place at the ends if
  a start/goal yaw is given). If it breaks a limit it is reported as infeasible with
  the reason, and its energy is still given when it stays on the map.
* ``direct_best_yaw``: the same straight line walked with the body at its cheapest
  constant yaw from the direction of travel (crabbing, as ``plan`` and ``energy`` allow),
  so that the saving of the energy-optimal route splits into gait (``direct`` ->
  ``direct_best_yaw``) and route (``direct_best_yaw`` -> ``energy_optimal``).
* ``shortest``: the shortest feasible path, by distance along the ground: the lattice
  searched with edge length as the weight under the same limits, then refined off the
  lattice under a cost equal to the ground distance (starting also from the straight
  line and from the energy-optimal path, whichever ends shorter), walked facing forward.
* ``energy_optimal``: :func:`energy_planner.planning.plan` (default ``auto``), refined
  again, and the shortest route and the straight line refined under the energy (local
  refinement keeps the homotopy class of its start); each start is also tried walked
  with the cheapest constant body yaw (a model can make crabbing up a slope cheaper than
  facing it, and pose-by-pose refinement cannot reach a whole-path gait change); the
  cheapest is kept.

When two routes are the same path (within a cell everywhere, and with the body turned
the same way within 15 deg), the later one says so
(``same_as``) instead of repeating the other: with no limit the straight line is usually
the shortest feasible path.

Why a detour can save energy without any limit: walking up a grade ``g`` (the sine of the
path's inclination) costs ``c(g)`` joules per metre, so a metre of height costs
``c(g) / g``. When ``c`` is convex (copper losses grow with the square of the force the
legs hold against gravity: ``c = a + b g + k g^2``), ``c(g) / g`` is least at the
critical grade ``g* = sqrt(a / k)``; climbing a hill steeper than ``g*`` costs more per
metre of height than zig-zagging or going round at ``g*``. :func:`grade_cost` computes
``c``, ``g*`` and the closed form from a model; the comparison reports them with each
route's climbing grade.

Every energy is :func:`energy_planner.energy.path_energy` of the route's poses with the
same :class:`~energy_planner.energy.MotionCost`.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.angles import wrap
from energy_planner.errors import EnergyPlannerError, RouteNameError
from energy_planner.request import DEFAULT_SPEED

__all__ = [
    "GradeCost",
    "ROUTE_NAMES",
    "Route",
    "RouteComparison",
    "compare_routes",
    "grade_cost",
]

#: Route names, in report order.
ROUTE_NAMES = ("direct", "direct_best_yaw", "shortest", "energy_optimal")


@dataclass
class GradeCost:
    """The cost per metre of walking straight up a grade, and its critical grade.

    Attributes
    ----------
    grades : ndarray
        Grades ``g`` (sine of the inclination), from 0 up.
    cost_per_m : ndarray
        ``c(g)``: energy per metre along the ground, J/m (power / speed).
    critical_grade : float or None
        ``g*`` minimizing ``c(g) / g`` on the grid (refined by a parabola), or ``None``
        when ``c(g) / g`` keeps falling up to the steepest grade (a detour never pays
        by physics alone).
    quadratic : tuple of float
        ``(a, b, k)`` of the least-squares fit ``c = a + b g + k g^2`` on ``g <= g_fit``.
    closed_form_grade : float or None
        ``sqrt(a / k)`` when ``a > 0`` and ``k > 0``.
    body_yaw : ndarray
        The cheapest yaw of the body relative to the direction of travel at each grade,
        radians, measured in the slope plane like ``gamma`` (0: facing it; +-pi/2:
        sideways).
    """

    grades: np.ndarray
    cost_per_m: np.ndarray
    critical_grade: float | None
    quadratic: tuple[float, float, float]
    closed_form_grade: float | None
    body_yaw: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def per_height(self, g: float) -> float:
        """``c(g) / g``: J per metre of height climbed at grade ``g`` (> 0)."""
        return float(np.interp(g, self.grades, self.cost_per_m)) / g

    @staticmethod
    def deg(g: float | None) -> float | None:
        """A grade as the inclination in degrees (``asin(g)``)."""
        return None if g is None else math.degrees(math.asin(min(max(g, -1.0), 1.0)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        a, b, k = self.quadratic
        yaw = None
        if self.critical_grade is not None and self.body_yaw.size:
            i = int(np.argmin(np.abs(self.grades - self.critical_grade)))
            yaw = abs(math.degrees(float(self.body_yaw[i])))
        return {
            "body_yaw_at_critical_deg": yaw,
            "critical_grade": self.critical_grade,
            "critical_grade_deg": self.deg(self.critical_grade),
            "quadratic_a_b_k": [a, b, k],
            "closed_form_grade": self.closed_form_grade,
            "closed_form_grade_deg": self.deg(self.closed_form_grade),
        }


def grade_cost(
    model,
    speed: float = DEFAULT_SPEED,
    *,
    slope: float | None = None,
    max_grade: float = 0.8,
    fit_max_grade: float = 0.6,
    constants: dict[str, Any] | None = None,
    any_yaw: bool = True,
) -> GradeCost:
    """``c(g)``, the least energy per metre of walking up the fall line at grade ``g``.

    The least over the body's yaw relative to the direction of travel (forward,
    crabbing, sideways, backward: a model can make a diagonal gait cheaper than facing
    the slope), unless ``any_yaw`` is False (facing the direction of travel): the
    project's one cheapest way to move along a heading
    (:func:`energy_planner.energy.heading.heading_cost`, its continuous minimum over the
    yaw) on a plane of the grade's slope, per metre of ground.

    Parameters
    ----------
    model : EnergyModel
        A fitted model.
    speed : float
        Walking speed along the ground, m/s.
    slope : float, optional
        Walk on a plane of this slope (sine of the slope angle) instead of up the fall
        line of each grade: grade ``g <= slope`` is travelled at the relative heading
        ``acos(g / slope)`` from uphill, so cross-slope terms count (a zig-zag or a spiral
        round a cone of that slope climbs this way). ``max_grade`` becomes ``slope``.
    max_grade : float
        Steepest grade evaluated (sine of the inclination).
    fit_max_grade : float
        Steepest grade used for the quadratic fit.
    constants : dict, optional
        Values of extra channels the model reads.
    any_yaw : bool
        Minimise over the body's yaw relative to the travel (else face the travel).

    Returns
    -------
    GradeCost

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> up, sq, other = ("pos(vx) * sin(alpha) * cos(gamma)", "pos(vx) * sin(alpha) ** 2",
    ...                  "pos(-vx) + abs(vy)")  # other gaits: dear
    >>> m = EnergyModel(["pos(vx)", up, sq, other],
    ...                 {"pos(vx)": 600.0, up: 1000.0, sq: 15000.0, other: 20000.0})
    >>> gc = grade_cost(m)
    >>> round(gc.critical_grade, 3), round(gc.closed_form_grade, 3), float(gc.body_yaw[0])
    (0.2, 0.2, 0.0)
    >>> m = EnergyModel(["pos(vx)", up, other], {"pos(vx)": 600.0, up: 1000.0, other: 2e4})
    >>> print(grade_cost(m).critical_grade)
    None
    """
    from energy_planner.energy.heading import heading_cost

    if slope is not None:
        max_grade = fit_max_grade = float(slope)
    g = np.linspace(0.0, max_grade, 801)
    # travel direction relative to uphill, in the slope plane (tau) and on the map (phi)
    tau = np.zeros(g.size) if slope is None else np.arccos(np.clip(g / slope, -1.0, 1.0))
    alpha = np.arcsin(g) if slope is None else np.full(g.size, math.asin(slope))
    phi = np.arctan2(np.sin(tau), np.cos(tau) * np.cos(alpha))
    # the one cheapest way along a heading (any yaw; or facing the travel: no crab, never
    # backward); J per map metre -> per metre of ground
    gait = {} if any_yaw else {"max_crab_deg": 0.0, "max_backward_slope_deg": -1.0}
    hc = heading_cost(model, speed=float(speed), constants=constants, **gait)
    per_map, r = hc.per_metre(np.tan(alpha), 0.0, phi)
    c = per_map / np.hypot(1.0, np.tan(alpha) * np.cos(phi))
    # the body's yaw from the travel, in the slope plane (as gamma is measured)
    theta = phi + r
    yaw = wrap(np.arctan2(np.sin(theta) * np.cos(alpha), np.cos(theta)) - tau)
    per_h = c[1:] / g[1:]
    i = int(np.argmin(per_h))
    crit: float | None
    if i >= per_h.size - 1:
        crit = None
    elif 0 < i:
        # parabola through the three grid points around the minimum
        y0, y1, y2 = per_h[i - 1 : i + 2]
        den = y0 - 2 * y1 + y2
        h = g[2] - g[1]
        crit = float(g[i + 1] + (0.5 * h * (y0 - y2) / den if den > 0 else 0.0))
    else:
        crit = float(g[1])
    m = g <= fit_max_grade
    a, b, k = (float(v) for v in np.polynomial.polynomial.polyfit(g[m], c[m], 2))
    closed = math.sqrt(a / k) if a > 0 and k > 0 else None
    return GradeCost(g, c, crit, (a, b, k), closed, yaw)


def _climb(terrain, states: np.ndarray) -> tuple[float, float | None]:
    """Total ascent (m) and mean climbing grade along a route's positions.

    The grade is ascent / ground length of the climbing parts; ``None`` if the route
    never climbs.
    """
    from energy_planner.planning.refine import densify

    xy = np.column_stack([states[:, :2], np.zeros(len(states))])
    d = densify(xy, 0.25 * abs(float(terrain.grid[2])))
    z = np.asarray(terrain.sample(d[:, 0], d[:, 1]).elevation, float)
    dz = np.diff(z)
    ds = np.sqrt(np.hypot(np.diff(d[:, 0]), np.diff(d[:, 1])) ** 2 + dz**2)
    up = np.isfinite(dz) & (dz > 0)
    ascent = float(dz[up].sum())
    length = float(ds[up].sum())
    return ascent, (ascent / length if length > 0 else None)


@dataclass
class Route:
    """One route of a comparison (poses in the working CRS, radians).

    ``same_as`` names an earlier route of the comparison that is the same path (within
    a cell everywhere, body yaw within 15 deg); ``body_yaw_deg`` is the constant body yaw
    from the direction of travel a route is walked with, where it has one; ``ascent_m``
    is the total climb and ``climb_grade`` the mean grade of its climbing parts (sine of
    the inclination).
    """

    name: str
    states: np.ndarray | None
    energy_j: float | None
    distance_m: float | None
    duration_s: float | None
    max_slope_deg: float | None
    feasible: bool
    reason: str | None = None
    saving_vs_direct: float | None = None
    same_as: str | None = None
    ascent_m: float | None = None
    climb_grade: float | None = None
    body_yaw_deg: float | None = None

    @property
    def energy_wh(self) -> float | None:
        """Energy in Wh."""
        return None if self.energy_j is None else self.energy_j / 3600.0

    @property
    def climb_grade_deg(self) -> float | None:
        """Mean climbing grade as an inclination, degrees."""
        return GradeCost.deg(self.climb_grade)

    def to_dict(self, terrain=None) -> dict[str, Any]:
        """JSON-ready dict (``waypoints`` in the DEM's CRS when ``terrain`` is given)."""
        out: dict[str, Any] = {
            "name": self.name,
            "energy_j": self.energy_j,
            "energy_wh": self.energy_wh,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "max_slope_deg": self.max_slope_deg,
            "ascent_m": self.ascent_m,
            "climb_grade_deg": self.climb_grade_deg,
            "feasible": self.feasible,
            "saving_vs_direct": self.saving_vs_direct,
            "same_as": self.same_as,
            "body_yaw_deg": self.body_yaw_deg,
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

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Route:
        """Inverse of :meth:`to_dict` (without the poses)."""
        g = d.get("climb_grade_deg")
        return cls(
            d["name"], None, d["energy_j"], d["distance_m"], d["duration_s"],
            d["max_slope_deg"], d["feasible"], d.get("reason"), d.get("saving_vs_direct"),
            d.get("same_as"), d.get("ascent_m"),
            None if g is None else math.sin(math.radians(g)), d.get("body_yaw_deg"),
        )  # fmt: skip


@dataclass
class RouteComparison:
    """The three routes and what produced them.

    ``physics`` is :meth:`GradeCost.to_dict` of the model (the critical grade), ``None``
    when the model cannot be evaluated without extra channels.
    """

    routes: list[Route]
    start: tuple[float, float, float | None]
    goal: tuple[float, float, float | None]
    limits: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    physics: dict[str, Any] | None = None

    def route(self, name: str) -> Route:
        """The route called ``name`` (one of :data:`ROUTE_NAMES`).

        Raises
        ------
        RouteNameError
            If there is no such route (a ``KeyError`` too).
        """
        for r in self.routes:
            if r.name == name:
                return r
        raise RouteNameError(f"no route {name!r}; routes: {', '.join(r.name for r in self.routes)}")

    def to_dict(self, terrain=None) -> dict[str, Any]:
        """JSON-ready dict with ``routes`` (one entry per route), ``limits`` and ``physics``."""
        return {
            "routes": [r.to_dict(terrain) for r in self.routes],
            "limits": self.limits,
            "info": self.info,
            "physics": self.physics,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RouteComparison:
        """Rebuild a comparison (without poses) from :meth:`to_dict`'s output."""
        return cls(
            [Route.from_dict(r) for r in d["routes"]], (0.0, 0.0, None), (0.0, 0.0, None),
            d.get("limits", {}), d.get("info", {}), d.get("physics"),
        )  # fmt: skip

    def table(self) -> str:
        """A plain-text table of the routes, then why the detour saves (or not)."""

        def f(v, fmt):
            # a missing value keeps its column's width, so the rows stay aligned
            width = int(fmt.split(".")[0] or 0)
            return "-".rjust(width) if v is None else format(v, fmt)

        def deg(v):
            return " " if v is None else "\u00b0"

        lines = [
            f"{'route':<15} {'energy J':>10} {'Wh':>7} {'dist m':>8} {'time s':>7} "
            f"{'ascent m':>8} {'climb':>6} {'max slope':>9} {'saving':>7}  feasible"
        ]
        for r in self.routes:
            if r.same_as is not None:
                lines.append(f"{r.name:<15} = {r.same_as} (the same path)")
                continue
            saving = None if r.saving_vs_direct is None else 100 * r.saving_vs_direct
            lines.append(
                f"{r.name:<15} {f(r.energy_j, '10.0f')} {f(r.energy_wh, '7.2f')} "
                f"{f(r.distance_m, '8.1f')} {f(r.duration_s, '7.0f')} "
                f"{f(r.ascent_m, '8.1f')} {f(r.climb_grade_deg, '5.1f')}{deg(r.climb_grade_deg)} "
                f"{f(r.max_slope_deg, '8.1f')}{deg(r.max_slope_deg)} {f(saving, '6.1f')}"
                f"{'%' if saving is not None else ' '}  "
                f"{'yes' if r.feasible else 'no: ' + str(r.reason)}"
            )
        lines += ["", *self.explain()]
        return "\n".join(lines)

    def saving_split(self) -> list[str]:
        """Lines splitting the energy-optimal saving into gait and route (paper Fig. 1)."""
        try:
            d, dy, eo = (self.route(n) for n in ("direct", "direct_best_yaw", "energy_optimal"))
        except RouteNameError:
            return []
        if not (d.energy_j and dy.energy_j and eo.energy_j):
            return []
        gait = (d.energy_j - dy.energy_j) / d.energy_j
        route = (dy.energy_j - eo.energy_j) / d.energy_j
        return textwrap.wrap(
            f"Of the {100 * (gait + route):.1f}% saving, {100 * gait:.1f} points are gait (the "
            f"direct line walked with the body turned {dy.body_yaw_deg:+.0f} deg from the "
            f"direction of travel) and {100 * route:.1f} points are the route.",
            width=92,
        )

    def explain(self) -> list[str]:
        """Lines saying why the energy-optimal route saves energy (the model's physics)."""
        p = self.physics
        out = [
            "saving: energy saved against the direct line (negative: costs more); climb: mean",
            "grade of the climbing parts.",
        ]
        out += self.saving_split()
        if p is None:
            return out
        gstar = p.get("critical_grade_deg")
        a, b, k = p["quadratic_a_b_k"]
        fit = f"c(g) ~ {a:.0f} + {b:.0f} g + {k:.0f} g^2 J/m"
        yaw = p.get("body_yaw_at_critical_deg")
        if yaw is not None and yaw > 1.0:
            fit += f" (cheapest gait: body turned {yaw:.0f} deg from the direction of travel)"
        if gstar is None:
            out += textwrap.wrap(
                f"Physics: walking up grade g costs {fit}; per metre of height c(g)/g keeps "
                "falling as g rises, so under this model a detour saves energy only by "
                "avoiding limits or cross-slopes, never by climbing more gently.",
                width=92,
            )
            return out
        closed = p.get("closed_form_grade_deg")
        out += textwrap.wrap(
            f"Physics: walking up grade g costs {fit}. A metre of height costs c(g)/g, "
            f"least at the critical grade g* = {gstar:.1f} deg"
            + (f" (closed form sqrt(a/k): {closed:.1f} deg)" if closed is not None else "")
            + ": the copper losses grow with the square of the force the legs hold against "
            "gravity, so climbing steeper than g* costs more per metre of height than a "
            "longer route at g*.",
            width=92,
        )
        for r in self.routes:
            if r.same_as is None and r.climb_grade_deg is not None and "per_height" in p:
                ph = p["per_height"].get(r.name)
                if ph is not None:
                    out.append(
                        f"  {r.name}: climbs at {r.climb_grade_deg:.1f} deg on average, "
                        f"c(g)/g = {ph:.0f} J per metre of height"
                    )
        return out

    def plot(
        self, terrain, path: str | Path, title: str | None = None, request: Any = None
    ) -> Path:
        """Draw the routes over a hillshade with heading marks; write a PNG.

        ``request`` (the :class:`~energy_planner.request.Request` the routes were planned
        with) adds its keep-outs, slope-limit mask and channel rasters
        (:func:`energy_planner.plotting.draw_request`). The axes name the working CRS.
        """
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
        from energy_planner.plotting import draw_request, label_map_axes

        draw_request(ax, terrain, request)
        colors = {"direct": "tab:blue", "shortest": "tab:green", "energy_optimal": "tab:red"}
        # zoom to the routes (with a margin), within the map
        pts = [np.asarray(r.states)[:, :2] for r in self.routes if r.states is not None]
        pts.append(np.array([self.start[:2], self.goal[:2]], float))
        allp = np.vstack(pts)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        pad = max(25.0, 0.5 * float(np.max(hi - lo)))
        view = (
            max(extent[0], lo[0] - pad), min(extent[1], hi[0] + pad),
            max(extent[2], lo[1] - pad), min(extent[3], hi[1] + pad),
        )  # fmt: skip
        span = max(view[1] - view[0], view[3] - view[2])
        for r in self.routes:
            if r.states is None:
                continue
            s = r.states
            label = r.name.replace("_", " ")
            if r.same_as is not None:
                ax.plot([], [], " ", label=f"{label} = {r.same_as.replace('_', ' ')}")
                continue
            if r.energy_j is not None:
                label += f": {r.energy_j / 1000:.1f} kJ, {r.distance_m:.0f} m"
            if r.climb_grade_deg is not None:
                label += f", climbs at {r.climb_grade_deg:.0f}\u00b0"
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
        ax.set_xlim(view[0], view[1])
        ax.set_ylim(view[2], view[3])
        ax.set_aspect("equal")
        ax.ticklabel_format(useOffset=False, style="plain")
        label_map_axes(ax, terrain.crs)
        title = title or "Direct climb vs detour (arrows: robot heading)"
        if self.physics and self.physics.get("critical_grade_deg") is not None:
            title += (
                f"\ncritical grade g* = {self.physics['critical_grade_deg']:.1f}\u00b0: "
                "climbing steeper costs more per metre of height"
            )
        ax.set_title(title, fontsize=10)
        ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
        fig.tight_layout()
        from energy_planner.io import save_figure

        save_figure(fig, path, dpi=120)
        plt.close(fig)
        return path


def _route(name: str, states: np.ndarray, terrain, model, cost) -> Route:
    """Price ``states`` (raises EnergyPlannerError if a motion breaks a limit)."""
    from energy_planner.energy import path_energy

    pe = path_energy(terrain, model, states[:, :2], yaw=states[:, 2], cost=cost)
    ascent, grade = _climb(terrain, states)
    return Route(
        name=name,
        states=states,
        energy_j=pe.energy_j,
        distance_m=pe.distance_m,
        duration_s=pe.duration_s,
        max_slope_deg=float(pe.segments["max_slope_deg"].max()),
        feasible=True,
        ascent_m=ascent,
        climb_grade=grade,
    )


def _face_along(states: np.ndarray, start, goal) -> np.ndarray:
    """Poses that walk forward along each segment of ``states`` and turn at corners.

    A distance-optimal path's headings are arbitrary (turning is free for a distance
    metric); a robot taking the shortest route walks it facing forward.
    """
    from energy_planner.energy.path import face_along_poses
    from energy_planner.planning.lattice import simplify_states

    xy = simplify_states(np.column_stack([states[:, :2], np.zeros(len(states))]))[:, :2]
    xy = xy[np.r_[True, np.any(np.diff(xy, axis=0) != 0, axis=1)]]
    if len(xy) < 2:
        return states
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


#: Two routes whose body yaws differ by more than this at matching places are not the
#: same path, even along the same line (a crabbed walk is another gait).
SAME_YAW_TOL = math.radians(15.0)


def _same_path(a: Route, b: Route, tol: float, yaw_tol: float = SAME_YAW_TOL) -> bool:
    """True when both routes' poses match.

    Positions within ``tol`` metres everywhere (Hausdorff) and, at every vertex of either,
    the body yaw within ``yaw_tol`` of the other route's nearest vertex.
    """
    from shapely.geometry import LineString, Point

    if a.states is None or b.states is None:
        return False

    def geom(s):
        xy = s[:, :2]
        xy = xy[np.r_[True, np.any(np.diff(xy, axis=0) != 0, axis=1)]]
        return Point(xy[0]) if len(xy) < 2 else LineString(xy)

    if geom(a.states).hausdorff_distance(geom(b.states)) > tol:
        return False
    for p, q in ((a.states, b.states), (b.states, a.states)):
        d = np.hypot(p[:, None, 0] - q[None, :, 0], p[:, None, 1] - q[None, :, 1])
        dyaw = np.remainder(p[:, 2] - q[np.argmin(d, axis=1), 2] + np.pi, 2 * np.pi) - np.pi
        if np.max(np.abs(dyaw)) > yaw_tol:
            return False
    return True


def _best_gait(states: np.ndarray, cost, start, goal) -> tuple[np.ndarray, float]:
    """The path's positions walked with the body at the cheapest constant yaw offset.

    The yaw ``psi`` is measured from the direction of travel (0: facing it); the cheapest
    ``psi`` on a 10 deg grid is used.

    Local refinement moves one pose at a time, so it cannot turn a whole path into a
    crabbing gait (each single yaw change costs two turns first); this offers it whole.
    """
    base = _face_along(states, start, goal)
    fixed = np.zeros(len(base), bool)
    if start[2] is not None:
        fixed[0] = True
    if goal[2] is not None:
        fixed[-1] = True
    best, best_e, best_psi = states, float(np.sum(_edges(cost, states))), 0.0
    for grid in (np.arange(-180.0, 180.0, 10.0), None):
        if grid is None:  # then 1 deg steps about the best of the 10 deg grid
            grid = math.degrees(best_psi) + np.arange(-9.0, 10.0, 1.0)
        for psi in np.radians(grid):
            cand = base.copy()
            cand[~fixed, 2] = np.remainder(cand[~fixed, 2] + psi + np.pi, 2 * np.pi) - np.pi
            e = float(np.sum(_edges(cost, cand)))
            if e < best_e:
                best, best_e, best_psi = cand, e, float(psi)
    return best, best_psi


def _edges(cost, s: np.ndarray) -> np.ndarray:
    return cost.batch(s[:-1, 0], s[:-1, 1], s[:-1, 2], s[1:, 0], s[1:, 1], s[1:, 2])


class _Candidates:
    """Refine several starting paths under one cost; keep the best route by a key.

    ``objective`` prices the refinement (energy, or ground distance for the shortest
    route); every candidate is then walked as ``post(states)`` and priced by
    :func:`_route` with the energy cost and its limits, so that only feasible routes
    (keep-out checked exactly) compete.
    """

    def __init__(self, name, terrain, model, cost, geoms, key, budget, seed, post=None):
        self.name, self.terrain, self.model, self.cost = name, terrain, model, cost
        self.geoms, self.key, self.budget, self.seed = geoms, key, budget, seed
        self.post = post or (lambda s: s)
        self.best: Route | None = None
        self.origin: str | None = None

    def offer(self, states: np.ndarray | None, origin: str, objective=None, gait=None) -> None:
        """Offer ``states`` as a candidate route.

        They are refined under ``objective`` first when given; with ``gait = (start,
        goal)``, first walked with the cheapest constant body yaw.
        """
        from energy_planner.planning.limits import keep_out_violation
        from energy_planner.planning.refine import densify, refine_path

        if states is None:
            return
        if gait is not None:
            states, psi = _best_gait(states, objective or self.cost, *gait)
            if psi:
                origin += f", body turned {math.degrees(psi):.0f} deg"
        tries = [(states, origin)]
        spacing = abs(float(self.terrain.grid[2]))
        # refinement densifies the path first; a path that hugs a limit can break it
        # once resampled, and then cannot be refined (it still competes as it is)
        dense = densify(states, spacing)
        if (
            objective is not None
            and np.isfinite(objective.batch(*dense[:-1].T, *dense[1:].T)).all()
        ):
            refined, _ = refine_path(
                objective, states, budget=self.budget, seed=self.seed, spacing=spacing
            )
            tries.insert(0, (refined, origin + ", refined"))
        for s, why in tries:
            s = self.post(s)
            try:
                r = _route(self.name, s, self.terrain, self.model, self.cost)
            except EnergyPlannerError:
                continue
            if keep_out_violation(s, self.geoms) is not None:
                continue
            if self.best is None or self.key(r) < self.key(self.best) * (1 - 1e-9):
                self.best, self.origin = r, why


def _motion_cost(terrain, model, request, distance: bool = False):
    """The motion cost of ``request`` (robot, limits, channels) and the keep-out polygons.

    The polygons are in the working CRS
    (:func:`energy_planner.planning.limits.make_motion_cost`). With ``distance`` the
    "model" prices the ground distance (power = speed) under the same limits and reads no
    channel.
    """
    import dataclasses

    from energy_planner.model import EnergyModel
    from energy_planner.planning.limits import make_motion_cost

    if distance:
        model = EnergyModel(["speed"], {"speed": 1.0})
        request = dataclasses.replace(request, channels=None)
    return make_motion_cost(terrain, model, request)


def compare_routes(
    terrain,
    model,
    start: Sequence[float],
    goal: Sequence[float],
    request=None,
    *,
    planner: str = "auto",
    time: float = 5.0,
    seed: int = 0,
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
    request : Request, optional
        Robot (speed, yaw rate), limits (slope, cross-slope, keep-out; applied to all
        three routes) and channels; default :class:`energy_planner.request.Request()`.
    planner, time, seed, step, progress
        Passed to :func:`energy_planner.planning.plan` for the energy-optimal route
        (``step`` also sets the shortest-path lattice). Each extra refinement gets
        ``min(2, max(time / 4, 0.5))`` seconds.

    Returns
    -------
    RouteComparison
        ``routes`` in the order ``direct``, ``shortest``, ``energy_optimal``;
        ``saving_vs_direct`` is ``(E_direct - E) / E_direct``; ``physics`` the model's
        critical grade.
    """
    from energy_planner.energy import MotionCost
    from energy_planner.planning.lattice import lattice_plan
    from energy_planner.planning.limits import check_endpoint, keep_out_violation
    from energy_planner.planning.plan import _pose, plan
    from energy_planner.request import Request

    request = Request() if request is None else request
    s = _pose(start, "start")
    g = _pose(goal, "goal")
    cost, geoms = _motion_cost(terrain, model, request)
    check_endpoint(cost, terrain, "start", s, geoms)
    check_endpoint(cost, terrain, "goal", g, geoms)
    lim = request.limits
    budget = min(2.0, max(time / 4, 0.5))
    cell = abs(float(terrain.grid[2]))

    # direct line
    d_states = _direct_states(s, g)
    direct_ok = True
    try:
        bad = keep_out_violation(d_states, geoms)
        if bad is not None:
            raise EnergyPlannerError(bad)
        direct = _route("direct", d_states, terrain, model, cost)
    except EnergyPlannerError as exc:
        direct_ok = False
        reason = _direct_reason(cost, d_states, str(exc))
        free = MotionCost(
            terrain, model, request.robot.speed, request.robot.yaw_rate,
            channels=request.channels,
        )  # fmt: skip
        try:
            direct = _route("direct", d_states, terrain, model, free)
        except EnergyPlannerError:
            direct = Route("direct", d_states, None, None, None, None, False)
        direct.feasible = False
        if direct.max_slope_deg is not None and lim.max_slope_deg is not None:
            reason += f" (the line reaches {direct.max_slope_deg:.1f} deg)"
        direct.reason = reason

    # the same line at its cheapest constant body yaw: the gait part of any saving
    if direct_ok:
        crab, psi = _best_gait(d_states, cost, s, g)
        direct_yaw = _route("direct_best_yaw", crab, terrain, model, cost)
        direct_yaw.body_yaw_deg = round(math.degrees(psi), 1)
        direct.body_yaw_deg = 0.0
    else:
        direct_yaw = Route("direct_best_yaw", None, None, None, None, None, False, direct.reason)

    # the distance-optimal lattice path (same limits), then the energy-optimal plan
    dist_cost, _ = _motion_cost(terrain, model, request, distance=True)
    dist_cost.compile()  # before the refinements' time budgets start
    try:
        lat_states = lattice_plan(cost, terrain, s, g, step=step, metric="distance").states
        lat_error = None
    except EnergyPlannerError as exc:
        lat_states, lat_error = None, str(exc)
    info: dict[str, Any] = {"planner": planner}
    plan_states = None
    plan_error = None
    try:
        res = plan(
            terrain, model, s, g, planner=planner, time=time, seed=seed, progress=progress,
            step=step, cost=cost,
        )  # fmt: skip
        bad = keep_out_violation(res.states, geoms)
        if bad is not None:
            raise EnergyPlannerError(f"the {planner} path enters a keep-out area: {bad}")
        plan_states = res.states
        info.update({k: v for k, v in res.info.items() if k != "request"}, time_s=res.time_s)
    except EnergyPlannerError as exc:
        plan_error = str(exc)

    # shortest: least ground distance over the refined lattice path, the straight line
    # and the energy-optimal path refined under the distance cost
    short = _Candidates(
        "shortest", terrain, model, cost, geoms, lambda r: r.distance_m, budget, seed,
        post=lambda st: _face_along(st, s, g),
    )  # fmt: skip
    short.offer(lat_states, "distance lattice", dist_cost)
    if direct_ok:
        short.offer(d_states, "straight line")
    short.offer(plan_states, "energy-optimal path", dist_cost)

    # energy-optimal: the plan, and the shortest route / straight line refined under energy
    best = _Candidates(
        "energy_optimal", terrain, model, cost, geoms, lambda r: r.energy_j, budget, seed
    )
    best.offer(plan_states, f"plan ({planner})", cost)
    best.offer(plan_states, f"plan ({planner})", cost, gait=(s, g))
    if short.best is not None:
        best.offer(short.best.states, "shortest route", cost, gait=(s, g))
    if direct_ok:
        best.offer(d_states, "straight line", cost, gait=(s, g))
    if best.best is not None and not best.origin.startswith("plan"):
        # the energy refinement of the shortest route can end shorter than it
        short.offer(best.best.states, "energy-optimal route", dist_cost)
        if short.best is not None:
            best.offer(short.best.states, "shortest route")
    info["energy_optimal_from"] = best.origin
    info["shortest_from"] = short.origin

    routes = [direct, direct_yaw]
    for cand, err in ((short, lat_error or plan_error), (best, plan_error or lat_error)):
        if cand.best is None:
            routes.append(Route(cand.name, None, None, None, None, None, False, err))
        else:
            routes.append(cand.best)
    # a route that is the same path as an earlier one says so
    for i in range(1, len(routes)):
        for j in range(i):
            if routes[i].feasible and routes[j].feasible and _same_path(routes[i], routes[j], cell):
                routes[i].same_as = routes[j].name
                break
    if direct.energy_j:
        for r in routes:
            if r.energy_j is not None:
                r.saving_vs_direct = (direct.energy_j - r.energy_j) / direct.energy_j
    physics = None
    try:
        consts = dict(request.channels.constants) if request.channels is not None else None
        gc = grade_cost(model, request.robot.speed, constants=consts)
        physics = gc.to_dict()
        physics["per_height"] = {
            r.name: gc.per_height(r.climb_grade) for r in routes if r.climb_grade
        }
    except EnergyPlannerError:
        pass  # the model needs channels that are not given as constants
    return RouteComparison(
        routes=routes,
        start=s,
        goal=g,
        limits={
            "max_slope_deg": lim.max_slope_deg,
            "max_cross_slope_deg": lim.max_cross_slope_deg,
            "max_backward_slope_deg": lim.max_backward_slope_deg,
            "max_crab_deg": lim.max_crab_deg,
            "keep_out_areas": len(geoms),
        },
        info=info,
        physics=physics,
    )


def _direct_reason(cost, states: np.ndarray, fallback: str) -> str:
    """Name the limit the straight line breaks first, with its value."""
    from energy_planner.planning.limits import fmt_xy

    d = np.asarray(states)
    for a, b in zip(d[:-1], d[1:], strict=True):
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(2, int(length / (0.25 * abs(cost.terrain.grid[2]))) + 1)
        for f in np.linspace(0, 1, n):
            x, y = a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])
            v = cost.violation(x, y, b[2])
            if v is not None:
                return f"{v} at {fmt_xy(cost.terrain, x, y)}, {f * length:.1f} m along"
    return fallback
