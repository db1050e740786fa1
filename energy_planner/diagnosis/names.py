"""Short names of discovered terms, and their resolution on the logs (``fit --term``).

See docs/diagnosis.md, *Short names of discovered terms*.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from energy_planner.calibration.windowdata import WindowData
from energy_planner.diagnosis.candidates import Candidate, canonical, default_candidates, hinge
from energy_planner.model.terms import Term

#: A discovered term whose formula is longer than this many characters is named in the
#: model by its candidate's short name (``load_kg*P_base``: a channel times the fitted base
#: power, hundreds of characters); a shorter one is named by its formula.
LONG_FORMULA = 80


def term_spec(term: str | Term) -> str:
    """What evaluates a term on windows: a catalog name as is, else its formula.

    >>> term_spec(Term("load_kg*P_base", "load_kg * (2 * (pos(vx)))"))
    'load_kg * (2 * pos(vx))'
    >>> term_spec("idle_power")
    'idle_power'
    """
    from energy_planner.model import CATALOG

    if isinstance(term, Term):
        return term.name if term.name in CATALOG else canonical(term.formula)
    return term


def model_term(name: str | None, formula: str, explanation: str = "") -> str | Term:
    """The term a discovered candidate adds to a model.

    Its formula when that is short (the name is then the formula), else a
    :class:`~energy_planner.model.Term` named ``name`` that carries the formula: the name
    is what messages print and ``fit --term`` takes (:func:`resolve_names`), the formula
    goes into the model file and the report.

    >>> model_term("x*speed", "x * speed")
    'x * speed'
    >>> t = model_term("x*P_base", "x * (" + " + ".join(["2 * pos(vx)"] * 20) + ")")
    >>> t.name, len(t.formula) > LONG_FORMULA
    ('x*P_base', True)
    """
    if name is None or len(formula) <= LONG_FORMULA:
        return formula
    return Term(name=name, formula=formula, explanation=explanation or "discovered term")


#: ``ch<q``, ``ch>q`` and ``speed*(ch<q)``: the names :func:`hinge` gives (any knot).
_HINGE_NAME = r"^(speed\*\()?([A-Za-z_]\w*)([<>])(-?[0-9.]+(?:e[-+]?[0-9]+)?)(\))?$"


def _candidate_named(spec: str, wd: WindowData, context: list[str]) -> Candidate | dict | None:
    """The candidate ``discover`` names ``spec`` on these windows after ``context``, or None."""
    import re

    m = re.match(_HINGE_NAME, spec)
    if m and bool(m.group(1)) == bool(m.group(5)):
        ch = m.group(2)
        if ch in wd.samples.columns or ch == "speed":
            times = "speed" if m.group(1) else ""
            return hinge(ch, float(m.group(4)), m.group(3) == "<", times=times)
    from energy_planner.errors import EnergyPlannerError

    try:
        cands, unsupported = default_candidates(wd, context)
    except EnergyPlannerError:  # logs discover could not rank: no name to look up
        return None
    found = next((c for c in cands if c.name == spec), None)
    return found or next((u for u in unsupported if u["name"] == spec), None)


def resolve_names(
    specs: Iterable[str], wd: WindowData, base_terms: Sequence[str] | None = None
) -> list[str | Term]:
    """Resolve term specs that are the names ``discover`` prints, in order, on these logs.

    A spec without spaces that is not a catalog name is looked up among the candidates
    discover tries on these windows with the base terms and the specs before it
    (:func:`default_candidates`, and any hinge knot ``ch<q``): ``load_kg*P_base`` becomes
    the channel times the base power fitted on these windows, as discover built it at that
    step, so ``fit --term`` with the names discover printed, in its order, fits the same
    terms. Anything else (a catalog name, a formula) is returned as given.

    Parameters
    ----------
    specs : iterable of str
        ``--term`` values.
    wd : WindowData
        The windows the terms will be fitted on.
    base_terms : sequence of str, optional
        The model the terms are added to; default the base model of these windows
        (:func:`energy_planner.calibration.fit.base_terms`, as ``discover`` starts).

    Returns
    -------
    list of str or Term
        Per spec: the spec, a formula, or a named :class:`~energy_planner.model.Term`
        (:func:`model_term`).

    Examples
    --------
    >>> import pandas as pd
    >>> s = pd.DataFrame({"run": ["a"] * 4, "t": [0, 1, 2, 3], "power": [1.0, 3, 5, 7],
    ...                   "window": [0, 0, 1, 1], "vx": 0.3, "vy": 0.0, "wz": 0.0,
    ...                   "alpha": 0.0, "gamma": 0.0, "load_kg": [0.0, 0, 5, 5]})
    >>> from energy_planner.diagnosis import window_data
    >>> resolve_names(["load_kg<2.5", "speed*(load_kg>1)", "idle_power", "vx * vy"],
    ...               window_data(s))
    ['pos(2.5 - load_kg)', 'speed * pos(load_kg - 1)', 'idle_power', 'vx * vy']
    """
    from energy_planner.calibration.fit import base_terms as default_base
    from energy_planner.model import CATALOG

    context = [term_spec(t) for t in (default_base(wd) if base_terms is None else base_terms)]
    out: list[str | Term] = []
    for spec in specs:
        found = None
        if spec not in CATALOG and " " not in spec:
            found = _candidate_named(spec, wd, context)
        if found is None:
            out.append(spec)
            context.append(spec)
            continue
        if isinstance(found, dict):
            name, formula, expl = found["name"], found["term"], ""
        else:
            name, formula, expl = found.name, found.term, found.explanation
        out.append(model_term(name, formula, expl))
        context.append(formula)
    return out
