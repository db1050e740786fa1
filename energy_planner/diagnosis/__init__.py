"""Diagnosis: how far a model is from the measurements, and which effect it is missing.

The flow (``energy-planner diagnose``): windowed measurements and a fitted model give
power-level errors on windows, energy errors per run, the superposition check of composite
paths, the residual broken down by every variable, a ranked list of suspects (candidate
physical effects validated on held-out runs) and the greedy staircase of held-out error
as the best suspects are added one by one. ``discover`` walks that staircase from raw
logs after the data checks (sensor problems reported as data findings and repaired).

>>> from energy_planner.diagnosis import Thresholds
>>> Thresholds().alpha, Thresholds().min_rel
(0.01, 0.05)
"""

from energy_planner.calibration.windowdata import WindowData, window_data
from energy_planner.diagnosis.core import Diagnosis, diagnose, infer_composites, run_table
from energy_planner.diagnosis.discover import Discovery, discover
from energy_planner.diagnosis.metrics import breakdown, hotspots, power_metrics, superposition
from energy_planner.diagnosis.suspects import (
    Candidate,
    Ranking,
    Step,
    Suspect,
    Thresholds,
    rank_suspects,
    span_residual,
    staircase,
)
from energy_planner.measurements.datacheck import DataFinding, check_data

__all__ = [
    "Candidate",
    "DataFinding",
    "Discovery",
    "check_data",
    "discover",
    "Diagnosis",
    "Ranking",
    "Step",
    "Suspect",
    "Thresholds",
    "WindowData",
    "breakdown",
    "diagnose",
    "hotspots",
    "infer_composites",
    "power_metrics",
    "rank_suspects",
    "run_table",
    "span_residual",
    "staircase",
    "superposition",
    "window_data",
]
