"""The one data pipeline of ``fit``, ``diagnose`` and ``discover``: checks, cleaning, windows.

Raw canonical samples go through

1. the data checks (:func:`energy_planner.measurements.datacheck.check_data`): sensor
   problems (current sign, clock offset between power and motion, odometry slip growing
   with slope, odometry scale, IMU tilt, twist noise), each reported as a *data finding*
   and, with ``repair=True`` (the default), corrected - but a repair is kept only if the
   held-out error does not rise (:func:`heldout_score` of a model on the windows
   without and with it; ``guard=True``; a repair that changes units, :data:`UNIT_REPAIRS`,
   by the held-out runs' energies predicted from the pose, :func:`energy_score`): a
   repair that costs accuracy is reported as rejected, with the two numbers;
2. cleaning (:func:`clean_logs`: :func:`~energy_planner.measurements.preprocess.preprocess`,
   paper IV-B, but the stops stay: the standing power is fitted on them);
3. windows (:func:`~energy_planner.measurements.windows.make_windows`).

Every command and Python verb that starts from logs calls :func:`prepare_logs`, so the
same logs give the same findings, repairs and windows whichever command reads them.

Examples
--------
>>> import numpy as np, pandas as pd
>>> t = np.arange(0, 8, 0.05)
>>> s = pd.DataFrame({"run": np.repeat(["a", "b"], len(t) // 2), "t": np.r_[t[:80], t[:80]],
...                   "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0, "vx": 0.3, "vy": 0.0,
...                   "wz": 0.0, "voltage": 50.0, "current": -4.0 + 0.1 * np.sin(7 * t)})
>>> p = prepare_logs(s)
>>> [f.name for f in p.found], p.repair, len(p.windows.table) > 0
(['current_sign'], True, True)
"""

from __future__ import annotations

import math
import threading
import warnings
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.measurements.datacheck import DataFinding, check_data
from energy_planner.measurements.preprocess import PreprocessParams

__all__ = [
    "CLEANING",
    "EnergyScore",
    "HeldOutScore",
    "MIN_STOP_S",
    "PreparedLogs",
    "clean_logs",
    "prepare_logs",
    "energy_score",
    "findings_text",
    "heldout_score",
    "pose_twist",
    "UNIT_REPAIRS",
    "WholeRuns",
    "altitude_from_map",
    "whole_runs",
    "yardstick_terms",
]


@dataclass
class PreparedLogs:
    """Raw samples after the data checks, cleaning and windows (:func:`prepare_logs`).

    Attributes
    ----------
    windows : Windows
        The windows every fit and diagnosis works on.
    findings : list of DataFinding
        Every data check's result (finding or not, with its evidence).
    repair : bool
        Whether the findings were corrected before cleaning.
    preprocess_report : PreprocessReport
        What cleaning removed, step by step.
    """

    windows: Any
    findings: list[DataFinding]
    repair: bool
    preprocess_report: Any

    @property
    def found(self) -> list[DataFinding]:
        """The checks that found a problem."""
        return [f for f in self.findings if f.finding]

    def findings_dicts(self) -> list[dict[str, Any]]:
        """Every check's result, JSON-ready (the ``data_findings`` of each command)."""
        return [f.to_dict() for f in self.findings]


#: Cleaning as the paper's IV-B, but no sample is discarded for a low speed there
#: (``min_speed`` and ``min_yaw_rate`` 0): :func:`clean_logs` drops the low-speed samples
#: that are not stops. The standing windows tell the standing power (``idle_power``)
#: from what the gait adds while walking (``gait_power``, ``calibration.fit.base_terms``);
#: without them the fit's constant is the walking one, and a robot standing is priced at
#: the power of a robot walking (+70 % on mission logs).
CLEANING = PreprocessParams(min_speed=0.0, min_yaw_rate=0.0)
#: A stretch of low-speed samples (below ``PreprocessParams().min_speed`` and
#: ``min_yaw_rate``, the paper's rule) lasting at least this long (s) is a stop and stays;
#: a shorter one is the end of a speed ramp (the gait starting or stopping), dropped.
MIN_STOP_S = 1.0


def clean_logs(samples: pd.DataFrame) -> tuple[pd.DataFrame, Any]:
    """Clean raw samples as every command does: paper IV-B, keeping the stops.

    :func:`~energy_planner.measurements.preprocess.preprocess` with :data:`CLEANING`, then
    the low-speed samples (the paper's rule, ``PreprocessParams()``) are dropped unless
    they belong to a stretch of at least :data:`MIN_STOP_S` within one gap-free segment
    (the step ``discard_speed_ramps`` of the report). A speed ramp passes the low speeds in
    a fraction of a second, with a power neither standing nor walking; a stop lasts.

    Returns
    -------
    clean : pandas.DataFrame
    report : PreprocessReport
        With the step ``discard_speed_ramps`` last.

    Examples
    --------
    >>> t = np.arange(0, 6, 0.1)  # a 1 s speed ramp from rest, a 2 s stop
    >>> vx = np.where((t > 2) & (t < 4), 0.0, np.minimum(t, 1.0) * 0.3)
    >>> s = pd.DataFrame({"run": "a", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
    ...     "vx": vx, "vy": 0.0, "wz": 0.0, "voltage": 50.0, "current": 4.0})
    >>> clean, rep = clean_logs(s)
    >>> rep.steps[-1].name, rep.steps[-1].n_removed, int((clean["speed"] < 0.05).sum())
    ('discard_speed_ramps', 3, 16)
    """
    from energy_planner.measurements.preprocess import StepRecord, preprocess, segment_slices

    clean, report = preprocess(samples, CLEANING)
    rule = PreprocessParams()
    low = (np.hypot(clean["vx"].to_numpy(float), clean["vy"].to_numpy(float)) < rule.min_speed) & (
        np.abs(clean["wz"].to_numpy(float)) < rule.min_yaw_rate
    )
    t = clean["t"].to_numpy(float)
    drop = _short_stretches(low, t, segment_slices(clean), MIN_STOP_S)
    reason = (
        f"speed < {rule.min_speed:g} m/s and |wz| < {rule.min_yaw_rate:g} rad/s for less "
        f"than {MIN_STOP_S:g} s (a speed ramp, not a stop)"
    )
    report.steps.append(
        StepRecord(
            "discard_speed_ramps",
            len(clean),
            int(len(clean) - drop.sum()),
            {reason: int(drop.sum())} if drop.any() else {},
            note=f"low-speed stretches of at least {MIN_STOP_S:g} s are stops, kept",
        )
    )
    return clean.loc[~drop].reset_index(drop=True), report


