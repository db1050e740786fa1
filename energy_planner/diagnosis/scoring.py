"""Scoring candidates on held-out runs: the run test, the noise rule, the ranking.

The rules (held-out by run, the signed-rank test by run, the choice tested nested by fold,
Bonferroni over the candidates scored, the smallest relative gain, confounded suspects)
are told in :mod:`energy_planner.diagnosis.suspects`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import pandas as pd

from energy_planner.calibration.windowdata import WindowData
from energy_planner.diagnosis.candidates import (
    Candidate,
    _unsup,
    canonical,
    default_candidates,
    hinge,
    user_candidates,
)
from energy_planner.diagnosis.names import term_spec
from energy_planner.model.terms import Term
from energy_planner.stats import fold_index, paired_run_test, span_basis, span_residual
from energy_planner.stats import wls_coef as wls
from energy_planner.stats.heldout import choice_by_fold, run_sq_gain


@dataclass(frozen=True)
class Thresholds:
    """Rules that decide support and noise (see the module docstring).

    Attributes
    ----------
    alpha : float
        Family-wise false-finding level of one ranking: choosing a candidate (nested by
        fold, :class:`ChoiceTest`) must pass at ``alpha``; then the best candidate's
        one-sided test by run at ``alpha``, another's at ``alpha / m`` (``m`` candidates
        scored).
    min_rel : float
        Smallest relative reduction of the pooled held-out RMSE that counts.
    span_tol : float
        Candidates whose column is within this relative residual of the model's span
        are unsupported.
    n_splits, seed : int
        Folds by run and the seed of their assignment.
    n_partitions : int
        Partitions of the runs into folds that the choice test (rule 1) averages over: the
        ranking's own (``seed``) and ``n_partitions - 1`` more (seeds ``seed + 1, ...``;
        a partition equal to an earlier one counts once, as with one run per fold). A
        run's gain is its mean over them, so that the test does not turn on how the runs
        happen to be dealt into folds (one partition may hold out together the few runs
        an effect shows in).
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
    n_partitions: int = 10


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
    #: suspects above noise that a refit with them leaves out (``term``, ``name``,
    #: ``reason``), best first: the staircase tried them before the one it added
    dropped: list[dict] = field(default_factory=list)
    #: the test of the choice itself (:class:`ChoiceTest`), None when nothing was scored
    choice: ChoiceTest | None = None
    #: the windows their fold's training runs do not walk as they walk
    #: (:func:`outside_support`): every score and test is over the others
    #: (``supported_rmse_w``); ``heldout_rmse_w`` is over every window, as ``fit``'s
    outside: dict = field(default_factory=dict)
    supported_rmse_w: float = math.nan
    #: which windows are supported by their fold (``WindowData.fold_support``)
    supported: np.ndarray | None = field(default=None, repr=False)
    #: the best candidate when it passes its own test but the choice test fails
    #: (:class:`Undecided`): the logs cannot decide it; None otherwise
    undecided: Undecided | None = None


@dataclass(frozen=True)
class ChoiceTest:
    """The held-out test of choosing the best candidate (nested by fold).

    For each fold, the candidate its training folds alone choose
    (:func:`energy_planner.stats.heldout.choice_by_fold`); the held-out errors of every
    fold's windows with its own choice, against the model's, by the run test. The folds
    are dealt ``Thresholds.n_partitions`` times (:func:`choice_partitions`), and the test
    is of each run's squared-error gain averaged over the partitions. When no candidate
    passes its own test at ``alpha`` nothing can be above noise whatever this test says,
    and it is made on the ranking's own partition only (``partitions`` holds one).

    Attributes
    ----------
    chosen : list of str or None
        The term each fold's training folds chose in the ranking's own partition (None:
        none improves there).
    heldout_rmse_w : float
        Pooled held-out RMSE of the windows with their fold's choice (over every
        partition), W.
    z, p_value : float
        The run test's statistic and one-sided p-value.
    n_runs : int
        Runs in the test.
    p_threshold : float
        The level the p-value must be below (its share of ``Thresholds.alpha``).
    partitions : list of list of str or None
        Each partition's choices fold by fold (the first is ``chosen``).
    partition_p_values : list of float
        The run test of each partition alone (for the record: the test is the pooled one).
    """

    chosen: list[str | None]
    heldout_rmse_w: float
    z: float
    p_value: float
    n_runs: int
    p_threshold: float
    partitions: list[list[str | None]] = field(default_factory=list)
    partition_p_values: list[float] = field(default_factory=list)

    @property
    def all_chosen(self) -> list[str | None]:
        """Every fold's choice, partition after partition."""
        return [c for part in (self.partitions or [self.chosen]) for c in part]

    @property
    def passed(self) -> bool:
        """Choosing a candidate lowers the held-out error beyond noise."""
        return bool(self.p_value < self.p_threshold)

    def to_dict(self) -> dict:
        """JSON-friendly dict."""
        return asdict(self) | {"passed": self.passed}


