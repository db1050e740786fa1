"""Planning and reach on DEMs larger than memory: windows proven to hold the answer.

A DEM whose working set would pass the memory cap
(:func:`energy_planner.terrain.memory_cap`, :data:`PLAN_BYTES_PER_CELL` bytes per cell
for the search) is never loaded whole. :func:`plan_in_corridor` reads a window around
the start and the goal (rasterio windowed read through
:func:`~energy_planner.terrain.load_dem`), plans in it, and then proves or widens it:

- ``c_min`` is a lower bound of the energy per metre of any translation on the DEM:
  the least J/m of :func:`~energy_planner.planning.search.gradient_table` over the box
  of gradients the DEM holds (a streaming pass over the raster in strips of rows,
  :func:`gradient_box`), or over the slope limit's box when a slope limit is set.
  Turns in place cost >= 0.
- A path of energy at most ``E`` has length at most ``E / c_min``, so each of its points
  ``p`` satisfies ``|s p| + |p g| <= E / c_min``: it lies in the ellipse with foci at the
  start and the goal. With ``E`` the energy of the window's path (a feasible path of the
  whole map), every path that could beat it lies in that ellipse.
- If the ellipse (plus a margin of :data:`PAD_CELLS` cells for Horn's stencil and the
  kernel's bilinear sampling) lies inside the window, the window's search saw every
  candidate: its answer is the one the whole-map search would give (optimal on the
  primitives with ``eps = 1``, at most ``eps`` times the optimum otherwise). If not, the
  window grows to the ellipse's bounding box and the search runs again, which then
  proves it; when that box would pass the cap, the largest window that fits is planned
  and the result says that it is not proven, with the bound.

Cells on a window's border have no Horn gradient (NaN), so they are impassable in the
window: a window can only make paths dearer, never cheaper than on the whole map, and
every path it returns is feasible on the whole map with the same energy.

:func:`reach_in_window` does the same for ``reach`` with a budget: a cell within the
budget ``B`` lies at most ``B / c_min`` from the start (``B / (2 c_min)`` for the round
trip), so the disc of that radius holds every path that matters; cells costing more
than the budget are left nodata (their value in the window would only be an upper
bound).

The corridor needs a projected DEM (metres): on a longitude/latitude DEM the windows
would be warped one by one to UTM; warp the DEM once instead
(``gdalwarp -t_srs EPSG:326zz``), as the error says.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.energy.kernels import IN_TMAX
from energy_planner.errors import (
    DEMError,
    InvalidStateError,
    PlanningError,
    RasterTooLargeError,
)
from energy_planner.problem import Problem
from energy_planner.terrain.memory import DEFAULT_CAP, Cap, resolve_cap

__all__ = [
    "PAD_CELLS",
    "PLAN_BYTES_PER_CELL",
    "RasterInfo",
    "ellipse_box",
    "gradient_box",
    "least_cost_per_metre",
    "needs_window",
    "needs_windows",
    "plan_in_corridor",
    "raster_info",
    "reach_in_window",
]

#: Peak bytes per DEM cell of the default planner (terrain, gradient, 16-heading search
#: state, heuristic; ``benchmarks/bench_planning_scale.py``: 1.58 GB on 3200 x 3200
#: including the interpreter), rounded up.
PLAN_BYTES_PER_CELL = 160
#: Cells kept between the proven region and a window's inner edge (Horn's 3 x 3 stencil
#: makes the outer ring NaN; the kernel samples gradients bilinearly between cells).
PAD_CELLS = 3
#: Rows read per strip by :func:`gradient_box` are chosen to hold about this many cells.
STRIP_CELLS = 4_000_000


@dataclass(frozen=True)
class RasterInfo:
    """What the header of a DEM says (nothing decoded).

    Attributes
    ----------
    path : str
        The file.
    shape : (int, int)
        Rows, columns.
    transform : affine.Affine
        Geotransform (north-up).
    crs : rasterio.crs.CRS or None
        The DEM's CRS.
    band : int
        The band planned on.
    """

    path: str
    shape: tuple[int, int]
    transform: Any
    crs: Any
    band: int

    @property
    def cell(self) -> float:
        """Cell size in metres (the larger side)."""
        return max(abs(float(self.transform.a)), abs(float(self.transform.e)))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` outer bounds."""
        t = self.transform
        rows, cols = self.shape
        xs = (t.c, t.c + t.a * cols)
        ys = (t.f, t.f + t.e * rows)
        return (min(xs), min(ys), max(xs), max(ys))

    def snap(self, box: Sequence[float]) -> tuple[float, float, float, float]:
        """``box`` grown to whole cells and clipped to the raster (its CRS)."""
        x0, y0, x1, y1 = self.bounds
        a, e = abs(float(self.transform.a)), abs(float(self.transform.e))
        bx0 = x0 + math.floor((max(box[0], x0) - x0) / a + 1e-9) * a
        bx1 = x0 + math.ceil((min(box[2], x1) - x0) / a - 1e-9) * a
        by1 = y1 - math.floor((y1 - min(box[3], y1)) / e + 1e-9) * e
        by0 = y1 - math.ceil((y1 - max(box[1], y0)) / e - 1e-9) * e
        return (bx0, by0, max(bx1, bx0 + a), max(by1, by0 + e))

    def cells(self, box: Sequence[float]) -> int:
        """Number of cells of the snapped ``box``."""
        b = self.snap(box)
        a, e = abs(float(self.transform.a)), abs(float(self.transform.e))
        return round((b[2] - b[0]) / a) * round((b[3] - b[1]) / e)

    def inside(self, inner: Sequence[float], window: Sequence[float], pad: int) -> bool:
        """True if ``inner`` lies ``pad`` cells inside ``window`` (raster edges excepted)."""
        m = pad * self.cell
        x0, y0, x1, y1 = self.bounds
        tol = 1e-6 * self.cell
        ok_left = inner[0] - m >= window[0] - tol or window[0] <= x0 + tol
        ok_bottom = inner[1] - m >= window[1] - tol or window[1] <= y0 + tol
        ok_right = inner[2] + m <= window[2] + tol or window[2] >= x1 - tol
        ok_top = inner[3] + m <= window[3] + tol or window[3] >= y1 - tol
        return ok_left and ok_bottom and ok_right and ok_top


