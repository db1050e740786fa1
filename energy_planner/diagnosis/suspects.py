"""Which physical effect is the model missing: candidates, held-out validation, ranking.

A *candidate* is one more term (a catalog name or a formula) with a one-line physical
explanation. Candidates come from the model catalog (``energy_planner.model.CATALOG``, plus
surface type per value of the ``surface`` channel) and from the data: every extra channel
of the logs gets a few term shapes (``x``, ``x * speed``, ``abs(wz) * x``, hinges
``pos(q - x)`` / ``pos(x - q)`` at data quantiles; per value ``(c == 'v')`` and
``speed * (c == 'v')`` for a categorical channel) and the best shape by held-out error
stands for the channel.

Each candidate is scored by the held-out error of the model refitted with it, validated
by run (grouped K-fold: all windows of a run are in the same fold, so a run is never
predicted by a fit that saw it). The rules:

*Unsupported* (listed, never ranked): the candidate needs a channel the logs lack, its
column has no variance or no finite value, or its column is nearly in the span of the
model's columns: the relative residual ``||z - X b|| / ||z||`` of its least-squares
projection on the model's columns is below ``span_tol`` (default 0.05). Example: a
``speed**2`` term from single-speed runs is ``0.3 * speed`` up to noise, which the motion
terms already carry; its coefficient would be noise.

*Above noise* (a finding): with ``d_f`` the held-out RMSE reduction on fold ``f`` (same
held-out windows with and without the candidate), the mean reduction must exceed ``k``
(default 2.5) times its fold-to-fold standard error ``sd(d_f) / sqrt(n_folds)``, AND the
pooled held-out RMSE must fall by at least ``min_rel`` (default 5 %) of its current value.
The first rule asks that the gain be systematic across runs, not the luck of one fold: it
is a one-sided paired t-test over the folds (with 5 folds, 4 degrees of freedom, t > 2.5
has a chance of about 3 % under no effect; 2.13 would be the usual 5 %). The second keeps
out gains too small to matter, which a search over a few dozen candidates would
otherwise find in noise. Both were checked on noise-only data (see docs/diagnosis.md).

``error_explained`` is the fraction of the current held-out mean squared error that the
candidate removes, ``1 - MSE_cv(with) / MSE_cv(without)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from energy_planner.diagnosis.data import MAX_CATEGORIES, WindowData
from energy_planner.errors import FitError

#: Quantiles at which hinge terms on a numeric channel are tried.
HINGE_QUANTILES = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)


@dataclass(frozen=True)
class Thresholds:
    """Rules that decide support and noise (see the module docstring)."""

    k: float = 2.5
    min_rel: float = 0.05
    span_tol: float = 0.05
    n_splits: int = 5
    seed: int = 0


@dataclass
class Candidate:
    """A candidate physical effect: one more term for the model."""

    name: str
    term: str
    variables: list[str]
    explanation: str
    source: str  # "catalog" or "data"
    channel: str | None = None  # channel whose shapes compete for this candidate
    formula: str = ""  # the formula behind a catalog name (for de-duplication)
    knot_level: float | None = None  # hinge: quantile level of the knot in the channel
    below: bool = True  # hinge: pos(q - x) (True) or pos(x - q)

    def __post_init__(self) -> None:
        self.term = canonical(self.term)
        self.formula = self.formula or self.term


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
    reduction_se_w: float
    above_noise: bool
    n_windows: int
    coefficient: float = math.nan

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


# --------------------------------------------------------------------------- folds / CV


def run_folds(runs: Sequence, n_splits: int = 5, seed: int = 0) -> np.ndarray:
    """Fold index of each window, whole runs per fold.

    The assignment is :func:`energy_planner.calibration.run_folds` (the folds ``fit``
    validates on, for the same ``n_splits`` and ``seed``); ``n_splits`` is reduced to the
    number of runs when there are fewer.

    Examples
    --------
    >>> f = run_folds(["a", "a", "b", "c", "c", "c"], n_splits=2)
    >>> bool(f[0] == f[1]) and bool(f[3] == f[4] == f[5]), sorted(set(f.tolist()))
    (True, [0, 1])
    """
    from energy_planner.calibration import run_folds as calibration_folds

    runs = np.asarray(runs).astype(str)
    uniq = np.unique(runs)
    if len(uniq) < 2:
        raise FitError(
            f"held-out validation by run needs at least 2 runs, got {len(uniq)} "
            f"({list(uniq)}); record more runs"
        )
    folds = calibration_folds(uniq.tolist(), max(2, min(n_splits, len(uniq))), seed)
    fold_of = {r: i for i, part in enumerate(folds) for r in part}
    return np.array([fold_of[r] for r in runs], dtype=np.int64)


def _solve_gram(g: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Minimum-norm solution of the normal equations ``g b = r`` (small, symmetric)."""
    return np.linalg.lstsq(g, r, rcond=1e-12)[0]


