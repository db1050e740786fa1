"""``ep.mission``: the mission verb, with the ``mission`` command's keywords.

It lives in the missions package (and :mod:`energy_planner.api` re-exports it) so that
the package, which Python's import system sets as ``energy_planner.mission`` when it is
imported, calls the same verb (:class:`energy_planner.mission._VerbModule`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from energy_planner.problem import REQUEST_KEYS, Problem, verb_doc
from energy_planner.trust import TRUST_KEYS

__all__ = ["mission"]


@verb_doc
def mission(
    dem: Any,
    sites: Any,
    *,
    order: str = "best",
    return_to_start: bool = False,
    eps: float = 1.0,
    client: Any = None,
    model: Any = None,
    request: Any = None,
    speed: float | tuple[float, float] | str | None = None,
    yaw_rate: float | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    level: float = 0.9,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
    planner: str = "auto",
    leg_eps: float | None = None,
    n_headings: int = 16,
    time_budget: float | None = None,
    windows: Any = None,
    progress: bool = False,
):
    """Visit ``sites`` in the least-energy (or given) order (the ``mission`` command).

    Parameters
    ----------
    {dem}
    sites : path, name or Sites
        A CSV ``x,y[,yaw_deg][,name]`` in the DEM's CRS or GeoJSON points
        (``--sites``), a bundled file's name (``"hill_sites"``), or
        :class:`~energy_planner.mission.Sites`. The first site is the start.
    order : {{"best", "given"}}
        ``best``: the least-energy order; ``given``: as listed (``--order``).
    return_to_start : bool
        Come back to the first site (``--return``).
    eps : float
        Heuristic weight of the per-site searches that choose the order (``--eps``).
    client : distributed.Client or str, optional
        Run the per-site searches on a dask cluster, or on the scheduler at this
        address (``--scheduler``).
    {common}
    {trust}
    planner, leg_eps, n_headings
        How each leg is planned (as :func:`plan` plans it).
    time_budget : float, optional
        Seconds for the whole tour (``--time-budget``): the order and each leg's route and
        speeds chosen together, the least energy in time (energy + lambda x time, one
        ``lambda`` for every leg, by bisection); speeds within ``speed`` (default
        ``"auto"``).
    windows : mapping or sequence, optional
        Per-site arrival windows in seconds from the start, ``{{name: (after, before)}}``
        (None: an open end) or one pair per site; default the sites file's
        ``arrive_after`` / ``arrive_before``. The order and each leg's speeds keep every
        window; a robot early at a site waits at the model's standing power
        (:mod:`energy_planner.mission.windows`).
    progress : bool
        Progress on stderr.

    Notes
    -----
    ``speed`` is a fixed speed (m/s, ``--speed V``) or a range each motion of the matrix's
    searches and of the legs chooses its least-energy speed from, ``(vmin, vmax)`` or
    ``"auto"`` (``--speed MIN:MAX``, ``--speed auto``).

    Returns
    -------
    MissionResult
        Remembers its Problem: ``write_geojson(path)``, ``plot(path)``,
        ``write_bag(path)``, ``write_html(path)``, ``write_nav2_graph(path)``,
        ``write_json(path)``.
    """
    given = {k: v for k, v in locals().items() if k in REQUEST_KEYS}
    choice = {"time_budget": time_budget, "windows": windows}
    if speed is not None and not isinstance(speed, int | float):
        choice["speed"] = given.pop("speed")  # a range: chosen per motion
    trust = {k: v for k, v in locals().items() if k in TRUST_KEYS}
    from energy_planner.maps import resolve
    from energy_planner.mission import mission as _mission  # the planner (core.mission)

    prob = Problem.coerce(dem, model, request, **given)  # a DEM file or a bundled name
    if isinstance(sites, str | Path):
        sites = resolve(sites)  # a file, or a bundled file's name ("hill_sites")
    own = None
    if isinstance(client, str):
        from distributed import Client

        client = own = Client(client)
    try:
        res = _mission(prob, sites, order=order, return_to_start=return_to_start, eps=eps,
                       client=client, planner=planner, leg_eps=leg_eps, n_headings=n_headings,
                       progress=progress, **choice, **trust)  # fmt: skip
    finally:
        if own is not None:
            own.close()
    res.problem = prob
    return res