def raster_info(path: str | Path, band: int | None = None) -> RasterInfo:
    """Read a DEM's header; a longitude/latitude DEM is refused with the warp to use.

    Raises
    ------
    DEMIOError
        The file does not exist or cannot be opened.
    DEMError
        Several bands and no ``band``; a geographic or rotated raster.
    """
    from energy_planner.terrain.dem import utm_epsg
    from energy_planner.terrain.load import open_dem
    from energy_planner.terrain.native import metric_scale
    from energy_planner.terrain.raster import band_reading

    name = str(path)
    with open_dem(name) as src:
        if band is None:
            if src.count != 1:
                raise DEMError(
                    f"DEM {name!r} has {src.count} bands; choose one with --band N, "
                    f"N in 1..{src.count}",
                    path=name,
                    value=src.count,
                    param="band",
                    expected=f"a band in 1..{src.count}",
                )
            band = 1
        t = src.transform
        if t.b != 0 or t.d != 0:
            raise DEMError(
                f"DEM {name!r} has a rotated/sheared geotransform; expected north-up",
                path=name,
                value=tuple(t)[:6],
                expected="a north-up geotransform",
            )
        if src.crs is not None and not metric_scale(src.crs, src.bounds, name).metric:
            from rasterio.warp import transform_bounds

            lon0, lat0, lon1, lat1 = transform_bounds(src.crs, "EPSG:4326", *src.bounds)
            epsg = utm_epsg(0.5 * (lon0 + lon1), 0.5 * (lat0 + lat1))
            raise DEMError(
                f"DEM {name!r} ({src.height} x {src.width} cells) is in {src.crs}, whose "
                "units are not ground metres, and too large to load whole: planning by "
                "windows needs a DEM in ground metres (UTM). Warp it once: gdalwarp -t_srs "
                f"EPSG:{epsg} -r bilinear {name} dem_utm.tif",
                path=name,
                value=str(src.crs),
                crs=str(src.crs),
                expected="a projected CRS in metres",
                hint=f"gdalwarp -t_srs EPSG:{epsg}",
            )
        band_reading(src, int(band), name)  # a unit or scale it cannot read: said now
        return RasterInfo(name, (src.height, src.width), t, src.crs, int(band))


