"""Cost-aware local refinement of an SE(2) path, vectorized over the motion-cost batch.

Used by the ``auto`` planner to remove a lattice path's discretisation (16 headings,
16 move directions, a grid of positions). Each round

1. perturbs the interior poses (x, y and yaw) with Gaussian steps: every other pose at
   a time, ``k`` candidates per pose, all priced in one call to ``MotionCost.batch``
   (a pose's two adjacent motions are all that change); a candidate is kept only if it
   lowers the energy of those two motions;
2. tries shortcuts: replacing the poses between ``i`` and ``i + gap`` by one straight
   motion when that costs less (gaps 2, 3, 4, 6, 8, ...);
3. with a cost that chooses its speed, merges each long straight run walked at one yaw
   and one speed into one motion (its shortcuts never gain: each motion of the run takes
   its own best speed, a shortcut one speed for all; they are not priced).

Turns in place are first spread along the following motion (turning while walking), so
that single-pose moves can bend the path. The step size adapts to the acceptance rate.
The result is never dearer than the input, motions
stay finite (limits hold), and with a given ``seed`` the result is reproducible as
long as the refinement converges (or ``max_rounds`` ends it) within the time budget.

OMPL's ``PathSimplifier.perturbPath`` would be the natural tool, but with the PyPI
``ompl`` 2.0.1 bindings it never accepted a perturbation on ``SE2StateSpace`` in our
measurements (it returned False for any step size, with the energy objective and with
path length), so this module does the same job with the library's own kernel.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable

import numpy as np

from energy_planner.angles import wrap
from energy_planner.energy.kernels import OUT_DISTANCE

__all__ = ["densify", "refine_path"]


def densify(states: np.ndarray, spacing: float) -> np.ndarray:
    """Insert poses every ``spacing`` metres along each motion (shortest-arc yaw).

    Examples
    --------
    >>> densify(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 1.0]]), 1.0).tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [2.0, 0.0, 1.0]]
    """
    states = np.asarray(states, float)
    out = [states[:1]]
    for a, b in zip(states[:-1], states[1:], strict=True):
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(1, math.ceil(d / spacing - 1e-9))
        f = (np.arange(1, n + 1) / n)[:, None]
        dth = float(wrap(b[2] - a[2]))
        seg = np.column_stack(
            [a[0] + f[:, 0] * (b[0] - a[0]), a[1] + f[:, 0] * (b[1] - a[1]), a[2] + f[:, 0] * dth]
        )
        seg[:, 2] = wrap(seg[:, 2])
        seg[-1] = b
        out.append(seg)
    return np.vstack(out)


def _edge_costs(cost, s: np.ndarray) -> np.ndarray:
    return cost.batch(s[:-1, 0], s[:-1, 1], s[:-1, 2], s[1:, 0], s[1:, 1], s[1:, 2])


def _shortcut_prices(cost, a: np.ndarray, b: np.ndarray, direct=None) -> np.ndarray:
    """Shortcuts from poses ``a`` to poses ``b``: rows ``direct, t1, walk, t2`` (J).

    ``direct``: straight at the poses' yaws; ``t1 + walk + t2``: turn to face along,
    walk, turn back. ``direct`` (optional mask): the shortcuts whose ``direct`` is
    priced; the others' is NaN.
    """
    h = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
    if direct is None:
        first = cost.batch(a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2])
    else:
        first = np.full(len(a), np.nan)
        d = np.asarray(direct, bool)
        if d.any():
            first[d] = cost.batch(a[d, 0], a[d, 1], a[d, 2], b[d, 0], b[d, 1], b[d, 2])
    return np.array([
        first,
        cost.batch(a[:, 0], a[:, 1], a[:, 2], a[:, 0], a[:, 1], h),
        cost.batch(a[:, 0], a[:, 1], h, b[:, 0], b[:, 1], h),
        cost.batch(b[:, 0], b[:, 1], h, b[:, 0], b[:, 1], b[:, 2]),
    ]).reshape(4, len(a))  # fmt: skip


#: Tolerance (rad) of :func:`_straight_spans`: a run of motions whose yaws and directions
#: agree to it is one straight line walked at one yaw (2e-7 m off line over 2 m).
STRAIGHT_TOL = 1e-7


def _straight_runs(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Straight walks of ``s``, to :data:`STRAIGHT_TOL`: ``(dirs, one_yaw, along)``.

    Per motion its direction and whether it walks at one yaw; per pose between two
    motions whether they walk the same direction.
    """
    d = np.diff(s, axis=0)
    dirs = np.arctan2(d[:, 1], d[:, 0])
    one_yaw = (np.abs(wrap(d[:, 2])) <= STRAIGHT_TOL) & (np.hypot(d[:, 0], d[:, 1]) > 0)
    along = np.abs(wrap(np.diff(dirs))) <= STRAIGHT_TOL
    return dirs, one_yaw, along


