"""The payoff of discovery: the discovered model's plan spends less TRUE energy.

End-to-end check of the whole chain on the mechanistic simulator (simulate -> discover
on the raw logs -> plan with the base and the discovered model, the ground given as a
raster with ``--channel ground=RASTER:TABLE`` -> charge both plans the simulator's
true physics along the path), on a reduced campaign hiding the ground effect, planned
across the bundled 10 deg plane.
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
def test_discovered_model_plans_a_truly_cheaper_route(tmp_path):
    from energy_planner.model import EnergyModel
    from energy_planner.simulate import CampaignConfig

    payoff = _load().run(
        "ground", config=CampaignConfig.small(repeats=2), scenario_name="plane", out_dir=tmp_path
    )
    assert payoff.channel_options[0].startswith("--channel ground=")
    assert payoff.heldout_rmse_discovered_w < 0.8 * payoff.heldout_rmse_base_w
    base, found = payoff.plans["base"], payoff.plans["discovered"]
    # the base model cannot see the ground: its prediction misses the truth by far more
    err_base = abs(base["predicted_energy_j"] - base["true_energy_j"]) / base["true_energy_j"]
    err_found = abs(found["predicted_energy_j"] - found["true_energy_j"]) / found["true_energy_j"]
    assert err_found < err_base
    # and the discovered model's route is cheaper in truth
    assert payoff.saving > 0.01, payoff.plans  # measured: 2.3 %
    assert any("ground" in EnergyModel([t]).variables for t in payoff.added_terms)
