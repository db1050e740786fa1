"""Acceptance test of the diagnosis on the mechanistic simulator.

The simulator's truth is physics (gravity work through an efficiency, copper losses of
the leg forces, swing losses, gait ripple...), not the model's formulas; each channel
effect changes that physics (a carried mass, a resisting ground, the winding resistance
following the motor temperature, grease stiffening in the cold, grass dragging on the
legs). The base model is fitted, and the diagnosis must name a term reading the hidden
effect's channel first, and that term must cut the held-out error. A campaign with no
hidden effect gives no suspect above noise.

The sensors keep white noise (battery current and voltage, spikes, IMU orientation noise)
and a constant odometry slip, but no slip growing with slope, IMU tilt bias or twist
noise: those corrupt the measured *features*, which ``diagnose`` (working on windows, not
on raw logs) cannot repair; ``discover`` checks and repairs them first (see
tests/test_discover.py).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

from energy_planner.calibration import fit_model
from energy_planner.diagnosis import diagnose
from energy_planner.measurements import make_windows, preprocess
from energy_planner.model import BASE_TERMS, EnergyModel
from energy_planner.simulate import EFFECTS, CampaignConfig, SensorConfig, simulate_campaign

WHITE_NOISE = SensorConfig(slip_per_sin_slope=0.0, slip_std=0.0, twist_noise_v=0.0,
                           twist_noise_w=0.0, imu_bias_deg=0.0)  # fmt: skip
CHANNEL_EFFECTS = [name for name, e in EFFECTS.items() if e.channel]


def test_channel_effects_are_covered():
    """The parametrization covers every channel effect of the simulator (>= 3)."""
    assert len(CHANNEL_EFFECTS) >= 3
    assert {"load", "ground", "motor_temp"} <= set(CHANNEL_EFFECTS)


@functools.cache
def _campaign(effect: str | None, seed: int = 0):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(
            seed=seed,
            effects=() if effect is None else (effect,),
            config=CampaignConfig.small(sensors=WHITE_NOISE),
        )
        windows = make_windows(preprocess(camp.logs)[0], duration=2.0)
        base = fit_model(windows, BASE_TERMS, n_splits=0).model
    return camp, windows, base


@functools.cache
def _clean_diagnosis():
    """The diagnosis of the campaign with no hidden effect (with its runs' table, one step
    allowed): computed once for the three tests of the ``diagnosis_clean`` xdist group."""
    camp, windows, base = _campaign(None)
    return diagnose(base, windows, runs_meta=camp.runs, max_steps=1)


@pytest.mark.parametrize("effect", CHANNEL_EFFECTS)
def test_diagnosis_names_the_hidden_channel(effect):
    camp, windows, base = _campaign(effect)
    d = diagnose(base, windows, runs_meta=camp.runs, max_steps=0).to_dict()
    assert d["suspects"], f"nothing above noise for {effect}: {d['below_noise'][:3]}"
    top = d["suspects"][0]
    channel = EFFECTS[effect].channel
    assert channel in top["variables"], f"{effect}: top suspect {top['name']}"
    # the suggested term is accepted as is by the model and cuts the held-out error
    assert top["term"] in EnergyModel([*BASE_TERMS, top["term"]]).term_names
    assert top["heldout_rmse_w"] <= 0.8 * d["heldout_rmse_w"]
    assert top["p_value"] < top["p_threshold"]


@pytest.mark.xdist_group("diagnosis_clean")
def test_no_hidden_effect_no_suspect():
    d = _clean_diagnosis().to_dict()
    assert d["suspects"] == [], d["suspects"]
    assert len(d["staircase"]) == 1
    # candidates were scored, not skipped: each is below noise
    assert d["n_tested"] >= 100 and len(d["below_noise"]) >= 5
    assert all(not s["above_noise"] for s in d["below_noise"])
    # the closing note is worded by the noise floor the logs show, as discover words it
    (note,) = [n for n in d["notes"] if n.startswith("no candidate effect is above noise")]
    assert "noise floor" in note and "as well as the data can tell" not in note


@pytest.mark.xdist_group("diagnosis_clean")
def test_speed_terms_unsupported_at_single_speed():
    d = _clean_diagnosis().to_dict()  # nothing added (test_no_hidden_effect_no_suspect)
    names = {u["name"]: u["reason"] for u in d["unsupported"]}
    assert "one walking speed" in names["speed_dependence"]
    assert all(s["name"] != "speed_dependence" for s in d["suspects"] + d["below_noise"])


@pytest.mark.xdist_group("diagnosis_clean")
def test_superposition_and_run_energies():
    """Measured E(AB) vs E(A) + E(B) on the composite runs, and per-run energies (of the
    base model: the clean campaign's diagnosis adds no term)."""
    camp = _campaign(None)[0]
    d = _clean_diagnosis()
    assert len(d.to_dict()["staircase"]) == 1  # the base model alone
    doc = d.to_dict()
    concat = [s for s in doc["superposition"] if s["kind"] == "concatenation"]
    assert concat, "the campaign has composite runs"
    truth = camp.runs.set_index("run")["true_energy_j"]
    for s in concat:
        # the physics is additive up to the ramps between the legs (one stop and start
        # fewer in AB): the measured superposition error is the true one
        true_rel = truth[s["composite"]] / sum(truth[p] for p in s["parts"]) - 1
        assert s["superposition_error_rel"] == pytest.approx(true_rel, abs=0.03)
    runs = {r["run"]: r for r in doc["runs"]}
    for s in concat:
        assert s["measured_parts_j"] == pytest.approx(
            sum(runs[p]["measured_j"] for p in s["parts"])
        )
    rel = np.abs(d.runs["error_rel"].to_numpy(float))
    assert np.median(rel) < 0.03