def _straight_spans(s: np.ndarray, gap: int) -> tuple[np.ndarray, np.ndarray]:
    """Which shortcuts from pose ``i`` to ``i + gap`` only merge one straight walk.

    ``straight[i]``: the motions from pose ``i`` to ``i + gap`` all walk the same
    direction at the same constant yaw (collinear poses, no turn); ``forward[i]``: and
    that yaw faces along. For a cost that chooses its speed, such a shortcut's
    ``direct`` motion is the same walk at one speed for all of it, where the motions it
    replaces each take their own best speed: never cheaper (up to the sampling of the
    motions), so it is not priced; a forward one's turn-walk-turn is that same walk.

    Examples
    --------
    >>> s = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 1, 0.0]])
    >>> [m.tolist() for m in _straight_spans(s, 2)]
    [[True, False], [True, False]]
    >>> [m.tolist() for m in _straight_spans(s[:, [0, 1, 0]] * [1, 1, 0] + [0, 0, 1.0], 2)]
    [[True, False], [False, False]]
    """
    dirs, one_yaw, along = _straight_runs(s)
    cm = np.r_[0, np.cumsum(~one_yaw)]
    cj = np.r_[0, np.cumsum(~along)]
    i = np.arange(0, len(s) - gap)
    straight = (cm[i + gap] == cm[i]) & (cj[i + gap - 1] == cj[i])
    forward = straight & (
        np.abs(wrap(s[i, 2] - dirs[np.minimum(i, len(dirs) - 1)])) <= STRAIGHT_TOL
    )
    return straight, forward


