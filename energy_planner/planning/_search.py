"""Numba core of the full-resolution search (template, compiled once per energy model).

:func:`energy_planner.planning.search.search_module` copies this file, replaces the
kernel import below with the model's generated motion-kernel module (see
:func:`energy_planner.energy.kernels.make_kernels`), writes it to the kernel cache and
imports it, so that numba's on-disk cache keeps the compiled search between runs.
Imported as it is, ``kernel`` is the template's level-ground placeholder model.

States are ``s = p * H + h``: lattice position ``p = j * nx + i`` (x index ``i``, y index
``j``) and heading index ``h``. Per state the search keeps ``g`` (float32, J) and a code
(int8): 0 never reached (then ``g`` is not read: the caller allocates ``g`` with
``np.empty`` and the codes with ``np.zeros``, so the operating system maps only the pages
of states the search reaches, and memory follows the states reached, not the map);
``1 + m`` reached by translation ``MOVES[m]`` at constant heading; 17 by a turn from heading
``h - 1``; 18 by a turn from ``h + 1``; 19 a start state; +64 once expanded (closed).
The open list is a binary heap of (key, state) with lazy deletion, grown by the caller
when full.
"""

import math

import numba
import numpy as np

from energy_planner.energy._motion import motion_full as kernel  # --- kernel import ---
from energy_planner.energy.kernels import IN_CHAN, N_OUT, sample_gradient

UNSEEN = 0
TURN_FROM_PREV = 17
TURN_FROM_NEXT = 18
START = 19
CLOSED = 64

# chunk return codes
RUNNING, FOUND, EXHAUSTED, HEAP_FULL = 0, 1, 2, 3
OPENED = 4  # next_open: a state to expand


@numba.njit(cache=True)
def heap_push(keys, vals, n, key, val):
    i = n[0]
    if i >= keys.shape[0]:
        return False
    n[0] = i + 1
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        vals[i] = vals[parent]
        i = parent
    keys[i] = key
    vals[i] = val
    return True


@numba.njit(cache=True)
def heap_pop(keys, vals, n):
    key = keys[0]
    val = vals[0]
    m = n[0] - 1
    n[0] = m
    if m > 0:
        keys[0] = keys[m]
        vals[0] = vals[m]
        _sift_down(keys, vals, 0, m)
    return key, val


@numba.njit(cache=True)
def next_open(keys, vals, n, code, pops, max_pops, room, max_key):
    """Pop the best state of the open list that is not closed yet, and close it.

    The one loop head of the A* expansions (:func:`astar_chunk`, :func:`astar_cached_chunk`,
    :func:`astar_lazy_chunk`). Returns ``(status, s)``: ``OPENED`` and the state, or
    ``RUNNING`` (``pops`` reached ``max_pops``), ``HEAP_FULL`` (fewer than ``room`` free
    entries left for the state's successors) or ``EXHAUSTED`` (the list is empty, or its
    best key is above ``max_key``: the list is then emptied) with ``s = -1``.
    """
    while n[0] > 0:
        if pops >= max_pops:
            return RUNNING, -1
        if n[0] + room > keys.shape[0]:
            return HEAP_FULL, -1
        key, s = heap_pop(keys, vals, n)
        c = code[s]
        if c >= CLOSED:
            continue
        if key > max_key:
            n[0] = 0
            return EXHAUSTED, -1
        code[s] = c + CLOSED
        return OPENED, s
    return EXHAUSTED, -1