def needs_window(info: RasterInfo, cap: Cap = DEFAULT_CAP) -> bool:
    """True if planning on the whole DEM would pass the memory cap ``cap``.

    ``cap``: bytes, :data:`~energy_planner.terrain.memory.DEFAULT_CAP` or
    :data:`~energy_planner.terrain.memory.NO_CAP` (:func:`~energy_planner.terrain.memory.
    resolve_cap`).
    """
    return _over_cap(*info.shape, cap)


def _over_cap(rows: int, cols: int, cap: Cap) -> bool:
    return float(rows) * cols * PLAN_BYTES_PER_CELL > resolve_cap(cap)


def gradient_box(info: RasterInfo, *, progress: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
    """Least and greatest Horn gradient ``(dz/dx, dz/dy)`` over the DEM, read in strips.

    Each strip of rows is read with one row of overlap on either side, so every cell gets
    the gradient :func:`~energy_planner.terrain.horn.horn_gradient` gives on the whole
    raster; memory stays at about :data:`STRIP_CELLS` cells.

    Returns
    -------
    lo, hi : ndarray, shape (2,)
        Component-wise minimum and maximum gradient (m/m, east and north).
    valid : int
        Cells with a gradient.

    Raises
    ------
    DEMError
        No cell has a gradient (all nodata).
    """
    import rasterio
    from rasterio.windows import Window

    from energy_planner.terrain.horn import horn_gradient
    from energy_planner.terrain.raster import band_reading

    rows, cols = info.shape
    step = max(8, STRIP_CELLS // max(cols, 1))
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    valid = 0
    bar = None
    if progress is not False:
        from energy_planner.progress import reporter

        bar = reporter(progress).bar("gradient range (strips)", rows, "rows")
    # a small GDAL block cache: the pass reads every block once (the default cache, 5 % of
    # the memory, would fill up with blocks that are never read again)
    with rasterio.Env(GDAL_CACHEMAX=64), rasterio.open(info.path) as src:
        reading = band_reading(src, info.band, info.path, scan=True)
        for r0 in range(0, rows, step):
            r1 = min(rows, r0 + step)
            a, b = max(0, r0 - 1), min(rows, r1 + 1)
            z = reading.read(src, window=Window(0, a, cols, b - a))
            gx, gy = horn_gradient(z, float(info.transform.a), float(info.transform.e))
            k0, k1 = r0 - a, r0 - a + (r1 - r0)
            gx, gy = gx[k0:k1], gy[k0:k1]
            ok = np.isfinite(gx) & np.isfinite(gy)
            n = int(ok.sum())
            if n:
                valid += n
                lo = np.minimum(lo, [gx[ok].min(), gy[ok].min()])
                hi = np.maximum(hi, [gx[ok].max(), gy[ok].max()])
            if bar is not None:
                bar.update(r1 - r0)
    if bar is not None:
        bar.close()
    if valid == 0:
        raise DEMError(
            f"DEM {info.path!r} has no cell with a gradient (all nodata, or holes everywhere)",
            path=info.path,
            expected="valid elevations",
        )
    return lo, hi, valid


def least_cost_per_metre(
    cost, lo: Sequence[float], hi: Sequence[float], n_headings: int = 16, moves: str = "all"
) -> float:
    """Lower bound of J per metre of any translation on gradients in ``lo .. hi``.

    The minimum of :func:`~energy_planner.planning.search.gradient_table` over move
    directions, headings and the gradient box; 0 when the cost reads channel rasters
    (they vary over the map, so no constant-gradient table bounds them).
    """
    from energy_planner.planning.moves import lattice_headings, move_table
    from energy_planner.planning.search import BOUND_MARGIN, gradient_table

    if getattr(getattr(cost, "channels", None), "rasters", None):
        return 0.0
    headings = lattice_headings(int(n_headings))
    table, _ = gradient_table(
        cost, headings, move_table(headings, moves), np.asarray(lo), np.asarray(hi)
    )
    fin = table[np.isfinite(table)]
    return float(fin.min()) * BOUND_MARGIN if fin.size else 0.0


def ellipse_box(
    start: Sequence[float], goal: Sequence[float], length: float
) -> tuple[float, float, float, float]:
    """Bounding box of the points ``p`` with ``|s p| + |p g| <= length``.

    Examples
    --------
    >>> [round(v, 6) for v in ellipse_box((0, 0), (6, 0), 10)]
    [-2.0, -4.0, 8.0, 4.0]
    """
    sx, sy = float(start[0]), float(start[1])
    gx, gy = float(goal[0]), float(goal[1])
    f = 0.5 * math.hypot(gx - sx, gy - sy)
    a = max(0.5 * float(length), f)
    b = math.sqrt(max(a * a - f * f, 0.0))
    th = math.atan2(gy - sy, gx - sx)
    hx = math.sqrt((a * math.cos(th)) ** 2 + (b * math.sin(th)) ** 2)
    hy = math.sqrt((a * math.sin(th)) ** 2 + (b * math.cos(th)) ** 2)
    cx, cy = 0.5 * (sx + gx), 0.5 * (sy + gy)
    return (cx - hx, cy - hy, cx + hx, cy + hy)


def _window_cells(cap: Cap) -> tuple[int | None, int]:
    """The cap in bytes (None: no cap) and the most cells a window may hold."""
    limit = resolve_cap(cap)
    if math.isinf(limit):
        return None, sys.maxsize  # no cap: a window may hold any number of cells
    return int(limit), int(limit // PLAN_BYTES_PER_CELL)


def _check_inside(info: RasterInfo, which: str, x: float, y: float) -> None:
    """:class:`InvalidStateError` if ``(x, y)`` is outside the DEM's bounds."""
    x0, y0, x1, y1 = info.bounds
    if not (x0 <= x <= x1 and y0 <= y <= y1):
        from energy_planner.errors import extent_text
        from energy_planner.planning.limits import outside_map

        raise outside_map(which, x, y, f"DEM {info.path!r}, which covers "
                          f"{extent_text((x0, y0, x1, y1), info.crs)}")  # fmt: skip


def _grow(box: Sequence[float], m: float) -> tuple[float, float, float, float]:
    return (box[0] - m, box[1] - m, box[2] + m, box[3] + m)


def _fit_cap(
    info: RasterInfo, box: Sequence[float], must: Sequence[float], max_cells: int
) -> tuple[float, float, float, float] | None:
    """``box`` shrunk about its centre until it fits ``max_cells`` (still covering ``must``)."""
    if info.cells(box) <= max_cells:
        return info.snap(box)
    cx, cy = 0.5 * (box[0] + box[2]), 0.5 * (box[1] + box[3])
    hx, hy = 0.5 * (box[2] - box[0]), 0.5 * (box[3] - box[1])
    lo, hi = 0.0, 1.0
    for _ in range(40):
        k = 0.5 * (lo + hi)
        cand = (cx - k * hx, cy - k * hy, cx + k * hx, cy + k * hy)
        cand = (
            min(cand[0], must[0]),
            min(cand[1], must[1]),
            max(cand[2], must[2]),
            max(cand[3], must[3]),
        )
        if info.cells(cand) <= max_cells:
            lo = k
        else:
            hi = k
    cand = (cx - lo * hx, cy - lo * hy, cx + lo * hx, cy + lo * hy)
    cand = (min(cand[0], must[0]), min(cand[1], must[1]), max(cand[2], must[2]),
            max(cand[3], must[3]))  # fmt: skip
    return info.snap(cand) if info.cells(cand) <= max_cells else None


@dataclass
class _Log:
    show: Any
    lines: list[str] = field(default_factory=list)

    def __call__(self, text: str) -> None:
        self.lines.append(text)
        if self.show is not False:
            from energy_planner.progress import reporter

            reporter(self.show).say(text, stage="corridor")


def _too_large(info: RasterInfo, what: str, cells: int, max_cells: int, cap: int, hint: str):
    from energy_planner.terrain.memory import format_bytes

    return RasterTooLargeError(
        f"DEM {info.path!r} ({info.shape[0]} x {info.shape[1]} cells) is too large to plan "
        f"on whole, and {what} needs a window of {cells} cells "
        f"({format_bytes(cells * PLAN_BYTES_PER_CELL)} at {PLAN_BYTES_PER_CELL} bytes per "
        f"cell), above the memory cap {format_bytes(cap)} ({max_cells} cells). Hint: {hint}",
        path=info.path,
        shape=info.shape,
        size_bytes=int(cells * PLAN_BYTES_PER_CELL),
        cap_bytes=int(cap),
        hint=hint,
        expected=f"a window of at most {max_cells} cells",
    )


def _bound(cost, info, n_headings, moves, log, progress) -> tuple[float, list]:
    """``c_min`` and the gradient box it was taken over."""
    tmax = float(cost.data[IN_TMAX])
    if math.isfinite(tmax):
        lo, hi = np.array([-tmax, -tmax]), np.array([tmax, tmax])
        log(f"gradient box from the slope limit: |dz/dx|, |dz/dy| <= {tmax:.3f}")
    else:
        t0 = time.perf_counter()
        lo, hi, _ = gradient_box(info, progress=progress)
        log(
            f"gradient box of the whole DEM (read in strips, {time.perf_counter() - t0:.1f} s): "
            f"dz/dx {lo[0]:.3f}..{hi[0]:.3f}, dz/dy {lo[1]:.3f}..{hi[1]:.3f}"
        )
    c_min = least_cost_per_metre(cost, lo, hi, n_headings, moves)
    return c_min, [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])]


def needs_windows(dem: str | Path, cap: Cap = DEFAULT_CAP) -> bool:
    """True if planning on the whole of ``dem`` would pass the memory cap (header only).

    ``cap`` as :func:`~energy_planner.terrain.memory.resolve_cap` reads it (default: the
    default cap). A file rasterio cannot open returns False, so that loading it reports
    the problem.
    """
    import rasterio

    try:
        with rasterio.open(dem) as src:
            shape = (src.height, src.width)
    except Exception:  # noqa: BLE001 - any open error is the loader's to report
        return False
    return _over_cap(*shape, cap)


def _first_window(info: RasterInfo, s, g, margin: float, max_cells: int, cap):
    """The box the start and the goal need (``must``) and the first window around it.

    Raises
    ------
    RasterTooLargeError
        Even ``must`` passes the cap.
    """
    sg = (min(s[0], g[0]), min(s[1], g[1]), max(s[0], g[0]), max(s[1], g[1]))
    must = _grow(sg, PAD_CELLS * info.cell)
    if info.cells(must) > max_cells:
        raise _too_large(
            info, "the box of the start and the goal", info.cells(must), max_cells, cap,
            "plan through intermediate goals (each leg's box must fit), a coarser DEM "
            "(gdalwarp -tr XRES YRES -r average), or raise ENERGY_PLANNER_MEMORY_CAP",
        )  # fmt: skip
    dist = math.hypot(g[0] - s[0], g[1] - s[1])
    window = _fit_cap(info, _grow(sg, max(margin * dist, 32 * info.cell)), must, max_cells)
    return must, window


def _widen_unreachable(info: RasterInfo, window, must, max_cells: int, exc: PlanningError):
    """The window doubled (within the cap) after it held no path; ``exc`` if it cannot grow."""
    if tuple(window) == tuple(info.snap(info.bounds)):
        raise exc
    bigger = _fit_cap(
        info, _grow(window, max(window[2] - window[0], window[3] - window[1])), must, max_cells
    )
    if bigger is None or info.cells(bigger) <= info.cells(window):
        raise PlanningError(
            f"{exc} (in the largest window that fits the memory cap, "
            f"{info.cells(window)} cells; the whole DEM was not searched)",
            limit="unreachable",
        ) from exc
    return bigger


def _widen_to_ellipse(
    info: RasterInfo, ell, window, must, max_cells: int, attempt: int, energy_j: float,
    length_bound: float, log: _Log,
):  # fmt: skip
    """The next window: the ellipse's box, or the largest that fits; None to stop."""
    need = info.snap(_grow(ell, PAD_CELLS * info.cell + info.cell))
    if info.cells(need) <= max_cells:
        if attempt > 0 and tuple(need) == tuple(window):
            return None
        log(
            f"paths under {energy_j:.0f} J may reach {length_bound:.0f} m: widening "
            "the window to their ellipse"
        )
        return need
    bigger = _fit_cap(info, need, must, max_cells)
    if bigger is None or info.cells(bigger) <= info.cells(window) or attempt > 0:
        return None
    log(
        f"the ellipse of paths under {energy_j:.0f} J needs {info.cells(need)} cells, "
        "above the cap: planning once more in the largest window that fits"
    )
    return bigger


def _cost_and_bound(problem, info, n_headings, moves, log, progress):
    """The first window's motion cost compiled; ``c_min`` and its gradient box."""
    cost = problem.cost.compile()
    c_min, gbox = _bound(cost, info, n_headings, moves, log, progress)
    log(f"least energy per metre anywhere on the DEM: c_min = {c_min:.2f} J/m")
    return c_min, gbox


def _keep_last_path(exc: PlanningError, have_path: bool, log: _Log) -> bool:
    """True to stop on a window's time-out with a path; re-raise all but "unreachable"."""
    if getattr(exc, "limit", None) == "time" and have_path:
        log("the time budget ran out in this window: keeping the last window's path")
        return True
    if getattr(exc, "limit", None) not in ("unreachable",) or isinstance(exc, InvalidStateError):
        raise exc
    return False


def _time_left(budget: float, t_start: float, have_path: bool) -> float:
    """Seconds of the ``time`` budget left (<= 0: stop and keep the path found so far).

    Raises
    ------
    PlanningError
        The budget ran out before any window was planned.
    """
    left = budget - (time.perf_counter() - t_start)
    if left <= 0 and not have_path:
        raise PlanningError(
            f"the planning time budget ({budget:g} s) ran out before the first "
            "window was planned; give more --time",
            limit="time",
        )
    return left


def plan_in_corridor(
    dem: str | Path,
    model,
    start: Sequence[float],
    goal: Sequence[float],
    request=None,
    *,
    band: int | None = None,
    cap: Cap = DEFAULT_CAP,
    progress: bool = False,
    margin: float = 0.25,
    **plan_kwargs: Any,
):
    """Plan on a DEM read by windows (a corridor about the start and the goal).

    Parameters
    ----------
    dem : str or Path
        A projected DEM (see the module docstring for geographic ones).
    model : EnergyModel
        The energy model.
    start, goal : sequence of float
        ``(x, y[, yaw])`` in the DEM's CRS (yaw radians CCW from east).
    request : Request, optional
        As :func:`energy_planner.planning.plan.plan`.
    band : int, optional
        Band of a multi-band DEM.
    cap : int, DEFAULT_CAP or NO_CAP
        Memory cap (:func:`~energy_planner.terrain.memory.resolve_cap`; default
        :func:`energy_planner.terrain.memory_cap`); windows hold at most
        ``cap / PLAN_BYTES_PER_CELL`` cells.
    progress : bool
        Progress bars and the corridor's steps on stderr.
    margin : float
        First window: the start-goal box grown by this share of their distance (at
        least 32 cells).
    **plan_kwargs
        Passed to :func:`~energy_planner.planning.plan.plan` (``planner``, ``eps``,
        ``step``, ``moves``, ``n_headings``, ``time``, ``seed``, ...). ``time`` bounds
        the whole call (the gradient pass, every window's read and planning): each window
        gets what is left, and when it runs out the best path so far is returned, not
        proven.

    Returns
    -------
    result : PlanResult
        The plan; ``result.info["corridor"]`` holds the windows, ``c_min`` and whether
        the window is proven to hold every path that could beat the result.
    terrain : Terrain
        The last window's terrain (for the result's ``to_dict``/``to_geojson``).

    Raises
    ------
    InvalidStateError
        The start or goal is outside the DEM (or breaks a limit in its window).
    RasterTooLargeError
        Even the start-goal box passes the cap.
    PlanningError
        No path in the largest window that fits the cap.
    """
    from energy_planner.planning.plan import _pose, plan
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem
    from energy_planner.terrain.memory import format_bytes

    request = Request() if request is None else request
    info = raster_info(dem, band)
    cap, max_cells = _window_cells(cap)
    log = _Log(progress)
    t_start = time.perf_counter()
    budget = plan_kwargs.get("time")
    s, g = _pose(start, "start"), _pose(goal, "goal")
    for which, p in (("start", s), ("goal", g)):
        _check_inside(info, which, p[0], p[1])
    log(
        f"DEM {info.shape[0]} x {info.shape[1]} cells needs "
        f"~{format_bytes(info.shape[0] * info.shape[1] * PLAN_BYTES_PER_CELL)} "
        f"to plan whole, above the memory cap {format_bytes(cap or 0)}: planning in windows "
        f"of at most {max_cells} cells"
    )
    n_headings = int(plan_kwargs.get("n_headings", 16))
    moves = str(plan_kwargs.get("moves", "all"))
    must, window = _first_window(info, s, g, margin, max_cells, cap)
    windows: list[dict[str, Any]] = []
    best = best_terrain = c_min = gbox = ell = None
    proven = False
    length_bound = math.inf
    for attempt in range(4):
        t0 = time.perf_counter()
        terrain = load_dem(info.path, band=info.band, bounds=window)
        problem = Problem(terrain, model, request)
        kw = dict(plan_kwargs)
        if c_min is None:  # the first window's cost bounds every window
            c_min, gbox = _cost_and_bound(problem, info, n_headings, moves, log, progress)
        log(
            f"window {attempt + 1}: x {window[0]:.1f}..{window[2]:.1f}, "
            f"y {window[1]:.1f}..{window[3]:.1f} ({terrain.shape[0]} x {terrain.shape[1]} cells)"
        )
        rec: dict[str, Any] = {"bounds": list(window), "shape": list(terrain.shape)}
        if budget is not None:
            kw["time"] = _time_left(budget, t_start, best is not None)
            if kw["time"] <= 0:
                log("the time budget ran out: keeping the last window's path")
                break
        try:
            res = plan(problem, start, goal, progress=progress, **kw)
        except PlanningError as exc:
            if _keep_last_path(exc, best is not None, log):
                break
            rec.update(energy_j=None, seconds=time.perf_counter() - t0)
            windows.append(rec)
            if best is not None:
                break
            window = _widen_unreachable(info, window, must, max_cells, exc)
            log("no path in this window: widening it")
            continue
        rec.update(energy_j=res.energy_j, seconds=time.perf_counter() - t0)
        windows.append(rec)
        if best is None or res.energy_j < best.energy_j:
            best, best_terrain = res, terrain
        if c_min <= 0:
            log("c_min is 0 (channel rasters or a free motion): the window cannot be proven")
            break
        length_bound = best.energy_j / c_min
        ell = ellipse_box(s, g, length_bound)
        if info.inside(ell, window, PAD_CELLS):
            proven = True
            log(
                f"proven: every path under {best.energy_j:.0f} J is shorter than "
                f"{length_bound:.0f} m and lies in the window"
            )
            break
        window = _widen_to_ellipse(
            info, ell, window, must, max_cells, attempt, best.energy_j, length_bound, log
        )
        if window is None:
            break
    if best is None:
        raise PlanningError(
            f"no feasible path from the start to the goal in {len(windows)} windows of DEM "
            f"{info.path!r} (the last {windows[-1]['shape'][0]} x {windows[-1]['shape'][1]} "
            "cells); relax the limits or raise the memory cap",
            limit="unreachable",
        )
    if not proven and ell is not None:
        share = info.cells(windows[-1]["bounds"]) / max(info.cells(ell), 1)
        log(
            "NOT proven: a path leaving the window might be cheaper (the window covers "
            f"{min(share, 1.0):.0%} of the box of paths under {best.energy_j:.0f} J)"
        )
    best.info["corridor"] = {
        "dem_shape": list(info.shape), "dem_bounds": [float(v) for v in info.bounds],
        "cap_bytes": cap, "max_window_cells": max_cells,
        "bytes_per_cell": PLAN_BYTES_PER_CELL, "c_min_j_per_m": c_min, "gradient_box": gbox,
        "length_bound_m": length_bound if math.isfinite(length_bound) else None,
        "ellipse_bounds": list(ell) if ell is not None else None,
        "windows": windows, "proven": proven, "log": log.lines,
    }  # fmt: skip
    return best, best_terrain


def reach_in_window(
    dem: str | Path,
    model,
    start: Sequence[float],
    budget_j: float,
    request=None,
    *,
    band: int | None = None,
    cap: Cap = DEFAULT_CAP,
    round_trip: bool = False,
    progress: bool = False,
    **reach_kwargs: Any,
):
    """``reach`` within a budget on a DEM read by one window about the start.

    Every path of energy at most ``budget_j`` stays within ``budget_j / c_min`` of the
    start (half of it for a round trip), so the window of that radius (plus
    :data:`PAD_CELLS`) gives every cell within the budget its whole-map value. Cells
    above the budget are set to NaN.

    Returns
    -------
    result : ReachMap
        On the window's grid (a part of the DEM's grid); ``info["window"]`` says which.
    terrain : Terrain
        The window.

    Raises
    ------
    RasterTooLargeError
        The window the budget needs passes the memory cap (the message gives the budget
        that would fit).
    """
    from energy_planner.planning.reach import reach
    from energy_planner.terrain import load_dem

    info = raster_info(dem, band)
    cap, max_cells = _window_cells(cap)
    log = _Log(progress)
    sx, sy = float(start[0]), float(start[1])
    _check_inside(info, "start", sx, sy)
    probe = info.snap(_grow((sx, sy, sx, sy), 8 * info.cell))
    cost = Problem(load_dem(info.path, band=info.band, bounds=probe), model, request).cost
    cost.compile()
    n_headings = int(reach_kwargs.get("n_headings", 16))
    c_min, gbox = _bound(cost, info, n_headings, "all", log, progress)
    if c_min <= 0:
        raise PlanningError(
            "reach by windows needs a positive least energy per metre, and this request's "
            "is 0 (channel rasters cannot be bounded): load the DEM whole (raise "
            "ENERGY_PLANNER_MEMORY_CAP) or give constant channels with --set",
            limit="window",
        )
    radius = budget_j / (c_min * (2.0 if round_trip else 1.0))
    window = info.snap(_grow((sx, sy, sx, sy), radius + (PAD_CELLS + 1) * info.cell))
    cells = info.cells(window)
    log(
        f"least energy per metre anywhere: c_min = {c_min:.2f} J/m; within "
        f"{budget_j / 3600:.3g} Wh the robot stays within {radius:.0f} m of the start: "
        f"window of {cells} cells"
    )
    if cells > max_cells:
        side = math.sqrt(max_cells) * info.cell
        fit_wh = max(0.5 * side - (PAD_CELLS + 1) * info.cell, 0.0) * c_min
        fit_wh *= (2.0 if round_trip else 1.0) / 3600.0
        raise _too_large(
            info, f"a budget of {budget_j / 3600:.3g} Wh (radius {radius:.0f} m)", cells,
            max_cells, cap,
            f"a budget of at most {fit_wh:.3g} Wh fits; or a coarser DEM (gdalwarp -tr XRES "
            "YRES -r average), or raise ENERGY_PLANNER_MEMORY_CAP",
        )  # fmt: skip
    terrain = load_dem(info.path, band=info.band, bounds=window)
    res = reach(Problem(terrain, model, request), start, round_trip=round_trip,
                progress=progress, max_energy=budget_j, **reach_kwargs)  # fmt: skip
    above = ~(res.energy_j <= budget_j)
    res.energy_j[above] = np.nan
    res.info["window"] = {
        "dem_shape": list(info.shape),
        "bounds": list(window),
        "shape": list(terrain.shape),
        "cap_bytes": cap,
        "c_min_j_per_m": c_min,
        "gradient_box": gbox,
        "radius_m": radius,
        "cells_above_budget_masked": int(above.sum()),
        "log": log.lines,
    }
    return res, terrain
