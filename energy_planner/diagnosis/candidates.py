"""Candidate effects: one more term each, with its physical explanation.

Where the candidates come from (the catalog, every extra channel's family of shapes,
speed-change and speed shapes, the user's ``--term``) and how they are explained is told
in :mod:`energy_planner.diagnosis.suspects`, which scores and ranks them
(:mod:`energy_planner.diagnosis.scoring`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from energy_planner.calibration.windowdata import MAX_CATEGORIES, WindowData
from energy_planner.stats import wls_coef as wls

#: Quantiles at which hinge terms on a numeric channel are tried.
HINGE_QUANTILES = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
#: Rate of climb along the motion per unit speed, sin(alpha) times the grade of the
#: direction of travel (forward ``sin a cos g``, left ``-sin a sin g``), m/s.
CLIMB = "sin(alpha) * (vx * cos(gamma) - vy * sin(gamma))"
#: Steady walking samples whose 90th / 10th percentile speed ratio exceeds this hold
#: several speeds: speed shapes are then tried.
SPEED_SPREAD = 1.25
#: Windows slower than this (m/s) are standing or turning in place, not walking.
WALKING_SPEED = 0.05

#: What a channel's name says it measures: a kind and the words of a name that give it
#: (the name is split at non-alphanumerics: ``motor_temp`` -> ``motor``, ``temp``).
CHANNEL_KINDS = (
    ("mass", frozenset({"kg", "mass", "load", "payload", "weight"})),
    ("temperature", frozenset({"temp", "temperature", "celsius", "degc", "kelvin"})),
)


def channel_kind(ch: str) -> str | None:
    """The kind of quantity a channel's name says it is (:data:`CHANNEL_KINDS`), or None.

    Explanations of a channel's candidates are worded by it: a term that scales the base
    by ``motor_temp`` is not "a carried mass".

    >>> channel_kind("load_kg"), channel_kind("motor_temp"), channel_kind("grass_height_m")
    ('mass', 'temperature', None)
    """
    import re

    parts = set(re.split(r"[^a-z0-9]+", ch.lower()))
    return next((kind for kind, words in CHANNEL_KINDS if parts & words), None)


def _reads_as(ch: str, hints: dict[str, str], default: str) -> str:
    """The words for ``ch``'s kind (``hints``), or ``default`` for a channel of no known kind."""
    return hints.get(channel_kind(ch) or "", default).format(ch=ch)


@dataclass
class Candidate:
    """A candidate physical effect: one more term for the model."""

    name: str
    term: str
    variables: list[str]
    explanation: str
    source: str  # "catalog", "data", "speed" or "user"
    channel: str | None = None  # family whose shapes compete (a channel, or "speed")
    formula: str = ""  # the formula behind a catalog name (for de-duplication)
    knot_level: float | None = None  # hinge: quantile level of the knot in the channel
    below: bool = True  # hinge: pos(q - x) (True) or pos(x - q)
    shape: str = ""  # kind of shape within the family (hinges of one kind share it)
    needs_speeds: bool = False  # only identifiable from several walking speeds
    hinge_times: str = ""  # hinge multiplied by this ("" or "speed")

    def __post_init__(self) -> None:
        self.term = canonical(self.term)
        self.formula = self.formula or self.term
        self.shape = self.shape or self.name


def _fmt(q: float) -> str:
    """Short literal for a threshold in a formula."""
    return f"{float(q):.4g}"


def hinge(ch: str, q: float, below: bool, level: float | None = None, times: str = "") -> Candidate:
    """The hinge candidate ``pos(q - ch)`` (``below``) or ``pos(ch - q)`` on a channel.

    Optionally times ``speed`` (a force per metre that starts at a threshold).

    >>> hinge("temperature_c", 15.0, True).term
    'pos(15 - temperature_c)'
    >>> hinge("x", -2.5, False).term
    'pos(x + 2.5)'
    >>> hinge("motor_temp", 60.0, False, times="speed").term
    'speed * pos(motor_temp - 60)'
    """
    qs = _fmt(q)
    if below:
        h, name = f"pos({qs} - {ch})", f"{ch}<{qs}"
        what = f"as {ch} falls below {qs}"
    else:
        h = f"pos({ch} - {qs})" if q >= 0 else f"pos({ch} + {_fmt(-q)})"
        name, what = f"{ch}>{qs}", f"as {ch} rises above {qs}"
    example = _reads_as(
        ch,
        {"temperature": " (e.g. stiff cold joints, hot motors)", "mass": " (of the load)"},
        "",
    )
    if times == "speed":
        return Candidate(
            f"speed*({name})",
            f"speed * {h}",
            sorted({ch, "speed"}),
            f"the force per metre grows {what}: a threshold effect on walking{example}",
            "data",
            ch,
            knot_level=level,
            below=below,
            shape=f"speed*hinge{'<' if below else '>'}",
            hinge_times="speed",
        )
    return Candidate(
        name,
        h,
        [ch],
        f"extra standing power grows {what}: a threshold effect{example}",
        "data",
        ch,
        knot_level=level,
        below=below,
        shape=f"hinge{'<' if below else '>'}",
    )