def _short_stretches(low: np.ndarray, t: np.ndarray, segments: Any, min_s: float) -> np.ndarray:
    """The samples of stretches of ``low`` lasting less than ``min_s`` within a segment.

    A stretch lasts from its first sample to the sample after its last (its own last
    sample at the end of its segment). Every segment's stretches at once: the stretch
    starts and ends are where ``low`` changes within a segment.
    """
    n = low.size
    drop = np.zeros(n, dtype=bool)
    if not n or not low.any():
        return drop
    first = np.zeros(n, dtype=bool)  # the first sample of each segment
    last = np.zeros(n, dtype=bool)  # and its last
    for sl in segments:
        if sl.stop > sl.start:
            first[sl.start] = True
            last[sl.stop - 1] = True
    prev = np.r_[False, low[:-1]] & ~first
    nxt = np.r_[low[1:], False] & ~last
    starts = np.flatnonzero(low & ~prev)
    stops = np.flatnonzero(low & ~nxt) + 1  # one past each stretch's last sample
    seg_end = np.flatnonzero(last)[np.searchsorted(np.flatnonzero(last), starts)]
    end = np.minimum(stops, seg_end)  # the stretch lasts until the next sample
    short = t[end] - t[starts] < min_s
    mark = np.zeros(n + 1, dtype=np.int64)
    np.add.at(mark, starts[short], 1)
    np.add.at(mark, stops[short], -1)
    drop[:] = np.cumsum(mark[:-1]) > 0
    return drop


#: A repair is refused when it raises the held-out error beyond noise: the pooled RMSE
#: rises and the runs are worse with it by a one-sided signed-rank test over runs at this
#: level (``stats.paired_run_test``, the test of the candidates).
REPAIR_ALPHA = 0.05


@dataclass(frozen=True)
class HeldOutScore:
    """Held-out window-power error of a model on samples (:func:`heldout_score`).

    Attributes
    ----------
    rmse_w : float
        Pooled held-out RMSE over the windows, W (NaN when it cannot be computed).
    run_mse : pandas.Series
        Mean squared held-out window error of every run, W^2, indexed by run.
    """

    rmse_w: float
    run_mse: pd.Series


def yardstick_terms(wd: Any) -> list[str]:
    """The model the repair guard scores by default: the base model and the channels.

    The base terms (:func:`energy_planner.calibration.fit.base_terms`), and for every extra channel
    of the logs a standing power and a force per metre: ``c`` and ``c * speed`` for a
    numeric channel with variance, ``speed * (c == 'v')`` for each value of a categorical
    one (2 to ``MAX_CATEGORIES`` values). A hidden effect on a channel (a payload, a
    ground) would otherwise dominate the base model's error and drown the repairs'
    differences; the same logs give the same yardstick in every command.
    """
    from energy_planner.calibration.fit import base_terms
    from energy_planner.calibration.windowdata import MAX_CATEGORIES

    terms = base_terms(wd)
    for ch in wd.numeric_extras:
        v = wd.samples[ch].to_numpy(dtype=float)
        v = v[np.isfinite(v)]
        if v.size and np.ptp(v) > 0:
            terms += [ch, f"{ch} * speed"]
    for ch in wd.categorical_extras:
        cats = sorted(wd.samples[ch].dropna().astype(str).unique().tolist())
        if 2 <= len(cats) <= MAX_CATEGORIES:
            terms += [f"speed * ({ch} == {v!r})" for v in cats]
    return terms


def heldout_score(
    samples: pd.DataFrame, *, window: float = 2.0, terms: Sequence[Any] | None = None
) -> HeldOutScore:
    """Held-out window-power error of a model's terms on raw samples cleaned and windowed.

    The yardstick of the repairs (:func:`prepare_logs`): the samples are cleaned
    (``preprocess``) and cut into windows as every command does, and the model ``terms``
    (default :func:`yardstick_terms`: the base model and the logs' channels) is scored
    by the one held-out evaluation (``WindowData.heldout``: 5 folds by run, seed 0, each fold
    fitting the terms its training windows identify, floored per sample). NaN (and no
    runs) when it cannot be computed: fewer than two runs, no window.
    """
    # the one held-out evaluation with each fold's identifiable terms is the diagnosis'
    # window view (WindowData.heldout, calibration.windowdata)
    return _heldout_score(samples, window, terms)


def _clean_windows(samples: pd.DataFrame, window: float) -> tuple[Any, Any, bool]:
    """``(windows, report, warned)``: :func:`clean_logs` then ``make_windows``.

    As :func:`prepare_logs` cleans and cuts the checked samples. The warnings of the
    two steps are recorded, not shown (``warned``: whether there were any); the cleaned
    copy is not held beside the windows (memory).
    """
    from energy_planner.measurements.windows import make_windows

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        clean, report = clean_logs(samples)
        windows = make_windows(clean, duration=window)
        del clean
    return windows, report, bool(caught)


