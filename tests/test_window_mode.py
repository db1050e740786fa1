"""A window's value of a non-numeric channel is its mode, as ``value_counts`` ranks it.

``make_windows`` counts every window in one grouping; the reference here is the counting
of each window itself (pandas' ``value_counts``, first of the sorted counts), on random
categorical and text channels with missing values and ties.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.measurements.windows import _mode, make_windows


def _reference(s: pd.Series):
    """The first of the sorted counts; None with no value (``value_counts`` of an all-missing
    categorical lists its categories with zero counts: no value is not its first category)."""
    vc = s.value_counts(sort=True, dropna=True)
    vc = vc[vc > 0]
    return vc.index[0] if len(vc) else None


values = st.lists(st.sampled_from(["asphalt", "gravel", "mud", None]), min_size=1, max_size=12)


@given(values, st.booleans(), st.lists(st.sampled_from(["mud", "asphalt", "gravel", "ice"])))
@settings(max_examples=60, deadline=None)
def test_mode_is_the_first_of_the_counts(vals, categorical, extra_categories):
    if categorical:
        cats = list(dict.fromkeys([*extra_categories, "asphalt", "gravel", "mud"]))
        s = pd.Series(pd.Categorical(vals, categories=cats))
    else:
        s = pd.Series(vals, dtype=object)
    got, want = _mode(s), _reference(s)
    assert got == want and type(got) is type(want), (vals, got, want)


def test_windows_of_a_changing_ground_take_its_mode():
    """Windows of 2 s at 10 Hz over a ground that changes mid-window (and is missing in
    places): each window's ground is the counted mode of its samples."""
    n = 200
    t = np.arange(n) * 0.1
    ground = np.array(["mud", "gravel", "asphalt"])[(np.arange(n) // 7) % 3].astype(object)
    ground[::13] = None
    df = pd.DataFrame(
        {
            "run": "r0", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
            "vx": 0.3, "vy": 0.0, "wz": 0.0, "voltage": 48.0, "current": 2.0,
            "ground": pd.Categorical(ground, categories=["asphalt", "gravel", "mud"]),
        }
    )  # fmt: skip
    w = make_windows(df, duration=2.0)
    assert len(w.table) >= 5
    for win, grp in w.samples.groupby("window"):
        row = w.table.loc[w.table["window"] == win].iloc[0]
        assert row["ground"] == _reference(grp["ground"])
    assert w.table["ground"].nunique() > 1