#: Runs :class:`Undecided` describes, largest gain first.
UNDECIDED_TOP_RUNS = 3
#: Share of an undecided candidate's gain that makes it rest on few runs: its note names
#: the top run when that one carries this much, else the top three when they do, else it
#: calls the gain spread over the runs.
FEW_RUNS_SHARE = 0.5


@dataclass(frozen=True)
class Undecided:
    """The best candidate when its own test passes but the choice test fails.

    The candidate lowers the held-out error by itself (its own run test below its level
    and the ``min_rel`` gain) but the folds do not agree on choosing it
    (:class:`ChoiceTest` failed), so the ranking has nothing above noise: the logs cannot
    decide it. The usual reason is a gain that rests on few runs; how much it does is
    measured by run from the same held-out errors as its own test
    (:func:`~energy_planner.stats.heldout.run_sq_gain` over the supported windows).

    Attributes
    ----------
    name, term, variables, explanation, source : str, str, list of str, str, str
        As the candidate's :class:`Suspect`.
    heldout_rmse_before_w, heldout_rmse_w : float
        Held-out RMSE without and with it (its own score: the supported windows), W.
    p_value, p_threshold : float
        Its own run test and the level it passes (``Thresholds.alpha``).
    chosen : list of str or None
        The term each fold's training runs chose, partition after partition
        (:attr:`ChoiceTest.all_chosen`).
    n_folds_chose : int
        Folds (of every partition) whose choice is this candidate.
    choice_p_value, choice_p_threshold : float
        The choice test's p-value and level.
    n_runs, n_runs_better : int
        Runs scored, and those whose squared held-out error it lowers.
    top_share, top3_share : float
        Share of its reduction of the pooled squared held-out error that comes from the
        run with the largest reduction, and from the three largest (the runs that lose
        count against the total, so a share can exceed 1).
    top_runs : list of dict
        The :data:`UNDECIDED_TOP_RUNS` runs with the largest reduction: ``run``, ``share``,
        ``n_windows``, ``values`` (the run's duration-weighted mean of each of the term's
        extra channels, of ``slope_deg`` (``|alpha|``) and of ``speed``, where the windows
        carry them; a categorical channel: its most frequent value) and ``runs_as_high`` /
        ``runs_as_low`` (for each value, the runs whose value is at least / at most as
        large, this one included; a categorical value: the runs with the same value), among
        the ``n_runs`` scored.
    """

    name: str
    term: str
    variables: list[str]
    explanation: str
    source: str
    heldout_rmse_before_w: float
    heldout_rmse_w: float
    p_value: float
    p_threshold: float
    chosen: list[str | None]
    n_folds_chose: int
    choice_p_value: float
    choice_p_threshold: float
    n_runs: int
    n_runs_better: int
    top_share: float
    top3_share: float
    top_runs: list[dict]

    def to_dict(self) -> dict:
        """JSON-friendly dict."""
        return asdict(self)

    def sentence(self) -> str:
        """What it means for the user, in one sentence (the closing note says it).

        Examples
        --------
        >>> u = Undecided("load_kg^2", "load_kg ** 2", ["load_kg"], "", "data", 11.59, 8.93,
        ...               0.005, 0.01, ["load_kg ** 2", "speed", None, "load_kg ** 2",
        ...               "load_kg ** 2"], 3, 0.09, 0.01, 60, 42, 0.79, 1.02,
        ...               [{"run": "m46", "share": 0.79, "n_windows": 30,
        ...                 "values": {"load_kg": 9.0, "slope_deg": 21.0, "speed": 0.4},
        ...                 "runs_as_high": {"load_kg": 30, "slope_deg": 1, "speed": 20},
        ...                 "runs_as_low": {"load_kg": 31, "slope_deg": 60, "speed": 41}}])
        >>> print(u.sentence())  # doctest: +NORMALIZE_WHITESPACE
        load_kg^2 would lower the held-out RMSE 11.6 -> 8.93 W (its own test by run: p 0.005),
        but the folds disagree on choosing it (3 of 5 chose it; choice test p 0.09, not below
        0.01) and 79 % of its gain comes from run m46 (load_kg 9, slope 21 deg, speed 0.4 m/s):
        the logs cannot decide it; log more runs like it (slope 21 deg or more: 1 of 60 runs)
        to decide; `fit --term load_kg^2`, with the model's other terms, adds it by hand
        """
        lead = (
            f"{self.name} would lower the held-out RMSE {self.heldout_rmse_before_w:.3g} -> "
            f"{self.heldout_rmse_w:.3g} W (its own test by run: p {self.p_value:.2g}), but the "
            f"folds disagree on choosing it ({self.n_folds_chose} of {len(self.chosen)} chose "
            f"it; choice test p {self.choice_p_value:.2g}, not below {self.choice_p_threshold:g})"
        )
        hint = f"`fit --term {self.name}`, with the model's other terms, adds it by hand"
        top = self.top_runs[0] if self.top_runs else None
        if top is None or self.top3_share < FEW_RUNS_SHARE:  # spread: no run to point at
            return (
                f"{lead}, with a gain spread over the runs ({self.n_runs_better} of "
                f"{self.n_runs} improve): more runs would decide; {hint}"
            )
        if self.top_share < FEW_RUNS_SHARE:  # three runs: the first described, with its own share
            first = f"{top['run']} ({_run_values(top)}; {_pct(self.top_share)})"
            rest = [r["run"] for r in self.top_runs[1:]]
            names = ", ".join([first, *rest[:-1]]) + (f" and {rest[-1]}" if rest else "")
            runs = f"{_pct(self.top3_share)} of its gain comes from runs {names}"
        else:
            runs = f"{_pct(self.top_share)} of its gain comes from run {top['run']} ("
            runs += f"{_run_values(top)})"
        rare = _rare_values(top, self.n_runs)
        them = "these" if self.top_share < FEW_RUNS_SHARE else "it"
        like = f"log more runs like {them}" + (f" ({rare})" if rare else "") + " to decide"
        return f"{lead} and {runs}: the logs cannot decide it; {like}; {hint}"