@numba.njit(cache=True)
def edge_bound(grad, gx0, gy0, gdx, gdy, kstep, tmax, xa, ya, xb, yb, table, tmin, m, t0x,
               t0y, tdx, tdy):  # fmt: skip
    """Lower bound of the kernel's energy (J) of translation ``m`` from (xa, ya) to (xb, yb).

    The kernel (``motion_full``) prices a translation of map length ``L`` as ``n =
    ceil(L / kstep)`` samples at the midpoints of equal parts, each ``L / n`` map metres
    walked on the gradient interpolated there: at constant heading and speed, a sample's
    energy is ``L / n`` times the J per map metre of walking on that gradient at that
    yaw. The same samples are taken here, each priced by the cheapest yaw at its own
    gradient: ``table[m]`` (J per map metre over a grid of gradients, the least over
    body yaws) interpolated bilinearly there. Where a node around the sample is ``inf``
    (steeper than the limit ``tmax``, or no yaw may move) the sample takes ``tmin[m]``,
    the least of ``table[m]``; a sample outside the valid terrain or steeper than
    ``tmax`` is refused by the kernel at every heading: ``inf``. The caller scales the
    sum down by its margin (the table's interpolation error).
    """
    ddx = xb - xa
    ddy = yb - ya
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    n = max(1, int(math.ceil(dist / kstep)))
    K = table.shape[1]
    total = 0.0
    for i in range(n):
        s = (i + 0.5) / n
        ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, xa + s * ddx, ya + s * ddy)
        if not ok or gxs * gxs + gys * gys > tmax * tmax:
            return np.inf
        fx = (gxs - t0x) / tdx
        fy = (gys - t0y) / tdy
        if not (fx >= 0.0 and fy >= 0.0 and fx <= K - 1 and fy <= K - 1):
            return np.inf  # the table spans every walkable gradient of the terrain
        i0 = min(int(fx), K - 2)
        j0 = min(int(fy), K - 2)
        tx = fx - i0
        ty = fy - j0
        v = (1.0 - tx) * ((1.0 - ty) * table[m, i0, j0] + ty * table[m, i0, j0 + 1]) + tx * (
            (1.0 - ty) * table[m, i0 + 1, j0] + ty * table[m, i0 + 1, j0 + 1]
        )
        if not math.isfinite(v):
            v = tmin[m]
        total += v
    return total * dist / n


@numba.njit(cache=True)
def translation_refused(grad, blocked, gx0, gy0, gdx, gdy, step, tmax, xa, ya, xb, yb):
    """Whether the motion kernel refuses the translation (xa, ya) -> (xb, yb) at every heading.

    The kernel's first pass (``motion_full`` in :mod:`energy_planner.energy._motion`)
    samples the gradient at ``n = ceil(length / step)`` midpoints and refuses the motion
    if a sample lies outside the valid gradients, in a keep-out cell (nearest cell of
    ``blocked``) or on ground steeper than ``tmax``; none of these depends on the heading,
    so a translation refused here costs ``inf`` at every heading (the relaxed problem may
    drop it and stay a lower bound). The same samples as the kernel's, in the same order
    (``tests/test_planning_search.py`` checks the two agree).
    """
    ddx = xb - xa
    ddy = yb - ya
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    n = max(1, int(math.ceil(dist / step)))
    nr, nc = blocked.shape
    t2 = tmax * tmax
    for i in range(n):
        s = (i + 0.5) / n
        x = xa + s * ddx
        y = ya + s * ddy
        ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x, y)
        if not ok:
            return True
        if nr > 0:
            r = int(round((y - gy0) / gdy))
            c = int(round((x - gx0) / gdx))
            if 0 <= r < nr and 0 <= c < nc and blocked[r, c]:
                return True
        if gxs * gxs + gys * gys > t2:
            return True
    return False


@numba.njit(cache=True)
def unsafe_cells(grad, blocked, tmax):
    """uint8 per DEM cell: 1 where the kernel may refuse a motion that reads the cell.

    Invalid (NaN) gradient, steeper than ``tmax``, or kept out (``blocked``, may be
    empty); see :func:`cells_safe`.
    """
    nr, nc = grad.shape[0], grad.shape[1]
    out = np.zeros((nr, nc), np.uint8)
    t2 = tmax * tmax
    kept = blocked.shape[0] > 0
    for r in range(nr):
        for c in range(nc):
            a = grad[r, c, 0]
            b = grad[r, c, 1]
            if not (a * a + b * b <= t2) or (kept and blocked[r, c]):
                out[r, c] = 1
    return out


