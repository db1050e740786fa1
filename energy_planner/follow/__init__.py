"""Follow a mission: online slope check, coefficient updates and remaining energy.

>>> from energy_planner.follow import Follower  # doctest: +SKIP
>>> f = Follower(terrain, model, path_xy, battery_wh=500, reserve_wh=50)  # doctest: +SKIP
>>> updates = f.replay(log_samples)  # doctest: +SKIP

See :mod:`energy_planner.follow.core` and ``docs/follow.md``.
"""

from energy_planner.follow.calibrate import RemainingScores, calibrate_remaining
from energy_planner.follow.core import (
    Follower,
    FollowError,
    FollowUpdate,
    SlopeFinding,
    follow_log,
    walked_path,
)
from energy_planner.follow.rls import ForgettingRLS, seed_covariance
from energy_planner.follow.terms import PathTerms, path_term_energies

__all__ = [
    "FollowError",
    "FollowUpdate",
    "Follower",
    "ForgettingRLS",
    "PathTerms",
    "RemainingScores",
    "SlopeFinding",
    "calibrate_remaining",
    "follow_log",
    "path_term_energies",
    "seed_covariance",
    "walked_path",
]
