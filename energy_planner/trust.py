"""What a priced energy is worth: its interval, its domain and a battery's verdict, as data.

Every result that prices a path (:class:`~energy_planner.energy.path.PathEnergy`,
:class:`~energy_planner.planning.plan.PlanResult`, each route of a
:class:`~energy_planner.planning.routes.RouteComparison`, a
:class:`~energy_planner.mission.MissionResult` and its legs) carries an
:class:`Assessment`, made in one place,
:func:`energy_planner.uncertainty.assess.assess` (the model's error model and the share
of the path outside the calibration's domain). The verbs take the :class:`Trust`
keywords (``level=``, ``battery_wh=``, ``reserve_wh=``, ``confidence=``); the command
line prints the result's own fields.

This module holds data only (no computation, no import of the package's other units), so
that every layer's results can carry it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

__all__ = ["Assessed", "Assessment", "Trust", "TRUST_KEYS"]

#: The keywords of :class:`Trust` every pricing verb takes.
TRUST_KEYS = ("level", "battery_wh", "reserve_wh", "confidence")


@dataclass(frozen=True)
class Trust:
    """What is asked of a priced energy: an interval's level and, optionally, a battery.

    Attributes
    ----------
    level : float
        Nominal coverage of the energy's prediction interval (0.9: 90 %).
    battery_wh : float or None
        Battery energy, Wh (None: no battery decision).
    reserve_wh : float
        Energy to keep in the battery, Wh.
    confidence : float
        Required chance that the battery suffices.

    Examples
    --------
    >>> kw = {"battery_wh": 30.0, "time": 2}
    >>> Trust.pop(kw), kw
    (Trust(level=0.9, battery_wh=30.0, reserve_wh=0.0, confidence=0.9), {'time': 2})
    """

    level: float = 0.9
    battery_wh: float | None = None
    reserve_wh: float = 0.0
    confidence: float = 0.9

    @classmethod
    def pop(cls, kwargs: dict[str, Any]) -> Trust:
        """The :data:`TRUST_KEYS` taken out of a verb's ``kwargs`` (defaults for the rest).

        A ``trust=`` keyword (a :class:`Trust`) is the base the other keywords replace.
        """
        base = kwargs.pop("trust", None) or cls()
        values = {k: kwargs.pop(k) for k in TRUST_KEYS if k in kwargs}
        if not isinstance(base, Trust):
            raise TypeError(f"trust must be an energy_planner.trust.Trust, not {base!r}")
        return dataclasses.replace(base, **values) if values else base

    @property
    def usable_j(self) -> float | None:
        """The battery's usable energy (battery less reserve), J; None without a battery."""
        return None if self.battery_wh is None else (self.battery_wh - self.reserve_wh) * 3600.0


@dataclass(frozen=True)
class Assessment:
    """A priced energy's interval, its domain report and, given a battery, the verdict.

    Attributes
    ----------
    interval : EnergyInterval or None
        The prediction interval (None: the model carries no held-out run errors).
    domain : dict or None
        :func:`energy_planner.uncertainty.domain_report` of the path (None: the model
        records no calibration domain).
    battery : BatteryDecision or None
        The chance the battery suffices (None: no battery was given, or refused).
    battery_refused : str or None
        Why no battery decision was given although a battery was: the path goes beyond
        the calibration's ranges where the error's growth could not be measured.
    """

    interval: Any = None
    domain: dict[str, Any] | None = None
    battery: Any = None
    battery_refused: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """``interval``, ``domain`` and (with a battery) ``battery``, JSON-ready."""
        out: dict[str, Any] = {
            "interval": None if self.interval is None else self.interval.to_dict(),
            "domain": self.domain,
        }
        if self.battery is not None:
            out["battery"] = self.battery.to_dict()
        if self.battery_refused is not None:
            out["battery"] = None
            out["battery_refused"] = self.battery_refused
        return out

    def text(self) -> str:
        """The interval, domain and battery lines for people."""
        iv, lines = self.interval, []
        if iv is not None:
            few = " (Student-t: too few runs)" if "Student" in iv.method else ""
            lines.append(f"interval  {iv.text()}, split-conformal on {iv.n_scores} held-out "
                         f"runs{few}")  # fmt: skip
        else:
            lines.append("interval  none: the model carries no held-out run errors")
        dom = self.domain
        if dom:
            why = "; ".join(f"{k} ({100 * v:.0f} %)" for k, v in dom["reasons"].items())
            wide = "; the interval is widened" if dom["outside_share"] > 0 else ""
            lines.append(f"domain    {100 * dom['outside_share']:.0f} % of the path lies "
                         f"outside the calibration's ranges{': ' + why if why else ''}"
                         f"{wide}")  # fmt: skip
        if self.battery_refused is not None:
            lines.append(f"battery   {self.battery_refused}")
        if self.battery is not None:
            lines.append(self.battery.text())
        return "\n".join(lines)


class Assessed:
    """A result whose energy carries an :class:`Assessment` (attribute ``assessment``).

    ``None`` until a verb assessed it (the low-level pricing functions do not).
    """

    assessment: Assessment | None

    @property
    def interval(self) -> Any:
        """The energy's prediction interval (``EnergyInterval``), or None."""
        return None if self.assessment is None else self.assessment.interval

    @property
    def domain(self) -> dict[str, Any] | None:
        """The share of the path outside the calibration's domain (a report), or None."""
        return None if self.assessment is None else self.assessment.domain

    @property
    def battery(self) -> Any:
        """The battery's verdict (``BatteryDecision``), or None."""
        return None if self.assessment is None else self.assessment.battery

    def assessment_dict(self) -> dict[str, Any]:
        """The assessment's JSON fields (``{}`` when not assessed)."""
        return {} if self.assessment is None else self.assessment.to_dict()
