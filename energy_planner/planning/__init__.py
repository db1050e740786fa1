"""Energy-minimal planning on SE(2): full-resolution search, lattice reference, OMPL, routes.

Heavy imports (ompl, numba, matplotlib) happen inside the submodules that need them;
importing this package is cheap.

>>> from energy_planner.planning import PLANNERS
>>> PLANNERS
('auto', 'search', 'lattice', 'rrtstar', 'sorrtstar', 'bitstar')
"""

from __future__ import annotations

#: Planner names accepted by :func:`plan` (defined in :mod:`energy_planner.planners`, which
#: a command imports to list them without importing the planners).
from energy_planner.planners import PLANNERS

__all__ = ["PLANNERS", "plan", "PlanResult", "compare_routes", "RouteComparison"]

# After PLANNERS: plan.py reads it. These modules import ompl, numba and matplotlib only
# inside their functions, so importing them here stays cheap. (A lazy __getattr__ cannot
# serve ``plan``: the submodule of the same name shadows it, and it recursed.)
from energy_planner.planning.compare import RouteComparison, compare_routes  # noqa: E402
from energy_planner.planning.plan import PlanResult, plan  # noqa: E402