def _nonlinear_in_speed(formula: str) -> bool:
    f = formula.replace(" ", "")
    return "speed**" in f or "speed*speed" in f


def catalog_candidates(model_terms: Iterable[str], wd: WindowData) -> list[Candidate]:
    """Catalog effects the model does not yet have, plus surface type per value."""
    from energy_planner.model import BASE_TERMS, CATALOG, SPEED_TERMS, STANDING_TERMS

    have = {canonical(t) for t in model_terms}
    out = []
    for name, term in CATALOG.items():
        # the speed terms join the base when the logs span a range of speeds
        # (calibration.fit.speed_support); speed_candidates tries their shapes
        if name in BASE_TERMS or name in STANDING_TERMS or name in SPEED_TERMS or name in have:
            continue
        formula = term.formula
        if formula in have:
            continue
        out.append(
            Candidate(
                name=name,
                term=name,
                variables=sorted(term.variables),
                explanation=str(getattr(term, "explanation", "")),
                source="catalog",
                formula=formula,
                needs_speeds=_nonlinear_in_speed(formula),
            )
        )
    if "surface" in wd.categorical_extras:
        for value in _categories(wd, "surface"):
            term = f"speed * (surface == {value!r})"
            if canonical(term) in have:
                continue
            out.append(
                Candidate(
                    name=f"surface_type[{value}]",
                    term=term,
                    variables=["speed", "surface"],
                    explanation=(
                        f"walking on {value} costs a different force per metre (sinkage, "
                        "slip, compliance of the ground)"
                    ),
                    source="catalog",
                    channel="surface",
                    shape="speed*(c==v)",
                )
            )
    return out


@functools.lru_cache(maxsize=8192)
def canonical(term: str) -> str:
    """The name :class:`~energy_planner.model.EnergyModel` gives a formula term.

    Remembered per text: every step of the staircase names the same candidates again
    (parsing and unparsing each formula was ~5 % of ``diagnose``).

    >>> canonical("speed*(surface=='mud')")
    "speed * (surface == 'mud')"
    """
    from energy_planner.model import CATALOG, parse_formula

    return term if term in CATALOG else parse_formula(term).text


def _categories(wd: WindowData, ch: str) -> list[str]:
    vals = wd.samples[ch].dropna().astype(str)
    return sorted(vals.unique().tolist())


def speed_levels(wd: WindowData) -> dict:
    """Do the logs hold several walking speeds? From the steady walking samples.

    A sample is steady walking when its speed exceeds :data:`WALKING_SPEED` and its
    acceleration (``ax, ay`` when the samples have them) is below 0.05 m/s^2: the ramps
    at the start and end of a run are not other speeds.

    Returns
    -------
    dict
        ``{"several": bool, "p10": float, "p90": float, "n_walking": int}``: several
        speeds when the 90th / 10th percentile ratio of steady walking speeds exceeds
        :data:`SPEED_SPREAD`.
    """
    s = wd.samples
    none = {"several": False, "p10": math.nan, "p90": math.nan, "n_walking": 0}
    if "speed" not in s.columns:
        return none
    sp = s["speed"].to_numpy(float)
    keep = np.isfinite(sp) & (sp > WALKING_SPEED)
    if {"ax", "ay"} <= set(s.columns):
        acc = np.hypot(s["ax"].to_numpy(float), s["ay"].to_numpy(float))
        keep &= np.nan_to_num(acc, nan=np.inf) < 0.05
    walking = sp[keep]
    if walking.size < 20:
        return {**none, "n_walking": int(walking.size)}
    lo, hi = np.quantile(walking, [0.1, 0.9])
    return {
        "several": bool(hi > SPEED_SPREAD * lo),
        "p10": float(lo),
        "p90": float(hi),
        "n_walking": int(walking.size),
    }


