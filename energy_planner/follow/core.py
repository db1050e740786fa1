"""A prediction that follows the robot: online slope check, coefficients and remaining energy.

:class:`Follower` takes the plan's remaining path and the robot's log samples (the
canonical log table of :mod:`energy_planner.measurements`, with the pose ``x, y``) as they
arrive. Every complete window of the log (cut by
:func:`energy_planner.measurements.make_windows`, as for the fit) gives one update:

1. the slope the IMU measures (:func:`~energy_planner.measurements.imu_slope_heading`, the
   window's mean ``alpha``) against the DEM's slope under the window's poses; a
   disagreement beyond the sensors' noise is reported with its place
   (:class:`SlopeFinding`);
2. the model's coefficients, by recursive least squares with forgetting
   (:class:`~energy_planner.follow.rls.ForgettingRLS`) on the window's row of the model's
   design matrix, seeded from the fit's coefficients and covariance;
3. the energy of the rest of the path priced with the updated coefficients
   (:func:`~energy_planner.follow.terms.path_term_energies`), its interval (the model's
   split-conformal interval widened by the coefficients' uncertainty and by the power
   the model still misses, the recent mean innovation times the time left) and, with a
   battery, the chance that what is left of it suffices
   (:func:`energy_planner.uncertainty.success_probability`). Below the confidence the
   follower replans from the current pose to the goal (or to the nearest site that still
   fits) and says so.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import EnergyPlannerError, LogError
from energy_planner.follow.calibrate import score_group
from energy_planner.follow.rls import ForgettingRLS, seed_covariance
from energy_planner.follow.terms import (
    PathTerms,
    coefficient_channels,
    motion_term_energies,
    path_term_energies,
    runtime_coefficient_model,
)
from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE
from energy_planner.uncertainty import DEFAULT_LEVEL, interval, model_scores, success_probability

__all__ = [
    "FollowUpdate",
    "Follower",
    "SlopeFinding",
    "FollowError",
    "follow_log",
    "imu_gradient",
]

#: Smallest relative spread a calibrated score is normalized by (0.2 %: the order of the
#: remaining-energy error on plain ground).
SPREAD_FLOOR = 0.002

#: Per-sample features the windows derive (not log channels).
_FEATURES = {"alpha", "gamma", "vx", "vy", "wz", "speed", "ax", "ay", "power"}


def imu_gradient(alpha: Any, gamma: Any, yaw: Any) -> np.ndarray:
    """The ground's gradient ``(dz/dx, dz/dy)`` the IMU measures, shape ``(n, 2)``.

    From the slope ``alpha``, the relative heading ``gamma`` (in the slope plane:
    ``tan(gamma) = tan(yaw - psi) cos(alpha)``, design notes) and the body's yaw: the
    uphill azimuth ``psi = yaw - atan2(sin(gamma), cos(gamma) cos(alpha))`` and the
    gradient ``tan(alpha) (cos(psi), sin(psi))``.

    >>> imu_gradient([math.atan(0.1)], [0.0], [math.pi / 2]).round(12).tolist()
    [[0.0, 0.1]]
    """
    a, g, th = (np.asarray(v, dtype=float) for v in (alpha, gamma, yaw))
    psi = th - np.arctan2(np.sin(g), np.cos(g) * np.cos(a))
    return np.tan(a)[:, None] * np.column_stack([np.cos(psi), np.sin(psi)])


def _finite_or_none(v: float) -> float | None:
    """``v``, or None where it was not measured (NaN): JSON has no NaN."""
    return float(v) if math.isfinite(v) else None


def _conditions_text(scores: Any) -> str:
    c = getattr(scores, "conditions", None) or {}
    if "duration_s" not in c:
        return ""
    return f": simulated missions of {c['duration_s']:g} s at {c.get('rate_hz', 0):g} Hz"


def _path_domain(terrain, model, xy, yaw, t, speed, yaw_rate, channels) -> dict | None:
    """The plan's path's share outside the model's calibration domain (None: no domain).

    :func:`energy_planner.uncertainty.assess.path_domain` of the path priced as given.
    """
    from energy_planner.uncertainty.assess import path_domain
    from energy_planner.uncertainty.domain import domain_of

    if not domain_of(model):
        return None
    from energy_planner.energy import MotionCost, path_energy

    cost = MotionCost(terrain, model, speed, yaw_rate, channels=channels)
    pe = path_energy(terrain, model, np.asarray(xy, dtype=float), yaw=yaw, t=t, cost=cost)
    return path_domain(model, pe, cost)


def default_scores(model: Any, which: str, notes: list[str]) -> Any:
    """The follower's calibrated scores by default (``"auto"``), or None.

    The bundled scores (:func:`~energy_planner.follow.calibrate.bundled_scores`) when
    ``model`` is the bundled model (the same coefficients and terms: they were calibrated
    on it); else None, and a note says the interval is the model's run errors widened.
    """
    from energy_planner.follow.calibrate import bundled_scores
    from energy_planner.io import content_id
    from energy_planner.model import EnergyModel

    if which != "auto":
        raise FollowError(f"remaining_scores must be RemainingScores, 'auto' or None, not "
                          f"{which!r}", value=which)  # fmt: skip
    if content_id(model.to_dict()) == content_id(EnergyModel.default().to_dict()):
        return bundled_scores()
    notes.append("no calibrated remaining-energy errors for this model (the bundled ones "
                 "are the bundled model's): the interval is the model's run errors widened "
                 "by the coefficients' uncertainty (give calibrated scores: --scores)")  # fmt: skip
    return None


class FollowError(LogError):
    """Log samples a follower cannot use (missing pose, several runs, time going back)."""


@dataclass(frozen=True)
class FollowUpdate:
    """One update of the follower (one window of the log).

    Attributes
    ----------
    t : float
        Time at the end of the window, s (the log's clock).
    distance_m : float
        Distance done along the plan's path (ground metres) at the window's last pose.
    remaining_j, low_j, high_j : float
        Energy of the rest of the path and its interval: the median of the follower's
        predictive distribution (:attr:`model_j` over one plus the median of the
        calibrated errors the interval is made of, so that it lies in its interval).
        The errors measure how far :attr:`model_j` is from the truth in the follower's
        state (e.g. soon after a change is detected, the coefficients have not caught
        up yet and the priced rest is short of the truth): the estimate takes that
        known bias out.
    static_j : float
        The same with the fit's coefficients (no online update).
    probability : float or None
        Chance that the battery's usable energy left suffices (None without a battery).
    used_j : float
        Measured battery energy spent so far (integral of voltage times current).
    x, y : float
        The window's last pose (working CRS).
    innovation_w : float
        Measured minus predicted mean power of the window before the update, W.
    event : str or None
        What the follower did at this update (a replan), in words.
    state : str
        ``steady`` (no change detected), ``adapting`` (a change detected: the
        coefficients follow the log) or ``dem`` (a slope finding: the DEM is wrong here).
    remaining_share : float
        Share of the path's time still ahead.
    spread : float
        The follower's own relative uncertainty of the remaining energy (the
        coefficients' variance and the power the model still misses over the time left,
        over the remaining energy; at least :data:`SPREAD_FLOOR`): calibrated scores
        are normalized by it.
    step : float
        Relative size of the largest change of conditions detected so far: the short
        mean innovation at its detection over the recent mean power (signed; 0 before
        any).
    group : str
        The calibrated scores' group the interval was read from
        (:func:`~energy_planner.follow.calibrate.score_group`: the state, with
        ``adapting`` split into ``adapting_small`` / ``adapting_large`` by ``step``).
    model_j : float
        The rest of the path priced with the updated coefficients (and a DEM error's
        extrapolation), before the calibrated bias is taken out: what the calibrated
        errors ``model_j / E_true - 1`` are measured on
        (:func:`~energy_planner.follow.calibrate.calibrate_remaining`).
    battery_ok : bool or None
        The battery's verdict: :attr:`probability` at least the required confidence
        (None without a battery).
    deadline_slack_s : float or None
        With a deadline: the time it leaves once the rest of the path is walked at the
        plan's own pace (its times, or the nominal speed), s; negative: at that pace the
        robot arrives late (None without a deadline).
    speed_to_keep_m_s : float or None
        With a deadline: the mean ground speed over the rest of the path that arrives
        exactly at the deadline (the ground distance left over the time left; turns in
        place not counted); ``inf`` once the deadline has passed.
    """

    t: float
    distance_m: float
    remaining_j: float
    low_j: float
    high_j: float
    static_j: float
    probability: float | None
    used_j: float
    x: float
    y: float
    innovation_w: float
    event: str | None = None
    state: str = "steady"
    remaining_share: float = 1.0
    spread: float = 0.0
    step: float = 0.0
    group: str = "steady"
    model_j: float = math.nan
    battery_ok: bool | None = None
    deadline_slack_s: float | None = None
    speed_to_keep_m_s: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The ``--json`` record: time, distance, remaining energy with bounds, chance.

        With a deadline (:class:`Follower`'s ``deadline``): ``deadline_ok``,
        ``deadline_slack_s`` and ``speed_to_keep_m_s``.
        """
        out = {
            "t": self.t,
            "distance_m": self.distance_m,
            "remaining_j": self.remaining_j,
            "remaining_low_j": self.low_j,
            "remaining_high_j": self.high_j,
            "static_remaining_j": self.static_j,
            "success_probability": self.probability,
            "used_j": self.used_j,
            "x": self.x,
            "y": self.y,
            "innovation_w": self.innovation_w,
            "event": self.event,
            "state": self.state,
            "remaining_share": self.remaining_share,
            "spread": self.spread,
            "step": self.step,
            "group": self.group,
            "model_remaining_j": self.model_j,
            "battery_ok": self.battery_ok,
        }
        if self.deadline_slack_s is not None:
            out["deadline_ok"] = self.deadline_slack_s >= 0
            out["deadline_slack_s"] = self.deadline_slack_s
            out["speed_to_keep_m_s"] = self.speed_to_keep_m_s
        return out


