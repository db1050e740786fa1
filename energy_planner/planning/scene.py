"""The direct climb and the detour at the fixed speed, at the best speed and under a deadline.

:func:`speed_scene` prices the routes of :func:`~energy_planner.planning.compare.compare_routes`
(the direct line, the line at its best body yaw, the shortest and the energy-optimal route,
planned at the nominal speed) three ways, and splits the saving of the best choice against
the direct climb at the nominal speed into what each choice contributes:

* **body yaw**: ``direct`` -> ``direct_best_yaw``, both at the nominal speed;
* **route**: ``direct_best_yaw`` -> ``energy_optimal``, at the nominal speed;
* **speed**: the energy-optimal route retimed at each motion's least-energy speed within the
  nominal speed's gait (its logged speeds);
* **gait**: the same route with each motion's gait chosen too (each gait within its logged
  speeds, ``metadata.fit.domain.gait_speed_m_s``: the motion's cheapest gait and speed);
* **replanned** (``route_with_speed``): the route planned with each motion's gait and speed
  chosen (:func:`~energy_planner.planning.plan.plan` over the gaits' speeds: row
  ``planned_at_best_speed``) where it beats the energy-optimal route retimed (else 0):
  gait, speed and route chosen together.

The parts telescope: they add up to the total saving. A row's gait is the one its motions
walk, ``mixed`` where they walk several. The other routes' poses are those planned at the
nominal speed; only their timing (and gaits) change
(:func:`~energy_planner.planning.speed.timed`,
:func:`~energy_planner.planning.speed.timed_deadline`).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from energy_planner.errors import EnergyPlannerError, PlanningConfigError

__all__ = ["SpeedScene", "speed_scene"]

#: The routes priced, in table order (then :data:`PLANNED`).
SCENE_ROUTES = ("direct", "direct_best_yaw", "shortest", "energy_optimal")
#: The row of the route planned with each motion's speed chosen (in the cheaper gait).
PLANNED = "planned_at_best_speed"


def _gaits(model: Any) -> dict[str, tuple[float, float]]:
    """The model's gaits and their logged speeds; an error naming the model without."""
    from energy_planner.calibration.speed import gait_ranges

    ranges = gait_ranges(model)
    if not ranges:
        raise PlanningConfigError(
            "the model's logs name no gait (no gait channel, or no speeds per gait in "
            "metadata.fit.domain.gait_speed_m_s): give a model fitted on logs with a gait "
            "channel, e.g. --model b1_speeds",
            value=getattr(model, "source", None),
            param="model",
        )
    return {str(g): (float(lo), float(hi)) for g, (lo, hi) in ranges.items()}


