"""The calibration's domain: which part of a path lies outside it, and plans kept inside.

A fitted model records the ranges its calibration windows saw
(:func:`energy_planner.calibration.fit.calibration_domain`, ``metadata.fit.domain``):
slope, relative heading per gait, walking speed, turning rate and the values of each
channel it reads. :func:`domain_report` gives the share of a path's duration outside each
of them; :func:`stay_in_domain` turns the domain into a planning request that keeps a plan
inside it as far as the planner's limits can.
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
    "domain_report",
    "path_channel_values",
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


class DomainError(EnergyPlannerError, ValueError):
    """A model records no calibration domain where one is needed."""


def domain_of(model: Any) -> dict[str, Any] | None:
    """The ``metadata.fit.domain`` a model records, or None."""
    return ((getattr(model, "metadata", None) or {}).get("fit") or {}).get("domain") or None


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
    if isinstance(seen, list) and seen and isinstance(seen[0], str):
        return np.array([v is not None and str(v) not in seen for v in values], dtype=bool)
    f = np.array([np.nan if v is None or isinstance(v, str) else float(v) for v in values])
    return np.isfinite(f) & ((f < seen[0]) | (f > seen[1]))


def report_against(
    dom: Mapping[str, Any],
    segments: Any,
    constants: Mapping[str, Any] | None = None,
    poses: Any = None,
    channel_values: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """:func:`domain_report` against a domain dict (the core; see there)."""
    dur = np.asarray(segments["duration_s"], dtype=float)
    dist = np.asarray(segments["distance_m"], dtype=float)
    turn = np.radians(np.abs(np.asarray(segments["turn_deg"], dtype=float)))
    total = float(dur.sum())
    if total <= 0:
        return {"outside_share": 0.0, "reasons": {}, "shares": {}, "domain": dict(dom)}
    safe = np.where(dur > 0, dur, np.inf)
    speed, rate = dist / safe, turn / safe
    masks: dict[str, tuple[str, np.ndarray]] = {}
    slope = np.asarray(segments["max_slope_deg"], dtype=float)
    masks[f"slope above {dom['max_slope_deg']:g} deg"] = ("slope", slope > dom["max_slope_deg"])
    if dom.get("speed_m_s"):
        lo, hi = dom["speed_m_s"]
        masks[f"speed outside {lo:g}-{hi:g} m/s"] = (
            "speed", (speed > 0.05) & ((speed < lo) | (speed > hi))
        )  # fmt: skip
    masks[f"turning faster than {dom['max_turn_rate_rad_s']:g} rad/s"] = (
        "turning_rate", rate > dom["max_turn_rate_rad_s"] * 1.05
    )  # fmt: skip
    gaits = _segment_gaits(segments, poses)
    recorded = dom.get("gaits") or {}
    for g in ("forward", "backward", "lateral", "turning"):
        if g not in recorded:
            masks[f"{g} motion, absent from the calibration"] = ("gait", gaits == g)
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
                "relative_heading", out
            )  # fmt: skip
    seen_ch = dom.get("channels") or {}
    per_seg: dict[str, Any] = dict(channel_values or {})
    for c, v in dict(constants or {}).items():
        per_seg.setdefault(c, np.full(dur.size, v, dtype=object))
    for c, vals in per_seg.items():
        seen = seen_ch.get(c)
        if seen is None or len(vals) != dur.size:
            continue
        if any(isinstance(v, np.ndarray) for v in vals):  # samples along each segment
            out = np.array([np.mean(_channel_outside(seen, np.atleast_1d(v))) if np.size(v)
                            else 0.0 for v in vals])  # fmt: skip
        else:
            out = _channel_outside(seen, vals).astype(float)
        what = f"{c} outside the logs' {seen}"
        if c in (constants or {}):
            what = f"{c} = {vals[0]} outside the logs' {seen}"
        masks[what] = (f"channel {c}", out)
    # a mask is the share of each segment outside (0 or 1, or a fraction of the samples
    # along it); the share outside several ranges is at least the largest of them
    any_out = np.zeros(dur.size)
    reasons: dict[str, float] = {}
    shares: dict[str, float] = {q: 0.0 for q in QUANTITIES}
    by_q: dict[str, np.ndarray] = {}
    for why, (q, m) in masks.items():
        m = np.asarray(m, dtype=float)
        by_q[q] = np.maximum(by_q.get(q, np.zeros(dur.size)), m)
        if m.any():
            reasons[why] = round(float(np.sum(dur * m) / total), 4)
            any_out = np.maximum(any_out, m)
    for q, m in by_q.items():
        shares[q] = round(float(np.sum(dur * m) / total), 4)
    return {
        "outside_share": round(float(np.sum(dur * any_out) / total), 4),
        "reasons": reasons,
        "shares": shares,
        "domain": dict(dom),
    }


def domain_report(
    model: Any,
    segments: Any,
    constants: Any = None,
    poses: Any = None,
    channel_values: Mapping[str, Any] | None = None,
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

    Returns
    -------
    dict or None
        ``outside_share`` (share of the path's duration outside, 0-1), ``reasons``
        (reason -> share of the duration), ``shares`` (quantity -> share outside it:
        ``slope``, ``gait``, ``relative_heading``, ``speed``, ``turning_rate``,
        ``channel NAME``) and ``domain``; None when the model records no domain.
    """
    dom = domain_of(model)
    if not dom:
        return None
    return report_against(dom, segments, constants, poses, channel_values)


def path_channel_values(terrain: Any, channels: Any, poses: Any) -> dict[str, list[Any]]:
    """Per raster channel, its values along each segment (nearest cell, every half cell).

    ``channels`` must be bound to ``terrain`` (:meth:`Channels.bind`); categorical values
    come back as category names. Returns, per channel, one array of samples per segment
    between consecutive ``poses`` (``{}`` without raster channels).
    """
    if channels is None or not getattr(channels, "rasters", None):
        return {}
    p = np.asarray(poses, dtype=float)
    x0, y0, dx, dy = (float(v) for v in terrain.grid)  # centre of cell (0, 0)
    step = 0.5 * min(abs(dx), abs(dy))
    cells = []
    for a, b in zip(p[:-1, :2], p[1:, :2], strict=True):
        k = max(int(np.ceil(np.hypot(*(b - a)) / step)), 1) + 1
        xy = a + np.linspace(0.0, 1.0, k)[:, None] * (b - a)
        r = np.clip(np.rint((xy[:, 1] - y0) / dy).astype(int), 0, terrain.shape[0] - 1)
        c = np.clip(np.rint((xy[:, 0] - x0) / dx).astype(int), 0, terrain.shape[1] - 1)
        cells.append((r, c))
    out: dict[str, list[Any]] = {}
    for name, ras in channels.rasters.items():
        if ras.values is None:
            continue
        vals = np.asarray(ras.values, dtype=float)
        per = [vals[r, c] for r, c in cells]
        if ras.categories is not None:
            cats = ras.categories
            per = [np.array([cats[int(x)] if np.isfinite(x) else None for x in v], dtype=object)
                   for v in per]  # fmt: skip
        out[name] = per
    return out


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
    are not enforced: the planner has no limit for them (:func:`domain_report` still
    reports them).

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
