"""Numba core of the matrix's heuristics: the relaxed edges priced once, then one Dijkstra per site.

The relaxed problem of :func:`energy_planner.planning.search.relaxed_cost_to_go` (no
turning, every translation priced by the lower bound
:func:`energy_planner.planning._search.edge_bound` scaled by the margin, the translations
the kernel refuses at every heading dropped) is the same graph for every site of a
mission: only the goal differs. :func:`relaxed_edges` prices each of its edges once into a
table (float32, each value rounded down so that it stays a lower bound), and
:func:`relaxed_dijkstra` then solves it backward from each site by reading the table: the
20 sites of a mission price the graph once instead of 20 times.

A translation and its reverse sample the gradient at the same points (the midpoints of
equal parts of the segment, in reverse order) and read the same cells, so
:func:`relaxed_edges` samples each such pair once and prices both directions (a
translation uphill and the same one downhill look up their own move's row of the
gradient table). Nothing here depends on the energy model (the model is in the gradient
table), so the module compiles once per machine.
"""

import math

import numba
import numpy as np

from energy_planner.energy._sampling import sample_gradient
from energy_planner.planning._search import _pop_indexed, _sift_up, cells_safe, translation_refused


@numba.njit(cache=True)
def _lookup(table, m, fx, fy, tmin):
    """``table[m]`` bilinear at fractional node indices (fx, fy), ``tmin[m]`` where inf.

    As :func:`energy_planner.planning._search.edge_bound` reads one sample's bound.
    """
    K = table.shape[1]
    i0 = min(int(fx), K - 2)
    j0 = min(int(fy), K - 2)
    tx = fx - i0
    ty = fy - j0
    v = (1.0 - tx) * ((1.0 - ty) * table[m, i0, j0] + ty * table[m, i0, j0 + 1]) + tx * (
        (1.0 - ty) * table[m, i0 + 1, j0] + ty * table[m, i0 + 1, j0 + 1]
    )
    if not math.isfinite(v):
        v = tmin[m]
    return v


@numba.njit(cache=True)
def _bound_pair(grad, geo, kstep, tmax, xa, ya, xb, yb, table, tmin, m, r, tgeo):
    """The unscaled bounds of (xa, ya) -> (xb, yb) by move ``m`` and back by move ``r``.

    Each equals :func:`energy_planner.planning._search.edge_bound` of its direction (the
    same samples; the reverse direction sums them in the other order). ``r < 0``: the
    first only (the second returned as inf).
    """
    ddx = xb - xa
    ddy = yb - ya
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    n = max(1, int(math.ceil(dist / kstep)))
    K = table.shape[1]
    fwd = 0.0
    bwd = 0.0
    for i in range(n):
        s = (i + 0.5) / n
        ok, gxs, gys = sample_gradient(grad, geo[0], geo[1], geo[2], geo[3], xa + s * ddx,
                                       ya + s * ddy)  # fmt: skip
        if not ok or gxs * gxs + gys * gys > tmax * tmax:
            return np.inf, np.inf
        fx = (gxs - tgeo[0]) / tgeo[2]
        fy = (gys - tgeo[1]) / tgeo[3]
        if not (fx >= 0.0 and fy >= 0.0 and fx <= K - 1 and fy <= K - 1):
            return np.inf, np.inf  # the table spans every walkable gradient of the terrain
        fwd += _lookup(table, m, fx, fy, tmin)
        if r >= 0:
            bwd += _lookup(table, r, fx, fy, tmin)
    scale = dist / n
    return fwd * scale, (bwd * scale if r >= 0 else np.inf)


@numba.njit(cache=True)
def _down32(v):
    """float32 of ``v`` rounded down (a lower bound stays one)."""
    w = np.float32(v)
    if w > v:
        w = np.nextafter(w, np.float32(-np.inf))
    return w


