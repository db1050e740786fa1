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

from energy_planner.angles import wrap

__all__ = ["EnergyObjective", "bind_kernel", "make_space", "set_state", "path_states", "path_cost"]

# re-exported: they live in binding.py so that planning without OMPL does not import it
from energy_planner.planning.binding import bind_kernel, path_cost  # noqa: E402


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
        return ob.Cost(self._kernel(*key))

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
