"""The one place a priced energy gets its interval, its domain report and a battery verdict.

Every verb that prices a path (``path_energy``, ``plan``, ``compare_routes``, ``mission``)
calls :func:`assess_path` (or :func:`assess` for a sum of paths) with the caller's
:class:`~energy_planner.trust.Trust`; the result carries the
:class:`~energy_planner.trust.Assessment`.

Examples
--------
>>> import energy_planner as ep
>>> from energy_planner.trust import Trust
>>> a = assess(ep.load_model(), 50_000.0, duration_s=150.0, trust=Trust(battery_wh=20.0))
>>> bool(a.interval.low_j < 50_000.0 < a.interval.high_j), a.battery.ok
(True, True)
"""

from __future__ import annotations

from typing import Any

from energy_planner.trust import Assessment, Trust

__all__ = ["assess", "assess_path", "path_domain"]


def assess(
    model: Any,
    energy_j: float,
    *,
    duration_s: float | None = None,
    domain: dict[str, Any] | None = None,
    trust: Trust | None = None,
) -> Assessment:
    """The :class:`~energy_planner.trust.Assessment` of ``energy_j`` predicted by ``model``.

    Parameters
    ----------
    model : EnergyModel
        The model that priced it (its held-out errors and error model).
    energy_j : float
        The predicted energy, J.
    duration_s : float, optional
        The path's duration, s (an input of the fit's error model).
    domain : dict, optional
        The path's :func:`path_domain` report; its ``outside_share`` widens the interval.
    trust : Trust, optional
        Level and battery (default: a 90 % interval, no battery).

    Raises
    ------
    BatteryError
        A battery was given and the model carries no held-out run errors, or the reserve
        is not below the battery.
    """
    from energy_planner.uncertainty import path_trust

    trust = trust or Trust()
    t = path_trust(model, energy_j, duration_s, domain, level=trust.level,
                   battery_wh=trust.battery_wh, reserve_wh=trust.reserve_wh,
                   confidence=trust.confidence)  # fmt: skip
    return Assessment(t.interval, domain, t.battery, t.battery_refused)


def path_domain(model: Any, priced: Any, cost: Any) -> dict[str, Any] | None:
    """The share of a priced path outside the model's calibration domain, or None.

    ``priced`` is the path's :class:`~energy_planner.energy.path.PathEnergy`, ``cost``
    the :class:`~energy_planner.energy.MotionCost` that priced it (its channel constants
    and rasters are the values along the path): counted per metre walked by
    :func:`energy_planner.uncertainty.domain.path_domain`.
    """
    from energy_planner.uncertainty.domain import path_domain as per_metre

    return per_metre(model, cost.terrain, priced, cost.channels)


def assess_path(model: Any, priced: Any, cost: Any, trust: Trust | None = None) -> Assessment:
    """:func:`assess` of a priced path, with its :func:`path_domain` and duration."""
    dom = path_domain(model, priced, cost)
    return assess(model, priced.energy_j, duration_s=priced.duration_s, domain=dom,
                  trust=trust)  # fmt: skip


def sum_domain(parts: list[tuple[dict[str, Any] | None, float]]) -> dict[str, Any] | None:
    """The domain report of a path made of parts: each ``(report, duration_s)``.

    Shares are weighted by duration (as :func:`~energy_planner.uncertainty.domain_report`
    counts them along one path); ``domain`` is the first part's. None when no part has
    a report.
    """
    have = [(d, t) for d, t in parts if d is not None]
    if not have:
        return None
    total = sum(t for _, t in have) or 1.0

    def mix(key: str) -> dict[str, float]:
        names = dict.fromkeys(k for d, _ in have for k in d.get(key, {}))
        return {k: round(sum(d.get(key, {}).get(k, 0.0) * t for d, t in have) / total, 4)
                for k in names}  # fmt: skip

    peak: dict[str, float] = {}
    for d, _ in have:
        for k, v in (d.get("max_excess") or {}).items():
            peak[k] = max(peak.get(k, 0.0), v)
    power: dict[str, Any] = {}
    if all("mean_power_w" in d for d, _ in have):  # the whole's, as one path's
        power["mean_power_w"] = round(sum(d["mean_power_w"] * t for d, t in have) / total, 3)
    return {
        **power,
        "outside_share": round(sum(d["outside_share"] * t for d, t in have) / total, 4),
        "outside_m": round(sum(d.get("outside_m", 0.0) for d, _ in have), 3),
        "reasons": {k: v for k, v in mix("reasons").items() if v > 0},
        "shares": mix("shares"),
        # the distance beyond each range, averaged over the whole path's duration as
        # domain_report averages it along one path (what the error's growth scales)
        "excess": mix("excess"),
        "max_excess": peak,
        "domain": have[0][0].get("domain"),
    }