def speed_candidates(wd: WindowData) -> list[Candidate]:
    """Shapes of a speed dependence (only meaningful when the logs hold several speeds)."""
    sp = wd.table["speed"].to_numpy(float) if "speed" in wd.table.columns else np.array([])
    walking = sp[np.isfinite(sp) & (sp > WALKING_SPEED)]
    out = [
        Candidate(
            "speed^2",
            "speed ** 2",
            ["speed"],
            "leg swing and damping losses grow with speed: the force per metre grows with speed",
            "speed",
            "speed",
            shape="speed^2",
            needs_speeds=True,
        ),
        Candidate(
            "speed^3",
            "speed ** 3",
            ["speed"],
            "losses that grow with the square of speed per metre (fast leg swing, impacts)",
            "speed",
            "speed",
            shape="speed^3",
            needs_speeds=True,
        ),
    ]
    # per gait: the force per metre of one direction of motion grows with speed (its
    # touch-downs per second, its swing losses), each gait by its own amount
    for name, term, words in (
        ("forward*speed", "pos(vx) ** 2", "walking forward"),
        ("backward*speed", "pos(-vx) ** 2", "walking backward"),
        ("lateral*speed", "vy ** 2", "side-stepping"),
    ):
        out.append(
            Candidate(
                name,
                term,
                ["vx"] if "vx" in term else ["vy"],
                f"the force per metre {words} grows with speed (more touch-downs and faster "
                "leg swings per metre at a fixed stride length), by its own amount per gait",
                "speed",
                "speed",
                shape=name,
                needs_speeds=True,
            )
        )
    if walking.size >= 10:
        levels = (0.25, 0.5, 0.75)
        for level, q in zip(levels, np.quantile(walking, levels), strict=True):
            qs = _fmt(q)
            out.append(
                Candidate(
                    f"speed>{qs}",
                    f"pos(speed - {qs})",
                    ["speed"],
                    f"above {qs} m/s the gait changes and costs more per second",
                    "speed",
                    "speed",
                    knot_level=float(level),
                    shape="speed-hinge",
                    needs_speeds=True,
                )
            )
    return out


#: Rate of change of the kinetic energy per unit mass, ``d(v^2 / 2) / dt``, W/kg.
KINETIC = "ax * vx + ay * vy"


def kinetic_candidates(wd: WindowData) -> list[Candidate]:
    """Shapes of a cost of speed changes beyond the catalog's ``acceleration``.

    The catalog's ``pos(ax vx + ay vy)`` pays the kinetic energy when speeding up only.
    Masses that the drive spins up and then brakes actively (rotors, swinging legs) cost
    both ways: ``abs(ax vx + ay vy)``; braking alone: ``pos(-(ax vx + ay vy))``. Samples
    without ``ax, ay`` make them unsupported (the preprocessing derives them from the
    twist). ``wd`` is not read: the shapes are the same for any logs.

    >>> [c.name for c in kinetic_candidates(None)]
    ['speed_changes', 'slowing_down']
    """
    return [
        Candidate(
            "speed_changes",
            f"abs({KINETIC})",
            ["ax", "ay", "vx", "vy"],
            "every speed change costs kinetic energy, speeding up and slowing down alike "
            "(rotors and legs spun up by the motors and braked by them, not recovered)",
            "motion",
        ),
        Candidate(
            "slowing_down",
            f"pos(-({KINETIC}))",
            ["ax", "ay", "vx", "vy"],
            "slowing down costs (the motors brake the moving masses actively)",
            "motion",
        ),
    ]


def holding_candidates(wd: WindowData) -> list[Candidate]:
    """Shapes of a holding cost in proportion to the slope load, beside its square.

    The base prices holding a slope by copper losses, the square of the load
    (``tilt_x_sq``, ``tilt_y_sq``). Losses in proportion to the load itself are as
    common in a drive: the motor drivers' conduction and switching losses grow with the
    current (not its square), gearbox and joint friction with the torque carried. With
    both, the holding power is concave in the square: more than the square prices on
    gentle slopes, less on steep ones. ``wd`` is not read: the shapes are the same for any
    logs (on level ground they have no variance and are unsupported).

    >>> [c.term for c in holding_candidates(None)]
    ['abs(sin(alpha) * cos(gamma))', 'abs(sin(alpha) * sin(gamma))']
    """
    # the grades the base's tilt_x_sq and tilt_y_sq square
    from energy_planner.model.terms import _TILT_X, _TILT_Y

    out = []
    for name, tilt, words in (
        ("tilt_x_abs", _TILT_X, "along the body x axis (up or down the slope)"),
        ("tilt_y_abs", _TILT_Y, "across the body (the sideways load and the roll moment)"),
    ):
        out.append(
            Candidate(
                name,
                f"abs({tilt})",
                ["alpha", "gamma"],
                f"holding the slope load {words} costs in proportion to the load, beside "
                "the copper losses in its square: motor-driver losses that grow with the "
                "current, gearbox and joint friction that grow with the torque "
                "(W per unit of the grade's sine)",
                "motion",
            )
        )
    return out


