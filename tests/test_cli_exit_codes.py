"""#19 point 5: one rule for exit codes, held by a table of bad inputs run through the CLI.

2 (usage): the command line is wrong, including a file it names that does not exist and a
channel value the model cannot take. 1 (data): a file that is there but whose content is
wrong. The rule lives in ``energy_planner.cli.exit_status_error``; no case prints a
traceback, and each message names the file or the option at fault.
"""

from __future__ import annotations

import pytest
from b1_model import B1, b1_model  # tests/ helper
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.maps import map_path

HILL = str(map_path("hill"))
S, G = ["--start", "500058,5000046"], ["--goal", "500058,5000084"]


@pytest.fixture(scope="module")
def bad(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    files = {
        "garbage.tif": "not a raster",
        "bad.json": "{not json",
        "terms.json": '{"terms": []}',
        "ko.geojson": '{"type": "Point"}',
        "wp.csv": "x,y\n1,2,3\nfoo\n",
        "log.csv": "a,b\n1,2\n",
        "table.csv": "code,ground\nx,mud\n",
        "sites.csv": "name,x,y\nA,1\n",
        "w.csv": "x,y\n500058,5000046\n500058,5000084\n",
    }
    for name, text in files.items():
        (d / name).write_text(text)
    base = dict.fromkeys(B1, 0.0) | {"fwd_const": 600.0}
    b1_model(base, extra={"speed * (ground == 'mud')": 250.0}).save(d / "mud.json")
    b1_model(base, extra={"load_kg * speed": 7.0}).save(d / "load.json")
    return d


def _cases(d):
    w = ["--waypoints", str(d / "w.csv")]
    energy = ["energy", "--dem", HILL, *w]
    mud = [*energy, "--model", str(d / "mud.json")]
    load = [*energy, "--model", str(d / "load.json")]
    nope = str(d / "nope")
    return [
        # (args, exit code, words the message must have)
        (["terrain", nope + ".tif"], 2, ["nope.tif", "does not exist"]),
        (["terrain", str(d / "garbage.tif")], 1, ["garbage.tif", "raster"]),
        (["energy", "--dem", nope + ".tif", *w], 2, ["--dem", "does not exist"]),
        (["energy", "--dem", str(d / "garbage.tif"), *w], 1, ["--dem", "garbage.tif"]),
        (["energy", "--dem", HILL, "--waypoints", nope + ".csv"], 2, ["--waypoints", "nope.csv"]),
        (["energy", "--dem", HILL, "--waypoints", str(d / "wp.csv")], 1, ["wp.csv", "line 3"]),
        ([*energy, "--model", nope + ".json"], 2, ["--model", "does not exist"]),
        ([*energy, "--model", str(d / "bad.json")], 1, ["--model", "bad.json", "JSON"]),
        ([*energy, "--model", str(d / "terms.json")], 1, ["terms.json", "not an energy_planner"]),
        ([*mud, "--channel", f"ground={nope}.tif"], 2, ["--channel", "nope.tif"]),
        ([*mud, "--channel", f"ground={d / 'garbage.tif'}:{d / 'table.csv'}"], 1,
         ["table.csv", "line 2"]),
        ([*mud, "--channel", f"ground={HILL}:{nope}.csv"], 2, ["--channel", "nope.csv"]),
        ([*mud, "--channel", f"ground={d / 'garbage.tif'}"], 2, ["RASTER:TABLE"]),
        ([*mud, "--set", "ground=Mud"], 2, ["'Mud'", "'mud'"]),
        ([*load, "--set", "load_kg=10kg"], 2, ["'load_kg'", "a number"]),
        (load, 2, ["load_kg", "--set NAME=VALUE"]),  # a channel the model needs
        ([*energy, "--set", "speed=2"], 2, ["--set", "motion feature"]),
        (["energy-map", nope + ".tif", "--out", str(d / "o.tif")], 2, ["nope.tif"]),
        (["energy-map", str(d / "garbage.tif"), "--out", str(d / "o.tif")], 1, ["garbage.tif"]),
        (["plan", "--dem", HILL, *S, *G, "--keep-out", nope + ".geojson"], 2, ["--keep-out"]),
        (["plan", "--dem", HILL, *S, *G, "--keep-out", str(d / "ko.geojson")], 1,
         ["--keep-out", "ko.geojson"]),
        (["plan", "--dem", HILL, *S, *G, "--model", str(d / "bad.json")], 1, ["bad.json"]),
        (["plan", "--dem", HILL, *S, "--goal", "500058,6000000"], 2, ["--goal", "outside"]),
        (["compare-routes", "--dem", str(d / "garbage.tif"), *S, *G], 1, ["garbage.tif"]),
        (["reach", str(d / "garbage.tif"), *S], 1, ["garbage.tif"]),
        (["mission", "--dem", HILL, "--sites", nope + ".csv"], 2, ["--sites", "nope.csv"]),
        (["mission", "--dem", HILL, "--sites", str(d / "sites.csv")], 1, ["sites.csv"]),
        (["fit", nope, "--out", str(d / "o.json")], 2, ["LOGS", "does not exist"]),
        (["fit", str(d / "log.csv"), "--out", str(d / "o.json")], 1, ["log.csv", "columns"]),
        (["discover", str(d / "log.csv"), "--out", str(d / "o.json")], 1, ["log.csv"]),
        (["diagnose", str(d / "log.csv"), "--model", str(d / "bad.json")], 1, ["bad.json"]),
        (["demo", "--model", str(d / "bad.json")], 1, ["--model", "bad.json"]),
        (["simulate", "--out", str(d / "s"), "--missions", "1", "--dem", nope + ".tif"], 2,
         ["--dem", "nope.tif"]),
        (["simulate", "--out", str(d / "s"), "--missions", "1", "--dem",
          str(d / "garbage.tif")], 1, ["garbage.tif"]),
    ]  # fmt: skip


def test_bad_inputs_exit_by_the_rule(bad):
    wrong = []
    for args, code, words in _cases(bad):
        r = CliRunner().invoke(main, args)
        text = " ".join(r.output.split())
        ok = (
            r.exit_code == code
            and all(w in text for w in words)
            and "Traceback" not in r.output
            and isinstance(r.exception, SystemExit | None)
        )
        if not ok:
            wrong.append((args[:1] + [a.rsplit("/", 1)[-1] for a in args[1:]], r.exit_code,
                          code, text[-300:]))  # fmt: skip
    assert not wrong, "\n".join(map(str, wrong))


def test_a_library_error_no_command_caught_is_a_data_error_without_traceback(monkeypatch):
    """The safety net: an EnergyPlannerError escaping a command exits 1 with its message."""
    import energy_planner.cli.terrain as terrain_cli
    from energy_planner.errors import FitError

    def boom(*args, **kwargs):
        raise FitError("the fit cannot be made: 2 runs for 17 terms", path="logs/")

    monkeypatch.setattr(terrain_cli, "load_dem", boom, raising=False)
    monkeypatch.setattr("energy_planner.terrain.load_dem", boom)
    r = CliRunner().invoke(main, ["terrain", HILL])
    assert r.exit_code == 1, r.output
    assert "the fit cannot be made" in r.output and "Traceback" not in r.output
