"""Energy model: formulas, the term library and :class:`EnergyModel`.

>>> from energy_planner.model import EnergyModel, BASE_TERMS
>>> EnergyModel(BASE_TERMS).term_names[:2]
['fwd_const', 'fwd_up']
"""

from energy_planner.model.formula import CONSTANTS, FUNCTIONS, Formula, parse_formula
from energy_planner.model.model import (
    SCHEMA,
    SCHEMA_VERSION,
    EnergyModel,
    prepare_features,
)
from energy_planner.model.terms import (
    BASE_TERMS,
    CATALOG,
    EFFECT_TERMS,
    GAIT_CHANNEL,
    KINDS,
    SPEED_TERMS,
    STANDING_TERMS,
    Term,
    gait_terms,
    resolve_term,
)

__all__ = [
    "BASE_TERMS",
    "CATALOG",
    "CONSTANTS",
    "EFFECT_TERMS",
    "FUNCTIONS",
    "KINDS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "STANDING_TERMS",
    "SPEED_TERMS",
    "GAIT_CHANNEL",
    "gait_terms",
    "EnergyModel",
    "Formula",
    "Term",
    "parse_formula",
    "prepare_features",
    "resolve_term",
]