def _pct(v: float) -> str:
    return f"{100 * v:.0f} %"


def _fmt_value(key: str, v) -> str:
    if isinstance(v, str):
        return f"{key} {v}"
    if key == "slope_deg":
        return f"slope {v:.0f} deg"
    if key == "speed":
        return f"speed {v:.2g} m/s"
    return f"{key} {v:.3g}"


def _run_values(run: dict) -> str:
    return ", ".join(_fmt_value(k, v) for k, v in run["values"].items())


def _rare_values(run: dict, n_runs: int) -> str:
    """The values of ``run`` that few runs share (at most 10 % of them, at least one)."""
    few = max(1, int(0.1 * n_runs))
    out = []
    for k, v in run["values"].items():
        hi, lo = run["runs_as_high"].get(k, n_runs), run["runs_as_low"].get(k, n_runs)
        if isinstance(v, str):
            if hi <= few:
                out.append(f"{_fmt_value(k, v)}: {hi} of {n_runs} runs")
        elif hi <= few and hi <= lo:
            out.append(f"{_fmt_value(k, v)} or more: {hi} of {n_runs} runs")
        elif lo <= few:
            out.append(f"{_fmt_value(k, v)} or less: {lo} of {n_runs} runs")
    return "; ".join(out)


def choice_partitions(folds: np.ndarray, runs: np.ndarray, th: Thresholds) -> list[np.ndarray]:
    """The partitions of the runs into folds that the choice test averages over.

    ``folds`` (the ranking's own) first, then :func:`~energy_planner.stats.fold_index` with
    seeds ``th.seed + 1, ...`` up to ``th.n_partitions`` in all; a partition that deals the
    runs as an earlier one does (whatever its fold numbers) is left out.

    Examples
    --------
    Three runs in three folds can be dealt only one way (one run per fold):

    >>> runs = np.array(["a", "a", "b", "c"])
    >>> f = fold_index(runs, 3, 0)
    >>> len(choice_partitions(f, runs, Thresholds(n_splits=3)))
    1
    >>> runs = np.repeat(np.arange(12), 2)
    >>> len(choice_partitions(fold_index(runs, 3, 0), runs, Thresholds(n_splits=3)))
    10
    """
    out = [np.asarray(folds)]
    seen = {_dealt(out[0], runs)}
    for r in range(1, th.n_partitions):
        f = fold_index(runs, th.n_splits, th.seed + r)
        key = _dealt(f, runs)
        if key not in seen:
            seen.add(key)
            out.append(f)
    return out