def _merge_straight(cost, s: np.ndarray, e: np.ndarray):
    """Drop the poses inside straight runs walked at one yaw (gait changes kept).

    As :func:`~energy_planner.planning.lattice.simplify_states` does to the planned path.
    For a cost that chooses its speed: such a run's motions each take their own best
    speed, which its one merged motion cannot (the merged path costs a little more, but it
    is the path the planner returns); merged, later rounds perturb and shortcut a few
    poses rather than every densified one. Returns ``(s, e, priced)``: the merged motions
    priced, and how many.
    """
    from energy_planner.planning.speed import gait_changes

    _, one_yaw, along = _straight_runs(s)
    drop = np.r_[False, one_yaw[:-1] & one_yaw[1:] & along, False]
    if not drop.any():
        return s, e, 0
    # only where the two motions walk at nearly the same speed: the merged one loses
    # (to second order) what their different speeds saved
    dt, _ = cost.best_timing(s[:, 0], s[:, 1], s[:, 2])
    v = cost.details(s[:, 0], s[:, 1], s[:, 2], dt)[:, OUT_DISTANCE] / dt
    drop[1:-1] &= np.abs(v[1:] - v[:-1]) <= MERGE_SPEED_RTOL * np.maximum(v[1:], v[:-1])
    pins = gait_changes(cost, s)
    if pins is not None:
        drop &= ~pins
    # only long runs: a short one's poses are where the next rounds bend the path
    edges = np.diff(np.r_[0, drop.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    for a, b in zip(starts, ends, strict=True):
        if b - a + 1 < MERGE_MIN_RUN:
            drop[a:b] = False
    if not drop.any():
        return s, e, 0
    kept = np.flatnonzero(~drop)
    e2 = e[kept[:-1]].copy()
    merged = np.flatnonzero(np.diff(kept) > 1)
    if merged.size:
        a, b = s[kept[merged]], s[kept[merged + 1]]
        e2[merged] = cost.batch(a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2])
    return s[kept], e2, int(merged.size)


#: Relative difference of speed under which :func:`_merge_straight` merges two motions.
MERGE_SPEED_RTOL = 0.01
#: Motions a straight run has at least for :func:`_merge_straight` to merge it.
MERGE_MIN_RUN = 16


#: Rounds over which :func:`refine_path` averages its gain to decide it has converged.
CALM_WINDOW = 10


#: Shortcut prices a refinement keeps (``memo`` of :func:`_shortcut_pass`): beyond this
#: many, the memo starts again.
MEMO_SIZE = 500_000


def _shortcut_pass(cost, s: np.ndarray, e: np.ndarray, gap: int, memo: dict | None = None):
    """Try every shortcut from pose i to pose i + gap; apply the best non-overlapping ones.

    ``memo``: prices of shortcuts by their end poses (bytes), kept across passes and
    rounds: a shortcut whose ends did not move is not priced again (the same kernel on
    the same poses gives the same numbers).
    """
    n = len(s)
    i = np.arange(0, n - gap)
    csum = np.concatenate([[0.0], np.cumsum(e)])
    old = csum[i + gap] - csum[i]
    a, b = s[i], s[i + gap]
    if getattr(cost, "ranged", False):  # the shortcuts that cannot gain are not priced
        straight, forward = _straight_spans(s, gap)
    else:
        straight = forward = np.zeros(len(i), dtype=bool)
    if memo is None and not straight.any():
        direct, t1, walk, t2 = _shortcut_prices(cost, a, b)
        evals = 4 * len(i)
    else:
        prices = np.full((4, len(i)), np.inf)
        miss = ~forward
        if memo is not None:
            ends = np.ascontiguousarray(np.hstack([a, b]))
            keys = [row.tobytes() for row in ends]
            # a kept price whose direct motion was not priced (a straight run then)
            # serves a straight run only
            got = [memo.get(k) if m else None for k, m in zip(keys, miss, strict=True)]
            hit = np.array([g is not None and (straight[k] or not np.isnan(g[0]))
                            for k, g in enumerate(got)], dtype=bool)  # fmt: skip
            miss &= ~hit
            if hit.any():
                prices[:, hit] = np.array([got[k] for k in np.nonzero(hit)[0]]).T
        evals = 0
        if miss.any():
            new = _shortcut_prices(cost, a[miss], b[miss], direct=~straight[miss])
            prices[:, miss] = new
            evals = 3 * int(miss.sum()) + int((~straight[miss]).sum())
            if memo is not None:
                if len(memo) > MEMO_SIZE:
                    memo.clear()
                for k, col in zip(np.nonzero(miss)[0], new.T, strict=True):
                    memo[keys[k]] = col
        prices[0, np.isnan(prices[0])] = np.inf
        direct, t1, walk, t2 = prices
    h = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
    facing = t1 + walk + t2
    use_b = facing < direct
    new = np.where(use_b, facing, direct)
    # an infeasible (inf) old edge gains inf from a feasible new one and nothing from an
    # infeasible one (inf - inf would be NaN)
    gain = np.where(np.isfinite(old), old - new, np.where(np.isfinite(new), np.inf, 0.0))
    good = np.nonzero(gain > 1e-9 * np.where(np.isfinite(old), np.maximum(old, 1.0), 1.0))[0]
    if good.size == 0:
        return s, e, evals
    taken = np.zeros(n, dtype=bool)  # poses inside or at the ends of a taken shortcut
    chosen = []
    for r in good[np.argsort(-gain[good])]:
        lo = i[r]
        if taken[lo : lo + gap + 1].any():
            continue
        taken[lo : lo + gap + 1] = True
        chosen.append(r)
    chosen.sort(key=lambda r: i[r])
    poses, costs = [], []
    pos = 0
    for r in chosen:
        lo, hi = i[r], i[r] + gap
        poses.append(s[pos : lo + 1])
        costs.append(e[pos:lo])
        if use_b[r]:
            poses.append(np.array([[a[r, 0], a[r, 1], h[r]], [b[r, 0], b[r, 1], h[r]]]))
            costs.append(np.array([t1[r], walk[r], t2[r]]))
        else:
            costs.append(np.array([direct[r]]))
        pos = hi
    poses.append(s[pos:])
    costs.append(e[pos:])
    s2 = np.vstack(poses)
    e2 = np.concatenate(costs)
    # drop zero-length, zero-turn motions (a turn to the yaw the pose already has)
    dup = np.r_[False, np.all(np.abs(np.diff(s2, axis=0)) < 1e-12, axis=1)]
    if dup.any():
        keep = ~dup
        s2 = s2[keep]
        e2 = _edge_costs(cost, s2)
    return s2, e2, evals


def refine_path(
    cost,
    states: np.ndarray,
    *,
    budget: float,
    seed: int = 0,
    spacing: float = 2.0,
    free_start_yaw: bool = False,
    free_goal_yaw: bool = False,
    max_rounds: int | None = None,
    min_rounds: int = 0,
    candidates: int = 8,
    tol: float = 2e-5,
    report: Callable[[float], None] | None = None,
) -> tuple[np.ndarray, dict]:
    """Lower the energy of a feasible path by local moves (never raises it).

    Parameters
    ----------
    cost : MotionCost
        Prices motions (``batch``); infinite costs (limits) are never accepted.
    states : ndarray, shape (n, 3)
        Initial path (working CRS, radians), finite energy.
    budget : float
        Seconds.
    seed : int
        Seed of the perturbations.
    spacing : float
        Pose spacing after densifying the initial path, m.
    free_start_yaw, free_goal_yaw : bool
        Whether the first/last yaw may change (positions never do).
    max_rounds : int, optional
        Stop after this many rounds.
    min_rounds : int
        Run at least this many rounds (unless converged or ``max_rounds`` is smaller),
        even past ``budget``: a floor of work rather than of seconds, the same on a fast
        and a slow machine.
    candidates : int
        Candidates per pose and round.
    tol : float
        Converged after five rounds in a row with a relative gain below ``tol`` and
        a step size below a fiftieth of ``spacing``, or when the last
        :data:`CALM_WINDOW` rounds together gained less than ``CALM_WINDOW * tol``
        (relative): less than ``tol`` a round on average. The step size tells on a long
        path (most of its poses stop accepting moves, the step shrinks); on a short one
        a single accepted move in a round keeps the step (one pose in a few is a high
        acceptance rate), so the step rarely shrinks that far while the rounds gain
        little.
    report : callable, optional
        ``report(energy)`` after each round.

    Returns
    -------
    states : ndarray, shape (m, 3)
    info : dict
        ``rounds``, ``evaluations`` (motions priced), ``converged``.
    """
    t0 = _time.perf_counter()
    rng = np.random.default_rng(seed)
    states = np.asarray(states, float)
    e0 = _edge_costs(cost, states)
    total0 = float(e0.sum())
    # turns in place become turns while walking (the yaw then changes along the next
    # motion), so that moving one pose at a time can bend the path
    same = np.r_[False, np.all(np.diff(states[:, :2], axis=0) == 0, axis=1)]
    same[-1] = False
    s = densify(states[~same], spacing)
    e = _edge_costs(cost, s)
    if not np.isfinite(e).all():
        s = densify(states, spacing)
        e = _edge_costs(cost, s)
    total = float(e.sum())
    sig_xy, sig_yaw = 0.5 * spacing, 0.3
    evals = len(e)
    # a cost that chooses its speed prices each motion at several speeds: the shortcuts
    # whose ends stay put are not priced again in later rounds (a fixed speed's are
    # cheap, and its rounds fill a time budget: its results stay as they were)
    ranged = bool(getattr(cost, "ranged", False))
    memo: dict | None = {} if ranged else None
    rounds = 0
    calm = 0
    totals = [total]  # the energy before round 1, then after each round
    converged = False
    if report is not None:
        report(total)
    while (rounds < min_rounds or _time.perf_counter() - t0 < budget) and (
        max_rounds is None or rounds < max_rounds
    ):
        rounds += 1
        before = total
        tried = accepted = 0
        n = len(s)
        # 1. perturb every other pose, both parities
        for parity in (0, 1):
            lo = 0 if free_start_yaw else 1
            hi = n if free_goal_yaw else n - 1
            idx = np.arange(lo, hi)
            idx = idx[idx % 2 == parity]
            if idx.size == 0:
                continue
            k = candidates
            cand = np.repeat(s[idx][:, None, :], k, axis=1)
            noise = rng.standard_normal((idx.size, k, 3))
            interior = ((idx > 0) & (idx < n - 1))[:, None]
            cand[:, :, 0] += np.where(interior, noise[:, :, 0] * sig_xy, 0.0)
            cand[:, :, 1] += np.where(interior, noise[:, :, 1] * sig_xy, 0.0)
            cand[:, :, 2] = wrap(cand[:, :, 2] + noise[:, :, 2] * sig_yaw)
            c = cand.reshape(-1, 3)
            has_prev = np.repeat(idx > 0, k)
            has_next = np.repeat(idx < n - 1, k)
            prev = s[np.maximum(np.repeat(idx, k) - 1, 0)]
            nxt = s[np.minimum(np.repeat(idx, k) + 1, n - 1)]
            cin = np.zeros(len(c))
            cout = np.zeros(len(c))
            if has_prev.any():
                p, q = prev[has_prev], c[has_prev]
                cin[has_prev] = cost.batch(p[:, 0], p[:, 1], p[:, 2], q[:, 0], q[:, 1], q[:, 2])
            if has_next.any():
                p, q = c[has_next], nxt[has_next]
                cout[has_next] = cost.batch(p[:, 0], p[:, 1], p[:, 2], q[:, 0], q[:, 1], q[:, 2])
            evals += int(has_prev.sum() + has_next.sum())
            cin, cout = cin.reshape(-1, k), cout.reshape(-1, k)
            new = cin + cout
            best = np.argmin(new, axis=1)
            rows = np.arange(idx.size)
            cur = np.where(idx > 0, e[np.maximum(idx - 1, 0)], 0.0) + np.where(
                idx < n - 1, e[np.minimum(idx, n - 2)], 0.0
            )
            # cur * (1 - 1e-9) rather than cur - 1e-9 * cur: an infeasible (inf) current
            # pair must not give inf - inf = NaN
            better = new[rows, best] < np.where(cur > 1.0, cur * (1.0 - 1e-9), cur - 1e-9)
            tried += idx.size
            accepted += int(better.sum())
            for r in np.nonzero(better)[0]:
                i = idx[r]
                s[i] = cand[r, best[r]]
                if i > 0:
                    e[i - 1] = cin[r, best[r]]
                if i < n - 1:
                    e[i] = cout[r, best[r]]
        # 2. shortcuts: straight at the current yaws (A), or turn to face along, walk,
        # turn back (B)
        for gap in (2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128):
            n = len(s)
            if n <= gap:
                break
            s, e, k = _shortcut_pass(cost, s, e, gap, memo)
            evals += k
        if ranged:
            s, e, k = _merge_straight(cost, s, e)
            evals += k
        total = float(e.sum())
        rate = accepted / max(tried, 1)
        if rate < 0.05:
            sig_xy, sig_yaw = sig_xy * 0.8, sig_yaw * 0.8
        elif rate > 0.2:
            sig_xy, sig_yaw = min(sig_xy * 1.25, spacing), min(sig_yaw * 1.25, 0.5)
        if report is not None:
            report(min(total, total0))
        gain = (before - total) / max(abs(before), 1e-12)
        calm = calm + 1 if gain < tol else 0
        totals.append(total)
        if calm >= 5 and sig_xy < 0.02 * spacing:
            converged = True
            break
        if len(totals) > CALM_WINDOW:
            ref = totals[-CALM_WINDOW - 1]
            if (ref - total) / max(abs(ref), 1e-12) < CALM_WINDOW * tol:
                converged = True
                break
    if not total < total0:  # never return something dearer than the input
        return states.copy(), {"rounds": rounds, "evaluations": evals, "converged": converged}
    return s, {"rounds": rounds, "evaluations": evals, "converged": converged}
