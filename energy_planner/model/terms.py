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
twist, linear in the twist per direction of motion. Moving along the body direction
``beta`` the grade is ``sin(alpha) * cos(gamma + beta)``: forward ``sin a cos g``,
backward ``-sin a cos g``, left ``-sin a sin g``, right ``+sin a sin g``. Left and right
share coefficients (right is the mirror of left), which makes the lateral grade term
``-vy sin(alpha) sin(gamma)`` for either direction. Every base term satisfies the mirror
symmetry ``P(alpha, gamma, vx, vy, wz) = P(alpha, -gamma, vx, -vy, -wz)``.

Examples
--------
>>> sorted(BASE_TERMS)[:3]
['bwd_const', 'bwd_grade', 'fwd_const']
>>> CATALOG["cross_slope_roll"].formula
'speed * sin(alpha) * abs(sin(gamma))'
>>> resolve_term("payload_kg*speed*sin(alpha)").name
'payload_kg * speed * sin(alpha)'
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from energy_planner.errors import FormulaError, ModelError
from energy_planner.model.formula import Formula, parse_formula

__all__ = ["Term", "CATALOG", "BASE_TERMS", "EFFECT_TERMS", "resolve_term", "KINDS"]

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


_BASE = [
    _t("fwd_const", "pos(vx)", "force to walk forward on level ground", "N", "forward"),
    _t(
        "fwd_grade",
        "pos(vx) * sin(alpha) * cos(gamma)",
        "extra force per unit grade walking forward (gravity work, divided by efficiency)",
        "N",
        "forward",
    ),
    _t("bwd_const", "pos(-vx)", "force to walk backward on level ground", "N", "backward"),
    _t(
        "bwd_grade",
        "-pos(-vx) * sin(alpha) * cos(gamma)",
        "extra force per unit grade walking backward",
        "N",
        "backward",
    ),
    _t("lat_const", "abs(vy)", "force to walk sideways on level ground", "N", "lateral"),
    _t(
        "lat_grade",
        "-vy * sin(alpha) * sin(gamma)",
        "extra force per unit grade walking sideways (left and right mirror each other)",
        "N",
        "lateral",
    ),
    _t("turn_const", "abs(wz)", "torque to turn in place on level ground", "N m", "turning"),
    _t(
        "turn_slope",
        "abs(wz) * sin(alpha)",
        "extra turning torque per unit of sin(slope): stabilising while reorienting",
        "N m",
        "turning",
    ),
]

_EFFECTS = [
    _t(
        "idle_power",
        "1",
        "standing power: electronics and holding the body up cost energy even at rest",
        "W",
        "other",
    ),
    _t(
        "speed_dependence",
        "speed ** 2",
        "leg swing and damping losses grow with speed, so the force per metre grows with speed",
        "N s/m",
        "other",
    ),
    _t(
        "joule_heating",
        "sin(alpha) ** 2",
        "motor current grows with the supporting force the legs hold against the slope; "
        "I^2 R loss grows with its square",
        "W",
        "other",
    ),
    _t(
        "downhill_braking",
        "pos(-sin(alpha) * (vx * cos(gamma) - vy * sin(gamma)))",
        "uphill/downhill asymmetry: descending, the legs brake the body and dissipate "
        "instead of regenerating",
        "N",
        "other",
    ),
    _t(
        "cross_slope_roll",
        "speed * sin(alpha) * abs(sin(gamma))",
        "with the slope to one side the robot holds its roll and loads its downhill legs",
        "N",
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
CATALOG: dict[str, Term] = {t.name: t for t in (*_BASE, *_EFFECTS)}
#: The paper's model (wrench from alpha and gamma only).
BASE_TERMS: tuple[str, ...] = tuple(t.name for t in _BASE)
#: The catalog's physical effects, none of which the base model contains.
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
    return Term(name=parsed.text, formula=parsed.text)
