"""``energy-planner fit`` and ``energy-planner figures`` through click's CliRunner."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.model import BASE_TERMS, CATALOG, EnergyModel
from energy_planner.simulate import CampaignConfig, Physics, simulate_campaign


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign")
    config = CampaignConfig.small(slopes_deg=(0.0, 20.0), arcs=False, stand=False)
    simulate_campaign(seed=3, config=config).write(out)
    return out


def test_fit_json(logs, tmp_path):
    out = tmp_path / "new" / "model.json"  # its folder is made (test_outputs_everywhere)
    r = CliRunner().invoke(
        main,
        [
            "fit",
            str(logs),
            "--out",
            str(out),
            "--term",
            "load_kg * speed",
            "--folds",
            "3",
            "--json",
        ],
    )
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert {"model", "load", "preprocessing", "windows", "fit"} <= set(doc)
    fit = doc["fit"]
    assert {"terms", "n_windows", "n_runs", "heldout", "warnings", "coverage"} <= set(fit)
    names = [t["name"] for t in fit["terms"]]
    assert names == [*BASE_TERMS, "load_kg * speed"] and fit["unidentified"] == []
    assert all(t["stderr"] > 0 and t["status"] == "fitted" for t in fit["terms"])
    assert fit["heldout"]["n_splits"] == 3
    assert fit["heldout"]["energy_mean_abs_rel_error"] < 0.05
    # every run is held out exactly once
    runs = [r["run"] for r in fit["heldout"]["runs"]]
    assert len(runs) == len(set(runs)) == fit["n_runs"]
    model = EnergyModel.load(out)
    assert model.term_names == names
    # level walking near the simulator's truth (slip makes the logs show ~2 % more)
    for vx, vy in ((0.3, 0.0), (-0.3, 0.0), (0.0, 0.3)):
        f = {"alpha": 0.0, "gamma": 0.0, "vx": vx, "vy": vy, "wz": 0.0, "load_kg": 0.0}
        assert model.power(f)[0] == pytest.approx(Physics().expected_power(f)[0], rel=0.1)


def test_fit_text_output(logs, tmp_path):
    out = tmp_path / "m.json"
    # the layout of the printed report, not the numbers (test_fit_json checks those): the
    # data repairs' held-out checks (60 % of a fit's time) are spared
    args = ["fit", str(logs), "--out", str(out), "--term", "load_kg * speed", "--no-repair"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    assert "discard_low_speed" in r.output  # the preprocessing report
    assert "std err" in r.output and "load_kg * speed" in r.output
    assert "held-out by run" in r.output and "held-out run energies" in r.output
    assert out.is_file()


def test_fit_bad_term(logs, tmp_path):
    r = CliRunner().invoke(
        main, ["fit", str(logs), "--out", str(tmp_path / "m.json"), "--term", "speeed * sin(alpha)"]
    )
    assert r.exit_code == 2
    assert "speeed" in r.output and "idle_power" in r.output  # names it, lists the catalog
    assert not (tmp_path / "m.json").exists()
    r = CliRunner().invoke(  # a term without a space is checked on the windows (a short
        # name discover printed): --no-repair spares the repairs' held-out checks
        main,
        ["fit", str(logs), "--out", str(tmp_path / "m.json"), "--term", "__import__('os')",
         "--no-repair"],
    )  # fmt: skip
    assert r.exit_code == 2 and "unknown function '__import__'" in r.output
    assert all(name in r.output for name in CATALOG)


def test_fit_too_little_data(logs, tmp_path):
    one = sorted(logs.glob("straight_forward_*.csv"))[:1]
    r = CliRunner().invoke(main, ["fit", str(one[0]), "--out", str(tmp_path / "m.json")])
    assert r.exit_code == 1
    assert "from 1 run(s)" in r.output and "from at least 2 runs" in r.output


def test_fit_unknown_channel(logs, tmp_path):
    r = CliRunner().invoke(  # the channels are checked on the windows (no repair needed)
        main,
        ["fit", str(logs), "--out", str(tmp_path / "m.json"), "--term", "mass_kg * speed",
         "--no-repair"],
    )  # fmt: skip
    assert r.exit_code == 2
    assert "'mass_kg'" in r.output and "load_kg" in r.output  # lists the log channels


def test_fit_missing_path(tmp_path):
    r = CliRunner().invoke(main, ["fit", str(tmp_path / "nope"), "--out", str(tmp_path / "m")])
    assert r.exit_code == 2 and "nope" in r.output


def test_figures_json(logs, tmp_path):
    out = tmp_path / "new" / "figs"  # its folder is made (test_outputs_everywhere)
    r = CliRunner().invoke(main, ["figures", str(logs), "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    figs = doc["figures"]
    assert set(figs) == {"force_slope", "yaw_torque", "superposition"}
    for f in figs.values():
        p = out / f["path"].split("/")[-1]
        assert p.is_file() and p.stat().st_size > 10_000
    assert (
        figs["force_slope"]["uphill_forward_median_n"]
        > figs["force_slope"]["downhill_forward_median_n"]
    )
    # A then B as one run against the two parts: the physics adds up to the speed ramps
    # at the parts' ends (1 s of each 1-2 m leg of the small campaign)
    assert figs["superposition"]["mean_abs_rel_ab"] < 0.1
    assert doc["model"] == "base model fitted to the logs"


def test_figures_with_model_and_no_composites(logs, tmp_path):
    files = sorted(p for p in logs.glob("*.csv") if p.name != "runs.csv")
    files = [p for p in files if not p.name.startswith("sup")]
    model = tmp_path / "m.json"
    EnergyModel.default().save(model)
    r = CliRunner().invoke(
        main, ["figures", *map(str, files), "--out", str(tmp_path / "f"), "--model", str(model)]
    )
    assert r.exit_code == 0, r.output
    assert "force_slope.png" in r.output and "yaw_torque.png" in r.output
    # runs.csv is found next to the files, but none of its composites was loaded
    assert "superposition.png not drawn" in r.output


def test_fit_reports_unidentified_terms_and_holds_them_at_a_prior(logs, tmp_path):
    """No backward runs: JSON and text name the backward terms as not identified; with
    --prior default they are held at the bundled model's values instead."""
    files = [
        p for p in sorted(logs.glob("*.csv")) if "backward" not in p.name and p.name != "runs.csv"
    ]
    r = CliRunner().invoke(
        main, ["fit", *map(str, files), "--out", str(tmp_path / "a.json"), "--json"]
    )
    assert r.exit_code == 0, r.output
    fit = json.loads(r.stdout)["fit"]
    bwd = ["bwd_const", "bwd_up", "bwd_down", "bwd_brake_sq"]
    assert [u["name"] for u in fit["unidentified"]] == bwd
    assert not set(bwd) & {t["name"] for t in fit["terms"]}
    # the text and --prior runs name and hold the same terms: which terms the runs identify
    # does not depend on the data repairs or the held-out folds, which they spare (a fit
    # without them costs a third)
    quick = ["--no-repair", "--folds", "0"]
    r = CliRunner().invoke(
        main, ["fit", *map(str, files), "--out", str(tmp_path / "b.json"), *quick]
    )
    assert "not identified by this campaign" in r.output and "bwd_brake_sq" in r.output
    r = CliRunner().invoke(
        main,
        [
            "fit",
            *map(str, files),
            "--out",
            str(tmp_path / "c.json"),
            "--prior",
            "default",
            "--json",
            *quick,
        ],
    )
    assert r.exit_code == 0, r.output
    fit = json.loads(r.stdout)["fit"]
    prior = EnergyModel.default().coefficients
    held = {t["name"]: t for t in fit["terms"] if t["status"] == "prior"}
    assert sorted(held) == sorted(bwd) and fit["unidentified"] == []
    assert all(held[n]["coefficient"] == prior[n] for n in bwd)
    r = CliRunner().invoke(
        main, ["fit", str(logs), "--out", str(tmp_path / "d.json"), "--prior", "nope.json"]
    )
    assert r.exit_code == 2 and "--prior" in r.output
