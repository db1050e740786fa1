"""Missions: several sites, the least-energy order, each leg planned.

>>> from energy_planner.mission import held_karp
>>> held_karp([[0, 2, 9], [9, 0, 2], [2, 9, 0]], return_to_start=True)
([0, 1, 2], 6.0)
"""

import sys
import types

from energy_planner.mission.core import Leg, MissionResult, energy_matrix, mission
from energy_planner.mission.sites import Sites, read_sites
from energy_planner.mission.tour import (
    EXACT_MAX_SITES,
    SettledOrder,
    brute_force,
    held_karp,
    order_sites,
    settle_order,
)

__all__ = [
    "EXACT_MAX_SITES",
    "Leg",
    "MissionResult",
    "SettledOrder",
    "Sites",
    "brute_force",
    "energy_matrix",
    "held_karp",
    "mission",
    "order_sites",
    "settle_order",
    "read_sites",
]


class _VerbModule(types.ModuleType):
    """The missions package, callable as the top-level verb ``ep.mission``.

    Importing ``energy_planner.mission`` sets the package's attribute ``mission`` to this
    module (Python's import system does), hiding the verb of the same name: calling the
    module does what :func:`energy_planner.api.mission` does, so ``ep.mission(...)`` works
    whatever was imported first.
    """

    def __call__(self, *args, **kwargs):
        from energy_planner.mission.verb import mission as verb

        return verb(*args, **kwargs)

    @property
    def __signature__(self):
        """The verb's signature (``inspect.signature(ep.mission)``, ``help``'s first line)."""
        import inspect

        from energy_planner.mission.verb import mission as verb

        return inspect.signature(verb)


sys.modules[__name__].__class__ = _VerbModule


def _verb_help() -> str:
    """The package's help ends with the verb's, so ``help(ep.mission)`` lists its options."""
    from energy_planner.mission.verb import mission as verb

    return f"{__doc__}\n\nCalled as ``ep.mission(dem, sites, ...)``: {verb.__doc__}"


__doc__ = _verb_help()
