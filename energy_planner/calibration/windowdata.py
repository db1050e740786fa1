"""Window-level view of the measurements used by the diagnosis.

The diagnosis works on windows (paper IV-C): the target is the mean measured power of a
window and a term's column is the window mean of the term evaluated per sample (power is
linear in the coefficients, so the window mean of power is the sum of the window means of
the terms). This module turns the per-sample table of
``energy_planner.measurements.make_windows(...).samples`` into that view, and evaluates
any term (catalog name or formula) on it.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from energy_planner.errors import FitError, LogError
from energy_planner.measurements.schema import CANONICAL_COLUMNS
from energy_planner.measurements.windows import DERIVED_COLUMNS

if TYPE_CHECKING:
    from energy_planner.stats import HeldOut

# Columns of the canonical samples that are not extra channels: the measurements
# module's canonical and derived columns, plus a few common log fields.
KNOWN_COLUMNS = frozenset(
    {
        *CANONICAL_COLUMNS,
        *DERIVED_COLUMNS,
        *("z", "az", "dt", "valid", "keep", "composite", "part"),
    }
)

#: Categorical channels with more distinct values than this are treated as identifiers.
MAX_CATEGORIES = 12

REQUIRED = ("run", "t", "power", "window")
#: Bytes of per-sample term columns :class:`WindowData` keeps between calls (least
#: recently used first out; an evicted column is evaluated again when asked for, to the
#: same values). Without a bound a full campaign kept every candidate's column: 525 k
#: samples x hundreds of candidates, 3 GB.
SAMPLE_CACHE_BYTES = 64 * 2**20
#: A walking window whose grade along its travel is within this many degrees of level is
#: level for :meth:`WindowData.fold_support`; beyond it, up or down.
SUPPORT_LEVEL_DEG = 2.0
#: Terms evaluated per sample at once (bounds the design matrix made in one go).
EVAL_CHUNK = 8


@dataclass
class _FoldPlan:
    """A model's per-sample design with the samples sorted by their window's fold.

    :meth:`WindowData.heldout` predicts each fold's samples with that fold's coefficients
    in one product over a contiguous block (the samples of a window stay together), for
    every candidate scored on the model.
    """

    key: tuple  # the model's terms
    folds: np.ndarray  # fold of every window
    order: np.ndarray  # samples (their index) sorted by fold, stable
    X: np.ndarray  # (samples, terms), rows in ``order``
    bounds: np.ndarray  # fold f's samples: rows bounds[f]:bounds[f + 1]
    starts: np.ndarray  # first row of every window
    seg_win: np.ndarray  # the window of each of those
    means: np.ndarray  # (windows, terms): the window means of the terms
    y: np.ndarray  # mean measured power of every window
    w: np.ndarray  # fit weight of every window
    _extra: np.ndarray | None = None
    fit: Any = None  # stats.heldout._FoldFit of the model on every window, when made

    def extra_buffer(self, e: int) -> np.ndarray:
        """Room for ``e`` extra per-sample columns in the plan's order (reused)."""
        if self._extra is None or self._extra.shape[1] < e:
            self._extra = np.empty((len(self.order), max(e, 2)), order="F")
        return self._extra[:, :e]


