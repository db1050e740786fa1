"""A bundled map's name works wherever a DEM or sites path does, from any folder."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.cli import main
from energy_planner.errors import DEMIOError
from energy_planner.maps import map_path, resolve


def test_resolve_prefers_an_existing_file_then_a_bundled_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert resolve("hill") == map_path("hill")
    assert resolve("hill_sites") == map_path("hill_sites")
    (tmp_path / "hill").write_text("a user's own file")
    assert resolve("hill").resolve() == (tmp_path / "hill").resolve()  # the file wins
    assert str(resolve("sub/hill")) == "sub/hill"  # a path is never taken for a name
    with pytest.raises(DEMIOError, match="valid names: hill, jacksboro, plane"):
        map_path("hil")


def test_the_library_and_the_cli_take_bundled_names_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no maps/ here
    t = ep.open_terrain("plane")
    assert t.path == map_path("plane")
    from energy_planner.mission.sites import read_sites

    assert len(read_sites("hill_sites", ep.open_terrain("hill"))) == 3
    r = CliRunner().invoke(main, ["terrain", "hill", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["path"] == str(map_path("hill"))
    r = CliRunner().invoke(
        main, ["energy", "--dem", "hill", "--waypoints", str(_wp(tmp_path)), "--json"]
    )
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["energy_j"] > 0
    r = CliRunner().invoke(main, ["energy", "--dem", "hil", "--waypoints", str(_wp(tmp_path))])
    assert r.exit_code == 2 and "hil" in r.output


def _wp(d):
    p = d / "wp.csv"
    p.write_text("x,y\n500058,5000046\n500058,5000060\n")
    return p


def test_ep_mission_stays_the_verb_after_its_package_is_imported():
    import energy_planner.mission  # noqa: F401 - sets ep.mission to the package

    sites = ep.read_sites("hill_sites", ep.open_terrain("hill"))
    assert callable(ep.mission) and len(sites) == 3
