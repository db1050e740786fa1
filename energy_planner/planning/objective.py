"""OMPL optimization objective on SE(2) whose motion cost is the energy kernel.

``motionCost(s1, s2)`` is exactly ``MotionCost.kernel(x1, y1, yaw1, x2, y2, yaw2)``: the
same numba function that prices every other path in the library, so a planned path and
a queried path never disagree. A motion that leaves valid terrain, crosses a keep-out
cell or breaks a slope limit costs ``inf`` and is never part of a finite-cost solution.

Facts about the PyPI ``ompl`` 2.0.1 bindings this relies on (measured, see the project's
OMPL notes): a Python objective must define ``stateCost`` and return :class:`ob.Cost`;
``isSymmetric()`` must return False for a direction-dependent cost (otherwise RRT* reuses
the forward cost for the reverse motion); ``motionCostHeuristic`` is honoured by BIT*
and SORRT*.
"""

from __future__ import annotations

import math

import numpy as np
from ompl import base as ob

__all__ = ["EnergyObjective", "bind_kernel", "make_space", "set_state", "path_states", "path_cost"]

_BOUND: dict = {}


def bind_kernel(cost):
    """A fast Python-callable ``f(x0, y0, th0, x1, y1, th1) -> J`` for ``cost``.

    ``MotionCost.kernel`` takes the terrain/limit data tuple as a seventh argument;
    passing that tuple from Python unboxes three arrays per call (about 14 us). Here the
    tuple sits in a numba jitclass, which unboxes as one pointer, and a small njit
    wrapper calls the kernel with it (about 1 us per call, most of it numba's dispatch).
    A cost whose ``kernel`` takes six arguments is returned as is.
    """
    data = getattr(cost, "data", None)
    kernel = cost.kernel
    if data is None:
        return kernel
    import numba
    from numba.experimental import jitclass

    dtype = numba.typeof(data)
    key = (id(kernel), str(dtype))
    if key not in _BOUND:
        holder_cls = jitclass([("data", dtype)])(_make_holder_class())

        @numba.njit
        def call(x0, y0, th0, x1, y1, th1, holder):
            return kernel(x0, y0, th0, x1, y1, th1, holder.data)

        _BOUND[key] = (holder_cls, call, kernel)  # keep kernel alive: the key uses its id
    holder_cls, call, _ = _BOUND[key]
    cache = getattr(cost, "_planning_bound", None)
    if cache is not None and cache[0] is data:
        return cache[1]
    holder = holder_cls(data)

    def f(x0, y0, th0, x1, y1, th1):
        return call(x0, y0, th0, x1, y1, th1, holder)

    try:
        cost._planning_bound = (data, f)
    except AttributeError:
        pass
    return f


def _make_holder_class():
    class _Holder:
        def __init__(self, data):
            self.data = data

    return _Holder


class EnergyObjective(ob.OptimizationObjective):
    """Energy (J) of SE(2) motions from a :class:`~energy_planner.energy.MotionCost`.

    Parameters
    ----------
    si : ompl.base.SpaceInformation
        Space information of an ``SE2StateSpace``.
    cost : MotionCost
        Supplies ``kernel`` (the numba function) and ``min_cost_per_metre``.

    Attributes
    ----------
    calls : int
        Number of ``motionCost`` evaluations (for benchmarks).
    """

    def __init__(self, si, cost) -> None:
        super().__init__(si)
        self._kernel = bind_kernel(cost)
        self._lb = max(float(getattr(cost, "min_cost_per_metre", 0.0)), 0.0)
        self.calls = 0
        self.setCostThreshold(ob.Cost(0.0))

    def motionCost(self, s1, s2):  # noqa: N802 - OMPL's name
        """Energy of the straight SE(2) motion from ``s1`` to ``s2`` (J)."""
        self.calls += 1
        return ob.Cost(
            self._kernel(s1.getX(), s1.getY(), s1.getYaw(), s2.getX(), s2.getY(), s2.getYaw())
        )

    def stateCost(self, s):  # noqa: N802 - OMPL's name
        """Energy is spent by motions only: zero per state."""
        return ob.Cost(0.0)

    def isSymmetric(self) -> bool:  # noqa: N802 - OMPL's name
        """False: climbing and descending cost differently."""
        return False

    def motionCostHeuristic(self, s1, s2):  # noqa: N802 - OMPL's name
        """Admissible lower bound: minimum J per metre times the planar distance."""
        return ob.Cost(self._lb * math.hypot(s2.getX() - s1.getX(), s2.getY() - s1.getY()))


def make_space(terrain):
    """An ``SE2StateSpace`` bounded by the terrain's extent in the working CRS."""
    from energy_planner.planning.lattice import _terrain_extent

    xmin, xmax, ymin, ymax = _terrain_extent(terrain)
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
    state.setYaw(float(math.remainder(yaw, 2 * math.pi)))


def path_states(path) -> np.ndarray:
    """Copy an OMPL ``PathGeometric``'s states to an ``(n, 3)`` float array at once."""
    return np.array([(s.getX(), s.getY(), s.getYaw()) for s in path.getStates()], dtype=float)


def path_cost(kernel, states: np.ndarray) -> float:
    """Sum of the kernel over consecutive poses (the objective's cost of the path)."""
    s = np.asarray(states, float)
    return float(sum(kernel(*s[k], *s[k + 1]) for k in range(len(s) - 1)) if len(s) > 1 else 0.0)
