"""Energy of SE(2) motions and paths: hand-worked cases and physical laws."""

from __future__ import annotations

import math

import numpy as np
import pytest
from b1_model import b1_model  # tests/ helper
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from energy_planner.energy import MotionCost, path_energy
from energy_planner.errors import OutsideMapError
from energy_planner.terrain import Terrain

MODEL = b1_model()


def plane(slope_deg: float, psi_deg: float, size: float = 100.0) -> Terrain:
    """A plane rising at ``slope_deg`` toward azimuth ``psi_deg`` (CCW from east)."""
    k = math.tan(math.radians(slope_deg))
    c, s = math.cos(math.radians(psi_deg)), math.sin(math.radians(psi_deg))
    return Terrain.from_function(lambda x, y: k * (c * x + s * y), size=(size, size))


@pytest.mark.parametrize("psi", [0.0, 37.0, 90.0, 200.0])
def test_straight_climb_and_descent_of_a_plane(psi):
    """E = (f0 +- f1 sin a) L: the force is constant, L = 40 m / cos(a) along the ground."""
    a = 12.0
    t = plane(a, psi)
    u = np.array([math.cos(math.radians(psi)), math.sin(math.radians(psi))])
    start = np.array([50.0, 50.0]) - 20 * u
    end = np.array([50.0, 50.0]) + 20 * u
    up = path_energy(t, MODEL, [start, end])
    sa = math.sin(math.radians(a))
    length = 40.0 / math.cos(math.radians(a))
    assert up.energy_j == pytest.approx((600 + 1000 * sa) * length, rel=1e-9)
    assert up.distance_m == pytest.approx(length)
    assert up.duration_s == pytest.approx(length / 0.3)
    down = path_energy(t, MODEL, [end, start])
    assert down.energy_j == pytest.approx((600 - 1000 * sa) * length, rel=1e-9)
    seg = up.segments.iloc[0]
    assert seg.mean_slope_deg == pytest.approx(a, abs=1e-9)
    assert seg.mean_rel_heading_deg == pytest.approx(0.0, abs=1e-6)
    assert seg.forward_share == pytest.approx(1.0)


def test_diagonal_climb_is_charged_the_true_grade():
    """Walking 60 deg off the fall line: the force is f0 + f1 * (rise / ground distance).

    That holds exactly because gamma is the heading in the slope plane, under which
    sin(alpha) cos(gamma) is the grade along body x.
    """
    a, off = math.radians(20.0), math.radians(60.0)
    t = plane(20.0, 0.0)
    L = 30.0
    xy = [[35.0, 50.0], [35.0 + L * math.cos(off), 50.0 + L * math.sin(off)]]
    rise = L * math.cos(off) * math.tan(a)
    ground = math.hypot(L, rise)
    r = path_energy(t, MODEL, xy)
    assert r.distance_m == pytest.approx(ground, rel=1e-9)
    assert r.energy_j == pytest.approx((600 + 1000 * rise / ground) * ground, rel=1e-9)


def test_lateral_traverse_and_lateral_climb():
    a, psi = 15.0, 30.0
    t = plane(a, psi)
    p = math.radians(psi)
    sa = math.sin(math.radians(a))
    # along the contour, facing uphill, stepping left: no grade
    contour = np.array([-math.sin(p), math.cos(p)])
    xy = [np.array([50.0, 50.0]) - 15 * contour, np.array([50.0, 50.0]) + 15 * contour]
    r = path_energy(t, MODEL, xy, yaw=[p, p])
    assert r.energy_j == pytest.approx(800 * 30.0, rel=1e-9)
    assert r.segments.lateral_share.iloc[0] == pytest.approx(1.0)
    # climbing sideways with uphill on the robot's left (gamma = -pi/2): moving left climbs
    u = np.array([math.cos(p), math.sin(p)])
    xy = [np.array([50.0, 50.0]) - 10 * u, np.array([50.0, 50.0]) + 10 * u]
    r = path_energy(t, MODEL, xy, yaw=[p - math.pi / 2] * 2)
    assert r.energy_j == pytest.approx(
        (800 + 900 * sa) * 20.0 / math.cos(math.radians(a)), rel=1e-9
    )


def test_turn_in_place():
    """E = (tau0 + tau1 sin a) |dtheta|, whatever the yaw rate."""
    t = plane(20.0, 0.0)
    sa = math.sin(math.radians(20.0))
    for rate in (0.3, 0.9):
        r = path_energy(t, MODEL, [[50, 50], [50, 50]], yaw=[0.2, 0.2 + 2.5], yaw_rate=rate)
        assert r.energy_j == pytest.approx((250 + 300 * sa) * 2.5, rel=1e-9)
        assert r.duration_s == pytest.approx(2.5 / rate)
        assert r.segments.turning_share.iloc[0] == pytest.approx(1.0)


