"""Energy of a given path: waypoints (with optional yaw and time) over a terrain."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from energy_planner.energy.channels import Channels
from energy_planner.energy.kernels import (
    OK,
    OUT_CODE,
    OUT_DISTANCE,
    OUT_DURATION,
    OUT_E_BACKWARD,
    OUT_E_FORWARD,
    OUT_E_LATERAL,
    OUT_E_OTHER,
    OUT_E_TURNING,
    OUT_ENERGY,
    OUT_MAX_SLOPE,
    OUT_MEAN_GAMMA,
    OUT_MEAN_SLOPE,
    OUT_TURN,
    TOO_BACKWARD,
    TOO_CRAB,
    VIOLATIONS,
)
from energy_planner.energy.motion import MotionCost
from energy_planner.errors import EnergyPlannerError, NonPositivePowerError, OutsideMapError
from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE
from energy_planner.results import Result
from energy_planner.trust import Assessed

if TYPE_CHECKING:  # the table is made without pandas: ``segments`` imports it on use
    import pandas as pd

__all__ = [
    "PathEnergy",
    "path_energy",
    "face_along_poses",
    "path_poses",
    "vertex_times",
    "check_cost_power",
    "SEGMENT_COLUMNS",
]

SEGMENT_COLUMNS = [
    "segment",
    "energy_j",
    "distance_m",
    "duration_s",
    "turn_deg",
    "mean_slope_deg",
    "max_slope_deg",
    "mean_rel_heading_deg",
    "forward_share",
    "lateral_share",
    "turning_share",
    "other_share",
]


@dataclass(repr=False)
class PathEnergy(Result, Assessed):
    """Energy breakdown of a path.

    Attributes
    ----------
    energy_j, distance_m, duration_s : float
        Totals.
    table : dict of str to ndarray
        One entry per segment between consecutive waypoints in each column of
        :data:`SEGMENT_COLUMNS` (:attr:`segments` as plain arrays). Without given yaw,
        the turn in place at a segment's first waypoint is part of that segment. Shares
        are the fractions of the segment's work done walking forward or backward,
        sideways, turning, and by other terms (idle power, effects).
    poses : ndarray
        The executed SE(2) poses ``(x, y, yaw)``, turns in place included.
    map_distance_m : ndarray
        Per segment, the horizontal distance between its waypoints on the working grid
        (what a GIS measures; ``distance_m`` is along the ground).
    assessment : Assessment or None
        The energy's interval, domain report and battery verdict
        (:class:`~energy_planner.trust.Assessment`; :attr:`interval`, :attr:`domain`,
        :attr:`battery`), set by the verbs (``ep.path_energy``,
        :meth:`~energy_planner.problem.Problem.path_energy`); None from this module's
        :func:`path_energy`.
    """

    energy_j: float
    distance_m: float
    duration_s: float
    table: dict[str, np.ndarray] = field(repr=False)
    poses: np.ndarray = field(repr=False)
    map_distance_m: np.ndarray | None = field(default=None, repr=False)
    assessment: Any = field(default=None, repr=False)

    @cached_property
    def segments(self) -> pd.DataFrame:
        """:attr:`table` as a DataFrame, one row per segment (pandas imported on use)."""
        import pandas as pd

        return pd.DataFrame({c: self.table[c] for c in SEGMENT_COLUMNS})

    @property
    def energy_wh(self) -> float:
        """Total energy in Wh."""
        return self.energy_j / 3600.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: totals, ``segments`` and, when assessed, the assessment's keys.

        Keys ``energy_j``, ``energy_wh``, ``distance_m``, ``map_distance_m``,
        ``duration_s``, ``segments`` (each with its ``map_distance_m``) and, assessed,
        ``interval``, ``domain`` (and ``battery`` with a battery).
        """
        flat = self.map_distance_m
        segs = [
            {c: int(v) if c == "segment" else float(v)
             for c, v in zip(SEGMENT_COLUMNS, row, strict=True)}
            for row in zip(*(self.table[c].tolist() for c in SEGMENT_COLUMNS), strict=True)
        ]  # fmt: skip
        out: dict[str, Any] = {
            "energy_j": self.energy_j,
            "energy_wh": self.energy_wh,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "segments": segs,
        }
        if flat is not None:
            out["map_distance_m"] = float(np.sum(flat))
            for seg, d in zip(segs, flat, strict=True):
                seg["map_distance_m"] = float(d)
        return {**out, **self.assessment_dict()}

    def write_json(self, path: Any) -> Any:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict())

    def to_geojson(self, terrain: Any = None, *, native: bool = False) -> dict[str, Any]:
        """The executed poses as the project's GeoJSON path document, with the totals.

        ``terrain``: default the one the energy was computed on.
        """
        from energy_planner.geojson import path_document_from_work

        props = {"energy_j": self.energy_j, "distance_m": self.distance_m,
                 "duration_s": self.duration_s}  # fmt: skip
        return path_document_from_work(self._terrain(terrain), self.poses, properties=props,
                                       native=native)  # fmt: skip

    def write_geojson(self, path: Any, terrain: Any = None, *, native: bool = False) -> Any:
        """Write :meth:`to_geojson` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_geojson

        return write_geojson(path, self.to_geojson(terrain, native=native))

    def plot(self, path: Any) -> Any:
        """Cumulative energy and energy per metre along the path; write a PNG at ``path``."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from energy_planner.io import save_figure

        seg = self.table
        d = np.concatenate([[0.0], np.cumsum(np.asarray(seg["distance_m"], float))])
        e = np.concatenate([[0.0], np.cumsum(np.asarray(seg["energy_j"], float))])
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
        a1.plot(d, e / 1000.0, "-", color="C0")
        a1.set_ylabel("cumulative energy (kJ)")
        a1.set_title(f"{self.energy_j / 1000:.2f} kJ over {self.distance_m:.1f} m, "
                     f"{self.duration_s:.0f} s", fontsize=10)  # fmt: skip
        with np.errstate(invalid="ignore", divide="ignore"):
            per_m = np.asarray(seg["energy_j"], float) / np.asarray(seg["distance_m"], float)
        a2.step(d[1:], per_m, where="pre", color="C3")
        a2.set_ylabel("energy per metre (J/m)")
        a2.set_xlabel("distance along the path (m)")
        fig.tight_layout()
        try:
            return save_figure(fig, path)
        finally:
            plt.close(fig)