def wls(x: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """Weighted least squares ``y ~ x`` (columns scaled; minimum norm if rank-deficient).

    Solved through the normal equations of the unit-norm scaled columns: the problems
    here have a dozen well-scaled columns, and a ``k x k`` solve is much cheaper than an
    SVD of the ``n x k`` matrix when thousands of fits are made.

    >>> x = np.column_stack([np.ones(4), [0.0, 1, 2, 3]])
    >>> np.round(wls(x, np.array([1.0, 3, 5, 7])), 9).tolist()
    [1.0, 2.0]
    """
    sw = np.ones(len(y)) if w is None else np.sqrt(np.asarray(w, float))
    xw = x * sw[:, None]
    scale = np.linalg.norm(xw, axis=0)
    scale[scale == 0] = 1.0
    xs = xw / scale
    return _solve_gram(xs.T @ xs, xs.T @ (y * sw)) / scale


def _cv_errors(x: np.ndarray, y: np.ndarray, folds: np.ndarray, w=None) -> np.ndarray:
    """Held-out residuals of weighted least squares ``y ~ x`` by fold (prediction >= 0).

    The training normal equations of a fold are the totals minus the fold's own.
    """
    sw = np.ones(len(y)) if w is None else np.sqrt(np.asarray(w, float))
    xw = x * sw[:, None]
    scale = np.linalg.norm(xw, axis=0)
    scale[scale == 0] = 1.0
    xs = xw / scale
    yw = y * sw
    g, r = xs.T @ xs, xs.T @ yw
    err = np.empty_like(y)
    for f in np.unique(folds):
        te = folds == f
        xt = xs[te]
        coef = _solve_gram(g - xt.T @ xt, r - xt.T @ yw[te]) / scale
        err[te] = y[te] - np.maximum(x[te] @ coef, 0.0)
    return err


def _fold_rmse(err: np.ndarray, folds: np.ndarray, n_folds: int) -> np.ndarray:
    sq = np.bincount(folds, weights=err**2, minlength=n_folds)
    n = np.bincount(folds, minlength=n_folds)
    return np.sqrt(sq / np.maximum(n, 1))


def heldout_rmse(
    x: np.ndarray, y: np.ndarray, folds: np.ndarray, w: np.ndarray | None = None
) -> tuple[float, np.ndarray]:
    """Pooled and per-fold held-out RMSE of the linear model ``y ~ x`` validated by fold.

    The fits weigh each row by ``w`` (window duration, as the calibration does); the RMSE
    weighs every held-out window alike.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = np.column_stack([np.ones(200), rng.uniform(size=200)])
    >>> y = x @ [1.0, 2.0] + rng.normal(0, 0.1, 200)
    >>> rmse, per_fold = heldout_rmse(x, y, np.arange(200) % 4)
    >>> bool(0.08 < rmse < 0.12), per_fold.shape
    (True, (4,))
    """
    err = _cv_errors(x, y, folds, w)
    n_folds = int(folds.max()) + 1
    return float(np.sqrt(np.mean(err**2))), _fold_rmse(err, folds, n_folds)


def span_basis(x: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column span of ``x`` (from its SVD)."""
    if x.shape[1] == 0:
        return np.zeros((x.shape[0], 0))
    u, sv, _ = np.linalg.svd(x, full_matrices=False)
    return u[:, sv > sv[0] * 1e-10] if sv.size and sv[0] > 0 else u[:, :0]


def span_residual(z: np.ndarray, x: np.ndarray, basis: np.ndarray | None = None) -> float:
    """Relative residual ``||z - X b|| / ||z||`` of the projection of ``z`` on ``X``'s span.

    0 means ``z`` is a combination of the columns of ``X`` (the data cannot tell it apart);
    1 means it is orthogonal to them. ``basis`` (:func:`span_basis` of ``x``) saves the
    decomposition when many ``z`` are tested against the same ``x``.

    Examples
    --------
    >>> x = np.column_stack([np.ones(4), [0.0, 1, 2, 3]])
    >>> round(span_residual(np.array([1.0, 3, 5, 7]), x), 6)
    0.0
    """
    norm = float(np.linalg.norm(z))
    if norm == 0.0:
        return 0.0
    q = span_basis(x) if basis is None else basis
    return float(np.linalg.norm(z - q @ (q.T @ z)) / norm)


# --------------------------------------------------------------------------- candidates


def _fmt(q: float) -> str:
    """Short literal for a threshold in a formula."""
    return f"{float(q):.4g}"


def hinge(ch: str, q: float, below: bool, level: float | None = None) -> Candidate:
    """The hinge candidate ``pos(q - ch)`` (``below``) or ``pos(ch - q)`` on a channel.

    >>> hinge("temperature_c", 15.0, True).term
    'pos(15 - temperature_c)'
    >>> hinge("x", -2.5, False).term
    'pos(x + 2.5)'
    """
    qs = _fmt(q)
    if below:
        return Candidate(
            f"{ch}<{qs}",
            f"pos({qs} - {ch})",
            [ch],
            f"extra standing power grows as {ch} falls below {qs} (a threshold effect, "
            "e.g. stiff cold joints, a low battery)",
            "data",
            ch,
            knot_level=level,
            below=True,
        )
    return Candidate(
        f"{ch}>{qs}",
        f"pos({ch} - {qs})" if q >= 0 else f"pos({ch} + {_fmt(-q)})",
        [ch],
        f"extra standing power grows as {ch} rises above {qs} (a threshold effect)",
        "data",
        ch,
        knot_level=level,
        below=False,
    )


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


def channel_candidates(
    wd: WindowData, catalog_terms: Iterable[str] = ()
) -> tuple[list[Candidate], list[dict]]:
    """Data-driven candidates, one group of shapes per extra channel.

    Returns the candidates and the channels that cannot give one (with the reason).
    """
    skip_terms = {canonical(t) for t in catalog_terms}
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
        shapes = [
            (ch, ch, f"a standing power proportional to {ch}"),
            (
                f"{ch}*speed",
                f"{ch} * speed",
                f"a force along the motion proportional to {ch} (drag, resistance, carried load)",
            ),
            (f"{ch}*turn", f"abs(wz) * {ch}", f"the cost of turning grows with {ch}"),
        ]
        for name, term, expl in shapes:
            if canonical(term) in skip_terms:
                continue
            variables = sorted(
                {ch, *(["speed"] if "speed" in term else []), *(["wz"] if "wz" in term else [])}
            )
            out.append(Candidate(name, term, variables, expl, "data", ch))
        seen = set()
        for level, q in zip(HINGE_QUANTILES, np.quantile(fin, HINGE_QUANTILES), strict=True):
            key = _fmt(q)
            if fin.min() < q < fin.max() and key not in seen:  # at an end: 0 or linear
                seen.add(key)
                out.extend(hinge(ch, float(q), b, level) for b in (True, False))
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
            for name, term, variables, expl in (
                (
                    f"{ch}=={value}",
                    f"({ch} == {value!r})",
                    [ch],
                    f"extra standing power when {ch} is {value}",
                ),
                (
                    f"speed*({ch}=={value})",
                    f"speed * ({ch} == {value!r})",
                    ["speed", ch],
                    f"a different force per metre when {ch} is {value}",
                ),
            ):
                if canonical(term) in skip_terms:
                    continue
                out.append(Candidate(name, term, variables, expl, "data", ch))
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


def rank_suspects(
    wd: WindowData,
    terms: Sequence[str],
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
    terms : sequence of str
        The current model's terms (names or formulas).
    thresholds : Thresholds, optional
        Support and noise rules.
    candidates : list of Candidate, optional
        Default: catalog and data-driven candidates (:func:`catalog_candidates`,
        :func:`channel_candidates`).
    folds : numpy.ndarray, optional
        Fold of each window (:func:`run_folds`); default from ``thresholds``.
    extra : sequence of str
        More candidate terms to test (the user's own hypotheses), scored like the others.

    Returns
    -------
    Ranking
    """
    th = thresholds or Thresholds()
    y = wd.power
    x = wd.columns(terms)
    if folds is None:
        folds = run_folds(wd.runs, th.n_splits, th.seed)
    unsupported: list[dict] = []
    if candidates is None:
        candidates = catalog_candidates(terms, wd)
        data, bad = channel_candidates(
            wd, [c.term for c in candidates] + [c.formula for c in candidates]
        )
        candidates = candidates + data
        unsupported.extend(bad)
    seen = {c.term for c in candidates}
    candidates = candidates + [c for c in user_candidates(extra) if c.term not in seen]
    ctx = _Context(wd, x, y, folds, th, {canonical(t) for t in terms})
    scored, unsup = ctx.evaluate(candidates)
    unsupported.extend(unsup)
    # the best shape per data channel stands for the channel (hinge knots refined)
    best: dict[str, tuple[Suspect, Candidate]] = {}
    rest: list[Suspect] = []
    for sus, cand in scored:
        if cand.source == "data" and cand.channel is not None:
            prev = best.get(cand.channel)
            if prev is None or sus.heldout_rmse_w < prev[0].heldout_rmse_w:
                best[cand.channel] = (sus, cand)
        else:
            rest.append(sus)
    final = rest + [ctx.refine(sus, cand) for sus, cand in best.values()]
    final.sort(key=lambda s: -s.error_explained)
    return Ranking(
        terms=list(terms),
        heldout_rmse_w=ctx.base_rmse,
        fold_rmse_w=ctx.base_fold.tolist(),
        suspects=[s for s in final if s.above_noise],
        below_noise=[s for s in final if not s.above_noise],
        unsupported=unsupported,
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
        ok = self.base_ok
        self.base_rmse, self.base_fold = heldout_rmse(
            self.x[ok], self.y[ok], self.folds[ok], self.w[ok]
        )
        self.available = set(self.wd.samples.columns) | {"speed"}
        self.basis = span_basis(self.x[ok])

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
                scored.append((self._score(c, cols[c.term]), c))
        return scored, unsupported

    def _unsupported(self, c: Candidate, z: np.ndarray | None) -> str:
        missing = sorted(set(c.variables) - self.available)
        if missing:
            return f"needs channel(s) {missing}, which the logs do not have"
        if z is None:
            return "the term cannot be evaluated on these logs"
        ok = self.base_ok & np.isfinite(z)
        if ok.sum() < 3 or len(np.unique(self.wd.runs[ok])) < 2:
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

    def _score(self, c: Candidate, z: np.ndarray) -> Suspect:
        ok = self.base_ok & np.isfinite(z)
        x, y, folds, w = self.x[ok], self.y[ok], self.folds[ok], self.w[ok]
        if ok.sum() == self.base_ok.sum():
            before, before_fold = self.base_rmse, self.base_fold
        else:  # compare on the same windows
            before, before_fold = heldout_rmse(x, y, folds, w)
        xz = np.column_stack([x, z[ok]])
        after, after_fold = heldout_rmse(xz, y, folds, w)
        present = np.bincount(folds, minlength=self.n_folds) > 0
        d = (before_fold - after_fold)[present]
        se = float(np.std(d, ddof=1) / np.sqrt(d.size)) if d.size > 1 else math.inf
        red = before - after
        explained = 1.0 - (after / before) ** 2 if before > 0 else 0.0
        above = bool(d.mean() > self.th.k * se and red >= self.th.min_rel * before)
        coef = float(wls(xz, y, w)[-1])
        return Suspect(
            name=c.name,
            term=c.term,
            variables=list(c.variables),
            explanation=c.explanation,
            source=c.source,
            error_explained=float(explained),
            heldout_rmse_w=float(after),
            heldout_rmse_before_w=float(before),
            reduction_w=float(red),
            reduction_se_w=se,
            above_noise=above,
            n_windows=int(ok.sum()),
            coefficient=coef,
        )

    def refine(self, sus: Suspect, cand: Candidate) -> Suspect:
        """For a hinge, search the knot on a finer grid of quantiles around the best one."""
        if cand.knot_level is None or cand.channel is None:
            return sus
        v = self.wd.samples[cand.channel].to_numpy(dtype=float)
        fin = v[np.isfinite(v)]
        levels = np.clip(cand.knot_level + np.linspace(-0.1, 0.1, 21), 0.01, 0.99)
        cands = []
        for level, q in zip(levels, np.quantile(fin, levels), strict=True):
            if fin.min() < q < fin.max():
                cands.append(hinge(cand.channel, float(q), cand.below, float(level)))
        cands = list({c.term: c for c in cands if c.term != cand.term}.values())
        scored, _ = self.evaluate(cands)
        for s2, _c in scored:
            if s2.heldout_rmse_w < sus.heldout_rmse_w:
                sus = s2
        return sus


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

    def to_dict(self) -> dict:
        """JSON-friendly dict."""
        return asdict(self)


def staircase(
    wd: WindowData,
    terms: Sequence[str],
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
    terms = list(terms)
    ranking = rank_suspects(wd, terms, th, folds=folds, extra=extra)
    steps = [Step(0, None, None, ranking.heldout_rmse_w, ranking.fold_rmse_w, None)]
    rankings = [ranking]
    for i in range(1, max_steps + 1):
        if not ranking.suspects:
            break
        best = ranking.suspects[0]
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
            )
        )
        if progress is not None:
            progress(i)
    return steps, rankings
