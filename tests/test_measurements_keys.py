"""The hashing shortcuts of the loaders give what numpy's and pandas' sorting forms give."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from energy_planner.measurements.schema import _unique_inverse, float_values


@pytest.mark.parametrize("seed", range(5))
def test_unique_inverse_is_np_unique(seed):
    rng = np.random.default_rng(seed)
    names = ["b", "a", "ä", "a1", "", "Z", "10", "9", "run_2", "run_10"]
    runs = rng.choice(names, int(rng.integers(1, 300))).astype(object).astype(str)
    uniq, inv = _unique_inverse(runs)
    ref_uniq, ref_inv = np.unique(runs, return_inverse=True)
    assert uniq.dtype == ref_uniq.dtype and inv.dtype == ref_inv.dtype
    np.testing.assert_array_equal(uniq, ref_uniq)
    np.testing.assert_array_equal(inv, ref_inv)


def test_float_values_is_to_numeric():
    cols = [
        pd.Series([1.5, np.nan, -0.0]),
        pd.Series([1, 2, 3]),
        pd.Series(["1.5", "x", None], dtype=object),
        pd.Series(["2", "3.25", ""], dtype="str"),
    ]
    for col in cols:
        ref = pd.to_numeric(col, errors="coerce").to_numpy(dtype=float)
        got = float_values(col)
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, ref)
