"""The follower's calibrated interval (split-conformal by group) and what it learns from."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import energy_planner as ep
from energy_planner.follow import RemainingScores
from energy_planner.follow.calibrate import calibrate_remaining, counted
from energy_planner.simulate.config import MissionEvent
from energy_planner.uncertainty import interval


@given(
    n=st.integers(19, 80),
    scale=st.floats(0.002, 0.2),
    shift=st.floats(-0.05, 0.05),
    heavy=st.booleans(),
    seed=st.integers(0, 2**31 - 1),
)
@settings(max_examples=8, deadline=None)
def test_group_interval_covers_exchangeable_errors_at_least_at_the_level(
    n, scale, shift, heavy, seed
):
    # Split-conformal: with n exchangeable calibration errors, a new error of the same law
    # falls inside the interval with probability >= level, whatever the law (by
    # construction). 1500 independent repetitions: the empirical coverage is within
    # 3 binomial sd (0.023 at 0.9) of its expectation, which is >= 0.9.
    rng = np.random.default_rng(seed)
    level, reps = 0.9, 1500

    def draw(size):
        e = rng.standard_t(2, size) if heavy else rng.normal(0.0, 1.0, size)
        return np.clip(shift + scale * e, -0.9, 10.0)

    hits = 0
    for _ in range(reps):
        rs = RemainingScores({"steady": [(0.5, float(e)) for e in draw(n)]})
        sc = rs.for_group("steady", 0.5, level)
        e_true = 1000.0
        e_pred = e_true * (1.0 + draw(1)[0])
        iv = interval(e_pred, sc, level)
        hits += iv.low_j <= e_true <= iv.high_j
    assert hits / reps >= level - 3.0 * np.sqrt(level * (1 - level) / reps)


def test_group_falls_back_to_its_state_then_to_all_when_too_few():
    rs = RemainingScores(
        {"steady": [(0.1, 0.01)] * 5 + [(0.5, 0.02)] * 20, "dem": [(0.1, 0.5)] * 3}
    )
    assert rs.for_group("steady", 0.5, 0.9).tolist() == [0.02] * 20  # its share: 20 >= 19
    assert rs.for_group("steady", 0.51, 0.9).tolist() == [0.02] * 20  # within 0.025
    # 5 near 0.1: the neighbourhood doubles (0.05, 0.1, 0.2, 0.4) until it holds 0.5's
    assert rs.for_group("steady", 0.1, 0.9).size == 25
    assert rs.for_group("dem", 0.1, 0.9).size == 28  # state has 3: every state's
    back = RemainingScores.from_dict(rs.to_dict())
    assert back.scores == rs.scores


def test_dem_error_windows_and_the_dead_band_leave_the_fit_coefficients_unchanged(
    follow_mission, make_follower
):
    # A stretch where the DEM is 5 deg off: the IMU sees it (a finding), its windows are
    # DEM errors, not model errors; nothing else changes, so no change of conditions is
    # detected and the coefficients stay exactly the fit's (the dead band).
    logs = follow_mission([MissionEvent("dem_bias", at=0.3, until=0.6, slope_bias_deg=5.0)])
    f = make_follower(logs)
    ups = f.replay(logs)
    assert f.findings
    assert not [e for e in f.events if "a change of conditions" in e]
    np.testing.assert_array_equal(f.rls.coef, ep.load_model().coef_array())
    assert {u.state for u in ups} >= {"steady", "dem"}
    # without the dead band the coefficients are learnt from every window ...
    g = make_follower(logs, dead_band=False)
    x = np.ones_like(g.c0)
    before = g.rls.coef.copy()
    g._n_windows = 1
    # ... except a window whose IMU slope disagrees with the DEM's beyond the tolerance
    g._update(0.0, x, 500.0, 10.0, 12.0, 12.0 - 2 * g.slope_tol_deg, (0, 0), (0, 0), 8.0)
    np.testing.assert_array_equal(g.rls.coef, before)
    # and the agreeing window right after it (it straddles the stretch's end)
    g._update(0.0, x, 500.0, 12.0, 12.0, 12.0, (0, 0), (0, 0), 10.0)
    np.testing.assert_array_equal(g.rls.coef, before)
    g._update(0.0, x, 500.0, 14.0, 12.0, 12.0, (0, 0), (0, 0), 12.0)
    assert not np.array_equal(g.rls.coef, before)


def test_calibrated_interval_is_the_conformal_interval_of_the_followers_group(
    follow_mission, make_follower
):
    logs = follow_mission([MissionEvent("payload", at=0.3, load_kg=15.0)])
    rng = np.random.default_rng(3)
    scores = {
        s: list(zip(rng.uniform(0, 1, 400).tolist(),
                    rng.normal(0.0, 0.01 * (i + 1), 400).tolist(), strict=True))
        for i, s in enumerate(("steady", "adapting", "dem"))
    }  # fmt: skip
    for normalized in (False, True):
        rs = RemainingScores(scores, normalized=normalized)
        f = make_follower(logs, remaining_scores=rs)
        ups = f.replay(logs)
        assert {u.state for u in ups} == {"steady", "adapting"}
        for u in ups[::7]:
            z = rs.for_group(u.state, u.remaining_share, 0.9)
            assert 19 <= z.size < 400  # the scores near its remaining share only
            # normalized: the scores are in units of the follower's own spread
            sc = np.maximum(z * u.spread, -0.9) if normalized else z
            iv = interval(u.remaining_j, sc, 0.9)
            assert (u.low_j, u.high_j) == pytest.approx((max(iv.low_j, 0.0), iv.high_j))
    # the spread is larger after the pick-up (the follower is catching up) than before
    steady = [u.spread for u in ups if u.state == "steady"]
    adapting = [u.spread for u in ups if u.state == "adapting"]
    assert np.median(adapting) > np.median(steady)


def test_calibration_scores_only_what_the_follower_has_picked_up():
    run = {"t_event": 50.0, "picked_at": 55.0}
    assert not counted(run, 52.0) and counted(run, 56.0)
    assert not counted({"t_event": 50.0, "picked_at": None}, 90.0)
    assert counted({"t_event": None, "picked_at": None}, 1.0)
    rs = calibrate_remaining(ep.load_model(), seeds=[7], events=("none",), duration=60.0)
    assert rs.seeds == (7,)
    assert len(rs.scores["steady"]) == 14 and not rs.scores["adapting"] and not rs.scores["dem"]
    shares = sorted(p[0] for p in rs.scores["steady"])  # remaining 80 % ... 15 %, 2 s steps
    assert shares[0] == pytest.approx(0.15, abs=0.04) and shares[-1] == pytest.approx(0.8, abs=0.04)
    assert rs.normalized and RemainingScores.from_dict(rs.to_dict()) == rs
