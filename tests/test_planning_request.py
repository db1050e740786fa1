"""The planning request object: defaults, validation with structured fields."""

import math

import pytest
from shapely.geometry import box

from energy_planner.errors import EnergyPlannerError
from energy_planner.request import (
    DEFAULT_SPEED,
    DEFAULT_YAW_RATE,
    Limits,
    Request,
    RequestError,
    Robot,
)


def test_defaults_are_the_papers():
    r = Request()
    assert r.robot.speed == DEFAULT_SPEED == 0.3
    assert r.robot.yaw_rate == DEFAULT_YAW_RATE == 0.5
    assert r.limits == Limits()
    assert r.channels is None


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"speed": 0}, "speed"),
        ({"speed": math.nan}, "speed"),
        ({"yaw_rate": -0.1}, "yaw_rate"),
        ({"max_slope_deg": -1}, "max_slope_deg"),
        ({"max_cross_slope_deg": 91}, "max_cross_slope_deg"),
        ({"max_slope_deg": "steep"}, "max_slope_deg"),
        ({"keep_out": 3}, "keep_out"),
        ({"keep_out": [box(0, 0, 1, 1), "x"]}, "keep_out"),
    ],
)
def test_bad_values_raise_with_fields(kwargs, field):
    with pytest.raises(RequestError) as err:
        Request.make(**kwargs)
    assert err.value.field == field
    assert isinstance(err.value, EnergyPlannerError) and isinstance(err.value, ValueError)
    assert field in str(err.value)


def test_single_geometry_becomes_a_tuple_and_request_is_hashable_when_plain():
    g = box(0, 0, 1, 1)
    assert Limits(keep_out=g).keep_out == (g,)
    assert hash(Request.make(speed=0.4)) == hash(Request(robot=Robot(speed=0.4)))


def test_wrong_component_types():
    with pytest.raises(RequestError, match="robot"):
        Request(robot=0.3)
    with pytest.raises(RequestError, match="channels"):
        Request(channels={"payload_kg": 3})


# --- plan() with a request: issue 13's bad inputs --------------------------------------
import json  # noqa: E402

from click.testing import CliRunner  # noqa: E402

from energy_planner.errors import InvalidStateError, PlanningConfigError  # noqa: E402
from energy_planner.model import EnergyModel  # noqa: E402
from energy_planner.planning.limits import make_motion_cost  # noqa: E402
from energy_planner.planning.plan import plan  # noqa: E402
from energy_planner.terrain import Terrain  # noqa: E402


@pytest.fixture(scope="module")
def ramp():
    return Terrain.from_function(lambda x, y: 0.5 * y, size=(30, 30))


def test_start_equal_to_goal_is_a_stay_with_a_turn(ramp):
    m = EnergyModel.default()
    r = plan(ramp, m, (10.0, 10.0), (10.0, 10.0), progress=False)
    assert r.energy_j == 0.0 and r.distance_m == 0.0 and len(r.states) == 2
    turn = plan(ramp, m, (10.0, 10.0, 0.0), (10.0, 10.0, math.pi / 2), progress=False)
    cost, _ = make_motion_cost(ramp, m)
    assert turn.energy_j == pytest.approx(cost(10.0, 10.0, 0.0, 10.0, 10.0, math.pi / 2))
    assert turn.energy_j > 0


def test_endpoint_errors_carry_fields(ramp):
    m = EnergyModel.default()
    with pytest.raises(InvalidStateError) as err:
        plan(ramp, m, (10.0, 10.0, 0.0), (10.0, 20.0), Request.make(max_slope_deg=20),
             progress=False)  # fmt: skip
    e = err.value
    assert (e.endpoint, e.limit) == ("start", "max_slope_deg")
    assert e.value == pytest.approx(math.degrees(math.atan(0.5)), abs=0.05)
    with pytest.raises(InvalidStateError) as err:
        plan(ramp, m, (10.0, 10.0), (10.0, 99.0), progress=False)
    assert (err.value.endpoint, err.value.limit) == ("goal", "map")
    with pytest.raises(InvalidStateError) as err:
        plan(ramp, m, (10.0, 10.0), (15.0, 15.0),
             Request.make(keep_out=[box(14, 14, 16, 16)]), progress=False)  # fmt: skip
    assert (err.value.endpoint, err.value.limit) == ("goal", "keep_out")


def test_cost_and_request_must_agree(ramp):
    m = EnergyModel.default()
    cost, _ = make_motion_cost(ramp, m, Request.make(speed=0.4))
    with pytest.raises(PlanningConfigError, match="speed=0.4") as err:
        plan(ramp, m, (5.0, 5.0), (20.0, 5.0), Request.make(speed=0.3), cost=cost,
             progress=False)  # fmt: skip
    assert err.value.param == "speed"
    # cost= alone: the request is the cost's
    r = plan(ramp, m, (5.0, 5.0), (20.0, 5.0), cost=cost, planner="search", progress=False)
    assert r.info["request"].robot.speed == 0.4


def test_self_intersecting_keep_out_is_named_with_its_file(ramp, tmp_path):
    bowtie = {"type": "Polygon", "coordinates": [[[5, 5], [10, 10], [10, 5], [5, 10], [5, 5]]]}
    f = tmp_path / "ko.geojson"
    f.write_text(json.dumps(bowtie))
    with pytest.raises(PlanningConfigError, match="Self-intersection") as err:
        plan(ramp, EnergyModel.default(), (2.0, 2.0), (20.0, 2.0), Request.make(keep_out=f),
             progress=False)  # fmt: skip
    assert err.value.path == str(f) and str(f) in str(err.value)


def test_cli_plan_names_the_option(tmp_path):
    from energy_planner.cli import main
    from energy_planner.maps import map_path

    hill = str(map_path("hill"))
    runner = CliRunner()
    same = runner.invoke(main, ["plan", "--dem", hill, "--start", "500058,5000046",
                                "--goal", "500058,5000046", "--json"])  # fmt: skip
    assert same.exit_code == 0, same.output
    assert json.loads(same.stdout)["energy_j"] == 0.0
    bowtie = {"type": "Feature", "properties": {"crs": "EPSG:32631"}, "geometry": {
              "type": "Polygon",
              "coordinates": [[[500050, 5000060], [500060, 5000070], [500060, 5000060],
                               [500050, 5000070], [500050, 5000060]]]}}  # fmt: skip
    f = tmp_path / "ko.geojson"
    f.write_text(json.dumps(bowtie))
    bad = runner.invoke(main, ["plan", "--dem", hill, "--start", "500058,5000046",
                               "--goal", "500058,5000109", "--keep-out", str(f)])  # fmt: skip
    assert bad.exit_code == 1 and "--keep-out" in bad.output and "Self-intersection" in bad.output
    steep = runner.invoke(main, ["plan", "--dem", hill, "--start", "500058,5000080",
                                 "--goal", "500058,5000046", "--max-slope", "5"])  # fmt: skip
    assert steep.exit_code == 2 and "--start" in steep.output
    neg = runner.invoke(main, ["plan", "--dem", hill, "--start", "500058,5000046",
                               "--goal", "500058,5000109", "--speed", "-1"])  # fmt: skip
    assert neg.exit_code == 2 and "--speed" in neg.output
    jb = str(map_path("jacksboro_fault_dem"))
    metric = runner.invoke(main, ["plan", "--dem", jb, "--start", "741700,4048300",
                                  "--goal", "746000,4054000"])  # fmt: skip
    assert metric.exit_code == 2 and "--start" in metric.output