def user_candidates(specs: Iterable[str]) -> list[Candidate]:
    """Candidates from term specs (catalog names or formulas) a user wants tested.

    >>> user_candidates(["payload_kg*speed*sin(alpha)"])[0].variables
    ['alpha', 'payload_kg', 'speed']
    """
    from energy_planner.model import resolve_term

    out = []
    for spec in specs:
        t = resolve_term(spec)
        expl = t.explanation if t.explanation != "user-defined term" else "user-proposed term"
        out.append(Candidate(t.name, t.name, sorted(t.variables), expl, "user"))
    return out


def _numeric_shapes(ch: str, several_speeds: bool) -> list[tuple[str, str, str, list[str]]]:
    climb = f"pos({CLIMB})"
    descent = f"pos(-({CLIMB}))"
    geo = ["alpha", "gamma", "vx", "vy"]
    mass = channel_kind(ch) == "mass"
    force = _reads_as(
        ch,
        {"mass": " (a carried load)", "temperature": " (friction that changes with temperature)"},
        " (drag, resistance)",
    )
    shapes = [
        (ch, ch, f"a standing power proportional to {ch}", []),
        (
            f"{ch}*speed",
            f"{ch} * speed",
            f"a force along the motion proportional to {ch}{force}",
            ["speed"],
        ),
        (
            f"{ch}*climb",
            f"{ch} * {climb}",
            f"climbing costs more in proportion to {ch}"
            + (" (lifting work: a mass carried uphill)" if mass else ""),
            geo,
        ),
        (
            f"{ch}*descent",
            f"{ch} * {descent}",
            f"descending costs more in proportion to {ch}"
            + (" (braking work: a mass lowered downhill)" if mass else ""),
            geo,
        ),
        (
            f"{ch}*slope",
            f"{ch} * speed * sin(alpha)",
            f"walking on any slope costs more in proportion to {ch}"
            + (" (a load held on a slope)" if mass else ""),
            ["speed", "alpha"],
        ),
        (f"{ch}*turn", f"abs(wz) * {ch}", f"the cost of turning grows with {ch}", ["wz"]),
    ]
    if mass:
        # the legs support the whole mass m0 + x at every moment, standing or walking:
        # joint torques and motor currents grow with it, copper losses with its square,
        # (m0 + x)^2 = m0^2 + 2 m0 x + x^2; the part in proportion to x is the shape x
        shapes.append(
            (
                f"{ch}^2",
                f"{ch} ** 2",
                f"a power in the square of {ch} at every moment, standing or walking: {ch} "
                "reads as a carried mass, the legs' joint torques and motor currents grow "
                "with the whole mass they support, their copper (I^2 R) losses with its "
                f"square (the part in proportion to it is the shape {ch})",
                [],
            )
        )
    if several_speeds:
        shapes.append(
            (
                f"{ch}*speed^2",
                f"{ch} * speed ** 2",
                f"swing losses that grow with speed, in proportion to {ch}",
                ["speed"],
            )
        )
    return shapes


def _base_products(ch: str, model_terms: Iterable[str]) -> list[tuple[str, str, str, list[str]]]:
    """``ch`` times each base term of the model: the base's own physics scaled by a channel.

    A load scales the lifting work, the copper losses of holding a slope, ...
    """
    from energy_planner.model import BASE_TERMS, CATALOG, STANDING_TERMS

    out = []
    for name in model_terms:
        if name not in (*BASE_TERMS, *STANDING_TERMS) or CATALOG[name].formula.strip() == "1":
            continue
        t = CATALOG[name]
        expl = t.explanation.split(":")[0]
        out.append(
            (
                f"{ch}*{name}",
                f"{ch} * ({t.formula})",
                f"{expl}, in proportion to {ch}",
                sorted(t.variables),
            )
        )
    return out


