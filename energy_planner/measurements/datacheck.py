"""Data findings: sensor problems in the logs, told apart from physical effects.

A physical effect is something the robot really spends; a sensor problem makes the logs
lie about what it did or spent. Both leave a residual that some candidate term can fit
(odometry that under-reports speed more on steep ground makes every metre look dearer on
slopes, which ``sin(alpha)**2`` fits), so the sensor problems are looked for first, on the
raw canonical samples, each with a test of its own, and are reported as *data findings*:

``current_sign``
    Runs whose battery current is mostly negative while the robot walks: the current
    sensor's sign is the other way round (canonical: positive while discharging). Repair:
    the sign of those runs' current is flipped.
``clock_offset``
    The power stream (voltage, current) and the motion stream (twist) are shifted in time:
    the power's step at the start and the stop of each run is timed against the motion's
    (:func:`check_clock_offset`). Repair: the power stream is shifted back.
``odometry_slip``
    Needs the optional pose columns ``x, y`` (from a source other than the legged
    odometry, as in the simulator's logs). Per run, the net horizontal displacement of the
    twist integrated through the IMU orientation is compared with the pose's; the ratio is
    ``1 - slip``. A finding when the slip grows with ``sin(alpha)`` (regression slope over
    runs, one-sided t-test at :data:`DATA_ALPHA`, at least :data:`MIN_SLIP_PER_SIN` per unit
    ``sin(alpha)``). Repair: each run's twist is divided by its measured ratio (runs that do
    not translate: by the fitted slip at their slope).
``odometry_scale``
    Needs the pose ``x, y`` too. A slip at one level on every slope (the odometry reads
    every metre a few percent short or long), which ``odometry_slip`` leaves: the mean
    of the runs' slips differs from zero (t-test over runs). Repair: each run's twist
    divided by its measured ratio (:func:`check_odometry_scale`).
``imu_tilt``
    Needs the pose with altitude ``x, y, z`` (from a source other than the IMU, e.g. a
    map-referenced localization; the simulator's mission logs have it). A robot walking
    on the ground moves in the plane of its body's x and y axes, so the pose's
    displacement over each second, rotated into the body frame by the IMU orientation,
    has no body-z component; an IMU tilted against the body by small angles (roll
    ``e_r``, pitch ``e_p``) shows one: ``dz_body = e_p dx_body - e_r dy_body``. Per run,
    least squares over one-second chords (orientation at the chord's middle) give
    ``e_p`` and, when the run moves sideways enough to tell it (standard error at most
    :data:`MAX_TILT_SE_DEG`), ``e_r`` (:func:`imu_tilt_bias`). A finding when the
    estimates differ from zero beyond their standard errors (chi-square over runs, p <
    :data:`DATA_ALPHA`) and their root mean square is at least :data:`MIN_TILT_DEG`.
    Repair: each run's orientation is rotated back by its estimate. A tilt of a few
    tenths of a degree moves the slope by as much and turns the heading on gentle slopes
    by ``tilt / slope`` radians; on mission logs, whose long steady windows have little
    power noise, that was the largest error left to the base model.

Each check reports what it measured whether or not it is a finding (``evidence``), so a
clean log says *why* it is clean. Every check measures within the gap-free stretches of
a run (a time gap, longer than five of the run's sample periods, splits it, as
preprocessing does: :func:`~energy_planner.measurements.schema.time_gaps`), never across
a gap.

Examples
--------
>>> import pandas as pd
>>> t = np.arange(0, 4, 0.05)
>>> s = pd.DataFrame({"run": "a", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
...                   "vx": 0.3, "vy": 0.0, "wz": 0.0, "voltage": 50.0,
...                   "current": -4.0 + 0.1 * np.sin(7 * t)})
>>> found, fixed = check_data(s)
>>> [f.name for f in found if f.finding], float(fixed["current"].iloc[0])
(['current_sign'], 4.0)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.measurements.schema import time_gaps

#: Level of each data check's test (one test per check).
DATA_ALPHA = 1e-3
#: Smallest clock offset reported, s.
MIN_OFFSET_S = 0.15
#: Largest spread (interquartile range over runs, s) of the offsets for a clock finding:
#: a clock offset is the same in every run.
MAX_OFFSET_IQR_S = 0.2
#: Smallest growth of the odometry slip per unit sin(alpha) reported.
MIN_SLIP_PER_SIN = 0.02
#: Smallest mean odometry slip over runs (either sign) reported as a scale error, 1.
MIN_SCALE_SLIP = 0.005
#: Smallest pose distance of a run (summed over its chords) used for the slip check, m.
MIN_DISPLACEMENT_M = 0.5
#: Length of the chords over which the odometry is compared with the pose, s. Short
#: enough that the heading error the integrated twist accumulates stays small (over a
#: whole curved mission of 10-30 minutes it moved each run's net-displacement ratio by
#: 2-4 %), long enough that the pose's noise and staleness are small against the chord.
ODOMETRY_CHORD_S = 10.0
#: Smallest root mean square over runs of the IMU tilt estimates reported, deg.
MIN_TILT_DEG = 0.05
#: Largest standard error of a run's IMU tilt estimate that is used (and repaired), deg.
MAX_TILT_SE_DEG = 0.05
#: Length of the pose chords of the tilt check, s.
TILT_CHORD_S = 1.0


@dataclass
class DataFinding:
    """The result of one data check.

    Attributes
    ----------
    name : str
        ``current_sign``, ``clock_offset``, ``odometry_slip``, ``odometry_scale``,
        ``imu_tilt`` or ``twist_noise``.
    finding : bool
        True when the check found the problem.
    summary : str
        One line for a person.
    evidence : dict
        What was measured (numbers, test statistics, affected runs).
    repaired : bool
        True when the samples returned by :func:`check_data` have it corrected.
    """

    name: str
    finding: bool
    summary: str
    evidence: dict[str, Any] = field(default_factory=dict)
    repaired: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict."""
        return asdict(self)