def test_corners_without_yaw_turn_in_place():
    """An L-shaped path on flat ground: two straight legs plus one 90 degree turn."""
    t = plane(0.0, 0.0)
    r = path_energy(t, MODEL, [[10, 10], [40, 10], [40, 30]])
    assert r.energy_j == pytest.approx(600 * 50 + 250 * math.pi / 2, rel=1e-9)
    assert r.duration_s == pytest.approx(50 / 0.3 + (math.pi / 2) / 0.5)
    assert len(r.segments) == 2
    assert r.segments.turn_deg.tolist() == pytest.approx([0.0, 90.0])


def test_ridge_is_charged_on_both_sides():
    """A tent ridge crossed in one segment: uphill then downhill, each half charged."""
    a = math.radians(10)
    t = Terrain.from_function(lambda x, y: math.tan(a) * (30 - np.abs(x - 50)), size=(100, 100))
    r = path_energy(t, MODEL, [[20, 50], [80, 50]])
    expected = ((600 + 1000 * math.sin(a)) * 30 + (600 - 1000 * math.sin(a)) * 30) / math.cos(a)
    # the gradient flips within one cell at the ridge: bilinear smoothing costs < 1 m there
    assert r.energy_j == pytest.approx(expected, rel=2e-3)
    assert r.segments.max_slope_deg.iloc[0] == pytest.approx(10.0, abs=1e-6)


def test_timed_path_base_model_energy_does_not_depend_on_speed():
    """The base model is a force times distance: walking slower costs the same."""
    t = plane(8.0, 45.0)
    xy = [[20, 20], [60, 40], [70, 70]]
    fast = path_energy(t, MODEL, xy)
    slow = path_energy(t, MODEL, xy, t=[0.0, 400.0, 700.0])
    assert slow.energy_j == pytest.approx(fast.energy_j, rel=1e-9)
    assert slow.duration_s == pytest.approx(700.0)
    idle = b1_model(extra={"1": 30.0})  # 30 W standing power
    e_fast = path_energy(t, idle, xy).energy_j
    e_slow = path_energy(t, idle, xy, t=[0.0, 400.0, 700.0]).energy_j
    assert e_slow - e_fast == pytest.approx(30.0 * (700.0 - fast.duration_s), rel=1e-9)


def test_standing_still_reports_the_local_slope():
    t = plane(12.0, 0.0)
    r = path_energy(t, MODEL, [[50, 50], [50, 50]])
    assert r.energy_j == 0.0
    assert r.segments.max_slope_deg.iloc[0] == pytest.approx(12.0)


def test_waypoint_outside_the_map_is_named():
    t = plane(5.0, 0.0)
    with pytest.raises(OutsideMapError, match=r"waypoint 2 at \(150.00, 10.00\)"):
        path_energy(t, MODEL, [[10, 10], [20, 10], [150, 10]])
    z = t.elevation.copy()
    z[40:60, 40:60] = np.nan
    holey = Terrain(z, t.transform, t.crs)
    with pytest.raises(OutsideMapError, match="segment 0 .* outside the map or on nodata"):
        path_energy(holey, MODEL, [[10, 50], [90, 50]])


