"""Shared numerics: weighted least squares, folds by run, identifiability, motion classes.

Everything lives in :mod:`energy_planner.stats.numerics`; see its docstring.

>>> from energy_planner.stats import run_folds
>>> run_folds(["a", "b"], 2)
[['a'], ['b']]
"""

from energy_planner.stats.numerics import (
    MOTIONS,
    WLSFit,
    classify_motion,
    cluster_stderr,
    fold_index,
    heldout_residuals,
    heldout_rmse,
    independent_columns,
    run_folds,
    span_basis,
    span_residual,
    vif,
    wls,
    wls_coef,
)

__all__ = [
    "MOTIONS",
    "WLSFit",
    "classify_motion",
    "cluster_stderr",
    "fold_index",
    "heldout_residuals",
    "heldout_rmse",
    "independent_columns",
    "run_folds",
    "span_basis",
    "span_residual",
    "vif",
    "wls",
    "wls_coef",
]
