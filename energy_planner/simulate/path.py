"""The simulator's TRUE energy of a path over a DEM (to charge planned paths).

:func:`true_path_energy` walks a path the way the planners' motion primitives do
(:mod:`energy_planner.energy`): between consecutive poses the robot moves at a
constant speed along the surface and a constant yaw rate, taking ``max(surface length /
speed, |turn| / yaw_rate)``; without yaws it faces along each segment and turns in
place at the corners. Each motion is cut into sub-steps of at most ``step_m`` metres
and ``ang_step`` radians; at each sub-step's midpoint the terrain gradient gives slope,
heading and the body twist, and the truth's expected power
(:meth:`~energy_planner.simulate.physics.Physics.expected_power`, gait-cycle mean) is
charged for the sub-step's duration.

Examples
--------
A 10 m walk on level ground costs the level power for 10 m / 0.3 m/s:

>>> import numpy as np
>>> from energy_planner.terrain import Terrain
>>> flat = Terrain.from_function(lambda x, y: 0.0 * x, size=(20.0, 20.0))
>>> e = true_path_energy(flat, [[5.0, 5.0], [15.0, 5.0]])
>>> level = Physics().expected_power({"alpha": 0.0, "gamma": 0.0, "vx": 0.3, "vy": 0.0,
...                                  "wz": 0.0})[0]
>>> bool(np.isclose(e.energy_j, level * 10 / 0.3))
True
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.angles import wrap
from energy_planner.errors import EnergyPlannerError, OutsideMapError
from energy_planner.simulate.physics import Physics, RobotParams

__all__ = ["PathTruth", "true_path_energy", "channel_values"]


@dataclass(frozen=True)
class PathTruth:
    """True energy of a path.

    Attributes
    ----------
    energy_j, distance_m, duration_s : float
        Totals (distance along the surface).
    segments : DataFrame
        One row per motion between consecutive poses: energy_j, distance_m,
        duration_s, turn_rad.
    """

    energy_j: float
    distance_m: float
    duration_s: float
    segments: pd.DataFrame


def channel_values(
    channels: Mapping[str, Any] | None, x: np.ndarray, y: np.ndarray
) -> dict[str, np.ndarray]:
    """Channel values at points.

    Constants are broadcast; callables ``f(x, y)`` or objects with ``.sample(x, y)``
    (a raster) are evaluated there.

    >>> channel_values({"load_kg": 10, "ground": "mud"}, np.zeros(2), np.zeros(2))["ground"]
    array(['mud', 'mud'], dtype=object)
    """
    out: dict[str, np.ndarray] = {}
    for name, v in (channels or {}).items():
        if hasattr(v, "sample"):
            val = np.asarray(v.sample(x, y))
        elif callable(v):
            val = np.asarray(v(x, y))
        else:
            val = np.asarray(v)
        if val.dtype.kind in "US" or val.dtype == object:
            val = val.astype(str).astype(object)
        out[name] = np.broadcast_to(val, x.shape).copy()
    return out


def true_path_energy(
    terrain: Any,
    states: Any,
    effects: Iterable[str] = (),
    channels: Mapping[str, Any] | None = None,
    speed: Any = 0.3,
    yaw_rate: float = 0.5,
    *,
    params: RobotParams | None = None,
    gaits: Any = None,
    step_m: float = 0.25,
    ang_step: float = 0.1,
) -> PathTruth:
    """True energy of walking a path over a DEM.

    Parameters
    ----------
    terrain : Terrain
        The map (working CRS, metres).
    states : array-like, shape (n, 2) or (n, 3)
        Waypoints ``x, y`` or poses ``x, y, yaw`` (yaw in rad CCW from +x, as the
        planners' ``states``); n >= 2.
    effects : iterable of str
        Effects of the truth (e.g. ``campaign.effects``).
    channels : mapping, optional
        Channel values the effects read: constants (``{"load_kg": 10}``), callables
        ``f(x, y)`` or rasters with ``.sample(x, y)``.
    speed : float or array-like
        Walking speed along the surface, m/s: one for the whole path, or one per segment
        (a speed profile, ``n - 1`` values).
    yaw_rate : float
        Turning rate, rad/s.
    params : RobotParams, optional
        Robot parameters of the truth.
    gaits : GaitSchedule, optional
        The truth's gaits across speeds (:mod:`energy_planner.simulate.gaits`; e.g.
        ``campaign.physics.gaits``): the gait of each motion follows its speed and slope.
    step_m, ang_step : float
        Largest sub-step, m and rad.

    Returns
    -------
    PathTruth

    Raises
    ------
    EnergyPlannerError
        Malformed states or non-positive speed / yaw rate.
    OutsideMapError
        A sub-step lies outside the map or on nodata.
    ModelError
        An effect reads a channel that ``channels`` does not give.
    """
    st = np.asarray(states, dtype=float)
    if st.ndim != 2 or st.shape[1] not in (2, 3) or st.shape[0] < 2:
        raise EnergyPlannerError(
            f"states must be an (n >= 2, 2 or 3) array of x, y[, yaw]; got shape {st.shape}"
        )
    if not np.isfinite(st).all():
        raise EnergyPlannerError("states contain NaN or infinite values")
    v_seg = np.asarray(speed, dtype=float)
    if v_seg.ndim > 1 or (v_seg.ndim == 1 and v_seg.size != st.shape[0] - 1):
        raise EnergyPlannerError(
            f"speed must be one value or one per segment ({st.shape[0] - 1}); got shape "
            f"{v_seg.shape}"
        )
    if not (np.all(v_seg > 0) and yaw_rate > 0):
        raise EnergyPlannerError(
            f"speed = {speed!r} m/s and yaw_rate = {yaw_rate!r} rad/s must both be > 0"
        )
    if st.shape[1] == 2:
        from energy_planner.energy.path import face_along_poses

        st = face_along_poses(st[:, :2])
    physics = Physics(params, effects, gaits=gaits)
    x0, y0, th0 = st[:-1, 0], st[:-1, 1], st[:-1, 2]
    ddx, ddy = np.diff(st[:, 0]), np.diff(st[:, 1])
    dth = wrap(np.diff(st[:, 2]))
    dist_h = np.hypot(ddx, ddy)
    n_sub = np.maximum.reduce(
        [
            np.ones_like(dist_h, dtype=int),
            np.ceil(dist_h / step_m).astype(int),
            np.ceil(np.abs(dth) / ang_step).astype(int),
        ]
    )
    seg = np.repeat(np.arange(len(dist_h)), n_sub)
    first = np.concatenate([[0], np.cumsum(n_sub)[:-1]])
    i_in = np.arange(len(seg)) - first[seg]
    s = (i_in + 0.5) / n_sub[seg]
    x = x0[seg] + s * ddx[seg]
    y = y0[seg] + s * ddy[seg]
    smp = terrain.sample(x, y)
    gx = np.asarray(smp.dzdx, dtype=float)
    gy = np.asarray(smp.dzdy, dtype=float)
    bad = np.flatnonzero(~(np.isfinite(gx) & np.isfinite(gy)))
    if bad.size:
        k = int(bad[0])
        raise OutsideMapError(
            f"segment {int(seg[k])} of the path reaches ({x[k]:.2f}, {y[k]:.2f}), outside "
            "the map or on nodata"
        )
    hx, hy = ddx[seg] / n_sub[seg], ddy[seg] / n_sub[seg]
    dz = gx * hx + gy * hy
    ds = np.sqrt(hx * hx + hy * hy + dz * dz)
    surface = np.bincount(seg, weights=ds, minlength=len(dist_h))
    T = np.maximum(surface / v_seg, np.abs(dth) / yaw_rate)
    Ts = T[seg]
    surf_s = surface[seg]
    dt = np.where(surf_s > 0, Ts * ds / np.where(surf_s > 0, surf_s, 1.0), Ts / n_sub[seg])
    th = th0[seg] + s * dth[seg]
    g2 = gx * gx + gy * gy
    alpha = np.arctan(np.sqrt(g2))
    gh = th - np.arctan2(gy, gx)
    gamma = np.arctan2(np.sin(gh) * np.cos(alpha), np.cos(gh))
    safe_dt = np.where(dt > 0, dt, 1.0)
    v = np.stack([hx, hy, dz]) / safe_dt
    c_, s_ = np.cos(th), np.sin(th)
    bx = np.stack([c_, s_, gx * c_ + gy * s_])
    bx /= np.linalg.norm(bx, axis=0)
    bz = np.stack([-gx, -gy, np.ones_like(gx)]) / np.sqrt(1.0 + g2)
    by = np.cross(bz, bx, axis=0)
    vx = np.where(dt > 0, np.sum(v * bx, axis=0), 0.0)
    vy = np.where(dt > 0, np.sum(v * by, axis=0), 0.0)
    wz = np.where(T[seg] > 0, dth[seg] / np.where(Ts > 0, Ts, 1.0), 0.0)
    features = {
        "alpha": alpha,
        "gamma": gamma,
        "vx": vx,
        "vy": vy,
        "wz": wz,
        **channel_values(channels, x, y),
    }
    p = physics.expected_power(features)
    e = p * dt
    seg_e = np.bincount(seg, weights=e, minlength=len(dist_h))
    segments = pd.DataFrame(
        {"energy_j": seg_e, "distance_m": surface, "duration_s": T, "turn_rad": dth}
    )
    return PathTruth(float(seg_e.sum()), float(surface.sum()), float(T.sum()), segments)
