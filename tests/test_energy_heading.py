"""The cheapest way to move along a heading (energy_planner.energy.heading).

Independent sides: closed forms of hand-built models (crabbing, backward walking, gait
limits), the motion kernel of ``energy`` swept over the body's yaw, and the exact
minimum for the table's bilinear lookup and lower bound (hypothesis)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from energy_planner.energy import MotionCost
from energy_planner.energy.heading import heading_cost
from energy_planner.model import EnergyModel
from energy_planner.terrain import Terrain

TILT = "speed * (sin(alpha) * cos(gamma)) ** 2"
#: walking costs 100 J per metre of ground, plus 400 sin^2 of the grade along the body's x
#: axis, plus 400 cos r when walking forward at r from the body's x axis (so backward and
#: sideways walking are cheap): with any yaw, the body held across the slope walks any
#: direction for 100 J/m
GAIT = EnergyModel(["speed", TILT, "pos(vx)"], {"speed": 100.0, TILT: 400.0, "pos(vx)": 400.0})


def per_map_metre(ground: float, alpha: float, phi: float) -> float:
    """J per map metre from J per ground metre, travelling ``phi`` from uphill."""
    return ground * math.hypot(1.0, math.tan(alpha) * math.cos(phi))


@pytest.mark.parametrize("phi_deg", [0.0, 30.0, 90.0, 160.0, 180.0])
def test_any_yaw_crabs_across_the_slope(phi_deg):
    """Any direction on a 20 deg plane costs 100 J per metre of ground: the body is held
    across the slope (sideways or backward, never forward)."""
    alpha, phi = math.radians(20.0), math.radians(phi_deg)
    cost, yaw = heading_cost(GAIT).per_metre(math.tan(alpha), 0.0, phi)
    assert float(cost) == pytest.approx(per_map_metre(100.0, alpha, phi), rel=1e-6)
    assert abs(math.degrees(float(yaw))) >= 90.0 - 1e-3


def test_gait_limits_closed_form():
    """Straight up a 20 deg plane. ``max_crab_deg=0``: backward, 100 + 400 sin^2(alpha);
    30: backward with the body 30 deg off the fall line in the slope plane (where the
    motion kernel checks the crab angle), 100 + 400 sin^2(alpha) cos^2(30 deg), a map yaw
    of atan(tan 30 deg / cos alpha) off it; and with no backward walking above 10 deg:
    forward at 30 deg, plus 400 cos 30 deg. The energy map's lookup applies the backward
    limit per cell."""
    alpha, c = math.radians(20.0), math.radians(30.0)
    gx, s2 = math.tan(alpha), math.sin(alpha) ** 2
    c_map = math.degrees(math.atan(math.tan(c) / math.cos(alpha)))  # 31.6 deg
    cases = [
        ({"max_crab_deg": 0.0}, 100.0 + 400.0 * s2, 180.0),
        ({"max_crab_deg": 30.0}, 100.0 + 400.0 * s2 * math.cos(c) ** 2, 180.0 - c_map),
        (
            {"max_crab_deg": 30.0, "max_backward_slope_deg": 10.0},
            100.0 + 400.0 * math.cos(c) + 400.0 * s2 * math.cos(c) ** 2,
            c_map,
        ),
        ({"max_crab_deg": 0.0, "max_backward_slope_deg": 10.0}, 500.0 + 400.0 * s2, 0.0),
    ]
    for limits, ground, yaw_deg in cases:
        hc = heading_cost(GAIT, **limits)
        cost, yaw = hc.per_metre(gx, 0.0, 0.0)
        assert float(cost) == pytest.approx(per_map_metre(ground, alpha, 0.0), rel=1e-6), limits
        assert abs(math.degrees(float(yaw))) == pytest.approx(yaw_deg, abs=0.01), limits
        along, best = np.empty((1, 1, 1), np.float32), np.empty((1, 1, 1), np.float32)
        g = np.array([[gx]]), np.array([[0.0]])
        hc.map_bands(*g, np.zeros((0, 1, 1)), np.zeros(1), along, best)
        assert float(best[0, 0, 0]) == pytest.approx(float(cost), rel=1e-5), limits
        forward = per_map_metre(500.0 + 400.0 * s2, alpha, 0.0)
        assert float(along[0, 0, 0]) == pytest.approx(forward, rel=1e-6)
    # on 5 deg ground backward walking is allowed again
    flat = heading_cost(GAIT, max_crab_deg=0.0, max_backward_slope_deg=10.0)
    a5 = math.radians(5.0)
    want = per_map_metre(100.0 + 400.0 * math.sin(a5) ** 2, a5, 0.0)
    assert float(flat.per_metre(math.tan(a5), 0.0, 0.0)[0]) == pytest.approx(want, rel=1e-6)


def test_exact_minimum_equals_the_motion_kernel_swept_over_yaws():
    """The bundled model on a 24 deg plane: the least energy of a 1 cm motion over the
    body's yaw every 0.25 deg (``MotionCost``, the kernel of ``energy``) equals the exact
    minimum within 0.1 %, and the exact minimum is never above it."""
    model = EnergyModel.default()
    k = math.tan(math.radians(24.0))
    t = Terrain.from_function(lambda x, y: k * (0.6 * x + 0.8 * y), size=(8, 8))
    cost = MotionCost(t, model)
    hc = heading_cost(model)
    yaw = np.radians(np.arange(0.0, 360.0, 0.25))
    x, y, eps = 3.5, 3.5, 0.005
    for h in np.radians([0.0, 37.0, 90.0, 143.0, 200.0, 290.0]):
        c, s = math.cos(h), math.sin(h)
        ones = np.ones(yaw.size)
        e = cost.batch(ones * (x - eps * c), ones * (y - eps * s), h + yaw,
                       ones * (x + eps * c), ones * (y + eps * s), h + yaw) / (2 * eps)  # fmt: skip
        got, r = hc.per_metre(0.6 * k, 0.8 * k, h)
        assert float(got) <= e.min() * (1 + 1e-6)
        # the sweep misses a sharp minimum (a kink of the model) by up to 0.07 %
        assert float(got) == pytest.approx(e.min(), rel=1e-3)


@settings(max_examples=60, deadline=None)
@given(
    slope=st.floats(0.0, 70.0),
    azimuth=st.floats(0.0, 360.0),
    heading=st.floats(0.0, 360.0),
    w_deg=st.floats(0.5, 90.0),
)
def test_yaw_window_is_the_map_image_of_the_in_plane_gait_window(slope, azimuth, heading, w_deg):
    """The sweep's window of map yaws holds exactly the yaws whose angle between body x
    and the velocity, in the tilted body frame of the motion kernel (3-D geometry, not
    the window's closed form), is within ``w`` of the travel; turned by pi, of its
    opposite."""
    from energy_planner.energy import _motion as km

    g = math.tan(math.radians(slope))
    gx, gy = g * math.cos(math.radians(azimuth)), g * math.sin(math.radians(azimuth))
    h, w = math.radians(heading), math.radians(w_deg)
    alpha, ca, sa, c_psi, s_psi = km.slope_of(gx, gy)
    u0, u1 = math.cos(h), math.sin(h)
    centre, width = km.yaw_window(ca, c_psi, s_psi, u0, u1, w)
    assert abs(centre) <= width + 1e-12  # facing along is always inside
    v = (u0, u1, gx * u0 + gy * u1)
    for r in np.radians(np.arange(-180.0, 180.0, 0.1)):
        vx, vy = km.body_velocity_cs(gx, gy, math.cos(h + r), math.sin(h + r), *v)
        ang = math.atan2(abs(vy), vx)  # 0: along the travel, pi: straight back
        d_fwd = abs(km.wrap_angle(r - centre))
        d_back = abs(km.wrap_angle(r - centre - math.pi))
        if d_fwd < width - 1e-6:
            assert ang <= w + 1e-6, (math.degrees(r), math.degrees(ang))
        elif d_fwd > width + 1e-6:
            assert ang > w - 1e-6, (math.degrees(r), math.degrees(ang))
        if d_back < width - 1e-6:
            assert math.pi - ang <= w + 1e-6, (math.degrees(r), math.degrees(ang))
        elif d_back > width + 1e-6:
            assert math.pi - ang > w - 1e-6, (math.degrees(r), math.degrees(ang))


@pytest.mark.parametrize(
    "limits", [{"max_crab_deg": 30.0, "max_backward_slope_deg": 10.0}, {"max_crab_deg": 45.0}]
)
def test_gait_limited_minimum_equals_the_limited_motion_kernel_swept_over_yaws(limits):
    """The gait limits as the motion kernel checks them (in the slope plane): on a 24 deg
    plane the least energy of a 1 cm motion over every 0.25 deg of body yaw that the
    limited ``MotionCost`` allows equals the heading cost's minimum within 0.1 %, is never
    below it (the window covers every allowed yaw, also where the map image of the crab
    window is asymmetric, travelling off the fall line), and the yaw it returns is one
    the kernel allows."""
    model = EnergyModel.default()
    k = math.tan(math.radians(24.0))
    t = Terrain.from_function(lambda x, y: k * (0.6 * x + 0.8 * y), size=(8, 8))
    cost = MotionCost(t, model, **limits)
    hc = heading_cost(model, **limits)
    yaw = np.radians(np.arange(0.0, 360.0, 0.25))
    x, y, eps = 3.5, 3.5, 0.005
    uphill = math.atan2(0.8, 0.6)
    for off in (0.0, 12.0, 40.0, 90.0, 160.0, 200.0, 300.0):
        h = uphill + math.radians(off)
        c, s = math.cos(h), math.sin(h)
        ones = np.ones(yaw.size)
        e = cost.batch(ones * (x - eps * c), ones * (y - eps * s), h + yaw,
                       ones * (x + eps * c), ones * (y + eps * s), h + yaw) / (2 * eps)  # fmt: skip
        got, r = hc.per_metre(0.6 * k, 0.8 * k, h)
        assert np.isfinite(e).any() and np.isinf(e).any(), off  # the limits act
        assert float(got) <= e.min() * (1 + 1e-6), off
        assert float(got) == pytest.approx(e.min(), rel=1e-3), off
        th = h + float(r)
        at_r = cost(x - eps * c, y - eps * s, th, x + eps * c, y + eps * s, th) / (2 * eps)
        assert float(got) == pytest.approx(at_r, rel=1e-6), off


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    slope=st.floats(0.0, 55.0),
    azimuth=st.floats(0.0, 360.0),
    heading=st.floats(0.0, 360.0),
    crab=st.sampled_from([None, 45.0]),
    cross=st.sampled_from([None, 20.0]),
)
def test_table_lookup_is_within_half_a_percent_and_the_bound_below(
    slope, azimuth, heading, crab, cross
):
    """The map's bilinear table lookup equals the exact minimum within 0.5 % (never above
    walking forward), and the heuristic's lower bound stays below it (with the planner's
    1 % margin)."""
    model = EnergyModel.default()
    hc = heading_cost(model, max_crab_deg=crab, max_cross_slope_deg=cross)
    g = math.tan(math.radians(slope))
    gx = np.array([[g * math.cos(math.radians(azimuth))]])
    gy = np.array([[g * math.sin(math.radians(azimuth))]])
    h = math.radians(heading)
    exact = float(hc.per_metre(gx, gy, h)[0][0, 0])
    along, best = np.empty((1, 1, 1), np.float32), np.empty((1, 1, 1), np.float32)
    hc.map_bands(gx, gy, np.zeros((0, 1, 1)), np.array([h]), along, best)
    if not math.isfinite(exact):
        assert math.isinf(best[0, 0, 0])
        return
    assert float(best[0, 0, 0]) == pytest.approx(exact, rel=5e-3)
    assert best[0, 0, 0] <= along[0, 0, 0]
    assert float(hc.lower_bound(gx, gy, h)[0, 0]) * 0.99 <= exact
