"""Issue 20 point 2: no arbitrary coefficients, no free lunch.

Mission logs where the robot always faces along its path (no sideways, no backward
walking) and carries a hidden payload (``simulate_missions``, reduced: 3 missions x 120 s).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.calibration import fit_model
from energy_planner.calibration._windows import aligned_table
from energy_planner.calibration.fit import identifiable, refuse_free_walking
from energy_planner.calibration.windowdata import window_data
from energy_planner.diagnosis.candidates import default_candidates
from energy_planner.diagnosis.names import model_term
from energy_planner.energy.path import path_energy
from energy_planner.errors import NonPositivePowerError
from energy_planner.measurements import make_windows, preprocess
from energy_planner.model import BASE_TERMS, EnergyModel, resolve_term
from energy_planner.model.model import check_walking_power
from energy_planner.simulate import MissionConfig, simulate_missions, true_path_energy
from energy_planner.terrain import load_dem
from energy_planner.uncertainty import predict_interval

HILL = Path(__file__).resolve().parents[1] / "energy_planner" / "data" / "maps" / "hill.tif"
#: 10 m across the middle of the bundled hill, walked facing +x (forward) or +y (sideways)
XY = np.array([[500090.0, 5000100.0], [500100.0, 5000100.0]])


@pytest.fixture(scope="module")
def forward_missions():
    """Windows of short mission logs that never walk sideways or backward, with a payload."""
    cfg = MissionConfig(missions=6, duration_s=120.0, sideways_prob=0.0, backward_prob=0.0)
    camp = simulate_missions(seed=1, effects=("load",), config=cfg)
    clean, _ = preprocess(camp.logs)
    windows = make_windows(clean, duration=4.0)
    return camp, windows


def _payload_term(windows, base):
    """The ``load_kg*P_base`` candidate discover builds on the base ``base``."""
    cands, _ = default_candidates(window_data(windows.samples), list(base))
    c = next(c for c in cands if c.name == "load_kg*P_base")
    return model_term(c.name, c.formula, c.explanation)


def test_no_lateral_or_backward_windows(forward_missions):
    _, windows = forward_missions
    kinds = set(windows.table["motion"])
    assert not any(k.startswith(("lateral", "backward")) for k in kinds)


def test_payload_on_the_whole_base_is_not_identified(forward_missions):
    # the staircase's base fit gives the lateral and backward terms arbitrary values
    # (1e5 W, 1e-12 W): a channel times that base prices sideways walking with them
    _, windows = forward_missions
    term = _payload_term(windows, BASE_TERMS)
    fit = fit_model(windows, [*BASE_TERMS, term], n_splits=0)
    why = fit.model.metadata["fit"]["unidentified"]
    assert "load_kg*P_base" in why and "lateral" in why["load_kg*P_base"]
    assert "load_kg*P_base" not in fit.model.term_names
    assert "lat_const" in why and "bwd_const" in why


def test_payload_on_the_identified_base_is_kept(forward_missions):
    # discover's hand-off: the staircase starts from the base terms the windows identify
    _, windows = forward_missions
    unident = identifiable(windows, BASE_TERMS)
    base = [t for t in BASE_TERMS if resolve_term(t).name not in unident]
    term = _payload_term(windows, base)
    assert "vy" not in term.formula and "-vx" not in term.formula
    fit = fit_model(windows, [*BASE_TERMS, term], n_splits=0)
    assert "load_kg*P_base" in fit.model.term_names
    assert fit.model.coefficients["load_kg*P_base"] > 0  # a payload costs


@settings(max_examples=15, deadline=None)
@given(c=st.floats(0.01, 1e6) | st.floats(-1e6, -0.01))
def test_other_term_on_an_absent_motion_is_never_identified(forward_missions, c):
    """Whatever its scale or sign, a term that prices sideways walking is not identified
    from logs without it, and one that reads only the payload is not flagged for it."""
    _, windows = forward_missions
    why = identifiable(windows, [*BASE_TERMS, f"{c!r} * vy ** 2", f"{c!r} * load_kg"])
    assert "lateral" in why[resolve_term(f"{c!r} * vy ** 2").name]
    assert resolve_term(f"{c!r} * load_kg").name not in why


@pytest.fixture(scope="module")
def hill():
    return load_dem(HILL)


def _free_lunch_model(windows):
    """The issue's model: a payload term with -165,700 on vy^2/speed, on a fitted base."""
    unident = identifiable(windows, BASE_TERMS)
    base = [t for t in BASE_TERMS if resolve_term(t).name not in unident]
    fit = fit_model(windows, base, n_splits=0)
    coefs = {**fit.model.coefficients, "load_kg*P_base": 1.0}
    payload = model_term(
        "load_kg*P_base",
        "load_kg * (10 * (pos(vx) ** 2 / max(speed, 0.05)) + "
        "-165700 * (vy ** 2 / max(speed, 0.05)))",
    )
    return EnergyModel([*fit.model.terms, payload], coefs)