def path_energy(
    terrain: Any,
    model: Any,
    xy: Any,
    yaw: Any = None,
    t: Any = None,
    speed: float = DEFAULT_SPEED,
    yaw_rate: float = DEFAULT_YAW_RATE,
    *,
    constants: Mapping[str, Any] | None = None,
    channels: Channels | None = None,
    cost: MotionCost | None = None,
    gait: Any = None,
) -> PathEnergy:
    """Energy of walking through waypoints (working CRS, metres).

    Parameters
    ----------
    terrain : Terrain
        The map.
    model : EnergyModel
        A fitted model.
    xy : array-like, shape (n, 2)
        Waypoints, n >= 2.
    yaw : array-like, shape (n,), optional
        Body yaw at each waypoint, radians CCW from +x. Without it the robot faces along
        each segment and turns in place at the corners; with it the robot follows the
        given orientation (walking sideways if so told).
    t : array-like, shape (n,), optional
        Times at the waypoints (s, strictly increasing). Without them the nominal
        ``speed`` and ``yaw_rate`` set the timing.
    speed, yaw_rate : float
        Nominal walking speed (m/s) and turning rate (rad/s).
    constants : mapping, optional
        Values of extra channels the model reads (e.g. ``payload_kg``).
    channels : Channels, optional
        Extra channels as constants and rasters (see :class:`MotionCost`).
    cost : MotionCost, optional
        Reuse a prepared :class:`MotionCost` (its speed and yaw rate apply).
    gait : sequence of str or None, shape (n - 1,), optional
        The gait of each segment (a plan's choice, :attr:`MotionCost.gaits`; None: the
        channels' own), for a model that names gaits; the cost must choose its gait
        (``gait_choice``; built so when ``cost`` is not given).

    Raises
    ------
    OutsideMapError
        If a waypoint, or a motion between two, leaves the valid map (names which).
    EnergyPlannerError
        For malformed input (shapes, times not increasing).
    """
    xy = _waypoints(xy)
    n = xy.shape[0]
    if cost is None:
        cost = MotionCost(terrain, model, speed, yaw_rate, constants=constants, channels=channels,
                          gait_choice=True if gait is not None else None)  # fmt: skip
    seg_gaits = None
    if gait is not None:
        gait = list(gait)
        if len(gait) != n - 1:
            raise EnergyPlannerError(
                f"gait has {len(gait)} entries for {n - 1} segments; expected one per segment"
            )
        seg_gaits = cost.gait_indices(gait)
    samples = terrain.sample(xy[:, 0], xy[:, 1])
    bad = np.flatnonzero(~np.isfinite(np.asarray(samples.slope, dtype=float)))
    if bad.size:
        i = int(bad[0])
        raise OutsideMapError(
            f"waypoint {i} at ({xy[i, 0]:.2f}, {xy[i, 1]:.2f}) is outside the map or on "
            f"nodata ({bad.size} waypoint(s) are: {bad.tolist()[:10]})"
        )
    poses, seg_of, durations = path_poses(xy, yaw, t, cost.yaw_rate)
    gaits = None if seg_gaits is None else seg_gaits[seg_of]
    out = cost.details(poses[:, 0], poses[:, 1], poses[:, 2], durations, gaits)
    invalid = np.flatnonzero(out[:, OUT_CODE] != OK)
    if invalid.size:
        k = int(invalid[0])
        s = int(seg_of[k])
        code = int(out[k, OUT_CODE])
        gait = {
            TOO_BACKWARD: ("max_backward_slope_deg", cost.max_backward_slope_deg),
            TOO_CRAB: ("max_crab_deg", cost.max_crab_deg),
        }
        if code in gait:  # a gait limit: the motion, not the cells, breaks it
            name, value = gait[code]
            raise OutsideMapError(
                f"segment {s} (waypoint {s} to {s + 1}) is walked {VIOLATIONS[code]} "
                f"({name} = {value:g} deg)",
                limit=name,
                value=value,
            )
        raise OutsideMapError(
            f"segment {s} (waypoint {s} to {s + 1}) crosses cells {VIOLATIONS[code]}"
        )
    segments = _segment_table(out, seg_of, n - 1)
    kinds = out[:, [OUT_E_FORWARD, OUT_E_BACKWARD, OUT_E_LATERAL, OUT_E_TURNING, OUT_E_OTHER]]
    unclamped = np.bincount(seg_of, weights=kinds.sum(axis=1), minlength=n - 1)
    _check_path_power(cost, segments, unclamped, sideways=yaw is not None)
    return PathEnergy(
        energy_j=float(out[:, OUT_ENERGY].sum()),
        distance_m=float(out[:, OUT_DISTANCE].sum()),
        duration_s=float(out[:, OUT_DURATION].sum()),
        table=segments,
        poses=poses,
        map_distance_m=np.hypot(*np.diff(xy, axis=0).T),
    )


