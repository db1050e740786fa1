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
from collections.abc import Mapping
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
    "path_samples",
    "report_against",
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
    turn = np.abs(np.asarray(segments["turn_deg"], dtype=float))
    out = np.where(dist > 1e-9, "forward", np.where(turn > 0, "turning", "none")).astype(object)
    p = None if poses is None else np.asarray(poses, dtype=float)
    if p is None or p.ndim != 2 or p.shape[0] != dist.size + 1 or p.shape[1] < 3:
        return out
    d = np.diff(p[:, :2], axis=0)
    rel = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - p[:-1, 2])))
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
    v = np.atleast_1d(np.asarray(values, dtype=object))
    return np.array([np.nan if x is None or isinstance(x, str) else float(x) for x in v])


def _beyond(lo: float, hi: float, values: Any) -> np.ndarray:
    """Distance of each value beyond ``[lo, hi]`` (0 inside, NaN-safe), in its unit."""
    f = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        d = np.maximum(np.maximum(lo - f, f - hi), 0.0)
    return np.where(np.isfinite(d), d, 0.0)


def _weighted(per_seg: Any, weights: Any, fn: Any) -> np.ndarray:
    """Per segment the weighted mean of ``fn(samples)`` (samples along it, or one value)."""
    out = np.zeros(len(per_seg))
    for i, v in enumerate(per_seg):
        x = np.asarray(fn(np.atleast_1d(v)), dtype=float)
        if x.size == 0:
            continue
        w = None if weights is None else np.asarray(weights[i], dtype=float)
        if w is None or w.size != x.size or not np.sum(w) > 0:
            out[i] = float(np.mean(x))
        else:
            out[i] = float(np.sum(w * x) / np.sum(w))
    return out


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
    its ``max_slope_deg`` (a calibration window: its mean slope).
    """
    dur = np.asarray(segments["duration_s"], dtype=float)
    dist = np.asarray(segments["distance_m"], dtype=float)
    turn = np.radians(np.abs(np.asarray(segments["turn_deg"], dtype=float)))
    total = float(dur.sum())
    if total <= 0:
        return {"outside_share": 0.0, "reasons": {}, "shares": {}, "excess": {},
                "max_excess": {}, "domain": dict(dom)}  # fmt: skip
    safe = np.where(dur > 0, dur, np.inf)
    speed, rate = dist / safe, turn / safe
    along = dict(along or {})
    weights = along.get("weight")
    # quantity -> (reason, share of each segment outside, its excess per segment or None,
    # the largest excess of a sample)
    masks: dict[str, tuple[str, np.ndarray, np.ndarray | None, float]] = {}
    top = float(dom["max_slope_deg"])
    if "slope_deg" in along:
        s_out = _weighted(along["slope_deg"], weights, lambda v: v > top)
        s_exc = _weighted(along["slope_deg"], weights, lambda v: _beyond(-np.inf, top, v))
        peak = max((float(np.max(_beyond(-np.inf, top, v))) for v in along["slope_deg"]
                    if np.size(v)), default=0.0)  # fmt: skip
    else:
        slope = np.asarray(segments["max_slope_deg"], dtype=float)
        s_out = (slope > top).astype(float)
        s_exc = _beyond(-np.inf, top, slope)
        peak = float(np.max(s_exc)) if s_exc.size else 0.0
    masks[f"slope above {top:g} deg"] = ("slope", s_out, s_exc, peak)
    if dom.get("speed_m_s"):
        lo, hi = dom["speed_m_s"]
        walking = speed > 0.05
        exc = np.where(walking, _beyond(lo, hi, speed), 0.0)
        masks[f"speed outside {lo:g}-{hi:g} m/s"] = (
            "speed", (walking & ((speed < lo) | (speed > hi))).astype(float), exc,
            float(exc.max()) if exc.size else 0.0,
        )  # fmt: skip
    masks[f"turning faster than {dom['max_turn_rate_rad_s']:g} rad/s"] = (
        "turning_rate", (rate > dom["max_turn_rate_rad_s"] * 1.05).astype(float), None, 0.0
    )  # fmt: skip
    gaits = _segment_gaits(segments, poses)
    recorded = dom.get("gaits") or {}
    for g in ("forward", "backward", "lateral", "turning"):
        if g not in recorded:
            masks[f"{g} motion, absent from the calibration"] = (
                "gait", (gaits == g).astype(float), None, 0.0
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
                "relative_heading", out.astype(float), None, 0.0
            )  # fmt: skip
    power = _mean_power(dom, segments, dur, total)
    if power is not None and not power[1] <= power[0] <= power[2]:
        p, lo, hi = power
        side, gap = ("above", p - hi) if p > hi else ("below", lo - p)
        masks[
            f"mean power {p:.0f} W {side} every calibration run's ({lo:.0f}-{hi:.0f} W): "
            f"log runs at that power ({POWER_HOW[side]})"
        ] = (MEAN_POWER, np.ones(dur.size), np.full(dur.size, gap), gap)
    seen_ch = dom.get("channels") or {}
    per_seg: dict[str, Any] = dict(channel_values or {})
    ch_weights: dict[str, Any] = {}
    for c, v in along.items():
        if c not in ("weight", "slope_deg"):
            per_seg[c], ch_weights[c] = v, weights
    for c, v in dict(constants or {}).items():
        per_seg.setdefault(c, np.full(dur.size, v, dtype=object))
    for c, vals in per_seg.items():
        seen = seen_ch.get(c)
        if seen is None or len(vals) != dur.size:
            continue
        w = ch_weights.get(c)
        out = _weighted(vals, w, lambda v, seen=seen: _channel_outside(seen, v))
        exc, peak = None, 0.0
        if not _categorical(seen):
            exc = _weighted(vals, w, lambda v, seen=seen: _beyond(seen[0], seen[1], _numbers(v)))
            peak = max((float(np.max(_beyond(seen[0], seen[1], _numbers(v)))) for v in vals
                        if np.size(v)), default=0.0)  # fmt: skip
        what = f"{c} outside the logs' {seen}"
        if c in (constants or {}):
            what = f"{c} = {vals[0]} outside the logs' {seen}"
        masks[what] = (f"channel {c}", out, exc, peak)
    # a mask is the share of each segment outside (0 or 1, or the share of its metres);
    # the share outside several ranges is at least the largest of them
    any_out = np.zeros(dur.size)
    reasons: dict[str, float] = {}
    shares: dict[str, float] = {q: 0.0 for q in QUANTITIES}
    excess: dict[str, float] = {}
    max_excess: dict[str, float] = {}
    by_q: dict[str, np.ndarray] = {}
    for why, (q, m, exc, peak) in masks.items():
        m = np.asarray(m, dtype=float)
        by_q[q] = np.maximum(by_q.get(q, np.zeros(dur.size)), m)
        if exc is not None:
            excess[q] = max(excess.get(q, 0.0), round(float(np.sum(dur * exc) / total), 6))
            max_excess[q] = max(max_excess.get(q, 0.0), round(peak, 6))
        if m.any():
            reasons[why] = round(float(np.sum(dur * m) / total), 4)
            any_out = np.maximum(any_out, m)
    for q, m in by_q.items():
        shares[q] = round(float(np.sum(dur * m) / total), 4)
    out = {
        "outside_share": round(float(np.sum(dur * any_out) / total), 4),
        "outside_m": round(float(np.sum(dist * any_out)), 3),
        "reasons": reasons,
        "shares": shares,
        "excess": excess,
        "max_excess": max_excess,
        "domain": dict(dom),
    }
    if power is not None:
        shares.setdefault(MEAN_POWER, 0.0)
        out["mean_power_w"] = round(power[0], 3)
    return out


def _mean_power(
    dom: Mapping[str, Any], segments: Any, dur: np.ndarray, total: float
) -> tuple[float, float, float] | None:
    """``(path's mean power, lo, hi)`` in W, or None when there is nothing to check.

    None when the domain records no runs' mean power (a model file saved before it was
    recorded, or fitted without cross-validation) or the segments carry no ``energy_j``
    (calibration windows).
    """
    rng = dom.get("mean_power_w")
    if not rng or "energy_j" not in segments:
        return None
    e = np.asarray(segments["energy_j"], dtype=float)
    if e.size != dur.size or not np.all(np.isfinite(e)):
        return None
    return float(np.sum(e) / total), float(rng[0]), float(rng[1])


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
    from energy_planner.terrain.sample import bilinear

    p = np.asarray(poses, dtype=float)
    x0, y0, dx, dy = (float(v) for v in terrain.grid)
    h = float(step) if step else 0.5 * min(abs(dx), abs(dy))
    seg = motion_segments(p, n_segments)
    n_seg = int(seg.max()) + 1 if seg.size else 0
    a, b = p[:-1, :2], p[1:, :2]
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
    walks = np.bincount(seg, weights=length, minlength=n_seg) > 0
    w = np.where(piece > 0, w, np.where(walks[seg[owner]], 0.0, 1.0))
    cols: dict[str, np.ndarray] = {"weight": w, "slope_deg": slope}
    rasters = getattr(channels, "rasters", None) or {}
    r = np.clip(np.rint((xy[:, 1] - y0) / dy).astype(int), 0, terrain.shape[0] - 1)
    c = np.clip(np.rint((xy[:, 0] - x0) / dx).astype(int), 0, terrain.shape[1] - 1)
    for name, ras in rasters.items():
        if ras.values is None:
            continue
        vals = np.asarray(ras.values, dtype=float)
        near = vals[r, c]
        if ras.categories is not None:
            cats = ras.categories
            cols[name] = np.array([cats[int(v)] if np.isfinite(v) else None for v in near],
                                  dtype=object)  # fmt: skip
        else:
            (lin,) = bilinear((vals,), terrain.grid, xy[:, 0], xy[:, 1])
            cols[name] = np.where(np.isfinite(lin), lin, near)
    of_seg = seg[owner]
    cut = np.flatnonzero(np.diff(of_seg)) + 1
    return {name: np.split(v, cut) for name, v in cols.items()}


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