def test_walking_priced_at_zero_is_an_error_naming_the_term(forward_missions, hill):
    _, windows = forward_missions
    model = _free_lunch_model(windows)
    # facing along the path the payload term is positive: a valid energy
    fwd = path_energy(hill, model, XY, constants={"load_kg": 18.0})
    assert fwd.energy_j > 0
    # sideways it is -165,700 * 18 * v: the floor used to make the walk free (0 J)
    with pytest.raises(NonPositivePowerError, match=r"load_kg\*P_base") as err:
        path_energy(hill, model, XY, yaw=[np.pi / 2] * 2, constants={"load_kg": 18.0})
    assert "sideways" in str(err.value)
    # without a payload the same model is fine (the term is zero)
    assert path_energy(hill, model, XY, yaw=[np.pi / 2] * 2, constants={"load_kg": 0.0})


def test_a_fit_that_prices_walking_below_zero_is_refused(forward_missions):
    _, windows = forward_missions
    model = _free_lunch_model(windows)
    model.coefficients["fwd_const"] = -5000.0  # forward walking below zero in the domain
    with pytest.raises(NonPositivePowerError, match="fwd_const"):
        refuse_free_walking(model, aligned_table(windows))


@settings(max_examples=20, deadline=None)
@given(
    c=st.floats(-2000.0, 2000.0),
    slope=st.floats(0.0, 40.0),
)
def test_check_agrees_with_the_sign_of_the_power(c, slope):
    """Level sideways power of idle 100 W + c * vy^2/speed at 0.3 m/s is 100 + 0.3 c
    (analytic): the check refuses exactly when that is <= 0."""
    m = EnergyModel(["idle_power", "lat_const"], {"idle_power": 100.0, "lat_const": c})
    ok = 100.0 + 0.3 * c > 0.0
    if ok:
        assert check_walking_power(m, max_slope_deg=slope, speeds=[0.3]) > 0
    else:
        with pytest.raises(NonPositivePowerError, match="lat_const"):
            check_walking_power(m, max_slope_deg=slope, speeds=[0.3])


def test_loaded_sideways_walk_costs_what_the_physics_says(forward_missions, hill):
    """Issue 20's free lunch, end to end on reduced mission logs: discover's hand-off
    (payload on the identified base), the unidentified motion terms held at the bundled
    model (a prior), then 10 m on the hill with 18 kg: the simulator's true energy lies in
    the 90 % interval, forward and sideways; and neither costs 0 J."""
    camp, windows = forward_missions
    unident = identifiable(windows, BASE_TERMS)
    base = [t for t in BASE_TERMS if resolve_term(t).name not in unident]
    term = _payload_term(windows, base)
    fit = fit_model(windows, [*BASE_TERMS, term], n_splits=4, prior=EnergyModel.default())
    model = fit.model
    assert set(model.metadata["fit"]["held_at_prior"]) >= {"lat_const", "bwd_const"}
    for yaw in (0.0, np.pi / 2):
        pe = path_energy(hill, model, XY, yaw=[yaw, yaw], constants={"load_kg": 18.0})
        truth = true_path_energy(
            hill,
            np.column_stack([XY, [yaw, yaw]]),
            effects=camp.effects,
            channels={"load_kg": 18.0},
        )
        iv = predict_interval(model, pe.energy_j)
        assert pe.energy_j > 1000.0
        assert iv.low_j <= truth.energy_j <= iv.high_j, (yaw, pe.energy_j, truth.energy_j, iv)


