"""The cost per metre of walking up a grade and its critical grade (the physics of a detour).

Walking up a grade ``g`` (the sine of the path's inclination) costs ``c(g)`` joules per
metre, so a metre of height costs ``c(g) / g``; when ``c`` is convex that is least at the
critical grade ``g*``: on steeper ground a zig-zag at ``g*`` climbs for less energy than the
direct line (paper Fig. 1). :func:`grade_cost` computes ``c``, ``g*`` and the closed form
``sqrt(a / k)`` of a quadratic fit from a model, over the body yaws the gait may use
(the one cheapest way along a heading, :func:`energy_planner.energy.heading.heading_cost`);
:func:`critical_grade` is its summary as a dict (the model file's ``critical_grade``
metadata, facing the travel by default). This is the one critical-grade computation of
the models; the simulator keeps its own from its physics on purpose
(:func:`energy_planner.simulate.physics.critical_grade`: the truth a fit is checked
against).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.angles import wrap
from energy_planner.request import DEFAULT_SPEED

__all__ = ["GradeCost", "critical_grade", "grade_cost"]


@dataclass
class GradeCost:
    """The cost per metre of walking straight up a grade, and its critical grade.

    Attributes
    ----------
    grades : ndarray
        Grades ``g`` (sine of the inclination), from 0 up.
    cost_per_m : ndarray
        ``c(g)``: energy per metre along the ground, J/m (power / speed).
    critical_grade : float or None
        ``g*`` minimizing ``c(g) / g`` on the grid (refined by a parabola), or ``None``
        when ``c(g) / g`` keeps falling up to the steepest grade (a detour never pays
        by physics alone).
    quadratic : tuple of float
        ``(a, b, k)`` of the least-squares fit ``c = a + b g + k g^2`` on ``g <= g_fit``.
    closed_form_grade : float or None
        ``sqrt(a / k)`` when ``a > 0`` and ``k > 0``.
    body_yaw : ndarray
        The cheapest yaw of the body relative to the direction of travel at each grade,
        radians, measured in the slope plane like ``gamma`` (0: facing it; +-pi/2:
        sideways).
    """

    grades: np.ndarray
    cost_per_m: np.ndarray
    critical_grade: float | None
    quadratic: tuple[float, float, float]
    closed_form_grade: float | None
    body_yaw: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def per_height(self, g: float) -> float:
        """``c(g) / g``: J per metre of height climbed at grade ``g`` (> 0)."""
        return float(np.interp(g, self.grades, self.cost_per_m)) / g

    @staticmethod
    def deg(g: float | None) -> float | None:
        """A grade as the inclination in degrees (``asin(g)``)."""
        return None if g is None else math.degrees(math.asin(min(max(g, -1.0), 1.0)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        a, b, k = self.quadratic
        yaw = None
        if self.critical_grade is not None and self.body_yaw.size:
            i = int(np.argmin(np.abs(self.grades - self.critical_grade)))
            yaw = abs(math.degrees(float(self.body_yaw[i])))
        return {
            "body_yaw_at_critical_deg": yaw,
            "critical_grade": self.critical_grade,
            "critical_grade_deg": self.deg(self.critical_grade),
            "quadratic_a_b_k": [a, b, k],
            "closed_form_grade": self.closed_form_grade,
            "closed_form_grade_deg": self.deg(self.closed_form_grade),
        }


def grade_cost(
    model,
    speed: float = DEFAULT_SPEED,
    *,
    slope: float | None = None,
    max_grade: float = 0.8,
    fit_max_grade: float = 0.6,
    constants: dict[str, Any] | None = None,
    any_yaw: bool = True,
) -> GradeCost:
    """``c(g)``, the least energy per metre of walking up the fall line at grade ``g``.

    The least over the body's yaw relative to the direction of travel (forward,
    crabbing, sideways, backward: a model can make a diagonal gait cheaper than facing
    the slope), unless ``any_yaw`` is False (facing the direction of travel): the
    project's one cheapest way to move along a heading
    (:func:`energy_planner.energy.heading.heading_cost`, its continuous minimum over the
    yaw) on a plane of the grade's slope, per metre of ground.

    Parameters
    ----------
    model : EnergyModel
        The fitted model whose ``c(g)`` is wanted.
    speed : float
        Walking speed along the ground (m/s) at every grade.
    slope : float, optional
        Walk on a plane of this slope (sine of the slope angle) instead of up the fall
        line of each grade: grade ``g <= slope`` is travelled at the relative heading
        ``acos(g / slope)`` from uphill, so cross-slope terms count (a zig-zag or a spiral
        round a cone of that slope climbs this way). ``max_grade`` becomes ``slope``.
    max_grade : float
        Steepest grade evaluated (sine of the inclination).
    fit_max_grade : float
        Steepest grade used for the quadratic fit.
    constants : dict, optional
        Values of extra channels the model reads.
    any_yaw : bool
        Minimise over the body's yaw relative to the travel (else face the travel).

    Returns
    -------
    GradeCost

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> up, sq, other = ("pos(vx) * sin(alpha) * cos(gamma)", "pos(vx) * sin(alpha) ** 2",
    ...                  "pos(-vx) + abs(vy)")  # other gaits: dear
    >>> m = EnergyModel(["pos(vx)", up, sq, other],
    ...                 {"pos(vx)": 600.0, up: 1000.0, sq: 15000.0, other: 20000.0})
    >>> gc = grade_cost(m)
    >>> round(gc.critical_grade, 3), round(gc.closed_form_grade, 3), float(gc.body_yaw[0])
    (0.2, 0.2, 0.0)
    >>> m = EnergyModel(["pos(vx)", up, other], {"pos(vx)": 600.0, up: 1000.0, other: 2e4})
    >>> print(grade_cost(m).critical_grade)
    None
    """
    from energy_planner.energy.heading import heading_cost

    if slope is not None:
        max_grade = fit_max_grade = float(slope)
    g = np.linspace(0.0, max_grade, 801)
    # travel direction relative to uphill, in the slope plane (tau) and on the map (phi)
    tau = np.zeros(g.size) if slope is None else np.arccos(np.clip(g / slope, -1.0, 1.0))
    alpha = np.arcsin(g) if slope is None else np.full(g.size, math.asin(slope))
    phi = np.arctan2(np.sin(tau), np.cos(tau) * np.cos(alpha))
    # the one cheapest way along a heading (any yaw; or facing the travel: no crab, never
    # backward); J per map metre -> per metre of ground
    gait = {} if any_yaw else {"max_crab_deg": 0.0, "max_backward_slope_deg": -1.0}
    hc = heading_cost(model, speed=float(speed), constants=constants, **gait)
    per_map, r = hc.per_metre(np.tan(alpha), 0.0, phi)
    c = per_map / np.hypot(1.0, np.tan(alpha) * np.cos(phi))
    # the body's yaw from the travel, in the slope plane (as gamma is measured)
    theta = phi + r
    yaw = wrap(np.arctan2(np.sin(theta) * np.cos(alpha), np.cos(theta)) - tau)
    per_h = c[1:] / g[1:]
    i = int(np.argmin(per_h))
    crit: float | None
    if i >= per_h.size - 1:
        crit = None
    elif 0 < i:
        # parabola through the three grid points around the minimum
        y0, y1, y2 = per_h[i - 1 : i + 2]
        den = y0 - 2 * y1 + y2
        h = g[2] - g[1]
        crit = float(g[i + 1] + (0.5 * h * (y0 - y2) / den if den > 0 else 0.0))
    else:
        crit = float(g[1])
    m = g <= fit_max_grade
    a, b, k = (float(v) for v in np.polynomial.polynomial.polyfit(g[m], c[m], 2))
    closed = math.sqrt(a / k) if a > 0 and k > 0 else None
    return GradeCost(g, c, crit, (a, b, k), closed, yaw)


#: Relative residual below which ``c(g)`` counts as exactly quadratic (closed form).
QUADRATIC_TOL = 1e-9


def critical_grade(
    model: Any,
    speed: float = DEFAULT_SPEED,
    *,
    any_yaw: bool = False,
    max_slope_deg: float = 60.0,
) -> dict[str, Any]:
    """Grade beyond which a detour climbs a hill for less energy than the direct line.

    The summary of :func:`grade_cost` on grades up to ``max_slope_deg``: ``g*`` minimises
    ``c(g) / g``, the energy per metre of height. When ``c`` is exactly quadratic on that
    range (the base model: ``c(g) = fwd_const + idle_power / v + fwd_up g + tilt_x_sq g^2
    / v``), ``g* = sqrt(a / k)`` from its coefficients (``method = "closed form"``);
    otherwise the grid minimum refined by a parabola (``"numeric"``).

    Parameters
    ----------
    model, speed
        As :func:`grade_cost`.
    any_yaw : bool
        Take the cheapest body yaw (crab, sideways, backward) at each grade; default:
        face the direction of travel, as the paper's Fig. 1 does.
    max_slope_deg : float
        Steepest slope evaluated, degrees.

    Returns
    -------
    dict
        ``grade`` (g*; ``inf`` when ``c(g) / g`` keeps falling up to the steepest grade,
        so no detour pays by physics alone), ``slope_deg``, ``cost_n`` (c(g*), J/m),
        ``level_cost_n`` (c(0)) and ``method``.

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> m = EnergyModel(["fwd_const", "fwd_up", "idle_power", "tilt_x_sq"],
    ...     {"fwd_const": 100.0, "fwd_up": 700.0, "idle_power": 120.0, "tilt_x_sq": 600.0})
    >>> c = critical_grade(m)
    >>> round(c["grade"], 9), round(c["slope_deg"], 6), c["method"]
    (0.5, 30.0, 'closed form')
    """
    top = math.sin(math.radians(max_slope_deg))
    gc = grade_cost(model, speed, max_grade=top, fit_max_grade=top, any_yaw=any_yaw)
    g, c = gc.grades, gc.cost_per_m
    level = float(c[0])
    a, b, k = gc.quadratic
    fitted = a + b * g + k * g**2
    scale = max(float(np.max(np.abs(c))), 1e-300)
    quadratic = bool(np.all(np.isfinite(c))) and float(np.max(np.abs(fitted - c))) <= (
        QUADRATIC_TOL * scale
    )
    if quadratic:
        grade = gc.closed_form_grade if gc.closed_form_grade is not None else math.inf
        method = "closed form"
    else:
        grade = gc.critical_grade if gc.critical_grade is not None else math.inf
        method = "numeric"
    if not grade < top:  # c(g) / g still falling at the steepest grade evaluated
        return {
            "grade": math.inf,
            "slope_deg": 90.0,
            "cost_n": math.nan,
            "level_cost_n": level,
            "method": method,
        }
    return {
        "grade": float(grade),
        "slope_deg": math.degrees(math.asin(grade)),
        "cost_n": float(np.interp(grade, g, c)) if not quadratic else a + b * grade + k * grade**2,
        "level_cost_n": level,
        "method": method,
    }
