"""``fit``, ``diagnose`` and ``discover`` agree: one held-out evaluation, one data pipeline.

The held-out numbers of the three commands come from one function
(:func:`energy_planner.stats.heldout`) on one set of folds (:func:`fold_index`), and all
three start from raw logs through one pipeline (:func:`energy_planner.calibration.prepare_logs`).
The campaign is the mechanistic simulator's (its truth is physics, not the model's formulas),
reduced to a small one. The numbers are the same up to the rounding of window means summed
in another order (relative 1e-9).
"""

from __future__ import annotations

import functools
import json
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from energy_planner.calibration import fit_model
from energy_planner.diagnosis import diagnose, discover
from energy_planner.model import BASE_TERMS

REL = 1e-9


@functools.cache
def _campaign(faults: tuple[str, ...] = ()):
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        config = CampaignConfig.small(run_s=4.0, rate_hz=10.0)  # 4.6k samples, 92 runs
        return simulate_campaign(seed=0, faults=faults, config=config)


def _quiet(f, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args, **kwargs)


@pytest.mark.xdist_group("heldout_campaign")  # one worker simulates _campaign()
def test_fit_diagnose_discover_report_the_same_heldout_numbers():
    logs = _campaign().logs
    fit = _quiet(fit_model, logs, BASE_TERMS, n_splits=5, seed=0)
    terms = fit.model.term_names
    diag = _quiet(diagnose, fit.model, logs, max_steps=0)
    disc = _quiet(discover, logs, base_terms=terms, max_steps=0)
    rmse = fit.heldout.rmse_w
    assert diag.ranking.heldout_rmse_w == pytest.approx(rmse, rel=REL)
    assert disc.steps[0].heldout_rmse_w == pytest.approx(rmse, rel=REL)
    assert disc.fit.heldout.rmse_w == pytest.approx(rmse, rel=REL)
    # window by window: the same held-out prediction (same windows, same folds)
    pred_fit = fit.heldout.windows["predicted_w"].to_numpy()
    pred_diag = diag.data.power - diag.ranking.heldout_errors
    np.testing.assert_allclose(pred_diag, pred_fit, rtol=REL, atol=1e-9)
    # and the same data findings
    names = [f["name"] for f in fit.data_findings if f["finding"]]
    assert names == [f["name"] for f in diag.data_findings if f["finding"]]
    assert names == [f.name for f in disc.data_findings if f.finding]


def test_diagnose_repairs_a_clock_offset_like_discover():
    """Logs whose power lags the motion: ``acceleration`` is the clock, not physics."""
    logs = _campaign(("clock_offset",)).logs
    # the fits give the data findings and the model diagnose reads: their held-out folds
    # (n_splits) play no part in either, so none are run
    fit = _quiet(fit_model, logs, BASE_TERMS, n_splits=0)
    found = {f["name"]: f for f in fit.data_findings}
    assert found["clock_offset"]["finding"] and found["clock_offset"]["repaired"]
    diag = _quiet(diagnose, fit.model, logs, max_steps=0)
    clock = {f["name"]: f for f in diag.data_findings}["clock_offset"]
    assert clock["finding"] and clock["repaired"]
    assert "acceleration" not in {s.name for s in diag.suspects}
    # without the repair the lag reads as an effect of acceleration, as it did before
    raw = _quiet(fit_model, logs, BASE_TERMS, n_splits=0, repair=False)
    unrepaired = _quiet(diagnose, raw.model, logs, max_steps=0, repair=False)
    assert not {f["name"]: f for f in unrepaired.data_findings}["clock_offset"]["repaired"]
    assert "acceleration" in {s.name for s in unrepaired.suspects}
    # discover finds and repairs the same offset
    disc = _quiet(discover, logs, max_steps=0, fit_final=False)  # its findings: no final fit
    same = {f.name: f for f in disc.data_findings}["clock_offset"]
    assert same.repaired and same.summary == clock["summary"]


@pytest.mark.xdist_group("heldout_campaign")  # one worker simulates _campaign()
def test_cli_fit_diagnose_discover_agree(tmp_path):
    from energy_planner.cli import main

    logs, model = str(tmp_path / "logs.csv"), str(tmp_path / "m.json")
    _campaign().logs.to_csv(logs, index=False)  # one file: loading 92 is most of the time
    runner = CliRunner()

    def run(*args: str) -> dict:
        res = _quiet(runner.invoke, main, [*args, "--json"])
        assert res.exit_code == 0, res.output
        return json.loads(res.stdout)

    fit = run("fit", logs, "--out", model)
    diag = run("diagnose", logs, "--model", model, "--max-steps", "0")
    disc = run("discover", logs, "--out", str(tmp_path / "d.json"), "--max-steps", "0")
    rmse = fit["fit"]["heldout"]["power_rmse_w"]
    assert diag["heldout_rmse_w"] == pytest.approx(rmse, rel=REL)
    assert disc["staircase"][0]["heldout_rmse_w"] == pytest.approx(rmse, rel=REL)
    assert disc["final_fit"]["heldout_power_rmse_w"] == pytest.approx(rmse, rel=REL)
    # every command reports the same data checks; --no-repair is one option for all three
    checks = [f["name"] for f in fit["data_findings"]]
    assert checks == [f["name"] for f in diag["data_findings"]]
    assert checks == [f["name"] for f in disc["data_findings"]]
    assert [f["name"] for f in fit["fit"]["data_findings"]] == checks
    off = run("fit", logs, "--out", model, "--no-repair", "--folds", "0")
    assert not any(f["repaired"] for f in off["data_findings"])