@dataclass(frozen=True)
class SlopeFinding:
    """A stretch where the IMU's slope and the DEM's disagree beyond the sensors' noise."""

    t_start: float
    t_end: float
    x_start: float
    y_start: float
    x_end: float
    y_end: float
    imu_slope_deg: float
    dem_slope_deg: float
    threshold_deg: float
    n_windows: int
    offset_deg: float = math.nan
    distance_m: float = math.nan
    length_m: float = math.nan

    @property
    def difference_deg(self) -> float:
        """Mean IMU minus DEM slope over the stretch, degrees."""
        return self.imu_slope_deg - self.dem_slope_deg

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "t_start": self.t_start,
            "t_end": self.t_end,
            "from": [self.x_start, self.y_start],
            "to": [self.x_end, self.y_end],
            "imu_slope_deg": self.imu_slope_deg,
            "dem_slope_deg": self.dem_slope_deg,
            "difference_deg": self.difference_deg,
            "threshold_deg": self.threshold_deg,
            "n_windows": self.n_windows,
            "gradient_offset_deg": _finite_or_none(self.offset_deg),
            "distance_m": _finite_or_none(self.distance_m),
            "length_m": _finite_or_none(self.length_m),
        }

    def text(self) -> str:
        """One line for people."""
        grad = (
            f", the ground's gradient off by {self.offset_deg:.1f} deg"
            if math.isfinite(self.offset_deg)
            else ""
        )
        return (
            f"slope: the IMU measures {self.imu_slope_deg:.1f} deg where the DEM gives "
            f"{self.dem_slope_deg:.1f} deg ({self.difference_deg:+.1f} deg{grad}, beyond "
            f"the sensors' {self.threshold_deg:.1f} deg) from ({self.x_start:.1f}, "
            f"{self.y_start:.1f}) to ({self.x_end:.1f}, {self.y_end:.1f}), "
            f"t {self.t_start:.0f}-{self.t_end:.0f} s"
        )


@dataclass
class _Stretch:
    t0: float
    t1: float
    p0: tuple[float, float]
    p1: tuple[float, float]
    done0: float = 0.0  # distance done along the path at the stretch's start, m
    imu: list[float] = field(default_factory=list)
    dem: list[float] = field(default_factory=list)
    offset: list[tuple[float, float]] = field(default_factory=list)  # IMU - DEM gradient


