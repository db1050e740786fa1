"""The names of the planners (:func:`energy_planner.planning.plan`), without the planners.

A command that only lists them (its ``--planner`` choices) imports this module, not
:mod:`energy_planner.planning`, whose package imports the planners and the route
comparison (about 10 ms of every command's start-up).

>>> from energy_planner.planners import PLANNERS
>>> PLANNERS
('auto', 'search', 'lattice', 'rrtstar', 'sorrtstar', 'bitstar')
"""

from __future__ import annotations

#: Planner names accepted by :func:`energy_planner.planning.plan`.
PLANNERS: tuple[str, ...] = ("auto", "search", "lattice", "rrtstar", "sorrtstar", "bitstar")
