"""The bands of an energy map: their names, descriptions and how a block of cells is priced.

``2 N`` heading bands (``along_*``, ``best_*``) then :data:`SUMMARY_BANDS`; the one
kernel call every way of computing a map shares (:func:`block_bands`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "BAND_SETS",
    "SPEED_BANDS",
    "DEFAULT_BANDS",
    "DEM_EAST",
    "GRID_EAST",
    "SUMMARY_BANDS",
    "band_descriptions",
    "band_names",
    "block_bands",
    "heading_angles",
]

#: The bands after the 2 N heading bands, in order.
SUMMARY_BANDS = ("cheapest", "dearest", "anisotropy", "cheapest_heading_deg")
#: The bands after the summary bands of a map at the best speed of a range (a robot that
#: chooses its speed: :func:`energy_planner.energymap.energy_map`'s ``speed_range``).
SPEED_BANDS = ("cheapest_speed",)
#: Which bands a map file holds: ``best`` (``best_*`` and the summary bands, N + 4),
#: ``all`` (``along_*`` too, 2 N + 4) or ``summary`` (the four summary bands: the cheapest
#: heading and its cost, the dearest, their ratio). The heading bands are written only
#: when asked, so a user who wants the cheapest heading does not pay for compressing and
#: writing them, and the ``along_*`` bands are kept in memory only with ``all``
#: (:func:`block_bands`'s ``along``).
BAND_SETS = ("best", "all", "summary")
#: The bands written unless asked otherwise.
DEFAULT_BANDS = "best"


def first_band(headings: int, bands: str) -> int:
    """Index (0-based) in the full layout of :func:`band_names` of a file's first band.

    The written bands are the full layout's from there on: ``best`` leaves out the N
    ``along_*`` bands that lead it, ``summary`` the 2 N heading bands.

    Examples
    --------
    >>> first_band(16, "best"), first_band(16, "all"), first_band(16, "summary")
    (16, 0, 32)
    """
    return {"best": headings, "summary": 2 * headings}.get(bands, 0)


def band_names(headings: int, bands: str = "all", extra: tuple[str, ...] = ()) -> list[str]:
    """Names of the bands of a map with ``headings`` headings, in order.

    ``bands``: the set written (:data:`BAND_SETS`); ``all``: the full layout. ``extra``:
    bands after the summary ones (:data:`SPEED_BANDS` for a map at the best speed).

    Examples
    --------
    >>> band_names(4)  # doctest: +NORMALIZE_WHITESPACE
    ['along_000', 'along_090', 'along_180', 'along_270', 'best_000', 'best_090',
     'best_180', 'best_270', 'cheapest', 'dearest', 'anisotropy', 'cheapest_heading_deg']
    """
    degs = [_deg_label(360.0 * j / headings) for j in range(headings)]
    names = [f"along_{d}" for d in degs] + [f"best_{d}" for d in degs] + list(SUMMARY_BANDS)
    return names[first_band(headings, bands) :] + list(extra)


def _deg_label(d: float) -> str:
    return f"{d:05.1f}".rstrip("0").rstrip(".").zfill(3) if d != int(d) else f"{int(d):03d}"


#: Heading frame of a map on a metric grid: the grid's own +x axis.
GRID_EAST = "degrees counter-clockwise from the grid's +x axis (east)"
#: Heading frame of a map resampled onto a geographic (non-metric) DEM's grid.
DEM_EAST = (
    "degrees counter-clockwise from the DEM's local east (its CRS's +x direction, e.g. "
    "increasing longitude, at the cell): the working (UTM) grid's headings rotated by the "
    "meridian convergence"
)


def band_descriptions(
    headings: int, frame: str = "east", bands: str = "all", extra: tuple[str, ...] = (),
    speed_range: tuple[float, float] | None = None, gaits: tuple[str, ...] = (),
) -> list[tuple[str, str, str]]:  # fmt: skip
    """``(name, description, units)`` of every band written.

    ``bands``: the set written, as for :func:`band_names`; ``frame`` names the heading
    frame; ``extra``: the bands after the summary ones (:data:`SPEED_BANDS`, and
    ``cheapest_gait``), of a map at the best speed within ``speed_range`` (m/s) and, with
    ``gaits``, in the best of them.
    """
    out = []
    for j in range(headings):
        d = 360.0 * j / headings
        out.append(
            (f"along_{_deg_label(d)}", f"J per map metre walking forward, facing heading "
             f"{d:g} deg (CCW from {frame})", "J/m")
        )  # fmt: skip
    for j in range(headings):
        d = 360.0 * j / headings
        out.append(
            (f"best_{_deg_label(d)}", f"J per map metre moving along heading {d:g} deg (CCW "
             f"from {frame}), cheapest over the body's yaw (crabbing included)", "J/m")
        )  # fmt: skip
    out += [
        ("cheapest", "least best_* over the headings, J per map metre", "J/m"),
        ("dearest", "greatest best_* over the headings, J per map metre", "J/m"),
        ("anisotropy", "dearest / cheapest (inf where the cheapest costs nothing)", "1"),
        ("cheapest_heading_deg", f"heading of the cheapest, degrees CCW from {frame}", "deg"),
    ]
    lo, hi = speed_range if speed_range is not None else (math.nan, math.nan)
    what = {
        "cheapest_speed": (f"ground speed of the cheapest: the best in {lo:g}..{hi:g} m/s of "
                           "its heading and body yaw (each cost band is at its own best "
                           "speed)", "m/s"),
        "cheapest_gait": ("gait of the cheapest, by code: " + ", ".join(
            f"{k} = {g}" for k, g in enumerate(gaits)) + " (each cost band in its own "
            "best gait)", "1"),
    }  # fmt: skip
    return out[first_band(headings, bands) :] + [(n, *what[n]) for n in extra]


def heading_angles(headings: int) -> np.ndarray:
    """The map headings in radians, ``2 pi j / N``."""
    return 2.0 * np.pi * np.arange(headings) / headings


def block_bands(
    heading: Any, gx: np.ndarray, gy: np.ndarray, chan: np.ndarray, headings: int,
    out: np.ndarray | None = None, precompiled: bool = False, along: bool = True,
    then: Any = None,
) -> np.ndarray:  # fmt: skip
    """Every band of a block of cells, float32 ``(2 N + 4 + E, rows, cols)``.

    ``heading``: the :class:`~energy_planner.energy.heading.HeadingCost` of the map's
    model, speed and limits (it prices ``along`` and ``best``), or a
    :class:`~energy_planner.energy.speed_map.RangedHeadingCost` (each yaw at its best
    speed: then ``E = 1``, the :data:`SPEED_BANDS`, else 0); ``gx``, ``gy``: the cells'
    Horn gradient; ``chan``: raster channels on the same cells ``(k, rows, cols)``;
    ``out``: a C-contiguous float32 array of that shape to fill (a window's buffer reused
    from one window to the next: no fresh pages to fault in), else a new one.
    ``precompiled``: with the model's precompiled map kernels where there are some
    (:meth:`~energy_planner.energy.heading.HeadingCost.precompiled_map`: no numba to
    load; the same values). ``along``: False leaves out the ``along_*`` bands, for a
    file that does not hold them: ``(N + 4 + E, rows, cols)``, from ``best_*`` on, the
    same values. The kernel prices ``along`` either way; the precompiled one writes it
    into one ``(rows, cols)`` plane that every heading overwrites (a stride of 0 along the
    headings: no memory traffic for bands nobody reads), numba's into a scratch block
    (its kernel is compiled for contiguous bands only).
    ``then(out, a, b)``: called for each range of rows ``a .. b`` once every band of those
    rows is final: with the precompiled kernels and no speed bands, in the row thread
    that computed them, right after its kernel and summary rows (no wait for the other
    rows, e.g. to encode them: :func:`~energy_planner.energymap.core._map_by_windows`);
    else over the row ranges of :func:`~energy_planner.energy.heading.run_by_rows` at
    the end.
    """
    gx = np.ascontiguousarray(gx, dtype=np.float64)
    gy = np.ascontiguousarray(gy, dtype=np.float64)
    rows, cols = gx.shape
    if chan.shape[0] == 0:
        chan = np.zeros((0, rows, cols))
    chan = np.ascontiguousarray(chan, dtype=np.float64)
    ang = heading_angles(headings)
    extra = len(speed_bands(heading))
    lead = headings if along else 0  # the along_* bands out holds
    shape = (lead + headings + 4 + extra, rows, cols)
    if out is None or out.shape != shape:
        out = np.empty(shape, dtype=np.float32)
    aot = heading.precompiled_map() if precompiled else None
    if along:
        fwd = out[:headings]
    else:
        # the precompiled kernel's along values go to the cheapest band's plane, which
        # the summary fills from best afterwards (a plane of out: none to allocate)
        plane = out[lead + headings] if aot is not None else None
        fwd = _discarded_along(headings, rows, cols, shared=aot is not None, plane=plane)
    best = out[lead : lead + headings]
    summary = out[lead + headings : lead + headings + 4]
    if aot is None:
        from energy_planner.energymap._summary import summary_bands

        heading.map_bands(gx, gy, chan, ang, fwd, best, precompiled)
        summary_bands(best, np.degrees(ang), summary)
    else:
        deg = np.degrees(ang)

        def rows_done(a: int, b: int) -> None:  # in the row thread of rows a .. b
            aot.summary(best[:, a:b], deg, summary[:, a:b])
            if then is not None and not extra:
                then(out, a, b)

        heading.map_bands(gx, gy, chan, ang, fwd, best, precompiled, then=rows_done)
    if extra:
        with np.errstate(invalid="ignore"):
            head = np.radians(summary[3].astype(np.float64))
        heading.fill_speed_bands(gx, gy, chan, head, out[lead + headings + 4 :], best)
    if then is not None and (extra or aot is None):
        from energy_planner.energy.heading import run_by_rows

        run_by_rows(lambda a, b: then(out, a, b), rows)
    return out


def _discarded_along(
    headings: int, rows: int, cols: int, shared: bool, plane: np.ndarray | None = None
) -> np.ndarray:
    """Somewhere for the kernel to put ``along`` bands nobody reads, ``(N, rows, cols)``.

    ``shared``: one ``(rows, cols)`` float32 plane seen N times (stride 0 along the
    headings), for the precompiled kernel, whose bands may have any strides: each cell's
    N values land on one address (the threads of :func:`~energy_planner.energy.heading.
    run_by_rows` take distinct rows, so never the same one); ``plane``: that plane (a
    C-contiguous float32 ``(rows, cols)`` array whose values are written over later),
    else a new one. Else a scratch array of its own: numba's kernel is compiled for
    C-contiguous bands, and a view with a stride of 0 would make it compile another
    specialisation.
    """
    if not shared:
        return np.empty((headings, rows, cols), dtype=np.float32)
    if plane is None:
        plane = np.empty((rows, cols), dtype=np.float32)
    return np.lib.stride_tricks.as_strided(
        plane, shape=(headings, rows, cols), strides=(0, *plane.strides)
    )


def speed_bands(heading: Any) -> tuple[str, ...]:
    """The bands after the summary bands of a map priced by ``heading``.

    :data:`SPEED_BANDS` for a :class:`~energy_planner.energy.speed_map.RangedHeadingCost`
    (each yaw at its best speed), and ``cheapest_gait`` after it for a
    :class:`~energy_planner.energy.speed_map.GaitChoice`; else none.
    """
    return tuple(getattr(heading, "speed_band_names", ()))
