"""``energy_score`` keeps its results by the content of the samples: never a stale one.

The repair guard scores the same states of the samples again (a repair's "before" is the
last repair's "after"; fit, diagnose and discover on the same logs check them the same
way), so :func:`energy_planner.calibration.prepare.energy_score` keeps its last results.
A kept result must be exactly what a fresh computation gives, and any change of the
samples (one number, a column's type), the window or the terms must compute afresh.
"""

from __future__ import annotations

import functools
import warnings

import pandas as pd
import pytest

from energy_planner.calibration import prepare as P


@functools.cache
def _logs() -> pd.DataFrame:
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        config = CampaignConfig.small(run_s=4.0, rate_hz=10.0)  # 4.6k samples, 92 runs
        return simulate_campaign(seed=0, config=config).logs


def _fresh(samples, **kw):
    """The score computed, bypassing the kept results."""
    return P._energy_score(samples, kw.get("window", 2.0), kw.get("terms"))


@pytest.fixture
def empty_cache():
    P._ENERGY_SCORES.clear()
    yield
    P._ENERGY_SCORES.clear()


def test_the_same_samples_get_the_same_score(empty_cache):
    logs = _logs()
    first = P.energy_score(logs)
    assert len(first.rel_error) > 10
    again = P.energy_score(logs.copy())  # another object, the same content
    assert again is first  # kept
    pd.testing.assert_series_equal(again.rel_error, _fresh(logs).rel_error, check_exact=True)


def test_changed_samples_window_or_terms_are_scored_afresh(empty_cache):
    logs = _logs()
    first = P.energy_score(logs)
    moved = logs.copy()
    moved.loc[moved.index[len(moved) // 2], "x"] += 0.5  # one pose sample, half a metre off
    got = P.energy_score(moved)
    assert got is not first
    pd.testing.assert_series_equal(got.rel_error, _fresh(moved).rel_error, check_exact=True)
    assert not got.rel_error.equals(first.rel_error)  # the change shows in the score
    longer = P.energy_score(logs, window=3.0)
    assert longer is not first
    pd.testing.assert_series_equal(
        longer.rel_error, _fresh(logs, window=3.0).rel_error, check_exact=True
    )
    terms = ["speed", "1"]
    fewer = P.energy_score(logs, terms=terms)
    assert fewer is not first
    pd.testing.assert_series_equal(
        fewer.rel_error, _fresh(logs, terms=terms).rel_error, check_exact=True
    )
    # the same numbers under another type (float32 poses) are other samples
    as32 = logs.astype({"y": "float32"})
    assert P.energy_score(as32) is not first
