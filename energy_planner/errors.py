"""Exception hierarchy.

Every error the library raises on purpose derives from :class:`EnergyPlannerError` and
from the builtin that fits it best, as rasterio does (``RasterioIOError(RasterioError,
OSError)``), so callers can catch either. Messages name the offending value, the file
and what was expected.
"""

from __future__ import annotations


class EnergyPlannerError(Exception):
    """Base class of all energy_planner errors."""


class DEMError(EnergyPlannerError, ValueError):
    """A DEM cannot be used as given (bad band, all nodata, unusable CRS, ...)."""


class DEMIOError(EnergyPlannerError, OSError):
    """A DEM file cannot be found or opened."""


class OutsideMapError(EnergyPlannerError, ValueError):
    """A position lies outside the map or on nodata."""


class ModelError(EnergyPlannerError, ValueError):
    """An energy model is malformed: unknown term, bad coefficient, bad schema version."""


class FormulaError(ModelError):
    """A term formula cannot be parsed or names an unknown variable or function."""


class LogError(EnergyPlannerError, ValueError):
    """A robot log is malformed: missing column, time going backwards, absurd values."""


class LogIOError(EnergyPlannerError, OSError):
    """A robot log file cannot be found or read."""


class FitError(EnergyPlannerError, ValueError):
    """A fit cannot be made: too little data, a term the data cannot support."""


class PlanningError(EnergyPlannerError, RuntimeError):
    """No valid plan: start/goal invalid, no solution within the budget."""


class PlanningConfigError(PlanningError, ValueError):
    """A planning request is malformed: unknown planner, bad keep-out file, bad pose."""


class InvalidStateError(PlanningError, ValueError):
    """A start or goal breaks a limit (outside the map, too steep, in a keep-out area)."""


class RemovedAPIError(EnergyPlannerError, ImportError):
    """A name that was removed; the message says what replaces it."""