def _heldout_score(
    samples: pd.DataFrame,
    window: float,
    terms: Sequence[Any] | None,
    cleaned: Callable[[], Any] | None = None,
) -> HeldOutScore:
    """:func:`heldout_score` computed.

    ``cleaned()``, when given, returns the samples' windows (:func:`_clean_windows`).
    """
    from energy_planner.calibration.windowdata import window_data
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.stats import fold_index

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the pipeline itself warns once, after
            windows = _clean_windows(samples, window)[0] if cleaned is None else cleaned()
            wd = window_data(windows.samples)
            del windows
        folds = fold_index(wd.runs, 5, 0)
        use = yardstick_terms(wd) if terms is None else terms
        names = [getattr(t, "formula", t) for t in use]
        h = wd.heldout(names, folds)
    except (EnergyPlannerError, ValueError):
        return HeldOutScore(math.nan, pd.Series(dtype=float))
    run_mse = pd.Series(h.residuals**2).groupby(np.asarray(wd.runs)).mean()
    return HeldOutScore(h.rmse, run_mse)


#: The data findings whose repair changes the units of the logs (the odometry's metre, the
#: power's sign, its clock) or what the odometry's speed means (the twist's dead band: the
#: noise that ``abs()`` and ``pos()`` terms rectify into motion is set to zero, a speed
#: that a path in map metres never has). Windows fitted and scored in the logs' own units
#: cannot see such an error (the coefficients absorb it: the dead band raises the window
#: error while the energies of paths lose a bias), so these repairs are judged by what
#: the model is for: the energy of a path in map metres (:func:`energy_score`).
UNIT_REPAIRS = frozenset(
    {"current_sign", "clock_offset", "odometry_slip", "odometry_scale", "twist_noise"}
)
#: Half-width of the central difference that turns the pose track into a velocity, s.
POSE_HALF_WIDTH_S = 0.5