@numba.njit(cache=True)
def cells_safe(unsafe, gx0, gy0, gdx, gdy, xa, ya, xb, yb):
    """True when no cell the kernel may read on (xa, ya) -> (xb, yb) is ``unsafe``.

    Every sample of the segment reads the 4 cells around it (bilinear) and its nearest
    cell (keep-out), all inside ``[floor(f), floor(f) + 1]`` of the endpoints' fractional
    indices ``f``; ``unsafe[r, c]`` marks the cells whose gradient is invalid, steeper
    than the limit, or kept out. When none is unsafe, every interpolated gradient is a
    convex combination of gradients no steeper than the limit (so is not steeper either)
    and :func:`translation_refused` would return False: it need not sample.
    """
    nr, nc = unsafe.shape
    fa_c = (xa - gx0) / gdx
    fb_c = (xb - gx0) / gdx
    fa_r = (ya - gy0) / gdy
    fb_r = (yb - gy0) / gdy
    lo_c, hi_c = min(fa_c, fb_c), max(fa_c, fb_c)
    lo_r, hi_r = min(fa_r, fb_r), max(fa_r, fb_r)
    if lo_c < 0.0 or lo_r < 0.0 or hi_c > nc - 1 or hi_r > nr - 1:
        return False
    c1 = min(int(math.floor(hi_c)) + 1, nc - 1)
    r1 = min(int(math.floor(hi_r)) + 1, nr - 1)
    for r in range(int(math.floor(lo_r)), r1 + 1):
        for c in range(int(math.floor(lo_c)), c1 + 1):
            if unsafe[r, c]:
                return False
    return True


@numba.njit(cache=True)
def _sift_up(keys, vals, pos, i):
    key = keys[i]
    v = vals[i]
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        vals[i] = vals[parent]
        pos[vals[i]] = i
        i = parent
    keys[i] = key
    vals[i] = v
    pos[v] = i


@numba.njit(cache=True)
def _pop_indexed(keys, vals, pos, n):
    key = keys[0]
    val = vals[0]
    pos[val] = -2
    m = n[0] - 1
    n[0] = m
    if m > 0:
        k = keys[m]
        v = vals[m]
        i = 0
        while True:
            c = 2 * i + 1
            if c >= m:
                break
            if c + 1 < m and keys[c + 1] < keys[c]:
                c += 1
            if keys[c] >= k:
                break
            keys[i] = keys[c]
            vals[i] = vals[c]
            pos[vals[i]] = i
            i = c
        keys[i] = k
        vals[i] = v
        pos[v] = i
    return key, val


@numba.njit(cache=True)
def heuristic_chunk(
    grad,
    blocked,
    unsafe,
    geo,
    sampling,
    lat,
    moves,
    move_len,
    table,
    tgeo,
    h,
    pos,
    keys,
    vals,
    n,
    max_pops,
    margin,
    stop_p,
    stop_factor,
    limit,
):
    """Backward search of the relaxed problem (no turning, least J/m over headings).

    ``geo`` = (x0, y0, dx, dy) of the DEM grid; ``lat`` = (xs0, ys0, step, nx, ny);
    ``tgeo`` = (t0x, t0y, tdx, tdy) of the table; ``sampling`` = (kernel step, tmax):
    a move the kernel refuses at every heading (:func:`translation_refused`: steep,
    keep-out, nodata) is no edge of the relaxed problem either, so ``h`` sees the same
    barriers as the search (sampled only near the cells marked ``unsafe``,
    :func:`cells_safe`). ``h`` (float64, nx * ny) holds the
    tentative costs-to-go (inf = not reached). The open list is an indexed heap
    (``pos[p]``: index in the heap, -1 never reached, -2 settled) with decrease-key, so it
    never holds more than one entry per position. ``margin`` (< 1) scales every bound
    down. Without ``stop_p`` (< 0) it is Dijkstra and settles everything it reaches.
    With ``stop_p`` (the start ``s``) it is A* towards ``s``: keys ``h(p) + d(p)`` with
    ``d(p) = c |p - s|``, ``c`` the least J/m of any edge (the table's minimum: a
    consistent heuristic, so every settled ``h`` is still exact); when ``s`` is settled
    at ``h(s)``, ``limit[0]`` becomes ``stop_factor * h(s)`` and the search stops at the
    first key above it (``limit[1]`` receives ``c``). A position ``p`` not settled by
    then has ``h(p) + d(p) > limit[0]``: :func:`cap_unsettled` sets its ``h`` to
    ``limit[0] - d(p)`` (a lower bound). So only the ellipse-like region of positions a
    path of energy ``limit[0]`` can visit is settled, not the disc around the goal.
    Returns (code, pops).
    """
    gx0, gy0, gdx, gdy = geo[0], geo[1], geo[2], geo[3]
    xs0, ys0, step = lat[0], lat[1], lat[2]
    nx = int(lat[3])
    ny = int(lat[4])
    t0x, t0y, tdx, tdy = tgeo[0], tgeo[1], tgeo[2], tgeo[3]
    kstep, tmax = sampling[0], sampling[1]
    nm = moves.shape[0]
    # least bound of each move over the whole table: an edge that cannot improve h[p]
    # even at this cost is skipped without looking up its own bound
    gmin = np.empty(nm)
    tmin = np.empty(nm)
    cmin = np.inf  # J per metre
    for m in range(nm):
        tmin[m] = table[m].min()
        gmin[m] = margin * move_len[m] * step * tmin[m]
        cmin = min(cmin, margin * tmin[m])
    if stop_p < 0 or not math.isfinite(cmin):
        cmin = 0.0
    limit[1] = cmin
    js, i_s = divmod(max(stop_p, 0), nx)
    pops = 0
    while n[0] > 0:
        if pops >= max_pops:
            return RUNNING, pops
        if keys[0] > limit[0]:
            n[0] = 0
            return EXHAUSTED, pops
        key, q = _pop_indexed(keys, vals, pos, n)
        hq = h[q]
        if q == stop_p:
            limit[0] = stop_factor * hq
        pops += 1
        jq, iq = divmod(q, nx)
        xb = xs0 + iq * step
        yb = ys0 + jq * step
        for m in range(nm):
            ip = iq - moves[m, 0]
            jp = jq - moves[m, 1]
            if ip < 0 or jp < 0 or ip >= nx or jp >= ny:
                continue
            p = jp * nx + ip
            if pos[p] == -2 or hq + gmin[m] >= h[p]:
                continue
            xa = xs0 + ip * step
            ya = ys0 + jp * step
            lb = edge_bound(grad, gx0, gy0, gdx, gdy, kstep, tmax, xa, ya, xb, yb, table, tmin,
                            m, t0x, t0y, tdx, tdy)  # fmt: skip
            nk = hq + margin * lb
            if nk < h[p]:
                if not cells_safe(unsafe, gx0, gy0, gdx, gdy, xa, ya, xb, yb) and (
                    translation_refused(grad, blocked, gx0, gy0, gdx, gdy, kstep, tmax, xa, ya,
                                        xb, yb)
                ):  # fmt: skip
                    continue
                h[p] = nk
                i = pos[p]
                if i < 0:
                    i = n[0]
                    n[0] = i + 1
                keys[i] = nk + cmin * step * math.hypot(ip - i_s, jp - js)
                vals[i] = p
                _sift_up(keys, vals, pos, i)
    return EXHAUSTED, pops