def check_cost_power(
    cost: MotionCost,
    max_slope_deg: float | None = None,
    gaits: Any = None,
    speeds: Any = None,
) -> int:
    """Refuse a model that prices walking on this map at zero or negative power.

    :func:`energy_planner.model.model.check_walking_power` with the cost's channel values
    (constants; rasters from their minimum to their maximum, every category), speed and
    yaw rate, on slopes up to ``max_slope_deg`` (default: the map's steepest, or the
    cost's slope limit). The kernels floor power at zero (a legged robot does not
    regenerate), so without this a term with an arbitrary negative value would make
    walking free; ``path_energy`` and ``plan`` call it.

    Parameters
    ----------
    cost : MotionCost
        The prepared cost (model, channels, speed, yaw rate, limits).
    max_slope_deg : float, optional
        Steepest slope checked.
    gaits : iterable of str, optional
        Gaits checked (default: all; see ``check_walking_power``).
    speeds : sequence of float, optional
        Speeds checked (default: the cost's).

    Returns
    -------
    int
        Number of walking motions checked.

    Raises
    ------
    NonPositivePowerError
        Names the motion, its power and the term with the largest negative contribution.
    """
    from energy_planner.model.model import WALKING_GAITS, check_walking_power

    if max_slope_deg is None:
        slope = np.asarray(cost.terrain.slope, dtype=float)
        top = float(np.nanmax(slope)) if np.isfinite(slope).any() else 0.0
        max_slope_deg = math.degrees(top)
        if cost.max_slope_deg is not None:
            max_slope_deg = min(max_slope_deg, float(cost.max_slope_deg))
    values = cost.channels.value_samples()
    speeds = (cost.speed,) if speeds is None else tuple(speeds)
    gaits = tuple(WALKING_GAITS) if gaits is None else tuple(gaits)
    key = _power_check_key(cost.model, values, max_slope_deg, speeds, cost.yaw_rate, gaits)
    checked = _POWER_CHECKED.get(key) if key is not None else None
    if checked is None:
        checked = check_walking_power(
            cost.model, values, max_slope_deg=max_slope_deg, speeds=speeds,
            yaw_rate=cost.yaw_rate, gaits=gaits,
        )  # fmt: skip
        if key is not None:
            if len(_POWER_CHECKED) >= _POWER_CHECKED_MAX:
                _POWER_CHECKED.clear()
            _POWER_CHECKED[key] = checked
    return checked