@numba.njit(cache=True)
def relaxed_edges(grad, blocked, unsafe, geo, sampling, lat, moves, table, tgeo, margin, j0, j1,
                  out):  # fmt: skip
    """Price the relaxed edges leaving the lattice rows ``j0 .. j1 - 1`` into ``out``.

    ``out[(j - j0) * nx + i, m]`` (float32, J): ``margin`` times the bound of the
    translation ``moves[m]`` from position (i, j), rounded down; ``inf`` where it leaves
    the lattice, is refused by the kernel at every heading
    (:func:`~energy_planner.planning._search.translation_refused`, checked only near
    unsafe cells as :func:`~energy_planner.planning._search.cells_safe` allows) or has no
    finite bound. ``moves[m + M/2]`` is the reverse of ``moves[m]`` (``MOVES_16``): a pair
    inside the strip is sampled once for both directions. Strips stacked in order give
    the whole table (so they can be priced in parallel).
    """
    xs0, ys0, step = lat[0], lat[1], lat[2]
    nx = int(lat[3])
    ny = int(lat[4])
    kstep, tmax = sampling[0], sampling[1]
    nm = moves.shape[0]
    half = nm // 2
    tmin = np.empty(nm)
    for m in range(nm):
        tmin[m] = table[m].min()
    for jp in range(j0, j1):
        for ip in range(nx):
            p = (jp - j0) * nx + ip
            xa = xs0 + ip * step
            ya = ys0 + jp * step
            for m in range(nm):
                r = (m + half) % nm
                iq = ip + moves[m, 0]
                jq = jp + moves[m, 1]
                if iq < 0 or jq < 0 or iq >= nx or jq >= ny:
                    out[p, m] = np.inf
                    continue
                both = j0 <= jq < j1
                if both and m >= half:
                    continue  # priced with its reverse from the other end
                xb = xs0 + iq * step
                yb = ys0 + jq * step
                if not cells_safe(unsafe, geo[0], geo[1], geo[2], geo[3], xa, ya, xb, yb) and (
                    translation_refused(grad, blocked, geo[0], geo[1], geo[2], geo[3], kstep,
                                        tmax, xa, ya, xb, yb)
                ):  # fmt: skip
                    f = b = np.inf
                else:
                    f, b = _bound_pair(grad, geo, kstep, tmax, xa, ya, xb, yb, table, tmin, m,
                                       r if both else -1, tgeo)  # fmt: skip
                out[p, m] = _down32(margin * f)
                if both:
                    out[(jq - j0) * nx + iq, r] = _down32(margin * b)


@numba.njit(cache=True)
def relaxed_dijkstra(edges, lat, moves, goal, h, pos, keys, vals):
    """Least relaxed cost from every position to ``goal``, into ``h`` (float64, J).

    A backward Dijkstra over :func:`relaxed_edges`'s table with an indexed heap
    (decrease-key, one entry per position). The caller gives ``h`` filled with inf,
    ``pos`` (int32) with -1 and ``keys``, ``vals`` of one entry per position. Returns the
    positions settled.
    """
    nx = int(lat[3])
    ny = int(lat[4])
    nm = moves.shape[0]
    n = np.zeros(1, np.int64)
    h[goal] = 0.0
    keys[0] = 0.0
    vals[0] = goal
    pos[goal] = 0
    n[0] = 1
    pops = 0
    while n[0] > 0:
        _, q = _pop_indexed(keys, vals, pos, n)
        hq = h[q]
        pops += 1
        jq, iq = divmod(q, nx)
        for m in range(nm):
            ip = iq - moves[m, 0]
            jp = jq - moves[m, 1]
            if ip < 0 or jp < 0 or ip >= nx or jp >= ny:
                continue
            p = jp * nx + ip
            if pos[p] == -2:
                continue
            nk = hq + edges[p, m]
            if nk < h[p]:
                h[p] = nk
                i = pos[p]
                if i < 0:
                    i = n[0]
                    n[0] = i + 1
                keys[i] = nk
                vals[i] = p
                _sift_up(keys, vals, pos, i)
    return pops
