"""An effect the logs cannot decide: it passes its own test but the folds disagree on it.

A clean reduced campaign of the mechanistic simulator gets a ``payload_kg`` channel and
a standing power in proportion to it (battery current ``c * payload / voltage``): in the
first campaign one run carries 20 kg and the others 0-0.5 kg, so the effect lives in that
run (with 0-2 kg the light runs alone show it: the choice test, averaged over ten
partitions into folds, then confirms it, as it should); in the second every run carries
0-20 kg. The first ends with an ``undecided`` record
that names the loaded run, with its share of the gain computed here from two plain
least-squares fits per fold; the second adds the term and records nothing undecided.
"""

from __future__ import annotations

import functools
import json
import warnings
from html import escape

import numpy as np
import pytest
from click.testing import CliRunner

#: Standing power per kg of payload, W (the current is raised by this / voltage).
WATTS_PER_KG = 4.0
HEAVY_KG = 20.0
#: Largest payload of the other runs when one run is heavy, kg.
LIGHT_KG = 0.5


@functools.cache
def _payload_logs(seed: int, spread: bool):
    """The clean reduced campaign (seed 0) with a payload: one heavy run, or spread."""
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        logs = simulate_campaign(0, (), CampaignConfig.small()).logs
    chans = ["load_kg", "ground", "motor_temp", "air_temp_c", "grass_height_m"]
    logs = logs.drop(columns=[c for c in chans if c in logs.columns])  # fewer candidates
    rng = np.random.default_rng(seed)
    runs = sorted(logs["run"].unique())
    if spread:
        pay = dict(zip(runs, rng.uniform(0, HEAVY_KG, len(runs)), strict=True))
        heavy = None
    else:
        pay = dict(zip(runs, rng.uniform(0, LIGHT_KG, len(runs)), strict=True))
        heavy = runs[int(rng.integers(len(runs)))]
        pay[heavy] = HEAVY_KG
    logs["payload_kg"] = logs["run"].map(pay)
    logs["current"] = logs["current"] + WATTS_PER_KG * logs["payload_kg"] / logs["voltage"]
    return logs, heavy


