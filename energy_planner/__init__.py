"""energy_planner: energy-minimal routes for legged robots on sloping ground.

Data flows one way (see ``docs/architecture.md``)::

    terrain  -> model -> energy (path energy) -> planning
    measurements -> calibration -> diagnosis

Heavy modules (rasterio, ompl, numba) are imported by the subpackages that need them,
not here, so ``import energy_planner`` stays cheap.
"""

from energy_planner.errors import EnergyPlannerError

__version__ = "0.1.0"
__all__ = ["EnergyPlannerError", "__version__"]
