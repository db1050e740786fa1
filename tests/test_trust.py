"""Issue 20 point 2: no arbitrary coefficients, no free lunch.

Mission logs where the robot always faces along its path (no sideways, no backward
walking) and carries a hidden payload (``simulate_missions``, reduced: 3 missions x 120 s).
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.calibration import fit_model
from energy_planner.calibration.fit import identifiable
from energy_planner.diagnosis.candidates import default_candidates
from energy_planner.diagnosis.data import window_data
from energy_planner.diagnosis.names import model_term
from energy_planner.measurements import make_windows, preprocess
from energy_planner.model import BASE_TERMS, resolve_term
from energy_planner.simulate import MissionConfig, simulate_missions


@pytest.fixture(scope="module")
def forward_missions():
    """Windows of short mission logs that never walk sideways or backward, with a payload."""
    cfg = MissionConfig(missions=3, duration_s=120.0, sideways_prob=0.0, backward_prob=0.0)
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