@numba.njit(cache=True)
def cap_unsettled(h, pos, nx, stop_p, cmin, step, limit):
    """``h[p] = max(limit - cmin |p - s|, 0)`` where the search did not settle ``p``.

    ``cmin``: the least J per metre of any edge of the relaxed problem (the same as
    :func:`heuristic_chunk`'s); ``s`` = ``stop_p``. See :func:`heuristic_chunk`.
    """
    js, i_s = divmod(stop_p, nx)
    for p in range(h.shape[0]):
        if pos[p] != -2:
            j, i = divmod(p, nx)
            h[p] = max(limit - cmin * step * math.hypot(i - i_s, j - js), 0.0)


@numba.njit(cache=True)
def astar_chunk(
    data,
    lat,
    headings,
    moves,
    moves_of,
    move_lb,
    h2d,
    eps,
    g,
    code,
    goal_p,
    goal_h,
    keys,
    vals,
    n,
    max_pops,
    max_key,
    out,
):
    """Expand up to ``max_pops`` states of the (x, y, heading) search.

    Edge costs are ``kernel`` of the motion (translation at constant heading to the
    neighbour ``moves[m]`` for the ``m`` in ``moves_of[h]``, or a turn in place to the
    next heading either side), priced when first needed. Keys are ``g + eps * h2d``.
    ``goal_p`` < 0: no goal (expand everything with ``g <= max_key``). ``goal_h`` < 0:
    any heading at the goal. On FOUND, ``out[0]`` is the goal state. Returns
    (code, pops, edges priced).

    ``move_lb[m]``: a lower bound of the kernel's energy of translation ``m`` anywhere
    (J; zeros: none). A translation to a state already reached with ``g <= g(s) +
    move_lb[m]`` cannot lower its ``g`` (``g(s) + e >= g(s) + move_lb[m]`` in floating
    point too), so it is not priced: the same ``g`` and codes, for fewer kernel calls
    (on a whole-map reach over half of the translations priced before).
    """
    xs0, ys0, step = lat[0], lat[1], lat[2]
    nx = int(lat[3])
    ny = int(lat[4])
    H = headings.shape[0]
    nmv = moves_of.shape[1]
    pops = 0
    priced = 0
    buf = np.empty(N_OUT + data[IN_CHAN].shape[0])  # results, then channel scratch
    while True:
        status, s = next_open(keys, vals, n, code, pops, max_pops, nmv + 2, max_key)
        if status != OPENED:
            return status, pops, priced
        pops += 1
        p, hh = divmod(s, H)
        if p == goal_p and (goal_h < 0 or hh == goal_h):
            out[0] = s
            return FOUND, pops, priced
        j, i = divmod(p, nx)
        x = xs0 + i * step
        y = ys0 + j * step
        th = headings[hh]
        gs = g[s]
        for k in range(nmv):
            m = moves_of[hh, k]
            if m < 0:
                continue
            i2 = i + moves[m, 0]
            j2 = j + moves[m, 1]
            if i2 < 0 or j2 < 0 or i2 >= nx or j2 >= ny:
                continue
            q = j2 * nx + i2
            t = q * H + hh
            ct = code[t]
            if ct >= CLOSED or not math.isfinite(h2d[q]):
                continue
            if ct != UNSEEN and gs + move_lb[m] >= g[t]:
                continue  # no energy of this move could improve t: left unpriced
            kernel(x, y, th, xs0 + i2 * step, ys0 + j2 * step, th, -1.0, data, buf)
            e = buf[0]
            priced += 1
            if not math.isfinite(e):
                continue
            ng = gs + e
            if code[t] == UNSEEN or ng < g[t]:
                g[t] = ng
                code[t] = 1 + m
                heap_push(keys, vals, n, ng + eps * h2d[q], t)
        for d in (-1, 1):
            h2 = (hh + d) % H
            t = p * H + h2
            if code[t] >= CLOSED:
                continue
            kernel(x, y, th, x, y, headings[h2], -1.0, data, buf)
            e = buf[0]
            priced += 1
            if not math.isfinite(e):
                continue
            ng = gs + e
            if code[t] == UNSEEN or ng < g[t]:
                g[t] = ng
                code[t] = TURN_FROM_PREV if d == 1 else TURN_FROM_NEXT
                heap_push(keys, vals, n, ng + eps * h2d[p], t)


