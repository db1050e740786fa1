"""One planning request: the robot's nominal motion, the limits and the extra channels.

:func:`energy_planner.planning.plan`, ``compare_routes``, ``energy_map`` and ``reach`` take
a :class:`Request` instead of repeating speed, yaw rate, slope limits, keep-out areas and
channel values as separate parameters. The defaults (0.3 m/s along the ground, 0.5 rad/s)
are the paper's runs and are defined here once.

Every field is checked when the object is made; a bad value raises :class:`RequestError`
(an :class:`~energy_planner.errors.EnergyPlannerError` and a :class:`ValueError`) whose
``field`` and ``value`` attributes name what was wrong.

Examples
--------
>>> r = Request(robot=Robot(speed=0.5), limits=Limits(max_slope_deg=20))
>>> r.robot.speed, r.robot.yaw_rate, r.limits.max_slope_deg
(0.5, 0.5, 20.0)
>>> Robot(speed=-1)
Traceback (most recent call last):
...
energy_planner.request.RequestError: speed must be a finite number > 0 m/s, got -1
>>> Limits(max_slope_deg=95).max_slope_deg
Traceback (most recent call last):
...
energy_planner.request.RequestError: max_slope_deg must be a number in [0, 90] degrees, got 95
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from energy_planner.errors import EnergyPlannerError

if TYPE_CHECKING:  # the emap engineer's class; imported by name only
    from energy_planner.energy.channels import Channels

__all__ = [
    "DEFAULT_SPEED",
    "DEFAULT_YAW_RATE",
    "GAIT_TOL_RAD",
    "Robot",
    "Limits",
    "Request",
    "RequestError",
]

#: Nominal walking speed along the ground, m/s (as in the paper's runs).
DEFAULT_SPEED: float = 0.3
#: Nominal turning rate, rad/s.
DEFAULT_YAW_RATE: float = 0.5
#: Slack of the gait limits (:class:`Limits`), radians: a body within this of the
#: direction of travel (or of its opposite) has crab angle 0, and walking counts as
#: backward only beyond 90 degrees plus this.
GAIT_TOL_RAD: float = 1e-6


class RequestError(EnergyPlannerError, ValueError):
    """A planning request field has a bad value.

    Attributes
    ----------
    field : str
        The field's name (``"speed"``, ``"max_slope_deg"``, ...).
    value : object
        The value given.
    """

    def __init__(self, message: str, *, field: str, value: Any, **fields: Any) -> None:
        super().__init__(message, value=value, field=field, param=field, **fields)


def _positive(name: str, value: Any, unit: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise RequestError(
            f"{name} must be a finite number > 0 {unit}, got {value!r}", field=name, value=value
        )
    return v


def _angle_limit(name: str, value: Any) -> float | None:
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (0.0 <= v <= 90.0):
        raise RequestError(
            f"{name} must be a number in [0, 90] degrees, got {value!r}", field=name, value=value
        )
    return v


@dataclass(frozen=True)
class Robot:
    """The robot's nominal motion.

    Parameters
    ----------
    speed : float
        Walking speed along the ground, m/s (> 0).
    yaw_rate : float
        Turning rate, rad/s (> 0).
    """

    speed: float = DEFAULT_SPEED
    yaw_rate: float = DEFAULT_YAW_RATE

    def __post_init__(self) -> None:
        object.__setattr__(self, "speed", _positive("speed", self.speed, "m/s"))
        object.__setattr__(self, "yaw_rate", _positive("yaw_rate", self.yaw_rate, "rad/s"))


@dataclass(frozen=True)
class Limits:
    """Where the robot may go.

    Parameters
    ----------
    max_slope_deg : float, optional
        Steepest ground slope a path may cross, degrees in [0, 90].
    max_cross_slope_deg : float, optional
        Steepest slope across the robot's body, degrees in [0, 90].
    keep_out : path or sequence of shapely geometries, optional
        Keep-out polygons: a GeoJSON file (RFC 7946 longitude/latitude unless it declares
        a CRS; read when planning, so that errors name the file), geometries read with
        their CRS (:func:`energy_planner.io.read_geometries`) or shapely geometries in the
        DEM's CRS (a single geometry is accepted too).
    max_backward_slope_deg : float, optional
        Gait limit: no backward walking on ground steeper than this, degrees in [0, 90].
        A motion walks backward where the angle between body x and its direction of
        travel exceeds 90 degrees (:data:`GAIT_TOL_RAD` of slack); walking exactly
        sideways is not backward. Checked at every sub-step of a motion against the
        slope there. None: backward walking is allowed everywhere; 0: only on level ground.
    max_crab_deg : float, optional
        Gait limit: the crab angle, the angle between body x and the direction of
        travel, or between body x and its opposite when walking backward, is at most
        this, degrees in [0, 90]. 0: the body faces along the direction of travel or
        straight back; 90 (or None): any gait, sideways included.

    Notes
    -----
    Both gait limits are about translation. The direction of travel of a motion is the
    direction of its velocity along the ground, and the angles are measured in the
    ground plane, in the body frame tilted with the ground (``atan2(|vy|, vx)`` of the
    body-frame velocity, the twist the energy model prices), at every sub-step.
    "Backward" thus means that the feet carry the robot towards its rear along the
    ground. On a slope this differs from the horizontal angle between the yaw and the
    map direction of travel, except at 0 and 180 degrees (and at 90 degrees when the
    body or the direction of travel lies along a contour line).

    A turn in place has no direction of travel, so neither limit restricts it (nor a
    pose: a start or goal is never refused for its yaw). A motion that turns while it
    translates is checked with its yaw at each sub-step, so under ``max_crab_deg=0``
    the body may only translate at constant yaw along its axis, or turn in place.
    """

    max_slope_deg: float | None = None
    max_cross_slope_deg: float | None = None
    keep_out: str | Path | Sequence[Any] | None = None
    max_backward_slope_deg: float | None = None
    max_crab_deg: float | None = None

    def __post_init__(self) -> None:
        for name in ("max_slope_deg", "max_cross_slope_deg", "max_backward_slope_deg",
                     "max_crab_deg"):  # fmt: skip
            object.__setattr__(self, name, _angle_limit(name, getattr(self, name)))
        ko = self.keep_out
        if ko is None or isinstance(ko, str | Path):
            return
        if hasattr(ko, "geom_type"):  # one shapely geometry
            object.__setattr__(self, "keep_out", (ko,))
            return
        try:
            geoms = tuple(ko)
        except TypeError:
            raise RequestError(
                f"keep_out must be a GeoJSON path or a sequence of shapely geometries, got "
                f"{type(ko).__name__}",
                field="keep_out",
                value=ko,
            ) from None
        for k, g in enumerate(geoms):
            if not hasattr(g, "geom_type"):
                raise RequestError(
                    f"keep_out[{k}] is a {type(g).__name__}, expected a shapely geometry",
                    field="keep_out",
                    value=g,
                )
        if getattr(ko, "crs", None) is not None:  # io.Geometries: keep their CRS
            geoms = type(ko)(geoms, crs=ko.crs, source=getattr(ko, "source", ""))
        object.__setattr__(self, "keep_out", geoms)


@dataclass(frozen=True)
class Request:
    """Everything a planning query needs besides the map, the model and the endpoints.

    Parameters
    ----------
    robot : Robot
        Nominal speed and yaw rate.
    limits : Limits
        Slope limits and keep-out areas.
    channels : Channels, optional
        Values of the extra channels the model's terms read
        (:class:`energy_planner.energy.channels.Channels`: ``--set`` constants and
        ``--channel`` rasters).
    """

    robot: Robot = field(default_factory=Robot)
    limits: Limits = field(default_factory=Limits)
    channels: Channels | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.robot, Robot):
            raise RequestError(
                f"robot must be a Robot, got {type(self.robot).__name__}",
                field="robot",
                value=self.robot,
            )
        if not isinstance(self.limits, Limits):
            raise RequestError(
                f"limits must be a Limits, got {type(self.limits).__name__}",
                field="limits",
                value=self.limits,
            )
        ch = self.channels
        if ch is not None and not (hasattr(ch, "constants") and hasattr(ch, "rasters")):
            raise RequestError(
                f"channels must be an energy_planner.energy.channels.Channels, got "
                f"{type(ch).__name__}",
                field="channels",
                value=ch,
            )

    @classmethod
    def make(
        cls,
        speed: float = DEFAULT_SPEED,
        yaw_rate: float = DEFAULT_YAW_RATE,
        max_slope_deg: float | None = None,
        max_cross_slope_deg: float | None = None,
        keep_out: str | Path | Sequence[Any] | None = None,
        channels: Channels | None = None,
        max_backward_slope_deg: float | None = None,
        max_crab_deg: float | None = None,
    ) -> Request:
        """A request from flat keyword values (what a CLI command has).

        Examples
        --------
        >>> Request.make(speed=0.4, max_slope_deg=25).limits.max_slope_deg
        25.0
        """
        return cls(
            robot=Robot(speed=speed, yaw_rate=yaw_rate),
            limits=Limits(
                max_slope_deg=max_slope_deg,
                max_cross_slope_deg=max_cross_slope_deg,
                keep_out=keep_out,
                max_backward_slope_deg=max_backward_slope_deg,
                max_crab_deg=max_crab_deg,
            ),
            channels=channels,
        )