def test_kernel_agrees_with_numpy_evaluation_of_the_model():
    """Midpoint rule done independently with Terrain.sample, 3-D vectors and model.power."""
    t = Terrain.from_function(lambda x, y: 0.002 * (x - 40) ** 2 + 0.001 * x * y, size=(80, 80))
    cost = MotionCost(t, MODEL, 0.3, 0.5, step=0.1)
    x0, y0, th0, x1, y1, th1 = 10.0, 15.0, 0.3, 60.0, 55.0, 1.9
    e = cost(x0, y0, th0, x1, y1, th1)
    d = math.hypot(x1 - x0, y1 - y0)
    n = int(math.ceil(d / 0.1))
    s = (np.arange(n) + 0.5) / n
    x, y, th = x0 + s * (x1 - x0), y0 + s * (y1 - y0), th0 + s * (th1 - th0)
    smp = t.sample(x, y)
    g = np.column_stack([smp.dzdx, smp.dzdy])
    h = np.array([x1 - x0, y1 - y0]) / n
    step3 = np.column_stack([np.broadcast_to(h, (n, 2)), g @ h])  # 3-D step along the ground
    ds = np.linalg.norm(step3, axis=1)
    T = max(ds.sum() / 0.3, abs(th1 - th0) / 0.5)
    dt = T * ds / ds.sum()
    heading = np.column_stack([np.cos(th), np.sin(th)])
    bx = np.column_stack([heading, np.sum(g * heading, axis=1)])
    bx /= np.linalg.norm(bx, axis=1)[:, None]
    bz = np.column_stack([-g, np.ones(n)])
    bz /= np.linalg.norm(bz, axis=1)[:, None]
    by = np.cross(bz, bx)
    v = step3 / dt[:, None]
    psi = np.asarray(smp.uphill_azimuth)
    e_up = np.column_stack([np.cos(psi), np.sin(psi), np.hypot(*g.T)])
    e_up /= np.linalg.norm(e_up, axis=1)[:, None]
    e_side = np.column_stack([-np.sin(psi), np.cos(psi), np.zeros(n)])
    f = {
        "alpha": np.asarray(smp.slope),
        # in-plane heading: angle of body x from the in-plane uphill direction
        "gamma": np.arctan2(np.sum(bx * e_side, axis=1), np.sum(bx * e_up, axis=1)),
        "vx": np.sum(v * bx, axis=1),
        "vy": np.sum(v * by, axis=1),
        "wz": np.full(n, (th1 - th0) / T),
    }
    assert e == pytest.approx(float(np.sum(MODEL.power(f) * dt)), rel=1e-10)


# ---------------------------------------------------------------- properties (hypothesis)
BOWL = Terrain.from_function(
    lambda x, y: 0.004 * (x - 30) ** 2 + 0.002 * (y - 45) ** 2 + 0.15 * x, size=(100, 100)
)
BOWL_COST = MotionCost(BOWL, MODEL)
coord = st.floats(5, 95)
yaw = st.floats(-math.pi, math.pi)


@settings(max_examples=40, deadline=None)
@given(x0=coord, y0=coord, x1=coord, y1=coord, th=yaw, f=st.floats(0.1, 0.9))
def test_energies_of_concatenated_segments_add(x0, y0, x1, y1, th, f):
    """Superposition: A->M plus M->B equals A->B when M lies on the motion."""
    xm, ym = x0 + f * (x1 - x0), y0 + f * (y1 - y0)
    whole = BOWL_COST(x0, y0, th, x1, y1, th)
    parts = BOWL_COST(x0, y0, th, xm, ym, th) + BOWL_COST(xm, ym, th, x1, y1, th)
    # midpoint rule with sub-steps of 0.25 m on a smooth surface
    assert parts == pytest.approx(whole, rel=2e-3, abs=1e-6)


