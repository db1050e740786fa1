"""The poses a log walked, as a path: what a replay, a follower and a fit price.

A log's pose ``x, y, yaw`` with its times is the path the robot walked. The energy of a
logged mission (``energy --waypoints`` of its poses with times), the follower's replay
(:mod:`energy_planner.follow`) and the error model's whole held-out runs
(:mod:`energy_planner.calibration.prepare`) all take it from here.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from energy_planner.errors import LogError
from energy_planner.measurements.logs import MOTION_THRESHOLD

__all__ = ["fresh_poses", "walked_path"]


def fresh_poses(samples: pd.DataFrame) -> np.ndarray:
    """Which samples of one run carry a pose of their own time (a boolean mask).

    A localisation slower than the log (a pose at 2.5 Hz written into every sample of a
    10 Hz log) repeats each pose until the next one arrives. A repeat is stamped later
    than the pose was taken: priced as waypoints with their times, the repeats make the
    robot stand still and then walk each step at several times its speed (+4 % energy on
    such a log). A sample is kept unless its ``x, y, yaw`` equal the previous sample's
    while the odometry says the robot moves (speed or ``|wz|`` at least
    :data:`~energy_planner.measurements.logs.MOTION_THRESHOLD`): at rest a repeated pose
    is the robot standing, and standing takes time. The first and last samples are kept.

    Examples
    --------
    >>> s = pd.DataFrame({"t": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5], "vx": 0.3, "vy": 0.0,
    ...                   "wz": 0.0, "x": [0.0, 0.0, 0.06, 0.06, 0.12, 0.12], "y": 0.0,
    ...                   "yaw": 0.0})
    >>> fresh_poses(s).tolist()
    [True, False, True, False, True, True]
    >>> fresh_poses(s.assign(vx=0.0)).tolist()  # at rest: every sample is the robot standing
    [True, True, True, True, True, True]
    """
    n = len(samples)
    keep = np.ones(n, dtype=bool)
    if n < 3:
        return keep
    cols = [c for c in ("x", "y", "yaw") if c in samples.columns]
    pose = samples[cols].to_numpy(float)
    same = np.all(pose[1:] == pose[:-1], axis=1)
    if {"vx", "vy", "wz"} <= set(samples.columns):
        speed = np.hypot(samples["vx"].to_numpy(float), samples["vy"].to_numpy(float))
        turn = np.abs(samples["wz"].to_numpy(float))
        moving = (speed >= MOTION_THRESHOLD) | (turn >= MOTION_THRESHOLD)
        same &= moving[1:]
    keep[1:] = ~same
    keep[-1] = True
    return keep


def walked_path(samples: pd.DataFrame, run: str | None = None, every_s: float = 0.5):
    """The poses a log walked, as the path to follow (a replay of what was walked).

    Parameters
    ----------
    samples : pandas.DataFrame
        Canonical log samples with the pose ``x, y`` (the DEM's CRS) and ``yaw`` (radians
        counter-clockwise from the CRS's x axis).
    run : str, optional
        The run to take when the log holds several (default: the first).
    every_s : float
        One pose every this many seconds of log time (and the last one), with its time.
        Repeats of a localisation slower than the log are skipped first
        (:func:`fresh_poses`), so that each pose comes with the time it was taken.

    Returns
    -------
    Waypoints
        In the DEM's CRS, with yaw and times (from the run's first sample).

    Raises
    ------
    LogError
        The log has no pose columns, or the run is not in it.
    """
    from energy_planner.io.path_format import Waypoints

    missing = [c for c in ("x", "y", "yaw", "t") if c not in samples.columns]
    if missing:
        raise LogError(
            f"the log has no pose column(s) {', '.join(missing)}: give the plan's path "
            "with --path (follow needs a path to price the rest of)"
        )
    runs = list(dict.fromkeys(samples["run"].astype(str))) if "run" in samples else [None]
    name = runs[0] if run is None else run
    if name not in runs:
        raise LogError(f"no run {name!r} in the log; runs: {', '.join(map(str, runs))}")
    d = samples if name is None else samples[samples["run"].astype(str) == name]
    d = d[fresh_poses(d)]
    t = d["t"].to_numpy(float) - float(d["t"].iloc[0])
    k = np.unique(np.r_[np.searchsorted(t, np.arange(0.0, t[-1], every_s)), len(t) - 1])
    return Waypoints(
        xy=d[["x", "y"]].to_numpy(float)[k],
        yaw_rad=d["yaw"].to_numpy(float)[k],
        t=t[k],
        crs_note="the log's own poses (the DEM's CRS)",
    )