def _dealt(folds: np.ndarray, runs: np.ndarray) -> frozenset:
    """How ``folds`` deals the runs, whatever the folds' numbers: the set of run groups."""
    groups: dict[int, set] = {}
    for f, r in set(zip(np.asarray(folds).tolist(), np.asarray(runs).tolist(), strict=True)):
        groups.setdefault(f, set()).add(r)
    return frozenset(frozenset(g) for g in groups.values())


def _fold_rmse(err: np.ndarray, folds: np.ndarray, n_folds: int) -> np.ndarray:
    sq = np.bincount(folds, weights=err**2, minlength=n_folds)
    n = np.bincount(folds, minlength=n_folds)
    return np.sqrt(sq / np.maximum(n, 1))


#: The significance test of a candidate (:func:`energy_planner.stats.paired_run_test`), as
#: reports name it (one place: the text, the HTML report and the docs read it here).
RUN_TEST_NAME = "one-sided Wilcoxon signed-rank test by run"


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
        Fold of each window (:func:`~energy_planner.stats.fold_index`); default from
        ``thresholds``.
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
        folds = fold_index(wd.runs, th.n_splits, th.seed)
    unsupported: list[dict] = []
    if candidates is None:
        candidates, bad = default_candidates(wd, terms)
        unsupported.extend(bad)
    seen = {c.term for c in candidates}
    candidates = candidates + [c for c in user_candidates(extra) if c.term not in seen]
    ctx = _Context(wd, x, y, folds, th, {canonical(t) for t in terms}, list(terms))
    outside = outside_support(ctx.base_err, ctx.inside, wd.runs)
    scored, unsup = ctx.evaluate(candidates)
    unsupported.extend(unsup)
    # the candidates fixed before any look at the errors (the refined knots are not)
    a_priori = [s.term for s, _ in scored]
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
    # the gate (suspects' docstring, *Above noise*): choosing at all, tested at alpha on
    # errors no choice saw; only then the best at alpha and the others at alpha / m
    # when no candidate passes its own test at alpha nothing can be above noise whatever
    # the choice test says: it is then made on the ranking's own partition only (a report)
    decisive = any(ctx.passes(s, th.alpha) for s in final)
    choice = ctx.choice_test(a_priori, th.alpha, None if decisive else 1)
    undecided = None
    if choice is None or not choice.passed:
        for s in final:
            s.above_noise = False
        if choice is not None and final and ctx.passes(final[0], th.alpha):
            undecided = ctx.undecided(final[0], choice)  # a report: decides nothing
    elif final and not final[0].above_noise:
        ctx.decide(final[0], th.alpha)
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
        choice=choice,
        outside=outside,
        supported_rmse_w=ctx.supported_rmse,
        supported=ctx.inside,
        undecided=undecided,
    )


def outside_support(err: np.ndarray, inside: np.ndarray, runs: np.ndarray) -> dict:
    """The held-out error of the windows outside their fold's support, apart.

    Parameters
    ----------
    err : numpy.ndarray
        Held-out error of every window (NaN: not scored).
    inside : numpy.ndarray
        Whether each window's fold supports it (``WindowData.fold_support``).
    runs : numpy.ndarray
        Run of every window.

    Returns
    -------
    dict
        ``n_windows``, ``n_runs``, ``rmse_w`` (NaN when there are none) and
        ``share_sq_error`` (their share of the squared held-out error of all windows).

    Examples
    --------
    >>> outside_support(np.array([1.0, 1.0, 7.0]), np.array([True, True, False]),
    ...                 np.array(["a", "a", "b"]))
    {'n_windows': 1, 'n_runs': 1, 'rmse_w': 7.0, 'share_sq_error': 0.9607843137254902}
    """
    ok = np.isfinite(err)
    out = ok & ~np.asarray(inside, dtype=bool)
    total = float(np.sum(err[ok] ** 2))
    sq = float(np.sum(err[out] ** 2))
    return {
        "n_windows": int(out.sum()),
        "n_runs": int(len(np.unique(np.asarray(runs)[out]))),
        "rmse_w": float(np.sqrt(sq / out.sum())) if out.any() else math.nan,
        "share_sq_error": sq / total if total > 0 else 0.0,
    }


