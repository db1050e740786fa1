"""The follower's calibrated interval (split-conformal by group) and what it learns from."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import energy_planner as ep
from energy_planner.follow import RemainingScores, bundled_scores
from energy_planner.follow.calibrate import (
    calibrate_remaining,
    counted,
    group_state,
    score_group,
)
from energy_planner.simulate.config import MissionEvent
from energy_planner.uncertainty import conformal_bounds, interval


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
            iv = interval(u.model_j, sc, 0.9)
            assert (u.low_j, u.high_j) == pytest.approx((max(iv.low_j, 0.0), iv.high_j))
            assert u.low_j <= u.remaining_j <= u.high_j
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


@given(
    state=st.sampled_from(["steady", "adapting", "dem"]),
    step=st.floats(-1.0, 1.0),
    split=st.one_of(st.none(), st.floats(0.0, 0.5)),
)
def test_score_group_splits_only_adapting_by_the_detected_steps_size(state, step, split):
    g = score_group(state, step, split)
    assert group_state(g) == state  # a group never leaves its state (the fallback's key)
    if state != "adapting" or split is None:
        assert g == state
    else:
        assert g == ("adapting_large" if abs(step) > split else "adapting_small")


@given(
    n_small=st.integers(0, 40),
    n_large=st.integers(0, 40),
    n_other=st.integers(20, 40),
    legacy=st.booleans(),
)
@settings(max_examples=30, deadline=None)
def test_group_falls_back_to_both_adapting_groups_then_to_all(n_small, n_large, n_other, legacy):
    # the scores carry their group in their value, so where they came from is readable
    scores = {
        "steady": [(0.5, 1.0)] * n_other,
        "adapting_small": [(0.5, 2.0)] * n_small,
        "adapting_large": [(0.5, 3.0)] * n_large,
    }
    if legacy:  # a file calibrated before the split: one "adapting" group
        scores = {"steady": scores["steady"], "adapting": [(0.5, 4.0)] * (n_small + n_large)}
    rs = RemainingScores(scores, normalized=True, step_split=None if legacy else 0.08)
    need = 19  # a two-sided 90 % interval
    got = rs.for_group("adapting_large", 0.5, 0.9)
    if legacy:
        expect = [4.0] * (n_small + n_large) if n_small + n_large >= need else None
    elif n_large >= need:
        expect = [3.0] * n_large
    elif n_small + n_large >= need:
        expect = [2.0] * n_small + [3.0] * n_large  # the state's: both adapting groups
    else:
        expect = None
    if expect is None:  # too few in the state at any width: every state's
        assert got.size == n_other + n_small + n_large
    else:
        assert sorted(got.tolist()) == expect
    # the state's name reads every group of that state
    both = rs.for_group("adapting", 0.5, 0.9)
    assert both.size == (n_small + n_large if n_small + n_large >= need else got.size)


@given(ratio=st.floats(2.0, 4.0), seed=st.integers(0, 2**31 - 1))
@settings(max_examples=4, deadline=None)
def test_split_by_a_run_time_feature_covers_two_error_scales_alike(ratio, seed):
    # Two kinds of mission in one state whose normalized errors differ in scale by
    # `ratio` (a payload's, a mud's), told apart by a feature a follower knows (the
    # detected step, here 0.12 vs 0.06). A pooled interval over-covers the small kind
    # and under-covers the large one; Mondrian groups by the feature cover each at the
    # level (split-conformal's guarantee within each group). 400 calibrations of 150
    # per kind, each tried on 50 new missions per kind: the coverage is within 3
    # binomial sd of its expectation (>= 0.9).
    rng = np.random.default_rng(seed)
    level, reps, n, m = 0.9, 400, 150, 50
    cover = {"split": {0.06: 0, 0.12: 0}, "pooled": {0.06: 0, 0.12: 0}}
    for _ in range(reps):
        cal = {step: rng.normal(0.0, 1.0 if step < 0.1 else ratio, n) for step in (0.06, 0.12)}
        split: dict[str, list] = {}
        for step, z in cal.items():
            split.setdefault(score_group("adapting", step, 0.08), []).extend((0.5, v) for v in z)
        pooled = {"adapting": [p for v in split.values() for p in v]}
        for kind, scores in (("split", split), ("pooled", pooled)):
            rs = RemainingScores(scores, normalized=True, step_split=0.08)
            for step in (0.06, 0.12):
                g = score_group("adapting", step, rs.step_split if kind == "split" else None)
                lo, hi = conformal_bounds(rs.for_group(g, 0.5, level), level)
                new = rng.normal(0.0, 1.0 if step < 0.1 else ratio, m)
                cover[kind][step] += int(np.sum((new >= lo) & (new <= hi)))
    tol = 3.0 * np.sqrt(level * (1 - level) / (reps * m)) + 0.01  # + the calibration's spread
    for step in (0.06, 0.12):
        assert cover["split"][step] / (reps * m) >= level - tol
    # pooled: the large kind is under-covered, the small one over-covered
    assert cover["pooled"][0.12] / (reps * m) < level - tol
    assert cover["pooled"][0.06] / (reps * m) > level + tol


def test_a_large_payload_lands_in_the_large_step_group_and_no_event_stays_steady(
    follow_mission, make_follower
):
    # Independent truth: the log's own measured power (voltage x current) with and
    # without a 30 kg payload on the same mission (same seed and path): its relative rise
    # over the 10 s after the pick-up. The follower's detected step is the short mean
    # innovation at detection: at least change_share (the detection rule) and at most the
    # rise (the mean only catches up with it); a large payload's is above the bundled
    # calibration's split.
    payload = [MissionEvent("payload", at=0.4, load_kg=30.0)]
    base, loaded = follow_mission(), follow_mission(payload)
    t = base["t"].to_numpy()
    t_ev = t[0] + 0.4 * (t[-1] - t[0])
    after = (t >= t_ev + 1.0) & (t <= t_ev + 11.0)

    def power(logs):
        return (logs["voltage"] * logs["current"]).to_numpy()[after].mean()

    rise = power(loaded) / power(base) - 1.0
    rs = bundled_scores()
    assert rs.step_split is not None and rs.step_split < rise
    f = make_follower(loaded, remaining_scores=rs)
    ups = f.replay(loaded)
    detected = [u for u in ups if u.state == "adapting"]
    assert detected and detected[0].t >= t_ev
    step = detected[0].step
    assert f.change_share <= step <= 1.1 * rise
    assert step > rs.step_split
    assert {u.group for u in detected} == {"adapting_large"}
    assert all(u.group == "steady" and u.step == 0.0 for u in ups if u.t < t_ev)
    # the interval is read from that group's scores
    u = detected[-1]
    z = rs.for_group("adapting_large", u.remaining_share, 0.9)
    iv = interval(u.model_j, np.maximum(z * u.spread, -0.9), 0.9)
    assert (u.low_j, u.high_j) == pytest.approx((max(iv.low_j, 0.0), iv.high_j))
    # without an event: never leaves steady, no step
    g = make_follower(base, remaining_scores=rs)
    assert {(u.group, u.step) for u in g.replay(base)} == {("steady", 0.0)}


def test_bundled_scores_are_the_file_and_each_call_its_own_copy():
    """The bundled scores are read once per process: each call equals the file read afresh
    (``RemainingScores.load``), and changing one call's scores leaves the next call's whole."""
    from pathlib import Path

    import energy_planner.follow.calibrate as cal

    path = Path(cal.__file__).resolve().parents[1] / "data" / cal.SCORES_FILE
    fresh = RemainingScores.load(path)
    first = bundled_scores()
    assert first == fresh and first.to_dict() == fresh.to_dict()
    group = next(iter(first.scores))
    first.scores[group].clear()
    first.conditions.clear()
    again = bundled_scores()
    assert again == fresh and again.scores[group] and again is not first