@numba.njit(cache=True)
def trace(code, moves, nx, H, s):
    """States from a start state to ``s`` following the codes."""
    out = []
    while True:
        out.append(s)
        c = code[s] % CLOSED
        if c == START or c == UNSEEN:
            break
        p, hh = divmod(s, H)
        if c == TURN_FROM_PREV:
            s = p * H + (hh - 1) % H
        elif c == TURN_FROM_NEXT:
            s = p * H + (hh + 1) % H
        else:
            j, i = divmod(p, nx)
            s = (j - moves[c - 1, 1]) * nx + (i - moves[c - 1, 0])
            s = s * H + hh
    res = np.empty(len(out), np.int64)
    for k in range(len(out)):
        res[k] = out[len(out) - 1 - k]
    return res


@numba.njit(cache=True)
def min_over_headings(g, code, P, H):
    """Least ``g`` over the headings of each position (inf where none was reached)."""
    res = np.empty(P, np.float64)
    for p in range(P):
        b = np.inf
        for hh in range(H):
            if code[p * H + hh] == UNSEEN:
                continue
            v = g[p * H + hh]
            if v < b:
                b = v
        res[p] = b
    return res


@numba.njit(cache=True)
def min_rows(rows, which, out):
    """``out[p]`` = least of ``rows[k, p]`` over the row indices ``k`` in ``which``.

    The heuristic of a search toward several goals: the least of the goals' relaxed
    costs-to-go (``inf`` where no goal in ``which`` can be reached).
    """
    for p in range(out.shape[0]):
        b = np.inf
        for k in which:
            v = rows[k, p]
            if v < b:
                b = v
        out[p] = b


@numba.njit(cache=True)
def _sift_down(keys, vals, i, m):
    k = keys[i]
    v = vals[i]
    while True:
        c = 2 * i + 1
        if c >= m:
            break
        if c + 1 < m and keys[c + 1] < keys[c]:
            c += 1
        if keys[c] >= k:
            break
        keys[i] = keys[c]
        vals[i] = vals[c]
        i = c
    keys[i] = k
    vals[i] = v