@dataclass
class _Context:
    """What scoring a candidate needs: the data, the model's columns and the folds."""

    wd: WindowData
    x: np.ndarray
    y: np.ndarray
    folds: np.ndarray
    th: Thresholds
    have: set[str]
    terms: list = field(default_factory=list)  # the model's, in the order of x

    def __post_init__(self) -> None:
        self.n_folds = int(self.folds.max()) + 1
        self.base_ok = np.all(np.isfinite(self.x), axis=1) & np.isfinite(self.y)
        self.w = self.wd.weights
        self.runs = self.wd.runs
        # the runs as integers in the order of their names: the run tests group by them
        # (the same groups, in the same order, without sorting strings every candidate)
        self.run_codes = np.unique(self.runs, return_inverse=True)[1].reshape(-1)
        ok = self.base_ok
        self.base_err = np.full(len(self.y), np.nan)
        self.base_err[ok] = self.wd.heldout(self.terms, self.folds, ok).residuals
        # the windows their fold's training runs support: every score is over these
        self.inside = self.wd.fold_support(self.folds)
        if not (ok & self.inside).any():  # nothing supported: score every window
            self.inside = np.ones(len(self.y), dtype=bool)
        e = self.base_err[ok]  # the model's held-out RMSE: every window (as fit's)
        self.base_rmse = float(np.sqrt(np.mean(e**2)))
        self.base_fold = _fold_rmse(e, self.folds[ok], self.n_folds)
        self.supported_rmse = float(np.sqrt(np.mean(self.base_err[ok & self.inside] ** 2)))
        self.available = set(self.wd.samples.columns) | {"speed"}
        self.x_ok = self.x[ok]  # the model's columns on its windows (the span's rows)
        self.n_ok = int(ok.sum())
        self.basis = span_basis(self.x_ok)
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
        n_ok = int(ok.sum())
        if n_ok < 3:
            return "too few windows with a finite value"
        codes = self.run_codes[ok]
        if not (codes != codes[0]).any():  # one run
            return "too few windows with a finite value"
        zz = z[ok]
        if np.ptp(zz) == 0 and zz[0] == 0:
            return "no variance: the term is 0 in every window"
        if n_ok == self.n_ok:  # the model's windows: their span's basis, made once
            rel = span_residual(zz, self.x_ok, self.basis)
        else:
            rel = span_residual(zz, self.x[ok])
        if rel < self.th.span_tol:
            return (
                f"nearly in the span of the model's columns (relative residual {rel:.3g} < "
                f"{self.th.span_tol}): the runs do not vary what it needs (e.g. a speed term "
                "from single-speed runs)"
            )
        return ""

    def _score(self, c: Candidate, z: np.ndarray, plus: str | None = None) -> Suspect:
        """Held-out scores of the model (and the scored term ``plus``) plus ``z``."""
        self.n_scored += 1
        more = [] if plus is None else [plus]
        if plus is None:
            base_ok = self.base_ok
        else:
            x = np.column_stack([self.x, self.columns[plus]])
            base_ok = np.all(np.isfinite(x), axis=1) & np.isfinite(self.y)
        ok = base_ok & np.isfinite(z)
        if plus is None and ok.sum() == self.base_ok.sum():
            e0 = self.base_err[ok]
        else:  # compare on the same windows
            e0 = self.wd.heldout(self.terms, self.folds, ok, extra=more).residuals
        e1 = self.wd.heldout(self.terms, self.folds, ok, extra=[*more, c.term]).residuals
        sup = self.inside[ok]  # the scores: over the supported windows
        before = float(np.sqrt(np.mean(e0[sup] ** 2)))
        after = float(np.sqrt(np.mean(e1[sup] ** 2)))
        t, p, n_runs = paired_run_test(e0[sup], e1[sup], self.run_codes[ok][sup])
        explained = 1.0 - (after / before) ** 2 if before > 0 else 0.0
        coef = math.nan  # filled in for the suspects reported (see rank_suspects)
        if plus is None:
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
            n_windows=int((ok & self.inside).sum()),
            coefficient=coef,
            channel=c.channel,
        )

    def choice_test(
        self, terms: list[str], level: float, n_partitions: int | None = None
    ) -> ChoiceTest | None:
        """:class:`ChoiceTest` of the candidates ``terms`` (scored, a priori) at ``level``.

        Over ``n_partitions`` partitions (default ``Thresholds.n_partitions``).
        """
        terms = [t for t in terms if t in self.columns]
        if not terms or not (self.base_ok & self.inside).any():
            return None
        ok = self.base_ok
        Z = np.column_stack([self.columns[t][ok] for t in terms])
        th = self.th if n_partitions is None else replace(self.th, n_partitions=n_partitions)
        e0s, e1s, runs, chosen, p_each = [], [], [], [], []
        for r, folds in enumerate(choice_partitions(self.folds, self.runs, th)):
            if r == 0:  # the ranking's own folds: its errors are already made
                base, inside, errors = self.base_err, self.inside, self.errors
            else:
                base = np.full(len(self.y), np.nan)
                base[ok] = self.wd.heldout(self.terms, folds, ok).residuals
                inside = self.wd.fold_support(folds)
                if not (ok & inside).any():
                    inside = np.ones(len(self.y), dtype=bool)
                errors = {}
            # scored on the supported windows only: a fold whose training runs lack a way
            # of walking extrapolates it, and the folds would choose whatever fits that
            # extrapolation; every window still enters the fits
            sup = inside[ok]
            f_ok = folds[ok]
            pick = choice_by_fold(self.x[ok], Z, self.y[ok], f_ok, self.w[ok], scored=sup)
            e0 = base[ok]
            e1 = e0.copy()
            for f, j in enumerate(pick):
                if j < 0:
                    continue
                if terms[j] not in errors:
                    errors[terms[j]] = self._heldout_with(terms[j], folds)
                ej = errors[terms[j]][ok]
                there = (f_ok == f) & np.isfinite(ej)
                e1[there] = ej[there]
            codes = self.run_codes[ok][sup]
            p_each.append(paired_run_test(e0[sup], e1[sup], codes)[1])
            e0s.append(e0[sup])
            e1s.append(e1[sup])
            runs.append(codes)
            chosen.append([terms[j] if j >= 0 else None for j in pick])
        # each run's gain is its mean over the partitions (paired_run_test averages a run's
        # windows, and a run has its windows once per partition)
        e1 = np.concatenate(e1s)
        z, p, n = paired_run_test(np.concatenate(e0s), e1, np.concatenate(runs))
        return ChoiceTest(
            chosen=chosen[0],
            heldout_rmse_w=float(np.sqrt(np.mean(e1**2))),
            z=z,
            p_value=p,
            n_runs=n,
            p_threshold=level,
            partitions=chosen,
            partition_p_values=[float(v) for v in p_each],
        )

    def _heldout_with(self, term: str, folds: np.ndarray) -> np.ndarray:
        """Held-out errors of the model plus the scored candidate ``term`` on ``folds``.

        NaN where its column is not finite; made as :meth:`_score` makes them.
        """
        z = self.columns[term]
        ok = self.base_ok & np.isfinite(z)
        out = np.full(len(self.y), np.nan)
        out[ok] = self.wd.heldout(self.terms, folds, ok, extra=[term]).residuals
        return out

    def undecided(self, s: Suspect, choice: ChoiceTest) -> Undecided:
        """:class:`Undecided` of the scored candidate ``s`` (its gain by run)."""
        e1 = self.errors[s.term]
        ok = self.base_ok & np.isfinite(e1) & self.inside  # the windows of its own test
        ids, gain, count = run_sq_gain(self.base_err[ok], e1[ok], self.runs[ok])
        total = float(gain.sum())
        order = np.argsort(-gain, kind="stable")
        share = gain / total if total > 0 else np.full(gain.shape, np.nan)
        values = _run_values_table(self.wd, s.variables)
        values = {str(r): values.get(str(r), {}) for r in ids}  # the runs scored
        top = []
        for i in order[:UNDECIDED_TOP_RUNS]:
            run = str(ids[i])
            v = values.get(run, {})
            top.append(
                {
                    "run": run,
                    "share": float(share[i]),
                    "n_windows": int(count[i]),
                    "values": v,
                    "runs_as_high": {k: _as_extreme(values, k, x, +1) for k, x in v.items()},
                    "runs_as_low": {k: _as_extreme(values, k, x, -1) for k, x in v.items()},
                }
            )
        return Undecided(
            name=s.name,
            term=s.term,
            variables=list(s.variables),
            explanation=s.explanation,
            source=s.source,
            heldout_rmse_before_w=s.heldout_rmse_before_w,
            heldout_rmse_w=s.heldout_rmse_w,
            p_value=s.p_value,
            p_threshold=self.th.alpha,
            chosen=choice.all_chosen,
            n_folds_chose=sum(c == s.term for c in choice.all_chosen),
            choice_p_value=choice.p_value,
            choice_p_threshold=choice.p_threshold,
            n_runs=int(ids.size),
            n_runs_better=int((gain > 0).sum()),
            top_share=float(share[order[0]]) if ids.size else math.nan,
            top3_share=float(share[order[:UNDECIDED_TOP_RUNS]].sum()) if ids.size else math.nan,
            top_runs=top,
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
        from scipy.special import ndtri  # the normal quantile (scipy.stats: ~1 s to import)

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
            ok = np.isfinite(ea) & np.isfinite(eb) & self.inside
            t_ab, _, n = paired_run_test(eb[ok], ea[ok], self.run_codes[ok])  # > 0: A better
            crit = float(-ndtri(self.th.confound_alpha / 2))
            if not (abs(t_ab) < crit):
                continue
            zb = self.columns[s.term]
            n0 = self.n_scored
            b_given_a = self._score(self.cands[s.term], zb, best.term)
            a_given_b = self._score(self.cands[best.term], za, s.term)
            self.n_scored = n0  # side checks, not candidates of the ranking
            if not self.passes(b_given_a, p_thr) and not self.passes(a_given_b, p_thr):
                s.above_noise = True
                s.p_threshold = p_thr
                out.append(s)
        return out


def _run_values_table(wd: WindowData, variables: Sequence[str]) -> dict[str, dict]:
    """Each run's value of the term's extra channels, its slope and speed (:class:`Undecided`).

    Numeric: the duration-weighted mean over the run's windows (the slope: of
    ``|alpha_deg|``); categorical: the value most of its windows have.
    """
    t = wd.table
    chans = [v for v in variables if v in wd.extras]  # the logs' own channels
    cols = list(dict.fromkeys([*chans, "slope_deg", "speed"]))
    w = pd.Series(wd.weights, index=t.index).fillna(0.0)
    runs = t["run"].astype(str)
    out: dict[str, dict] = {str(r): {} for r in pd.unique(runs)}
    for c in cols:
        src = "alpha_deg" if c == "slope_deg" else c
        if src not in t.columns:
            continue
        col = t[src]
        if pd.api.types.is_numeric_dtype(col):
            x = col.to_numpy(dtype=float)
            x = np.abs(x) if c == "slope_deg" else x
            ok = np.isfinite(x) & (w.to_numpy() > 0)
            num = pd.Series(np.where(ok, x * w, 0.0)).groupby(runs.to_numpy()).sum()
            den = pd.Series(np.where(ok, w, 0.0)).groupby(runs.to_numpy()).sum()
            for r in num.index:
                if den[r] > 0:
                    out[str(r)][c] = float(num[r] / den[r])
        else:
            for r, g in col.astype(str).groupby(runs.to_numpy()):
                out[str(r)][c] = str(g.mode().iloc[0])
    return out


def _as_extreme(values: dict[str, dict], key: str, x, side: int) -> int:
    """Runs whose ``key`` is at least (``side`` +1) / at most (-1) ``x``; categorical: equal."""
    xs = [v[key] for v in values.values() if key in v]
    if isinstance(x, str):
        return sum(v == x for v in xs)
    return int(sum((v - x) * side >= -1e-9 * max(1.0, abs(x)) for v in xs))


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