def test_plan_refuses_a_free_route(forward_missions, tmp_path):
    """The CLI: plan with the free-lunch model and 18 kg exits 1 naming the term."""
    from click.testing import CliRunner

    from energy_planner.cli import main

    _, windows = forward_missions
    path = _free_lunch_model(windows).save(tmp_path / "free.json")
    args = ["plan", "--dem", str(HILL), "--model", str(path), "--start", "500058,5000046",
            "--goal", "500058,5000084", "--set", "load_kg=18"]  # fmt: skip
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 1, res.output
    assert "load_kg*P_base" in res.output and "Traceback" not in res.output


# ------------------------------------------------------------------ D: calibration domain
def test_fit_records_its_domain(forward_missions):
    _, windows = forward_missions
    fit = fit_model(windows, BASE_TERMS, n_splits=0)
    dom = fit.model.metadata["fit"]["domain"]
    table = aligned_table(windows)
    assert dom["max_slope_deg"] == pytest.approx(np.degrees(table["alpha"].max()), abs=0.01)
    assert "forward" in dom["gaits"] and "lateral" not in dom["gaits"]
    lo, hi = dom["speed_m_s"]
    assert 0.05 < lo < hi <= table["speed"].max() + 1e-3


def _segments(durations, slopes, distances=None):
    import pandas as pd

    d = np.asarray(durations, float)
    return pd.DataFrame(
        {
            "duration_s": d,
            "distance_m": 0.3 * d if distances is None else distances,
            "max_slope_deg": slopes,
            "turn_deg": np.zeros(d.size),
        }
    )


def _domain_model():
    dom = {"max_slope_deg": 24.0, "speed_m_s": [0.2, 0.45], "max_turn_rate_rad_s": 0.6,
           "gaits": {"forward": {"windows": 9, "rel_heading_deg": [0.0, 180.0]}},
           "channels": {"load_kg": [0.0, 15.0]}}  # fmt: skip
    return EnergyModel(["idle_power"], {"idle_power": 100.0}, metadata={"fit": {"domain": dom}})


def test_domain_share_is_the_duration_outside():
    from energy_planner.uncertainty import domain_report

    m = _domain_model()
    rep = domain_report(m, _segments([1.0, 2.0, 1.0], [10.0, 30.0, 10.0]), {"load_kg": 10})
    assert rep["outside_share"] == 0.5 and list(rep["reasons"].values()) == [0.5]
    rep = domain_report(m, _segments([1.0, 2.0, 1.0], [10.0, 10.0, 10.0]), {"load_kg": 18})
    assert rep["outside_share"] == 1.0 and "load_kg" in next(iter(rep["reasons"]))
    assert (
        domain_report(EnergyModel(["idle_power"], {"idle_power": 1.0}), _segments([1], [0])) is None
    )


@settings(max_examples=30, deadline=None)
@given(yaw=st.floats(-np.pi, np.pi))
def test_a_gait_the_calibration_lacks_is_outside(yaw):
    """Walking +x with body yaw ``yaw``: forward within 45 deg, else outside (no lateral or
    backward windows in the calibration)."""
    from hypothesis import assume

    from energy_planner.uncertainty import domain_report

    assume(min(abs(abs(yaw) - np.pi / 4), abs(abs(yaw) - 3 * np.pi / 4)) > 1e-6)
    poses = np.array([[0.0, 0.0, yaw], [3.0, 0.0, yaw]])
    rep = domain_report(_domain_model(), _segments([10.0], [0.0]), poses=poses)
    forward = abs(yaw) < np.pi / 4
    assert rep["outside_share"] == (0.0 if forward else 1.0)
    if not forward:
        assert any(("lateral" in k) or ("backward" in k) for k in rep["reasons"])