def _runs(samples: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Code of each sample's gap-free stretch of a run, and the stretches' names.

    The samples are sorted by run and t. A time gap
    (:func:`~energy_planner.measurements.schema.time_gaps`) splits a run (as preprocessing
    does): every check measures within a stretch, never across a gap (a 10-minute pause
    would otherwise read as 10 minutes of odometry at the speed of the sample after it).
    A run without gaps is one stretch named as the run; the parts of a split run are
    named ``"<run> (part k)"``.

    Examples
    --------
    >>> s = pd.DataFrame({"run": ["a", "a", "a", "a", "b"], "t": [0.0, 0.1, 0.2, 600.0, 0.0]})
    >>> code, names = _runs(s)
    >>> code.tolist(), names.tolist()
    ([0, 0, 0, 1, 2], ['a (part 1)', 'a (part 2)', 'b'])
    """
    run = samples["run"].astype(str).to_numpy(dtype=object)
    t = samples["t"].to_numpy(float)
    if len(run) == 0:
        return np.zeros(0, dtype=np.int64), np.asarray([], dtype=object)
    same = run[1:] == run[:-1]
    gap = time_gaps(run, t).step
    if not gap.any():
        code, names = pd.factorize(run, sort=True)
        return code.astype(np.int64), np.asarray(names, dtype=object)
    start = np.r_[True, ~same | gap]
    code = np.cumsum(start) - 1
    first = np.flatnonzero(start)
    split_runs = set(run[1:][gap])
    names = []
    k = 0
    for i, a in enumerate(first):
        if i and run[a] != run[first[i - 1]]:
            k = 0
        k += 1
        names.append(f"{run[a]} (part {k})" if run[a] in split_runs else str(run[a]))
    return code.astype(np.int64), np.asarray(names, dtype=object)


def check_current_sign(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """Runs whose current is mostly negative (see the module docstring)."""
    code, names = _runs(samples)
    cur = pd.Series(samples["current"].to_numpy(float))
    g = cur.groupby(code)
    med = g.median().reindex(range(len(names))).to_numpy(float)
    # noise of the sensor from successive differences (robust): a standing robot whose
    # current is zero up to noise has no sign to check
    noise = (
        pd.Series(np.abs(np.diff(cur.to_numpy(), prepend=np.nan)))
        .where(np.r_[False, code[1:] == code[:-1]])
        .groupby(code)
        .median()
        .reindex(range(len(names)))
        .to_numpy(float)
        * 1.4826
        / math.sqrt(2)
    )
    bad = np.nan_to_num(med, nan=0.0) < -3.0 * np.nan_to_num(noise, nan=0.0) - 1e-9
    ev = {"runs_checked": int(len(names)), "median_current_a": float(np.nanmedian(med))}
    if not bad.any():
        return (
            DataFinding("current_sign", False, "battery current is positive while walking", ev),
            samples,
        )
    bad_runs = [str(r) for r in names[bad]]
    ev.update({"runs": bad_runs[:20], "n_runs": len(bad_runs)})
    fixed = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    flip = bad[code]
    fixed.loc[flip, "current"] = -fixed.loc[flip, "current"]
    what = "every run" if bad.all() else f"{len(bad_runs)} of {len(names)} runs"
    return (
        DataFinding(
            "current_sign",
            True,
            f"battery current is negative in {what} while the robot works: the current "
            "sensor's sign is inverted (canonical: positive while discharging); flipped",
            ev,
            repaired=True,
        ),
        fixed,
    )


def _shift_within_runs(values: np.ndarray, code: np.ndarray, k: int) -> np.ndarray:
    """``values`` moved ``k`` samples later within each run (NaN where nothing comes)."""
    out = np.full(values.shape, np.nan)
    n = len(values)
    if k == 0:
        return values.astype(float).copy()
    if k > 0:
        same = code[k:] == code[:-k]
        out[k:][same] = values[:-k][same]
    else:
        k = -k
        same = code[:-k] == code[k:]
        out[: n - k][same] = values[k:][same]
    return out


def _crossing(t: np.ndarray, v: np.ndarray, level: float, rising: bool) -> float:
    """First time ``v`` crosses ``level`` upwards (``rising``) or last time downwards.

    Linearly interpolated; NaN if it never does.
    """
    above = v >= level
    if rising:
        i = np.flatnonzero(~above[:-1] & above[1:])
        if not i.size:
            return math.nan
        i = int(i[0])
    else:
        i = np.flatnonzero(above[:-1] & ~above[1:])
        if not i.size:
            return math.nan
        i = int(i[-1])
    v0, v1 = v[i], v[i + 1]
    f = (level - v0) / (v1 - v0) if v1 != v0 else 0.0
    return float(t[i] + f * (t[i + 1] - t[i]))


def _transition_offsets(
    t: np.ndarray, p: np.ndarray, m: np.ndarray, ends: tuple[float, float, float, float]
) -> tuple[float, float]:
    """Power-minus-motion midpoint-crossing times at the start and at the end of a run.

    ``ends`` are the power and motion levels at the first and the last sample.
    """
    n = len(t)
    p1, m1 = np.median(p[n // 3 : 2 * n // 3]), np.median(m[n // 3 : 2 * n // 3])
    p0, m0, pe, me = ends
    out = []
    for rising, (pa, pb, ma, mb) in ((True, (p0, p1, m0, m1)), (False, (pe, p1, me, m1))):
        if not (abs(pb - pa) > 0.1 * abs(pb) and mb > 2 * max(ma, 1e-9)):
            out.append(math.nan)
            continue
        tp = _crossing(t, p, (pa + pb) / 2, rising=(pb > pa) == rising)
        tm = _crossing(t, m, (ma + mb) / 2, rising=rising)
        out.append(tp - tm)
    return out[0], out[1]


def check_clock_offset(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """Time shift between the power and the motion streams (see the module docstring).

    At the start of every run that starts walking (or turning) from rest, the time the
    power crosses the midpoint of its step is compared with the time the robot starts
    stepping (speed above 0.05 m/s or yaw rate above 0.1 rad/s, averaged over 0.25 s, crossing
    one half): a gait costs most of its power from the first step, so the two coincide
    when the streams share a clock. (The stop is not used: a lagging power stream is cut
    off by the end of the log there.) A finding when the median offset over runs is at
    least :data:`MIN_OFFSET_S` and a signed-rank test over runs gives p <
    :data:`DATA_ALPHA`, and the offsets agree between runs (interquartile range at most
    :data:`MAX_OFFSET_IQR_S`); measured on the simulator's campaigns: -0.06 s without the
    fault, +0.34 s (quartiles 0.32-0.37 s) with its 0.4 s lag. Mission logs, whose runs
    barely step in power when they start, are not checked (quartiles 0.05-17 s).
    """
    from energy_planner.stats.signedrank import signed_rank_test

    code, names = _runs(samples)
    t = samples["t"].to_numpy(float)
    same = code[1:] == code[:-1]
    dts = np.diff(t)[same]
    dt = float(np.median(dts)) if dts.size else math.nan
    if not math.isfinite(dt) or dt <= 0:
        return DataFinding("clock_offset", False, "too few samples to check timing"), samples
    p = samples["voltage"].to_numpy(float) * samples["current"].to_numpy(float)
    # whether the robot steps at all: a gait costs most of its power from the first step
    speed = np.hypot(samples["vx"].to_numpy(float), samples["vy"].to_numpy(float))
    motion = ((speed > 0.05) | (np.abs(samples["wz"].to_numpy(float)) > 0.1)).astype(float)
    width = max(1, int(round(0.25 / dt)))
    first = np.flatnonzero(np.r_[True, ~same])
    bounds = np.r_[first, len(code)]
    # the smoothed power and motion of every run, its rolling windows within the run: one
    # grouped rolling per step (the same numbers as a Series per run, bit for bit: a
    # window that does not overlap the one before starts its sums afresh)
    group = np.repeat(np.arange(len(bounds) - 1), np.diff(bounds))
    smooth_p = pd.Series(p).groupby(group).rolling(5, center=True, min_periods=1).median()
    smooth_p = pd.Series(smooth_p.to_numpy(float)).groupby(group)
    smooth_p = smooth_p.rolling(width, center=True, min_periods=1).mean().to_numpy(float)
    smooth_m = pd.Series(motion).groupby(group).rolling(width, center=True, min_periods=1)
    smooth_m = smooth_m.mean().to_numpy(float)
    offsets = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        if b - a < 20:
            continue
        pr, mr = smooth_p[a:b], smooth_m[a:b]
        # levels before the first step and after the last: the raw first / last samples
        # (the runs start moving at once; a smoothed level would already be rising)
        ends = (
            float(np.median(p[a : a + 2])),
            float(np.median(motion[a : a + 2])),
            float(np.median(p[b - 2 : b])),
            float(np.median(motion[b - 2 : b])),
        )
        d0, d1 = _transition_offsets(t[a:b], pr, mr, ends)
        if math.isfinite(d0):
            offsets.append(d0)
    offsets = np.asarray(offsets)
    if offsets.size < 5:
        return (
            DataFinding(
                "clock_offset", False, f"not checked: {offsets.size} runs start and stop moving"
            ),
            samples,
        )
    med = float(np.median(offsets))
    pval = signed_rank_test(offsets, "two-sided")[2]
    ev = {
        "offset_s": med,
        "offset_iqr_s": [float(np.quantile(offsets, 0.25)), float(np.quantile(offsets, 0.75))],
        "sample_interval_s": dt,
        "p_value": pval,
        "n_runs": int(offsets.size),
    }
    k = int(round(med / dt))
    q25, q75 = ev["offset_iqr_s"]
    if q75 - q25 > MAX_OFFSET_IQR_S:
        return (
            DataFinding(
                "clock_offset",
                False,
                f"timing not checked: the power steps of the runs do not line up with their "
                f"first steps consistently (offsets {q25:+.2f}..{q75:+.2f} s between the "
                "quartiles; runs that do not start from rest or whose power barely steps)",
                ev,
            ),
            samples,
        )
    if not (abs(med) >= MIN_OFFSET_S and pval < DATA_ALPHA and k != 0):
        return (
            DataFinding(
                "clock_offset",
                False,
                f"power and motion streams are in step (median offset {med:+.2f} s over "
                f"{offsets.size} runs)",
                ev,
            ),
            samples,
        )
    fixed = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    for col in ("voltage", "current"):
        fixed[col] = _shift_within_runs(fixed[col].to_numpy(float), code, -k)
    fixed = fixed[np.isfinite(fixed["current"].to_numpy(float))].reset_index(drop=True)
    n_lost = len(samples) - len(fixed)
    ev["samples_dropped"] = n_lost
    later = "later" if k > 0 else "earlier"
    return (
        DataFinding(
            "clock_offset",
            True,
            f"the power stream is stamped {abs(k) * dt:.2f} s {later} than the motion it "
            f"pays for (clock offset between the streams, median over {offsets.size} runs); "
            f"shifted back ({n_lost} samples at the ends of the runs had no power left and "
            "were dropped)",
            ev,
            repaired=True,
        ),
        fixed,
    )


def _rotate_xy(q: np.ndarray, vx: np.ndarray, vy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World x, y components of the body vector ``(vx, vy, 0)`` rotated by unit ``q``."""
    w, x, y, z = q.T
    r00 = 1 - 2 * (y * y + z * z)
    r01 = 2 * (x * y - w * z)
    r10 = 2 * (x * y + w * z)
    r11 = 1 - 2 * (x * x + z * z)
    return r00 * vx + r01 * vy, r10 * vx + r11 * vy


@dataclass(frozen=True)
class OdometryRatios:
    """Per run: the legged odometry's distance against the pose's (:func:`odometry_ratios`).

    Attributes
    ----------
    code : numpy.ndarray
        Run code of every sample (samples sorted by run, t).
    ratio : numpy.ndarray
        Per run, the horizontal distance of the twist integrated through the IMU
        orientation over the pose's, summed over chords of :data:`ODOMETRY_CHORD_S`
        (``1 - slip``); NaN where not ``use``.
    sin_slope : numpy.ndarray
        Per run, the mean ``sin(alpha)`` of its samples (IMU).

    use : numpy.ndarray
        Per run, whether its pose's chords add up to more than :data:`MIN_DISPLACEMENT_M`.
    """

    code: np.ndarray
    ratio: np.ndarray
    sin_slope: np.ndarray
    use: np.ndarray


def odometry_ratios(samples: pd.DataFrame) -> OdometryRatios:
    """Per-run ratio of the odometry's distance to the pose's, chord by chord.

    The one measurement of the odometry against the pose, shared by the ``odometry_slip``
    and ``odometry_scale`` checks. The samples must be sorted by run and ``t`` and have
    the pose ``x, y``. Each run is cut into chords of :data:`ODOMETRY_CHORD_S`; over each
    the twist, integrated through the IMU orientation, is compared with the pose's
    displacement, and the run's ratio is the sum of the odometry's chord lengths over the
    pose's. A ratio of the net displacements over the whole run is not used: on a long
    curved mission the integrated twist's heading error turns its far end, and the ratio
    then depends on the path's shape rather than on the odometry's scale (on 24 field
    missions of 6-27 minutes the net ratios strayed from the chord ratios by up to 4 %,
    sd 2 %, and each mission's repaired speed was off by as much: a constant power error
    per mission that no term could explain, r = 0.90 with the stray).

    Examples
    --------
    A run that walks 12 m east whose odometry reads 3 % short:

    >>> t = np.arange(0, 40, 0.05)
    >>> s = pd.DataFrame({"run": "a", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
    ...                   "vx": 0.3 * 0.97, "vy": 0.0, "x": 0.3 * t, "y": 0.0})
    >>> round(float(odometry_ratios(s).ratio[0]), 3)
    0.97
    """
    code, names = _runs(samples)
    n_runs = len(names)
    q = samples[["qw", "qx", "qy", "qz"]].to_numpy(float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    t = samples["t"].to_numpy(float)
    dt = np.zeros(len(t))
    same = code[1:] == code[:-1]
    dt[1:] = np.where(same, np.diff(t), 0.0)
    wx, wy = _rotate_xy(q, samples["vx"].to_numpy(float), samples["vy"].to_numpy(float))
    # the velocity of a sample times the step that leads to it (the first sample of a run
    # has none): the sum between two samples spans the same time as the pose's
    # displacement between them
    cx = np.cumsum(np.nan_to_num(wx * dt))
    cy = np.cumsum(np.nan_to_num(wy * dt))
    px, py = samples["x"].to_numpy(float), samples["y"].to_numpy(float)
    first = np.flatnonzero(np.r_[True, ~same])
    # chord ends: the first sample of each run, the first sample of each chord after it
    # and the last sample of each run (consecutive chords share their end samples)
    t0 = t[first][code]
    chord = np.floor((t - t0) / ODOMETRY_CHORD_S).astype(np.int64)
    new_chord = np.r_[True, (code[1:] != code[:-1]) | (chord[1:] != chord[:-1])]
    last = np.r_[first[1:] - 1, len(code) - 1]
    ends = np.union1d(np.flatnonzero(new_chord), last)
    a, b = ends[:-1], ends[1:]
    inside = code[a] == code[b]  # a chord within one run
    a, b = a[inside], b[inside]
    pose_len = np.hypot(px[b] - px[a], py[b] - py[a])
    odo_len = np.hypot(cx[b] - cx[a], cy[b] - cy[a])
    ok = np.isfinite(pose_len) & np.isfinite(odo_len)
    disp = np.bincount(code[a][ok], weights=pose_len[ok], minlength=n_runs)
    odo = np.bincount(code[a][ok], weights=odo_len[ok], minlength=n_runs)
    # slope of each run from the IMU: the body z axis against the vertical
    cos_a = 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2)
    sin_a = np.sqrt(np.clip(1 - cos_a**2, 0, 1))
    sin_run = np.bincount(code, weights=sin_a, minlength=n_runs) / np.bincount(code)
    use = np.isfinite(disp) & (disp > MIN_DISPLACEMENT_M) & np.isfinite(odo)
    ratio = np.full(n_runs, np.nan)
    ratio[use] = odo[use] / disp[use]
    return OdometryRatios(code, ratio, sin_run, use)


def check_odometry_slip(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """Odometry slip that grows with slope, against the pose (see the module docstring)."""
    if not {"x", "y"} <= set(samples.columns):
        return (
            DataFinding(
                "odometry_slip",
                False,
                "not checked: the logs have no pose (x, y) to compare the odometry with",
            ),
            samples,
        )
    m = odometry_ratios(samples)
    code, use, sin_run = m.code, m.use, m.sin_slope
    ev: dict[str, Any] = {"runs_used": int(use.sum())}
    if use.sum() < 5:
        return (
            DataFinding(
                "odometry_slip",
                False,
                f"not checked: {int(use.sum())} runs move more than {MIN_DISPLACEMENT_M} m",
                ev,
            ),
            samples,
        )
    ratio = m.ratio[use]
    slip = 1.0 - ratio
    xs = sin_run[use]
    a = np.column_stack([np.ones(xs.size), xs])
    from scipy.special import stdtr  # Student's t (scipy.stats costs ~1 s to import)

    from energy_planner.stats import wls

    fit = wls(a, slip)
    coef = fit.coef
    dof = max(xs.size - 2, 1)
    se = float(fit.stderr[1]) if np.isfinite(fit.stderr[1]) else math.inf
    tstat = coef[1] / se if se > 0 else (math.inf if coef[1] > 0 else 0.0)
    pval = float(stdtr(dof, -tstat))
    ev.update(
        {
            "slip_level": float(coef[0]),
            "slip_per_sin_slope": float(coef[1]),
            "stderr": se,
            "t": float(tstat),
            "p_value": pval,
            "slip_median": float(np.median(slip)),
        }
    )
    found = pval < DATA_ALPHA and coef[1] >= MIN_SLIP_PER_SIN
    if not found:
        return (
            DataFinding(
                "odometry_slip",
                False,
                f"odometry agrees with the pose on every slope (slip {coef[0]:+.3f} "
                f"{coef[1]:+.3f} sin(alpha), not a finding)",
                ev,
            ),
            samples,
        )
    factor = 1.0 - (coef[0] + coef[1] * sin_run)  # fitted ratio for every run
    factor[use] = ratio
    factor = np.clip(factor, 0.5, 1.5)
    fixed = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    for col in ("vx", "vy", "wz"):
        fixed[col] = fixed[col].to_numpy(float) / factor[code]
    return (
        DataFinding(
            "odometry_slip",
            True,
            f"the legged odometry under-reports distance more on steeper ground: slip "
            f"{coef[0]:.3f} + {coef[1]:.3f} sin(alpha) against the pose (t {tstat:.1f}); a "
            "sensor problem, not a physical effect: the twist of each run was rescaled by "
            "its measured slip",
            ev,
            repaired=True,
        ),
        fixed,
    )


def check_odometry_scale(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """Odometry that reads a constant share short or long, against the pose.

    ``odometry_slip`` repairs a slip that grows with slope; a slip at the same level on
    every slope is left to this check (after a slip repair the ratios are 1 and it finds
    nothing). Left in, the per-metre terms are fitted per *odometry* metre and priced per
    *map* metre: a plan or the energy of given poses is off by the slip (3 % slip: about
    +3 % energy). Per run, the ratio ``1 - slip`` of :func:`odometry_ratios`; a finding
    when the mean slip over the runs differs from zero (two-sided t-test over runs, p <
    :data:`DATA_ALPHA`) by at least :data:`MIN_SCALE_SLIP`. Repair: each run's twist
    ``(vx, vy, wz)`` divided by its measured ratio (runs that do not translate: by the
    mean ratio), so that the odometry's metres are the pose's.
    """
    if not {"x", "y"} <= set(samples.columns):
        return (
            DataFinding(
                "odometry_scale",
                False,
                "not checked: the logs have no pose (x, y) to compare the odometry with",
            ),
            samples,
        )
    m = odometry_ratios(samples)
    n_used = int(m.use.sum())
    ev: dict[str, Any] = {"runs_used": n_used}
    if n_used < 5:
        return (
            DataFinding(
                "odometry_scale",
                False,
                f"not checked: {n_used} runs move more than {MIN_DISPLACEMENT_M} m",
                ev,
            ),
            samples,
        )
    from scipy.special import stdtr  # Student's t (scipy.stats costs ~1 s to import)

    slip = 1.0 - m.ratio[m.use]
    level = float(np.mean(slip))
    se = float(np.std(slip, ddof=1) / math.sqrt(slip.size))
    tstat = level / se if se > 0 else (math.inf if level != 0 else 0.0)
    pval = float(2 * stdtr(slip.size - 1, -abs(tstat)))
    ev.update(
        {
            "slip_mean": level,
            "stderr": se,
            "t": float(tstat),
            "p_value": pval,
            "slip_quartiles": [float(np.quantile(slip, 0.25)), float(np.quantile(slip, 0.75))],
        }
    )
    short = "short" if level > 0 else "long"
    if not (pval < DATA_ALPHA and abs(level) >= MIN_SCALE_SLIP):
        return (
            DataFinding(
                "odometry_scale",
                False,
                f"odometry distance agrees with the pose (mean slip {level:+.3f}, t "
                f"{tstat:.1f}; a finding from {MIN_SCALE_SLIP:.3f} at p < {DATA_ALPHA:g})",
                ev,
            ),
            samples,
        )
    factor = np.where(m.use, m.ratio, 1.0 - level)
    factor = np.clip(factor, 0.5, 1.5)
    fixed = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    for col in ("vx", "vy", "wz"):
        fixed[col] = fixed[col].to_numpy(float) / factor[m.code]
    return (
        DataFinding(
            "odometry_scale",
            True,
            f"the legged odometry reads distance {100 * abs(level):.1f} % {short} against "
            f"the pose on every slope (mean slip {level:+.3f} over {n_used} runs, t "
            f"{tstat:.1f}); left in, the per-metre terms would be fitted per odometry "
            "metre and priced per map metre: the twist of each run was divided by its "
            "measured ratio",
            ev,
            repaired=True,
        ),
        fixed,
    )


def _rotation(q: np.ndarray) -> np.ndarray:
    """Body-to-world rotation matrices of unit quaternions ``(w, x, y, z)``, shape (n, 3, 3)."""
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def _rotate_by(q: np.ndarray, rv: np.ndarray) -> np.ndarray:
    """Quaternions ``q (x) exp(rv)``: ``q`` followed by the body-frame rotation vector ``rv``.

    >>> np.round(_rotate_by(np.array([[1.0, 0, 0, 0]]), np.array([[0, 0, np.pi]])), 12).tolist()
    [[0.0, 0.0, 0.0, 1.0]]
    """
    angle = np.linalg.norm(rv, axis=1)
    k = np.where(angle > 1e-12, np.sin(angle / 2) / np.where(angle > 1e-12, angle, 1.0), 0.5)
    bw, (bx, by, bz) = np.cos(angle / 2), (rv * k[:, None]).T
    aw, ax, ay, az = q.T
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=1,
    )


def imu_tilt_bias(samples: pd.DataFrame, chord_s: float = TILT_CHORD_S) -> pd.DataFrame:
    """Per-run tilt of the IMU against the body, from the pose's displacement.

    See ``imu_tilt`` in the module docstring. The samples must be sorted by run and ``t``
    and have ``qw, qx, qy, qz, x, y, z``.

    Returns
    -------
    pandas.DataFrame
        One row per run: ``run``, ``roll``, ``pitch`` (rad; the rotation that takes the
        body frame to the IMU's), ``roll_se``, ``pitch_se`` (rad; ``inf`` when the run
        cannot tell the angle: too few chords, or for roll no sideways motion), ``n_chords``.

    Examples
    --------
    A robot walking forward on a 10 degree slope, then sideways, with an IMU pitched by
    0.5 degree and rolled by -0.3 degree:

    >>> from energy_planner.simulate.kinematics import imu_quaternion, quat_from_rotvec
    >>> from energy_planner.simulate.kinematics import quat_mul
    >>> t = np.arange(0, 40, 0.05)
    >>> a, gam = np.radians(10.0), np.where(t < 20, 0.0, -np.pi / 2)  # body x up, then left
    >>> s = 0.3 * np.minimum(t, 20)                  # forward, uphill
    >>> lat = 0.3 * np.maximum(t - 20, 0)            # then sideways up (body y points uphill)
    >>> x = (s + lat) * np.cos(a); z = (s + lat) * np.sin(a)
    >>> q = imu_quaternion(np.full(t.size, a), np.zeros(t.size), gam)
    >>> q = quat_mul(q, quat_from_rotvec(np.radians([[-0.3, 0.5, 0.0]])))
    >>> df = pd.DataFrame({"run": "a", "t": t, "qw": q[:, 0], "qx": q[:, 1], "qy": q[:, 2],
    ...                    "qz": q[:, 3], "x": x, "y": 0.0, "z": z})
    >>> est = imu_tilt_bias(df)
    >>> np.round(np.degrees(est[["roll", "pitch"]].to_numpy()), 3).tolist()
    [[-0.3, 0.5]]
    """
    code, names = _runs(samples)
    t = samples["t"].to_numpy(float)
    q = samples[["qw", "qx", "qy", "qz"]].to_numpy(float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    pos = samples[["x", "y", "z"]].to_numpy(float)
    first = np.flatnonzero(np.r_[True, code[1:] != code[:-1]])
    bounds = np.r_[first, len(code)]
    rows = []
    for r, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
        tt = t[a:b]
        dt = float(np.median(np.diff(tt))) if b - a > 1 else math.nan
        k = max(1, int(round(chord_s / dt))) if math.isfinite(dt) and dt > 0 else 1
        i0 = np.arange(a, b - k, k)
        i1, im = i0 + k, i0 + k // 2
        ok = np.isfinite(pos[i0]).all(1) & np.isfinite(pos[i1]).all(1) & np.isfinite(q[im]).all(1)
        i0, i1, im = i0[ok], i1[ok], im[ok]
        est = [0.0, 0.0]
        se = [math.inf, math.inf]
        if i0.size >= 5:
            # displacement in the IMU's frame: R(q)^T dp
            d = np.einsum("nji,nj->ni", _rotation(q[im]), pos[i1] - pos[i0])
            A = np.column_stack([-d[:, 1], d[:, 0]])  # dz_body = -e_r dy + e_p dx
            gram = A.T @ A
            for j in (0, 1):  # an angle the chords cannot tell is left out of the fit
                if gram[j, j] < 1e-6 * max(gram[1 - j, 1 - j], 1e-12):
                    A[:, j] = 0.0
            coef, *_ = np.linalg.lstsq(A, d[:, 2], rcond=None)
            dof = max(i0.size - 2, 1)
            s2 = float(np.sum((d[:, 2] - A @ coef) ** 2)) / dof
            cov = s2 * np.linalg.pinv(A.T @ A)
            for j in (0, 1):
                if np.any(A[:, j]):
                    est[j] = float(coef[j])
                    se[j] = float(np.sqrt(max(cov[j, j], 0.0)))
        rows.append(
            {
                "run": str(names[r]),
                "roll": est[0],
                "pitch": est[1],
                "roll_se": se[0],
                "pitch_se": se[1],
                "n_chords": int(i0.size),
            }
        )
    return pd.DataFrame(rows, columns=["run", "roll", "pitch", "roll_se", "pitch_se", "n_chords"])


def check_imu_tilt(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """IMU tilted against the body, against a pose with altitude (module docstring)."""
    if not {"x", "y", "z"} <= set(samples.columns):
        return (
            DataFinding(
                "imu_tilt",
                False,
                "not checked: the logs have no pose with altitude (x, y, z) to compare the "
                "IMU's orientation with",
            ),
            samples,
        )
    from scipy.special import chdtrc  # chi-squared sf (scipy.stats costs ~1 s to import)

    est = imu_tilt_bias(samples)
    lim = math.radians(MAX_TILT_SE_DEG)
    angles = []
    for c in ("roll", "pitch"):
        use = est[f"{c}_se"].to_numpy(float) <= lim
        est[f"{c}_used"] = use
        angles.append((est[c].to_numpy(float)[use], est[f"{c}_se"].to_numpy(float)[use]))
    e = np.concatenate([a for a, _ in angles])
    se = np.concatenate([s for _, s in angles])
    ev: dict[str, Any] = {
        "runs": int(len(est)),
        "pitch_estimated_runs": int(est["pitch_used"].sum()),
        "roll_estimated_runs": int(est["roll_used"].sum()),
    }
    if e.size == 0:
        return (
            DataFinding(
                "imu_tilt",
                False,
                "not checked: no run moves enough against the pose to tell the IMU's tilt",
                ev,
            ),
            samples,
        )
    stat = float(np.sum((e / np.maximum(se, 1e-12)) ** 2))
    pval = float(chdtrc(e.size, stat))
    rms_deg = float(np.degrees(np.sqrt(np.mean(e**2))))
    ev.update(
        {
            "rms_tilt_deg": rms_deg,
            "pitch_deg_median": float(np.degrees(np.median(angles[1][0])))
            if angles[1][0].size
            else math.nan,
            "median_se_deg": float(np.degrees(np.median(se))),
            "chi2": stat,
            "dof": int(e.size),
            "p_value": pval,
            "per_run_deg": {
                r: [round(math.degrees(a), 4), round(math.degrees(b), 4)]
                for r, a, b in zip(
                    est["run"][:20],
                    np.where(est["roll_used"], est["roll"], np.nan)[:20],
                    np.where(est["pitch_used"], est["pitch"], np.nan)[:20],
                    strict=True,
                )
            },
        }
    )
    if not (pval < DATA_ALPHA and rms_deg >= MIN_TILT_DEG):
        return (
            DataFinding(
                "imu_tilt",
                False,
                f"the IMU's orientation agrees with the pose (tilt {rms_deg:.3f} deg rms over "
                f"{e.size} estimates, p {pval:.2g}: not a finding)",
                ev,
            ),
            samples,
        )
    code, _ = _runs(samples)
    rv = np.zeros((len(est), 3))
    rv[:, 0] = -np.where(est["roll_used"], est["roll"], 0.0)
    rv[:, 1] = -np.where(est["pitch_used"], est["pitch"], 0.0)
    cols = ["qw", "qx", "qy", "qz"]
    q = _rotate_by(samples[cols].to_numpy(float), rv[code])
    fixed = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    fixed[cols] = np.where(q[:, :1] < 0, -q, q)
    return (
        DataFinding(
            "imu_tilt",
            True,
            f"the IMU is tilted against the body by {rms_deg:.2f} deg rms (per run, "
            f"against the pose's altitude; chi-square p {pval:.2g}): it shifts the slope "
            "and the heading the model sees; a sensor problem, not a physical effect: each "
            "run's orientation was rotated back by its estimate",
            ev,
            repaired=True,
        ),
        fixed,
    )


def _noise_sd(v: np.ndarray, code: np.ndarray) -> float:
    """Robust white-noise level of a per-sample signal from successive differences."""
    d = np.diff(v)[code[1:] == code[:-1]]
    d = d[np.isfinite(d)]
    return float(1.4826 * np.median(np.abs(d)) / math.sqrt(2)) if d.size else 0.0


#: Twist noise whose rectified mean, ``sd * sqrt(2 / pi)``, exceeds this (m/s or rad/s) is
#: a finding: ``abs(vy)`` of a forward run would then carry a spurious constant.
MAX_RECTIFIED = 0.002


def check_twist_noise(samples: pd.DataFrame) -> tuple[DataFinding, pd.DataFrame]:
    """White noise on the twist, which the model's ``abs`` and ``pos`` terms rectify.

    A forward run has ``vy = 0``; with noise of standard deviation ``sd`` on ``vy``, the
    lateral term ``abs(vy)`` reads ``sd * sqrt(2 / pi)`` on average: a spurious lateral
    cost in every forward window, which a constant (``idle_power``) then "explains". The
    noise level comes from successive differences; a finding when its rectified mean
    exceeds :data:`MAX_RECTIFIED`. Repair: a dead band of three standard deviations on each
    twist component (values within it are set to zero).
    """
    code, _ = _runs(samples)
    sds = {c: _noise_sd(samples[c].to_numpy(float), code) for c in ("vx", "vy", "wz")}
    rect = {c: sd * math.sqrt(2 / math.pi) for c, sd in sds.items()}
    ev = {"noise_sd": sds, "rectified_mean": rect}
    if max(rect.values()) <= MAX_RECTIFIED:
        return DataFinding("twist_noise", False, "twist noise is negligible", ev), samples
    fixed = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    for c, sd in sds.items():
        v = fixed[c].to_numpy(float)
        fixed[c] = np.where(np.abs(v) < 3 * sd, 0.0, v)
    worst = max(rect, key=rect.get)
    return (
        DataFinding(
            "twist_noise",
            True,
            f"the odometry twist is noisy (sd {sds['vx']:.3g}, {sds['vy']:.3g} m/s, "
            f"{sds['wz']:.3g} rad/s): rectified by abs()/pos() terms it reads as a motion "
            f"that is not there ({rect[worst]:.3g} on {worst}); a dead band of 3 sd was applied",
            ev,
            repaired=True,
        ),
        fixed,
    )


CHECKS = (
    check_current_sign,
    check_clock_offset,
    check_odometry_slip,
    check_odometry_scale,
    check_imu_tilt,
    check_twist_noise,
)


def check_data(
    samples: pd.DataFrame,
    repair: bool = True,
    accept: Callable[[pd.DataFrame, pd.DataFrame, DataFinding], bool] | None = None,
) -> tuple[list[DataFinding], pd.DataFrame]:
    """Run every data check on raw canonical samples; return results and repaired samples.

    The samples come back with the findings repaired (unchanged when ``repair`` is False).

    The current sign is checked first (power is needed by the clock check), the clock
    before the slip (the slip check does not use power), the slope-dependent slip before
    the constant scale (which its repair removes).

    Parameters
    ----------
    samples : pandas.DataFrame
        Raw canonical samples.
    repair : bool
        Apply the repairs of the findings.
    accept : callable, optional
        ``accept(before, after, finding) -> bool``, asked for every repair (the samples
        without and with it): a repair it refuses is not applied (``finding.repaired``
        False; ``accept`` records why in the finding). ``calibration.prepare_logs``
        passes the held-out check (a repair that raises the held-out error is refused).
    """
    s = samples.assign(run=samples["run"].astype(str))
    run = s["run"].to_numpy(dtype=object)
    t = s["t"].to_numpy(dtype=float)
    same = run[1:] == run[:-1]
    if np.all((run[1:] > run[:-1]) | (same & (t[1:] >= t[:-1]))):
        s = s.reset_index(drop=True)  # sorted already (load_logs sorts): no copy (memory)
    else:
        s = s.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    del run, t, same
    out = []
    cur = s
    for check in CHECKS:
        found, fixed = check(cur)
        if not repair:
            found.repaired = False
        elif found.repaired and (accept is None or accept(cur, fixed, found)):
            cur = fixed
        else:
            found.repaired = False
        out.append(found)
    return out, cur