@numba.njit(cache=True)
def rekey(keys, vals, n, g, code, h2d, H):
    """Give every open entry the key ``g + h2d`` of a new heuristic, then re-heapify.

    Entries of closed states are dropped; a stale entry of a state whose ``g`` has
    improved since gets the same key as the live one (the second pop finds it closed).
    A* may switch to another consistent heuristic in mid-search this way: the closed
    states keep their optimal ``g``, and the open list is ordered by the new keys.
    """
    m = 0
    for k in range(n[0]):
        s = vals[k]
        if code[s] >= CLOSED:
            continue
        keys[m] = g[s] + h2d[s // H]
        vals[m] = s
        m += 1
    n[0] = m
    for i in range(m // 2 - 1, -1, -1):
        _sift_down(keys, vals, i, m)


@numba.njit(cache=True)
def edge_costs(data, lat, headings, moves, moves_of, j0, j1, out):
    """Price every edge of lattice rows ``j0 .. j1 - 1`` once: ``out[s - j0 * nx * H, k]``.

    float32 J for state ``s`` (so the rows of ``out`` follow the states of the strip).

    Column ``k < K`` (``K = moves_of.shape[1]``) is the translation ``moves_of[h, k]`` at
    constant heading (``inf`` where it leaves the lattice or there is no such move), column
    ``K`` the turn in place to heading ``h - 1`` and ``K + 1`` to ``h + 1``: the edges
    :func:`astar_chunk` prices on demand, priced by the same kernel call. Searches from
    several starts over the same lattice then share them (:func:`astar_cached_chunk`).
    """
    xs0, ys0, step = lat[0], lat[1], lat[2]
    nx = int(lat[3])
    ny = int(lat[4])
    H = headings.shape[0]
    nmv = moves_of.shape[1]
    buf = np.empty(N_OUT + data[IN_CHAN].shape[0])
    for p in range(j0 * nx, j1 * nx):
        j, i = divmod(p, nx)
        x = xs0 + i * step
        y = ys0 + j * step
        for hh in range(H):
            s = (p - j0 * nx) * H + hh
            th = headings[hh]
            for k in range(nmv):
                out[s, k] = np.inf
                m = moves_of[hh, k]
                if m < 0:
                    continue
                i2 = i + moves[m, 0]
                j2 = j + moves[m, 1]
                if i2 < 0 or j2 < 0 or i2 >= nx or j2 >= ny:
                    continue
                kernel(x, y, th, xs0 + i2 * step, ys0 + j2 * step, th, -1.0, data, buf)
                out[s, k] = buf[0]
            for d in range(2):
                h2 = (hh + 2 * d - 1) % H
                kernel(x, y, th, x, y, headings[h2], -1.0, data, buf)
                out[s, nmv + d] = buf[0]


@numba.njit(cache=True)
def astar_cached_chunk(edges, lat, H, moves, moves_of, h2d, g, code, goal_p, keys, vals, n,
                       max_pops, max_key):  # fmt: skip
    """:func:`astar_chunk` with ``eps = 1`` and the edges read from :func:`edge_costs`.

    The same expansion (moves, turns, closed and unreachable states skipped, codes), the
    edge costs looked up instead of priced. ``goal_p`` < 0: no goal. Returns (code, pops).
    """
    nx = int(lat[3])
    ny = int(lat[4])
    nmv = moves_of.shape[1]
    pops = 0
    while True:
        status, s = next_open(keys, vals, n, code, pops, max_pops, nmv + 2, max_key)
        if status != OPENED:
            return status, pops
        pops += 1
        p, hh = divmod(s, H)
        if p == goal_p:
            return FOUND, pops
        j, i = divmod(p, nx)
        gs = g[s]
        for k in range(nmv):
            m = moves_of[hh, k]
            if m < 0:
                continue
            i2 = i + moves[m, 0]
            j2 = j + moves[m, 1]
            if i2 < 0 or j2 < 0 or i2 >= nx or j2 >= ny:
                continue
            q = j2 * nx + i2
            t = q * H + hh
            e = np.float64(edges[s, k])
            if code[t] >= CLOSED or not math.isfinite(h2d[q]) or not math.isfinite(e):
                continue
            ng = gs + e
            if ng < g[t]:
                g[t] = ng
                code[t] = m
                heap_push(keys, vals, n, ng + h2d[q], t)
        for d in range(2):
            h2 = (hh + 2 * d - 1) % H
            t = p * H + h2
            e = np.float64(edges[s, nmv + d])
            if code[t] >= CLOSED or not math.isfinite(e):
                continue
            ng = gs + e
            if ng < g[t]:
                g[t] = ng
                code[t] = TURN_FROM_NEXT if d == 0 else TURN_FROM_PREV
                heap_push(keys, vals, n, ng + h2d[p], t)


@numba.njit(cache=True)
def astar_lazy_chunk(data, lat, headings, moves, moves_of, move_lb, h2d, g, code, goal_p, keys,
                     vals, n, max_pops, max_key, edges, done):  # fmt: skip
    """:func:`astar_chunk` with eps 1 and the edges kept in a shared cache as they are priced.

    ``edges`` has the columns of :func:`edge_costs` (a state's translations, then the
    turns to ``h - 1`` and ``h + 1``); bit ``k`` of ``done[s]`` says column ``k`` of state
    ``s`` holds its float32 price. An edge the expansion needs is read from the cache, or
    priced by the same kernel call as :func:`edge_costs` and kept; as in
    :func:`astar_chunk` an edge to a closed state, or a translation that could not
    improve the state it leads to even at ``move_lb[m]`` (a float32 lower bound, so below
    the kept price too), is not priced. Searches from several starts on the same lattice
    share ``edges`` and ``done``, so each edge is priced at most once, and only where
    some search needs it. ``g`` is read only where ``code`` says reached (as
    :func:`astar_chunk`'s; the caller may leave ``g``, ``edges`` unwritten and ``code``,
    ``done`` zero). Keys are ``g + h2d``; ``goal_p`` < 0: no goal. Returns (code, pops,
    edges priced).
    """
    xs0, ys0, step = lat[0], lat[1], lat[2]
    nx = int(lat[3])
    ny = int(lat[4])
    H = headings.shape[0]
    nmv = moves_of.shape[1]
    pops = 0
    priced = 0
    buf = np.empty(N_OUT + data[IN_CHAN].shape[0])
    while True:
        status, s = next_open(keys, vals, n, code, pops, max_pops, nmv + 2, max_key)
        if status != OPENED:
            return status, pops, priced
        pops += 1
        p, hh = divmod(s, H)
        if p == goal_p:
            return FOUND, pops, priced
        j, i = divmod(p, nx)
        x = xs0 + i * step
        y = ys0 + j * step
        th = headings[hh]
        gs = g[s]
        bits = np.int64(done[s])
        for k in range(nmv):
            m = moves_of[hh, k]
            if m < 0:
                continue
            i2 = i + moves[m, 0]
            j2 = j + moves[m, 1]
            if i2 < 0 or j2 < 0 or i2 >= nx or j2 >= ny:
                continue
            q = j2 * nx + i2
            t = q * H + hh
            ct = code[t]
            if ct >= CLOSED or not math.isfinite(h2d[q]):
                continue
            if not (bits >> k) & 1:
                if ct != UNSEEN and gs + move_lb[m] >= g[t]:
                    continue  # no energy of this move could improve t: left unpriced
                kernel(x, y, th, xs0 + i2 * step, ys0 + j2 * step, th, -1.0, data, buf)
                edges[s, k] = buf[0]
                bits |= 1 << k
                priced += 1
            e = np.float64(edges[s, k])
            if not math.isfinite(e):
                continue
            ng = gs + e
            if ct == UNSEEN or ng < g[t]:
                g[t] = ng
                code[t] = 1 + m
                heap_push(keys, vals, n, ng + h2d[q], t)
        for d in range(2):
            h2 = (hh + 2 * d - 1) % H
            t = p * H + h2
            if code[t] >= CLOSED:
                continue
            if not (bits >> (nmv + d)) & 1:
                kernel(x, y, th, x, y, headings[h2], -1.0, data, buf)
                edges[s, nmv + d] = buf[0]
                bits |= 1 << (nmv + d)
                priced += 1
            e = np.float64(edges[s, nmv + d])
            if not math.isfinite(e):
                continue
            ng = gs + e
            if code[t] == UNSEEN or ng < g[t]:
                g[t] = ng
                code[t] = TURN_FROM_NEXT if d == 0 else TURN_FROM_PREV
                heap_push(keys, vals, n, ng + h2d[p], t)
        done[s] = bits
