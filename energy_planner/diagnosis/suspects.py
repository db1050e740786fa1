"""Which physical effect is the model missing: candidates, held-out validation, ranking.

A *candidate* is one more term (a catalog name or a formula) with a one-line physical
explanation. Candidates come from

- the model catalog (``energy_planner.model.CATALOG``) and surface type per value of a
  ``surface`` channel;
- the data: every extra channel of the logs gets a family of shapes (:func:`channel_candidates`):
  numeric ``x`` (standing power), ``x * speed`` (force per metre), ``x * pos(climb)`` and
  ``x * pos(-climb)`` (a mass lifted and lowered: ``climb = sin(alpha) * (vx cos(gamma) -
  vy sin(gamma))`` is the rate of climb along the motion), ``x * speed * sin(alpha)`` (a load
  on any slope), ``abs(wz) * x`` (turning), ``x ** 2`` for a channel whose name reads
  as a mass (copper losses of supporting it), hinges ``pos(q - x)``, ``pos(x - q)`` and the same
  times speed at data quantiles ``q``; categorical ``(c == 'v')``, ``speed * (c == 'v')``,
  ``(c == 'v') * pos(climb)`` and ``abs(wz) * (c == 'v')`` per value. The best shape per
  channel by held-out error stands for the channel (a best hinge gets its knot refined);
- speed-change shapes (:func:`kinetic_candidates`): ``abs(ax vx + ay vy)`` and
  ``pos(-(ax vx + ay vy))`` next to the catalog's ``acceleration``;
- holding shapes (:func:`holding_candidates`): ``abs(sin(alpha) cos(gamma))`` and
  ``abs(sin(alpha) sin(gamma))``, a cost of the slope load in proportion to it next to the
  base's copper losses in its square;
- speed shapes (``speed ** 2``, ``speed ** 3``, per gait ``pos(vx) ** 2``, ``pos(-vx) ** 2``,
  ``vy ** 2``, hinges in speed), tried only when the logs hold several walking speeds
  (:func:`speed_levels`): at one speed they are the motion terms again;
- the user's own ``--term``.

Each candidate is scored by the held-out error of the model refitted with it, validated
by run (grouped K-fold: all windows of a run are in the same fold, so a run is never
predicted by a fit that saw it). A window whose fold's training runs do not walk as it
does (its direction and grade along the travel: ``WindowData.fold_support``) is an
extrapolation: it enters every fit, but the candidates' scores, tests and the choice are
over the other windows, and its error is reported apart (``Ranking.outside``); the
model's held-out RMSE stays over every window, as ``fit`` reports it.

*Unsupported* (listed, never ranked): the candidate needs a channel the logs lack, its
column has no variance or no finite value, or its column is nearly in the span of the
model's columns: the relative residual ``||z - X b|| / ||z||`` of its least-squares
projection on the model's columns is below ``span_tol`` (default 0.05).

*Above noise* (a finding). With ``d_r`` the reduction of run ``r``'s mean held-out squared
window error when the candidate is added (same held-out windows with and without it), a
one-sided signed-rank test over the runs (:func:`paired_run_test`; exact p for few runs)
asks that runs improve consistently. A ranking decides in a fixed sequence, so that the
chance that *anything* passes by luck is at most ``alpha`` (default 1 %) per step:

1. *choosing* must be worth it: for each fold, the candidate its training folds alone
   choose (:func:`energy_planner.stats.heldout.choice_by_fold`); the held-out errors of each
   fold's windows with its own choice must pass the test at ``alpha``
   (:class:`~energy_planner.diagnosis.scoring.ChoiceTest`, ``Ranking.choice``). No choice
   saw the errors it is tested on: one test, whatever the number of candidates. The runs
   are dealt into folds ``n_partitions`` times (10) and each run's gain is averaged over
   the deals, so that the answer does not turn on which runs one deal holds out together;
2. then the best candidate passes when its own p-value is below ``alpha``, any other when
   its p-value is below ``alpha / m`` where ``m`` is the number of candidates scored in this
   ranking (Bonferroni);

AND the pooled held-out RMSE must fall by at least ``min_rel`` (default 5 %) of its
current value. The tests control the false-finding rate whatever the number of
candidates; the last rule keeps out gains too small to matter (a real but negligible
structure of the residual). Measured rates are in docs/diagnosis.md.

``error_explained`` is the fraction of the current held-out mean squared error that the
candidate removes, ``1 - MSE_cv(with) / MSE_cv(without)``, over the supported windows; a
staircase step's is over every window, from its held-out RMSE and the step's before (the
table's RMSE column).

*Confounded* suspects: when another above-noise suspect ``B`` is not significantly worse than
the best one ``A`` (two-sided paired test by run at 5 %), and neither adds anything above
noise once the other is in the model, the data cannot tell them apart: ``B`` is listed in
``Ranking.alternatives`` and reported with ``A`` as one finding.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

from energy_planner.calibration.windowdata import WindowData
from energy_planner.diagnosis.candidates import (
    CHANNEL_KINDS,
    CLIMB,
    HINGE_QUANTILES,
    KINETIC,
    SPEED_SPREAD,
    WALKING_SPEED,
    Candidate,
    canonical,
    catalog_candidates,
    channel_candidates,
    channel_kind,
    default_candidates,
    hinge,
    holding_candidates,
    kinetic_candidates,
    speed_candidates,
    speed_levels,
    user_candidates,
)
from energy_planner.diagnosis.names import LONG_FORMULA, model_term, resolve_names, term_spec
from energy_planner.diagnosis.scoring import (
    RUN_TEST_NAME,
    Ranking,
    Suspect,
    Thresholds,
    paired_run_test,
    rank_suspects,
)
from energy_planner.model.terms import Term
from energy_planner.stats import fold_index, span_basis, span_residual
from energy_planner.stats import wls_coef as wls

# The candidates live in diagnosis.candidates, their scoring in diagnosis.scoring, the
# short names in diagnosis.names; this module is the staircase and the public face.
__all__ = [
    "CHANNEL_KINDS",
    "CLIMB",
    "HINGE_QUANTILES",
    "KINETIC",
    "LONG_FORMULA",
    "RUN_TEST_NAME",
    "SPEED_SPREAD",
    "WALKING_SPEED",
    "Candidate",
    "Ranking",
    "Step",
    "Suspect",
    "Term",
    "Thresholds",
    "canonical",
    "catalog_candidates",
    "channel_candidates",
    "channel_kind",
    "default_candidates",
    "hinge",
    "holding_candidates",
    "kinetic_candidates",
    "model_term",
    "paired_run_test",
    "rank_suspects",
    "resolve_names",
    "span_basis",
    "span_residual",
    "speed_candidates",
    "speed_levels",
    "staircase",
    "term_spec",
    "user_candidates",
    "wls",
]


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
    #: the windows outside their fold's support, scored apart (``Ranking.outside``), and
    #: the held-out RMSE of the others (``Ranking.supported_rmse_w``)
    outside: dict = field(default_factory=dict)
    supported_rmse_w: float = math.nan

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

    A suspect that the refit with it would leave out (:meth:`WindowData.unidentified`:
    the final fit on all windows, or a fold's fit, cannot identify it) is not added: it
    is recorded in its ranking's ``dropped``, with the reason, and the next suspect is
    tried. So every term added is in the model that is fitted and written, and a step's
    held-out RMSE is that model's.

    Returns the steps (step 0 is the model as given) and the ranking made at each step.
    """
    from energy_planner.progress import reporter

    th = thresholds or Thresholds()
    folds = fold_index(wd.runs, th.n_splits, th.seed)
    terms = [term_spec(t) for t in terms]
    rep = reporter(progress)
    ranking = rank_suspects(wd, terms, th, folds=folds, extra=extra)
    steps = [
        Step(0, None, None, ranking.heldout_rmse_w, ranking.fold_rmse_w, None,
             outside=ranking.outside, supported_rmse_w=ranking.supported_rmse_w)
    ]  # fmt: skip
    rankings = [ranking]
    for i in range(1, max_steps + 1):
        best = _first_kept(wd, terms, ranking, folds)
        if best is None:
            break
        alts = [
            {"name": a.name, "term": a.term, "explanation": a.explanation,
             "heldout_rmse_w": a.heldout_rmse_w}
            for a in ranking.alternatives
        ] if best is ranking.suspects[0] else []  # fmt: skip
        terms.append(best.term)
        before = ranking.heldout_rmse_w
        ranking = rank_suspects(wd, terms, th, folds=folds, extra=extra)
        rankings.append(ranking)
        # the step's share of the error over every window, as its RMSE column (the
        # candidate's own score, over the supported windows only, may differ)
        removed = 1.0 - (ranking.heldout_rmse_w / before) ** 2 if before > 0 else 0.0
        steps.append(
            Step(
                i,
                best.term,
                best.name,
                ranking.heldout_rmse_w,
                ranking.fold_rmse_w,
                removed,
                best.explanation,
                alts,
                ranking.outside,
                ranking.supported_rmse_w,
            )
        )
        rep.say(f"step {i} done", stage="staircase")
    return steps, rankings


def _first_kept(wd: WindowData, terms: list[str], ranking: Ranking, folds) -> Suspect | None:
    """The best suspect of ``ranking`` that a refit keeps; the others tried go to ``dropped``."""
    for s in ranking.suspects:
        why = wd.unidentified([*terms, s.term], folds).get(s.term)
        if not why:
            return s
        ranking.dropped.append({"term": s.term, "name": s.name, "reason": why})
    return None
