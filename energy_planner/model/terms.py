"""The term library: the paper's wrench model and a catalog of physical effects.

Every term is one coefficient times a formula over per-sample features (see
:mod:`energy_planner.model.formula`). Power is linear in the coefficients, so a model is
fitted by least squares and a new physical effect is one more line in :data:`CATALOG`.

Conventions (design notes): ``alpha`` is the slope angle, ``gamma`` the signed heading
relative to uphill (0 facing uphill, +pi/2 with uphill on the robot's right), measured
in the slope plane as the IMU sees it: ``tan(gamma) = tan(theta - psi) cos(alpha)``, equal
to ``wrap(theta - psi)`` on the fall line and across it. ``(vx, vy, wz)`` is the body
twist (REP-103: x forward, y left), along the ground.

The base set is the paper's wrench ``f(alpha, gamma) = (fx, fy, tau)`` applied to the
twist (Fig. 4 and Fig. 5 of the paper), plus what a legged robot draws per second whatever
it does. With ``sx = sin(alpha) cos(gamma)`` and ``sy = sin(alpha) sin(gamma)`` the grades
along and across the body, and per direction of motion ``d`` (forward, backward, lateral;
left is the mirror of right) its rate ``r`` (``pos(vx)``, ``pos(-vx)``, ``abs(vy)``, m/s)
and the grade along the travel ``G`` (``sx``, ``-sx``, ``-sign(vy) sy``)::

    P = sum_d [ c0_d r_d^2 / max(speed, 0.05) + c_up_d r_d pos(G_d) + c_down_d r_d pos(-G_d) ]
        + abs(wz) (t0 + t1 sin(alpha))
        + idle + k_x sx^2 + k_y sy^2 + (brake levers) + (side-stepping holding)

The per-metre pair ``c_up``/``c_down`` is a kink at level: lifting the body costs gravity
work through the drive efficiency, lowering it returns a gait-dependent fraction (Fig. 4:
downhill gets cheaper only walking forward; sideways it worsens). The level force of each
gait is weighted by its squared direction cosine, so walking obliquely costs a weighted
mean, not the sum, of the gaits' forces. The per-second terms are the standing power and
the copper (Joule) losses of the legs holding the slope load, which grow with the square
of that load along (``tilt_x_sq``) and across (``tilt_y_sq``, the cross slope, whichever
side it falls to) the body, with other levers when braking downhill and when
side-stepping; they make the cost per metre uphill convex, so that on steep ground a
detour beats the direct climb (:func:`energy_planner.model.critical_grade`). Turning in
place costs a torque growing with slope (Fig. 5) plus the same per-second terms. Every
term satisfies the mirror symmetry ``P(alpha, gamma, vx, vy, wz) = P(alpha, -gamma, vx,
-vy, -wz)``; along one direction of motion the per-metre terms are linear in the rate (the
paper's superposition), and energy stays additive along a path with the per-second terms.

Standing costs less per second than walking: the running gait (stance legs carrying the
body with peak forces, swing legs lifted) draws ``gait_power`` on top of the standing
power ``idle``, and copper losses of holding the slope along the body
(``gait_tilt_x_sq``) on top of standing's ``k_x sx^2``, while the robot walks or turns
(:data:`STANDING_TERMS`, fitted when the logs hold standing: without it the two cannot be
told apart and the walking values stand for both).

Examples
--------
>>> BASE_TERMS[:3]
('fwd_const', 'fwd_up', 'fwd_down')
>>> CATALOG["tilt_y_sq"].formula
'(sin(alpha) * sin(gamma)) ** 2'
>>> resolve_term("payload_kg*speed*sin(alpha)").name
'payload_kg * speed * sin(alpha)'
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from energy_planner.errors import FormulaError, ModelError
from energy_planner.model.formula import Formula, parse_formula

__all__ = [
    "Term",
    "CATALOG",
    "BASE_TERMS",
    "STANDING_TERMS",
    "SPEED_TERMS",
    "EFFECT_TERMS",
    "GAIT_CHANNEL",
    "gait_terms",
    "resolve_term",
    "KINDS",
]

#: What kind of work a term stands for; used for the forward/lateral/turning shares.
KINDS = ("forward", "backward", "lateral", "turning", "other")


@dataclass(frozen=True)
class Term:
    """One model term: a coefficient times ``formula``.

    Parameters
    ----------
    name : str
        Unique name (a catalog name, or the canonical formula text for custom terms).
    formula : str
        Formula over per-sample features.
    explanation : str
        One line: the physical effect this term stands for.
    unit : str
        Unit of the coefficient (power is in W).
    kind : str
        One of :data:`KINDS`.
    """

    name: str
    formula: str
    explanation: str = "user-defined term"
    unit: str = "W per unit of the formula"
    kind: str = "other"

    @cached_property
    def parsed(self) -> Formula:
        """The parsed formula."""
        return parse_formula(self.formula)

    @property
    def variables(self) -> frozenset[str]:
        """Feature names the term reads."""
        return self.parsed.variables

    def to_dict(self) -> dict[str, str]:
        """JSON-ready description."""
        return {
            "name": self.name,
            "formula": self.formula,
            "explanation": self.explanation,
            "unit": self.unit,
            "kind": self.kind,
        }


def _t(name: str, formula: str, explanation: str, unit: str, kind: str) -> Term:
    return Term(name, parse_formula(formula).text, explanation, unit, kind)


#: Directions of motion of the base: (prefix, kind, rate, rate weighted by the squared
#: direction cosine, grade along the travel, its negative, words for the explanations).
_DIRECTIONS = (
    (
        "fwd",
        "forward",
        "pos(vx)",
        "pos(vx) ** 2 / max(speed, 0.05)",
        "sin(alpha) * cos(gamma)",
        "-sin(alpha) * cos(gamma)",
        "walking forward",
    ),
    (
        "bwd",
        "backward",
        "pos(-vx)",
        "pos(-vx) ** 2 / max(speed, 0.05)",
        "-sin(alpha) * cos(gamma)",
        "sin(alpha) * cos(gamma)",
        "walking backward",
    ),
    (
        "lat",
        "lateral",
        "abs(vy)",
        "vy ** 2 / max(speed, 0.05)",
        "-sign(vy) * sin(alpha) * sin(gamma)",
        "sign(vy) * sin(alpha) * sin(gamma)",
        "side-stepping (left mirrors right)",
    ),
)


def _direction_terms(
    prefix: str, kind: str, r: str, r_mix: str, g: str, neg_g: str, words: str
) -> list[Term]:
    return [
        _t(
            f"{prefix}_const",
            r_mix,
            f"force {words} on level ground: touch-down losses, leg swing and gearbox "
            "friction per metre (walking obliquely, each gait's force is weighted by its "
            "squared direction cosine)",
            "N",
            kind,
        ),
        _t(
            f"{prefix}_up",
            f"{r} * pos({g})",
            f"extra force per unit uphill grade {words}: gravity work lifting the body, "
            "paid through the drive efficiency (about m g / efficiency)",
            "N",
            kind,
        ),
        _t(
            f"{prefix}_down",
            f"{r} * pos({neg_g})",
            f"change of force per unit downhill grade {words}: negative where the gait "
            "returns part of the released potential energy, about 0 where it brakes it",
            "N",
            kind,
        ),
    ]


#: Grade along the body x axis and across it (the slope the legs hold, whatever the motion).
_TILT_X = "sin(alpha) * cos(gamma)"
_TILT_Y = "sin(alpha) * sin(gamma)"

_BASE = [
    *(t for d in _DIRECTIONS for t in _direction_terms(*d)),
    _t(
        "turn_const",
        "abs(wz)",
        "torque to turn in place on level ground: twisting the planted feet",
        "N m",
        "turning",
    ),
    _t(
        "turn_slope",
        "abs(wz) * sin(alpha)",
        "extra turning torque per unit of sin(slope): re-balancing the tangential gravity "
        "load while the support pattern rotates",
        "N m",
        "turning",
    ),
    _t(
        "idle_power",
        "1",
        "power drawn per second whatever the motion, standing included: electronics, and the "
        "copper losses of holding the body up (with no standing in the logs, also the "
        "running gait's power, gait_power)",
        "W",
        "other",
    ),
    _t(
        "tilt_x_sq",
        f"({_TILT_X}) ** 2",
        "copper (I^2 R) losses per second of the legs pushing or holding the slope load "
        "along the body x axis: they grow with the square of that force",
        "W",
        "other",
    ),
    _t(
        "tilt_y_sq",
        f"({_TILT_Y}) ** 2",
        "copper losses per second of holding the sideways slope load and the roll moment "
        "(cross slope), whichever side the slope falls to",
        "W",
        "other",
    ),
    _t(
        "fwd_brake_sq",
        f"min(pos(vx) / 0.05, 1) * pos(-{_TILT_X}) ** 2",
        "walking forward downhill the legs brake through a shorter lever than they push "
        "with: change of the copper losses along x (per second; fully on above 0.05 m/s)",
        "W",
        "forward",
    ),
    _t(
        "bwd_brake_sq",
        f"min(pos(-vx) / 0.05, 1) * pos({_TILT_X}) ** 2",
        "walking backward downhill the legs brake through hip and knee: change of the "
        "copper losses along x (per second; fully on above 0.05 m/s)",
        "W",
        "backward",
    ),
    _t(
        "lat_tilt_sq",
        f"(vy / max(speed, 0.05)) ** 2 * ({_TILT_Y}) ** 2",
        "side-stepping, the sideways slope load goes through the hip ab/adduction joints "
        "(a longer lever than the wide stance of forward walking): extra copper losses",
        "W",
        "lateral",
    ),
]

#: The running gait: on while walking or turning in place, fully above 0.05 m/s or rad/s.
_GAIT = "min(max(speed, abs(wz)) / 0.05, 1)"

#: Walking or turning on top of standing (fitted when the logs hold standing windows).
_STANDING = [
    _t(
        "gait_power",
        _GAIT,
        "power the running gait draws per second on top of standing, whatever the direction: "
        "stance legs carry the body with peak forces (copper losses) and swing legs are "
        "lifted (paid while walking or turning in place; fully on above 0.05 m/s or rad/s)",
        "W",
        "other",
    ),
    _t(
        "gait_tilt_x_sq",
        f"{_GAIT} * ({_TILT_X}) ** 2",
        "walking, the stance legs hold the slope load along body x with peak forces (a "
        "half-sine stance force: the mean of its square grows by pi^2 / (8 duty factor)): "
        "copper losses on top of standing's tilt_x_sq (across the slope the wide stance holds "
        "the load on short levers, standing or walking: tilt_y_sq prices both)",
        "W",
        "other",
    ),
]

#: How the cost depends on the walking speed (fitted when the logs span a range of speeds,
#: ``calibration.fit.speed_support``): with them the cost per metre has an optimum speed.
_SPEED = [
    *(
        _t(
            f"{prefix}_speed_sq",
            rate,
            f"force per metre {words} that grows with speed: touch-downs per second and "
            "their impact speed both grow with it",
            "N s/m",
            kind,
        )
        for prefix, kind, rate, words in (
            ("fwd", "forward", "pos(vx) ** 2", "walking forward"),
            ("bwd", "backward", "pos(-vx) ** 2", "walking backward"),
            ("lat", "lateral", "vy ** 2", "side-stepping"),
        )
    ),
    _t(
        "speed_cubed",
        "speed ** 3",
        "swing-leg losses: the legs swing faster and more often as the robot speeds up, so "
        "their kinetic losses grow faster than the square of the speed per metre",
        "W s^3/m^3",
        "other",
    ),
    _t(
        "speed_tilt_x_sq",
        f"speed * ({_TILT_X}) ** 2",
        "the stance shortens as the robot speeds up, so the copper losses of holding the "
        "slope load along the body grow with speed (peak forces grow as the stance shortens)",
        "W s/m",
        "other",
    ),
    _t(
        "speed_tilt_y_sq",
        f"speed * ({_TILT_Y}) ** 2",
        "the copper losses of holding the cross slope grow with speed (shorter stance)",
        "W s/m",
        "other",
    ),
    _t(
        "speed_fwd_brake_sq",
        f"speed * min(pos(vx) / 0.05, 1) * pos(-{_TILT_X}) ** 2",
        "braking walking forward downhill: its copper losses grow with speed (shorter stance)",
        "W s/m",
        "forward",
    ),
]

#: The categorical log channel that names the gait (``walk``, ``trot``, ...), as legged
#: controllers report it; its terms: :func:`gait_terms`.
GAIT_CHANNEL = "gait"

#: Per gait other than the reference one: (formula times the gait's indicator, what it is).
_GAIT_SHAPES = (
    ("1", "power per second of {g} over {ref} (stance copper losses, foot lifting)", "W"),
    ("speed", "force per metre of {g} over {ref} (touch-downs, gearbox)", "N"),
    ("speed ** 2", "swing and impact losses of {g} over {ref}, growing with speed", "N s/m"),
    (f"({_TILT_X}) ** 2", "copper losses of holding the slope along the body, {g} over {ref}",
     "W"),
    (f"({_TILT_Y}) ** 2", "copper losses of holding the cross slope, {g} over {ref}", "W"),
    (f"min(pos(vx) / 0.05, 1) * pos(-{_TILT_X}) ** 2",
     "braking walking forward downhill, {g} over {ref}", "W"),
)  # fmt: skip


def gait_terms(gaits: list[str] | tuple[str, ...], reference: str) -> list[Term]:
    """The terms of a gait channel: each gait but ``reference`` differs from it.

    A gait changes the stance (duty factor), the stride and the touch-downs, so per gait
    the standing-like per-second power, the force per metre, its growth with speed and
    the copper losses of holding a slope differ: :data:`_GAIT_SHAPES` times the gait's
    indicator ``(gait == 'g')`` on the categorical channel :data:`GAIT_CHANNEL`.

    Examples
    --------
    >>> [t.name for t in gait_terms(["walk", "trot"], "walk")][:2]
    ["gait == 'trot'", "(gait == 'trot') * speed"]
    """
    out = []
    for g in gaits:
        if g == reference:
            continue
        is_g = f"({GAIT_CHANNEL} == {g!r})"
        for shape, words, unit in _GAIT_SHAPES:
            text = parse_formula(is_g if shape == "1" else f"{is_g} * {shape}").text
            out.append(Term(text, text, words.format(g=g, ref=reference), unit, "other"))
    return out


_EFFECTS = [
    _t(
        "speed_dependence",
        "speed ** 2",
        "leg swing and damping losses grow with speed, so the force per metre grows with speed",
        "N s/m",
        "other",
    ),
    _t(
        "turn_while_walking",
        "abs(wz) * speed",
        "turning while walking adds lateral foot slip and re-stepping",
        "N s",
        "other",
    ),
    _t(
        "acceleration",
        "pos(ax * vx + ay * vy)",
        "speeding up costs kinetic energy that is not recovered when slowing down",
        "kg",
        "other",
    ),
    _t(
        "payload",
        "payload_kg * speed",
        "carried mass adds to the weight the legs carry at every step",
        "N/kg",
        "other",
    ),
]

#: Every named term: the base set and the physical effects.
CATALOG: dict[str, Term] = {t.name: t for t in (*_BASE, *_STANDING, *_SPEED, *_EFFECTS)}
#: The paper's model (wrench from alpha and gamma only).
BASE_TERMS: tuple[str, ...] = tuple(t.name for t in _BASE)
#: Added to the base model when the logs hold standing (``calibration.fit.base_terms``):
#: then ``idle_power`` is the standing power and ``gait_power`` what walking adds to it.
#: Without standing they cannot be told apart, and ``idle_power`` holds both.
STANDING_TERMS: tuple[str, ...] = tuple(t.name for t in _STANDING)
#: Added to the base model when the logs span a range of walking speeds
#: (``calibration.fit.speed_support``): how the cost depends on speed.
SPEED_TERMS: tuple[str, ...] = tuple(t.name for t in _SPEED)
#: The catalog's physical effects, none of which the base model contains (uphill/downhill
#: asymmetry, cross-slope roll and copper losses on slopes are base terms now).
EFFECT_TERMS: tuple[str, ...] = tuple(t.name for t in _EFFECTS)


def resolve_term(spec: str | Term) -> Term:
    """Turn a catalog name or a formula into a :class:`Term`.

    Parameters
    ----------
    spec : str or Term
        A name from :data:`CATALOG`, or a formula such as ``payload_kg * speed``.

    Raises
    ------
    FormulaError
        If ``spec`` is neither a catalog name nor a valid formula; the message lists the
        catalog names.
    """
    if isinstance(spec, Term):
        return spec
    if not isinstance(spec, str):
        raise ModelError(f"a term is a catalog name or a formula string, got {spec!r}")
    if spec in CATALOG:
        return CATALOG[spec]
    try:
        parsed = parse_formula(spec)
    except FormulaError as exc:
        raise FormulaError(
            f"{exc} (a term is a catalog name - {', '.join(CATALOG)} - or a formula)"
        ) from exc
    return _known_gait_term(parsed.text) or Term(name=parsed.text, formula=parsed.text)


def _known_gait_term(text: str) -> Term | None:
    """A gait channel's term (:func:`gait_terms`) written as its formula, explained.

    >>> _known_gait_term("(gait == 'trot') * speed").unit
    'N'
    """
    import re

    m = re.fullmatch(rf"\(?{GAIT_CHANNEL} == '([^']+)'\)?(?: \* (.+))?", text)
    if m is None:
        return None
    shape = parse_formula(m.group(2)).text if m.group(2) else "1"
    for form, words, unit in _GAIT_SHAPES:
        if (parse_formula(form).text if form != "1" else "1") == shape:
            expl = words.format(g=m.group(1), ref="the reference gait")
            return Term(text, text, expl, unit, "other")
    return None