class Follower:
    """Follow a mission: update the model and the remaining energy from the robot's logs.

    Parameters
    ----------
    terrain : Terrain
        The DEM.
    model : EnergyModel
        The fitted model (its held-out run errors give the interval; its standard errors
        or covariance seed the online update).
    xy : array-like, shape (n, 2)
        The plan's path, working CRS.
    yaw, t : array-like, optional
        Its yaw (radians) and times (s) per vertex, as for
        :func:`~energy_planner.energy.path_energy`.
    speed, yaw_rate : float
        Nominal speed and yaw rate (when the path has no times).
    channels : Channels, optional
        Values of the channels the model reads (``--set`` / ``--channel``) on the path.
    battery_wh, reserve_wh : float, optional
        Battery and reserve, Wh; with them each update gives the chance of success.
    confidence : float
        Below this chance the follower replans.
    level : float
        Nominal coverage of the remaining energy's interval.
    window_s : float
        Window length, s (the fit's: 2 s).
    forgetting : float
        RLS forgetting factor per window (memory about ``1 / (1 - forgetting)`` windows).
    noise_w : float, optional
        Standard deviation of a window's mean power about the model, W (default: the
        fit's residual RMS or the model's noise floor, else 6 W).
    slope_tol_deg : float, optional
        IMU-minus-DEM slope beyond which two consecutive windows are reported (default:
        3 standard deviations of the IMU's tilt error, ``imu_bias_deg`` per run plus
        ``imu_noise_deg`` per sample averaged over the window, plus 0.5 deg for the DEM's
        sampling of a robot-sized footprint).
    imu_bias_deg, imu_noise_deg : float
        The IMU's per-run tilt bias and per-sample noise (standard deviations), deg.
    replan : bool
        Replan when the chance falls below the confidence.
    sites : array-like, shape (m, 2), optional
        Fallback sites (working CRS): when the goal no longer fits, the nearest site
        that still does.
    request : Request, optional
        Limits for replanning.
    replan_time : float
        Planner time for a replan, s.
    change_share : float
        A change of conditions is detected when the recent mean innovation (an
        exponentially weighted mean over about 3 windows) exceeds both 4 of its standard
        deviations and this share of the recent power; the covariance is then opened to
        its cap (:meth:`ForgettingRLS.reset`) and the event is said.
    batch_s : float
        The log is windowed once this much of it has arrived (log time, s); each call
        gives one update per complete window. A call's cost is mostly fixed (the table
        work of :func:`~energy_planner.measurements.make_windows`), so batching is what
        lets the follower run far faster than real time; it delays an update by at most
        ``batch_s`` of log time (0: window as soon as two windows have arrived).
    dead_band : bool
        Keep the fit's coefficients until a change of conditions is detected (default);
        False: update them at every window. Windows whose IMU slope disagrees with the
        DEM's (a DEM error) are never learnt from.
    remaining_scores : RemainingScores, "auto" or None
        The follower's own held-out errors of the remaining energy
        (:func:`~energy_planner.follow.calibrate.calibrate_remaining`); with them the
        interval is split-conformal on those errors (by remaining share and by group:
        the state, with ``adapting`` split by the detected change's size,
        :func:`~energy_planner.follow.calibrate.score_group`) instead of the model's run
        errors widened. ``"auto"`` (default, as the ``follow`` command): the bundled
        scores (:func:`~energy_planner.follow.calibrate.bundled_scores`) when ``model``
        is the bundled model, else None (they were calibrated on it; said in the notes).
    bias_ahead_m : float, optional
        While a stretch where the IMU's ground disagrees with the DEM's is open, the
        rest of the path is priced on the DEM tilted by the measured gradient offset
        (IMU minus DEM, the stretch's mean less the IMU's own offset where the two
        agree) over this many ground metres ahead, and on the DEM beyond. Default
        (None): by ``stretch_lengths_m``, else as far ahead as the stretch has been
        walked so far (where it ends is not observable; if the current point is
        anywhere in it with equal chance, the median of what is left equals what has
        been walked). 0: never.
    bias_until_m : float, optional
        Where the DEM's error is known to end (a mapped stretch, e.g. earthworks the DEM
        predates), ground metres along the path from its start: the measured offset is
        then applied from the current pose up to there (instead of ``bias_ahead_m``).
    stretch_lengths_m : array-like, optional
        Lengths (ground metres) of the DEM errors found before on this DEM or its kind
        (the slope findings of earlier or calibration missions,
        :attr:`SlopeFinding.length_m`); default: those stored with ``remaining_scores``.
        An open stretch is extrapolated over each of those longer than it is so far
        (what is left of them), equally likely: the mean re-priced energy, and the
        spread of where it ends in the interval.
    deadline : float, optional
        Seconds from the log's first sample by which the robot must reach the path's
        end: each update says whether the rest still fits at the plan's pace
        (:attr:`FollowUpdate.deadline_slack_s`) and the mean speed that arrives in time
        (:attr:`FollowUpdate.speed_to_keep_m_s`); the first update at which it no longer
        fits is an event.
    """

    def __init__(
        self,
        terrain: Any,
        model: Any,
        xy: Any,
        yaw: Any = None,
        t: Any = None,
        *,
        speed: float = DEFAULT_SPEED,
        yaw_rate: float = DEFAULT_YAW_RATE,
        channels: Any = None,
        battery_wh: float | None = None,
        reserve_wh: float = 0.0,
        confidence: float = DEFAULT_LEVEL,
        level: float = DEFAULT_LEVEL,
        window_s: float = 2.0,
        forgetting: float = 0.99,
        noise_w: float | None = None,
        slope_tol_deg: float | None = None,
        imu_bias_deg: float = 0.3,
        imu_noise_deg: float = 0.05,
        replan: bool = True,
        sites: Any = None,
        request: Any = None,
        replan_time: float = 2.0,
        batch_s: float = 20.0,
        change_share: float = 0.05,
        dead_band: bool = True,
        remaining_scores: Any = "auto",
        bias_ahead_m: float | None = None,
        bias_until_m: float | None = None,
        stretch_lengths_m: Any = None,
        deadline: float | None = None,
    ) -> None:
        from scipy.special import ndtri  # the normal quantile (scipy.stats: ~1 s to import)

        if deadline is not None and not (math.isfinite(deadline) and deadline > 0):
            raise FollowError(f"the deadline must be > 0 seconds, got {deadline!r}",
                              value=deadline)  # fmt: skip
        self.deadline = None if deadline is None else float(deadline)
        self._t_first: float | None = None  # the log's first time: the deadline's origin

        if battery_wh is not None and not reserve_wh < battery_wh:
            raise FollowError(
                f"the reserve ({reserve_wh:g} Wh) must be below the battery ({battery_wh:g} Wh)",
                value=reserve_wh,
            )
        self.terrain = terrain
        self.model = model
        self.speed, self.yaw_rate = float(speed), float(yaw_rate)
        self.channels = channels
        self.level, self.confidence = float(level), float(confidence)
        self.window_s = float(window_s)
        self.batch_s = float(batch_s)
        self.battery_wh, self.reserve_wh = battery_wh, float(reserve_wh)
        self.usable_j = None if battery_wh is None else (battery_wh - reserve_wh) * 3600.0
        self.replan_enabled, self.request, self.replan_time = replan, request, replan_time
        self.sites = None if sites is None else np.atleast_2d(np.asarray(sites, dtype=float))
        self.notes: list[str] = []
        self.path = path_term_energies(
            terrain, model, xy, yaw, t, speed, yaw_rate, channels=self.channels
        )
        self.goal = tuple(self.path.poses[-1])
        self.domain = _path_domain(terrain, model, xy, yaw, t, speed, yaw_rate, channels)
        self._total_s = max(self.path.remaining_s(0, 0.0), 1e-9)
        c0 = model.coef_array()
        cov, note = seed_covariance(model)
        self.notes.append(f"coefficients seeded from the fit; covariance: {note}")
        fit = (model.metadata or {}).get("fit") or {}
        if noise_w is None:
            noise_w = fit.get("residual_rms_w") or (model.metadata or {}).get("noise_floor_w")
            noise_w = float(noise_w) if noise_w else 6.0
        # a coefficient may drift by half its value (a payload on a 50 kg robot is a few
        # tens of %), plus three standard errors, before the cap stops wind-up
        cap = (0.5 * np.abs(c0) + 3.0 * np.sqrt(np.diag(cov))) ** 2
        self.rls = ForgettingRLS(c0, cov, noise_w**2, forgetting, cap)
        self.c0 = c0
        self.z = float(ndtri(0.5 + level / 2.0))
        self.scores = model_scores(model)
        if isinstance(remaining_scores, str):
            remaining_scores = default_scores(model, remaining_scores, self.notes)
        self.remaining_scores = remaining_scores
        if remaining_scores is not None:
            self.notes.append(
                "interval: split-conformal on the follower's own held-out remaining-energy "
                f"errors ({len(remaining_scores.seeds)} calibration seeds"
                + _conditions_text(remaining_scores)
                + "), per group (state; adapting by the detected change's size) "
                "and remaining share"
            )
        elif self.scores is None:
            self.notes.append(
                "the model carries no held-out run errors: the interval is "
                "the coefficients' uncertainty only"
            )
        if slope_tol_deg is None:
            sd = math.hypot(imu_bias_deg, imu_noise_deg / math.sqrt(10.0))
            slope_tol_deg = 3.0 * sd + 0.5
        self.slope_tol_deg = float(slope_tol_deg)
        self.bias_ahead_m = bias_ahead_m
        self.bias_until_m = bias_until_m
        self.imu_bias_deg = float(imu_bias_deg)
        if stretch_lengths_m is None and remaining_scores is not None:
            stretch_lengths_m = getattr(remaining_scores, "dem_lengths_m", None) or None
        self.stretch_lengths_m = (
            None
            if stretch_lengths_m is None
            else np.sort(np.asarray(stretch_lengths_m, dtype=float).ravel())
        )
        self._agree_sum = np.zeros(2)
        self._agree_n = 0
        self._runtime_model: Any = None
        self.updates: list[FollowUpdate] = []
        self.findings: list[SlopeFinding] = []
        self.changes: list[float] = []  # times of the detected changes of conditions, s
        self.events: list[str] = []
        from energy_planner.measurements import CANONICAL_COLUMNS

        self._columns = [c for c in CANONICAL_COLUMNS if c != "run"]
        self._columns += sorted(model.variables - set(self._columns) - _FEATURES)
        self._buf: dict[str, np.ndarray] | None = None
        self._run: str | None = None
        self._used_j = 0.0
        self._used_at = 0.0
        self._bias_w = 0.0  # recent mean innovation (EWMA with the RLS's memory), W
        self._bias_limit = 4.0 * noise_w * math.sqrt(0.3 / 1.7)
        self._fast_w = 0.0
        self._since_reset = 10**9
        self._n_windows = 0
        self._power_w = 0.0
        self.change_share = float(change_share)
        self._rem_s = 0.0
        self._spread = SPREAD_FLOOR
        self._last_power: tuple[float, float] | None = None  # (t, p) of the last sample
        self._motion = 0
        self._done_m = 0.0
        self._stretch: _Stretch | None = None
        self._cooldown_until = -math.inf
        self.dead_band = bool(dead_band)
        self._adapting = False  # a change was detected: the coefficients follow the log
        self._step = 0.0  # the largest detected change's relative size (score_group)
        self._model_j = math.nan  # the last raw remaining energy (before the bias)

    # ------------------------------------------------------------------ input
    def feed(self, samples: Any) -> list[FollowUpdate]:
        """Take newly arrived log samples; return the updates of the windows they complete.

        ``samples``: a DataFrame of the canonical log table, or a mapping of its columns
        to arrays (what :meth:`replay` feeds: no table work per chunk).
        """
        # only what windows and the model read: extra channels cost time in make_windows
        cols = {c: np.asarray(samples[c]) for c in (*self._columns, "run") if c in samples}
        if "t" not in cols or len(cols["t"]) == 0:
            return []
        self._check(cols)
        if self._t_first is None:
            self._t_first = float(cols["t"][0])
        used = self._integrate_power(cols)
        arrived = {c: v for c, v in cols.items() if c != "run"}
        arrived["_used"] = used
        buf = (
            arrived
            if self._buf is None
            else {c: np.concatenate([self._buf[c], arrived[c]]) for c in arrived}
        )
        t = buf["t"]
        if t[-1] - t[0] < max(2.0 * self.window_s, self.batch_s):
            self._buf = buf
            return []
        return self._process(buf, final=False)

    def finish(self) -> list[FollowUpdate]:
        """Process what is left in the buffer (the log has ended); close open findings."""
        out = [] if self._buf is None or len(self._buf) == 0 else self._process(self._buf, True)
        self._close_stretch()
        return out

    def replay(
        self, samples: pd.DataFrame, chunk_s: float = 1.0, speedup: float | None = None
    ) -> list[FollowUpdate]:
        """Feed a whole log in chunks of ``chunk_s`` seconds, then :meth:`finish`.

        ``speedup`` paces the replay at that many times real time (None: as fast as it
        goes).
        """
        import time

        cols = {c: samples[c].to_numpy() for c in (*self._columns, "run") if c in samples}
        t = cols["t"].astype(float)
        edges = np.searchsorted(t, np.arange(t[0], t[-1] + chunk_s, chunk_s), side="left")
        edges = np.r_[edges, len(t)]
        out: list[FollowUpdate] = []
        wall0 = time.monotonic()
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            if b <= a:
                continue
            if speedup:
                wait = (t[b - 1] - t[0]) / speedup - (time.monotonic() - wall0)
                if wait > 0:
                    time.sleep(wait)
            out += self.feed({c: v[a:b] for c, v in cols.items()})
        return out + self.finish()

    def _check(self, samples: dict[str, np.ndarray]) -> None:
        missing = [c for c in ("x", "y") if c not in samples]
        if missing:
            raise FollowError(
                f"the log has no pose column(s) {', '.join(missing)}: a follower needs the "
                "robot's position (columns x, y in the DEM's CRS) to know where on the path "
                "it is",
                value=missing,
                expected="columns x, y",
            )
        r = samples["run"] if "run" in samples else np.array(["log"])
        runs = [r[0]] if (r == r[0]).all() else list(pd.unique(r.astype(str)))
        if self._run is None:
            self._run = str(runs[0])
        if len(runs) > 1 or str(runs[0]) != self._run:
            raise FollowError(
                f"the log holds several runs ({', '.join(map(str, runs[:5]))}; following "
                f"{self._run!r}): follow one mission at a time (choose it with --run)",
                value=list(map(str, runs[:5])),
            )
        t0 = float(samples["t"][0])
        if self._last_power is not None and t0 <= self._last_power[0]:
            raise FollowError(
                f"time goes back: sample at t={t0:g} s after t={self._last_power[0]:g} s",
                value=t0,
            )

    def _integrate_power(self, samples: dict[str, np.ndarray]) -> np.ndarray:
        """Battery energy spent up to each new sample (trapezoids of voltage * current)."""
        t = samples["t"].astype(float)
        p = samples["voltage"].astype(float) * samples["current"].astype(float)
        t0, p0 = self._last_power if self._last_power is not None else (t[0], p[0])
        tt, pp = np.r_[t0, t], np.r_[p0, p]
        used = self._used_j + np.cumsum(0.5 * (pp[1:] + pp[:-1]) * np.diff(tt))
        self._used_j = float(used[-1])
        self._last_power = (float(t[-1]), float(p[-1]))
        return used

    # ------------------------------------------------------------------ updates
    def _process(self, buf: dict[str, np.ndarray], final: bool) -> list[FollowUpdate]:
        from energy_planner.measurements import make_windows
        from energy_planner.measurements.preprocess import PreprocessParams, hampel_mask

        # the fit's outlier filter on power (its windows had current spikes removed): a
        # spike would read as a change of conditions. The energy spent keeps them.
        pp = PreprocessParams()
        power = buf["voltage"].astype(float) * buf["current"].astype(float)
        ok = ~hampel_mask(power, pp.hampel_half_window, pp.hampel_n_sigma, pp.hampel_min_scale_w)
        frame = pd.DataFrame(buf if ok.all() else {c: v[ok] for c, v in buf.items()})
        frame.insert(0, "run", np.full(len(frame), self._run, dtype=object))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # a short buffer may drop its tail
            w = make_windows(frame, self.window_s)
        tab = w.table
        if len(tab) == 0:
            self._buf = None if final else buf
            return []
        if not final:
            tab = tab.iloc[:-1]  # the last window may still grow
            if len(tab) == 0:
                self._buf = buf
                return []
        ids = tab["window"].to_numpy()
        smp = w.samples[w.samples["window"].isin(ids)]
        win = smp["window"].to_numpy()
        X = self.model.design_matrix(smp, groups=win)
        xs, ys = smp["x"].to_numpy(float), smp["y"].to_numpy(float)
        ts = self.terrain.sample(xs, ys)
        dem = np.degrees(np.asarray(ts.slope, dtype=float))
        # window ids are sorted: the first and last sample of each, and the DEM's mean slope
        starts = np.flatnonzero(np.r_[True, win[1:] != win[:-1]])
        ends = np.r_[starts[1:], win.size] - 1
        size = ends - starts + 1
        dem_mean = np.add.reduceat(dem, starts) / size
        offset = np.full((len(tab), 2), np.nan)
        if "yaw" in smp.columns:
            g = imu_gradient(smp["alpha"], smp["gamma"], smp["yaw"]) - np.column_stack(
                [ts.dzdx, ts.dzdy]
            )
            offset = np.add.reduceat(g, starts, axis=0) / size[:, None]
        cols = {c: tab[c].to_numpy(float) for c in ("power", "t_start", "t_end", "alpha")}
        imu = np.degrees(cols["alpha"])
        used = smp["_used"].to_numpy(float)
        out = [
            self._update(
                used[ends[i]],
                X[i],
                cols["power"][i],
                cols["t_end"][i],
                imu[i],
                dem_mean[i],
                (xs[starts[i]], ys[starts[i]]),
                (xs[ends[i]], ys[ends[i]]),
                cols["t_start"][i],
                offset[i],
            )
            for i in range(len(tab))
        ]
        keep = buf["t"] > float(smp["t"].max())
        self._buf = None if final or not keep.any() else {c: v[keep] for c, v in buf.items()}
        return out

    def _update(
        self, used_j, x, power, t_end, imu_deg, dem_deg, p_first, p_last, t_start, offset=None
    ):
        # a window whose IMU slope disagrees with the DEM's is a DEM error, not a model
        # error: it is checked, not learnt from (nor counted as a change of conditions)
        dem_error = self._disagreement(imu_deg, dem_deg, offset) > self.slope_tol_deg
        # the first window after such a stretch straddles its end (part of it walked on
        # the wrong ground): neither learnt from nor counted either
        dem_error = dem_error or self._stretch is not None
        # dead band: the fit's coefficients are kept until a change of conditions is
        # detected (learning the odometry's slip on plain ground only adds error); the
        # first window holds the gait's start (a transient the fit's windows do not have)
        if self._n_windows == 0 or dem_error or not (self._adapting or not self.dead_band):
            innovation = float(power - x @ self.rls.coef)
        else:
            innovation = self.rls.update(x, power)
        self._n_windows += 1
        lam = self.rls.forgetting
        self._bias_w = lam * self._bias_w + (1.0 - lam) * innovation
        self._power_w = lam * self._power_w + (1.0 - lam) * power if self._power_w else power
        self._since_reset += 1
        # change detection on a short mean of the innovation (3 windows): beyond 4 of its
        # standard deviations and beyond change_share of the power (the model's own bias on
        # new ground is a few %)
        if not dem_error:
            self._fast_w = 0.7 * self._fast_w + 0.3 * innovation
        limit = max(self._bias_limit, self.change_share * self._power_w)
        if abs(self._fast_w) > limit and self._since_reset > 5:
            self.rls.reset()
            self._since_reset = 0
            self._adapting = True
            # the largest change detected so far: a second detection while the
            # coefficients still catch up with a large change is the rest of that change
            step = self._fast_w / max(abs(self._power_w), 1e-9)
            self._step = step if abs(step) > abs(self._step) else self._step
            self.changes.append(float(t_end))
            self.events.append(
                f"t={t_end:.0f} s at ({p_last[0]:.1f}, {p_last[1]:.1f}): the power departs "
                f"from the model by {self._fast_w:+.1f} W on average (beyond "
                f"{limit:.1f} W): a change of conditions; the coefficients are "
                "opened to follow it"
            )
        self._slope_check(t_start, t_end, imu_deg, dem_deg, p_first, p_last, offset)
        self._motion, frac = self.path.locate(*p_last, start=self._motion)
        m = self._motion
        dist = self.path.distance_m
        self._done_m = float(dist[:m].sum() + frac * (dist[m] if m < dist.size else 0.0))
        r = self.path.remaining(m, frac)
        static = float(max(r @ self.c0, 0.0))
        r, extra_var = self._biased_remaining(m, frac, r)
        self._used_at = float(used_j)
        self._rem_s = self.path.remaining_s(m, frac)
        rem, low, high, prob = self._predict(r, extra_var)
        model_j = self._model_j
        event = None
        if (
            self.usable_j is not None
            and prob is not None
            and prob < self.confidence
            and self.replan_enabled
            and t_end >= self._cooldown_until
        ):
            event, replaced = self._replan(p_last, t_end, rem, prob)
            if replaced:
                self._motion, frac = 0, 0.0
                r = self.path.remaining(0, 0.0)
                static = float(max(r @ self.c0, 0.0))
                self._rem_s = self.path.remaining_s(0, 0.0)
                self._total_s = max(self._rem_s, 1e-9)
                rem, low, high, prob = self._predict(r)
                model_j = self._model_j
        elif (
            self.usable_j is not None
            and prob is not None
            and prob < self.confidence
            and not self.replan_enabled
            and t_end >= self._cooldown_until
        ):
            self._cooldown_until = t_end + 30.0
            event = (
                f"t={t_end:.0f} s at ({p_last[0]:.1f}, {p_last[1]:.1f}): "
                f"{100 * prob:.0f} % chance the battery suffices for the {rem:.0f} J "
                f"left (< {100 * self.confidence:g} %); replanning is off"
            )
            self.events.append(event)
        slack, keep = self._deadline(t_end, m, frac, p_last)
        u = FollowUpdate(
            t_end,
            self._done_m,
            rem,
            low,
            high,
            static,
            prob,
            self._used_at,
            p_last[0],
            p_last[1],
            innovation,
            event,
            self.state,
            self._rem_s / self._total_s,
            self._spread,
            self._step,
            self.group,
            model_j,
            None if prob is None else bool(prob >= self.confidence),
            slack,
            keep,
        )
        self.updates.append(u)
        return u

    def _deadline(self, t_end, m, frac, p_last) -> tuple[float | None, float | None]:
        """``(slack, speed to keep)`` of the deadline at this update (None without one).

        The first update whose slack is negative (after one that was not) is an event.
        """
        if self.deadline is None:
            return None, None
        dist = self.path.distance_m
        left_m = float(dist[m:].sum() - frac * (dist[m] if m < dist.size else 0.0))
        left_s = self.deadline - (t_end - (self._t_first or 0.0))
        slack = float(left_s - self._rem_s)
        keep = float(max(left_m, 0.0) / left_s) if left_s > 0 else math.inf
        was_ok = all(u.deadline_slack_s is None or u.deadline_slack_s >= 0 for u in self.updates)
        if slack < 0 and was_ok:
            self.events.append(
                f"t={t_end:.0f} s at ({p_last[0]:.1f}, {p_last[1]:.1f}): at the plan's pace "
                f"the rest takes {self._rem_s:.0f} s and {max(left_s, 0.0):.0f} s are left "
                f"before the deadline: it holds only at {keep:.2f} m/s on average over the "
                f"{left_m:.0f} m left"
            )
        return slack, keep

    @property
    def state(self) -> str:
        """``dem`` after a slope finding, ``adapting`` after a change, else ``steady``."""
        s = self._stretch
        if self.findings or (s is not None and len(s.imu) >= 2):
            return "dem"
        return "adapting" if self._adapting else "steady"

    @property
    def group(self) -> str:
        """The calibrated scores' group of the follower now (:func:`score_group`)."""
        split = getattr(self.remaining_scores, "step_split", None)
        return score_group(self.state, self._step, split)

    def _predict(
        self, r: np.ndarray, extra_var: float = 0.0
    ) -> tuple[float, float, float, float | None]:
        """Remaining energy, its interval and the chance the battery suffices.

        ``extra_var``: variance of the DEM error's extrapolation ahead, J^2
        (:meth:`_biased_remaining`). The rest priced with the current coefficients
        (``raw``, kept in ``self._model_j``) and the scores of its errors
        ``raw / E_true - 1`` (the calibrated ones, or the model's run errors) make one
        predictive distribution of the true rest, ``raw / (1 + score)``: the interval is
        its conformal bounds, the chance its share within the battery, and the estimate
        its median, ``raw / (1 + median score)``, which lies inside the interval.
        """
        raw = float(max(r @ self.rls.coef, 0.0))
        self._model_j = raw
        # the coefficients' uncertainty, the power the model still misses (the recent
        # mean innovation: large while it catches up with a change) over the time left,
        # and where a DEM error ends ahead
        sd = math.sqrt(
            self.rls.variance_of(r) + (self._bias_w * self._rem_s) ** 2 + max(extra_var, 0.0)
        )
        self._spread = max(sd / max(raw, 1e-9), SPREAD_FLOOR)
        left = None if self.usable_j is None else self.usable_j - self._used_at
        if self.remaining_scores is not None:
            sc = self.remaining_scores.for_group(
                self.group, self._rem_s / self._total_s, self.level
            )
            if getattr(self.remaining_scores, "normalized", False):
                # normalized conformal: the scores are in units of the spread; a relative
                # error is > -1 (E_pred / E_true - 1), and below -0.9 would say the rest
                # costs over ten times its prediction: clipped there (a wider interval)
                sc = np.maximum(sc * self._spread, -0.9)
            iv = interval(raw, sc, self.level)
            prob = None if left is None else success_probability(raw, sc, left)
            low, high = iv.low_j, iv.high_j
        elif self.scores is not None:
            sc = self.scores
            iv = interval(raw, sc, self.level)
            low, high = iv.low_j - self.z * sd, iv.high_j + self.z * sd
            prob = None if left is None else success_probability(raw, sc, left)
        else:
            sc = None
            low, high = raw - self.z * sd, raw + self.z * sd
            prob = None
            if left is not None:
                from scipy.special import ndtr

                prob = float(ndtr((left - raw) / max(sd, 1e-9)))
        rem = raw if sc is None else raw / (1.0 + float(np.median(sc)))
        return rem, max(low, 0.0), high, prob

    # ------------------------------------------------------------------ slope
    @staticmethod
    def _disagreement(imu_deg: float, dem_deg: float, offset: Any = None) -> float:
        """How far the IMU's ground is from the DEM's, degrees (NaN: not measured).

        The angle of the gradient offset (IMU minus DEM gradient, :func:`imu_gradient`)
        when the log has the yaw: a DEM error across the path changes the slope's
        direction more than its size (5 deg across a 15 deg slope: 0.7 deg of slope,
        5 deg of gradient); else the difference of the slopes.
        """
        if offset is not None and np.isfinite(offset).all():
            return math.degrees(math.atan(math.hypot(float(offset[0]), float(offset[1]))))
        if math.isfinite(imu_deg) and math.isfinite(dem_deg):
            return abs(imu_deg - dem_deg)
        return math.nan

    def _slope_check(self, t0, t1, imu_deg, dem_deg, p0, p1, offset=None) -> None:
        gap = self._disagreement(imu_deg, dem_deg, offset)
        if not math.isfinite(gap):
            return
        if gap > self.slope_tol_deg:
            s = self._stretch
            if s is None:
                s = self._stretch = _Stretch(t0, t1, p0, p1, done0=self._done_m)
            s.t1, s.p1 = t1, p1
            s.imu.append(imu_deg)
            s.dem.append(dem_deg)
            if offset is not None and np.isfinite(offset).all():
                s.offset.append((float(offset[0]), float(offset[1])))
        else:
            if self._stretch is None and offset is not None and np.isfinite(offset).all():
                # where the IMU agrees with the DEM: its own offset (the IMU's tilt bias
                # and the DEM's footprint), taken out of a stretch's measured offset
                self._agree_sum += np.asarray(offset, dtype=float)
                self._agree_n += 1
            self._close_stretch()

    def _close_stretch(self) -> None:
        s, self._stretch = self._stretch, None
        if s is None or len(s.imu) < 2:  # one window alone is not reported (noise)
            return
        f = SlopeFinding(
            s.t0,
            s.t1,
            *s.p0,
            *s.p1,
            float(np.mean(s.imu)),
            float(np.mean(s.dem)),
            self.slope_tol_deg,
            len(s.imu),
            math.degrees(math.atan(float(np.hypot(*self._stretch_offset(s))))),
            s.done0,
            max(self._done_m - s.done0, 0.0),
        )
        self.findings.append(f)
        self.events.append(f.text())

    def _stretch_offset(self, s: _Stretch) -> np.ndarray:
        """The DEM's measured gradient error over an open stretch (NaN without yaw).

        The stretch's mean IMU-minus-DEM gradient, less the mean of the windows where the
        two agreed (the IMU's own tilt bias and the DEM's footprint, there all along).
        """
        if not s.offset:
            return np.full(2, np.nan)
        base = self._agree_sum / self._agree_n if self._agree_n else np.zeros(2)
        return np.mean(s.offset, axis=0) - base

    def _ahead_samples(self, walked: float) -> np.ndarray | None:
        """How far ahead the open DEM error may still last, ground metres (equally likely).

        From the lengths of the DEM errors found before (``stretch_lengths_m``): those
        longer than what this one has lasted so far, less that (the lengths' empirical
        distribution conditioned on having lasted ``walked``); None if none is longer.
        """
        lengths = self.stretch_lengths_m
        if lengths is None:
            return None
        left = lengths[lengths > walked] - walked
        return left if left.size else None

    def _biased_remaining(self, m: int, frac: float, r: np.ndarray) -> tuple[np.ndarray, float]:
        """``r`` with the path ahead re-priced on the DEM tilted by the measured offset.

        Only while a stretch of IMU-vs-DEM disagreement is open (two windows or more)
        and its gradient offset is measured (the log has ``yaw``). How far ahead the
        error lasts (where the stretch ends cannot be seen from the log): up to
        ``bias_until_m`` when it is known; ``bias_ahead_m`` when given; else the lengths
        of DEM errors found before (``stretch_lengths_m``) that are longer than this one
        so far, each equally likely (the mean of the re-priced energies); else, or when
        this one is longer than all of them, as far as it has been walked (the median
        of what is left for a point anywhere in a stretch of unknown length).

        Returns
        -------
        tuple
            The term energies and the variance of the re-priced energy, J^2: the spread
            over where the error ends (with no lengths to go by: the whole extrapolation
            as its standard deviation) and the offset's own uncertainty (the IMU's
            per-run tilt bias, ``imu_bias_deg``).
        """
        s = self._stretch
        if s is None or len(s.imu) < 2 or not s.offset or self.bias_ahead_m == 0:
            return r, 0.0
        n = self.path.energy.shape[0]
        if m >= n:
            return r, 0.0
        walked = max(self._done_m - s.done0, 0.0)
        unknown = False
        if self.bias_until_m is not None:
            ahead = np.array([self.bias_until_m - self._done_m])
        elif self.bias_ahead_m is not None:
            ahead = np.array([float(self.bias_ahead_m)])
        else:
            got = self._ahead_samples(walked)
            unknown = got is None
            ahead = np.array([walked]) if got is None else got
        dist = self.path.distance_m
        # ground metres from here to the end of each motion m, m+1, ...
        ends = np.cumsum(np.r_[(1.0 - frac) * dist[m], dist[m + 1 :]])
        k = min(m + int(np.searchsorted(ends, float(ahead.max()), side="left")) + 1, n)
        if float(ahead.max()) <= 0.0:
            return r, 0.0
        offset = self._stretch_offset(s)
        tilted = self._tilted_terrain(float(offset[0]), float(offset[1]))
        poses = self.path.poses[m : k + 1]
        e_tilt, _, _ = motion_term_energies(
            tilted, self.model, poses, self.path.duration_s[m:k], self.speed, self.yaw_rate,
            self.channels,
        )  # fmt: skip
        extra = e_tilt - self.path.energy[m:k]
        extra[0] *= 1.0 - frac
        # the extra term energies up to each distance ahead, linear within a motion
        cum = np.vstack([np.zeros((1, extra.shape[1])), np.cumsum(extra, axis=0)])
        at = np.r_[0.0, ends[: k - m]]
        upto = np.column_stack([np.interp(ahead, at, cum[:, q]) for q in range(cum.shape[1])])
        mean = upto.mean(axis=0)
        e = upto @ self.rls.coef
        var = float(np.var(e)) + (float(e[0]) ** 2 if unknown else 0.0)
        size = float(np.hypot(*offset))
        rel = math.tan(math.radians(self.imu_bias_deg)) / max(size, 1e-9)
        var += (rel * float(mean @ self.rls.coef)) ** 2
        return r + mean, var

    def _tilted_terrain(self, bx: float, by: float) -> Any:
        """The DEM with its gradient plus ``(bx, by)`` everywhere (a tilted plane added)."""
        from energy_planner.terrain import Terrain

        t = self.terrain
        xc, yc = t.cell_centers()
        return Terrain(
            t.elevation + bx * (xc - xc.mean()) + by * (yc - yc.mean()),
            t.transform,
            t.crs,
            gradient=(t.dzdx + bx, t.dzdy + by),
        )

    # ------------------------------------------------------------------ replanning
    def current_model(self) -> Any:
        """The model with the updated coefficients."""
        from energy_planner.model import EnergyModel

        m = self.model
        return EnergyModel(
            m.term_specs,
            dict(zip(m.term_names, map(float, self.rls.coef), strict=True)),
            stderr=m.stderr,
            regenerative=m.regenerative,
            metadata=m.metadata,
        )

    def replan_inputs(self) -> tuple[Any, Any]:
        """The model and request a replan plans with: the updated coefficients at run time.

        The model is :func:`~energy_planner.follow.terms.runtime_coefficient_model` of the
        fit's (built once), the request the follower's with the current coefficients as
        its constant channels: every replan shares one compiled motion kernel, whatever
        the coefficients (a model with the coefficients compiled in, as
        :meth:`current_model`, would compile a kernel per update).
        """
        from energy_planner.request import Request

        if self._runtime_model is None:
            self._runtime_model = runtime_coefficient_model(self.model)
        req = self.request if self.request is not None else Request()
        base = req.channels if req.channels is not None else self.channels
        chans = coefficient_channels(self.rls.coef, base)
        return self._runtime_model, dataclasses.replace(req, channels=chans)

    def _plan_to(self, start, goal) -> tuple[PathTerms, float, float | None] | None:
        from energy_planner.planning.plan import plan

        model, request = self.replan_inputs()
        try:
            res = plan(
                self.terrain,
                model,
                start,
                goal,
                request,
                time=self.replan_time,
                progress=False,
            )
        except EnergyPlannerError:
            return None
        pt = path_term_energies(
            self.terrain,
            self.model,
            res.states[:, :2],
            res.states[:, 2],
            None,
            self.speed,
            self.yaw_rate,
            channels=self.channels,
        )
        rem, _, _, prob = self._predict_on(pt)
        return pt, rem, prob

    def _predict_on(self, pt: PathTerms):
        return self._predict(pt.remaining(0, 0.0))

    def _replan(self, pose, t, rem, prob) -> tuple[str, bool]:
        """Replan to the goal, else to the nearest site that fits; (what was done, replaced)."""
        self._cooldown_until = t + 30.0
        yaw = float(self.path.poses[min(self._motion, len(self.path.poses) - 1), 2])
        start = (pose[0], pose[1], yaw)
        head = (
            f"t={t:.0f} s at ({pose[0]:.1f}, {pose[1]:.1f}): {100 * prob:.0f} % chance "
            f"the battery suffices for the {rem:.0f} J left (< {100 * self.confidence:g} %)"
        )
        got = self._plan_to(start, self.goal)
        if got is not None and got[2] is not None and got[2] >= self.confidence:
            self.path = got[0]
            msg = (
                f"{head}; replanned from the current pose to the goal: {got[1]:.0f} J, "
                f"{100 * got[2]:.0f} % chance"
            )
            self.events.append(msg)
            return msg, True
        if self.sites is not None:
            order = np.argsort(np.hypot(self.sites[:, 0] - pose[0], self.sites[:, 1] - pose[1]))
            for j in order:
                site = (float(self.sites[j, 0]), float(self.sites[j, 1]))
                got_s = self._plan_to(start, site)
                if got_s is not None and got_s[2] is not None and got_s[2] >= self.confidence:
                    self.path, self.goal = got_s[0], tuple(got_s[0].poses[-1])
                    msg = (
                        f"{head}; the goal no longer fits: replanned to the nearest site "
                        f"that does, ({site[0]:.1f}, {site[1]:.1f}): {got_s[1]:.0f} J, "
                        f"{100 * got_s[2]:.0f} % chance"
                    )
                    self.events.append(msg)
                    return msg, True
        msg = f"{head}; no replan fits (goal{' or any site' if self.sites is not None else ''})"
        self.events.append(msg)
        return msg, False

    # ------------------------------------------------------------------ results
    def write_html(self, path: Any) -> Any:
        """One self-contained HTML page (:func:`energy_planner.webmap.follow_page`).

        The path being followed (after any replan), the poses of the updates and, on
        hover, each update's time, energy used, remaining energy with its interval and
        battery chance.
        """
        from energy_planner.webmap import follow_page

        walked = [(u.x, u.y) for u in self.updates]
        return follow_page(self.terrain, path, walked, self.updates, self.path.poses[:, :2])

    def to_dict(self) -> dict[str, Any]:
        """Updates, slope findings, events, notes, the battery asked and the path's domain.

        What ``follow --json`` prints (with the log's, DEM's and path's names).
        """
        return {
            "updates": [u.to_dict() for u in self.updates],
            "slope_findings": [f.to_dict() for f in self.findings],
            "changes_t": list(self.changes),
            "events": list(self.events),
            "notes": list(self.notes),
            "coefficients": dict(
                zip(self.model.term_names, map(float, self.rls.coef), strict=True)
            ),
            "slope_tolerance_deg": self.slope_tol_deg,
            "level": self.level,
            "confidence": self.confidence,
            "battery_wh": self.battery_wh,
            "reserve_wh": self.reserve_wh,
            "domain": self.domain,
            **({} if self.deadline is None else {"deadline_s": self.deadline}),
        }


