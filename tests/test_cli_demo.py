"""``energy-planner demo``: the README's first command, on the bundled Fig. 1 hill."""

from __future__ import annotations

import json

from click.testing import CliRunner

from energy_planner.cli import main


def test_demo_compares_the_three_routes_on_the_hill(tmp_path):
    png = tmp_path / "demo.png"
    r = CliRunner().invoke(main, ["demo", "--time", "1", "--plot", str(png), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    routes = {x["name"]: x for x in res["routes"]}
    assert list(routes) == ["direct", "shortest", "energy_optimal"]
    # the straight climb meets 29.6 deg: infeasible for a robot limited to 25 deg
    assert routes["direct"]["feasible"] is False
    assert routes["direct"]["max_slope_deg"] > 25.0
    assert "slope" in routes["direct"]["reason"]
    opt, short = routes["energy_optimal"], routes["shortest"]
    assert opt["feasible"] and short["feasible"]
    assert opt["max_slope_deg"] <= 25.0 + 1e-6
    # the energy-optimal route never costs more than the shortest feasible one
    assert opt["energy_j"] <= short["energy_j"] * (1 + 1e-9)
    # and the shortest feasible route is no longer than the energy-optimal one
    assert short["distance_m"] <= opt["distance_m"] + 1e-6
    assert png.stat().st_size > 10_000


def test_demo_rejects_an_unknown_scenario():
    r = CliRunner().invoke(main, ["demo", "--scenario", "everest"])
    assert r.exit_code == 2
    assert "valid: hill, hill_crossing, plane" in r.output
