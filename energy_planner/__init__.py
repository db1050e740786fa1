"""energy_planner: energy-minimal routes for legged robots on sloping ground.

The public API is at the top level (``import energy_planner as ep``)::

    prob = ep.Problem.from_dem("hill", max_slope_deg=30)   # terrain+model+limits
    res = ep.plan(prob, start, goal)          # or ep.plan("hill", start, goal)
    ep.path_energy(prob, points), ep.compare_routes(...), ep.reach(...),
    ep.energy_map(...), ep.mission(...), ep.fit(logs), ep.discover(logs)
    ep.predict_interval(model, energy_j), ep.battery_decision(model, energy_j, wh)
    ep.path_trust(model, energy_j, duration_s, ep.path_domain(model, terrain, path_energy))

Data flows one way (see ``docs/architecture.md``)::

    terrain  -> model -> energy (path energy) -> planning -> mission
    measurements -> calibration -> diagnosis

Names are imported on first use (module ``__getattr__``), so ``import energy_planner``
stays cheap: rasterio, ompl and numba load only with the verb that needs them, and the
package itself imports nothing (not even :mod:`typing`, which ``energy-planner --help``
does without).
"""

from __future__ import annotations

import sys

__version__ = "0.1.0"

#: public name -> module that defines it
_LAZY: dict[str, str] = {
    "EnergyPlannerError": "energy_planner.errors",
    "Problem": "energy_planner.api",
    "open_terrain": "energy_planner.api",
    "load_model": "energy_planner.api",
    "plan": "energy_planner.api",
    "pareto": "energy_planner.api",
    "path_energy": "energy_planner.api",
    "compare_routes": "energy_planner.api",
    "reach": "energy_planner.api",
    "energy_map": "energy_planner.api",
    "mission": "energy_planner.api",
    "fit": "energy_planner.api",
    "discover": "energy_planner.api",
    "Terrain": "energy_planner.terrain",
    "EnergyModel": "energy_planner.model",
    "Request": "energy_planner.request",
    "Sites": "energy_planner.mission",
    "read_sites": "energy_planner.mission",
    "EnergyInterval": "energy_planner.uncertainty",
    "predict_interval": "energy_planner.uncertainty",
    "battery_decision": "energy_planner.uncertainty",
    "path_domain": "energy_planner.uncertainty",
    "path_trust": "energy_planner.uncertainty",
    "success_probability": "energy_planner.uncertainty",
    "map_path": "energy_planner.maps",
    "Follower": "energy_planner.follow",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str) -> object:
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'energy_planner' has no attribute {name!r}")
    __import__(mod)
    value = getattr(sys.modules[mod], name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
