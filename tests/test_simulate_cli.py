"""The ``energy-planner simulate`` command, through click's CliRunner."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from energy_planner.cli import main

HILL = str(Path(__file__).resolve().parents[1] / "maps" / "hill.tif")


def _run(*args: str):
    return CliRunner().invoke(main, ["simulate", *args], catch_exceptions=False)


def test_simulate_writes_readable_files_and_json(tmp_path):
    from energy_planner.measurements import load_logs

    res = _run(
        "--out",
        str(tmp_path),
        "--small",
        "--seed",
        "4",
        "--effect",
        "load",
        "--effect",
        "cold_joints",
        "--fault",
        "ros_current_sign",
        "--json",
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["summary"]["effects"] == ["load", "cold_joints"]
    assert doc["summary"]["faults"] == ["ros_current_sign"]
    assert [e["channel"] for e in doc["effects"]] == ["load_kg", "air_temp_c"]
    runs = pd.read_csv(tmp_path / "runs.csv", keep_default_na=False)
    assert doc["summary"]["runs"] == len(runs) == doc["files"]["logs"]
    physics = json.loads((tmp_path / "physics.json").read_text())
    assert physics["effects"] == ["load", "cold_joints"]
    assert doc["robot"]["mass_kg"] == 50.0
    logs = load_logs([tmp_path / f"{r}.csv" for r in runs["run"][:5]])
    assert set(logs["run"]) == set(runs["run"][:5])
    assert logs["load_kg"].nunique() >= 1
    meta = json.loads((tmp_path / "campaign.json").read_text())
    assert meta["seed"] == 4 and meta["effects"] == ["load", "cold_joints"]
    assert meta["faults"] == ["ros_current_sign"]


def test_simulate_missions_over_a_dem(tmp_path):
    res = _run(
        "--out",
        str(tmp_path),
        "--small",
        "--missions",
        "2",
        "--dem",
        HILL,
        "--effect",
        "ground",
        "--json",
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["missions"] and doc["summary"]["kinds"] == {"mission": 2}
    runs = pd.read_csv(tmp_path / "runs.csv", keep_default_na=False)
    assert list(runs["kind"]) == ["mission", "mission"]
    df = pd.read_csv(tmp_path / f"{runs['run'][0]}.csv")
    assert df["t"].is_monotonic_increasing and df["ground"].notna().all()
    # the ground map the missions walked on, for --channel ground=ground.tif:ground.csv
    assert (tmp_path / "ground.tif").exists()
    table = pd.read_csv(tmp_path / "ground.csv")
    assert set(df["ground"]) <= set(table["ground"])


def test_dem_without_missions_is_rejected(tmp_path):
    res = CliRunner().invoke(main, ["simulate", "--out", str(tmp_path), "--dem", HILL])
    assert res.exit_code == 2 and "--missions" in res.output
    res = CliRunner().invoke(
        main,
        ["simulate", "--out", str(tmp_path), "--missions", "1", "--plot", str(tmp_path / "p.png")],
    )
    assert res.exit_code == 2 and "Fig. 4" in res.output


def test_noise_free_parquet_energies_match_truth(tmp_path):
    res = _run(
        "--out",
        str(tmp_path),
        "--small",
        "--noise-free",
        "--format",
        "parquet",
        "--speeds",
        "0.2,0.45",
        "--plot",
        str(tmp_path / "cost.png"),
    )
    assert res.exit_code == 0, res.output
    assert (tmp_path / "cost.png").read_bytes()[:4] == b"\x89PNG"
    assert "mechanistic physics" in res.output
    runs = pd.read_csv(tmp_path / "runs.csv", keep_default_na=False).set_index("run")
    assert set(runs.loc[runs["kind"] == "straight", "speed"]) == {0.2, 0.45}
    for run in runs.index[:20]:
        df = pd.read_parquet(tmp_path / f"{run}.parquet")
        p, t = (df["voltage"] * df["current"]).to_numpy(), df["t"].to_numpy()
        energy = float(np.sum((p[1:] + p[:-1]) * np.diff(t) / 2))
        assert energy == pytest.approx(runs.loc[run, "true_energy_j"], rel=1e-9, abs=1e-9)


def test_unknown_effect_lists_the_valid_ones(tmp_path):
    res = CliRunner().invoke(main, ["simulate", "--out", str(tmp_path), "--effect", "gremlins"])
    assert res.exit_code == 2
    assert "unknown effect 'gremlins'" in res.output
    assert "vegetation" in res.output and "idle_power" in res.output
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("speeds", ["0.2,fast", "0", "-0.3", ","])
def test_bad_speeds_are_rejected(tmp_path, speeds):
    res = CliRunner().invoke(main, ["simulate", "--out", str(tmp_path), "--speeds", speeds])
    assert res.exit_code == 2
    assert "--speeds" in res.output and "0.2,0.3,0.45" in res.output


def test_unwritable_output_is_a_click_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    res = CliRunner().invoke(main, ["simulate", "--out", str(blocker / "sub"), "--small"])
    assert res.exit_code == 2  # a path that cannot be: a usage error (cli.exit_status_error)
    assert "cannot create the folder of" in res.output and "is a file" in res.output
    assert "hint" in res.output
