"""The public API (``import energy_planner as ep``) gives what the commands give."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.cli import main
from energy_planner.io import reproject_xy

PLANE = str(ep.map_path("plane"))
S, G = (500010.0, 5000020.0), (500080.0, 5000070.0)


def test_plan_equals_the_plan_command():
    # the search planner: auto's refinement ends on a time budget, so two auto runs under
    # load may differ (the CLI has no --iterations); the search is deterministic
    r = CliRunner().invoke(main, ["plan", "--dem", PLANE, "--start", "500010,5000020",
                                  "--goal", "500080,5000070", "--planner", "search",
                                  "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    cli = json.loads(r.stdout[r.stdout.index("{") :])
    res = ep.plan(PLANE, S, G, planner="search")
    assert res.energy_j == pytest.approx(cli["energy_j"], rel=1e-9)


def test_points_in_another_crs_give_the_same_plan():
    prob = ep.Problem.from_dem(PLANE)
    lon, lat = reproject_xy("EPSG:32631", "EPSG:4326", [S[0], G[0]], [S[1], G[1]])
    # refinement rounds, not its time budget, end both (reproducible under any load)
    kw = {"iterations": 40, "time": 60.0}
    a = ep.plan(prob, S, G, **kw)
    b = ep.plan(prob, (lon[0], lat[0]), (lon[1], lat[1]), crs="EPSG:4326", **kw)
    assert b.energy_j == pytest.approx(a.energy_j, rel=1e-6)


def test_path_energy_adds_over_concatenated_segments():
    prob = ep.Problem.from_dem(PLANE)
    mid = (500040.0, 5000020.0)
    whole = prob.path_energy([S, mid, (500040.0, 5000060.0)])
    a = prob.path_energy([S, mid])
    b = prob.path_energy([mid, (500040.0, 5000060.0)])
    # the whole path also pays the turn in place at the corner
    assert whole.energy_j >= a.energy_j + b.energy_j - 1e-6
    assert whole.distance_m == pytest.approx(a.distance_m + b.distance_m, rel=1e-9)


def test_plan_chooses_windows_for_a_dem_over_the_memory_cap():
    kw = {"iterations": 40, "time": 60.0}  # reproducible refinement (rounds, not time)
    res = ep.plan(PLANE, S, G, memory_cap=1_000_000, **kw)  # 100 x 100 cells need 1.6 MB whole
    assert "corridor" in res.info
    whole = ep.plan(PLANE, S, G, **kw)
    assert res.energy_j >= whole.energy_j * (1 - 1e-6)


def test_problem_path_energy_holds_the_gait_limits():
    """Problem.path_energy prices with the request's gait limits, as the energy command."""
    line = [(500058, 5000046), (500058, 5000084)]
    free = ep.Problem.from_dem(ep.map_path("hill"))
    strict = ep.Problem.from_dem(ep.map_path("hill"), max_crab_deg=0)
    # facing along the line breaks no limit: both price it the same
    assert strict.path_energy(line).energy_j == pytest.approx(free.path_energy(line).energy_j)
    sideways = free.path_energy(line, yaw=[0.0, 0.0])  # body x east, walking north
    assert sideways.energy_j > 0
    with pytest.raises(ep.EnergyPlannerError, match="crab angle"):
        strict.path_energy(line, yaw=[0.0, 0.0])
