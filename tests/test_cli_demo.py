"""``energy-planner demo``: the README's first command, on the bundled Fig. 1 hill."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from energy_planner.cli import main


def test_demo_shows_fig1_a_longer_route_that_costs_less_with_no_limit(tmp_path):
    """The paper's Fig. 1 with the bundled model and no slope limit: the energy-optimal
    route is a different path from the direct climb and from the shortest route, costs
    less than the direct climb, and climbs more gently than the model's critical grade
    lets the direct line do."""
    png = tmp_path / "new" / "demo.png"  # its folder is made (test_outputs_everywhere)
    r = CliRunner().invoke(main, ["demo", "--time", "2", "--plot", str(png), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert res["max_slope_deg"] is None
    routes = {x["name"]: x for x in res["routes"]}
    assert list(routes) == ["direct", "direct_best_yaw", "shortest", "energy_optimal"]
    direct, short, opt = routes["direct"], routes["shortest"], routes["energy_optimal"]
    assert direct["feasible"] and short["feasible"] and opt["feasible"]
    # no limit: the shortest path (along the ground) is the straight line (and the table
    # says so) or a path next to it that avoids a little of the steepest ground
    assert short["same_as"] == "direct" or short["distance_m"] <= direct["distance_m"]
    # the energy-optimal route is its own path (more than a cell away somewhere), longer
    # and cheaper than the direct climb
    assert opt["same_as"] is None
    assert opt["distance_m"] > 1.2 * direct["distance_m"]
    assert opt["energy_j"] < direct["energy_j"]
    # the physics: the direct line climbs steeper than the critical grade, the detour
    # climbs closer to it and pays less per metre of height
    gstar = res["physics"]["critical_grade_deg"]
    assert gstar is not None and direct["climb_grade_deg"] > gstar
    per_h = res["physics"]["per_height"]
    assert per_h["energy_optimal"] < per_h["direct"]
    # the saving splits into gait (the line crabbed) and route (the detour), both > 0
    crab = routes["direct_best_yaw"]
    assert crab["same_as"] is None and crab["distance_m"] == pytest.approx(direct["distance_m"])
    assert opt["energy_j"] < crab["energy_j"] < direct["energy_j"]
    assert png.stat().st_size > 10_000


def test_demo_rejects_an_unknown_scenario():
    r = CliRunner().invoke(main, ["demo", "--scenario", "everest"])
    assert r.exit_code == 2
    assert "valid: hill, hill_crossing, plane" in r.output
