"""The window view of the logs: lives in :mod:`energy_planner.calibration.windowdata`.

Kept so that ``from energy_planner.diagnosis.data import window_data`` goes on working.
"""

from energy_planner.calibration.windowdata import (  # noqa: F401 (re-exported)
    MAX_CATEGORIES,
    WindowData,
    window_data,
)

__all__ = ["MAX_CATEGORIES", "WindowData", "window_data"]
