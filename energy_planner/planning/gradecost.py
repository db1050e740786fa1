"""The cost per metre of walking up a grade: lives in :mod:`energy_planner.energy.grade`.

Kept so that ``from energy_planner.planning.gradecost import grade_cost`` goes on working.
"""

from energy_planner.energy.grade import GradeCost, critical_grade, grade_cost

__all__ = ["GradeCost", "critical_grade", "grade_cost"]
