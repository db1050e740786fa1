"""The paper's B1 base model written out as explicit terms, for hand-worked energy tests.

The catalog's base terms are the model engineer's to change; tests that check energies
by hand need terms that stay what they are, so they build the model from these formulas
(names prefixed ``b1_`` so that they never collide with catalog names).

>>> float(b1_model().power({"alpha": 0.0, "gamma": 0.0, "vx": 1.0, "vy": 0.0, "wz": 0.0})[0])
600.0
"""

from __future__ import annotations

from energy_planner.model import EnergyModel
from energy_planner.model.formula import parse_formula
from energy_planner.model.terms import Term

#: Coefficients by the paper's term names (N, or N m for turning).
B1 = {
    "fwd_const": 600.0, "fwd_grade": 1000.0, "bwd_const": 700.0, "bwd_grade": 1000.0,
    "lat_const": 800.0, "lat_grade": 900.0, "turn_const": 250.0, "turn_slope": 300.0,
}  # fmt: skip

_FORMULAS = {
    "fwd_const": ("pos(vx)", "forward"),
    "fwd_grade": ("pos(vx) * sin(alpha) * cos(gamma)", "forward"),
    "bwd_const": ("pos(-vx)", "backward"),
    "bwd_grade": ("-pos(-vx) * sin(alpha) * cos(gamma)", "backward"),
    "lat_const": ("abs(vy)", "lateral"),
    "lat_grade": ("-vy * sin(alpha) * sin(gamma)", "lateral"),
    "turn_const": ("abs(wz)", "turning"),
    "turn_slope": ("abs(wz) * sin(alpha)", "turning"),
}

#: The B1 terms, in the paper's order.
B1_TERMS = tuple(
    Term(f"b1_{name}", parse_formula(f).text, f"B1 base term {name}", "N", kind)
    for name, (f, kind) in _FORMULAS.items()
)


def b1_model(coefficients=None, extra=None) -> EnergyModel:
    """The B1 model (``coefficients`` by the paper's names, default :data:`B1`), plus
    ``extra`` terms ``{formula: coefficient}``."""
    c = dict(B1 if coefficients is None else coefficients)
    extra = dict(extra or {})
    terms = [*B1_TERMS, *extra]
    coefs = {f"b1_{k}": float(v) for k, v in c.items()} | extra
    return EnergyModel(terms, coefs)