@dataclass
class WindowData:
    """Per-sample features and their per-window aggregation.

    Attributes
    ----------
    samples : pandas.DataFrame
        Per-sample features (only samples that belong to a window), ``speed`` filled in.
    key : numpy.ndarray
        Window index of every sample, ``0 .. n_windows - 1``.
    table : pandas.DataFrame
        One row per window: ``run``, ``window``, ``n``, ``power`` (mean measured power, W),
        ``alpha_deg``, ``gamma_deg``, ``speed``, ``vx``, ``vy``, ``wz``, ``motion`` and every
        extra channel (numeric: window mean; categorical: most frequent value).
    numeric_extras, categorical_extras : list of str
        Extra channels found in the samples, by kind.
    """

    samples: pd.DataFrame
    key: np.ndarray
    table: pd.DataFrame
    numeric_extras: list[str] = field(default_factory=list)
    categorical_extras: list[str] = field(default_factory=list)
    _cache: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    _sample_cache: OrderedDict[str, np.ndarray] = field(default_factory=OrderedDict, repr=False)
    _plan: _FoldPlan | None = field(default=None, repr=False)
    _fold_cols: dict = field(default_factory=dict, repr=False)
    _start_idx: np.ndarray | None = field(default=None, repr=False)
    _support_bins: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    @property
    def n_windows(self) -> int:
        """Number of windows."""
        return len(self.table)

    @property
    def power(self) -> np.ndarray:
        """Mean measured power of each window, W."""
        return self.table["power"].to_numpy(dtype=float)

    @property
    def weights(self) -> np.ndarray:
        """Fit weight of each window: its duration (s) as the calibration weighs windows."""
        return self.table["duration"].to_numpy(dtype=float)

    @property
    def runs(self) -> np.ndarray:
        """Run identifier of each window."""
        return self.table["run"].to_numpy()

    @property
    def extras(self) -> list[str]:
        """All extra channels, numeric first."""
        return [*self.numeric_extras, *self.categorical_extras]

    def window_mean(self, values: np.ndarray) -> np.ndarray:
        """Mean over each window of a per-sample array (or of each column of a matrix).

        Non-finite samples are ignored; a window with no finite sample gets NaN.

        Samples are stored grouped by window, so this is one ``np.add.reduceat``.
        """
        values = np.asarray(values, dtype=float)
        ok = np.isfinite(values)
        starts = self._starts
        tot = np.add.reduceat(np.where(ok, values, 0.0), starts, axis=0)
        cnt = np.add.reduceat(ok.astype(float), starts, axis=0)
        out = np.full(tot.shape, np.nan)
        np.divide(tot, cnt, out=out, where=cnt > 0)
        return out

    @property
    def _starts(self) -> np.ndarray:
        """Index of the first sample of each window (samples are sorted by window)."""
        if self._start_idx is None:
            self._start_idx = np.flatnonzero(np.r_[True, self.key[1:] != self.key[:-1]])
        return self._start_idx

    def _evaluate(self, terms: list[str], sink: Any = None) -> None:
        """Evaluate the terms not yet cached on every sample; cache their window means.

        With ``sink``, ``sink(term, column)`` is called with the per-sample column of
        every term (from the per-sample cache, or evaluated again if the cache let it
        go); the caller copies it where it wants it, so that no term's column is held
        beyond the chunk being evaluated. Terms are evaluated :data:`EVAL_CHUNK` at a
        time and the per-sample cache holds at most :data:`SAMPLE_CACHE_BYTES` (least
        recently used out), so that memory does not grow with the number of candidates.
        """
        from energy_planner.calibration.fit import model_features
        from energy_planner.model import EnergyModel

        want = list(dict.fromkeys(terms))
        done: set[str] = set()
        if sink is not None:
            for t in want:
                if t in self._sample_cache:
                    sink(t, self._sample_cache[t])
                    self._sample_cache.move_to_end(t)
                    done.add(t)
        todo = [t for t in want if t not in self._cache or (sink is not None and t not in done)]
        for i in range(0, len(todo), EVAL_CHUNK):
            chunk = todo[i : i + EVAL_CHUNK]
            model = EnergyModel(terms=chunk)
            # only the columns these terms read (all of them as arrays: 110 MB on a full
            # campaign, held through the staircase)
            per_sample = model.design_matrix(model_features(self.samples, model))
            per_window = self.window_mean(per_sample)
            for j, t in enumerate(chunk):
                self._cache[t] = per_window[:, j].copy()
                if sink is not None:
                    sink(t, per_sample[:, j])
                self._keep_sample_column(t, np.ascontiguousarray(per_sample[:, j]))
            del per_sample, per_window  # before the next chunk is evaluated (memory)

    def _keep_sample_column(self, term: str, column: np.ndarray) -> None:
        """Put a per-sample column in the cache, dropping the least recently used."""
        cache = self._sample_cache
        cache[term] = column
        cache.move_to_end(term)
        total = sum(c.nbytes for c in cache.values())
        while total > SAMPLE_CACHE_BYTES and len(cache) > 1:
            _, old = cache.popitem(last=False)
            total -= old.nbytes

    def release_sample_columns(self) -> None:
        """Let go of the per-sample columns and the stacked design.

        They are caches, evaluated again if needed; ``discover`` lets them go before its
        final fit, which builds its own design (memory).
        """
        self._sample_cache.clear()
        self._plan = None

    def columns(self, terms: Iterable[str]) -> np.ndarray:
        """Window-mean design columns of ``terms`` (catalog names or formulas).

        Columns are cached by term: per window all of them (the staircase re-ranks the
        same candidates), per sample up to :data:`SAMPLE_CACHE_BYTES` (the held-out
        evaluation floors every sample; a column let go is evaluated again).

        Returns
        -------
        numpy.ndarray
            Shape ``(n_windows, len(terms))``.
        """
        terms = list(terms)
        self._evaluate(terms)
        if not terms:
            return np.empty((self.n_windows, 0))
        return np.column_stack([self._cache[t] for t in terms])

    def sample_columns(self, terms: Iterable[str], out: np.ndarray | None = None) -> np.ndarray:
        """Per-sample design columns of ``terms``, shape ``(n_samples, len(terms))``.

        With ``out`` (that shape, e.g. columns of a larger array), the columns are
        written there and ``out`` is returned: each column is copied once, straight
        from its evaluation, with no stacked intermediate (memory).
        """
        terms = list(terms)
        if out is None:
            out = np.empty((len(self.samples), len(terms)), order="F")
        if not terms:
            return out
        where: dict[str, list[int]] = {}
        for j, t in enumerate(terms):
            where.setdefault(t, []).append(j)

        def sink(term: str, column: np.ndarray) -> None:
            for j in where[term]:
                out[:, j] = column

        self._evaluate(terms, sink=sink)
        return out

    def heldout(
        self,
        terms: Sequence[str],
        folds: np.ndarray,
        ok: np.ndarray | None = None,
        extra: Sequence[str] = (),
    ) -> HeldOut:
        """Held-out prediction of the model ``terms + extra`` on the windows ``ok``.

        The one held-out evaluation (:func:`energy_planner.stats.heldout`): refitted on
        the other folds' windows, every sample of a held-out window predicted and floored
        at 0, the window's prediction the mean of its floored samples. As in
        ``calibration.cross_validate``, a fold fits only the model terms its training
        windows identify (:func:`energy_planner.calibration.fit.identifiable_by_fold`;
        the others are predicted as 0); the extra terms are always fitted.

        Parameters
        ----------
        terms, extra : sequence of str
            The model's terms and the terms tried with it (a candidate).
        folds : numpy.ndarray
            Fold of every window (:func:`energy_planner.stats.fold_index`).
        ok : numpy.ndarray, optional
            Boolean mask of the windows to use (default all); the result has one row
            per window in ``ok``.

        Returns
        -------
        HeldOut
        """
        from energy_planner.stats import HeldOut
        from energy_planner.stats.heldout import _fold_coef, _FoldFit

        key, k, e = tuple(terms), len(terms), len(extra)
        folds = np.asarray(folds, dtype=np.int64)
        plan = self._fold_plan(key, folds)
        means = plan.means
        if e:
            means = np.column_stack([means, self.columns(extra)])
        y, w, f_ok, table = plan.y, plan.w, folds, self.table
        cache_key = (key, folds.tobytes(), None)
        if ok is not None and not np.all(ok):
            ok = np.asarray(ok, dtype=bool)
            cache_key = (key, folds.tobytes(), ok.tobytes())
            means, y, w, f_ok, table = means[ok], y[ok], w[ok], folds[ok], table[ok]
        else:
            ok = None
        n_folds = int(f_ok.max()) + 1 if len(f_ok) else 0
        cols = self._identifiable(cache_key, means[:, :k], w, table, f_ok)
        cols = np.column_stack([cols, np.ones((len(cols), e), dtype=bool)])
        if cols.shape != (n_folds, k + e):
            raise FitError(f"fit_columns {cols.shape}, expected ({n_folds}, {k + e})")
        if ok is None:  # every window: the model's statistics made once (bordered)
            if plan.fit is None:
                plan.fit = _FoldFit(plan.means, y, f_ok, w)
            coef = plan.fit.coef(means[:, k:], cols)
        else:
            coef = _fold_coef(means, y, f_ok, w, cols)
        # every sample by its window's fold's coefficients: the samples sorted by fold,
        # one product per fold over its own samples, floored, then averaged by window
        Z = plan.extra_buffer(e)
        if e:
            where: dict[str, list[int]] = {}
            for j, t in enumerate(extra):
                where.setdefault(t, []).append(j)

            def sink(term: str, column: np.ndarray) -> None:
                for j in where[term]:
                    np.take(column, plan.order, out=Z[:, j])

            self._evaluate(list(extra), sink=sink)
        pred = np.full(len(plan.order), np.nan)
        # (the samples of windows left out are predicted too, and never read: their
        # non-finite values must not warn)
        with np.errstate(invalid="ignore", over="ignore"):
            for f in range(n_folds):
                a, b = plan.bounds[f], plan.bounds[f + 1]
                p = plan.X[a:b] @ coef[f, :k]
                if e:
                    p += Z[a:b] @ coef[f, k:]
                pred[a:b] = p
        np.maximum(pred, 0.0, out=pred)
        fin = np.isfinite(pred)
        tot = np.add.reduceat(np.where(fin, pred, 0.0), plan.starts)
        cnt = np.add.reduceat(fin.astype(float), plan.starts)
        win = np.full(self.n_windows, np.nan)
        np.divide(tot, cnt, out=tot, where=cnt > 0)
        win[plan.seg_win] = np.where(cnt > 0, tot, np.nan)
        pred_s = np.empty(len(pred))
        pred_s[plan.order] = pred
        if ok is not None:
            win, pred_s = win[ok], pred_s[ok[self.key]]
        return HeldOut(win, y - win, f_ok, coef, pred_s)

    def heldout_coef(self, terms: Sequence[str], folds: np.ndarray) -> np.ndarray:
        """Each fold's coefficients of :meth:`heldout` on every window (``HeldOut.coef``).

        The same numbers, without predicting the samples (for a caller that predicts
        other samples with them): the window means of the terms, the terms each fold
        identifies, the fold fits.
        """
        from energy_planner.stats.heldout import _FoldFit

        key = tuple(terms)
        folds = np.asarray(folds, dtype=np.int64)
        if folds.shape != (self.n_windows,):
            raise FitError(
                f"folds have shape {folds.shape}, expected ({self.n_windows},): one per window"
            )
        means, y, w = self.columns(list(key)), self.power, self.weights
        n_folds = int(folds.max()) + 1 if len(folds) else 0
        cols = self._identifiable((key, folds.tobytes(), None), means, w, self.table, folds)
        if cols.shape != (n_folds, len(key)):
            raise FitError(f"fit_columns {cols.shape}, expected ({n_folds}, {len(key)})")
        return _FoldFit(means, y, folds, w).coef(means[:, len(key) :], cols)

    def _fold_plan(self, key: tuple, folds: np.ndarray) -> _FoldPlan:
        """The model's per-sample design sorted by fold (cached for the last model)."""
        plan = self._plan
        if plan is not None and plan.key == key and np.array_equal(plan.folds, folds):
            return plan
        self._plan = None  # the old model's, let go first (memory)
        if folds.shape != (self.n_windows,):
            raise FitError(
                f"folds have shape {folds.shape}, expected ({self.n_windows},): one per window"
            )
        sample_fold = folds[self.key]
        order = np.argsort(sample_fold, kind="stable")  # windows stay contiguous
        X = np.empty((len(order), len(key)))
        where: dict[str, list[int]] = {}
        for j, t in enumerate(key):
            where.setdefault(t, []).append(j)

        def sink(term: str, column: np.ndarray) -> None:
            for j in where[term]:
                X[:, j] = column[order]

        self._evaluate(list(key), sink=sink)
        n_folds = int(folds.max()) + 1 if len(folds) else 0
        bounds = np.searchsorted(sample_fold[order], np.arange(n_folds + 1))
        keys = self.key[order]
        starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]]) if len(keys) else keys
        self._plan = _FoldPlan(
            key=key,
            folds=folds.copy(),
            order=order,
            X=X,
            bounds=bounds,
            starts=starts,
            seg_win=keys[starts],
            means=self.columns(list(key)),
            y=self.power,
            w=self.weights,
        )
        return self._plan

    def _identifiable(self, key: tuple, X, w, table, folds) -> np.ndarray:
        """:func:`~energy_planner.calibration.fit.identifiable_by_fold`, cached by key."""
        from energy_planner.calibration.fit import identifiable_by_fold
        from energy_planner.model import EnergyModel

        if key not in self._fold_cols:
            model = EnergyModel(terms=list(key[0]))
            t = _with_kind(table)
            self._fold_cols[key] = identifiable_by_fold(model, X, w, t, folds)
        return self._fold_cols[key]

    def fold_support(self, folds: np.ndarray) -> np.ndarray:
        """Whether each window's fold has training runs that walk as it walks.

        A window's *direction bin* is its motion kind (forward, backward, lateral,
        turning, standing, mixed; :func:`_with_kind`) and, walking, the grade along its
        travel: up, down or level (within :data:`SUPPORT_LEVEL_DEG`; a lateral window by
        the side it steps to, left the mirror of right). A window is *supported* when the
        other folds hold at least
        :data:`~energy_planner.calibration.fit.MIN_WINDOWS_PER_TERM` windows of its bin
        from at least :data:`~energy_planner.calibration.fit.MIN_RUNS` runs. An
        unsupported window is predicted by a fit that has not seen its way of walking (a
        direction only one or two runs hold): its error is an extrapolation (what the
        interval's widening outside the domain is for), not evidence for or against a
        term, and the diagnosis scores it apart (:mod:`energy_planner.diagnosis.scoring`;
        it still enters every fit).

        Parameters
        ----------
        folds : numpy.ndarray
            Fold of every window.

        Returns
        -------
        numpy.ndarray
            Boolean, one per window.

        Examples
        --------
        >>> import pandas as pd
        >>> t = pd.DataFrame({"run": list("aaabbbcccddd"), "vx": [0.3] * 9 + [-0.3] * 3,
        ...                   "vy": 0.0, "wz": 0.0, "speed": 0.3, "power": 1.0})
        >>> wd = WindowData(pd.DataFrame(), np.zeros(12, int), t)
        >>> folds = np.repeat([0, 1, 2, 0], 3)  # by run: a and d in fold 0
        >>> wd.fold_support(folds).reshape(4, 3)[:, 0].tolist()  # d alone walks backward
        [True, True, True, False]
        """
        from energy_planner.calibration.fit import MIN_RUNS, MIN_WINDOWS_PER_TERM

        bins, runs = self._direction_bins()
        folds = np.asarray(folds)
        out = np.zeros(len(bins), dtype=bool)
        for f in np.unique(folds):
            train = folds != f
            tb, tr = bins[train], runs[train]
            n_win = np.bincount(tb, minlength=bins.max() + 1)
            pairs = np.unique(np.column_stack([tb, tr]), axis=0)
            n_run = np.bincount(pairs[:, 0], minlength=bins.max() + 1)
            good = (n_win >= MIN_WINDOWS_PER_TERM) & (n_run >= MIN_RUNS)
            here = folds == f
            out[here] = good[bins[here]]
        return out

    def _direction_bins(self) -> tuple[np.ndarray, np.ndarray]:
        """Each window's direction bin and run, as codes, for :meth:`fold_support`.

        Made once: they do not depend on the folds, and the choice test asks for ten
        partitions at every step of a staircase.
        """
        if self._support_bins is not None:
            return self._support_bins
        t = _with_kind(self.table)
        kind = t["kind"].to_numpy(dtype=object).astype(str)
        side = np.full(len(t), "", dtype=object)
        if {"alpha_deg", "gamma_deg"} <= set(t.columns):
            a = np.radians(t["alpha_deg"].to_numpy(float))
            g = np.radians(t["gamma_deg"].to_numpy(float))
            sx, sy = np.sin(a) * np.cos(g), np.sin(a) * np.sin(g)
            vy = t["vy"].to_numpy(float)
            grade = np.select(
                [kind == "forward", kind == "backward", kind == "lateral"],
                [sx, -sx, -np.sign(vy) * sy],
                0.0,
            )
            lim = np.sin(np.radians(SUPPORT_LEVEL_DEG))
            side = np.where(grade > lim, "/up", np.where(grade < -lim, "/down", ""))
        bins = pd.factorize(pd.Series(kind + side.astype(str)))[0]
        runs = pd.factorize(pd.Series(t["run"].to_numpy()))[0]
        self._support_bins = (bins, runs)
        return self._support_bins

    def unidentified(self, terms: Sequence[str], folds: np.ndarray) -> dict[str, str]:
        """Terms a refit of the model ``terms`` leaves out, each with the reason.

        The rule of the final fit (:func:`~energy_planner.calibration.fit.identify_terms`
        on all windows) and of the held-out evaluation (the same on each fold's training
        windows, :meth:`heldout`): a term named here is not in the model that is written,
        or is predicted as 0 in some fold. Keys are the terms as given.

        Parameters
        ----------
        terms : sequence of str
            The model's terms (catalog names or formulas).
        folds : numpy.ndarray
            Fold of every window.

        Returns
        -------
        dict
            Term -> why (the first fold that leaves it out is named).
        """
        from energy_planner.calibration.fit import identify_terms
        from energy_planner.model import EnergyModel

        terms = list(terms)
        model = EnergyModel(terms=terms)
        names = model.term_names
        X, w, t = self.columns(terms), self.weights, _with_kind(self.table)
        folds = np.asarray(folds)
        out: dict[str, str] = {}
        for f in [None, *range(int(folds.max()) + 1)]:
            train = np.ones(len(t), dtype=bool) if f is None else folds != f
            lost = identify_terms(model, X[train], w[train], t[train])
            for term, name in zip(terms, names, strict=True):
                if name in lost and term not in out:
                    where = "all windows" if f is None else f"the training runs of fold {f}"
                    out[term] = f"{lost[name]} (on {where})"
        return out

    def predict(self, model) -> np.ndarray:
        """Window mean of the model's per-sample power (clamped at 0 as the model does)."""
        return self.window_mean(np.asarray(model.power(self.samples), dtype=float))