@settings(max_examples=30, deadline=None)
@given(x0=coord, y0=coord, x1=coord, y1=coord, th0=yaw, th1=yaw)
def test_mirror_symmetry(x0, y0, x1, y1, th0, th1):
    """Mirror terrain and path in y = 50: the energy is the same (design notes).

    A turn of exactly pi has no shorter side, so both the motion and its mirror turn
    the same way; it is excluded.
    """
    assume(abs(abs(math.remainder(th1 - th0, 2 * math.pi)) - math.pi) > 1e-6)
    mirrored = Terrain(BOWL.elevation[::-1].copy(), BOWL.transform, BOWL.crs)
    mc = MotionCost(mirrored, MODEL)
    e = BOWL_COST(x0, y0, th0, x1, y1, th1)
    em = mc(x0, 100 - y0, -th0, x1, 100 - y1, -th1)
    assert em == pytest.approx(e, rel=1e-9, abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(x0=coord, y0=coord, x1=coord, y1=coord, th0=yaw, th1=yaw, k=st.integers(1, 3))
# a turn of 38 angular steps whose rotated yaws round it to 38.00000000000001 steps: it
# took a 39th sub-step there (energy 1e-4 higher) before the count had its slack
@example(x0=5.0, y0=5.0, x1=5.0, y1=6.0, th0=1.9, th1=0.0, k=2)
def test_invariance_under_quarter_turns(x0, y0, x1, y1, th0, th1, k):
    """Rotating terrain and path together by k quarter turns about the map centre.

    A turn of (nearly) exactly pi is excluded: rounding in the rotated yaws can pick the
    other way round.
    """
    assume(abs(abs(math.remainder(th1 - th0, 2 * math.pi)) - math.pi) > 1e-6)
    rotated = Terrain(np.rot90(BOWL.elevation, k).copy(), BOWL.transform, BOWL.crs)
    rc = MotionCost(rotated, MODEL)

    def rot(x, y):
        for _ in range(k):  # 90 deg CCW about (50, 50)
            x, y = 100 - y, x
        return x, y

    a, b = rot(x0, y0), rot(x1, y1)
    e = BOWL_COST(x0, y0, th0, x1, y1, th1)
    er = rc(a[0], a[1], th0 + k * math.pi / 2, b[0], b[1], th1 + k * math.pi / 2)
    assert er == pytest.approx(e, rel=1e-9, abs=1e-9)


def test_a_to_b_and_b_to_a_differ_on_a_slope():
    t = plane(10.0, 0.0)
    c = MotionCost(t, MODEL)
    assert c(20, 50, 0.0, 80, 50, 0.0) > 1.5 * c(80, 50, math.pi, 20, 50, math.pi)


def test_limits_and_violations():
    t = plane(20.0, 0.0)
    c = MotionCost(t, MODEL, max_slope_deg=15.0)
    assert c(20, 50, 0.0, 80, 50, 0.0) == math.inf
    assert "slope 20.0 deg > limit 15 deg" == c.violation(50, 50, 0.0)
    cross = MotionCost(t, MODEL, max_cross_slope_deg=10.0)
    assert cross(50, 20, math.pi / 2, 50, 80, math.pi / 2) == math.inf
    assert cross(20, 50, 0.0, 80, 50, 0.0) < math.inf
    assert cross.violation(50, 50, math.pi / 2).startswith("cross-slope 20.0 deg")
    assert c.violation(500, 50) == "outside the map or on nodata"
    blocked = np.zeros(t.shape, bool)
    blocked[:, 48:52] = True
    b = MotionCost(t, MODEL, blocked=blocked)
    assert b(20, 30, 0.0, 80, 30, 0.0) == math.inf
    assert b.violation(50, 30) == "inside a keep-out area"


def test_lower_bound_is_admissible():
    c = MotionCost(BOWL, MODEL)
    rng = np.random.default_rng(0)
    p = rng.uniform(5, 95, (200, 4))
    th = rng.uniform(-math.pi, math.pi, (200, 2))
    e = c.batch(p[:, 0], p[:, 1], th[:, 0], p[:, 2], p[:, 3], th[:, 1])
    d = np.hypot(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    assert np.all(e >= c.min_cost_per_metre * d - 1e-9)
    assert c.min_cost_per_metre > 0


def test_a_passed_power_check_is_not_evaluated_again(monkeypatch):
    """check_cost_power evaluates check_walking_power's grid once per model content,
    channel values, speeds, yaw rate, gaits and slope-grid rows: the same count comes
    back; a model changed in place (here to a negative sideways term) is checked again
    and refused."""
    from energy_planner.energy import path as path_mod
    from energy_planner.errors import NonPositivePowerError
    from energy_planner.model import EnergyModel
    from energy_planner.model import model as model_mod

    calls = []
    real = model_mod.check_walking_power

    def counted(*args, **kw):
        calls.append(kw["max_slope_deg"])
        return real(*args, **kw)

    monkeypatch.setattr(model_mod, "check_walking_power", counted)
    monkeypatch.setattr(path_mod, "_POWER_CHECKED", {})
    m = EnergyModel(["idle_power", "lat_const"], {"idle_power": 100.0, "lat_const": 10.0})
    cost = MotionCost(plane(10.0, 0.0), m, 0.3, 0.5)
    # 36 headings x 5 gaits (4 walking at one speed, turning in place) per slope row
    n = path_mod.check_cost_power(cost, max_slope_deg=11.0)  # rows 0, 2.5, .., 10: 5
    assert n == 5 * 36 * 5 == real(m, max_slope_deg=11.0, speeds=[0.3], yaw_rate=0.5)
    assert path_mod.check_cost_power(cost, max_slope_deg=12.4) == n  # the same 5 rows
    assert len(calls) == 1
    assert path_mod.check_cost_power(cost, max_slope_deg=12.5) == 6 * 36 * 5  # a 6th row
    other = MotionCost(plane(3.0, 0.0), m, 0.3, 0.5)  # another cost, the same model
    assert path_mod.check_cost_power(other, max_slope_deg=10.0) == n
    assert len(calls) == 2
    m.coefficients["lat_const"] = -1000.0  # sideways at 0.3 m/s: 100 - 300 W < 0
    with pytest.raises(NonPositivePowerError, match="lat_const"):
        path_mod.check_cost_power(cost, max_slope_deg=11.0)
    with pytest.raises(NonPositivePowerError, match="lat_const"):  # a failure is not kept
        path_mod.check_cost_power(cost, max_slope_deg=11.0)
    assert len(calls) == 4
