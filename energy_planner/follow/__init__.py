"""Follow a mission: online slope check, coefficient updates and remaining energy.

>>> from energy_planner.follow import Follower  # doctest: +SKIP
>>> f = Follower(terrain, model, path_xy, battery_wh=500, reserve_wh=50)  # doctest: +SKIP
>>> updates = f.replay(log_samples)  # doctest: +SKIP

See :mod:`energy_planner.follow.core` and ``docs/follow.md``.
"""

from energy_planner.follow.calibrate import RemainingScores, bundled_scores, calibrate_remaining
from energy_planner.follow.core import (
    Follower,
    FollowError,
    FollowUpdate,
    SlopeFinding,
    follow_log,
    imu_gradient,
)
from energy_planner.follow.rls import ForgettingRLS, seed_covariance
from energy_planner.follow.terms import (
    PathTerms,
    coefficient_channels,
    path_term_energies,
    runtime_coefficient_model,
)
from energy_planner.measurements.poses import fresh_poses, walked_path

__all__ = [
    "FollowError",
    "FollowUpdate",
    "Follower",
    "ForgettingRLS",
    "PathTerms",
    "RemainingScores",
    "SlopeFinding",
    "bundled_scores",
    "calibrate_remaining",
    "coefficient_channels",
    "follow_log",
    "fresh_poses",
    "imu_gradient",
    "path_term_energies",
    "runtime_coefficient_model",
    "seed_covariance",
    "walked_path",
]