@settings(max_examples=30, deadline=None)
@given(a=st.floats(0.0, 1.0), b=st.floats(0.0, 1.0))
def test_interval_widens_with_the_share_outside(a, b):
    from energy_planner.uncertainty import predict_interval

    rng = np.random.default_rng(0)
    scores = sorted(float(x) for x in rng.normal(0.0, 0.05, 40))
    m = EnergyModel(["idle_power"], {"idle_power": 1.0},
                    metadata={"fit": {"heldout_run_rel_errors": scores}})  # fmt: skip
    lo, hi = sorted((a, b))
    narrow, wide = predict_interval(m, 1000.0, 0.9, lo), predict_interval(m, 1000.0, 0.9, hi)
    assert wide.low_j <= narrow.low_j + 1e-9 and wide.high_j >= narrow.high_j - 1e-9


def test_energy_cli_reports_the_share_outside(forward_missions, tmp_path):
    from click.testing import CliRunner

    from energy_planner.cli import main

    _, windows = forward_missions
    unident = identifiable(windows, BASE_TERMS)
    base = [t for t in BASE_TERMS if resolve_term(t).name not in unident]
    fit = fit_model(windows, [*BASE_TERMS, _payload_term(windows, base)], n_splits=3)
    path = fit.model.save(tmp_path / "m.json")
    wp = tmp_path / "wp.csv"
    wp.write_text("x,y\n500010,5000010\n500020,5000010\n")  # a level corner of the hill
    out = {}
    for load in (10, 18):
        args = ["energy", "--dem", str(HILL), "--waypoints", str(wp), "--model", str(path),
                "--set", f"load_kg={load}", "--json"]  # fmt: skip
        res = CliRunner().invoke(main, args)
        assert res.exit_code == 0, res.output
        out[load] = __import__("json").loads(res.output)
    assert out[18]["domain"]["outside_share"] == 1.0
    assert out[18]["domain"]["shares"]["channel load_kg"] == 1.0
    assert any("load_kg" in k for k in out[18]["domain"]["reasons"])
    assert not any("load_kg" in k for k in out[10]["domain"]["reasons"])
    rel = {k: (v["interval"]["high_j"] - v["interval"]["low_j"]) / v["energy_j"]
           for k, v in out.items()}  # fmt: skip
    assert out[10]["domain"]["outside_share"] == 0.0
    assert rel[18] > rel[10]  # the interval widens outside


def test_plan_stay_in_domain_keeps_the_route_on_calibrated_slopes(forward_missions, tmp_path):
    from click.testing import CliRunner

    from energy_planner.cli import main

    _, windows = forward_missions
    fit = fit_model(windows, BASE_TERMS, n_splits=3)
    path = fit.model.save(tmp_path / "m.json")
    top = fit.model.metadata["fit"]["domain"]["max_slope_deg"]
    args = ["plan", "--dem", str(HILL), "--model", str(path), "--start", "500010,5000010",
            "--goal", "500040,5000040", "--stay-in-domain", "--json"]  # fmt: skip
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    out = __import__("json").loads(res.output[res.output.index("{") :])
    assert out["limits"]["max_slope_deg"] == pytest.approx(top)
    assert not any(k.startswith("slope") for k in out["domain"]["reasons"])
    # the logs never walk sideways or backward: the plan may not either (gait limits)
    assert out["limits"]["max_crab_deg"] == 45.0 and out["limits"]["max_backward_slope_deg"] == 0
    assert any("crab" in n for n in out["stay_in_domain"])
    assert out["domain"]["shares"]["gait"] == 0.0
    # a model without a recorded domain: a usage error
    bare = EnergyModel.default().save(tmp_path / "bare.json")
    res = CliRunner().invoke(main, [*args[:4], str(bare), *args[5:]])
    assert res.exit_code == 2 and "domain" in res.output


