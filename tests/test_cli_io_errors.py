"""#19 errors: off-the-map errors give the extent and the CRS, exit codes agree, numbers
are for people."""

from __future__ import annotations

import json
import re

import pytest
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.errors import extent_text, fmt_num
from energy_planner.maps import map_path

HILL = str(map_path("hill"))  # EPSG:32631, x 500000 .. 500200, y 5000000 .. 5000200
EXTENT = "x 500000 .. 500200, y 5000000 .. 5000200 in EPSG:32631"
PLAN = ["plan", "--dem", HILL, "--start", "500058,5000046"]


def _run(args):
    return CliRunner().invoke(main, args)


def _no_exponent(text: str) -> None:
    assert not re.search(r"\de[+-]\d", text), text


@pytest.mark.parametrize(
    "args",
    [
        [*PLAN, "--goal", "500058,5009060"],
        ["plan", "--dem", HILL, "--start", "3.0,45.1", "--goal", "500058,5000060"],
        ["reach", HILL, "--start", "3,45"],
        ["compare-routes", "--dem", HILL, "--start", "500058,5000046", "--goal", "500058,4000000"],
    ],
)
def test_outside_the_map_gives_extent_and_crs(args):
    r = _run(args)
    assert r.exit_code == 2, r.output
    assert "outside the map" in r.output or "outside DEM" in r.output
    assert EXTENT in " ".join(r.output.split())
    assert "not longitude/latitude" in r.output
    _no_exponent(r.output)


def test_lonlat_on_a_projected_dem_is_named():
    r = _run(["plan", "--dem", HILL, "--start", "3.0,45.1", "--goal", "500058,5000060"])
    assert "looks like longitude, latitude" in " ".join(r.output.split())


def test_missing_keep_out_exits_like_a_missing_dem(tmp_path):
    missing = str(tmp_path / "nope.geojson")
    dem = _run(["plan", "--dem", str(tmp_path / "nope.tif"), "--start", "1,2", "--goal", "3,4"])
    assert dem.exit_code == 2
    for cmd in (
        [*PLAN, "--goal", "500058,5000060"],
        ["compare-routes", "--dem", HILL, "--start", "500058,5000046", "--goal", "500058,5000060"],
        ["reach", HILL, "--start", "500058,5000046"],
    ):
        r = _run([*cmd, "--keep-out", missing])
        assert r.exit_code == dem.exit_code, (cmd, r.output)
        assert "--keep-out" in r.output and "does not exist" in r.output
        assert "Errno" not in r.output and "Traceback" not in r.output


def test_numbers_for_people():
    assert fmt_num(5e6) == "5000000" and fmt_num(5.0002e6) == "5000200"
    assert "e+" not in extent_text((5e5, 5e6, 5.002e5, 5.0002e6), "EPSG:32631")


def test_projected_keep_out_without_crs_names_the_option(tmp_path):
    f = tmp_path / "ko.geojson"
    ring = [[5e5, 5e6], [5e5 + 9, 5e6], [5e5, 5e6 + 9], [5e5, 5e6]]
    f.write_text(json.dumps({"type": "Polygon", "coordinates": [ring]}))
    r = _run([*PLAN, "--goal", "500058,5000060", "--keep-out", str(f)])
    assert r.exit_code == 1, r.output  # the file is there, its content is wrong: data
    assert "RFC 7946" in r.output and "--keep-out" in r.output


def _options(cmd_name: str) -> set[str]:
    import click

    cmd = main.get_command(click.Context(main), cmd_name)
    return {o for p in cmd.params for o in getattr(p, "opts", []) if o.startswith("--")}


@pytest.mark.parametrize(
    ("cmd", "lighter"),
    [("plan", "a coarser --step or a larger --eps"), ("compare-routes", "")],
)
def test_time_budget_hint_names_only_existing_options(cmd, lighter):
    """--time running out suggests options the command has (not 'fewer headings')."""
    from energy_planner.cli.plan import planning_error
    from energy_planner.errors import PlanningError

    exc = PlanningError("budget", limit="time", stage="search", expanded=12)
    msg = planning_error(exc, lighter).message
    named = set(re.findall(r"--[a-z-]+", msg))
    assert "--time" in named and named <= _options(cmd), (named, cmd)
    assert "heading" not in msg


def test_search_messages_name_no_cli_option():
    """The library's budget errors name its own arguments (time=, step=, eps=)."""
    from pathlib import Path

    import energy_planner.planning.search as search

    lines = Path(search.__file__).read_text().splitlines()
    starts = [i for i, ln in enumerate(lines) if "raise PlanningError(" in ln]
    budget = [i for i in starts if any('limit="time"' in ln for ln in lines[i : i + 8])]
    assert budget
    for i in budget:
        call = "\n".join(lines[i : i + 8])
        assert "--" not in call and "headings" not in call, call


def test_category_raster_without_table_names_table(tmp_path):
    """--channel ground=RASTER for a model comparing ground with 'mud' names :TABLE."""
    from energy_planner.model import EnergyModel

    doc = EnergyModel.default().to_dict()
    doc["terms"].append({"name": "mud", "formula": "(ground == 'mud') * speed",
                         "explanation": "mud", "unit": "W", "kind": "fwd"})  # fmt: skip
    doc["coefficients"]["mud"] = 50.0
    if doc.get("stderr"):
        doc["stderr"]["mud"] = 1.0
    model = tmp_path / "mud.json"
    model.write_text(json.dumps(doc))
    r = _run([*PLAN, "--goal", "500058,5000109", "--model", str(model),
              "--channel", f"ground={HILL}"])  # fmt: skip
    assert r.exit_code != 0
    text = " ".join(r.output.split())
    assert "--channel ground=RASTER:TABLE" in text and "--set ground=mud" in text
    assert "Traceback" not in r.output
