"""The hill's routes at the fixed speed, at their best speed and gait, and under a deadline.

``planning.scene.speed_scene`` on a window of the bundled hill with the bundled
across-speeds model ``b1_speeds``; the direct climb at its best speed is checked against
the model's cost per metre minimised on a grid of speeds (per gait) and integrated along
the line, independent of the planner's closed-form speed choice and its pricing.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.calibration.speed import cost_per_metre, gait_ranges
from energy_planner.errors import PlanningConfigError
from energy_planner.planning.scene import speed_scene
from energy_planner.terrain import load_dem

WINDOW = (500040, 5000040, 500076, 5000068)  # 36 m x 28 m of the hill
A, B = (500058, 5000046), (500058, 5000062)


@pytest.fixture(scope="module")
def scene():
    terrain = load_dem(ep.map_path("hill"), bounds=WINDOW)
    prob = ep.Problem(terrain, ep.load_model("b1_speeds"))
    return prob, speed_scene(prob, terrain.to_work(*A), terrain.to_work(*B), time=0.5)


def test_bundled_model_by_name():
    m = ep.load_model("b1_speeds")
    assert m.metadata["fit"]["speed_terms"]["supported"]
    assert sorted(gait_ranges(m)) == ["trot", "walk"]
    assert any("--across-speeds" in c for c in m.metadata["made_by"])


def test_parts_add_up_and_best_speed_saves(scene):
    _, sc = scene
    direct, opt = sc.row("direct"), sc.row("energy_optimal")
    total = sc.parts["total_j"]
    parts = ("body_yaw", "route", "speed", "gait", "route_with_speed")
    assert sum(sc.parts[k] for k in parts) == pytest.approx(total)
    best = min(opt["best_j"], sc.row("planned_at_best_speed")["best_j"])
    assert total == pytest.approx(direct["fixed_j"] - best, rel=1e-9)
    assert sc.parts["route_with_speed"] >= 0
    for r in sc.rows:
        if r["fixed_j"] is not None:  # the fixed speed is one choice of the range
            assert r["best_j"] <= r["fixed_j"]
        if r["deadline_j"] is not None:  # in time, and never cheaper than unconstrained
            assert r["deadline_s"] <= sc.deadline_s * (1 + 1e-3)
            assert r["deadline_j"] >= r["best_j"] * (1 - 1e-6)
    slowest = max(r["best_s"] for r in sc.rows)  # the deadline binds on some route
    assert slowest > sc.deadline_s
    binds = [r for r in sc.rows if r["best_s"] > sc.deadline_s and r["deadline_j"] is not None]
    assert all(r["deadline_j"] > r["best_j"] for r in binds)


def test_direct_best_speed_is_the_per_metre_minimum_on_a_plane():
    """On the bundled 10 deg plane, straight uphill: the model's cost per metre minimised
    on a grid of each gait's logged speeds, times the ground length (no planner in it)."""
    terrain = load_dem(ep.map_path("plane"), bounds=(500010, 5000010, 500050, 5000040))
    model = ep.load_model("b1_speeds")
    up = np.radians(30.0)  # the plane rises towards 30 deg CCW from east
    a = np.array(terrain.to_work(500020, 5000020))
    b = a + 16.0 * np.array([np.cos(up), np.sin(up)])
    sc = speed_scene(ep.Problem(terrain, model), a, b, time=0.3)
    ground = 16.0 / np.cos(np.radians(10.0))
    per_m = {g: cost_per_metre(model, np.linspace(lo, hi, 4001), 10.0, 0.0, gait=g)
             for g, (lo, hi) in gait_ranges(model).items()}  # fmt: skip
    gait = min(per_m, key=lambda g: per_m[g].min())
    direct = sc.row("direct")
    assert direct["best_gait"] == gait == "trot"
    assert direct["best_j"] == pytest.approx(float(per_m[gait].min()) * ground, rel=0.01)
    walk = cost_per_metre(model, [0.3], 10.0, 0.0, gait="walk")[0]  # the fixed speed
    assert direct["fixed_j"] == pytest.approx(walk * ground, rel=0.01)
    assert direct["best_j"] < direct["fixed_j"]


def test_model_without_gaits_is_refused():
    terrain = load_dem(ep.map_path("hill"), bounds=WINDOW)
    with pytest.raises(PlanningConfigError, match="name no gait"):
        speed_scene(ep.Problem(terrain, ep.load_model()), terrain.to_work(*A),
                    terrain.to_work(*B))  # fmt: skip


def test_to_dict_is_json_and_cli_refuses_a_deadline_alone(scene):
    from energy_planner.cli import main

    d = json.loads(json.dumps(scene[1].to_dict()))  # what demo --speeds --json prints
    assert [r["route"] for r in d["rows"]] == [
        "direct",
        "direct_best_yaw",
        "shortest",
        "energy_optimal",
        "planned_at_best_speed",
    ]
    got = CliRunner().invoke(main, ["demo", "--deadline", "10"])
    assert got.exit_code == 2 and "--deadline needs --speeds" in got.output
