"""The results of a route comparison: :class:`Route` and :class:`RouteComparison`.

Each route's poses, energy, length, climb and feasibility; the comparison's JSON form,
text table, the physics explanation of a detour and its map plot. Built by
:func:`energy_planner.planning.compare.compare_routes`.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import RouteNameError
from energy_planner.planning.gradecost import GradeCost
from energy_planner.results import Result, path_first
from energy_planner.trust import Assessed

__all__ = ["ROUTE_NAMES", "Route", "RouteComparison"]

#: Route names, in report order.
ROUTE_NAMES = ("direct", "direct_best_yaw", "shortest", "energy_optimal")


@dataclass(repr=False)
class Route(Result, Assessed):
    """One route of a comparison (poses in the working CRS, radians).

    ``same_as`` names an earlier route of the comparison that is the same path (within
    a cell everywhere, body yaw within 15 deg); ``body_yaw_deg`` is the constant body yaw
    from the direction of travel a route is walked with, where it has one; ``ascent_m``
    is the total climb and ``climb_grade`` the mean grade of its climbing parts (sine of
    the inclination). A feasible route carries its ``assessment`` (interval, domain
    report, battery verdict: :class:`~energy_planner.trust.Assessment`).
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
    assessment: Any = field(default=None, repr=False, compare=False)
    times: np.ndarray | None = field(default=None, repr=False, compare=False)
    segment_distance_m: np.ndarray | None = field(default=None, repr=False, compare=False)
    deadline: dict[str, Any] | None = None

    def speed_profile(self) -> list[dict[str, float]]:
        """Per segment: distance, duration and ground speed, where the route chose its speeds.

        Empty at the nominal speed (:attr:`times` None); see
        :func:`energy_planner.planning.speed.speed_profile`.
        """
        from energy_planner.planning.speed import speed_profile

        if self.states is None:
            return []
        return speed_profile(self.states, self.times, self.segment_distance_m)

    def speed_range_m_s(self) -> tuple[float, float] | None:
        """The least and greatest walking speed of the profile (None without one)."""
        walk = [p["speed_m_s"] for p in self.speed_profile() if p["speed_m_s"] > 0]
        return (min(walk), max(walk)) if walk else None

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
        if self.times is not None and self.states is not None:
            out["times_s"] = [float(v) for v in self.times]
            out["speed_profile"] = self.speed_profile()
        if self.deadline is not None:
            out["deadline"] = dict(self.deadline)
        out.update(self.assessment_dict())
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
            deadline=d.get("deadline"),
        )  # fmt: skip


