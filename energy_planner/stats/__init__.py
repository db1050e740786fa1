"""Shared numerics: weighted least squares, folds by run, identifiability, motion classes.

Least squares, identifiability and motion classes live in
:mod:`energy_planner.stats.numerics`; folds by run and the one held-out evaluation
(:func:`heldout`, floored per sample) in :mod:`energy_planner.stats.heldout`.

>>> from energy_planner.stats import fold_index
>>> fold_index(["a", "a", "b"], 2).tolist()
[0, 0, 1]
"""

from energy_planner.stats import numerics as _numerics
from energy_planner.stats.heldout import HeldOut, fold_index, heldout, paired_run_test
from energy_planner.stats.numerics import *  # noqa: F403 (its __all__, re-exported)

__all__ = ["HeldOut", "fold_index", "heldout", "paired_run_test", *_numerics.__all__]