# --------------------------------------------------------------------------- issue 28.1
@pytest.fixture(scope="module")
def loaded_missions_with_stops():
    """Forward-only missions with stops (the base then has gait_power) and a payload."""
    from energy_planner.calibration.prepare import clean_logs

    cfg = MissionConfig(missions=6, duration_s=120.0, rate_hz=20.0, sideways_prob=0.0,
                        backward_prob=0.0, stop_prob=0.6, stop_s=5.0,
                        loads_kg=(0.0, 9.0, 18.0, 27.0))  # fmt: skip
    camp = simulate_missions(seed=1, effects=("load",), config=cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean, _ = clean_logs(camp.logs.drop(columns="z"))
    return make_windows(clean, duration=2.0)


def test_payload_on_a_base_with_the_gait_power_is_written(loaded_missions_with_stops):
    """gait_power prices every walk alike, backward too: a payload times that base prices
    backward walking no more than forward walking, which the logs hold, so the refit
    keeps it (it used to be dropped for pricing backward motion, and the staircase
    reported it as added while the written model lacked it)."""
    from energy_planner.calibration.fit import base_terms
    from energy_planner.diagnosis.names import term_spec
    from energy_planner.stats import fold_index

    windows = loaded_missions_with_stops
    base = base_terms(windows)
    unident = identifiable(windows, base)
    start = [t for t in base if resolve_term(t).name not in unident]
    assert "gait_power" in start and "bwd_const" not in start
    term = _payload_term(windows, start)
    wd = window_data(windows)
    folds = fold_index(wd.runs, 3)
    assert wd.unidentified([*start, term_spec(term)], folds) == {}
    fit = fit_model(windows, [*base, term], n_splits=0)
    assert "load_kg*P_base" in fit.model.term_names
    assert fit.model.coefficients["load_kg*P_base"] > 0


def test_a_suspect_the_refit_drops_is_reported_and_the_next_is_tried(
    loaded_missions_with_stops,
):
    from energy_planner.calibration.fit import base_terms
    from energy_planner.diagnosis.scoring import Ranking, Suspect
    from energy_planner.diagnosis.suspects import _first_kept
    from energy_planner.stats import fold_index

    windows = loaded_missions_with_stops
    wd = window_data(windows)
    start = [t for t in base_terms(windows) if resolve_term(t).name not in identifiable(
        windows, base_terms(windows))]  # fmt: skip

    def suspect(term):
        return Suspect(term, term, [], "", "data", 0.5, 1.0, 2.0, 1.0, 3.0, 1e-4, 6, 100)

    lateral, load = suspect("load_kg * vy ** 2"), suspect("load_kg")
    ranking = Ranking(start, 2.0, [], [lateral, load], [])
    assert _first_kept(wd, list(start), ranking, fold_index(wd.runs, 3)) is load
    (d,) = ranking.dropped
    assert d["term"] == "load_kg * vy ** 2" and "lateral" in d["reason"]


def test_a_mass_scales_the_power_the_gait_draws_never_below_zero():
    """``load_kg*P_base`` is the channel times the fitted base power, clipped at 0: where
    the base's fitted parts sum below 0 (a backward downhill motion priced poorly) a carried
    mass adds nothing, rather than a regeneration in proportion to the mass."""
    from energy_planner.diagnosis.candidates import _scaled_base
    from energy_planner.model import resolve_term
    from energy_planner.model.terms import Term

    def _f():  # walking backward at 0.3 m/s, facing uphill on 2 and 20 deg
        a = np.radians([2.0, 20.0])
        return {"vx": np.array([-0.3, -0.3]), "speed": np.array([0.3, 0.3]), "alpha": a,
                "gamma": np.zeros(2)}  # fmt: skip

    coef = {"bwd_const": 100.0, "bwd_down": -900.0}
    name, formula, _, _ = _scaled_base("load_kg", list(coef), coef)[0]
    assert name == "load_kg*P_base"
    base = sum(c * resolve_term(t).parsed.evaluate(_f()) for t, c in coef.items())
    got = Term(name, formula).parsed.evaluate({**_f(), "load_kg": np.array([10.0, 10.0])})
    # by hand: 10 kg times the base power where it is positive, 0 where it is not
    np.testing.assert_allclose(got, 10.0 * np.maximum(base, 0.0))
    assert base.min() < 0 < base.max()
