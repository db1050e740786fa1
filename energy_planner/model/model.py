"""The energy model: a sum of named terms, linear in its coefficients.

``P = max(sum_k c_k * term_k(features), 0)``: electrical power in W, never negative
because a legged robot does not regenerate (set ``regenerative=True`` for a machine
that does). Built like a scikit-learn estimator: ``__init__`` stores its arguments,
:meth:`EnergyModel.fit` validates the data and sets the coefficients.

Examples
--------
>>> import numpy as np
>>> m = EnergyModel(["fwd_const", "fwd_up"], {"fwd_const": 600.0, "fwd_up": 1000.0})
>>> f = {"alpha": np.radians([0.0, 10.0]), "gamma": np.zeros(2), "vx": np.full(2, 0.3),
...      "vy": np.zeros(2), "wz": np.zeros(2)}
>>> np.round(m.power(f), 2)
array([180.  , 232.09])
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterable, Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from energy_planner.errors import FitError, FormulaError, ModelError, NonPositivePowerError
from energy_planner.model.terms import BASE_TERMS, CATALOG, KINDS, Term, resolve_term
from energy_planner.request import DEFAULT_SPEED
from energy_planner.stats import independent_columns, wls

if TYPE_CHECKING:  # pandas is imported where a frame is made: the energy path never needs it
    import pandas as pd

__all__ = [
    "EnergyModel",
    "BUNDLED_MODELS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "WALKING_GAITS",
    "WALKING_SPEED",
    "WALKING_YAW_RATE",
    "check_walking_power",
    "prepare_features",
]

SCHEMA = "energy_planner.model"
SCHEMA_VERSION = 1
_DEFAULT_PATH = Path(__file__).resolve().parents[1] / "data" / "b1_default.json"
#: The bundled models by name (package data): what :meth:`EnergyModel.load` finds when
#: given a name that is not a file (``--model b1_speeds``, ``ep.load_model("b1_speeds")``).
BUNDLED_MODELS = {
    "b1_default": _DEFAULT_PATH,  # 0.3 m/s, one gait: the paper's robot
    "b1_speeds": _DEFAULT_PATH.parent / "b1_speeds.json",  # 0.15-1.2 m/s, walk and trot
}

#: Features every kernel receives as arguments; everything else is a constant.
KERNEL_ARGS = ("alpha", "gamma", "vx", "vy", "wz", "ax", "ay")

#: A motion is *walking* when its body speed exceeds this (m/s) or its turning rate
#: exceeds :data:`WALKING_YAW_RATE` (rad/s); below both the robot stands. The formulas'
#: own low-speed guard (``max(speed, 0.05)``) uses the same speed.
WALKING_SPEED = 0.05
WALKING_YAW_RATE = 0.05
#: Gaits of :func:`check_walking_power`: direction of the body velocity (rad from body x)
#: or ``None`` for turning in place.
WALKING_GAITS = {
    "forward": 0.0,
    "backward": math.pi,
    "sideways left": math.pi / 2,
    "sideways right": -math.pi / 2,
    "turning in place": None,
}


def prepare_features(features: Mapping[str, Any] | pd.DataFrame) -> dict[str, Any]:
    """Return a dict of per-sample features with ``speed`` derived when absent.

    ``speed = hypot(vx, vy)``. A DataFrame's columns become arrays.
    """
    pandas = sys.modules.get("pandas")  # a DataFrame exists only once pandas is imported
    if pandas is not None and isinstance(features, pandas.DataFrame):
        out: dict[str, Any] = {c: features[c].to_numpy() for c in features.columns}
    else:
        out = dict(features)
    if "speed" not in out and "vx" in out and "vy" in out:
        out["speed"] = np.hypot(np.asarray(out["vx"], float), np.asarray(out["vy"], float))
    return out


def _n_rows(features: Mapping[str, Any]) -> int:
    for v in features.values():
        arr = np.asarray(v)
        if arr.ndim >= 1:
            return arr.shape[0]
    return 1


class EnergyModel:
    """Heading-dependent power model of a legged robot: a sum of named terms.

    Parameters
    ----------
    terms : sequence of str or Term
        Catalog names (:data:`energy_planner.model.CATALOG`) or formulas. Default: the
        paper's base model :data:`energy_planner.model.BASE_TERMS`.
    coefficients : mapping, optional
        Term name -> coefficient. ``None`` for an unfitted model.
    stderr : mapping, optional
        Term name -> standard error of the coefficient (set by :meth:`fit`).
    regenerative : bool
        If False (default) power is floored at zero.
    metadata : mapping, optional
        Free-form provenance (robot, data, date), saved with the model.
    """

    def __init__(
        self,
        terms: Sequence[str | Term] = BASE_TERMS,
        coefficients: Mapping[str, float] | None = None,
        *,
        stderr: Mapping[str, float] | None = None,
        regenerative: bool = False,
        metadata: Mapping[str, Any] | None = None,
    ) -> None:
        self.term_specs = tuple(terms)
        self.coefficients = None if coefficients is None else dict(coefficients)
        self.stderr = None if stderr is None else dict(stderr)
        self.regenerative = regenerative
        self.metadata = dict(metadata or {})

    # ------------------------------------------------------------------ structure
    @cached_property
    def terms(self) -> list[Term]:
        """The resolved terms, in order."""
        terms = [resolve_term(s) for s in self.term_specs]
        names = [t.name for t in terms]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ModelError(f"term(s) {', '.join(dup)} appear more than once in the model")
        return terms

    @property
    def term_names(self) -> list[str]:
        """Names of the terms, in order."""
        return [t.name for t in self.terms]

    @property
    def variables(self) -> set[str]:
        """Feature names the model reads."""
        return set().union(*(t.variables for t in self.terms)) if self.terms else set()

    @property
    def is_fitted(self) -> bool:
        """True when every term has a coefficient."""
        return self.coefficients is not None

    def coef_array(self) -> np.ndarray:
        """Coefficients as an array in term order."""
        if self.coefficients is None:
            raise ModelError("the model has no coefficients yet: fit it or load a fitted model")
        missing = [n for n in self.term_names if n not in self.coefficients]
        if missing:
            raise ModelError(f"coefficient missing for term(s) {', '.join(missing)}")
        return np.array([float(self.coefficients[n]) for n in self.term_names])

    def with_terms(self, *terms: str | Term) -> EnergyModel:
        """A new, unfitted model with ``terms`` appended."""
        return EnergyModel(
            [*self.term_specs, *terms], regenerative=self.regenerative, metadata=self.metadata
        )

    def __repr__(self) -> str:
        state = "fitted" if self.is_fitted else "unfitted"
        return f"EnergyModel({self.term_names}, {state})"

    # ------------------------------------------------------------------ evaluation
    def design_matrix(
        self, features: Mapping[str, Any] | pd.DataFrame, groups: Any = None
    ) -> np.ndarray:
        """Per-sample term values, shape ``(n, k)``; with ``groups`` the per-group means.

        Parameters
        ----------
        features : DataFrame or mapping of arrays
            Per-sample features (see :func:`prepare_features`).
        groups : array-like, optional
            Group label per sample (e.g. a window id); rows come out sorted by label.

        Raises
        ------
        ModelError
            If a term needs a feature the data does not have (names the term).
        """
        f = prepare_features(features)
        n = _n_rows(f)
        if groups is not None:
            # group means 8 terms at a time (each column's mean is its own): the
            # per-sample design is never whole (memory: discover's final fit)
            import pandas as pd

            g = np.asarray(groups)
            parts = [
                pd.DataFrame(EnergyModel(self.terms[i : i + 8]).design_matrix(f), copy=False)
                .groupby(g, sort=True)
                .mean()
                .to_numpy()
                for i in range(0, len(self.terms), 8)
            ]
            return np.hstack(parts) if parts else np.empty((len(np.unique(g)), 0))
        X = np.empty((n, len(self.terms)))  # filled in place: no second copy of the design
        for j, term in enumerate(self.terms):
            try:
                col = term.parsed.evaluate(f)
            except FormulaError as exc:
                raise ModelError(f"term {term.name!r}: {exc}") from exc
            X[:, j] = np.broadcast_to(col, (n,))
        return X

    def contributions(self, features: Mapping[str, Any] | pd.DataFrame) -> pd.DataFrame:
        """Per-sample power of each term (W), one column per term (before the floor)."""
        import pandas as pd

        X = self.design_matrix(features)
        return pd.DataFrame(X * self.coef_array(), columns=self.term_names)

    def power(self, features: Mapping[str, Any] | pd.DataFrame) -> np.ndarray:
        """Electrical power in W for each sample.

        Floored at zero (unless ``regenerative``): a legged robot does not regenerate, so a
        small negative sum (a residual of the fit, standing still) costs nothing. The floor
        must never hide a *walking* motion priced at or below zero: that is a model defect,
        which :func:`check_walking_power` turns into an error naming the term (the fit,
        ``path_energy`` and ``plan`` call it).
        """
        p = self.design_matrix(features) @ self.coef_array()
        return p if self.regenerative else np.maximum(p, 0.0)

    # ------------------------------------------------------------------ fitting
    def fit(
        self,
        features: Mapping[str, Any] | pd.DataFrame,
        power: Any,
        groups: Any = None,
        sample_weight: Any = None,
    ) -> EnergyModel:
        """Joint (weighted) least-squares fit of all coefficients.

        Parameters
        ----------
        features : DataFrame or mapping
            Per-sample features.
        power : array-like
            Measured power in W, per sample, or per group when ``groups`` is given and
            ``power`` has one value per group (sorted by group label).
        groups : array-like, optional
            Group label per sample (window id): rows of the fit are group means.
        sample_weight : array-like, optional
            One weight per fitted row (e.g. window duration).

        Raises
        ------
        FitError
            Too little data, non-finite values, or terms the data cannot tell apart
            (the message names them).
        """
        X = self.design_matrix(features, groups)
        y = np.asarray(power, dtype=float)
        if groups is not None and y.shape[0] != X.shape[0]:
            import pandas as pd

            y = pd.Series(y).groupby(np.asarray(groups), sort=True).mean().to_numpy()
        if y.shape[0] != X.shape[0]:
            raise FitError(f"power has {y.shape[0]} values but the features {X.shape[0]} rows")
        n, k = X.shape
        w = np.ones(n) if sample_weight is None else np.asarray(sample_weight, dtype=float)
        bad = ~(np.isfinite(X).all(axis=1) & np.isfinite(y) & np.isfinite(w))
        if bad.any():
            raise FitError(
                f"{int(bad.sum())} of {n} rows have NaN or infinite features/power; "
                "clean the data first (energy_planner.measurements.preprocess)"
            )
        if n < k + 2:
            raise FitError(
                f"too little data: {n} rows for {k} terms ({', '.join(self.term_names)}); "
                f"need at least {k + 2}, and in practice ten or more per term"
            )
        keep, why = independent_columns(X, w)
        zero = [self.term_names[j] for j, by in why.items() if not by]
        if zero:
            raise FitError(
                f"term(s) {', '.join(zero)} are zero on every row: the data has none of the "
                "motion or conditions they describe; drop them or add such runs"
            )
        if not keep.all():
            names = self.term_names
            dep = "; ".join(
                f"{names[j]} (a combination of {', '.join(names[i] for i in by)})"
                for j, by in why.items()
            )
            raise FitError(
                "the data cannot tell these terms apart (their columns are linearly "
                f"dependent): {dep}; add runs that vary what distinguishes them (speeds, "
                "slopes, headings) or drop one"
            )
        res = wls(X, y, w)
        self.coefficients = dict(zip(self.term_names, map(float, res.coef), strict=True))
        self.stderr = dict(zip(self.term_names, map(float, res.stderr), strict=True))
        return self

    # ------------------------------------------------------------------ persistence
    def to_dict(self) -> dict[str, Any]:
        """The versioned JSON document (see :meth:`from_dict` for the schema)."""
        return {
            "schema": SCHEMA,
            "version": SCHEMA_VERSION,
            "terms": [t.to_dict() for t in self.terms],
            "coefficients": self.coefficients,
            "stderr": self.stderr,
            "regenerative": self.regenerative,
            "metadata": self.metadata,
        }

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], source: str = "<dict>") -> EnergyModel:
        """Build a model from its JSON document.

        Schema (version 1)::

            {"schema": "energy_planner.model", "version": 1,
             "terms": [{"name", "formula", "explanation", "unit", "kind"}, ...],
             "coefficients": {name: float} | null, "stderr": {name: float} | null,
             "regenerative": false, "metadata": {...}}

        A term whose name is in the catalog must carry the catalog's formula; other
        terms must carry a formula. Every term needs a finite coefficient (unless
        ``coefficients`` is null: an unfitted model).

        Raises
        ------
        ModelError
            Unknown schema or version, unknown term, missing or non-finite coefficient.
        """
        if not isinstance(doc, Mapping) or doc.get("schema") != SCHEMA:
            raise ModelError(f"{source}: not an energy_planner model (expected schema {SCHEMA!r})")
        if doc.get("version") != SCHEMA_VERSION:
            raise ModelError(
                f"{source}: model schema version {doc.get('version')!r} is not supported; "
                f"this library reads version {SCHEMA_VERSION}"
            )
        terms: list[Term] = []
        raw_terms = doc.get("terms")
        if raw_terms is not None and not isinstance(raw_terms, list):
            raise ModelError(
                f"{source}: 'terms' must be a list of term names or objects, got {raw_terms!r}"
            )
        for i, entry in enumerate(raw_terms or []):
            if isinstance(entry, str):
                entry = {"name": entry}
            if not isinstance(entry, Mapping):
                raise ModelError(
                    f"{source}: terms[{i}] must be a name or an object with 'name' and "
                    f"'formula', got {entry!r}"
                )
            name = entry.get("name")
            formula = entry.get("formula")
            for key, val in (("name", name), ("formula", formula)):
                if val is not None and not isinstance(val, str):
                    raise ModelError(f"{source}: terms[{i}].{key} must be a string, got {val!r}")
            if name is None and formula is None:
                raise ModelError(f"{source}: terms[{i}] has neither a name nor a formula")
            if name in CATALOG:
                if formula is not None and resolve_term(formula).formula != CATALOG[name].formula:
                    raise ModelError(
                        f"{source}: term {name!r} has formula {formula!r}, but the catalog's "
                        f"{name!r} is {CATALOG[name].formula!r}; rename the custom term"
                    )
                terms.append(CATALOG[name])
            elif formula is None:
                raise ModelError(
                    f"{source}: unknown term {name!r} without a formula; catalog terms: "
                    + ", ".join(CATALOG)
                )
            else:
                try:
                    parsed = resolve_term(formula)
                except FormulaError as exc:
                    raise ModelError(f"{source}: term {name!r}: {exc}") from exc
                terms.append(
                    Term(
                        name=name or parsed.name,
                        formula=parsed.formula,
                        explanation=entry.get("explanation", "user-defined term"),
                        unit=entry.get("unit", "W per unit of the formula"),
                        kind=entry.get("kind", "other") if entry.get("kind") in KINDS else "other",
                    )
                )
        if not terms:
            raise ModelError(f"{source}: the model has no terms")
        for key in ("coefficients", "stderr", "metadata"):
            val = doc.get(key)
            if val is not None and not isinstance(val, Mapping):
                what = "a free-form object" if key == "metadata" else "an object (name -> value)"
                raise ModelError(f"{source}: {key!r} must be {what} or null, got {val!r}")
        stderr = doc.get("stderr")
        for n, v in (stderr or {}).items():
            if v is not None and not isinstance(v, int | float):
                raise ModelError(
                    f"{source}: stderr of term {n!r} must be a number or null, got {v!r}"
                )
        coefs = doc.get("coefficients")
        if coefs is not None:
            for t in terms:
                v = coefs.get(t.name)
                if not isinstance(v, int | float) or not math.isfinite(v):
                    raise ModelError(
                        f"{source}: coefficient of term {t.name!r} is missing or not a finite "
                        f"number (got {v!r})"
                    )
        model = cls(
            terms,
            coefs,
            stderr=doc.get("stderr"),
            regenerative=bool(doc.get("regenerative", False)),
            metadata=doc.get("metadata") or {},
        )
        model.terms  # noqa: B018 - validate (duplicates) now
        return model

    def save(self, path: str | Path) -> Path:
        """Write the model as JSON; returns the path."""
        from energy_planner.io import write_json

        return write_json(Path(path), self.to_dict())

    @classmethod
    def load(cls, path: str | Path) -> EnergyModel:
        """Read a model saved by :meth:`save`, or a bundled model by name.

        A path that exists wins; else a name of :data:`BUNDLED_MODELS` (``"b1_speeds"``,
        the simulator's across-speeds model, walk and trot) is that bundled file.

        >>> EnergyModel.load("b1_speeds").metadata["fit"]["speed_terms"]["supported"]
        True

        Raises
        ------
        ModelError
            If the file is missing, not JSON, or does not follow the schema.
        """
        path = Path(path)
        if not path.exists() and len(path.parts) == 1 and path.stem in BUNDLED_MODELS:
            path = BUNDLED_MODELS[path.stem]
        try:
            doc = json.loads(path.read_text())
        except FileNotFoundError as exc:
            raise ModelError(
                f"model file {str(path)!r} does not exist (bundled models by name: "
                f"{', '.join(BUNDLED_MODELS)})",
                path=path,
            ) from exc
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ModelError(
                f"model file {str(path)!r} is not valid JSON: {exc}", path=path
            ) from exc
        try:
            return cls.from_dict(doc, source=str(path))
        except ModelError as exc:
            exc.fields.setdefault("path", str(path))  # the file at fault, for callers
            raise

    @classmethod
    def default(cls) -> EnergyModel:
        """The bundled B1-class model (about 50 kg, 0.3 m/s); see its ``metadata``."""
        return cls.load(_DEFAULT_PATH)

    def describe(self) -> str:
        """A table of terms, coefficients, standard errors and explanations."""
        rows = []
        for t in self.terms:
            c = None if self.coefficients is None else self.coefficients.get(t.name)
            s = None if self.stderr is None else self.stderr.get(t.name)
            cs = "-" if c is None else f"{c:10.3f}"
            ss = "" if s is None else f" ± {s:.3f}"
            rows.append(f"{t.name:<22} {cs}{ss:<12} {t.unit:<6} {t.explanation}")
        return "\n".join(rows)

    # ------------------------------------------------------------------ compiled kernels
    def kernel_source(
        self,
        constants: Mapping[str, Any] | None = None,
        channels: Sequence[tuple[str, Sequence[str] | None]] | None = None,
    ) -> str:
        """Python source of a scalar power function for numba.

        The function is ``power(alpha, gamma, vx, vy, wz, ax, ay) -> (total, by_kind)``
        where ``by_kind`` sums the terms of each kind in :data:`KINDS` order; ``total`` is
        floored at zero unless the model is regenerative. Features other than the
        arguments (extra channels such as ``payload_kg``) must be given in ``constants``
        (compiled in) or ``channels``.

        Parameters
        ----------
        constants : mapping, optional
            Channel name -> number or category (string), substituted at render time.
        channels : sequence of (name, categories or None), optional
            Channels that vary per sample (rasters). When given (even empty), the function
            takes an eighth argument ``ch``, a float array holding these channels in this
            order; a categorical channel (``categories`` a sequence of strings) holds the
            index of its category, and every term that reads it is rendered once per
            category (its comparisons folded) and chosen by that index at run time.

        Raises
        ------
        MissingChannelError
            If a term reads a channel given neither as a constant nor as a raster: names
            the channels, the terms, and the ``--set`` / ``--channel`` options.

        Examples
        --------
        >>> m = EnergyModel(["speed * (ground == 'meadow')"], {"speed * (ground == 'meadow')": 2.0})
        >>> src = m.kernel_source(channels=[("ground", ["asphalt", "meadow"])])
        >>> "if ch_ground == 0.0" in src
        True
        """
        from energy_planner.errors import MissingChannelError

        coefs = self.coef_array()
        consts = dict(constants or {})
        rasters = list(channels or [])
        raster_names = [name for name, _ in rasters]
        categories = {name: list(cats) for name, cats in rasters if cats is not None}
        varmap = {name: name for name in KERNEL_ARGS}
        varmap["speed"] = "speed"
        for name in raster_names:
            if name not in categories:
                varmap[name] = f"ch_{name}"
        known = set(varmap) | set(consts) | set(categories)
        missing = sorted(self.variables - known)
        if missing:
            readers = [t.name for t in self.terms if t.variables & set(missing)]
            given = sorted(set(consts) | set(raster_names))
            raise MissingChannelError(
                f"the model needs {', '.join(map(repr, missing))} (channel(s) read by "
                f"term(s) {', '.join(map(repr, readers))}), not given (channels given: "
                f"{', '.join(given) or 'none'}); give each with --set NAME=VALUE (a constant, "
                f"e.g. --set {missing[0]}=...) or --channel NAME=RASTER[:TABLE] (a map, e.g. "
                f"--channel {missing[0]}=map.tif), or choose a model without these terms",
                missing=missing,
            )

        def render(formula: Any, cats: list[str], fixed: dict[str, Any]) -> str:
            if not cats:
                return formula.to_scalar_source(varmap, {**consts, **fixed})
            name, rest = cats[0], cats[1:]
            options = [render(formula, rest, {**fixed, name: c}) for c in categories[name]]
            expr = options[-1]
            for i in range(len(options) - 2, -1, -1):
                expr = f"({options[i]} if ch_{name} == {float(i)!r} else {expr})"
            return expr

        kind_sums: dict[str, list[str]] = {k: [] for k in KINDS}
        for term, c in zip(self.terms, coefs, strict=True):
            cats = sorted(term.variables & set(categories))
            if any(not categories[n] for n in cats):
                empty = [n for n in cats if not categories[n]]
                raise MissingChannelError(
                    f"categorical channel(s) {', '.join(empty)} have no category", missing=empty
                )
            expr = render(term.parsed, cats, {})
            kind_sums[term.kind].append(f"{float(c)!r} * {expr}")
        args = ", ".join(KERNEL_ARGS) + (", ch" if channels is not None else "")
        lines = [
            f"def power({args}):",
            "    speed = math.sqrt(vx * vx + vy * vy)",
        ]
        for i, name in enumerate(raster_names):
            lines.append(f"    ch_{name} = ch[{i}]")
        for k in KINDS:
            lines.append(f"    p_{k} = " + (" + ".join(kind_sums[k]) or "0.0"))
        total = " + ".join(f"p_{k}" for k in KINDS)
        lines.append(f"    total = {total}")
        if not self.regenerative:
            lines.append("    total = max(total, 0.0)")
        lines.append("    return total, (" + ", ".join(f"p_{k}" for k in KINDS) + ")")
        return "\n".join(lines) + "\n"

    def power_kernel(self, constants: Mapping[str, Any] | None = None):
        """A numba-compiled scalar power function (see :meth:`kernel_source`)."""
        from energy_planner.model._codegen import compile_kernel

        return compile_kernel(self.kernel_source(constants))


def check_walking_power(
    model: EnergyModel,
    channel_values: Mapping[str, Any] | None = None,
    *,
    max_slope_deg: float = 45.0,
    speeds: Sequence[float] = (DEFAULT_SPEED,),
    yaw_rate: float = 0.5,
    gaits: Iterable[str] = tuple(WALKING_GAITS),
    where: str = "",
) -> int:
    """Raise if the model prices a walking motion at zero or negative power.

    The model's unclamped power (the sum of its terms, before the floor of
    :meth:`EnergyModel.power`) is evaluated on a grid: slopes from 0 to ``max_slope_deg``
    (2.5 deg steps), relative headings all round (10 deg steps), each gait at each speed
    (and turning in place at ``yaw_rate``), every combination of the channel values. Every
    grid motion is walking (:data:`WALKING_SPEED`, :data:`WALKING_YAW_RATE`), and a legged
    robot draws power to walk: a grid motion priced at <= 0 W means a term the logs did
    not pin down has a value that cancels the rest. A motion no term prices at all (every
    contribution exactly 0: a hand-written model without a term for it) has no term to
    blame and is not an error here; a fitted model always has ``idle_power``.

    Parameters
    ----------
    model : EnergyModel
        A fitted model (a regenerative one is not checked: it may legitimately return
        power).
    channel_values : mapping, optional
        Channel name -> value or sequence of values (numbers or categories).
    max_slope_deg : float
        Steepest slope checked, deg.
    speeds : sequence of float
        Walking speeds, m/s (each above :data:`WALKING_SPEED`).
    yaw_rate : float
        Turning rate of turning in place, rad/s.
    gaits : iterable of str
        Among ``forward``, ``backward``, ``sideways left``, ``sideways right``,
        ``turning in place``.
    where : str
        Prefix of the message (what was being done, e.g. the model file).

    Returns
    -------
    int
        The number of grid motions checked.

    Raises
    ------
    NonPositivePowerError
        Names the motion priced lowest, its power, and the term with the largest negative
        contribution there (with the other negative ones), and how many grid motions fail.
    ModelError
        A channel the model reads is missing from ``channel_values``.

    Examples
    --------
    >>> m = EnergyModel(["idle_power", "lat_const"], {"idle_power": 100.0, "lat_const": -900.0})
    >>> check_walking_power(m, gaits=["forward"])
    684
    >>> try:
    ...     check_walking_power(m)
    ... except NonPositivePowerError as exc:
    ...     print(str(exc)[:54], "'lat_const'" in str(exc))
    the model prices walking sideways left on level ground True
    """
    if model.regenerative:
        return 0
    gaits = list(gaits)
    bad_gaits = [g for g in gaits if g not in WALKING_GAITS]
    if bad_gaits:
        raise ModelError(f"unknown gait(s) {bad_gaits}; choose among {list(WALKING_GAITS)}")
    slopes = np.radians(np.arange(0.0, max(float(max_slope_deg), 0.0) + 1e-9, 2.5))
    headings = np.radians(np.arange(-180.0, 180.0, 10.0))
    rows = []
    for g in gaits:
        direction = WALKING_GAITS[g]
        for v in [None] if direction is None else list(speeds):
            a, h = np.meshgrid(slopes, headings, indexing="ij")
            n = a.size
            vx = 0.0 if direction is None else v * math.cos(direction)
            vy = 0.0 if direction is None else v * math.sin(direction)
            wz = yaw_rate if direction is None else 0.0
            rows.append((g, v, a.ravel(), h.ravel(), np.full(n, vx), np.full(n, vy), wz))
    alpha = np.concatenate([r[2] for r in rows])
    gamma = np.concatenate([r[3] for r in rows])
    vx = np.concatenate([r[4] for r in rows])
    vy = np.concatenate([r[5] for r in rows])
    wz = np.concatenate([np.full(r[2].size, r[6]) for r in rows])
    gait = np.concatenate([np.full(r[2].size, r[0], dtype=object) for r in rows])
    speed_of = np.concatenate([np.full(r[2].size, r[1] or 0.0) for r in rows])
    base = {"alpha": alpha, "gamma": gamma, "vx": vx, "vy": vy, "wz": wz}
    base["ax"] = base["ay"] = np.zeros(alpha.size)
    values = {
        k: np.atleast_1d(np.asarray(v, dtype=object)) for k, v in (channel_values or {}).items()
    }
    needed = sorted(model.variables - set(base) - {"speed"})
    missing = [c for c in needed if c not in values]
    if missing:
        raise ModelError(
            f"{where}the model reads channel(s) {', '.join(missing)}: give their values to "
            "check the power of walking (--set NAME=VALUE)"
        )
    combos: list[dict[str, Any]] = [{}]
    for c in needed:
        combos = [{**d, c: val} for d in combos for val in values[c]]
    coefs = model.coef_array()
    checked = 0
    worst = None
    n_bad = 0
    for combo in combos:
        f = dict(base)
        for c, val in combo.items():
            f[c] = np.full(alpha.size, val)
        contrib = model.design_matrix(f) * coefs
        p = contrib.sum(axis=1)
        checked += p.size
        bad = (p <= 0.0) & (contrib.min(axis=1) < 0.0)
        n_bad += int(bad.sum())
        if bad.any():
            i = int(np.argmin(p))
            if worst is None or p[i] < worst[0]:
                worst = (float(p[i]), i, combo, contrib[i])
    if worst is None:
        return checked
    p_min, i, combo, contrib = worst
    names = model.term_names
    order = np.argsort(contrib)
    negative = [f"{names[j]} {contrib[j]:+.1f} W" for j in order if contrib[j] < 0]
    culprit = names[int(order[0])]
    slope = math.degrees(alpha[i])
    where_slope = "on level ground" if slope == 0 else f"on a {slope:g} deg slope"
    at = f"at {speed_of[i]:g} m/s" if gait[i] != "turning in place" else f"at {yaw_rate:g} rad/s"
    ch = "".join(f", {c} = {v}" for c, v in combo.items())
    raise NonPositivePowerError(
        f"{where}the model prices walking {gait[i]} {where_slope} (heading "
        f"{math.degrees(gamma[i]):g} deg from uphill{ch}) {at} at {p_min:.1f} W, and "
        f"{n_bad} of {checked} walking motions checked at <= 0 W; a legged robot draws power "
        f"to walk. The term with the largest negative contribution is {culprit!r} "
        f"(negative terms there: {'; '.join(negative)}): the logs it was fitted on cannot "
        "have pinned it down for this motion (see metadata.fit.unidentified); refit "
        "without it, with a prior (fit --prior), or on logs that include this motion"
    )


def term_names(specs: Iterable[str | Term]) -> list[str]:
    """Resolve term specs to names (for messages and CLI output)."""
    return [resolve_term(s).name for s in specs]
