"""The calibration's domain: which part of a path lies outside it, and plans kept inside.

A fitted model records the ranges its calibration windows saw
(:func:`energy_planner.calibration.fit.calibration_domain`, ``metadata.fit.domain``):
slope, relative heading per gait, walking speed, turning rate and the values of each
channel it reads; and the range of its runs' predicted mean power
(:func:`energy_planner.calibration.fit.run_power_range`), against which a path's
predicted mean power is checked: each quantity may lie inside its range while their
combination (heavy and steep uphill) lies beyond every run the fit saw.
:func:`domain_report` gives the share of a path's duration outside each of them, and by
how far it lies beyond the numeric ranges (its ``excess``: the input of the calibrated
widening of :func:`energy_planner.uncertainty.predict_interval`);
:func:`path_domain` does it for a priced path over a terrain, sampling the slope and the
raster channels along every motion at the energy integration's sub-steps, so that a share
is counted per metre walked, not per segment. :func:`stay_in_domain` turns the domain into
a planning request that keeps a plan inside it as far as the planner's limits can.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from energy_planner.errors import EnergyPlannerError

if TYPE_CHECKING:  # pandas is imported on use: `energy` prices paths without it
    import pandas as pd

__all__ = [
    "QUANTITIES",
    "SLOPED_DEG",
    "DomainError",
    "domain_of",
    "gait_speed_ranges",
    "speed_range",
    "domain_report",
    "motion_segments",
    "path_channel_values",
    "path_domain",
    "motion_gaits",
    "motion_samples",
    "path_samples",
    "report_against",
    "segment_terms",
    "stay_in_domain",
    "window_segments",
]

#: Below this slope (deg) the relative heading is not defined well enough to record or
#: check (on level ground every heading is the same ground).
SLOPED_DEG = 3.0
#: Slack on a recorded relative-heading range, deg.
HEADING_SLACK_DEG = 2.0
#: The quantities whose shares :func:`domain_report` gives (channels as ``channel NAME``).
QUANTITIES = ("slope", "gait", "relative_heading", "speed", "turning_rate")
#: Units of the quantities whose distance beyond their range is measured (``excess``);
#: numeric channels are measured in their own unit.
EXCESS_UNITS = {"slope": "deg", "speed": "m/s", "mean_power": "W"}
#: The path's predicted mean power (energy over duration) against the calibration runs'
#: (``metadata.fit.domain.mean_power_w``): a combination of quantities each inside its
#: range (heavy AND steep uphill; light, level or downhill and slow) can lie beyond every
#: run the model and its error model saw. Its error growth is never measured: the
#: interval widens by the assumed factor and no battery decision is given
#: (:meth:`energy_planner.uncertainty.ErrorModel.outside`).
MEAN_POWER = "mean_power"
#: What runs at a mean power beyond the calibration's take, by side.
POWER_HOW = {"above": "heavier loads, steeper climbs, faster",
              "below": "lighter loads, level ground or downhill, slower"}  # fmt: skip


class DomainError(EnergyPlannerError, ValueError):
    """A model records no calibration domain where one is needed."""


def domain_of(model: Any) -> dict[str, Any] | None:
    """The ``metadata.fit.domain`` a model records, or None."""
    return ((getattr(model, "metadata", None) or {}).get("fit") or {}).get("domain") or None


def speed_range(model: Any) -> tuple[float, float] | None:
    """The walking speeds a model's calibration covers, ``(low, high)`` in m/s, or None.

    The slowest and fastest walking window of the fit (``metadata.fit.domain.speed_m_s``):
    a plan that walks outside it is outside the domain (its interval widens, and
    ``stay_in_domain`` clamps its speed into it). None for a model that records no domain
    or no walking.

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> m = EnergyModel(metadata={"fit": {"domain": {"speed_m_s": [0.15, 1.2]}}})
    >>> speed_range(m), speed_range(EnergyModel())
    ((0.15, 1.2), None)
    """
    dom = domain_of(model) or {}
    rng = dom.get("speed_m_s")
    return (float(rng[0]), float(rng[1])) if rng else None


def gait_speed_ranges(model: Any) -> dict[str, tuple[float, float]]:
    """Per gait of the ``gait`` channel, the speeds the calibration walked it at (m/s).

    Empty for a model that does not read a gait channel. A gait is priced only within its
    range: the controller chose it there, and the logs say nothing of it elsewhere.

    >>> from energy_planner.model import EnergyModel
    >>> dom = {"gait_speed_m_s": {"walk": [0.1, 0.5], "trot": [0.5, 1.2]}}
    >>> gait_speed_ranges(EnergyModel(metadata={"fit": {"domain": dom}}))
    {'walk': (0.1, 0.5), 'trot': (0.5, 1.2)}
    """
    dom = domain_of(model) or {}
    return {g: (float(r[0]), float(r[1])) for g, r in (dom.get("gait_speed_m_s") or {}).items()}


def _segment_gaits(segments: Any, poses: Any) -> np.ndarray:
    """Motion class of each segment: forward, backward, lateral or turning (in place).

    A ``gait`` column of ``segments`` is taken as it is. Otherwise from the poses (one
    per segment end) the direction of travel relative to the body yaw: within 45 deg of
    it forward, of its reverse backward, else lateral; a segment that does not move but
    turns is turning. Without poses matching the segments (the robot faced along its
    path) every moving segment is forward.
    """
    if "gait" in segments:
        return np.asarray(segments["gait"], dtype=object)
    dist = np.asarray(segments["distance_m"], dtype=float)
    turn = np.asarray(segments["turn_deg"], dtype=float)
    p = None if poses is None else np.asarray(poses, dtype=float)
    if p is None or p.ndim != 2 or p.shape[0] != dist.size + 1 or p.shape[1] < 3:
        return motion_gaits(dist, turn)
    return motion_gaits(dist, turn, p[:-1], p[1:])


def motion_gaits(dist: Any, turn_deg: Any, a: Any = None, b: Any = None) -> np.ndarray:
    """Motion class of each motion from pose ``a`` to pose ``b`` (``x, y, yaw`` rows).

    Forward, backward or lateral by the direction of travel relative to the body yaw at
    ``a`` (within 45 deg of it, of its reverse, else); ``turning`` a motion that does not
    move but turns; ``none`` neither. Without poses every moving motion is forward.

    >>> motion_gaits([1.0, 0.0, 1.0], [0.0, 30.0, 0.0],
    ...              [[0, 0, 0], [1, 0, 0], [1, 0, 0.5]], [[1, 0, 0], [1, 0, 0.5], [1, 1, 0.5]])
    array(['forward', 'turning', 'lateral'], dtype=object)
    """
    dist = np.asarray(dist, dtype=float)
    turn = np.abs(np.asarray(turn_deg, dtype=float))
    out = np.where(dist > 1e-9, "forward", np.where(turn > 0, "turning", "none")).astype(object)
    if a is None or b is None:
        return out
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    d = b[:, :2] - a[:, :2]
    rel = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - a[:, 2])))
    moving = dist > 1e-9
    lateral = np.abs(np.abs(rel) - np.pi / 2) < np.pi / 4
    out[moving & (np.abs(rel) > 3 * np.pi / 4)] = "backward"
    out[moving & lateral] = "lateral"
    return out


def _channel_outside(seen: Any, values: np.ndarray) -> np.ndarray:
    """Per value: outside the recorded range (numeric) or not among the categories."""
    if _categorical(seen):
        return np.array([v is not None and str(v) not in seen for v in values], dtype=bool)
    f = _numbers(values)
    return np.isfinite(f) & ((f < seen[0]) | (f > seen[1]))


def _categorical(seen: Any) -> bool:
    return isinstance(seen, list) and bool(seen) and isinstance(seen[0], str)


def _numbers(values: Any) -> np.ndarray:
    v = np.atleast_1d(np.asarray(values))
    if v.dtype.kind in "fiub":  # already numbers (a raster's samples)
        return v.astype(float)
    v = v.astype(object)
    return np.array([np.nan if x is None or isinstance(x, str) else float(x) for x in v])


def _beyond(lo: float, hi: float, values: Any) -> np.ndarray:
    """Distance of each value beyond ``[lo, hi]`` (0 inside, NaN-safe), in its unit."""
    f = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        d = np.maximum(np.maximum(lo - f, f - hi), 0.0)
    return np.where(np.isfinite(d), d, 0.0)


@dataclasses.dataclass
class _Flat:
    """Samples of ``n`` segments as one array: ``values[k]`` belongs to segment ``owner[k]``.

    ``owner`` is non-decreasing; ``weight`` (or None: plain means) weighs each sample.
    """

    values: np.ndarray
    owner: np.ndarray
    n: int
    weight: np.ndarray | None = None

    @classmethod
    def of(cls, per_seg: Any, weights: Any = None, n: int | None = None) -> _Flat:
        """From one value or one array of samples per segment (and the same of weights)."""
        if isinstance(per_seg, cls):
            return per_seg
        if isinstance(per_seg, np.ndarray) and per_seg.ndim == 1:  # one value each
            return cls(per_seg, np.arange(per_seg.size), per_seg.size if n is None else n)
        parts = [np.atleast_1d(np.asarray(v)) for v in per_seg]
        sizes = np.array([p.size for p in parts], dtype=np.int64)
        n = len(parts) if n is None else n
        kinds = {p.dtype.kind for p in parts if p.size}
        dtype = float if kinds <= set("fiub") else object
        vals = np.concatenate([p.astype(dtype) for p in parts]) if parts else np.zeros(0)
        owner = np.repeat(np.arange(len(parts)), sizes)
        w = None
        if weights is not None:
            ws = [np.atleast_1d(np.asarray(x, dtype=float)) for x in weights]
            same = len(ws) == len(parts)
            if same and all(x.size == p.size for x, p in zip(ws, parts, strict=True)):
                w = np.concatenate(ws) if ws else np.zeros(0)
        return cls(vals, owner, n, w)

    def mean(self, fn: Any) -> np.ndarray:
        """Per segment the weighted mean of ``fn(samples)``.

        A plain mean where the segment's weights sum to 0 or none are given; 0 for a
        segment without samples.
        """
        x = np.asarray(fn(self.values), dtype=float)
        cnt = np.bincount(self.owner, minlength=self.n).astype(float)
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.where(cnt > 0, np.bincount(self.owner, x, self.n) / cnt, 0.0)
            if self.weight is not None:
                sw = np.bincount(self.owner, self.weight, self.n)
                swx = np.bincount(self.owner, self.weight * x, self.n)
                out = np.where(sw > 0, swx / np.where(sw > 0, sw, 1.0), out)
        return out

    def peak(self, fn: Any) -> np.ndarray:
        """Per segment the largest of ``fn(samples)`` (0 without samples)."""
        x = np.asarray(fn(self.values), dtype=float)
        out = np.zeros(self.n)
        if x.size:
            cut = np.r_[0, np.flatnonzero(np.diff(self.owner)) + 1]
            out[self.owner[cut]] = np.maximum.reduceat(x, cut)
        return out


@dataclasses.dataclass
class SegmentTerms:
    """What :func:`report_against` sums over a path's segments, per segment.

    A path's report is :meth:`report` of the sums of these columns over its segments, so
    that the report of every path of a tree of motions (a reach map's least-energy paths)
    is the prefix sums of its motions' columns along the tree
    (:func:`energy_planner.planning.reach.reach`), the same numbers as
    :func:`report_against` of each path.

    Attributes
    ----------
    reasons : dict
        Reason -> ``(quantity, has an excess)``, in the report's order (the calibration
        runs' mean power, a whole-path check, as ``MEAN_POWER`` at its place).
    cols : dict
        Additive per-segment columns: ``duration_s``, ``distance_m``, ``energy_j`` (when
        the segments carry it), ``any_s`` / ``any_m`` (seconds and metres outside some
        range), ``("q", quantity)`` seconds outside it, ``("why", reason)`` seconds
        outside for that reason, ``("hit", reason)`` its share of the segment,
        ``("exc", reason)`` seconds times the distance beyond the range.
    peaks : dict
        Quantity -> per segment the largest distance of a sample beyond its range.
    """

    reasons: dict[str, tuple[str, bool]]
    cols: dict[Any, np.ndarray]
    peaks: dict[str, np.ndarray]

    def report(self, dom: Mapping[str, Any], sums: Mapping[Any, Any],
               peaks: Mapping[str, Any]) -> dict[str, Any]:  # fmt: skip
        """The report of a path (or of many: arrays) from its columns' sums and peaks.

        Arrays of sums give arrays in the report (one value per path; the reasons of the
        mean power then read ``mean power above ...`` without the path's own power).
        """
        total = np.asarray(sums["duration_s"], dtype=float)
        safe = np.where(total > 0, total, np.inf)
        any_s, any_m = np.asarray(sums["any_s"], float), np.asarray(sums["any_m"], float)
        shares: dict[str, Any] = {q: np.zeros(total.shape) for q in QUANTITIES}
        reasons: dict[str, Any] = {}
        excess: dict[str, Any] = {}
        max_excess: dict[str, Any] = {}
        power = None
        rng = dom.get("mean_power_w")
        if rng and "energy_j" in sums:
            p = np.asarray(sums["energy_j"], float) / safe
            lo, hi = float(rng[0]), float(rng[1])
            with np.errstate(invalid="ignore"):
                above, below = p > hi, p < lo
            power = (p, above, below, np.where(above, p - hi, np.where(below, lo - p, 0.0)))
            out_p = above | below
            any_s = np.where(out_p, total, any_s)
            any_m = np.where(out_p, np.asarray(sums["distance_m"], float), any_m)
        for why, (q, has_exc) in self.reasons.items():
            if q == MEAN_POWER:
                if power is None:
                    continue
                p, above, below, gap = power
                shares[MEAN_POWER] = (above | below).astype(float)
                if (above | below).any():
                    excess[MEAN_POWER] = gap
                    max_excess[MEAN_POWER] = gap
                for side, m in (("above", above), ("below", below)):
                    if m.any():
                        reasons[f"mean power {side} every calibration run's ({lo:.0f}-"
                                f"{hi:.0f} W): log runs at that power ({POWER_HOW[side]})"
                                ] = m.astype(float)  # fmt: skip
                continue
            shares[q] = np.asarray(sums[("q", q)], float) / safe
            if has_exc:
                e = np.asarray(sums[("exc", why)], float) / safe
                excess[q] = np.maximum(excess[q], e) if q in excess else e
                pk = np.asarray(peaks[q], float)
                max_excess[q] = np.maximum(max_excess[q], pk) if q in max_excess else pk
            hit = np.asarray(sums[("hit", why)], float) > 0
            if hit.any():
                reasons[why] = np.where(hit, np.asarray(sums[("why", why)], float) / safe, np.nan)
        out = {
            "outside_share": any_s / safe,
            "outside_m": any_m,
            "reasons": reasons,
            "shares": shares,
            "excess": excess,
            "max_excess": max_excess,
            "domain": dict(dom),
        }
        if power is not None:
            out["mean_power_w"] = power[0]
        return out


def segment_terms(
    dom: Mapping[str, Any],
    segments: Any,
    constants: Mapping[str, Any] | None = None,
    gaits: Any = None,
    channel_values: Mapping[str, Any] | None = None,
    along: Mapping[str, Any] | None = None,
) -> SegmentTerms:
    """Per segment, the columns of :func:`report_against` (:class:`SegmentTerms`).

    ``gaits``: each segment's motion class (:func:`motion_gaits`); ``along``: as
    :func:`report_against`, or its samples flat (``owner``: the segment of each sample,
    non-decreasing; ``weight``, ``slope_deg`` and each raster channel one array).
    """
    dur = np.asarray(segments["duration_s"], dtype=float)
    dist = np.asarray(segments["distance_m"], dtype=float)
    turn = np.radians(np.abs(np.asarray(segments["turn_deg"], dtype=float)))
    n = dur.size
    with np.errstate(invalid="ignore", divide="ignore"):
        safe = np.where(dur > 0, dur, np.inf)
        speed, rate = dist / safe, turn / safe
    along = dict(along or {})
    owner = along.pop("owner", None)

    def samples(name: str) -> _Flat:
        if owner is not None:
            return _Flat(np.asarray(along[name]), np.asarray(owner), n, along.get("weight"))
        return _Flat.of(along[name], along.get("weight"), n)

    # reason -> (quantity, share of each segment outside, its excess per segment or None,
    # the largest excess of a sample per segment or None)
    masks: dict[str, tuple[str, Any, Any, Any]] = {}
    top = float(dom["max_slope_deg"])
    if "slope_deg" in along:
        sl = samples("slope_deg")
        s_out = sl.mean(lambda v: v > top)
        s_exc = sl.mean(lambda v: _beyond(-np.inf, top, v))
        peak = sl.peak(lambda v: _beyond(-np.inf, top, v))
    else:
        slope = np.asarray(segments["max_slope_deg"], dtype=float)
        s_out = (slope > top).astype(float)
        s_exc = peak = _beyond(-np.inf, top, slope)
    masks[f"slope above {top:g} deg"] = ("slope", s_out, s_exc, peak)
    if dom.get("speed_m_s"):
        lo, hi = dom["speed_m_s"]
        walking = speed > 0.05
        exc = np.where(walking, _beyond(lo, hi, speed), 0.0)
        masks[f"speed outside {lo:g}-{hi:g} m/s"] = (
            "speed", (walking & ((speed < lo) | (speed > hi))).astype(float), exc, exc,
        )  # fmt: skip
    masks[f"turning faster than {dom['max_turn_rate_rad_s']:g} rad/s"] = (
        "turning_rate", (rate > dom["max_turn_rate_rad_s"] * 1.05).astype(float), None, None
    )  # fmt: skip
    gaits = (np.asarray(gaits, dtype=object) if gaits is not None
             else motion_gaits(dist, segments["turn_deg"]))  # fmt: skip
    recorded = dom.get("gaits") or {}
    for g in ("forward", "backward", "lateral", "turning"):
        if g not in recorded:
            masks[f"{g} motion, absent from the calibration"] = (
                "gait", (gaits == g).astype(float), None, None
            )  # fmt: skip
    if "mean_rel_heading_deg" in segments:
        gamma = np.abs(np.asarray(segments["mean_rel_heading_deg"], dtype=float))
        mean_slope = np.asarray(segments.get("mean_slope_deg", segments["max_slope_deg"]), float)
        sloped = mean_slope > SLOPED_DEG
        for g, rec in recorded.items():
            rng = rec.get("rel_heading_deg") if isinstance(rec, Mapping) else None
            if not rng or g == "turning":
                continue
            lo, hi = rng[0] - HEADING_SLACK_DEG, rng[1] + HEADING_SLACK_DEG
            out = (gaits == g) & sloped & ((gamma < lo) | (gamma > hi))
            masks[f"{g} at relative heading outside {rng[0]:g}-{rng[1]:g} deg"] = (
                "relative_heading", out.astype(float), None, None
            )  # fmt: skip
    masks[MEAN_POWER] = (MEAN_POWER, None, None, None)  # a whole-path check, at its place
    seen_ch = dom.get("channels") or {}
    per_seg: dict[str, Any] = dict(channel_values or {})
    for c in along:
        if c not in ("weight", "slope_deg"):
            per_seg[c] = None  # sampled along the segments
    constants = dict(constants or {})
    for c, v in constants.items():  # one value for every segment
        number = isinstance(v, int | float) and not isinstance(v, bool)
        per_seg.setdefault(c, np.full(n, v, dtype=float if number else object))
    for c, vals in per_seg.items():
        seen = seen_ch.get(c)
        if seen is None:
            continue
        if vals is None:
            fl = samples(c)
        elif len(vals) != n:
            continue
        else:
            fl = _Flat.of(vals, None, n)
        out = fl.mean(lambda v, seen=seen: _channel_outside(seen, v))
        exc = pk = None
        if not _categorical(seen):
            exc = fl.mean(lambda v, seen=seen: _beyond(seen[0], seen[1], _numbers(v)))
            pk = fl.peak(lambda v, seen=seen: _beyond(seen[0], seen[1], _numbers(v)))
        what = f"{c} outside the logs' {seen}"
        if c in constants and c not in (channel_values or {}) and c not in along:
            what = f"{c} = {constants[c]} outside the logs' {seen}"
        masks[what] = (f"channel {c}", out, exc, pk)
    # a mask is the share of each segment outside (0 or 1, or the share of its metres);
    # the share outside several ranges is at least the largest of them
    any_out = np.zeros(n)
    by_q: dict[str, np.ndarray] = {}
    cols: dict[Any, np.ndarray] = {"duration_s": dur, "distance_m": dist}
    if "energy_j" in segments:
        e = np.asarray(segments["energy_j"], dtype=float)
        if e.size == n and np.all(np.isfinite(e)):
            cols["energy_j"] = e
    peaks: dict[str, np.ndarray] = {}
    reasons: dict[str, tuple[str, bool]] = {}
    for why, (q, m, exc, pk) in masks.items():
        reasons[why] = (q, exc is not None)
        if m is None:
            continue
        m = np.asarray(m, dtype=float)
        by_q[q] = np.maximum(by_q.get(q, np.zeros(n)), m)
        any_out = np.maximum(any_out, m)
        cols[("why", why)] = dur * m
        cols[("hit", why)] = m
        if exc is not None:
            cols[("exc", why)] = dur * np.asarray(exc, dtype=float)
            peaks[q] = np.maximum(peaks.get(q, np.zeros(n)), np.asarray(pk, dtype=float))
    for q, m in by_q.items():
        cols[("q", q)] = dur * m
    cols["any_s"], cols["any_m"] = dur * any_out, dist * any_out
    return SegmentTerms(reasons, cols, peaks)


def report_against(
    dom: Mapping[str, Any],
    segments: Any,
    constants: Mapping[str, Any] | None = None,
    poses: Any = None,
    channel_values: Mapping[str, Any] | None = None,
    along: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """:func:`domain_report` against a domain dict (the core; see there).

    ``along`` (:func:`path_samples`): per segment the samples of the slope (``slope_deg``)
    and of the raster channels along it, with their ``weight`` (metres walked): the share
    of a segment outside a range is the share of its metres outside, and its excess the
    mean distance beyond the range over those metres. Without it a segment is outside by
    its ``max_slope_deg`` (a calibration window: its mean slope). The columns of each
    segment are :func:`segment_terms`, summed over the path (:meth:`SegmentTerms.report`).
    """
    dur = np.asarray(segments["duration_s"], dtype=float)
    if float(dur.sum()) <= 0:
        return _report_of_no_time(dom)
    terms = segment_terms(dom, segments, constants, _segment_gaits(segments, poses),
                          channel_values, along)  # fmt: skip
    sums = {k: float(np.sum(v)) for k, v in terms.cols.items()}
    peaks = {q: float(np.max(v)) if v.size else 0.0 for q, v in terms.peaks.items()}
    rep = terms.report(dom, sums, peaks)
    return rounded(rep)


def report_against_groups(
    dom: Mapping[str, Any],
    segments: Any,
    groups: Sequence[np.ndarray],
    channel_values: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """:func:`report_against` of each group of ``segments`` (rows ``groups[i]``).

    The segments' columns (:func:`segment_terms`: one value per segment, each from its
    own row) are made once for all of them, and each group's report from the sums and
    peaks of its rows, in its order: the same reports as ``report_against`` of each
    group's rows (with the channel values of those rows), without a frame per group.
    Segments without ``along`` samples or ``energy_j``, as calibration windows are.
    """
    if "energy_j" in segments:  # whether it is used depends on every row of the path
        return [
            report_against(dom, segments.iloc[g].reset_index(drop=True), None, None,
                           {c: np.asarray(v)[g] for c, v in (channel_values or {}).items()})
            for g in groups
        ]  # fmt: skip
    dur = np.asarray(segments["duration_s"], dtype=float)
    terms = segment_terms(dom, segments, None, _segment_gaits(segments, None), channel_values)
    out = []
    for g in groups:
        if float(dur[g].sum()) <= 0:
            out.append(_report_of_no_time(dom))
            continue
        sums = {k: float(np.sum(v[g])) for k, v in terms.cols.items()}
        peaks = {q: float(np.max(v[g])) if v[g].size else 0.0 for q, v in terms.peaks.items()}
        out.append(rounded(terms.report(dom, sums, peaks)))
    return out


def _report_of_no_time(dom: Mapping[str, Any]) -> dict[str, Any]:
    """The report of a path (or group of segments) that lasts no time: nothing outside."""
    return {"outside_share": 0.0, "reasons": {}, "shares": {}, "excess": {},
            "max_excess": {}, "domain": dict(dom)}  # fmt: skip


def rounded(rep: dict[str, Any]) -> dict[str, Any]:
    """A report of one path (:meth:`SegmentTerms.report`) as plain numbers, rounded.

    Shares to 4 decimals, metres to 3, excesses to 6; the reason of a mean power beyond
    the calibration runs' names the path's power.
    """
    reasons = {}
    for why, v in rep["reasons"].items():
        if why.startswith("mean power ") and "mean_power_w" in rep:
            side = why.split()[2]
            why = f"mean power {float(rep['mean_power_w']):.0f} W {side} " + why.split(
                f"{side} ", 1)[1]  # fmt: skip
        reasons[why] = round(float(v), 4)
    out = {
        "outside_share": round(float(rep["outside_share"]), 4),
        "outside_m": round(float(rep["outside_m"]), 3),
        "reasons": reasons,
        "shares": {q: round(float(v), 4) for q, v in rep["shares"].items()},
        "excess": {q: round(float(v), 6) for q, v in rep["excess"].items()},
        "max_excess": {q: round(float(v), 6) for q, v in rep["max_excess"].items()},
        "domain": rep["domain"],
    }
    if "mean_power_w" in rep:
        out["mean_power_w"] = round(float(rep["mean_power_w"]), 3)
    return out


def domain_report(
    model: Any,
    segments: Any,
    constants: Any = None,
    poses: Any = None,
    channel_values: Mapping[str, Any] | None = None,
    along: Mapping[str, Any] | None = None,
) -> dict[str, Any] | None:
    """The share of a path outside the ranges the model's calibration saw.

    Parameters
    ----------
    model : EnergyModel
        Its ``metadata.fit.domain`` (:func:`energy_planner.calibration.fit.calibration_domain`).
    segments : pandas.DataFrame
        ``PathEnergy.segments`` (``distance_m``, ``duration_s``, ``max_slope_deg``,
        ``turn_deg``; with ``mean_slope_deg`` and ``mean_rel_heading_deg`` the relative
        heading is checked per gait on sloped segments; a ``gait`` column overrides the
        gait from the poses).
    constants : mapping, optional
        Channel constants (a value outside the channel's range puts the whole path
        outside).
    poses : array-like, optional
        ``PathEnergy.poses`` (x, y, yaw per segment end): a segment walked in a gait the
        calibration had no window of (sideways, backward, turning in place) is outside.
    channel_values : mapping, optional
        Channel name -> per segment one value, or an array of values sampled along it
        (a raster channel along the path, :func:`path_channel_values`): the share of
        the samples outside the recorded range counts.
    along : mapping, optional
        :func:`path_samples` of the path: slope and raster channels per metre along each
        segment (:func:`path_domain` builds it).

    Returns
    -------
    dict or None
        ``outside_share`` (share of the path's duration outside, 0-1), ``outside_m``
        (metres outside), ``reasons`` (reason -> share of the duration), ``shares``
        (quantity -> share outside it: ``slope``, ``gait``, ``relative_heading``,
        ``speed``, ``turning_rate``, ``channel NAME``), ``excess`` (per numeric quantity:
        slope in deg, speed in m/s, a channel in its unit, the distance beyond its range
        averaged over the path's duration, 0 inside), ``max_excess`` (the farthest
        sample) and ``domain``; None when the model records no domain. When the domain
        records the runs' predicted mean power (``mean_power_w``) and the segments carry
        ``energy_j``: ``mean_power_w``, the path's (its energy over its duration), and
        the share ``mean_power``, 1 when it lies above the runs' largest or below their
        smallest (the whole path is then outside, its reason naming both), else 0; its
        ``excess`` is the distance beyond, W. A model file without the runs' power has
        neither key.
    """
    dom = domain_of(model)
    if not dom:
        return None
    return report_against(dom, segments, constants, poses, channel_values, along)


def motion_segments(poses: Any, n_segments: int | None = None) -> np.ndarray:
    """The path segment of each motion between consecutive ``poses``.

    :func:`energy_planner.energy.path_energy` walks a segment as a turn in place at its
    first waypoint (when the heading changes) and the walk: with more motions than
    segments, each turn in place (no displacement) belongs to the walk that follows it.
    With as many motions as segments (or ``n_segments`` None), motion ``k`` is segment
    ``k``.

    >>> motion_segments([[0, 0, 0], [1, 0, 0], [1, 0, 1.5], [1, 2, 1.5]], 2).tolist()
    [0, 1, 1]
    """
    p = np.asarray(poses, dtype=float)
    m = max(p.shape[0] - 1, 0)
    if n_segments is None or m == n_segments:
        return np.arange(m)
    still = np.hypot(*np.diff(p[:, :2], axis=0).T) == 0.0
    turn = still & (np.abs(np.diff(p[:, 2])) > 0)
    seg = np.cumsum(~turn) - (~turn)  # walks before each motion
    if int(np.count_nonzero(~turn)) != n_segments:
        raise DomainError(f"{m} motions do not make {n_segments} segments (turns in place "
                          "before each walk expected)")  # fmt: skip
    return np.minimum(seg, n_segments - 1)


def path_samples(
    terrain: Any,
    poses: Any,
    channels: Any = None,
    n_segments: int | None = None,
    step: float | None = None,
) -> dict[str, list[np.ndarray]]:
    """The slope and the raster channels sampled along a path, per segment.

    Each motion between consecutive ``poses`` is cut as the energy integration cuts it
    (:func:`energy_planner.energy._motion.motion_full`): ``n = ceil(length / step)``
    pieces, ``step`` half the smaller cell size, each sampled at its midpoint (the slope
    from the bilinear gradient; numeric rasters bilinear, categorical ones at the nearest
    cell, as the kernel reads them). A piece weighs its length along the ground; a turn in
    place is one sample of weight 0 unless its segment has no walk (then weight 1).

    Parameters
    ----------
    terrain : Terrain
        The map (working CRS).
    poses : array-like, shape (m + 1, 3)
        The executed poses (``PathEnergy.poses``; x, y in the working CRS).
    channels : Channels, optional
        Bound to ``terrain`` (:meth:`Channels.bind`); its rasters are sampled.
    n_segments : int, optional
        Number of path segments: the motions are grouped by :func:`motion_segments`
        (default: one segment per motion).
    step : float, optional
        Largest piece, m.

    Returns
    -------
    dict
        ``weight`` (m), ``slope_deg`` and each raster channel (numbers, or category names):
        per segment an array of its samples.
    """
    p = np.asarray(poses, dtype=float)
    seg = motion_segments(p, n_segments)
    n_seg = int(seg.max()) + 1 if seg.size else 0
    length = np.hypot(*(p[1:, :2] - p[:-1, :2]).T)
    walks = np.bincount(seg, weights=length, minlength=n_seg) > 0
    cols = motion_samples(terrain, p[:-1], p[1:], channels, ~walks[seg], step)
    of_seg = seg[cols.pop("owner")]
    cut = np.flatnonzero(np.diff(of_seg)) + 1
    return {name: np.split(v, cut) for name, v in cols.items()}


def motion_samples(
    terrain: Any,
    a: Any,
    b: Any,
    channels: Any = None,
    lone: Any = None,
    step: float | None = None,
) -> dict[str, np.ndarray]:
    """The samples of :func:`path_samples` of independent motions ``a[k] -> b[k]``, flat.

    ``lone``: per motion, True where a turn in place is a segment of its own (its one
    sample then weighs 1, else 0); default all. Returns ``owner`` (the motion of each
    sample, non-decreasing), ``weight``, ``slope_deg`` and each raster channel, one array
    each (categories as names).
    """
    from energy_planner.terrain.sample import bilinear

    a = np.asarray(a, dtype=float)[:, :2]
    b = np.asarray(b, dtype=float)[:, :2]
    x0, y0, dx, dy = (float(v) for v in terrain.grid)
    h = float(step) if step else 0.5 * min(abs(dx), abs(dy))
    length = np.hypot(*(b - a).T)
    n = np.maximum(np.ceil(length / h).astype(int), 1)
    owner = np.repeat(np.arange(length.size), n)
    k = np.arange(owner.size) - np.repeat(np.cumsum(n) - n, n)
    frac = (k + 0.5) / n[owner]
    xy = a[owner] + frac[:, None] * (b - a)[owner]
    smp = terrain.sample(xy[:, 0], xy[:, 1])
    gx, gy = np.asarray(smp.dzdx, float), np.asarray(smp.dzdy, float)
    piece = (length / n)[owner]
    unit = (b - a) / np.where(length > 0, length, 1.0)[:, None]
    rise = np.nan_to_num(gx * unit[owner, 0] + gy * unit[owner, 1])  # dz per map metre
    w = piece * np.sqrt(1.0 + rise**2)  # metres along the ground, as the kernel's distance
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    lone = np.ones(length.size, bool) if lone is None else np.asarray(lone, bool)
    w = np.where(piece > 0, w, np.where(lone[owner], 1.0, 0.0))
    cols: dict[str, np.ndarray] = {"owner": owner, "weight": w, "slope_deg": slope}
    rasters = getattr(channels, "rasters", None) or {}
    r = np.clip(np.rint((xy[:, 1] - y0) / dy).astype(int), 0, terrain.shape[0] - 1)
    c = np.clip(np.rint((xy[:, 0] - x0) / dx).astype(int), 0, terrain.shape[1] - 1)
    for name, ras in rasters.items():
        if ras.values is None:
            continue
        vals = np.asarray(ras.values, dtype=float)
        near = vals[r, c]
        if ras.categories is not None:
            cats = np.asarray(list(ras.categories) + [None], dtype=object)
            idx = np.where(np.isfinite(near), near, len(cats) - 1).astype(int)
            cols[name] = cats[idx]
        else:
            (lin,) = bilinear((vals,), terrain.grid, xy[:, 0], xy[:, 1])
            cols[name] = np.where(np.isfinite(lin), lin, near)
    return cols


def path_channel_values(terrain: Any, channels: Any, poses: Any) -> dict[str, list[Any]]:
    """Per raster channel, its values along each motion between consecutive ``poses``.

    ``channels`` must be bound to ``terrain`` (:meth:`Channels.bind`); categorical values
    come back as category names. The samples of :func:`path_samples` (one list per
    motion; ``{}`` without raster channels).
    """
    if channels is None or not getattr(channels, "rasters", None):
        return {}
    got = path_samples(terrain, poses, channels)
    return {k: v for k, v in got.items() if k not in ("weight", "slope_deg")}


def path_domain(model: Any, terrain: Any, path: Any, channels: Any = None) -> dict[str, Any] | None:
    """The calibration domain of a priced path: :func:`domain_report` per metre walked.

    The one way every door (``energy``, ``plan``, the result objects) reports the domain
    of a path: the slope and the raster channels are sampled along every motion at the
    energy integration's sub-steps (:func:`path_samples`), so a segment only part of
    which is steeper than the calibration is outside for that part.

    Parameters
    ----------
    model : EnergyModel
        Its ``metadata.fit.domain``.
    terrain : Terrain
        The map the path was priced on.
    path : PathEnergy
        :func:`energy_planner.energy.path_energy` of the path (``table``, ``poses``).
    channels : Channels, optional
        The channels it was priced with (constants; rasters, bound to ``terrain`` here).

    Returns
    -------
    dict or None
        As :func:`domain_report`; None when the model records no domain.
    """
    dom = domain_of(model)
    if not dom:
        return None
    if channels is not None and getattr(channels, "rasters", None):
        channels = channels.bind(terrain)
    table = path.table
    n_seg = len(table["duration_s"])
    along = path_samples(terrain, path.poses, channels, n_seg) if n_seg else None
    consts = None if channels is None else dict(channels.constants)
    return report_against(dom, table, consts, path.poses, None, along)


def window_segments(table: pd.DataFrame) -> pd.DataFrame:
    """Calibration windows as path segments for :func:`report_against`.

    Each window is one segment: its duration, distance (speed x duration), slope, turn,
    relative heading and motion class (``kind``).
    """
    dur = table["duration"].to_numpy(float)
    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    slope = np.degrees(table["alpha"].to_numpy(float))
    import pandas as pd

    seg = pd.DataFrame(
        {
            "distance_m": speed * dur,
            "duration_s": dur,
            "max_slope_deg": slope,
            "mean_slope_deg": slope,
            "turn_deg": np.degrees(table["wz"].to_numpy(float) * dur),
            "mean_rel_heading_deg": np.degrees(table["gamma"].to_numpy(float)),
            "gait": table["kind"].to_numpy() if "kind" in table else "forward",
        }
    )
    return seg


def stay_in_domain(request: Any, model: Any, terrain: Any = None) -> tuple[Any, list[str]]:
    """A request whose plans stay inside the model's calibration domain, and what changed.

    - slope: ``max_slope_deg`` at most the steepest calibration window;
    - relative heading: without lateral windows the crab angle is limited to 45 deg
      (``Limits.max_crab_deg``: no sideways walking); without backward windows backward
      walking is limited to level ground (``Limits.max_backward_slope_deg = 0``);
    - raster channels (with ``terrain``): cells whose value lies outside the recorded
      range (or is a category the logs never had) lose their value, so that motions there
      cost inf (impassable, as on too steep a slope);
    - speed and turning rate: the request's speed is clamped into the recorded walking
      speeds, its yaw rate to at most the fastest recorded turning;
    - constant channels outside the recorded range cannot be kept inside: an error.

    The relative-heading ranges within a recorded gait (e.g. forward windows only uphill)
    and the runs' mean power are not enforced: the planner has no limit for them
    (:func:`domain_report` still reports them).

    Raises
    ------
    DomainError
        The model records no domain, or a ``--set`` constant lies outside it.
    """
    from energy_planner.request import Robot

    dom = domain_of(model)
    if not dom:
        raise DomainError(
            "the model records no calibration domain (metadata.fit.domain; models fitted "
            "before it was recorded): refit it, or plan without staying in the domain"
        )
    notes: list[str] = []
    lim, rob, ch = request.limits, request.robot, request.channels
    top = float(dom["max_slope_deg"])
    ms = top if lim.max_slope_deg is None else min(lim.max_slope_deg, top)
    if ms != lim.max_slope_deg:
        notes.append(f"max slope {ms:g} deg: the steepest calibration window")
    gaits = dom.get("gaits") or {}
    crab, back = lim.max_crab_deg, lim.max_backward_slope_deg
    if "lateral" not in gaits and (crab is None or crab > 45.0):
        crab = 45.0
        notes.append("max crab 45 deg: the calibration has no sideways walking")
    if "backward" not in gaits and (back is None or back > 0.0):
        back = 0.0
        notes.append("backward walking only on level ground: the calibration has none")
    speed, yaw_rate = rob.speed, rob.yaw_rate
    if dom.get("speed_m_s"):
        lo, hi = dom["speed_m_s"]
        speed = float(min(max(speed, lo), hi))
        if speed != rob.speed:
            notes.append(f"speed {rob.speed:g} m/s clamped to {speed:g} m/s (recorded "
                         f"walking speeds {lo:g}-{hi:g} m/s)")  # fmt: skip
    top_rate = float(dom.get("max_turn_rate_rad_s") or 0.0)
    if top_rate > 0 and yaw_rate > top_rate:
        yaw_rate = top_rate
        notes.append(f"yaw rate {rob.yaw_rate:g} rad/s clamped to {top_rate:g} rad/s (the "
                     "fastest recorded turning)")  # fmt: skip
    seen_ch = dom.get("channels") or {}
    if ch is not None:
        for c, v in ch.constants.items():
            seen = seen_ch.get(c)
            if seen is not None and _channel_outside(seen, np.array([v], dtype=object))[0]:
                raise DomainError(
                    f"channel {c} = {v} lies outside the calibration's {seen}: no plan with "
                    "it stays in the domain; give a value in that range, or plan without "
                    "staying in the domain",
                    value=v,
                )
        if ch.rasters and terrain is not None:
            bound = ch.bind(terrain)
            rasters = {}
            for name, r in bound.rasters.items():
                seen = seen_ch.get(name)
                if seen is None or r.values is None:
                    rasters[name] = r
                    continue
                v = np.asarray(r.values, dtype=float).copy()
                if r.categories is not None:
                    ok_idx = [i for i, cat in enumerate(r.categories) if cat in seen]
                    bad = np.isfinite(v) & ~np.isin(v, ok_idx)
                else:
                    bad = np.isfinite(v) & ((v < seen[0]) | (v > seen[1]))
                if bad.any():
                    v[bad] = np.nan
                    notes.append(f"channel {name}: {int(bad.sum())} cells outside the "
                                 f"calibration's {seen} made impassable")  # fmt: skip
                rasters[name] = dataclasses.replace(r, values=v)
            ch = dataclasses.replace(bound, rasters=rasters)
    new = dataclasses.replace(
        request,
        robot=Robot(speed, yaw_rate),
        limits=dataclasses.replace(
            lim, max_slope_deg=ms, max_crab_deg=crab, max_backward_slope_deg=back
        ),  # fmt: skip
        channels=ch,
    )
    return new, notes
