"""OMPL optimization objective on SE(2) whose motion cost is the energy kernel.

``motionCost(s1, s2)`` is exactly ``MotionCost.kernel(x1, y1, yaw1, x2, y2, yaw2)``: the
same numba function that prices every other path in the library, so a planned path and
a queried path never disagree. A motion that leaves valid terrain, crosses a keep-out
cell or breaks a slope limit costs ``inf`` and is never part of a finite-cost solution.

Facts about the PyPI ``ompl`` 2.0.1 bindings this relies on (measured, see the project's
OMPL notes): a Python objective must define ``stateCost`` and return :class:`ob.Cost`;
``isSymmetric()`` must return False for a direction-dependent cost (otherwise RRT* reuses
the forward cost for the reverse motion); ``motionCostHeuristic`` is honoured by BIT*
and SORRT*. A cost-to-go cannot be handed to 2.0.1 otherwise: ``costToGo`` is not
virtual and ``setCostToGoHeuristic`` rejects Python callables, so :class:`CostToGo` (the
search's 2-D relaxed heuristic) enters through ``motionCostHeuristic(s, goal)``, which
is how BIT* estimates every vertex's cost-to-go.
"""

from __future__ import annotations

import math

import numpy as np
from ompl import base as ob

from energy_planner.angles import wrap

__all__ = [
    "COST_TO_GO_MARGIN",
    "CostToGo",
    "EnergyObjective",
    "bind_kernel",
    "make_space",
    "set_state",
    "path_states",
    "path_cost",
]

# re-exported: they live in binding.py so that planning without OMPL does not import it
from energy_planner.planning.binding import bind_kernel, path_cost  # noqa: E402

#: Scale of the search's relaxed cost-to-go for off-lattice states and motions. The
#: relaxed problem moves in the 16 lattice directions only: on ground of uniform cost a
#: straight motion between two of them (largest gap 26.57 deg) is 1/cos(13.28 deg) =
#: 1.0275 times shorter than its lattice zig-zag, so ``h / 1.0275`` still bounds it;
#: 0.97 adds room for the 16 body yaws of the relaxed table against any continuous yaw
#: and for gradients between cells. Checked, not proven, for general terrain:
#: ``tests/test_planning_objective.py`` compares it with the search's optimum and with
#: the kernel's direct motion from hypothesis-drawn poses.
COST_TO_GO_MARGIN = 0.97


class CostToGo:
    """Admissible estimate of the least energy from a position to one goal position.

    The search's 2-D relaxed heuristic
    (:func:`energy_planner.planning.search.relaxed_cost_to_go`: backward Dijkstra of the
    least J per metre over all body yaws, turns free) on positions aligned with the goal,
    read at a continuous ``(x, y)`` as the least of the (up to) four surrounding
    positions, times :data:`COST_TO_GO_MARGIN`. Bilinear interpolation would not be a
    lower bound (``h`` is not convex); the least corner is, up to the cost of the part of
    a cell (within ``step * sqrt(2)`` of ``(x, y)``) that the margin covers.

    Parameters
    ----------
    cost : MotionCost
        The motion cost the planner optimises (its limits make cells unreachable).
    terrain : Terrain
        The map (positions cover its extent).
    goal_xy : tuple of float
        Goal position in the working CRS.
    step : float, optional
        Position spacing, m (default: the DEM's cell size, as the search).
    margin : float
        Scale applied to ``h`` (default :data:`COST_TO_GO_MARGIN`).

    Attributes
    ----------
    h : ndarray, shape (ny, nx)
        The relaxed cost-to-go at the positions, J (``inf``: unreachable even relaxed).
    build_s : float
        Wall time of the relaxed problem, s.
    """

    def __init__(self, cost, terrain, goal_xy, *, step=None, margin=COST_TO_GO_MARGIN):
        import time

        from energy_planner.planning.search import _Grid, relaxed_cost_to_go, search_module

        t0 = time.perf_counter()
        grid = _Grid(cost, terrain, (float(goal_xy[0]), float(goal_xy[1])), step, 16, "all")
        pg = grid.position(float(goal_xy[0]), float(goal_xy[1]), "goal")
        h = relaxed_cost_to_go(cost, grid, pg, mod=search_module(cost, "path"))
        # inf = no relaxed path from that position: keep no information there rather
        # than prune a state that a continuous motion might still get through
        h = np.where(np.isfinite(h), h, 0.0) * float(margin)
        self.h = h.reshape(grid.ny, grid.nx)
        self.goal = (float(goal_xy[0]), float(goal_xy[1]))
        self._x0, self._y0, self._step = float(grid.xs[0]), float(grid.ys[0]), grid.step
        self._nx, self._ny = grid.nx, grid.ny
        self._rows = self.h.tolist()  # Python floats: faster to index one by one
        self.build_s = time.perf_counter() - t0

    def __call__(self, x: float, y: float) -> float:
        """Lower bound of the energy from ``(x, y)`` (any yaw) to the goal, J."""
        fi = (x - self._x0) / self._step
        fj = (y - self._y0) / self._step
        i0, j0 = math.floor(fi), math.floor(fj)
        best = math.inf
        for j in (j0, j0 + 1):
            if 0 <= j < self._ny:
                row = self._rows[j]
                for i in (i0, i0 + 1):
                    if 0 <= i < self._nx and row[i] < best:
                        best = row[i]
        return best if best < math.inf else 0.0