@dataclasses.dataclass
class SpeedScene:
    """Each route's energy at the nominal speed, at its best speed and under a deadline.

    ``rows``: one dict per route (``route``, ``fixed_j``, ``fixed_s``, ``best_j``,
    ``best_s``, ``best_gait``, ``deadline_j``, ``deadline_s``, ``deadline_gait``; None
    where it cannot). ``parts``: the saving's decomposition, joules by choice (``body_yaw``,
    ``route``, ``speed``, ``gait``) and ``total_j`` (their sum).
    """

    nominal_speed: float
    nominal_gait: str
    gaits: dict[str, tuple[float, float]]
    deadline_s: float
    rows: list[dict[str, Any]]
    parts: dict[str, float]
    baseline_j: float
    notes: list[str]

    def row(self, route: str) -> dict[str, Any]:
        """The row of ``route``."""
        return next(r for r in self.rows if r["route"] == route)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: every field."""
        d = dataclasses.asdict(self)
        d["gaits"] = {g: list(r) for g, r in self.gaits.items()}
        return d

    def table(self) -> str:
        """The rows and the decomposition, as printed by ``demo --speeds``."""

        def cell(j, s, g=None, missing="cannot"):
            if j is None:
                return f"{missing:>21}"
            return f"{j:8.0f} {s:5.0f}s" + (f" {g:<5}" if g is not None else "      ")

        v = self.nominal_speed
        lines = [
            f"{'route':<22}{f'at {v:g} m/s ({self.nominal_gait})':>21}  {'best speed':>21}  "
            f"{f'deadline {self.deadline_s:.0f} s':>21}",
        ]
        for r in self.rows:
            lines.append(
                f"{r['route']:<22}"
                f"{cell(r['fixed_j'], r['fixed_s'], self.nominal_gait, missing='-')}  "
                f"{cell(r['best_j'], r['best_s'], r['best_gait'])}  "
                f"{cell(r['deadline_j'], r['deadline_s'], r['deadline_gait'])}"
            )
        b = self.baseline_j
        lines += ["", f"Saving against the direct climb at {v:g} m/s ({b:.0f} J):"]
        for k, label in (
            ("body_yaw", "body yaw"),
            ("route", "route"),
            ("speed", "speed"),
            ("gait", "gait"),
            ("route_with_speed", "replanned"),
        ):
            lines.append(f"  {label:<10}{self.parts[k]:8.0f} J  {100 * self.parts[k] / b:5.1f}%")
        lines.append(f"  {'total':<10}{self.parts['total_j']:8.0f} J  "
                     f"{100 * self.parts['total_j'] / b:5.1f}%")  # fmt: skip
        return "\n".join(line.rstrip() for line in lines + [""] + self.notes)


def _gait_problem(problem: Any, gait: str) -> Any:
    from energy_planner.energy.channels import Channels

    ch = Channels.parse((f"gait={gait}",), (), allow_unknown_categories=True)
    return problem.replace(request=dataclasses.replace(problem.request, channels=ch))


def _gait_label(gaits: Any) -> str | None:
    """The gait a timed route walks: its name, ``mixed`` for several, None without."""
    walked = sorted({g for g in gaits or () if g is not None})
    return None if not walked else walked[0] if len(walked) == 1 else "mixed"


def _timed(problem, states, speed, name, deadline=None):
    """``(energy, duration, gait)`` of a route retimed, or Nones where it cannot be walked.

    Each motion's gait and speed chosen where ``problem`` leaves the gait open.
    """
    from energy_planner.planning.speed import timed, timed_deadline

    try:
        if deadline is None:
            res = timed(problem, states, speed=speed, name=name)
        else:
            res = timed_deadline(problem, states, deadline, speed=speed, name=name)
    except EnergyPlannerError:
        return None, None, None  # a limit, or too slow for the deadline
    given = getattr(problem.request.channels, "constants", None) or {}
    gait = _gait_label(res.gaits) or given.get("gait")
    return float(res.energy_j), float(res.duration_s), None if gait is None else str(gait)


def speed_scene(
    problem: Any,
    start: Sequence[float],
    goal: Sequence[float],
    *,
    deadline: float | None = None,
    deadline_factor: float = 0.9,
    time: float = 1.0,
    seed: int = 0,
    progress: bool = False,
) -> SpeedScene:
    """The routes at the nominal speed, at their best speed and gait, and under a deadline.

    Parameters
    ----------
    problem : Problem
        Its model must name gaits in its logs (e.g. the bundled ``b1_speeds``); the
        request's nominal speed is the fixed speed, walked in the gait whose logged speeds
        hold it.
    start, goal : sequence of float
        Working CRS (metres; a yaw in radians optional).
    deadline : float, optional
        Seconds; default ``deadline_factor`` times the best plan's duration at its best
        speed (so that it binds).
    time, seed, progress
        The energy-optimal route's planning
        (:func:`~energy_planner.planning.compare.compare_routes`).

    Returns
    -------
    SpeedScene
    """
    with warnings.catch_warnings():  # the model's baseline gait is no category it names
        warnings.filterwarnings("ignore", message="channel 'gait'")
        return _scene(problem, start, goal, deadline, deadline_factor, time, seed, progress)


def _scene(problem, start, goal, deadline, deadline_factor, time, seed, progress) -> SpeedScene:
    from energy_planner.planning.compare import compare_routes
    from energy_planner.planning.plan import plan
    from energy_planner.planning.speed import with_speed

    gaits = _gaits(problem.model)
    v = float(problem.request.robot.speed)
    home = [g for g, (lo, hi) in gaits.items() if lo <= v <= hi]
    if not home:
        raise PlanningConfigError(
            f"the nominal speed {v:g} m/s is in no gait's logged speeds "
            f"({', '.join(f'{g} {lo:.2f}-{hi:.2f}' for g, (lo, hi) in gaits.items())})",
            value=v,
            param="speed",
        )
    gait0 = min(home, key=lambda g: gaits[g][1] - gaits[g][0])  # the narrowest holding it
    fixed = _gait_problem(problem, gait0)
    span = (min(lo for lo, _ in gaits.values()), max(hi for _, hi in gaits.values()))
    comp = compare_routes(fixed, start, goal, time=time, seed=seed, progress=progress)
    rows, states = [], {}
    for name in SCENE_ROUTES:
        r = comp.route(name)
        st = r.states if r.feasible and r.states is not None else None
        if st is None and r.same_as:
            st = comp.route(r.same_as).states
        states[name] = st
        fixed_j = None if st is None else float(r.energy_j if r.energy_j is not None else 0)
        row = {"route": name, "fixed_j": fixed_j,
               "fixed_s": None if st is None else float(r.duration_s)}  # fmt: skip
        e, s, g = (None, None, None) if st is None else _timed(problem, st, span, name)
        row.update(best_j=e, best_s=s, best_gait=g)
        rows.append(row)
    opt = next(r for r in rows if r["route"] == "energy_optimal")
    if opt["best_j"] is None:
        raise EnergyPlannerError("the energy-optimal route cannot be walked at any speed")
    row = {"route": PLANNED, "fixed_j": None, "fixed_s": None, "best_j": None, "best_s": None,
           "best_gait": None}  # fmt: skip
    states[PLANNED] = None
    try:  # the route planned with each motion's gait and speed chosen
        found = plan(with_speed(problem, span), start, goal, time=time, seed=seed,
                     progress=progress)  # fmt: skip
    except EnergyPlannerError:
        found = None
    if found is not None:
        states[PLANNED] = np.asarray(found.states, float)
        row.update(best_j=float(found.energy_j), best_s=float(found.duration_s),
                   best_gait=_gait_label(found.gaits))  # fmt: skip
    rows.append(row)
    best = min((r for r in rows[-2:] if r["best_j"] is not None), key=lambda r: r["best_j"])
    if deadline is None:
        deadline = deadline_factor * best["best_s"]
    for row in rows:
        st = states[row["route"]]
        e, s, g = (None, None, None) if st is None else _timed(problem, st, span, row["route"],
                                                               deadline)  # fmt: skip
        row.update(deadline_j=e, deadline_s=s, deadline_gait=g)
    direct = rows[0]
    base = direct["fixed_j"]
    speed_only = _timed(fixed, states["energy_optimal"], gaits[gait0], "route")[0]
    parts = {
        "body_yaw": base - rows[1]["fixed_j"],
        "route": rows[1]["fixed_j"] - opt["fixed_j"],
        "speed": opt["fixed_j"] - speed_only,
        "gait": speed_only - opt["best_j"],
        "route_with_speed": opt["best_j"] - best["best_j"],
    }
    parts["total_j"] = sum(parts.values())
    notes = [
        f"Routes planned at {v:g} m/s, then retimed (poses kept): each motion in its",
        "least-energy gait and speed, each gait within its logged speeds",
        "(" + ", ".join(f"{g} {lo:.2f}-{hi:.2f} m/s" for g, (lo, hi) in gaits.items()) + ");",
        f"mixed: the motions walk both. {PLANNED}: planned with the gaits and",
        "speeds chosen (replanned: what it saves on the energy-optimal route retimed).",
        "Under the deadline: each route's least-energy timing in time (cannot: too slow",
        "even at the top speed).",
    ]
    return SpeedScene(nominal_speed=v, nominal_gait=gait0, gaits=gaits, deadline_s=float(deadline),
                      rows=rows, parts=parts, baseline_j=base, notes=notes)  # fmt: skip