def _scaled_base(ch: str, model_terms: Sequence[str], coef: dict[str, float] | None):
    """``ch`` times the fitted base power, and times its copper (squared-force) part.

    A channel that scales every force of the gait (a mass) or every copper loss (the
    winding resistance). The coefficients are the current fit's, written into the term;
    the scaled power is clipped at 0 (``pos``) as the power a gait draws is: where the
    fitted parts sum below 0 (a backward or downhill motion the base prices poorly) a
    carried mass must not make the robot regenerate in proportion to it.
    """
    from energy_planner.model import BASE_TERMS, CATALOG, STANDING_TERMS

    if not coef:
        return []
    family = (*BASE_TERMS, *STANDING_TERMS)  # the base, with the gait's running power
    base = [t for t in model_terms if t in family and np.isfinite(coef.get(t, np.nan))]
    out = []
    whole = _reads_as(
        ch,
        {
            "mass": "{ch} reads as a carried mass: it scales every leg force (gravity work, "
            "inertia and the losses of the leg forces)",
            "temperature": "{ch} reads as a temperature: warm motors and gearboxes draw more "
            "for the same forces (winding resistance, friction)",
        },
        "what {ch} measures scales the whole gait; the logs do not say why",
    )
    copper = _reads_as(
        ch,
        {
            "mass": "{ch} reads as a carried mass: the leg forces grow with it, their copper "
            "losses with the square of the forces",
            "temperature": "{ch} reads as a temperature: the winding resistance rises with it",
        },
        "what {ch} measures scales the copper losses; the logs do not say why",
    )
    sq = [t for t in base if t.endswith("_sq")]
    shapes = [
        ("*P_base", ch, base, f"the fitted base power (every term of the gait) grows in "
         f"proportion to {ch}; {whole}"),
        ("*P_copper", ch, sq, f"the base's copper (I^2 R) losses (its squared-force terms) "
         f"grow in proportion to {ch}; {copper}"),
    ]  # fmt: skip
    if channel_kind(ch) == "mass":
        # forces grow with the mass m0 + ch, copper losses with their square:
        # (1 + ch / m0)^2 = 1 + 2 ch / m0 + (ch / m0)^2, the second order a shape of its own
        shapes.append((
            "_sq*P_copper", f"{ch} ** 2", sq,
            f"the base's copper (I^2 R) losses grow with the square of {ch}: {ch} reads as "
            "a carried mass, the leg forces grow in proportion to the whole mass and their "
            "copper losses with its square (the part in proportion to it is "
            f"{ch}*P_copper)",
        ))  # fmt: skip
    for label, factor, names, expl in shapes:
        parts = [f"{coef[t]:.4g} * ({CATALOG[t].formula})" for t in names if coef[t] != 0]
        if not parts:
            continue
        variables = sorted({v for t in names for v in CATALOG[t].variables})
        # the power a gait draws is never negative (legged robots do not regenerate): the
        # channel scales that, not a sum whose fitted parts may go below 0 somewhere
        out.append((f"{ch}{label}", f"{factor} * pos({' + '.join(parts)})", expl, variables))
    return out