def pose_twist(samples: pd.DataFrame) -> pd.DataFrame:
    """The samples with their twist taken from the pose track instead of the odometry.

    Per run (samples in time order within each run), the pose's horizontal velocity is a
    central difference over +-:data:`POSE_HALF_WIDTH_S` (``x, y`` interpolated in time),
    and the body twist ``vx, vy`` is the one whose horizontal projection through the IMU
    orientation it is (the inverse of the projection ``odometry_ratios`` compares with
    the pose: the body moves in its own x-y plane, so the ground speed on a slope is
    read, not the map speed); ``wz`` is the rate of the pose's ``yaw`` when the logs
    have it. ``speed``, ``ax``, ``ay`` follow. A twist in map metres whatever the
    odometry's scale, for :func:`energy_score`.

    Examples
    --------
    Level ground, the body turned 90 deg (facing +y), walking +y at 0.3 m/s while the
    odometry reads 5 % short:

    >>> t = np.arange(0, 10, 0.1)
    >>> c = np.sqrt(0.5)
    >>> s = pd.DataFrame({"run": "a", "t": t, "qw": c, "qx": 0.0, "qy": 0.0, "qz": c,
    ...                   "vx": 0.285, "vy": 0.0, "wz": 0.0, "x": 0.0, "y": 0.3 * t})
    >>> p = pose_twist(s)
    >>> round(float(p["vx"].mean()), 6), round(float(p["vy"].abs().max()), 6)
    (0.3, 0.0)
    """
    from energy_planner.measurements.datacheck import _rotate_xy
    from energy_planner.measurements.preprocess import segment_gradient

    out = samples.copy(deep=False)
    run = out["run"].astype(str).to_numpy()
    t = out["t"].to_numpy(float)
    h = POSE_HALF_WIDTH_S
    rate = {c: np.full(len(out), np.nan) for c in ("x", "y", "yaw") if c in out}
    starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
    bounds = list(zip(starts, np.r_[starts[1:], len(run)], strict=True))
    track = {c: out[c].to_numpy(float) for c in rate}  # read once, sliced per run
    for a, b in bounds:
        tt = t[a:b]
        lo, hi = np.maximum(tt - h, tt[0]), np.minimum(tt + h, tt[-1])
        span = hi - lo
        for c in rate:
            v = track[c][a:b]
            if c == "yaw":
                v = np.unwrap(v)
            ok = np.isfinite(v)
            if ok.sum() < 2:
                continue
            d = np.interp(hi, tt[ok], v[ok]) - np.interp(lo, tt[ok], v[ok])
            rate[c][a:b] = np.where(span > 0, d / np.where(span > 0, span, 1.0), 0.0)
    q = out[["qw", "qx", "qy", "qz"]].to_numpy(float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    r00, r10 = _rotate_xy(q, np.ones(len(q)), np.zeros(len(q)))
    r01, r11 = _rotate_xy(q, np.zeros(len(q)), np.ones(len(q)))
    det = r00 * r11 - r01 * r10
    wx, wy = rate["x"], rate["y"]
    out["vx"] = (r11 * wx - r01 * wy) / det
    out["vy"] = (r00 * wy - r10 * wx) / det
    if "yaw" in rate:
        out["wz"] = rate["yaw"]
    vel = {"vx": out["vx"].to_numpy(float), "vy": out["vy"].to_numpy(float)}
    out["speed"] = np.hypot(vel["vx"], vel["vy"])
    edges = np.r_[starts, len(run)]
    out["ax"], out["ay"] = (segment_gradient(vel[c], t, edges) for c in ("vx", "vy"))
    return out


@dataclass(frozen=True)
class EnergyScore:
    """Held-out run energies predicted from the pose track (:func:`energy_score`).

    Attributes
    ----------
    rel_error : pandas.Series
        Per held-out run, ``E_pred / E_meas - 1``: the energy predicted from the pose
        track (:func:`pose_twist`) by the fit that did not see the run, against the
        measured battery energy of the same windows; indexed by run.
    """

    rel_error: pd.Series

    @property
    def median_abs(self) -> float:
        """Median over runs of ``|E_pred / E_meas - 1|`` (NaN without runs)."""
        e = self.rel_error.abs().dropna()
        return float(e.median()) if len(e) else math.nan


def energy_score(
    samples: pd.DataFrame, *, window: float = 2.0, terms: Sequence[Any] | None = None
) -> EnergyScore | None:
    """Held-out error of run energies predicted from the map poses, on raw samples.

    The yardstick of the repairs that change units (:data:`UNIT_REPAIRS`): the samples
    are cleaned and windowed as every command does, the model ``terms`` (default
    :func:`yardstick_terms`) is fitted by fold on the windows as logged (5 folds by run,
    seed 0, the one held-out evaluation ``WindowData.heldout``), and each held-out run's
    energy is predicted from its pose track (:func:`pose_twist`: the twist in map
    metres; slope and heading from the IMU), floored per sample, a window's energy its
    mean power times its duration, against the measured energy of the same windows.

    Returns
    -------
    EnergyScore or None
        None when the samples have no pose ``x, y``; an empty score when it cannot be
        computed (fewer than two runs, no window). The last :data:`ENERGY_SCORE_CACHE`
        scores are kept by the content of their samples (a repair's "before" is the last
        repair's "after"; every command on the same logs scores the same states) and
        returned again as they are: read them, do not modify them.
    """
    return _kept_energy_score(samples, window, terms)


def _kept_energy_score(
    samples: pd.DataFrame,
    window: float,
    terms: Sequence[Any] | None,
    cleaned: Callable[[], Any] | None = None,
) -> EnergyScore | None:
    """:func:`energy_score`, kept by content.

    ``cleaned()``, when given, returns the samples' windows (:func:`_clean_windows`);
    it is asked only when the score is computed.
    """
    if not {"x", "y", "qw", "qx", "qy", "qz"} <= set(samples.columns):
        return None
    try:
        key = _content_key(samples, window, terms)
    except TypeError:  # a column pandas cannot hash (objects of no hashable kind)
        return _energy_score(samples, window, terms, cleaned)
    with _ENERGY_LOCK:
        if key in _ENERGY_SCORES:
            _ENERGY_SCORES.move_to_end(key)
            return _ENERGY_SCORES[key]
    out = _energy_score(samples, window, terms, cleaned)
    with _ENERGY_LOCK:
        _ENERGY_SCORES[key] = out
        while len(_ENERGY_SCORES) > ENERGY_SCORE_CACHE:
            _ENERGY_SCORES.popitem(last=False)
    return out


#: How many :func:`energy_score` results are kept by the content of their samples: each
#: command of a session on the same logs (fit, figures, diagnose, discover through the
#: Python API, or in one process) checks and repairs them the same way, and scores the
#: same states; a score is one number per run, the samples are not kept.
ENERGY_SCORE_CACHE = 32
_ENERGY_SCORES: OrderedDict[tuple, EnergyScore] = OrderedDict()
_ENERGY_LOCK = threading.Lock()


def _samples_digest(samples: pd.DataFrame) -> tuple[str, str, str]:
    """The samples as a key: their columns, their index and a digest of their values.

    The columns' names, types and categories; the index's type, dtype and length; a
    SHA-1 of pandas' per-row hashes (which read each number's bits). The one digest of
    samples of :func:`energy_score` (in memory) and :func:`prepare_logs` (cache folder).

    Raises
    ------
    TypeError, ValueError
        A column pandas cannot hash.
    """
    import hashlib

    rows = pd.util.hash_pandas_object(samples).to_numpy()
    kinds = tuple(
        (repr(c), str(d), tuple(map(repr, getattr(d, "categories", ()))))
        for c, d in samples.dtypes.items()
    )
    index = f"{type(samples.index).__name__}:{samples.index.dtype}:{len(samples)}"
    return repr(kinds), index, hashlib.sha1(rows.tobytes()).hexdigest()


def _content_key(samples: pd.DataFrame, window: float, terms: Sequence[Any] | None) -> tuple:
    """What :func:`energy_score` depends on, as a dictionary key.

    The samples (:func:`_samples_digest`), the window and the terms.
    """
    names = None if terms is None else tuple(str(getattr(t, "formula", t)) for t in terms)
    return (*_samples_digest(samples), float(window), names)


def _energy_score(
    samples: pd.DataFrame,
    window: float,
    terms: Sequence[Any] | None,
    cleaned: Callable[[], Any] | None = None,
) -> EnergyScore:
    """:func:`energy_score` computed (samples with a pose).

    ``cleaned()``, when given, returns the samples' windows (:func:`_clean_windows`).
    """
    from energy_planner.calibration.windowdata import WindowData, window_data
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.stats import fold_index

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the pipeline itself warns once, after
            windows = _clean_windows(samples, window)[0] if cleaned is None else cleaned()
            wd = window_data(windows)
            del windows
        folds = fold_index(wd.runs, 5, 0)
        use = yardstick_terms(wd) if terms is None else terms
        names = [getattr(t, "formula", t) for t in use]
        coef = wd.heldout_coef(names, folds)  # the held-out fits (WindowData.heldout)
        on_map = WindowData(
            pose_twist(wd.samples), wd.key, wd.table, wd.numeric_extras, wd.categorical_extras
        )
        X = on_map.sample_columns(names)
    except (EnergyPlannerError, ValueError):
        return EnergyScore(pd.Series(dtype=float))
    fold = folds[wd.key]
    p = np.maximum(np.einsum("ij,ij->i", X, coef[fold]), 0.0)
    p[~np.all(np.isfinite(X), axis=1)] = np.nan
    dur = wd.weights
    pred = pd.Series(wd.window_mean(p) * dur).groupby(wd.runs).sum(min_count=1)
    meas = pd.Series(wd.power * dur).groupby(wd.runs).sum(min_count=1)
    rel = (pred / meas.where(meas > 0) - 1.0).replace([np.inf, -np.inf], np.nan)
    return EnergyScore(rel)


#: Largest windows (their samples' bytes) the repair guard keeps for :func:`prepare_logs`
#: to take: kept, they are held through the scores that follow (the pose twist, the
#: design), which on a full campaign raised discover's peak memory by their size (1.21 ->
#: 1.30 GB; issue 21). Larger windows are cut again after the checks.
GUARD_WINDOWS_BYTES = 32 << 20


def _frame_bytes(frame: pd.DataFrame) -> int:
    """Bytes of a frame's columns (their buffers, not the objects they point to)."""
    return int(frame.memory_usage(index=True, deep=False).sum())


class _HeldOutGuard:
    """``check_data``'s ``accept``: a repair is kept unless it raises the held-out error.

    Raised means: the pooled held-out RMSE is higher with the repair and the runs are
    worse with it beyond noise (:data:`REPAIR_ALPHA`); a difference within noise keeps
    the repair, since the check's own test found the fault. The score of the samples as
    they stand is computed once per state (the last accepted repair's samples are the
    next check's "before"). So are its windows (:func:`_clean_windows`), which the scores
    start from and :func:`prepare_logs` cuts from the checked samples: the last state
    scored keeps its windows (:meth:`windows`) while it is the samples as they stand,
    if they are at most :data:`GUARD_WINDOWS_BYTES`.
    """

    def __init__(self, window: float, terms: Sequence[Any] | None) -> None:
        self.window, self.terms = window, terms
        self._before: tuple[pd.DataFrame, HeldOutScore] | None = None
        # (samples, windows, report) of the last state scored, if it is not let go
        self._windows: list[tuple[pd.DataFrame, Any, Any]] = []

    def windows(self, samples: pd.DataFrame) -> tuple[Any, Any] | None:
        """``(windows, report)`` of ``samples`` made for a score, or None.

        The same object's, made without a warning, as :func:`clean_logs` and
        ``make_windows`` make them for :func:`prepare_logs`.
        """
        for s, windows, report in self._windows:
            if s is samples:
                return windows, report
        return None

    def _cleaned(self, samples: pd.DataFrame) -> Callable[[], Any]:
        """``cleaned()`` of the scores: the windows of ``samples``, made once."""

        def make() -> Any:
            got = self.windows(samples)
            if got is not None:
                return got[0]
            self._windows = []  # another state's: let go before these are made (memory)
            windows, report, warned = _clean_windows(samples, self.window)
            # kept unless they warned (prepare_logs shows the warnings of its own
            # cleaning) or are large (held through the score: discover's peak memory)
            if not warned and _frame_bytes(windows.samples) <= GUARD_WINDOWS_BYTES:
                self._windows.append((samples, windows, report))
            return windows

        return make

    def _score(self, samples: pd.DataFrame) -> HeldOutScore:
        if self._before is not None and self._before[0] is samples:
            return self._before[1]
        return _heldout_score(samples, self.window, self.terms, self._cleaned(samples))

    def __call__(self, before: pd.DataFrame, after: pd.DataFrame, finding: DataFinding) -> bool:
        keep = self._judge(before, after, finding)
        now = after if keep else before  # the samples as they stand: their windows stay
        self._windows = [e for e in self._windows if e[0] is now]
        return keep

    def _judge(self, before: pd.DataFrame, after: pd.DataFrame, finding: DataFinding) -> bool:
        if finding.name in UNIT_REPAIRS:
            e0 = _kept_energy_score(before, self.window, self.terms, self._cleaned(before))
            if e0 is not None:
                e1 = _kept_energy_score(after, self.window, self.terms, self._cleaned(after))
                keep = self._by_energy(e0, e1, finding)
                if keep:
                    self._before = None  # the samples changed: scored afresh next time
                return keep
        return self._by_power(before, after, finding)

    def _by_energy(self, e0: EnergyScore, e1: EnergyScore, finding: DataFinding) -> bool:
        """A unit repair: kept unless the held-out run energies get worse with it."""
        from energy_planner.stats import paired_run_test

        both = e0.rel_error.dropna().index.intersection(e1.rel_error.dropna().index)
        a0, a1 = e0.median_abs, e1.median_abs
        _, p, n = paired_run_test(
            e1.rel_error[both].to_numpy(float), e0.rel_error[both].to_numpy(float),
            np.arange(len(both)),
        )  # fmt: skip
        keep = not (math.isfinite(a0) and math.isfinite(a1) and a1 > a0 and p < REPAIR_ALPHA)
        finding.evidence["heldout_check"] = {
            "yardstick": "run energy from the pose",
            "energy_error_without_repair": a0,
            "energy_error_with_repair": a1,
            "p_worse": p,
            "runs": n,
            "kept": keep,
        }
        if not keep:
            finding.summary += (
                f"; the repair was NOT applied: it raises the error of the held-out runs' "
                f"energies predicted from the pose from {100 * a0:.2f} % to {100 * a1:.2f} % "
                f"(median), worse in the runs beyond noise (signed-rank p {p:.2g} over {n} "
                "runs; a repair of units is kept only if the energy of the path in map "
                "metres does not get worse)"
            )
        return keep

    def _by_power(self, before: pd.DataFrame, after: pd.DataFrame, finding: DataFinding) -> bool:
        """Any other repair: kept unless the held-out window-power error rises with it."""
        from energy_planner.stats import paired_run_test

        s0 = self._score(before)
        s1 = _heldout_score(after, self.window, self.terms, self._cleaned(after))
        r0, r1 = s0.rmse_w, s1.rmse_w
        both = s0.run_mse.index.intersection(s1.run_mse.index)
        # one "window" per run: d_r is the run's mean squared error without minus with
        _, p, n = paired_run_test(
            np.sqrt(s1.run_mse[both].to_numpy()),
            np.sqrt(s0.run_mse[both].to_numpy()),
            np.arange(len(both)),
        )
        keep = not (math.isfinite(r0) and math.isfinite(r1) and r1 > r0 and p < REPAIR_ALPHA)
        finding.evidence["heldout_check"] = {
            "rmse_without_repair_w": r0,
            "rmse_with_repair_w": r1,
            "p_worse": p,
            "runs": n,
            "kept": keep,
        }
        if keep:
            self._before = (after, s1)
        else:
            self._before = (before, s0)
            finding.summary += (
                f"; the repair was NOT applied: it raises the model's held-out RMSE from "
                f"{r0:.3f} to {r1:.3f} W, worse in the runs beyond noise (signed-rank p "
                f"{p:.2g} over {n} runs; a repair is kept only if the held-out error does "
                "not rise)"
            )
        return keep


def prepare_logs(
    samples: pd.DataFrame,
    *,
    window: float = 2.0,
    repair: bool = True,
    guard: bool = True,
    guard_terms: Sequence[Any] | None = None,
    terrain: Any = None,
) -> PreparedLogs:
    """Run the data checks on raw samples, repair (optionally), clean and cut windows.

    Parameters
    ----------
    samples : pandas.DataFrame
        Raw canonical samples (``load_logs`` or a simulated campaign's ``logs``).
    window : float
        Window length, s.
    repair : bool
        Correct what the checks find before cleaning (they are reported either way).
    guard : bool
        Keep a repair only if the held-out error of ``guard_terms``
        (:func:`heldout_score`) does not rise with it (beyond noise:
        :data:`REPAIR_ALPHA`); a refused repair is reported (``repaired`` False, the
        numbers in ``evidence["heldout_check"]`` and the summary). False: every repair
        is applied.
    guard_terms : sequence, optional
        The model the guard scores (terms or formulas); default
        :func:`yardstick_terms` (the base model and the logs' channels), the same for
        ``fit``, ``diagnose`` and ``discover``.
    terrain : Terrain, optional
        The map the robot walked (the DEM of its poses ``x, y``, in the DEM's own CRS).
        When the logs hold a pose without altitude, ``z`` is read from the map under it
        (:func:`altitude_from_map`), so that the IMU's tilt can be checked against the
        pose (the ``imu_tilt`` check; without altitude it is not checked).

    Returns
    -------
    PreparedLogs

    Raises
    ------
    LogError
        Missing columns or a non-positive window (from cleaning and windows).

    Notes
    -----
    The result is kept in the project's cache folder
    (:mod:`energy_planner.measurements.stored`, by the samples' content and every
    argument) when it was prepared without a warning and without a ``terrain``: the next
    command on the same logs gets the same windows, findings and reports at once.
    """
    from energy_planner.measurements import stored

    key = _prepare_key(samples, window, repair, guard, guard_terms, terrain)
    hit = stored.read("prepare", key)
    if isinstance(hit, PreparedLogs):
        return hit
    with stored.warnings_shown() as caught:
        out = _prepare(samples, window, repair, guard, guard_terms, terrain)
    if not (caught or out.preprocess_report.dropped_runs or out.windows.dropped_runs):
        stored.keep("prepare", key, out)
    return out


#: The modules whose names (as the process holds them) the key of :func:`prepare_logs`
#: holds: what checks, repairs, cleans and cuts the samples.
_PREPARE_MODULES = (
    "energy_planner.calibration",
    "energy_planner.calibration._windows",
    "energy_planner.calibration.fit",
    "energy_planner.calibration.forces",
    "energy_planner.calibration.prepare",
    "energy_planner.calibration.windowdata",
    "energy_planner.measurements",
    "energy_planner.measurements._ema",
    "energy_planner.measurements.conventions",
    "energy_planner.measurements.datacheck",
    "energy_planner.measurements.imu",
    "energy_planner.measurements.poses",
    "energy_planner.measurements.preprocess",
    "energy_planner.measurements.schema",
    "energy_planner.measurements.windows",
    "energy_planner.model",
    "energy_planner.model.formula",
    "energy_planner.model.model",
    "energy_planner.model.terms",
    "energy_planner.stats",
    "energy_planner.stats.heldout",
    "energy_planner.stats.numerics",
    "energy_planner.stats.signedrank",
)


def _prepare_key(
    samples: Any,
    window: float,
    repair: bool,
    guard: bool,
    guard_terms: Sequence[Any] | None,
    terrain: Any,
) -> str | None:
    """The cache key of :func:`prepare_logs` (None: not kept).

    The samples (:func:`_samples_digest`) and every argument. Not kept: with a
    ``terrain`` (the result holds the map itself), or ``guard_terms`` other than
    formulas (text).
    """
    from energy_planner.measurements import stored

    if not stored.enabled() or terrain is not None or not isinstance(samples, pd.DataFrame):
        return None
    if guard_terms is not None and not all(isinstance(t, str) for t in guard_terms):
        return None
    try:
        columns, index, values = _samples_digest(samples)
    except (TypeError, ValueError):  # values pandas cannot hash
        return None
    parts = [
        columns,
        index,
        values,
        repr((type(window).__name__, window, repair, guard)),
        repr(None if guard_terms is None else tuple(guard_terms)),
    ]
    return stored.digest("prepare_logs", parts, _PREPARE_MODULES)


def _prepare(
    samples: pd.DataFrame,
    window: float,
    repair: bool,
    guard: bool,
    guard_terms: Sequence[Any] | None,
    terrain: Any,
) -> PreparedLogs:
    """:func:`prepare_logs` computed."""
    from energy_planner.measurements.windows import make_windows

    if terrain is not None:
        samples = altitude_from_map(samples, terrain)
    accept = _HeldOutGuard(window, guard_terms) if guard else None
    findings, fixed = check_data(samples, repair=repair, accept=accept)
    made = None if accept is None else accept.windows(fixed)  # the guard's, if it made them
    del accept
    if made is None:
        clean, report = clean_logs(fixed)
        windows = make_windows(clean, duration=window)
        del clean
    else:
        windows, report = made
    windows.whole_runs = whole_runs(fixed, windows, terrain)
    return PreparedLogs(windows, findings, repair, report)


#: Cleaning that drops no valid sample: the features of every sample of a run
#: (:func:`whole_runs`), computed as :data:`CLEANING` computes them.
KEEP_ALL = PreprocessParams(
    hampel_n_sigma=1e12, min_speed=0.0, min_yaw_rate=0.0, min_mech_ratio=0.0,
    min_power_w=-math.inf, max_power_w=math.inf,
)  # fmt: skip


@dataclass(frozen=True)
class WholeRuns:
    """Every run whole: its battery energy and the samples its windows leave out.

    A user asks for the energy of a whole run (a path, a mission); the windows hold only
    part of it (cleaning drops the speed ramps as the gait starts and stops, samples
    beyond the consistency bound, Hampel outliers, windows shorter than their minimum).
    With these, a held-out run's prediction is its windows' prediction plus the left-out
    samples priced by the same fold's coefficients, against the battery energy of every
    sample (:func:`energy_planner.calibration.cross_validate`, ``CrossValidation.whole``).

    Attributes
    ----------
    runs : pandas.DataFrame
        Indexed by run: ``measured_j`` (trapezoidal integral of ``voltage * current``
        over every valid sample, gaps not bridged:
        :func:`~energy_planner.measurements.windows.run_energies`), ``duration_s`` (its
        integrated time), ``window_s`` (the run's windows' durations summed) and
        ``rest_s`` (``duration_s - window_s``, at least 0: the time no window holds).
    rest : pandas.DataFrame
        The run's samples in no window, with the features cleaning computes (slope,
        speed, accelerations, channels) and ``_w``: each sample's share of its run's
        ``rest_s`` (its time step, scaled so that a run's ``_w`` sum to ``rest_s``; a
        window may span a short dropped stretch, whose time is then not counted twice).
    twist : str
        Where the rest's twist comes from: ``"pose"`` (:func:`pose_twist`: from the
        poses, in map metres) or ``"odometry"`` (logs without a pose ``x, y``).
    paths : dict or None
        With a map: per run the path its poses walked, as the energy of a logged path
        takes it (``follow.walked_path``, one pose every :data:`PATH_POSE_EVERY_S` s with
        its time, in the map's working CRS): ``xy``, ``yaw``, ``t`` and ``values`` (each
        other column's value over the run: the constant, else the mean or the most
        frequent). None without a map or a pose ``x, y, yaw``.
    terrain : Terrain or None
        The map of ``paths``.
    """

    runs: pd.DataFrame
    rest: pd.DataFrame
    twist: str
    paths: dict[str, dict[str, Any]] | None = None
    terrain: Any = None

    @property
    def priced_by(self) -> str:
        """How a held-out run whole is priced.

        ``"path"``: its logged poses over the map, as ``energy`` prices a logged path;
        ``"samples"``: its windows plus the left-out samples.
        """
        return "path" if self.paths and self.terrain is not None else "samples"


#: One pose every this many seconds of a run's log when it is priced as a path (as
#: ``follow.walked_path`` takes a logged path by default).
PATH_POSE_EVERY_S = 0.5


def _run_paths(samples: pd.DataFrame, terrain: Any) -> dict[str, dict[str, Any]] | None:
    """Per run, its logged poses as a path over the map (:attr:`WholeRuns.paths`)."""
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.measurements.poses import walked_path
    from energy_planner.measurements.schema import CANONICAL_COLUMNS

    if not {"x", "y", "yaw", "t"} <= set(samples.columns):
        return None
    skip = set(CANONICAL_COLUMNS) | {"x", "y", "z", "yaw", "segment"}
    extra = [c for c in samples.columns if c not in skip]
    out: dict[str, dict[str, Any]] = {}
    for run, g in samples.groupby(samples["run"].astype(str), sort=True):
        g = g.sort_values("t", kind="stable")
        try:
            wp = walked_path(g, every_s=PATH_POSE_EVERY_S)
            xy = np.column_stack(terrain.to_work(wp.xy[:, 0], wp.xy[:, 1]))
        except (EnergyPlannerError, ValueError, IndexError):
            continue
        if len(xy) < 2 or not np.all(np.isfinite(xy)):
            continue
        values: dict[str, Any] = {}
        for c in extra:
            v = g[c].dropna()
            if not len(v):
                continue
            if pd.api.types.is_numeric_dtype(v) and not pd.api.types.is_bool_dtype(v):
                values[c] = float(v.mean())
            else:
                values[c] = v.mode().iloc[0]
        out[str(run)] = {"xy": xy, "yaw": wp.yaw_rad, "t": wp.t, "values": values}
    return out or None


def whole_runs(samples: pd.DataFrame, windows: Any, terrain: Any = None) -> WholeRuns | None:
    """The runs of ``samples`` whole, beside the ``windows`` cut from them (:class:`WholeRuns`).

    ``samples``: the raw samples as repaired (what cleaning and windows start from). The
    samples are cleaned again with :data:`KEEP_ALL` (the same filters and features, no
    sample dropped but invalid ones), those in no window (matched by run and time) kept
    with their time step; with a pose ``x, y`` their twist is the pose's
    (:func:`pose_twist` over the whole run, then the left-out samples taken). With the
    ``terrain`` the robot walked and a pose ``x, y, yaw``, each run's logged path too
    (:attr:`WholeRuns.paths`).

    Returns
    -------
    WholeRuns or None
        None when the samples cannot be cleaned (no valid sample).

    Examples
    --------
    A 1 s stop-and-go ramp dropped by cleaning (:func:`clean_logs`) is in ``rest``:

    >>> t = np.arange(0, 12, 0.1)
    >>> vx = np.where((t > 5) & (t < 5.8), 0.0, 0.3)
    >>> s = pd.DataFrame({"run": "a", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
    ...     "vx": vx, "vy": 0.0, "wz": 0.0, "voltage": 50.0, "current": 4.0})
    >>> p = prepare_logs(s)
    >>> w = p.windows.whole_runs
    >>> w.twist, round(float(w.runs.loc["a", "measured_j"]), 6)
    ('odometry', 2380.0)
    >>> bool(w.runs.loc["a", "rest_s"] > 0), round(float(w.rest["_w"].sum()), 6) == round(
    ...     float(w.runs.loc["a", "rest_s"]), 6)
    (True, True)
    """
    from energy_planner.errors import LogError
    from energy_planner.measurements.preprocess import preprocess
    from energy_planner.measurements.schema import time_gaps
    from energy_planner.measurements.windows import run_energies

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            full, _ = preprocess(samples, KEEP_ALL)
    except LogError:
        return None
    energy = run_energies(full).set_index("run")
    tab = windows.table
    win_s = tab.groupby(tab["run"].astype(str))["duration"].sum()
    runs = pd.DataFrame(
        {"measured_j": energy["measured_j"], "duration_s": energy["duration_s"]}
    ).astype(float)
    runs["window_s"] = win_s.reindex(runs.index).fillna(0.0).astype(float)
    runs["rest_s"] = (runs["duration_s"] - runs["window_s"]).clip(lower=0.0)
    twist = "odometry"
    if {"x", "y"} <= set(full.columns) and np.isfinite(full[["x", "y"]].to_numpy(float)).any():
        posed = pose_twist(full)
        ok = np.isfinite(posed[["vx", "vy"]].to_numpy(float)).all(axis=1)
        for c in ("vx", "vy", "wz", "speed", "ax", "ay"):
            full[c] = np.where(ok & np.isfinite(posed[c].to_numpy(float)),
                               posed[c].to_numpy(float), full[c].to_numpy(float))  # fmt: skip
        twist = "pose"
    run = full["run"].astype(str).to_numpy()
    t = full["t"].to_numpy(float)
    step = np.r_[np.diff(t), 0.0]
    brk = np.r_[(run[1:] != run[:-1]) | time_gaps(run, t).step, True]
    step[brk] = 0.0
    inside = pd.MultiIndex.from_arrays(
        [windows.samples["run"].astype(str).to_numpy(), windows.samples["t"].to_numpy(float)]
    )
    rest_mask = ~pd.MultiIndex.from_arrays([run, t]).isin(inside)
    rest = full.loc[rest_mask].reset_index(drop=True)
    dt = pd.Series(step[rest_mask])
    tot = dt.groupby(rest["run"].to_numpy()).transform("sum").to_numpy(float)
    want = runs["rest_s"].reindex(rest["run"].to_numpy()).to_numpy(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        rest["_w"] = np.where(tot > 0, dt.to_numpy(float) * want / tot, 0.0)
    paths = None if terrain is None else _run_paths(samples, terrain)
    return WholeRuns(runs, rest, twist, paths, terrain if paths else None)


def altitude_from_map(samples: pd.DataFrame, terrain: Any) -> pd.DataFrame:
    """The samples with the altitude ``z`` of the map under each pose ``x, y``.

    Samples that already hold ``z``, or no pose, are returned as they are. The pose is in
    the map's own CRS (``terrain.source_crs``); a pose off the map gets NaN (the
    ``imu_tilt`` check leaves its chords out).

    Parameters
    ----------
    samples : pandas.DataFrame
        Canonical samples.
    terrain : Terrain
        The map (:func:`energy_planner.open_terrain`).

    Returns
    -------
    pandas.DataFrame

    Examples
    --------
    >>> import energy_planner as ep
    >>> hill = ep.open_terrain("hill")
    >>> x0, y0 = hill.source_bounds[0] + 50.0, hill.source_bounds[1] + 50.0
    >>> s = pd.DataFrame({"x": [x0], "y": [y0]})
    >>> z = altitude_from_map(s, hill)["z"].iloc[0]
    >>> bool(z == hill.sample(*hill.to_work(x0, y0)).elevation)
    True
    """
    if "z" in samples.columns or not {"x", "y"} <= set(samples.columns):
        return samples
    x = samples["x"].to_numpy(float)
    y = samples["y"].to_numpy(float)
    ok = np.isfinite(x) & np.isfinite(y)
    z = np.full(len(samples), np.nan)
    if ok.any():
        wx, wy = terrain.to_work(x[ok], y[ok])
        z[ok] = np.asarray(terrain.sample(wx, wy).elevation, dtype=float)
    return samples.assign(z=z)


def findings_text(findings: list[dict[str, Any]] | list[DataFinding]) -> list[str]:
    """Lines for a person: each data finding and whether it was repaired (none: one line)."""
    rows = [f if isinstance(f, dict) else f.to_dict() for f in findings]
    found = [f for f in rows if f["finding"]]
    if not found:
        return [f"data checks: no sensor problem found ({len(rows)} checks)"]
    lines = ["data findings (sensor problems, not physical effects):"]
    for f in found:
        done = "repaired" if f["repaired"] else "not repaired"
        lines.append(f"  {f['name']} [{done}]: {f['summary']}")
    return lines