def follow_log(
    terrain: Any,
    model: Any,
    samples: pd.DataFrame,
    path: Any,
    *,
    run: str | None = None,
    speedup: float | None = None,
    chunk_s: float = 1.0,
    **options: Any,
) -> Follower:
    """Replay a log against a plan's path (what ``energy-planner follow`` runs).

    Parameters
    ----------
    terrain : Terrain
        The DEM.
    model : EnergyModel
        The fitted model.
    samples : pandas.DataFrame
        Canonical log samples (:func:`energy_planner.measurements.load_logs`) with the
        pose ``x, y`` in the DEM's CRS.
    path : Waypoints
        The plan's path as read by :func:`energy_planner.energy.waypoints.read_waypoints`
        (the project's GeoJSON path format, or CSV waypoints).
    run : str, optional
        The run to follow when the log holds several.
    speedup : float, optional
        Replay pace, times real time (None: as fast as possible).
    chunk_s : float
        Log time fed at once, s.
    **options
        Passed to :class:`Follower` (battery, confidence, forgetting, ...).

    Returns
    -------
    Follower
        With ``updates``, ``findings``, ``events`` and ``notes``.

    Raises
    ------
    FollowError
        Several runs and no ``run``, a ``run`` the log does not have, or no pose.
    """
    from energy_planner.energy.waypoints import waypoints_to_work

    runs = sorted(map(str, pd.unique(samples["run"].astype(str))))
    if run is None and len(runs) > 1:
        raise FollowError(
            f"the log holds {len(runs)} runs ({', '.join(runs[:5])}"
            f"{', ...' if len(runs) > 5 else ''}): choose one with --run",
            value=runs[:5],
            expected="one of " + ", ".join(runs[:20]),
        )
    if run is not None:
        if run not in runs:
            raise FollowError(
                f"run {run!r} is not in the log; runs: {', '.join(runs[:20])}",
                value=run,
                expected="one of " + ", ".join(runs[:20]),
            )
        samples = samples[samples["run"].astype(str) == run]
    missing = [c for c in ("x", "y") if c not in samples.columns]
    if missing:
        raise FollowError(
            f"the log has no pose column(s) {', '.join(missing)}: a follower needs the "
            "robot's position (columns x, y in the DEM's CRS)",
            value=missing,
            expected="columns x, y",
        )
    samples = samples.sort_values("t", kind="stable").reset_index(drop=True)
    xw, yw = terrain.to_work(samples["x"].to_numpy(float), samples["y"].to_numpy(float))
    samples = samples.assign(x=np.asarray(xw, dtype=float), y=np.asarray(yw, dtype=float))
    xy, yaw = waypoints_to_work(terrain, path)
    f = Follower(terrain, model, xy, yaw, path.t, **options)
    f.replay(samples, chunk_s=chunk_s, speedup=speedup)
    return f