@pytest.fixture(scope="module")
def undecided_case(tmp_path_factory):
    """``(logs folder, heavy run, discover on the logs as the command reads them)``."""
    from energy_planner.cli.fit import load_log_files
    from energy_planner.diagnosis.discover import discover

    logs, heavy = _payload_logs(0, False)
    folder = tmp_path_factory.mktemp("undecided") / "logs"
    folder.mkdir()
    logs.to_csv(folder / "campaign.csv", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = discover(load_log_files((folder,)), max_steps=1, progress=False)
    return folder, heavy, d


def _heldout(x: np.ndarray, y: np.ndarray, w: np.ndarray, folds: np.ndarray) -> np.ndarray:
    """Held-out errors of plain weighted least squares, one fit per fold (no package code)."""
    err = np.full(len(y), np.nan)
    sw = np.sqrt(w)
    for f in np.unique(folds):
        train, test = folds != f, folds == f
        b = np.linalg.lstsq(x[train] * sw[train, None], y[train] * sw[train], rcond=None)[0]
        err[test] = y[test] - x[test] @ b
    return err


@pytest.mark.xdist_group("undecided_case")
def test_one_heavy_run_is_undecided_and_named(undecided_case):
    _, heavy, d = undecided_case
    u = d.undecided
    assert d.added == [], d.added  # the staircase's rule is unchanged: nothing confirmed
    assert u is not None and "payload_kg" in u.variables, d.notes
    # it passes its own test by run, the choice by fold does not
    assert u.p_value < u.p_threshold and u.choice_p_value >= u.choice_p_threshold
    assert u.heldout_rmse_w < 0.95 * u.heldout_rmse_before_w
    assert u.n_folds_chose == sum(c == u.term for c in u.chosen) < len(u.chosen)
    # its gain by run, from two plain least-squares fits per fold on the same windows
    from energy_planner.stats import fold_index

    wd, last = d.data, d.rankings[-1]
    x0 = wd.columns(last.terms)
    x1 = np.column_stack([x0, wd.columns([u.term])])
    y, w = wd.power, wd.weights
    folds = fold_index(wd.runs, d.thresholds.n_splits, d.thresholds.seed)
    e0, e1 = _heldout(x0, y, w, folds), _heldout(x1, y, w, folds)
    ok = np.isfinite(e0) & np.isfinite(e1) & last.supported
    runs = wd.runs[ok]
    gain = {r: float(np.sum((e0[ok] ** 2 - e1[ok] ** 2)[runs == r])) for r in np.unique(runs)}
    total = sum(gain.values())
    order = sorted(gain, key=gain.get, reverse=True)
    assert u.top_runs[0]["run"] == order[0] == heavy
    assert u.top_share == pytest.approx(gain[heavy] / total, rel=1e-6)
    assert u.top_share > 0.5  # one run carries most of it
    assert u.top3_share == pytest.approx(sum(gain[r] for r in order[:3]) / total, rel=1e-6)
    assert [r["run"] for r in u.top_runs] == order[:3]
    assert u.n_runs == len(gain) and u.n_runs_better == sum(g > 0 for g in gain.values())
    assert np.sqrt(np.mean(e1[ok] ** 2)) == pytest.approx(u.heldout_rmse_w, rel=1e-6)
    # the heavy run's payload, and that no other run carries as much
    top = u.top_runs[0]
    assert top["values"]["payload_kg"] == pytest.approx(HEAVY_KG)
    assert top["runs_as_high"]["payload_kg"] == 1
    # the closing note says it, with the run and its share, and the report shows the note
    note = d.notes[-1]
    assert u.sentence() in note and heavy in note and f"{100 * u.top_share:.0f} %" in note
    assert "payload_kg 20 or more: 1 of" in note and f"fit --term {u.name}" in note
    from energy_planner.diagnosis.report import render_discovery_html

    assert escape(u.sentence()) in render_discovery_html(d.to_dict())


@pytest.mark.xdist_group("undecided_case")
def test_cli_json_is_to_dict(undecided_case, tmp_path):
    """``discover --json`` prints ``Discovery.to_dict()`` (and the model written)."""
    from energy_planner.cli import main
    from energy_planner.cli.discover import _text
    from energy_planner.cli.options import _jsonable

    folder, heavy, d = undecided_case
    out = tmp_path / "m.json"
    args = ["discover", str(folder), "--out", str(out), "--max-steps", "1", "--json"]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    want = json.loads(json.dumps(_jsonable({**d.to_dict(), "model": str(out)})))
    assert doc == want
    assert doc["undecided"]["top_runs"][0]["run"] == heavy
    assert d.undecided.sentence() in _text(doc)  # the printed text has the note


def test_spread_effect_is_added_not_undecided():
    from energy_planner.diagnosis.discover import discover

    logs, _ = _payload_logs(1, True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = discover(logs, max_steps=1, fit_final=False, progress=False)
    assert len(d.added) == 1 and "payload_kg" in d.added[0], d.added
    assert d.rankings[0].undecided is None and d.rankings[0].choice.passed
    assert d.to_dict()["undecided"] == (None if d.undecided is None else d.undecided.to_dict())


def test_diagnose_says_it_too():
    """``diagnose`` ranks the same way: a payload one run carries (synthetic windows, the
    base model's truth plus 3 W/kg standing power, run r07 at 20 kg, the others 0-2 kg) is
    undecided there too, in its record, its JSON and its note."""
    import sys
    from pathlib import Path

    from energy_planner.diagnosis import diagnose
    from energy_planner.model import EnergyModel

    sys.path.insert(0, str(Path(__file__).parent))
    from test_diagnosis_units import fitted_base, synth

    s = synth(n_runs=30, seed=3, noise=20.0).drop(columns=["temperature_c", "surface"])
    runs = sorted(s["run"].unique())
    pay = dict(zip(runs, np.random.default_rng(103).uniform(0, 2.0, len(runs)), strict=True))
    pay["r07"] = HEAVY_KG
    s["load_kg"] = s["run"].map(pay)
    s["power"] = s["power"] + 3.0 * EnergyModel(["load_kg"]).design_matrix(s)[:, 0]
    d = diagnose(fitted_base(s), s, max_steps=0)
    u = d.undecided
    assert not d.suspects and u is not None and u.top_runs[0]["run"] == "r07", d.notes
    assert u.top_share > 0.5 and u.sentence() in d.notes[-1]
    assert d.to_dict()["undecided"] == u.to_dict()