def _with_kind(table: pd.DataFrame) -> pd.DataFrame:
    """The window table with the calibration's motion ``kind`` of every window.

    The windows' motion classes as the measurements label them; other labels (hand-made
    samples) by ``classify_motion`` of the window's mean twist.
    """
    from energy_planner.calibration._windows import window_kind
    from energy_planner.stats import MOTIONS, classify_motion

    cls = classify_motion(*(table[c].to_numpy(float) for c in ("vx", "vy", "wz")))
    given = table["motion"] if "motion" in table else pd.Series(None, index=table.index)
    motion = np.where(given.isin(MOTIONS).to_numpy(), given.to_numpy(), cls)
    kind = window_kind(motion, table["speed"].to_numpy(float), table["wz"].to_numpy(float))
    return table.assign(kind=kind)


def _is_numeric(series: pd.Series) -> bool:
    return pd.api.types.is_numeric_dtype(series) and not pd.api.types.is_bool_dtype(series)


def _mode(series: pd.Series, key: np.ndarray, n: int) -> np.ndarray:
    """Most frequent value of a categorical per-sample series in each window (NaN-safe)."""
    codes, uniques = pd.factorize(series, use_na_sentinel=True)
    out = np.full(n, None, dtype=object)
    ok = codes >= 0
    if not ok.any():
        return out
    counts = np.zeros((n, len(uniques)), dtype=np.int64)
    np.add.at(counts, (key[ok], codes[ok]), 1)
    has = counts.sum(axis=1) > 0
    best = counts.argmax(axis=1)
    out[has] = np.asarray(uniques, dtype=object)[best[has]]
    return out


