"""One rule for every output of every command: its folder is created if missing.

Each command runs once with every output option it has pointed into folders that do not
exist yet (small maps and a small campaign keep it fast); a second test reads every
command's options so that an output option added later without a case here fails.
Also: an output that is a folder, an unwritable folder and a file where a folder should
be give one clear line (no traceback) and keep what was there.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import click
import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin

from energy_planner.cli import main

X0, Y0, RES, N = 500000.0, 5000060.0, 2.0, 30
START, GOAL = "500010,5000010", "500040,5000050"


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """A 60 m hill and sites on it."""
    d = tmp_path_factory.mktemp("outputs")
    yy, xx = np.mgrid[0:N, 0:N]
    z = (4.0 * np.exp(-((xx - 15.0) ** 2 + (yy - 15.0) ** 2) / 80.0)).astype("float32")
    dem = d / "dem.tif"
    prof = dict(driver="GTiff", height=N, width=N, count=1, dtype="float32", crs="EPSG:32631")
    with rasterio.open(dem, "w", transform=from_origin(X0, Y0, RES, RES), **prof) as dst:
        dst.write(z, 1)
    sites = d / "sites.csv"
    sites.write_text("x,y\n500010,5000010\n500040,5000050\n500012,5000045\n")
    return {"dem": str(dem), "sites": str(sites)}


#: Every command that writes, with every output option it has (the value a path under
#: a folder that does not exist) and the other arguments it needs.
CASES: dict[str, tuple[list[str], dict[str, str]]] = {
    "terrain": (
        ["{dem}"],
        {"--slope-out": "slope.tif", "--aspect-out": "aspect.tif", "--plot": "slope.png"},
    ),
    "plan": (
        ["--dem", "{dem}", "--start", START, "--goal", GOAL],
        {"--out": "path.geojson", "--plot": "path.png"},
    ),
    "compare-routes": (
        ["--dem", "{dem}", "--start", START, "--goal", GOAL, "--time", "0.2"],
        {"--plot": "routes.png"},
    ),
    "energy-map": (["{dem}", "--headings", "4"], {"--out": "map.tif", "--plot": "map.png"}),
    "reach": (
        # b1_speeds records its calibration domain (--domain-out needs one)
        [
            "{dem}",
            "--start",
            START,
            "--budget-wh",
            "1",
            "--battery-wh",
            "2",
            "--model",
            "b1_speeds",
        ],
        {
            "--out": "reach.tif",
            "--chance-out": "chance.tif",
            "--domain-out": "domain.tif",
            "--geojson": "reach.geojson",
            "--plot": "reach.png",
        },
    ),
    "mission": (
        ["--dem", "{dem}", "--sites", "{sites}"],
        {"--geojson": "tour.geojson", "--plot": "tour.png"},
    ),
    "simulate": (["--small", "--seed", "2"], {"--out": "campaign/", "--plot": "fig4.png"}),
}

#: The commands whose runs take many seconds of fitting: their outputs are pointed into
#: folders that do not exist yet by the tests that run them anyway (no extra run here).
ELSEWHERE: dict[str, tuple[str, list[str]]] = {
    "demo": (
        "test_cli_demo.py::test_demo_shows_fig1_a_longer_route_that_costs_less_with_no_limit",
        ["--plot"],
    ),
    "fit": ("test_cli_fit.py::test_fit_json", ["--out"]),
    "figures": ("test_cli_fit.py::test_figures_json", ["--out"]),
    "diagnose": ("test_diagnosis_units.py::test_cli_json_and_report", ["--report"]),
    "discover": ("test_discover.py::test_cli_discover", ["--out", "--report"]),
}

#: Options that name a file or folder the command writes.
OUTPUT_NAMES = ("out", "plot", "report", "geojson")


def _is_output(param: click.Parameter) -> bool:
    name = param.name or ""
    return isinstance(param.type, click.Path) and (
        name in OUTPUT_NAMES or (name.endswith("_out") and name != "keep_out")
    )


def test_every_output_option_of_every_command_has_a_case():
    ctx = click.Context(main)
    found = {}
    for name in main.list_commands(ctx):
        cmd = main.get_command(ctx, name)
        opts = sorted(max(p.opts, key=len) for p in cmd.params if _is_output(p))
        if opts:
            found[name] = opts
    expected = {c: sorted(o) for c, (_, o) in CASES.items()}
    expected.update({c: sorted(o) for c, (_, o) in ELSEWHERE.items()})
    assert found == expected
    here = Path(__file__).parent
    for where, _ in ELSEWHERE.values():  # those tests exist and write into a new folder
        file, test = where.split("::")
        text = (here / file).read_text()
        body = text[text.index(f"def {test}(") :]
        body = body[: body.find("\ndef ", 1)]
        assert '/ "new' in body, f"{where} does not write into a folder it must make"


@pytest.mark.parametrize("command", list(CASES))
def test_every_output_goes_into_a_folder_made_for_it(command, data, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # demo's default plot, if any, lands here
    args, outputs = CASES[command]
    args = [a.format(**data) for a in args]
    written = []
    for i, (opt, name) in enumerate(outputs.items()):
        path = tmp_path / f"new{i}" / "deeper" / name.rstrip("/")
        args += [opt, str(path)]
        written.append(path)
    r = CliRunner().invoke(main, [command, *args])
    assert r.exit_code == 0, r.output
    for path in written:
        assert path.exists(), f"{command}: {path} not written"
        if path.is_dir():
            assert any(path.iterdir())
        else:
            assert path.stat().st_size > 0
        # no temporary file left beside it
        assert [p.name for p in path.parent.iterdir()] == [path.name]


# ------------------------------------------------------------------------ refusals


def _plan(data, out):
    return CliRunner().invoke(
        main, ["plan", "--dem", data["dem"], "--start", START, "--goal", GOAL, "--out", str(out)]
    )


def test_an_output_that_is_a_folder_is_one_clear_line(data, tmp_path):
    out = tmp_path / "taken"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    r = _plan(data, out)
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "is a directory" in r.output and str(out) in r.output
    assert (out / "keep.txt").read_text() == "mine"


def test_a_file_where_a_folder_should_be_is_named(data, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    r = _plan(data, blocker / "path.geojson")
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert f"{str(blocker)!r} is a file, not a folder" in r.output
    assert blocker.read_text() == "not a folder"


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_an_unwritable_output_folder_is_one_clear_line_and_keeps_the_file(data, tmp_path):
    from faults import read_only_dir  # tests/ helper

    with read_only_dir(tmp_path / "ro", {"path.geojson": b"the previous path"}) as ro:
        r = _plan(data, ro / "path.geojson")
        assert r.exit_code != 0 and "Traceback" not in r.output, r.output
        assert "cannot write" in r.output and "the previous file is kept" in r.output
        assert (ro / "path.geojson").read_bytes() == b"the previous path"
        assert sorted(p.name for p in ro.iterdir()) == ["path.geojson"]


def test_simulate_into_a_campaign_refuses_then_overwrite_replaces_it_whole(tmp_path):
    out = tmp_path / "campaign"
    r1 = CliRunner().invoke(main, ["simulate", "--out", str(out), "--small", "--seed", "1"])
    assert r1.exit_code == 0, r1.output
    (out / "old_run.csv").write_text("a log of an older campaign")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    r2 = CliRunner().invoke(main, ["simulate", "--out", str(out), "--small", "--seed", "2"])
    assert r2.exit_code == 1 and "is not empty" in r2.output and "--overwrite" in r2.output
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    r3 = CliRunner().invoke(
        main, ["simulate", "--out", str(out), "--small", "--seed", "2", "--overwrite", "--json"]
    )
    assert r3.exit_code == 0, r3.output
    names = {p.name for p in out.iterdir()}
    assert "old_run.csv" not in names  # nothing of the old campaign is left
    assert json.loads((out / "campaign.json").read_text())["seed"] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["campaign"]  # no temp folder
    assert (
        len([n for n in names if n.endswith(".csv")]) == json.loads(r3.stdout)["files"]["logs"] + 1
    )  # runs.csv


def test_library_writer_refuses_a_non_empty_folder(tmp_path):
    from energy_planner.errors import OutputError
    from energy_planner.io import atomic_dir

    (tmp_path / "a.txt").write_text("x")
    with pytest.raises(OutputError, match="is not empty"):
        with atomic_dir(tmp_path):
            pass
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_an_energy_map_of_a_lonlat_dem_into_a_missing_folder_leaves_no_scratch(tmp_path):
    """A lon/lat DEM's map is computed in a scratch file beside --out, then resampled."""
    yy, xx = np.mgrid[0:N, 0:N]
    z = (3.0 * np.exp(-((xx - 15.0) ** 2 + (yy - 15.0) ** 2) / 60.0)).astype("float32")
    dem = tmp_path / "lonlat.tif"
    prof = dict(driver="GTiff", height=N, width=N, count=1, dtype="float32", crs="EPSG:4326")
    with rasterio.open(dem, "w", transform=from_origin(3.0, 45.0, 2e-5, 2e-5), **prof) as dst:
        dst.write(z, 1)
    out = tmp_path / "new" / "map.tif"
    r = CliRunner().invoke(main, ["energy-map", str(dem), "--out", str(out), "--headings", "4"])
    assert r.exit_code == 0, r.output
    assert [p.name for p in out.parent.iterdir()] == ["map.tif"]
