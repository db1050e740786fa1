"""What every result of a verb shares: the Problem it was made on and a short repr.

A result (:class:`~energy_planner.planning.plan.PlanResult`,
:class:`~energy_planner.energy.path.PathEnergy`,
:class:`~energy_planner.planning.routes.RouteComparison`,
:class:`~energy_planner.planning.reach.ReachMap`,
:class:`~energy_planner.mission.MissionResult`) remembers the
:class:`~energy_planner.problem.Problem` it was computed on (:attr:`Result.problem`), so
that it writes itself with one argument, the destination: ``write_json(path)``,
``write_geojson(path)``, ``write_bag(path)``, ``write_html(path)``, ``plot(path)``. A
``terrain=`` (and ``request=``) keyword still overrides what it remembers, and the older
order ``plot(terrain, path)`` is read as ``plot(path, terrain=terrain)``.

This module holds no computation and imports no other unit of the package.

Examples
--------
>>> from dataclasses import dataclass
>>> import numpy as np
>>> @dataclass(repr=False)
... class R(Result):
...     energy_j: float
...     states: np.ndarray
>>> R(12.5, np.zeros((1000, 3)))
R(energy_j=12.5, states=<array 1000x3>)
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["REPR_MAX", "Result", "path_first"]

#: The longest repr of a result, characters.
REPR_MAX = 300


def path_first(path: Any, terrain: Any) -> tuple[Any, Any]:
    """``(path, terrain)`` of a writer called so, or in the older order ``(terrain, path)``.

    A terrain is recognised by its ``to_work`` method (a path has none).
    """
    if hasattr(path, "to_work") and terrain is not None and not hasattr(terrain, "to_work"):
        return terrain, path
    return path, terrain


class Result:
    """A verb's result: remembers its :class:`~energy_planner.problem.Problem`.

    Attributes
    ----------
    problem : Problem or None
        The terrain, model and request the result was computed on (set by the verbs).
    """

    problem: Any = None

    def _terrain(self, terrain: Any = None) -> Any:
        """``terrain`` if given, else the remembered Problem's (an error without either)."""
        if terrain is not None:
            return terrain
        if self.problem is None:
            raise ValueError(
                f"this {type(self).__name__} does not know its terrain (it was not made by a "
                "verb of energy_planner): give terrain="
            )
        return self.problem.terrain

    def _request(self, request: Any = None) -> Any:
        """``request`` if given, else the remembered Problem's (None without one)."""
        if request is not None or self.problem is None:
            return request
        return self.problem.request

    def _problem_for(self, problem: Any = None) -> Any:
        """``problem`` if given, else the remembered one (an error without either)."""
        if problem is None:
            if self.problem is None:
                raise ValueError(f"this {type(self).__name__} does not know its Problem: give one")
            return self.problem
        return problem

    def __repr__(self) -> str:
        """Class name and the scalar fields (arrays by shape), at most :data:`REPR_MAX` chars."""
        parts = []
        fields = dataclasses.fields(self) if dataclasses.is_dataclass(self) else ()
        for f in fields:
            if not f.repr:
                continue
            parts.append(f"{f.name}={_short(getattr(self, f.name))}")
        text = f"{type(self).__name__}({', '.join(parts)})"
        return text if len(text) <= REPR_MAX else text[: REPR_MAX - 4] + "...)"


def _short(v: Any) -> str:
    """A value in a few characters: numbers rounded, arrays and containers by size."""
    if isinstance(v, np.ndarray):
        return f"<array {'x'.join(str(n) for n in v.shape)}>"
    if isinstance(v, float | np.floating):
        return f"{float(v):.10g}"
    if isinstance(v, dict):
        return f"<dict of {len(v)}>"
    scalar = (int, float, str, bool, type(None), np.number)
    if isinstance(v, list | tuple) and (len(v) > 4 or not all(isinstance(x, scalar) for x in v)):
        return f"<{type(v).__name__} of {len(v)}>"
    if isinstance(v, list | tuple):
        return "(" + ", ".join(_short(x) for x in v) + ("," if len(v) == 1 else "") + ")"
    if not isinstance(v, str | Result) and hasattr(v, "__len__"):
        return f"<{type(v).__name__} of {len(v)}>"
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."