def window_data(samples: Any, extras: Iterable[str] | None = None) -> WindowData:
    """Build the window-level view from windowed per-sample data.

    Parameters
    ----------
    samples : Windows or pandas.DataFrame
        ``make_windows(...)`` or its ``.samples``: per-sample ``run, t, vx, vy, wz, alpha,
        gamma, ax, ay, power, motion, window`` and any extra channel. Samples whose
        ``window`` is missing or negative belong to no window and are ignored. Given the
        ``Windows``, a window's ``duration`` (its fit weight) is the measurements' own (the
        sum of its samples' intervals), as the calibration weighs it; given samples alone,
        it is the number of samples times the run's median sample interval.
    extras : iterable of str, optional
        Extra channels to consider; default every column that is not a canonical one.

    Returns
    -------
    WindowData

    Raises
    ------
    LogError
        A required column is missing.
    FitError
        No sample belongs to a window.

    Examples
    --------
    >>> import pandas as pd
    >>> s = pd.DataFrame({"run": ["a"] * 4, "t": [0, 1, 2, 3], "power": [1.0, 3, 5, 7],
    ...                   "window": [0, 0, 1, 1], "vx": 0.3, "vy": 0.0, "wz": 0.0,
    ...                   "alpha": 0.0, "gamma": 0.0, "mud": ["x", "x", "y", "y"]})
    >>> wd = window_data(s)
    >>> wd.table["power"].tolist(), wd.categorical_extras, wd.table["mud"].tolist()
    ([2.0, 6.0], ['mud'], ['x', 'y'])
    """
    wtable = None
    if hasattr(samples, "samples") and hasattr(samples, "table"):
        wtable, samples = samples.table, samples.samples
    missing = [c for c in REQUIRED if c not in samples.columns]
    if missing:
        raise LogError(
            f"windowed samples lack column(s) {missing}; expected the output of "
            "energy_planner.measurements.make_windows(...).samples with columns "
            f"{list(REQUIRED)} and the per-sample features"
        )
    win = pd.to_numeric(samples["window"], errors="coerce")
    keep = win.notna().to_numpy() & (win.fillna(-1).to_numpy() >= 0)
    keep &= np.isfinite(pd.to_numeric(samples["power"], errors="coerce").to_numpy(dtype=float))
    s = samples.loc[keep].reset_index(drop=True).copy()
    if s.empty:
        raise FitError("no sample belongs to a window: nothing to diagnose (check make_windows)")
    if "speed" not in s.columns and {"vx", "vy"} <= set(s.columns):
        s["speed"] = np.hypot(s["vx"].to_numpy(float), s["vy"].to_numpy(float))
    s["run"] = s["run"].astype(str)
    # A window is identified by (run, window): window numbers may restart in each run.
    # key = (run code, window) packed in one integer; samples sorted by it (stable in t)
    run_code, run_names = pd.factorize(s["run"], sort=True)
    wid = s["window"].to_numpy(dtype=np.int64)
    wid = wid - wid.min()
    packed = run_code.astype(np.int64) * (int(wid.max()) + 1) + wid
    order = np.argsort(packed, kind="stable")
    s = s.iloc[order].reset_index(drop=True)
    uniq, key = np.unique(packed[order], return_inverse=True)
    key = key.astype(np.int64)
    n = len(uniq)
    first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    if extras is None:
        extras = [c for c in s.columns if c not in KNOWN_COLUMNS]
    extras = [c for c in extras if c in s.columns]

    def mean(col: str) -> np.ndarray:
        v = pd.to_numeric(s[col], errors="coerce").to_numpy(dtype=float)
        ok = np.isfinite(v)
        cnt = np.add.reduceat(ok.astype(float), first)
        tot = np.add.reduceat(np.where(ok, v, 0.0), first)
        out = np.full(n, np.nan)
        np.divide(tot, cnt, out=out, where=cnt > 0)
        return out

    table = pd.DataFrame(
        {
            "run": np.asarray(run_names, dtype=object)[run_code[order][first]].astype(str),
            "window": s["window"].to_numpy()[first],
            "n": np.bincount(key, minlength=n),
            "power": mean("power"),
        }
    )
    if "t" in s.columns:
        t = s["t"].to_numpy(dtype=float)
        table["t_start"] = np.minimum.reduceat(t, first)
        table["t_end"] = np.maximum.reduceat(t, first)
    if wtable is not None and "duration" in wtable.columns:
        # the measurements' own durations (the sum of the samples' intervals)
        per = dict(
            zip(
                zip(wtable["run"].astype(str), wtable["window"].astype(np.int64), strict=True),
                wtable["duration"].to_numpy(float),
                strict=True,
            )
        )
        keys = zip(table["run"], table["window"].astype(np.int64), strict=True)
        table["duration"] = [per.get(k, np.nan) for k in keys]
    else:
        # samples x the run's median sample interval (a window of 1 sample counts too)
        t_run = s["t"].to_numpy()
        codes = run_code[order]
        by_run = np.argsort(codes, kind="stable")
        cut = np.searchsorted(codes[by_run], np.arange(len(run_names) + 1))
        step = np.ones(len(run_names))
        for r in range(len(run_names)):
            v = t_run[by_run[cut[r] : cut[r + 1]]]
            if len(v) > 1:
                step[r] = np.median(np.diff(np.sort(v)))
        table["duration"] = np.bincount(key, weights=step[codes], minlength=n)
    if "alpha" in s.columns:
        table["alpha_deg"] = np.degrees(mean("alpha"))
    if "gamma" in s.columns:  # circular mean: headings near +-180 deg must not average to 0
        g = s["gamma"].to_numpy(dtype=float)
        s["_sin_g"], s["_cos_g"] = np.sin(g), np.cos(g)
        table["gamma_deg"] = np.degrees(np.arctan2(mean("_sin_g"), mean("_cos_g")))
        s = s.drop(columns=["_sin_g", "_cos_g"])
    for col in ("speed", "vx", "vy", "wz"):
        if col in s.columns:
            table[col] = mean(col)
    if "motion" in s.columns:
        table["motion"] = _mode(s["motion"].astype(object), key, n)
    numeric, categorical = [], []
    for col in extras:
        if _is_numeric(s[col]) or pd.api.types.is_bool_dtype(s[col]):
            if pd.api.types.is_bool_dtype(s[col]):
                s[col] = s[col].astype(float)
            table[col] = mean(col)
            numeric.append(col)
        else:
            table[col] = _mode(s[col].astype(object), key, n)
            categorical.append(col)
    return WindowData(s, key, table, numeric, categorical)
