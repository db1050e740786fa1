"""Ground-truth physics of the simulator: the base wrench plus switchable effects.

The truth is an ordinary :class:`~energy_planner.model.EnergyModel`: the paper's base
terms (:data:`~energy_planner.model.BASE_TERMS`) with B1-class coefficients
(:data:`BASE_COEFFICIENTS`), plus one term per switched-on effect from :data:`EFFECTS`.
With no effect switched on, the truth lies exactly inside the base model, so a perfect
calibration recovers :data:`BASE_COEFFICIENTS` up to sensor effects.

Base coefficients (about 50 kg robot, ``m g = 490 N``; level ground at 0.3 m/s costs
``600 N * 0.3 m/s = 180 W`` forward):

============  ========  =====================================================
term          value     why
============  ========  =====================================================
fwd_const     600 N     cost of transport ~1.2 at 0.3 m/s (B1-class)
fwd_grade     1000 N    ``m g / efficiency`` = 490 N / 0.49
bwd_const     700 N     backward gait is less efficient than forward
bwd_grade     1000 N    same gravity work as forward
lat_const     800 N     side stepping is the least efficient gait
lat_grade     900 N     gravity work sideways, slightly better efficiency
turn_const    250 N m   turning in place (per rad/s)
turn_slope    300 N m   extra stabilisation while turning on a slope
============  ========  =====================================================

Downhill at 25 degrees forward still costs ``600 - 1000 sin 25° = 177 N``, backward
``700 - 423 = 277 N`` and sideways ``800 - 900 sin 25° = 420 N``: power never goes
negative in the campaign, so the model's floor at zero is never active.

Examples
--------
>>> m = truth_model(("idle_power",))
>>> m.term_names[-1], m.coefficients["idle_power"]
('idle_power', 20.0)
>>> truth_model().term_names == list(BASE_TERMS)
True
>>> sorted(EFFECTS)[:3]
['acceleration', 'cold_joints', 'cross_slope_roll']
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from energy_planner.errors import ModelError
from energy_planner.model import BASE_TERMS, CATALOG, EnergyModel, Term, parse_formula

__all__ = ["Effect", "EFFECTS", "BASE_COEFFICIENTS", "truth_model", "check_effects"]

#: True coefficients of the paper's base terms (units: N for forces, N m for torques).
BASE_COEFFICIENTS: dict[str, float] = {
    "fwd_const": 600.0,
    "fwd_grade": 1000.0,
    "bwd_const": 700.0,
    "bwd_grade": 1000.0,
    "lat_const": 800.0,
    "lat_grade": 900.0,
    "turn_const": 250.0,
    "turn_slope": 300.0,
}


@dataclass(frozen=True)
class Effect:
    """One physical effect the simulator can switch on: a single model term.

    Attributes
    ----------
    name : str
        Effect name (``--effect NAME``); also the term name in the truth model.
    formula : str
        Term formula over per-sample features (see :mod:`energy_planner.model.formula`).
    coefficient : float
        True coefficient, in ``unit``.
    unit : str
        Unit of the coefficient (power is in W).
    explanation : str
        One line: the physics behind the term.
    needs : tuple of str
        What a campaign must contain for the effect to be visible and identifiable.
    catalog : bool
        True when :data:`energy_planner.model.CATALOG` names this effect; False for the
        effects a diagnosis has to find from the extra log channels.
    """

    name: str
    formula: str
    coefficient: float
    unit: str
    explanation: str
    needs: tuple[str, ...] = ()
    catalog: bool = False

    @property
    def term(self) -> Term:
        """The model term (the catalog's own :class:`Term` for catalog effects)."""
        if self.catalog:
            return CATALOG[self.name]
        return Term(self.name, parse_formula(self.formula).text, self.explanation, self.unit)

    @property
    def variables(self) -> frozenset[str]:
        """Feature names the effect's term reads."""
        return parse_formula(self.formula).variables


def _cat(name: str, coefficient: float, needs: tuple[str, ...]) -> Effect:
    t = CATALOG[name]
    return Effect(name, t.formula, coefficient, t.unit, t.explanation, needs, catalog=True)


#: Every effect the simulator knows: name -> :class:`Effect`. Strengths are chosen so that
#: each effect carries roughly 5-15 % of the mean power of the runs it acts on.
EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        _cat("idle_power", 20.0, ("stand runs (CampaignConfig.stand) or several speeds",)),
        _cat(
            "speed_dependence",
            300.0,
            ("several speeds, e.g. CampaignConfig(speeds=(0.2, 0.3, 0.45))",),
        ),
        _cat("joule_heating", 300.0, ("several slopes", "stand runs help")),
        _cat("downhill_braking", 400.0, ("downhill runs at several slopes",)),
        _cat("cross_slope_roll", 400.0, ("cross-slope headings at several slopes",)),
        _cat("turn_while_walking", 600.0, ("arc runs (CampaignConfig.arcs)",)),
        _cat(
            "acceleration",
            400.0,
            ("speed ramps at run start and end (CampaignConfig.ramp_s > 0)",),
        ),
        Effect(
            "surface_type",
            "speed * (surface == 'mud')",
            250.0,
            "N",
            "walking in mud costs extra force per metre (sinking feet, suction)",
            ("channel surface varies between runs (grass, gravel, mud, asphalt)",),
        ),
        _cat("payload", 10.0, ("channel payload_kg varies between runs (0, 5, 10, 15 kg)",)),
        Effect(
            "cold_joints",
            "pos(15 - temperature_c)",
            4.0,
            "W/K",
            "below 15 C gearbox grease stiffens: friction power grows as the air gets colder",
            ("channel temperature_c varies between runs (0..30 C)",),
        ),
        Effect(
            "vegetation_drag",
            "grass_height_m * speed",
            500.0,
            "N/m",
            "tall grass drags on the legs: force per metre grows with the grass height",
            ("channel grass_height_m varies between runs (0..0.4 m)",),
        ),
    )
}


