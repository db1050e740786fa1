"""Numba core of a reach map's least-energy paths: the tree of the states they pass.

After :func:`energy_planner.planning.search.reach_search` each reached state's code names
its predecessor (the codes of :mod:`energy_planner.planning._search`: ``1 + m`` reached
by translation ``moves[m]``, a turn from the heading either side, or a start state; +64
once closed). :func:`best_states` picks each position's least-energy state and
:func:`path_tree` the states on the paths to them, parents before children, so that
anything summed along a path is one pass of prefix sums over the tree.
"""

import numba
import numpy as np


@numba.njit(cache=True)
def best_states(g, code, P, H, unseen):
    """Per position the reached state of least ``g`` (-1 where none was reached)."""
    res = np.full(P, -1, np.int64)
    for p in range(P):
        b = np.inf
        for hh in range(H):
            s = p * H + hh
            if code[s] == unseen:
                continue
            if g[s] < b:
                b = g[s]
                res[p] = s
    return res


@numba.njit(cache=True)
def _parent(s, code, moves, nx, H, start, prev, nxt, closed):
    c = code[s] % closed
    if c == start:
        return -1
    p = s // H
    hh = s % H
    if c == prev:
        return p * H + (hh - 1) % H
    if c == nxt:
        return p * H + (hh + 1) % H
    j = p // nx
    i = p % nx
    return ((j - moves[c - 1, 1]) * nx + (i - moves[c - 1, 0])) * H + hh


@numba.njit(cache=True)
def path_tree(code, moves, nx, H, best, start, prev, nxt, closed):
    """The states on the paths from the start to the states ``best`` (>= 0), as a tree.

    Returns ``(states, parent, at)``: the states in an order where each one's parent
    comes first, the index of each one's parent in that order (-1 for a start state),
    and for each entry of ``best`` the index of its state (-1 where ``best`` is -1).
    """
    N = code.shape[0]
    idx = np.full(N, -1, np.int32)  # -1 unseen, -2 marked, >= 0 its place
    count = 0
    for k in range(best.shape[0]):
        s = best[k]
        while s >= 0 and idx[s] == -1:
            idx[s] = -2
            count += 1
            s = _parent(s, code, moves, nx, H, start, prev, nxt, closed)
    states = np.empty(count, np.int64)
    parent = np.empty(count, np.int64)
    stack = np.empty(count, np.int64)
    at = np.full(best.shape[0], -1, np.int64)
    n = 0
    for k in range(best.shape[0]):
        s = best[k]
        if s < 0:
            continue
        top = 0
        while s >= 0 and idx[s] == -2:
            stack[top] = s
            top += 1
            s = _parent(s, code, moves, nx, H, start, prev, nxt, closed)
        up = -1 if s < 0 else idx[s]
        while top > 0:
            top -= 1
            t = stack[top]
            idx[t] = n
            states[n] = t
            parent[n] = up
            up = n
            n += 1
        at[k] = idx[best[k]]
    return states, parent, at


@numba.njit(cache=True)
def prefix_sums(parent, cols, peaks):
    """Along the tree (parents first): ``cols`` summed and ``peaks`` maxed from the root.

    ``cols`` (n, k) and ``peaks`` (n, m) are each state's own motion's values, in place.
    """
    for t in range(parent.shape[0]):
        u = parent[t]
        if u < 0:
            continue
        for c in range(cols.shape[1]):
            cols[t, c] += cols[u, c]
        for c in range(peaks.shape[1]):
            if peaks[u, c] > peaks[t, c]:
                peaks[t, c] = peaks[u, c]


@numba.njit(cache=True)
def parent_tree(pred, best):
    """:func:`path_tree` from each state's predecessor (``pred[s] < 0``: a root).

    ``pred``: scipy's Dijkstra's predecessors (a lattice graph's search, forwards or on
    the transposed graph).
    """
    N = pred.shape[0]
    idx = np.full(N, -1, np.int32)
    count = 0
    for k in range(best.shape[0]):
        s = best[k]
        while s >= 0 and idx[s] == -1:
            idx[s] = -2
            count += 1
            s = pred[s]
    states = np.empty(count, np.int64)
    parent = np.empty(count, np.int64)
    stack = np.empty(count, np.int64)
    at = np.full(best.shape[0], -1, np.int64)
    n = 0
    for k in range(best.shape[0]):
        s = best[k]
        if s < 0:
            continue
        top = 0
        while s >= 0 and idx[s] == -2:
            stack[top] = s
            top += 1
            s = pred[s]
        up = -1 if s < 0 else idx[s]
        while top > 0:
            top -= 1
            t = stack[top]
            idx[t] = n
            states[n] = t
            parent[n] = up
            up = n
            n += 1
        at[k] = idx[best[k]]
    return states, parent, at