#: check_walking_power's grids that passed: key (:func:`_power_check_key`) -> its count
_POWER_CHECKED: dict[tuple, int] = {}
_POWER_CHECKED_MAX = 1024


def _power_check_key(model, values, max_slope_deg, speeds, yaw_rate, gaits) -> tuple | None:
    """What ``check_walking_power`` reads, as a key (None: not keyed, check it again).

    Every plan and priced path checks its model on its own slopes and speeds; on the same
    model, channel values, speeds and yaw rate the grid is the same whenever the slope
    grid (0 to ``max_slope_deg`` in 2.5 deg steps) has as many rows, so a grid that
    passed once is not evaluated again. Only passes are kept (a failure raises each time,
    with its message). The model is keyed by its content (terms, coefficients,
    regenerative), so a model changed in place is checked again.
    """
    try:
        coefs = model.coef_array().tobytes()
        terms = tuple((t.name, t.formula) for t in model.terms)
        chans = tuple(sorted((k, str(np.asarray(v).dtype), tuple(np.asarray(v).tolist()))
                             for k, v in values.items()))  # fmt: skip
        rows = np.arange(0.0, max(float(max_slope_deg), 0.0) + 1e-9, 2.5).size
        return (terms, coefs, bool(model.regenerative), chans, rows,
                tuple(float(v) for v in speeds), float(yaw_rate), tuple(gaits))  # fmt: skip
    except Exception:  # noqa: BLE001 - an unfitted model, odd values: no key, the check decides
        return None


def _check_path_power(
    cost: MotionCost, segments: Mapping[str, np.ndarray], unclamped: np.ndarray, sideways: bool
) -> None:
    """Check the walking power on a path's own slopes and speeds.

    :func:`check_cost_power`, then no moving segment may cost <= 0 J where its terms sum
    to a negative energy before the floor (``unclamped``, J: a raster channel between the
    sampled values).
    """
    from energy_planner.model.model import WALKING_SPEED, WALKING_YAW_RATE

    dur = np.asarray(segments["duration_s"], dtype=float)
    dist = np.asarray(segments["distance_m"], dtype=float)
    turn = np.radians(np.abs(np.asarray(segments["turn_deg"], dtype=float)))
    safe = np.where(dur > 0, dur, np.inf)
    moving = (dist / safe > WALKING_SPEED) | (turn / safe > WALKING_YAW_RATE)
    if not moving.any():
        return
    v = dist[moving] / safe[moving]
    v = v[v > WALKING_SPEED]
    speeds = sorted({cost.speed, *(() if v.size == 0 else (float(v.min()), float(v.max())))})
    gaits = None if sideways else ("forward", "turning in place")
    slope = float(np.nanmax(np.asarray(segments["max_slope_deg"], dtype=float)[moving]))
    check_cost_power(cost, max_slope_deg=slope, gaits=gaits, speeds=speeds)
    free = np.flatnonzero(
        moving & (np.asarray(segments["energy_j"], dtype=float) <= 0.0) & (unclamped < 0.0)
    )
    if free.size:
        k = int(free[0])
        raise NonPositivePowerError(
            f"segment {k} (waypoint {k} to {k + 1}) walks {dist[k]:.2f} m in {dur[k]:.2f} s "
            f"for {segments['energy_j'][k]:.3g} J (its terms sum to {unclamped[k]:.3g} J "
            f"before the floor; {free.size} moving segment(s) cost "
            "<= 0 J): the model prices this walking motion at zero or negative power (on "
            "the channel values there); refit the model on logs that include this motion"
        )


