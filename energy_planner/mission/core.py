"""A mission: several sites visited in the best order, each leg planned and priced.

The energy between every pair of sites comes from **one search per site**: the planner's
own search over (x, y, heading) (the same motions and kernel as
:func:`energy_planner.planning.reach.reach` and :func:`energy_planner.planning.plan`),
stopped once every other site is settled (:mod:`energy_planner.mission.matrix`). The
matrix is asymmetric (uphill is not downhill). The order is then chosen on it
(:mod:`energy_planner.mission.tour`), and each leg of the chosen order is planned with
:func:`energy_planner.planning.plan` for its path; with ``planner="search"`` and
``eps=1`` (the default here) a leg's planned energy equals its matrix entry.

Sites lie on the DEM's cell centres (as :func:`~energy_planner.planning.reach.reach` moves
its start), so that the matrix and the legs price the same poses; the moved distance is
reported. Headings are free at every site.

The per-site searches are independent: with a ``dask.distributed`` client they run in
parallel on its workers (a :class:`~distributed.LocalCluster` or a cluster given by
address), with the same result as the serial loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import PlanningError
from energy_planner.mission.sites import Sites
from energy_planner.mission.tour import order_sites
from energy_planner.problem import takes_problem

__all__ = ["Leg", "MissionResult", "energy_matrix", "mission"]


@dataclass(frozen=True)
class Leg:
    """One leg of a tour: from site ``a`` to site ``b``, planned."""

    a: int
    b: int
    energy_j: float
    matrix_energy_j: float
    distance_m: float
    duration_s: float
    states: np.ndarray = field(repr=False)


@dataclass
class MissionResult:
    """A planned mission: the order, its legs, totals and the energy matrix.

    Attributes
    ----------
    sites : Sites
        The sites (working CRS, on cell centres), names included.
    order : list of int
        Visiting order (site indices; the first is the start).
    legs : list of Leg
        The planned legs in order (with the return leg when ``return_to_start``).
    matrix_j : ndarray, shape (n, n)
        Least energy from row site to column site (one search per site), J.
    method : str
        How the order was chosen.
    return_to_start : bool
        Whether the tour comes back to the first site.
    """

    sites: Sites
    order: list[int]
    legs: list[Leg]
    matrix_j: np.ndarray
    method: str
    return_to_start: bool
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def energy_j(self) -> float:
        """Total planned energy, J."""
        return float(sum(leg.energy_j for leg in self.legs))

    @property
    def distance_m(self) -> float:
        """Total ground distance, m."""
        return float(sum(leg.distance_m for leg in self.legs))

    @property
    def duration_s(self) -> float:
        """Total walking time, s."""
        return float(sum(leg.duration_s for leg in self.legs))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: order, legs, totals, the matrix."""
        names = self.sites.names
        return {
            "order": [names[i] for i in self.order],
            "order_index": list(self.order),
            "method": self.method,
            "return": self.return_to_start,
            "energy_j": self.energy_j,
            "energy_wh": self.energy_j / 3600.0,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "legs": [
                {
                    "from": names[leg.a],
                    "to": names[leg.b],
                    "energy_j": leg.energy_j,
                    "matrix_energy_j": leg.matrix_energy_j,
                    "distance_m": leg.distance_m,
                    "duration_s": leg.duration_s,
                }
                for leg in self.legs
            ],  # fmt: skip
            "sites": self.sites.to_dicts(),
            "matrix_j": [
                [None if not math.isfinite(v) else float(v) for v in row] for row in self.matrix_j
            ],  # fmt: skip
            **self.info,
        }

    def battery(
        self, model, battery_wh: float, reserve_wh: float = 0.0, confidence: float = 0.9
    ) -> dict[str, Any]:
        """The chance of finishing each leg on one battery, and where the reserve is crossed.

        After leg ``k`` the robot has spent the sum of legs ``0..k``; its chance of
        success is :func:`energy_planner.uncertainty.battery_decision` of that sum (the
        model's split-conformal run errors). ``reserve_crossed_at`` names the first leg
        whose chance falls below ``confidence`` (None: the whole tour fits).
        """
        from energy_planner.uncertainty import battery_decision

        out, cum, cum_s, crossed = [], 0.0, 0.0, None
        for k, leg in enumerate(self.legs):
            cum += leg.energy_j
            cum_s += leg.duration_s  # the error model's duration input
            d = battery_decision(model, cum, battery_wh, reserve_wh, confidence, cum_s)
            out.append({"leg": k, "to": self.sites.names[leg.b], "spent_j": cum,
                        "probability": d.probability, "ok": d.ok})  # fmt: skip
            if crossed is None and not d.ok:
                crossed = k
        return {"battery_wh": battery_wh, "reserve_wh": reserve_wh, "confidence": confidence,
                "legs": out, "reserve_crossed_at": crossed,
                "probability": out[-1]["probability"] if out else 1.0}  # fmt: skip

    def to_geojson(self, terrain, *, native: bool = False) -> dict[str, Any]:
        """RFC 7946 FeatureCollection: one LineString per leg and one Point per site."""
        from shapely.geometry import LineString, Point

        from energy_planner.io.geojson import feature_collection

        geoms, props = [], []
        for k, leg in enumerate(self.legs):
            geoms.append(LineString(leg.states[:, :2]))
            props.append({"leg": k, "from": self.sites.names[leg.a],
                          "to": self.sites.names[leg.b], "energy_j": leg.energy_j,
                          "distance_m": leg.distance_m, "duration_s": leg.duration_s})  # fmt: skip
        for i in self.order:
            geoms.append(Point(self.sites.xy[i]))
            props.append({"site": self.sites.names[i], "visit": self.order.index(i)})
        return feature_collection(zip(geoms, props, strict=True), crs=terrain.crs, native=native)

    def plot(self, terrain, path: str | Path, request: Any = None) -> Path:
        """PNG: legs over a hillshade, sites numbered in visiting order.

        ``request`` adds its keep-outs, slope-limit mask and channel rasters
        (:func:`energy_planner.plotting.draw_request`). The axes name the working CRS.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from energy_planner.io import save_figure

        fig, ax = plt.subplots(figsize=(7, 6))
        x0, y0, dx, dy = terrain.grid
        rows, cols = terrain.shape
        ext = (x0 - dx / 2, x0 + (cols - 0.5) * dx, y0 + (rows - 0.5) * dy, y0 - dy / 2)
        im = ax.imshow(np.degrees(terrain.slope), extent=ext, cmap="Greys", origin="upper")
        fig.colorbar(im, ax=ax, label="slope (deg)")
        from energy_planner.plotting import draw_request, label_map_axes

        if draw_request(ax, terrain, request):
            ax.set_xlim(ext[0], ext[1])
            ax.set_ylim(ext[2], ext[3])
        for leg in self.legs:
            ax.plot(leg.states[:, 0], leg.states[:, 1], lw=2)
        for k, i in enumerate(self.order):
            x, y = self.sites.xy[i]
            ax.plot(x, y, "o", color="tab:red")
            ax.annotate(f"{k}: {self.sites.names[i]}", (x, y), textcoords="offset points",
                        xytext=(4, 4))  # fmt: skip
        ax.set_title(f"mission: {self.energy_j / 1000:.1f} kJ, {self.distance_m:.0f} m "
                     f"({self.method})")  # fmt: skip
        from matplotlib.ticker import MaxNLocator, ScalarFormatter

        for axis in (ax.xaxis, ax.yaxis):  # plain metres, no offset or exponent
            fmt = ScalarFormatter(useOffset=False)
            fmt.set_scientific(False)
            axis.set_major_formatter(fmt)
            axis.set_major_locator(MaxNLocator(5))
        ax.tick_params(axis="x", labelrotation=20)
        label_map_axes(ax, terrain.crs)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower left", fontsize=7, framealpha=0.9)
        out = save_figure(fig, path, dpi=110)
        plt.close(fig)
        return out

    def write_bag(
        self,
        path: str | Path,
        terrain,
        *,
        request: Any = None,
        frame: str = "map",
        storage: str = "mcap",
    ) -> dict[str, Any]:
        """Write each leg as a ``nav_msgs/msg/Path`` on its own topic into a ROS 2 bag.

        Topics ``/energy_planner/mission/leg_<k>`` (k = 0, 1, ... in visiting order), so
        that a robot can follow one leg, stop at its site and take the next. The stamps
        run on through the mission (leg ``k`` starts when leg ``k - 1`` ends); frame
        and stamps as :meth:`energy_planner.planning.plan.PlanResult.write_bag`
        (``request``: the one the mission was planned with). Returns the frame and
        conventions.
        """
        from energy_planner.energy.path import vertex_times
        from energy_planner.io.ros2 import write_path_bag

        paths, info, start = {}, {}, 0.0
        names = self.sites.names
        for k, leg in enumerate(self.legs):
            topic = f"/energy_planner/mission/leg_{k}"
            t = vertex_times(
                terrain, leg.states, request, duration_s=leg.duration_s, what=f"leg {k}"
            )
            paths[topic] = (leg.states, start + t)
            info[topic] = {"leg": k, "from": names[leg.a], "to": names[leg.b],
                           "energy_j": leg.energy_j, "distance_m": leg.distance_m,
                           "duration_s": leg.duration_s, "start_s": start}  # fmt: skip
            start += float(t[-1])
        return write_path_bag(path, paths, terrain, frame=frame, storage=storage, info=info)

    def write_nav2_graph(self, path: str | Path, problem: Any, **options: Any) -> dict[str, Any]:
        """Write the sites and legs as a Nav2 Route Server graph (GeoJSON) at ``path``.

        Every ordered pair of sites is a directed edge whose ``cost`` is its energy in J
        (both directions, each with its own cost), with its duration, interval and, with
        a battery, its chance in ``metadata``; the pairs outside the tour are planned on
        ``problem`` (the one the mission was planned on). ``options``: ``eps``,
        ``level``, ``battery_wh``, ``reserve_wh``, ``confidence``, ``frame``,
        ``progress`` (:func:`energy_planner.mission.graph.route_graph`). Returns the
        path, the counts and the frame.
        """
        from energy_planner.mission.graph import write_nav2_graph

        return write_nav2_graph(path, problem, self, **options)


@takes_problem(1)
def energy_matrix(
    problem,
    sites: Sites,
    *,
    n_headings: int = 16,
    max_energy: float | None = None,
    client: Any = None,
    eps: float = 1.0,
    progress: bool = False,
) -> np.ndarray:
    """Least energy between every ordered pair of sites, one search per site.

    Each search stops once every other site is settled, inside a proven window around
    the sites (:func:`energy_planner.mission.matrix.matrix_search`, which also reports
    the window and the states expanded); the entries equal a full search's (with
    ``eps > 1``: at most ``eps`` times it).

    Parameters
    ----------
    problem : Problem
        Terrain, model and request bound once (as for
        :func:`energy_planner.planning.plan`; the older form ``energy_matrix(terrain,
        model, sites, request=None, ...)`` is accepted).
    sites : Sites
        On cell centres (working CRS).
    n_headings : int
        Search headings.
    max_energy : float, optional
        Stop each search at this energy (J); farther sites get ``inf``.
    client : distributed.Client, optional
        Run the searches on this dask cluster's workers (same result as serial).
    eps : float
        Heuristic weight of the searches, as ``plan``'s (1: the least energies).
    progress : bool
        A progress bar over the sites on stderr.

    Returns
    -------
    ndarray, shape (n, n)
        ``E[i, j]``: energy from site i to site j, J (``inf`` unreachable, 0 diagonal).
    """
    from energy_planner.mission.matrix import matrix_search

    res = matrix_search(problem.terrain, problem.model, sites, problem.request,
                        n_headings=n_headings, max_energy=max_energy, client=client,
                        eps=eps, progress=progress)  # fmt: skip
    return res.energy_j


@takes_problem(1)
def mission(
    problem,
    sites: Sites | str | Path,
    *,
    order: str = "best",
    return_to_start: bool = False,
    planner: str = "search",
    eps: float = 1.0,
    n_headings: int = 16,
    client: Any = None,
    progress: bool = False,
) -> MissionResult:
    """Visit several sites in the given or the least-energy order and plan every leg.

    Parameters
    ----------
    problem : Problem
        Terrain, model and request (robot, limits, channels) bound once
        (:class:`energy_planner.problem.Problem`; the older form ``mission(terrain, model,
        sites, request=None, ...)`` is accepted).
    sites : Sites or path
        The sites, or a CSV/GeoJSON file (:func:`energy_planner.mission.read_sites`).
    order : {"best", "given"}
        ``best``: the least-energy order (exact up to
        :data:`~energy_planner.mission.tour.EXACT_MAX_SITES` sites).
    return_to_start : bool
        Come back to the first site.
    planner, eps, n_headings
        The planner for each leg's path (default: the optimal search, whose energy equals
        the matrix's); ``eps`` weighs the matrix's searches too (each entry at most
        ``eps`` times the least energy).
    client : distributed.Client, optional
        Run the per-site searches on a dask cluster.
    progress : bool
        Progress on stderr.

    Returns
    -------
    MissionResult
    """
    from energy_planner.planning.plan import plan

    terrain = problem.terrain
    if not isinstance(sites, Sites):
        from energy_planner.mission.sites import read_sites

        sites = read_sites(sites, terrain)
    sites = sites.on_cells(terrain)
    E = energy_matrix(problem, sites, n_headings=n_headings, client=client, eps=eps,
                      progress=progress)  # fmt: skip
    o, total, method = order_sites(E, order, return_to_start)
    if not math.isfinite(total):
        bad = [(sites.names[i], sites.names[j]) for i in range(len(E)) for j in range(len(E))
               if not math.isfinite(E[i, j])]  # fmt: skip
        raise PlanningError(
            f"no tour visits every site: no path between {bad[:5]} (slope limits, keep-outs "
            "or the map's edge separate them)", value=bad[:5])  # fmt: skip
    pairs = list(zip(o[:-1], o[1:], strict=True))
    if return_to_start and len(o) > 1:
        pairs.append((o[-1], o[0]))
    legs = []
    for a, b in pairs:
        r = plan(problem, tuple(sites.xy[a]), tuple(sites.xy[b]),
                 planner=planner, eps=eps, n_headings=n_headings, progress=progress)  # fmt: skip
        legs.append(Leg(a, b, float(r.energy_j), float(E[a, b]), float(r.distance_m),
                        float(r.duration_s), r.states))  # fmt: skip
    return MissionResult(sites, o, legs, E, method, return_to_start,
                         info={"matrix_energy_j": float(total), "planner": planner})  # fmt: skip
