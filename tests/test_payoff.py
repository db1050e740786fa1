"""The payoff of diagnosis: the corrected model's plan spends less TRUE energy.

This is the end-to-end check of the whole chain (simulate -> preprocess -> windows ->
fit base -> diagnose -> refit with the suggested term -> plan with both -> charge both
plans the simulator's true energy), on a small campaign with slope loading hidden.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "payoff_corrected_model.py"


def _load():
    spec = importlib.util.spec_from_file_location("payoff_corrected_model", BENCH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_corrected_model_plans_a_truly_cheaper_route():
    from energy_planner.simulate import CampaignConfig

    payoff = _load().run("joule_heating", config=CampaignConfig.small(repeats=2))
    assert payoff.suspect == "joule_heating"
    assert payoff.heldout_rmse_corrected_w < 0.5 * payoff.heldout_rmse_base_w
    base, corrected = payoff.plans["base"], payoff.plans["corrected"]
    # the routes differ and the corrected one is cheaper in truth, by a margin well above
    # the lattice's resolution effects
    assert corrected["distance_m"] != pytest.approx(base["distance_m"], abs=1.0)
    assert payoff.saving > 0.03