def channel_candidates(
    wd: WindowData,
    catalog_terms: Iterable[str] = (),
    several_speeds: bool | None = None,
    model_terms: Iterable[str] = (),
    coef: dict[str, float] | None = None,
) -> tuple[list[Candidate], list[dict]]:
    """Data-driven candidates, one family of shapes per extra channel.

    With ``model_terms``, also the channel times each of the model's base terms.

    Returns the candidates and the channels that cannot give one (with the reason).
    """
    skip_terms = {canonical(t) for t in catalog_terms}
    model_terms = list(model_terms)
    if several_speeds is None:
        several_speeds = speed_levels(wd)["several"]
    out: list[Candidate] = []
    bad: list[dict] = []
    for ch in wd.numeric_extras:
        v = wd.samples[ch].to_numpy(dtype=float)
        fin = v[np.isfinite(v)]
        if fin.size == 0:
            bad.append(_unsup(ch, ch, [ch], "data", "all values of the channel are missing"))
            continue
        if np.ptp(fin) == 0:
            bad.append(
                _unsup(ch, ch, [ch], "data", f"no variance: {ch} is {fin[0]:.4g} in every sample")
            )
            continue
        shapes = _numeric_shapes(ch, several_speeds) + _base_products(ch, model_terms)
        for name, term, expl, more in shapes + _scaled_base(ch, model_terms, coef):
            if canonical(term) in skip_terms:
                continue
            skip_terms.add(canonical(term))
            out.append(
                Candidate(
                    name,
                    term,
                    sorted({ch, *more}),
                    expl,
                    "data",
                    ch,
                    shape=name.replace(ch, "x"),
                    needs_speeds=_nonlinear_in_speed(term),
                )
            )
        seen = set()
        for level, q in zip(HINGE_QUANTILES, np.quantile(fin, HINGE_QUANTILES), strict=True):
            key = _fmt(q)
            if fin.min() < q < fin.max() and key not in seen:  # at an end: 0 or linear
                seen.add(key)
                for b in (True, False):
                    out.append(hinge(ch, float(q), b, level))
                    out.append(hinge(ch, float(q), b, level, times="speed"))
    for ch in wd.categorical_extras:
        cats = _categories(wd, ch)
        if len(cats) < 2:
            bad.append(
                _unsup(ch, ch, [ch], "data", f"no variance: {ch} takes only the value(s) {cats}")
            )
            continue
        if len(cats) > MAX_CATEGORIES:
            bad.append(
                _unsup(
                    ch,
                    ch,
                    [ch],
                    "data",
                    f"{len(cats)} distinct values (> {MAX_CATEGORIES}): an identifier?",
                )
            )
            continue
        for value in cats:
            is_v = f"({ch} == {value!r})"
            for name, term, variables, expl, shape in (
                (
                    f"{ch}=={value}",
                    is_v,
                    [ch],
                    f"extra standing power when {ch} is {value}",
                    "c==v",
                ),
                (
                    f"speed*({ch}=={value})",
                    f"speed * {is_v}",
                    ["speed", ch],
                    f"a different force per metre when {ch} is {value}",
                    "speed*(c==v)",
                ),
                (
                    f"climb*({ch}=={value})",
                    f"{is_v} * pos({CLIMB})",
                    ["alpha", "gamma", "vx", "vy", ch],
                    f"climbing costs more when {ch} is {value} (feet slip back, sink in)",
                    "climb*(c==v)",
                ),
                (
                    f"turn*({ch}=={value})",
                    f"abs(wz) * {is_v}",
                    ["wz", ch],
                    f"turning costs more when {ch} is {value} (feet twist against the ground)",
                    "turn*(c==v)",
                ),
            ):
                if canonical(term) in skip_terms:
                    continue
                out.append(Candidate(name, term, sorted(variables), expl, "data", ch, shape=shape))
    return out, bad


def _unsup(name, term, variables, source, reason) -> dict:
    return {
        "name": name,
        "term": term,
        "variables": sorted(variables),
        "source": source,
        "reason": reason,
    }


def default_candidates(
    wd: WindowData, terms: Sequence[str], speeds: dict | None = None
) -> tuple[list[Candidate], list[dict]]:
    """Catalog, speed and channel candidates for a model with ``terms``.

    Also returns the candidates that cannot be tried, with the reason.
    """
    speeds = speed_levels(wd) if speeds is None else speeds
    x, y = wd.columns(terms), wd.power
    ok = np.all(np.isfinite(x), axis=1) & np.isfinite(y)
    coef = dict(zip(terms, wls(x[ok], y[ok], wd.weights[ok]), strict=True)) if ok.any() else None
    cands = catalog_candidates(terms, wd)
    data, bad = channel_candidates(
        wd, [c.term for c in cands] + [c.formula for c in cands], speeds["several"], terms, coef
    )
    cands = cands + kinetic_candidates(wd) + holding_candidates(wd) + speed_candidates(wd) + data
    out, unsupported = [], list(bad)
    have = {canonical(t) for t in terms}
    for c in cands:
        if c.term in have or c.formula in have:
            continue
        if c.needs_speeds and not speeds["several"]:
            p10, p90 = speeds["p10"], speeds["p90"]
            spread = "" if not math.isfinite(p10) else f" (steady walking {p10:.2f}-{p90:.2f} m/s)"
            unsupported.append(
                _unsup(
                    c.name,
                    c.term,
                    c.variables,
                    c.source,
                    f"the logs hold one walking speed{spread}: a speed shape is the motion "
                    "terms again; record runs at several speeds",
                )
            )
            continue
        out.append(c)
    return out, unsupported
