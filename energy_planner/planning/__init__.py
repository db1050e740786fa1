"""Energy-minimal planning on SE(2): lattice reference, OMPL planners, route comparison.

Heavy imports (ompl, numba, matplotlib) happen inside the submodules that need them;
importing this package is cheap.

>>> from energy_planner.planning import PLANNERS
>>> PLANNERS
('auto', 'lattice', 'rrtstar', 'sorrtstar', 'bitstar')
"""

from __future__ import annotations

from typing import Any

#: Planner names accepted by :func:`plan`.
PLANNERS: tuple[str, ...] = ("auto", "lattice", "rrtstar", "sorrtstar", "bitstar")

__all__ = ["PLANNERS", "plan", "PlanResult", "compare_routes", "RouteComparison"]


def __getattr__(name: str) -> Any:
    if name in ("plan", "PlanResult"):
        from energy_planner.planning import plan as _plan

        return getattr(_plan, name)
    if name in ("compare_routes", "RouteComparison"):
        from energy_planner.planning import compare as _compare

        return getattr(_compare, name)
    raise AttributeError(f"module 'energy_planner.planning' has no attribute {name!r}")