@dataclass(repr=False)
class RouteComparison(Result):
    """The three routes and what produced them.

    ``physics`` is :meth:`GradeCost.to_dict` of the model (the critical grade), ``None``
    when the model cannot be evaluated without extra channels. ``problem``: the
    terrain, model and request the routes were planned on
    (:class:`~energy_planner.results.Result`), so that the writers need no terrain.
    """

    routes: list[Route]
    start: tuple[float, float, float | None]
    goal: tuple[float, float, float | None]
    limits: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    physics: dict[str, Any] | None = None
    fronts: dict[str, Any] = field(default_factory=dict)

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

    def to_dict(self, terrain: Any = None) -> dict[str, Any]:
        """JSON-ready dict with ``routes`` (one entry per route), ``limits`` and ``physics``.

        Each route's ``waypoints`` in the DEM's CRS when the terrain is known (given, or
        the one the routes were planned on).
        """
        if terrain is None and self.problem is not None:
            terrain = self.problem.terrain
        out = {
            "routes": [r.to_dict(terrain) for r in self.routes],
            "limits": self.limits,
            "info": self.info,
            "physics": self.physics,
        }
        if self.fronts:
            out["fronts"] = {n: f.to_dict(terrain) for n, f in self.fronts.items()}
        return out

    def write_json(self, path: str | Path, terrain: Any = None) -> Path:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict(terrain))

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
        lines += self.speed_lines()
        lines += ["", *self.explain()]
        for name, front in self.fronts.items():
            lines += ["", f"energy-time front of {name}:", *front.text().splitlines()]
        return "\n".join(lines)

    def speed_lines(self) -> list[str]:
        """Lines on the speeds the routes chose and, under a deadline, who arrives in time.

        None at the nominal speed (the table is then as it always was).
        """
        out = []
        timed = [r for r in self.routes if r.same_as is None and r.times is not None]
        if timed:
            sp = self.info.get("speed") or {}
            rng = sp.get("speed_range")
            within = f" within {rng[0]:g}-{rng[1]:g} m/s" if rng else ""
            out.append(f"speed chosen per motion{within}:")
            for r in timed:
                v = r.speed_range_m_s()
                txt = "-" if v is None else f"{v[0]:.2f}-{v[1]:.2f} m/s"
                out.append(f"  {r.name:<15} {txt}")
        d = self.info.get("deadline")
        if d:
            out.append(f"deadline {d['deadline_s']:g} s, each route at its least-energy timing "
                       "in time:")  # fmt: skip
            for c in d.get("candidates", []):
                if c["on_time"]:
                    out.append(f"  {c['route']:<42} {c['energy_j']:>9.0f} J  "
                               f"{c['duration_s']:>7.1f} s  (lambda "
                               f"{c['lambda_j_per_s']:.1f} J/s)")  # fmt: skip
                else:
                    out.append(f"  {c['route']:<42} late: {c['fastest_s']:.1f} s at the top "
                               "speed")  # fmt: skip
            if d.get("energy_optimal_from"):
                out.append(f"  the least energy in time (energy_optimal): "
                           f"{d['energy_optimal_from']}")  # fmt: skip
        return out

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

    def plot_fronts(self, path: str | Path, title: str | None = None) -> Path:
        """Draw the routes' energy-time fronts (:attr:`fronts`), one curve each; a PNG."""
        from energy_planner.planning.speed import plot_fronts

        if not self.fronts:
            raise RouteNameError("no energy-time fronts: compare the routes with pareto=N")
        return plot_fronts(self.fronts, path, title or "Energy-time front of each route "
                           "(labels: lambda, J/s)")  # fmt: skip

    def write_html(self, path: str | Path, problem: Any = None) -> Path:
        """One self-contained HTML page of the routes (:func:`energy_planner.webmap.routes_page`).

        ``problem``: default the :class:`~energy_planner.problem.Problem` they were
        planned on.
        """
        from energy_planner.webmap import routes_page

        return routes_page(self._problem_for(problem), self, path)

    def plot(
        self,
        path: str | Path,
        terrain: Any = None,
        title: str | None = None,
        request: Any = None,
    ) -> Path:
        """Draw the routes over a hillshade with heading marks; write a PNG.

        The request the routes were planned with (or ``request``) adds its keep-outs,
        slope-limit mask and channel rasters (:func:`energy_planner.plotting.draw_request`).
        The map is drawn in the DEM's own CRS (:class:`energy_planner.plotting.MapFrame`:
        degrees for a longitude/latitude DEM), its axes named with their units.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from energy_planner.plotting import MapFrame, draw_request

        path, terrain = path_first(path, terrain)
        terrain, request = self._terrain(terrain), self._request(request)
        path = Path(path)
        frame = MapFrame(terrain)
        rows, cols = frame.shape
        extent = frame.extent
        fig, ax = plt.subplots(figsize=(8, 7))
        try:
            shade = frame.hillshade()
        except Exception:  # a terrain without hillshade: plain elevation
            shade = frame.grid.elevation
        ax.imshow(shade, cmap="gray", extent=extent, origin="upper", alpha=0.9)
        cs = ax.contour(
            np.linspace(extent[0], extent[1], cols),
            np.linspace(extent[3], extent[2], rows),
            frame.grid.elevation,
            levels=12,
            colors="k",
            linewidths=0.4,
            alpha=0.5,
        )
        ax.clabel(cs, fontsize=6, fmt="%.0f m")  # elevation contours
        draw_request(ax, frame, request)
        colors = {"direct": "tab:blue", "shortest": "tab:green", "energy_optimal": "tab:red"}
        # zoom to the routes (with a margin), within the map (working metres)
        x0, y0, dx, dy = terrain.grid
        wrows, wcols = np.shape(terrain.elevation)
        work = (x0 - dx / 2, x0 + (wcols - 0.5) * dx, y0 + (wrows - 0.5) * dy, y0 - dy / 2)
        pts = [np.asarray(r.states)[:, :2] for r in self.routes if r.states is not None]
        pts.append(np.array([self.start[:2], self.goal[:2]], float))
        allp = np.vstack(pts)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        pad = max(25.0, 0.5 * float(np.max(hi - lo)))
        box = (
            max(work[0], lo[0] - pad), min(work[1], hi[0] + pad),
            max(work[2], lo[1] - pad), min(work[3], hi[1] + pad),
        )  # fmt: skip
        span = max(box[1] - box[0], box[3] - box[2])
        view = frame.view(box)
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
            line = ax.plot(
                *frame.xy(s[:, 0], s[:, 1]),
                color=colors.get(r.name, "k"),
                lw=widths.get(r.name, 2.0),
                ls="--" if not r.feasible else "-",
                alpha=0.6 if r.name == "shortest" else 1.0,
                label=label,
            )[0]
            line.set_gid(f"route:{r.name}")
            # heading marks every ~1/25 of the map
            from energy_planner.planning.refine import densify

            d = densify(s, span / 25)
            ax.quiver(
                *frame.directions(d[:, 0], d[:, 1], d[:, 2]),
                color=colors.get(r.name, "k"),
                scale=35,
                width=0.004,
                alpha=0.8,
            )
        ax.plot(*frame.xy(*self.start[:2]), "o", color="white", mec="k", ms=9, label="start")
        ax.plot(*frame.xy(*self.goal[:2]), "*", color="gold", mec="k", ms=14, label="goal")
        ax.set_xlim(view[0], view[1])
        ax.set_ylim(view[2], view[3])
        ax.ticklabel_format(useOffset=False, style="plain")
        frame.finish(ax)
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

    def write_bag(
        self,
        path: Any,
        terrain: Any = None,
        *,
        request: Any = None,
        frame: str = "map",
        storage: str = "mcap",
    ) -> dict[str, Any]:
        """Write each route as a ``nav_msgs/msg/Path`` on its own topic into a ROS 2 bag.

        Topics ``/energy_planner/routes/<name>`` (the routes with poses and an energy:
        an infeasible route has none), each stamped from 0; frame and stamps as
        :meth:`energy_planner.planning.plan.PlanResult.write_bag` (``request``: the one
        the routes were planned with, by default). Returns the frame and conventions.
        """
        from energy_planner.energy.path import write_paths_bag

        paths = [
            (f"/energy_planner/routes/{r.name}", r.states, r.duration_s, f"route {r.name!r}",
             {"route": r.name, "energy_j": r.energy_j, "distance_m": r.distance_m,
              "duration_s": r.duration_s, "same_as": r.same_as})
            for r in self.routes
            if r.states is not None and r.energy_j is not None
        ]  # fmt: skip
        return write_paths_bag(path, paths, self._terrain(terrain), self._request(request),
                               frame=frame, storage=storage)  # fmt: skip