def _waypoints(xy: Any) -> np.ndarray:
    xy = np.asarray(xy, dtype=float)
    if xy.ndim != 2 or xy.shape[1] != 2 or xy.shape[0] < 2:
        raise EnergyPlannerError(f"waypoints must be an (n >= 2, 2) array of x, y; got {xy.shape}")
    if not np.isfinite(xy).all():
        raise EnergyPlannerError("waypoints contain NaN or infinite coordinates")
    return xy


def path_poses(
    xy: Any, yaw: Any = None, t: Any = None, yaw_rate: float = DEFAULT_YAW_RATE
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The executed motions of a path, as :func:`path_energy` walks it.

    Parameters
    ----------
    xy, yaw, t, yaw_rate
        As for :func:`path_energy`.

    Returns
    -------
    poses : ndarray, shape (m, 3)
        The executed poses ``(x, y, yaw)``, turns in place included.
    seg_of : ndarray of int, shape (m - 1,)
        The waypoint segment of each motion.
    durations : ndarray, shape (m - 1,)
        Each motion's duration, s (-1: timed by the nominal speed and yaw rate).

    Raises
    ------
    EnergyPlannerError
        Malformed waypoints, yaw or times (not one per waypoint, not increasing).
    """
    xy = _waypoints(xy)
    n = xy.shape[0]
    if t is not None:
        t = np.asarray(t, dtype=float)
        if t.shape != (n,) or not np.all(np.diff(t) > 0):
            raise EnergyPlannerError("times must have one value per waypoint and increase strictly")
    seg_dt = None if t is None else np.diff(t)
    if yaw is None:
        return _face_along(xy, seg_dt, yaw_rate)
    yaw = np.asarray(yaw, dtype=float)
    if yaw.shape != (n,) or not np.isfinite(yaw).all():
        raise EnergyPlannerError("yaw must have one finite value per waypoint")
    durations = np.full(n - 1, -1.0) if seg_dt is None else seg_dt
    return np.column_stack([xy, yaw]), np.arange(n - 1), durations


def vertex_times(
    terrain: Any,
    states: Any,
    request: Any = None,
    *,
    duration_s: float | None = None,
    what: str = "the path",
) -> np.ndarray:
    """When the robot reaches each pose of a path, as :func:`path_energy` times it.

    Each motion between two poses lasts ``max(ground length / speed, |turn| / yaw_rate)``
    (the kernel's timing, :func:`energy_planner.energy._motion.motion_full`), so the
    times of a planned path are those its energy was integrated over.

    Parameters
    ----------
    terrain : Terrain
        The map (ground lengths follow its slopes).
    states : array-like, shape (n, 3)
        Poses ``x, y, yaw`` in the working CRS (metres, radians), n >= 2.
    request : Request, optional
        Its robot's speed and yaw rate: those the path was planned with (default
        :class:`~energy_planner.request.Request`).
    duration_s : float, optional
        The path's own duration: the last time must agree (1e-6 relative), so that a
        plan made at another speed is an error, not a silently wrong set of times.
    what : str
        The path's name in that error.

    Returns
    -------
    ndarray, shape (n,)
        Seconds from the first pose (0), strictly increasing where the robot moves.

    Raises
    ------
    WaypointError
        The times disagree with ``duration_s``.

    Examples
    --------
    >>> from energy_planner.request import Request
    >>> from energy_planner.terrain import Terrain
    >>> flat = Terrain.from_function(lambda x, y: 0 * x, size=(20, 20))
    >>> x0, y0 = flat.grid[:2]
    >>> st = [[x0 + 2, y0 - 2, 0.0], [x0 + 5, y0 - 2, 0.0], [x0 + 5, y0 - 2, 1.0]]
    >>> vertex_times(flat, st, Request.make(speed=0.5, yaw_rate=0.25)).round(6).tolist()
    [0.0, 6.0, 10.0]
    """
    from energy_planner.errors import WaypointError
    from energy_planner.model import EnergyModel
    from energy_planner.request import Request

    s = np.asarray(states, dtype=float)
    if s.ndim != 2 or s.shape[1] != 3:
        raise EnergyPlannerError(
            f"states must be an (n, 3) array of x, y, yaw; got shape {s.shape}",
            value=s.shape,
            expected="(n, 3)",
        )
    # any model gives the durations: the ground distance (power = speed) needs no channel
    robot = (request if request is not None else Request()).robot
    length = EnergyModel(["speed"], {"speed": 1.0})
    pe = path_energy(terrain, length, s[:, :2], yaw=s[:, 2], speed=robot.speed,
                     yaw_rate=robot.yaw_rate)  # fmt: skip
    t = np.concatenate([[0.0], np.cumsum(pe.table["duration_s"])])
    if duration_s is not None and not math.isclose(t[-1], duration_s, rel_tol=1e-6, abs_tol=1e-6):
        raise WaypointError(
            f"{what} lasts {duration_s:.6g} s, but its poses at {robot.speed:g} m/s and "
            f"{robot.yaw_rate:g} rad/s take {t[-1]:.6g} s: give the request it was planned "
            "with (request=)",
            value=float(t[-1]),
            expected=f"{duration_s:.6g} s",
        )
    return t


def write_paths_bag(
    path: Any,
    paths: Sequence[tuple[str, Any, float, str, dict[str, Any]]],
    terrain: Any,
    request: Any = None,
    *,
    frame: str = "map",
    storage: str = "mcap",
    origin: Sequence[float] | None = None,
    chain: bool = False,
) -> dict[str, Any]:
    """Write planned paths into a new ROS 2 bag, each stamped as :func:`vertex_times` times it.

    The one writer of every result's ``write_bag``
    (:meth:`~energy_planner.planning.plan.PlanResult.write_bag`, a route comparison's,
    a mission's).

    Parameters
    ----------
    path : str or pathlib.Path
        The bag folder to create.
    paths : sequence of (topic, states, duration_s, what, info[, times])
        Each path's topic, poses (n, 3, working CRS), its own duration (checked against
        the times), its name in errors and the metadata of its topic; optionally its
        own times per pose (s; a plan whose motions chose their speed), else the
        request's speed and yaw rate time it.
    terrain, request
        The map and the request the paths were planned with (their speed and yaw rate).
    frame, storage, origin
        As :func:`energy_planner.io.ros2.write_path_bag`.
    chain : bool
        Each path starts when the one before ends (a mission's legs; ``info`` gets
        ``start_s``); default: each from 0.

    Returns
    -------
    dict
        The frame and conventions (:meth:`energy_planner.io.ros2.MapFrame.to_dict`).
    """
    from energy_planner.io.ros2 import write_path_bag

    stamped, info, start = {}, {}, 0.0
    for topic, states, duration_s, what, meta, *own in paths:
        if own and own[0] is not None:
            t = np.asarray(own[0], dtype=float)
        else:
            t = vertex_times(terrain, states, request, duration_s=duration_s, what=what)
        stamped[topic] = (states, start + t if chain else t)
        info[topic] = {**meta, "start_s": start} if chain else dict(meta)
        if chain:
            start += float(t[-1])
    return write_path_bag(path, stamped, terrain, frame=frame, origin=origin, storage=storage,
                          info=info)  # fmt: skip


def face_along_poses(xy: Any) -> np.ndarray:
    """Poses ``(x, y, yaw)`` walking forward along each segment, turning at the corners.

    The turns are in place at the corners; a zero-length segment keeps the previous
    heading.

    >>> face_along_poses([[0, 0], [1, 0], [1, 2]]).round(3).tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.571], [1.0, 2.0, 1.571]]
    """
    return _face_along(np.asarray(xy, dtype=float), None, 1.0)[0]


def _face_along(xy: np.ndarray, seg_dt: np.ndarray | None, yaw_rate: float):
    """Poses for 'face along each segment, turn in place at corners'."""
    d = np.diff(xy, axis=0)
    lengths = np.hypot(d[:, 0], d[:, 1])
    heading = np.arctan2(d[:, 1], d[:, 0])
    # a zero-length segment keeps the previous heading
    for i in range(len(heading)):
        if lengths[i] == 0:
            heading[i] = heading[i - 1] if i else (heading[lengths > 0][0] if lengths.any() else 0)
    poses, seg_of, durations = [(xy[0, 0], xy[0, 1], heading[0])], [], []
    for i in range(len(heading)):
        turn_t = 0.0
        if i > 0:
            turn = math.remainder(heading[i] - heading[i - 1], 2 * math.pi)
            if turn != 0.0:
                poses.append((xy[i, 0], xy[i, 1], heading[i]))
                seg_of.append(i)
                turn_t = abs(turn) / yaw_rate
                durations.append(turn_t)
        poses.append((xy[i + 1, 0], xy[i + 1, 1], heading[i]))
        seg_of.append(i)
        if seg_dt is None:
            durations.append(-1.0)
        else:
            walk = seg_dt[i] - turn_t
            if walk <= 0 and lengths[i] > 0:
                raise EnergyPlannerError(
                    f"segment {i}: {seg_dt[i]:.2f} s is not enough to turn "
                    f"({turn_t:.2f} s at {yaw_rate} rad/s) and walk {lengths[i]:.2f} m"
                )
            durations.append(max(walk, 1e-9))
    return np.array(poses), np.array(seg_of), np.array(durations)


def _segment_table(out: np.ndarray, seg_of: np.ndarray, n_seg: int) -> dict[str, np.ndarray]:
    """The per-segment columns :data:`SEGMENT_COLUMNS` of the kernel's per-motion rows.

    Motions (turns in place, walks) are summed into the segment ``seg_of`` names; mean
    slope and relative heading are weighted by ground distance.
    """
    w = np.maximum(out[:, OUT_DISTANCE], 1e-12)

    def total(v: np.ndarray) -> np.ndarray:
        return np.bincount(seg_of, weights=v, minlength=n_seg)[:n_seg]

    weight = total(w)
    has = np.bincount(seg_of, minlength=n_seg)[:n_seg] > 0
    max_slope = np.zeros(n_seg)
    np.maximum.at(max_slope, seg_of, out[:, OUT_MAX_SLOPE])
    max_slope[~has] = 0.0
    kinds = {
        "forward_share": total(out[:, OUT_E_FORWARD] + out[:, OUT_E_BACKWARD]),
        "lateral_share": total(out[:, OUT_E_LATERAL]),
        "turning_share": total(out[:, OUT_E_TURNING]),
        "other_share": total(out[:, OUT_E_OTHER]),
    }
    # the work of each kind summed as its shares: fwd + lat + turn + other
    work = kinds["forward_share"] + kinds["lateral_share"] + kinds["turning_share"]
    work = work + kinds["other_share"]
    safe = np.where(work > 0, work, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        table = {
            "segment": np.arange(n_seg),
            "energy_j": total(out[:, OUT_ENERGY]),
            "distance_m": total(out[:, OUT_DISTANCE]),
            "duration_s": total(out[:, OUT_DURATION]),
            "turn_deg": np.degrees(total(out[:, OUT_TURN])),
            "mean_slope_deg": np.degrees(total(out[:, OUT_MEAN_SLOPE] * w) / weight),
            "max_slope_deg": np.degrees(max_slope),
            "mean_rel_heading_deg": np.degrees(total(out[:, OUT_MEAN_GAMMA] * w) / weight),
            **{k: v / safe for k, v in kinds.items()},
        }
    return {c: table[c] for c in SEGMENT_COLUMNS}
