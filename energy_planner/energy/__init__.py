"""Energy of SE(2) motions and of given paths over a terrain.

:class:`MotionCost` is the single numba-backed cost that path queries
(:func:`path_energy`) and planners share, so a planned path and a queried path never
disagree.
"""

from energy_planner.energy.grade import GradeCost, critical_grade, grade_cost
from energy_planner.energy.motion import MotionCost
from energy_planner.energy.path import SEGMENT_COLUMNS, PathEnergy, path_energy
from energy_planner.energy.waypoints import (
    Waypoints,
    read_waypoints,
    waypoints_to_work,
    write_waypoints_geojson,
    yaw_from_work,
    yaw_to_work,
)

__all__ = [
    "SEGMENT_COLUMNS",
    "GradeCost",
    "MotionCost",
    "PathEnergy",
    "Waypoints",
    "critical_grade",
    "grade_cost",
    "path_energy",
    "read_waypoints",
    "waypoints_to_work",
    "write_waypoints_geojson",
    "yaw_from_work",
    "yaw_to_work",
]
