"""Calibrate an energy model from a robot's own logs (paper section IV).

Two ways, on the windows built by :mod:`energy_planner.measurements`:

* :func:`fit_forces` - the paper's way: per-window force estimates ``P / v`` (straight
  runs) and yaw torques ``P / |w|`` (turns in place) indexed by slope and heading, then a
  compact fit of each force as a function of ``(alpha, gamma)``;
* :func:`fit_model` - a joint weighted least-squares fit of every term on all windows,
  with standard errors, specific warnings where the data cannot support a term, and
  held-out errors from :func:`cross_validate`, which validates by run.

Raw logs reach them through :func:`prepare_logs` (data checks, repairs kept only if the
held-out error does not rise, cleaning, windows): the one pipeline of fit, diagnose and
discover. It sits here, not in :mod:`energy_planner.measurements`, because its repair
guard scores each repair by a held-out fit (:mod:`energy_planner.calibration.windowdata`).
"""

from energy_planner.calibration.fit import (
    CrossValidation,
    FitResult,
    cross_validate,
    fit_model,
)
from energy_planner.calibration.forces import ForceFit, fit_forces, force_estimates
from energy_planner.calibration.prepare import PreparedLogs, findings_text, prepare_logs

__all__ = [
    "CrossValidation",
    "PreparedLogs",
    "FitResult",
    "ForceFit",
    "cross_validate",
    "fit_forces",
    "fit_model",
    "findings_text",
    "force_estimates",
    "prepare_logs",
]