def check_effects(effects: Iterable[str]) -> tuple[str, ...]:
    """Validate effect names; return them in order without duplicates.

    Raises
    ------
    ModelError
        Naming the unknown effect and listing the valid ones.

    Examples
    --------
    >>> check_effects(["payload", "idle_power", "payload"])
    ('payload', 'idle_power')
    """
    if isinstance(effects, str):
        effects = (effects,)
    out: list[str] = []
    for name in effects:
        if name not in EFFECTS:
            raise ModelError(
                f"unknown effect {name!r}; valid effects: {', '.join(sorted(EFFECTS))}"
            )
        if name not in out:
            out.append(name)
    return tuple(out)


def truth_model(effects: Iterable[str] = (), **overrides: float) -> EnergyModel:
    """The truth physics used by the simulator, as an :class:`EnergyModel`.

    Parameters
    ----------
    effects : iterable of str
        Names from :data:`EFFECTS` to switch on (one term each, appended in order).
    **overrides : float
        Coefficient overrides by term name, e.g. ``truth_model(fwd_const=650.0)``.

    Returns
    -------
    EnergyModel
        Base terms with :data:`BASE_COEFFICIENTS` plus the effects' terms; its metadata
        records the effects.

    Raises
    ------
    ModelError
        Unknown effect, or an override for a term the model does not have.

    Examples
    --------
    >>> truth_model(fwd_const=650.0).coefficients["fwd_const"]
    650.0
    """
    names = check_effects(effects)
    terms: list[str | Term] = [*BASE_TERMS, *(EFFECTS[n].term for n in names)]
    coefs: dict[str, float] = dict(BASE_COEFFICIENTS)
    coefs.update({n: float(EFFECTS[n].coefficient) for n in names})
    unknown = sorted(set(overrides) - set(coefs))
    if unknown:
        raise ModelError(
            f"cannot override {', '.join(map(repr, unknown))}: not a term of this truth "
            f"model; its terms are {', '.join(coefs)}"
        )
    coefs.update({k: float(v) for k, v in overrides.items()})
    return EnergyModel(
        terms,
        coefs,
        metadata={
            "source": "energy_planner.simulate ground truth",
            "effects": list(names),
        },
    )


def effect_table(effects: Mapping[str, Effect] | None = None) -> list[dict[str, object]]:
    """Rows describing the effects (name, formula, coefficient, unit, explanation, needs)."""
    effects = EFFECTS if effects is None else effects
    return [
        {
            "name": e.name,
            "formula": e.formula,
            "coefficient": e.coefficient,
            "unit": e.unit,
            "explanation": e.explanation,
            "needs": list(e.needs),
            "catalog": e.catalog,
        }
        for e in effects.values()
    ]
