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