class EnergyObjective(ob.OptimizationObjective):
    """Energy (J) of SE(2) motions from a :class:`~energy_planner.energy.MotionCost`.

    Parameters
    ----------
    si : ompl.base.SpaceInformation
        Space information of an ``SE2StateSpace``.
    cost : MotionCost
        Supplies ``kernel`` (the numba function) and ``min_cost_per_metre``.
    cost_to_go : CostToGo, optional
        Cost-to-go to the goal position; ``motionCostHeuristic(s, goal)`` uses it.

    Attributes
    ----------
    calls : int
        Number of ``motionCost`` evaluations (for benchmarks).
    priced : int
        Kernel evaluations: ``motionCost`` calls not answered by ``cache``, plus those
        of a pricing motion validator (for benchmarks).
    """

    def __init__(self, si, cost, cost_to_go: CostToGo | None = None) -> None:
        super().__init__(si)
        self._kernel = bind_kernel(cost)
        self._lb = max(float(getattr(cost, "min_cost_per_metre", 0.0)), 0.0)
        self.cost_to_go = cost_to_go
        self._ctg_memo = [math.nan, math.nan, 0.0]  # x, y, cost-to-go of the last s1
        self.calls = 0
        self.priced = 0
        self.cache: dict | None = None  # filled by a pricing motion validator, if any
        self.setCostThreshold(ob.Cost(0.0))

    def motionCost(self, s1, s2):  # noqa: N802 - OMPL's name
        """Energy of the straight SE(2) motion from ``s1`` to ``s2`` (J)."""
        self.calls += 1
        key = (s1.getX(), s1.getY(), s1.getYaw(), s2.getX(), s2.getY(), s2.getYaw())
        if self.cache is not None:
            e = self.cache.get(key)
            if e is not None:
                return ob.Cost(e)
        self.priced += 1
        return ob.Cost(self._kernel(*key))

    def stateCost(self, s):  # noqa: N802 - OMPL's name
        """Energy is spent by motions only: zero per state."""
        return ob.Cost(0.0)

    def isSymmetric(self) -> bool:  # noqa: N802 - OMPL's name
        """False: climbing and descending cost differently."""
        return False

    def motionCostHeuristic(self, s1, s2):  # noqa: N802 - OMPL's name
        """Admissible lower bound of the energy from ``s1`` to ``s2``.

        The minimum J per metre times the planar distance; when ``s2`` lies on the goal
        position and a :class:`CostToGo` is set, at least its value at ``s1`` (a lower
        bound of every path to the goal, hence of the motion). BIT* calls this with
        each goal sample as ``s2`` to estimate cost-to-go.
        """
        x1, y1, x2, y2 = s1.getX(), s1.getY(), s2.getX(), s2.getY()
        lbd = self._lb * math.hypot(x2 - x1, y2 - y1)
        ctg = self.cost_to_go
        if ctg is not None and x2 == ctg.goal[0] and y2 == ctg.goal[1]:
            # BIT* asks once per goal sample (16 yaws) for the same s1: keep the last
            memo = self._ctg_memo
            if memo[0] != x1 or memo[1] != y1:
                memo[0], memo[1], memo[2] = x1, y1, ctg(x1, y1)
            return ob.Cost(max(lbd, memo[2]))
        return ob.Cost(lbd)


def make_space(terrain):
    """An ``SE2StateSpace`` bounded by the terrain's extent in the working CRS."""
    from energy_planner.planning.moves import terrain_extent

    xmin, xmax, ymin, ymax = terrain_extent(terrain)
    space = ob.SE2StateSpace()
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(0, xmin)
    bounds.setHigh(0, xmax)
    bounds.setLow(1, ymin)
    bounds.setHigh(1, ymax)
    space.setBounds(bounds)
    return space


def set_state(state, x: float, y: float, yaw: float) -> None:
    """Write a pose into an SE(2) state (yaw wrapped to (-pi, pi])."""
    state.setX(float(x))
    state.setY(float(y))
    state.setYaw(float(wrap(yaw)))


def path_states(path) -> np.ndarray:
    """Copy an OMPL ``PathGeometric``'s states to an ``(n, 3)`` float array at once."""
    return np.array([(s.getX(), s.getY(), s.getYaw()) for s in path.getStates()], dtype=float)
