"""Which physical effect is the model missing: candidates, held-out validation, ranking.

A *candidate* is one more term (a catalog name or a formula) with a one-line physical
explanation. Candidates come from

- the model catalog (``energy_planner.model.CATALOG``) and surface type per value of a
  ``surface`` channel;
- the data: every extra channel of the logs gets a family of shapes (:func:`channel_candidates`):
  numeric ``x`` (standing power), ``x * speed`` (force per metre), ``x * pos(climb)`` and
  ``x * pos(-climb)`` (a mass lifted and lowered: ``climb = sin(alpha) * (vx cos(gamma) -
  vy sin(gamma))`` is the rate of climb along the motion), ``x * speed * sin(alpha)`` (a load
  on any slope), ``abs(wz) * x`` (turning), hinges ``pos(q - x)``, ``pos(x - q)`` and the same
  times speed at data quantiles ``q``; categorical ``(c == 'v')``, ``speed * (c == 'v')``,
  ``(c == 'v') * pos(climb)`` and ``abs(wz) * (c == 'v')`` per value. The best shape per
  channel by held-out error stands for the channel (a best hinge gets its knot refined);
- speed-change shapes (:func:`kinetic_candidates`): ``abs(ax vx + ay vy)`` and
  ``pos(-(ax vx + ay vy))`` next to the catalog's ``acceleration``;
- speed shapes (``speed ** 2``, ``speed ** 3``, per gait ``pos(vx) ** 2``, ``pos(-vx) ** 2``,
  ``vy ** 2``, hinges in speed), tried only when the logs hold several walking speeds
  (:func:`speed_levels`): at one speed they are the motion terms again;
- the user's own ``--term``.

Each candidate is scored by the held-out error of the model refitted with it, validated
by run (grouped K-fold: all windows of a run are in the same fold, so a run is never
predicted by a fit that saw it).

*Unsupported* (listed, never ranked): the candidate needs a channel the logs lack, its
column has no variance or no finite value, or its column is nearly in the span of the
model's columns: the relative residual ``||z - X b|| / ||z||`` of its least-squares
projection on the model's columns is below ``span_tol`` (default 0.05).

*Above noise* (a finding). With ``d_r`` the reduction of run ``r``'s mean held-out squared
window error when the candidate is added (same held-out windows with and without it), a
one-sided signed-rank test over the runs (:func:`paired_run_test`) asks that runs improve
consistently; its p-value must be below
``alpha / m`` where ``m`` is the number of candidates scored in this ranking (Bonferroni: the
chance that *any* of them passes by luck is at most ``alpha``, default 1 %), AND the pooled
held-out RMSE must fall by at least ``min_rel`` (default 5 %) of its current value. The first
rule controls the false-finding rate whatever the number of candidates; the second keeps
out gains too small to matter (a real but negligible structure of the residual). Measured
rates are in docs/diagnosis.md.

``error_explained`` is the fraction of the current held-out mean squared error that the
candidate removes, ``1 - MSE_cv(with) / MSE_cv(without)``.

*Confounded* suspects: when another above-noise suspect ``B`` is not significantly worse than
the best one ``A`` (two-sided paired test by run at 5 %), and neither adds anything above
noise once the other is in the model, the data cannot tell them apart: ``B`` is listed in
``Ranking.alternatives`` and reported with ``A`` as one finding.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from energy_planner.diagnosis.data import MAX_CATEGORIES, WindowData
from energy_planner.model.terms import Term
from energy_planner.stats import fold_index as run_folds
from energy_planner.stats import heldout_residuals as cv_errors
from energy_planner.stats import heldout_rmse, span_basis, span_residual
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


@dataclass(frozen=True)
class Thresholds:
    """Rules that decide support and noise (see the module docstring).

    Attributes
    ----------
    alpha : float
        Family-wise false-finding level of one ranking: the p-value of a candidate's
        one-sided test by run must be below ``alpha / m`` (``m`` candidates scored).
    min_rel : float
        Smallest relative reduction of the pooled held-out RMSE that counts.
    span_tol : float
        Candidates whose column is within this relative residual of the model's span
        are unsupported.
    n_splits, seed : int
        Folds by run and the seed of their assignment.
    confound_alpha : float
        Two-sided level of the paired signed-rank test by run that tells the best suspect
        from another one.
    """

    alpha: float = 0.01
    min_rel: float = 0.05
    span_tol: float = 0.05
    n_splits: int = 5
    seed: int = 0
    confound_alpha: float = 0.05


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


@dataclass
class Suspect:
    """A scored candidate."""

    name: str
    term: str
    variables: list[str]
    explanation: str
    source: str
    error_explained: float
    heldout_rmse_w: float
    heldout_rmse_before_w: float
    reduction_w: float
    z_by_run: float
    p_value: float
    n_runs: int
    n_windows: int
    coefficient: float = math.nan
    above_noise: bool = False
    p_threshold: float = math.nan
    channel: str | None = None

    def to_dict(self) -> dict:
        """JSON-friendly dict."""
        return asdict(self)


@dataclass
class Ranking:
    """Result of :func:`rank_suspects`."""

    terms: list[str]
    heldout_rmse_w: float
    fold_rmse_w: list[float]
    suspects: list[Suspect]  # above noise, best first
    below_noise: list[Suspect]
    unsupported: list[dict] = field(default_factory=list)
    alternatives: list[Suspect] = field(default_factory=list)  # confounded with the best
    n_tested: int = 0
    p_threshold: float = math.nan
    heldout_errors: np.ndarray | None = field(default=None, repr=False)


# --------------------------------------------------------------------------- folds / CV
# Least squares, folds by run and spans are energy_planner.stats' (shared with calibration).

__all__ = [
    "LONG_FORMULA",
    "RUN_TEST_NAME",
    "Candidate",
    "Ranking",
    "Step",
    "Suspect",
    "Thresholds",
    "channel_kind",
    "cv_errors",
    "heldout_rmse",
    "model_term",
    "paired_run_test",
    "rank_suspects",
    "resolve_names",
    "run_folds",
    "span_basis",
    "span_residual",
    "staircase",
    "term_spec",
    "wls",
]


def _fold_rmse(err: np.ndarray, folds: np.ndarray, n_folds: int) -> np.ndarray:
    sq = np.bincount(folds, weights=err**2, minlength=n_folds)
    n = np.bincount(folds, minlength=n_folds)
    return np.sqrt(sq / np.maximum(n, 1))


#: The significance test of a candidate, as reports name it (one place: the text, the
#: HTML report and the docs read it here).
RUN_TEST_NAME = "one-sided Wilcoxon signed-rank test by run"


def paired_run_test(e0: np.ndarray, e1: np.ndarray, runs: np.ndarray) -> tuple[float, float, int]:
    """One-sided paired test by run that ``e1`` has smaller squared errors than ``e0``.

    ``d_r`` is the mean over run ``r``'s windows of ``e0**2 - e1**2``; the runs are the
    independent units (held out by run; a run's windows share its ground and sensors). The
    test is Wilcoxon's signed-rank test of ``d_r`` (:data:`RUN_TEST_NAME`;
    ``scipy.stats.wilcoxon``, one-sided, normal approximation with tie correction, zero
    differences dropped): an effect often lives in a few runs (those on mud, those with a
    payload) and makes ``d_r`` very skewed, where a t-test has little power; the
    signed-rank test counts how consistently runs improve.

    Returns
    -------
    tuple
        ``(z, p, n_runs)``: the standardised signed-rank statistic (> 0: ``e1`` better),
        its one-sided p-value and the number of runs.

    Examples
    --------
    >>> runs = np.repeat(np.arange(20), 3)
    >>> rng = np.random.default_rng(1)
    >>> e0 = rng.normal(0, 2, 60); e1 = e0 / 2
    >>> z, p, n = paired_run_test(e0, e1, runs)
    >>> bool(z > 3 and p < 1e-3), n
    (True, 20)
    >>> z, p, n = paired_run_test(e1, e0, runs)
    >>> bool(z < -3 and p > 0.99)
    True
    """
    from scipy.stats import wilcoxon

    _, inv = np.unique(runs, return_inverse=True)
    d = np.bincount(inv, weights=e0**2 - e1**2) / np.bincount(inv)
    n = d.size
    scale = np.max(np.abs(d)) if n else 0.0
    d = d[np.abs(d) > 1e-12 * max(scale, 1e-300)]  # zero differences carry no sign
    if d.size < 2:
        return math.nan, 1.0, n
    res = wilcoxon(d, alternative="greater", method="approx", zero_method="wilcox")
    z = float(res.zstatistic)
    if not math.isfinite(z):
        return math.nan, 1.0, n
    return z, float(res.pvalue), n


# --------------------------------------------------------------------------- candidates


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
    from energy_planner.model import BASE_TERMS, CATALOG

    have = {canonical(t) for t in model_terms}
    out = []
    for name, term in CATALOG.items():
        if name in BASE_TERMS or name in have:
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


def canonical(term: str) -> str:
    """The name :class:`~energy_planner.model.EnergyModel` gives a formula term.

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
    from energy_planner.model import BASE_TERMS, CATALOG

    out = []
    for name in model_terms:
        if name not in BASE_TERMS or CATALOG[name].formula.strip() == "1":
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
    winding resistance). The coefficients are the current fit's, written into the term.
    """
    from energy_planner.model import BASE_TERMS, CATALOG

    if not coef:
        return []
    base = [t for t in model_terms if t in BASE_TERMS and np.isfinite(coef.get(t, np.nan))]
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
    for label, names, expl in (
        ("P_base", base, f"the fitted base power (every term of the gait) grows in "
         f"proportion to {ch}; {whole}"),
        ("P_copper", [t for t in base if t.endswith("_sq")],
         f"the base's copper (I^2 R) losses (its squared-force terms) grow in proportion to "
         f"{ch}; {copper}"),
    ):  # fmt: skip
        parts = [f"{coef[t]:.4g} * ({CATALOG[t].formula})" for t in names if coef[t] != 0]
        if not parts:
            continue
        variables = sorted({v for t in names for v in CATALOG[t].variables})
        out.append((f"{ch}*{label}", f"{ch} * ({' + '.join(parts)})", expl, variables))
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


# --------------------------------------------------------------------------- ranking


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
    cands = cands + kinetic_candidates(wd) + speed_candidates(wd) + data
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


def rank_suspects(
    wd: WindowData,
    terms: Sequence[str | Term],
    thresholds: Thresholds | None = None,
    candidates: list[Candidate] | None = None,
    folds: np.ndarray | None = None,
    extra: Sequence[str] = (),
) -> Ranking:
    """Score every candidate against the model with ``terms``, refitted by run-held-out CV.

    Parameters
    ----------
    wd : WindowData
        The measurements, by window.
    terms : sequence of str or Term
        The current model's terms (catalog names, formulas or a model's ``terms``).
    thresholds : Thresholds, optional
        Support and noise rules.
    candidates : list of Candidate, optional
        Default: :func:`default_candidates`.
    folds : numpy.ndarray, optional
        Fold of each window (:func:`run_folds`); default from ``thresholds``.
    extra : sequence of str
        More candidate terms to test (the user's own hypotheses), scored like the others.

    Returns
    -------
    Ranking
    """
    th = thresholds or Thresholds()
    terms = [term_spec(t) for t in terms]
    y = wd.power
    x = wd.columns(terms)
    if folds is None:
        folds = run_folds(wd.runs, th.n_splits, th.seed)
    unsupported: list[dict] = []
    if candidates is None:
        candidates, bad = default_candidates(wd, terms)
        unsupported.extend(bad)
    seen = {c.term for c in candidates}
    candidates = candidates + [c for c in user_candidates(extra) if c.term not in seen]
    ctx = _Context(wd, x, y, folds, th, {canonical(t) for t in terms})
    scored, unsup = ctx.evaluate(candidates)
    unsupported.extend(unsup)
    # the best shape per family stands for it (hinge knots refined)
    best: dict[str, tuple[Suspect, Candidate]] = {}
    rest: list[Suspect] = []
    for sus, cand in scored:
        if cand.source in ("data", "speed") and cand.channel is not None:
            prev = best.get(cand.channel)
            if prev is None or sus.heldout_rmse_w < prev[0].heldout_rmse_w:
                best[cand.channel] = (sus, cand)
        else:
            rest.append(sus)
    final = rest + [ctx.refine(sus, cand) for sus, cand in best.values()]
    m = max(ctx.n_scored, 1)
    p_thr = th.alpha / m
    for s in final:
        ctx.decide(s, p_thr)
        s.coefficient = ctx.coefficient(s.term)
    # best first; on a tie (complementary shapes: grass = not mud when a channel has two
    # values) the extra cost (positive coefficient) is named rather than a saving
    final.sort(key=lambda s: (-round(s.error_explained, 9), not s.coefficient > 0))
    suspects = [s for s in final if s.above_noise]
    alternatives = ctx.alternatives(suspects[0], p_thr) if suspects else []
    return Ranking(
        terms=list(terms),
        heldout_rmse_w=ctx.base_rmse,
        fold_rmse_w=ctx.base_fold.tolist(),
        suspects=suspects,
        below_noise=[s for s in final if not s.above_noise],
        unsupported=unsupported,
        alternatives=alternatives,
        n_tested=m,
        p_threshold=p_thr,
        heldout_errors=ctx.base_err,
    )


@dataclass
class _Context:
    """What scoring a candidate needs: the data, the model's columns and the folds."""

    wd: WindowData
    x: np.ndarray
    y: np.ndarray
    folds: np.ndarray
    th: Thresholds
    have: set[str]

    def __post_init__(self) -> None:
        self.n_folds = int(self.folds.max()) + 1
        self.base_ok = np.all(np.isfinite(self.x), axis=1) & np.isfinite(self.y)
        self.w = self.wd.weights
        self.runs = self.wd.runs
        ok = self.base_ok
        self.base_err = np.full(len(self.y), np.nan)
        self.base_err[ok] = cv_errors(self.x[ok], self.y[ok], self.folds[ok], self.w[ok])
        e = self.base_err[ok]
        self.base_rmse = float(np.sqrt(np.mean(e**2)))
        self.base_fold = _fold_rmse(e, self.folds[ok], self.n_folds)
        self.available = set(self.wd.samples.columns) | {"speed"}
        self.basis = span_basis(self.x[ok])
        self.n_scored = 0
        self.errors: dict[str, np.ndarray] = {}  # held-out errors with each candidate
        self.columns: dict[str, np.ndarray] = {}
        self.cands: dict[str, Candidate] = {}
        self.scored: list[Suspect] = []

    def evaluate(
        self, candidates: list[Candidate]
    ) -> tuple[list[tuple[Suspect, Candidate]], list[dict]]:
        """Score candidates; those the data cannot support come back as dicts."""
        todo = [c for c in candidates if c.term not in self.have]
        cols = _candidate_columns(self.wd, [c for c in todo if set(c.variables) <= self.available])
        scored, unsupported = [], []
        for c in todo:
            reason = self._unsupported(c, cols.get(c.term))
            if reason:
                unsupported.append(_unsup(c.name, c.term, c.variables, c.source, reason))
            else:
                s = self._score(c, cols[c.term])
                scored.append((s, c))
                self.scored.append(s)
        return scored, unsupported

    def _unsupported(self, c: Candidate, z: np.ndarray | None) -> str:
        missing = sorted(set(c.variables) - self.available)
        if missing:
            return f"needs channel(s) {missing}, which the logs do not have"
        if z is None:
            return "the term cannot be evaluated on these logs"
        ok = self.base_ok & np.isfinite(z)
        if ok.sum() < 3 or len(np.unique(self.runs[ok])) < 2:
            return "too few windows with a finite value"
        zz = z[ok]
        if np.ptp(zz) == 0 and zz[0] == 0:
            return "no variance: the term is 0 in every window"
        full = ok.sum() == self.base_ok.sum()
        rel = span_residual(zz, self.x[ok], self.basis if full else None)
        if rel < self.th.span_tol:
            return (
                f"nearly in the span of the model's columns (relative residual {rel:.3g} < "
                f"{self.th.span_tol}): the runs do not vary what it needs (e.g. a speed term "
                "from single-speed runs)"
            )
        return ""

    def _score(self, c: Candidate, z: np.ndarray, x: np.ndarray | None = None) -> Suspect:
        """Held-out scores of the model (``x``, default the current one) plus ``z``."""
        self.n_scored += 1
        x = self.x if x is None else x
        base_ok = np.all(np.isfinite(x), axis=1) & np.isfinite(self.y)
        ok = base_ok & np.isfinite(z)
        y, folds, w = self.y[ok], self.folds[ok], self.w[ok]
        if x is self.x and ok.sum() == self.base_ok.sum():
            e0 = self.base_err[ok]
        else:  # compare on the same windows
            e0 = cv_errors(x[ok], y, folds, w)
        xz = np.column_stack([x[ok], z[ok]])
        e1 = cv_errors(xz, y, folds, w)
        before = float(np.sqrt(np.mean(e0**2)))
        after = float(np.sqrt(np.mean(e1**2)))
        t, p, n_runs = paired_run_test(e0, e1, self.runs[ok])
        explained = 1.0 - (after / before) ** 2 if before > 0 else 0.0
        coef = math.nan  # filled in for the suspects reported (see rank_suspects)
        if x is self.x:
            full = np.full(len(self.y), np.nan)
            full[ok] = e1
            self.errors[c.term] = full
            self.columns[c.term] = z
            self.cands[c.term] = c
        return Suspect(
            name=c.name,
            term=c.term,
            variables=list(c.variables),
            explanation=c.explanation,
            source=c.source,
            error_explained=float(explained),
            heldout_rmse_w=after,
            heldout_rmse_before_w=before,
            reduction_w=before - after,
            z_by_run=t,
            p_value=p,
            n_runs=n_runs,
            n_windows=int(ok.sum()),
            coefficient=coef,
            channel=c.channel,
        )

    def coefficient(self, term: str) -> float:
        """Coefficient of a scored candidate in the model refitted with it (all windows)."""
        z = self.columns.get(term)
        if z is None:
            return math.nan
        ok = self.base_ok & np.isfinite(z)
        xz = np.column_stack([self.x[ok], z[ok]])
        return float(wls(xz, self.y[ok], self.w[ok])[-1])

    def passes(self, s: Suspect, p_thr: float) -> bool:
        """The noise rule (module docstring)."""
        return bool(
            s.p_value < p_thr and s.reduction_w >= self.th.min_rel * s.heldout_rmse_before_w
        )

    def decide(self, s: Suspect, p_thr: float) -> None:
        s.p_threshold = p_thr
        s.above_noise = self.passes(s, p_thr)

    def refine(self, sus: Suspect, cand: Candidate) -> Suspect:
        """For a hinge, search the knot on a finer grid of quantiles around the best one."""
        if cand.knot_level is None or cand.channel is None or cand.source != "data":
            return sus
        v = self.wd.samples[cand.channel].to_numpy(dtype=float)
        fin = v[np.isfinite(v)]
        levels = np.clip(cand.knot_level + np.linspace(-0.1, 0.1, 21), 0.01, 0.99)
        cands = []
        for level, q in zip(levels, np.quantile(fin, levels), strict=True):
            if fin.min() < q < fin.max():
                cands.append(
                    hinge(cand.channel, float(q), cand.below, float(level), cand.hinge_times)
                )
        cands = list({c.term: c for c in cands if c.term != cand.term}.values())
        scored, _ = self.evaluate(cands)
        for s2, _c in scored:
            if s2.heldout_rmse_w < sus.heldout_rmse_w:
                sus = s2
        return sus

    def alternatives(self, best: Suspect, p_thr: float) -> list[Suspect]:
        """Suspects the data cannot tell from ``best`` (module docstring, *Confounded*)."""
        from scipy.stats import norm

        best_c = self.cands.get(best.term)
        pool = [
            s
            for s in self.scored
            if s.term != best.term and self.passes(s, p_thr) and s.term in self.errors
        ]
        # one per (family, shape): hinge knots of one kind are one shape, not alternatives
        seen: set[tuple] = set()
        picked = []
        for s in sorted(pool, key=lambda s: s.heldout_rmse_w):
            c = self.cands[s.term]
            key = (c.channel, c.shape) if c.channel is not None else (s.term,)
            if best_c is not None and best_c.channel is not None:
                if key == (best_c.channel, best_c.shape):
                    continue
            if key in seen:
                continue
            seen.add(key)
            picked.append(s)
            if len(picked) >= 6:
                break
        out = []
        ea = self.errors[best.term]
        za = self.columns[best.term]
        for s in picked:
            eb = self.errors[s.term]
            ok = np.isfinite(ea) & np.isfinite(eb)
            t_ab, _, n = paired_run_test(eb[ok], ea[ok], self.runs[ok])  # > 0: A better
            crit = float(norm.isf(self.th.confound_alpha / 2))
            if not (abs(t_ab) < crit):
                continue
            zb = self.columns[s.term]
            n0 = self.n_scored
            b_given_a = self._score(self.cands[s.term], zb, np.column_stack([self.x, za]))
            a_given_b = self._score(self.cands[best.term], za, np.column_stack([self.x, zb]))
            self.n_scored = n0  # side checks, not candidates of the ranking
            if not self.passes(b_given_a, p_thr) and not self.passes(a_given_b, p_thr):
                s.above_noise = True
                s.p_threshold = p_thr
                out.append(s)
        return out


def _candidate_columns(wd: WindowData, cands: list[Candidate]) -> dict[str, np.ndarray]:
    """Window columns of candidate terms, evaluated all at once (one per term)."""
    from energy_planner.errors import EnergyPlannerError

    terms = list(dict.fromkeys(c.term for c in cands))
    if not terms:
        return {}
    try:
        z = wd.columns(terms)
        return {t: z[:, j] for j, t in enumerate(terms)}
    except EnergyPlannerError:
        out = {}
        for t in terms:  # isolate the term that cannot be evaluated
            try:
                out[t] = wd.columns([t])[:, 0]
            except EnergyPlannerError:
                pass
        return out


# --------------------------------------------------------------------------- staircase


@dataclass
class Step:
    """One step of the greedy staircase."""

    step: int
    added: str | None
    name: str | None
    heldout_rmse_w: float
    fold_rmse_w: list[float]
    error_explained: float | None
    explanation: str = ""
    alternatives: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-friendly dict."""
        return asdict(self)


def staircase(
    wd: WindowData,
    terms: Sequence[str | Term],
    thresholds: Thresholds | None = None,
    max_steps: int = 4,
    progress=None,
    extra: Sequence[str] = (),
) -> tuple[list[Step], list[Ranking]]:
    """Greedy forward selection: add the best suspect, refit, re-rank, while above noise.

    Returns the steps (step 0 is the model as given) and the ranking made at each step.
    """
    th = thresholds or Thresholds()
    folds = run_folds(wd.runs, th.n_splits, th.seed)
    terms = [term_spec(t) for t in terms]
    ranking = rank_suspects(wd, terms, th, folds=folds, extra=extra)
    steps = [Step(0, None, None, ranking.heldout_rmse_w, ranking.fold_rmse_w, None)]
    rankings = [ranking]
    for i in range(1, max_steps + 1):
        if not ranking.suspects:
            break
        best = ranking.suspects[0]
        alts = [
            {"name": a.name, "term": a.term, "explanation": a.explanation,
             "heldout_rmse_w": a.heldout_rmse_w}
            for a in ranking.alternatives
        ]  # fmt: skip
        terms.append(best.term)
        ranking = rank_suspects(wd, terms, th, folds=folds, extra=extra)
        rankings.append(ranking)
        steps.append(
            Step(
                i,
                best.term,
                best.name,
                ranking.heldout_rmse_w,
                ranking.fold_rmse_w,
                best.error_explained,
                best.explanation,
                alts,
            )
        )
        if progress is not None:
            progress(i)
    return steps, rankings


# --------------------------------------------------------------------------- short names

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
    cands, unsupported = default_candidates(wd, context)
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
        The model the terms are added to; default the base model.

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
    from energy_planner.model import BASE_TERMS, CATALOG

    context = [term_spec(t) for t in (BASE_TERMS if base_terms is None else base_terms)]
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
