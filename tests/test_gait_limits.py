"""Gait limits (issue #19 point 8): no backward walking above a slope, a bounded crab angle.

The independent side is 3-D geometry on analytic planes: the angle between the body's x
axis (tilted with the ground) and the velocity along the ground is computed here with
numpy from the plane's gradient, never by the kernel; hand-computed energies of single
1 m motions give the energy map's and reach's expected values; and the search's optimum
can only rise when a limit is added (hypothesis).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from b1_model import b1_model  # tests/ helper
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from energy_planner.cli import main
from energy_planner.errors import EnergyPlannerError, OutsideMapError
from energy_planner.maps import map_path
from energy_planner.model import EnergyModel
from energy_planner.planning.limits import make_motion_cost
from energy_planner.request import Limits, Request, RequestError
from energy_planner.terrain import Terrain, load_dem

SLOPE = 20.0  # degrees, the analytic plane's slope (rising east)
TOL_DEG = 1e-3  # the kernel's slack is 1e-6 rad; positions and yaws round-trip through floats


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


def plane(slope_deg: float = SLOPE, size: int = 16, azimuth_deg: float = 0.0) -> Terrain:
    """A plane of ``slope_deg`` rising towards ``azimuth_deg`` (CCW from east), 1 m cells."""
    k = math.tan(math.radians(slope_deg))
    c, s = math.cos(math.radians(azimuth_deg)), math.sin(math.radians(azimuth_deg))
    return Terrain.from_function(lambda x, y: k * (c * x + s * y), size=(size, size))


def body_travel_angle(gx: float, gy: float, yaw: float, dx: float, dy: float) -> float:
    """Degrees between body x (tilted with the ground of gradient g) and the 3-D velocity
    along the ground of a map displacement (dx, dy): 0 forward, 180 backward."""
    bx = np.array([math.cos(yaw), math.sin(yaw), gx * math.cos(yaw) + gy * math.sin(yaw)])
    v = np.array([dx, dy, gx * dx + gy * dy])
    c = float(bx @ v / np.linalg.norm(bx) / np.linalg.norm(v))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def gait_samples(terrain: Terrain, states: np.ndarray, n: int = 16) -> np.ndarray:
    """``(slope deg, body-travel angle deg)`` at ``n`` points of every translating motion.

    The yaw moves along the shortest arc, as the motion kernel's does; the gradient is the
    terrain's own sample (Horn, bilinear) at each point.
    """
    rows = []
    for a, b in zip(states[:-1], states[1:], strict=True):
        dx, dy = b[0] - a[0], b[1] - a[1]
        if math.hypot(dx, dy) < 1e-9:
            continue  # a turn in place: no direction of travel
        dth = math.remainder(b[2] - a[2], 2 * math.pi)
        for s in (np.arange(n) + 0.5) / n:
            smp = terrain.sample(np.array([a[0] + s * dx]), np.array([a[1] + s * dy]))
            gx, gy = float(np.asarray(smp.dzdx)[0]), float(np.asarray(smp.dzdy)[0])
            ang = body_travel_angle(gx, gy, a[2] + s * dth, dx, dy)
            rows.append((math.degrees(math.atan(math.hypot(gx, gy))), ang))
    return np.array(rows).reshape(-1, 2)


def crab_of(angle_deg: np.ndarray) -> np.ndarray:
    return np.minimum(angle_deg, 180.0 - angle_deg)


# ------------------------------------------------------------------------- the fields
@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"max_backward_slope_deg": -1}, "max_backward_slope_deg"),
        ({"max_backward_slope_deg": 91}, "max_backward_slope_deg"),
        ({"max_crab_deg": "wide"}, "max_crab_deg"),
        ({"max_crab_deg": math.nan}, "max_crab_deg"),
    ],
)
def test_bad_gait_limits_raise_with_fields(kwargs, field):
    with pytest.raises(RequestError) as err:
        Request.make(**kwargs)
    assert err.value.field == field and field in str(err.value)
    assert isinstance(err.value, EnergyPlannerError) and isinstance(err.value, ValueError)
    lim = Request.make(max_backward_slope_deg=20, max_crab_deg=0).limits
    assert (lim.max_backward_slope_deg, lim.max_crab_deg) == (20.0, 0.0)
    assert Limits() == Limits(max_backward_slope_deg=None, max_crab_deg=None)


# ------------------------------------------------------------- the kernel, by geometry
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    direction=st.floats(-180, 180),
    offset=st.floats(-180, 180),
    slope=st.sampled_from([0.0, 8.0, 25.0]),
    back=st.sampled_from([None, 0.0, 15.0]),
    crab=st.sampled_from([None, 0.0, 30.0, 90.0]),
)
def test_kernel_refuses_exactly_the_gaits_geometry_forbids(
    model, direction, offset, slope, back, crab
):
    """A straight motion at constant yaw on a plane is refused iff the 3-D angle between
    the tilted body x axis and the ground velocity breaks a limit (margins of 0.01 deg
    about each boundary are skipped)."""
    t = _planes[slope]
    cost, _ = make_motion_cost(
        t, model, Request.make(max_backward_slope_deg=back, max_crab_deg=crab)
    )
    d, yaw = math.radians(direction), math.radians(direction + offset)
    x0, y0 = 8.0, 8.0
    dx, dy = 2.0 * math.cos(d), 2.0 * math.sin(d)
    g = math.tan(math.radians(slope))
    ang = body_travel_angle(g, 0.0, yaw, dx, dy)
    near = [90.0] + ([] if crab is None else [crab, 180.0 - crab])
    if min(abs(ang - b) for b in near) < 0.01:
        return
    backward = ang > 90.0 and back is not None and slope > back
    crabbing = crab is not None and crab_of(np.array(ang)) > crab
    e = cost(x0, y0, yaw, x0 + dx, y0 + dy, yaw)
    assert math.isinf(e) == (backward or crabbing), (ang, e)
    # a turn in place is never refused by a gait limit
    assert math.isfinite(cost(x0, y0, yaw, x0, y0, yaw + 2.0))


_planes = {s: plane(s) for s in (0.0, 8.0, 25.0)}


def test_path_energy_names_the_gait_limit(model):
    from energy_planner.energy import path_energy

    t = plane()
    cost, _ = make_motion_cost(t, model, Request.make(max_backward_slope_deg=10))
    xy = np.array([[4.0, 8.0], [10.0, 8.0]])  # straight up the fall line ...
    with pytest.raises(OutsideMapError, match="backward") as err:
        path_energy(t, model, xy, yaw=[math.pi, math.pi], cost=cost)  # ... facing down it
    assert err.value.limit == "max_backward_slope_deg" and err.value.value == 10
    ok = path_energy(t, model, xy, yaw=[0.0, 0.0], cost=cost).energy_j
    assert ok == pytest.approx(cost(4.0, 8.0, 0.0, 10.0, 8.0, 0.0))


# --------------------------------------------------------------------------- planning
def test_plan_with_no_crab_faces_along_or_back_on_a_plane(model):
    """max_crab_deg=0: every translating motion of the plan holds the body along the
    direction of travel or straight against it (3-D angle 0 or 180 deg)."""
    from energy_planner.planning.plan import plan

    t = plane(25.0, size=11, azimuth_deg=30.0)
    s, g = (2.5, 2.5, None), (8.5, 7.5, None)
    free = plan(t, model, s, g, planner="search", eps=1.0, progress=False)
    assert crab_of(gait_samples(t, free.states)[:, 1]).max() > 5.0  # it crabs when it may
    req = Request.make(max_crab_deg=0)
    res = plan(t, model, s, g, req, planner="search", eps=1.0, progress=False)
    crab = crab_of(gait_samples(t, res.states)[:, 1])
    assert crab.size and crab.max() < TOL_DEG
    assert res.energy_j >= free.energy_j * (1 - 1e-6)
    assert res.info["request"].limits.max_crab_deg == 0.0


def test_plan_walks_no_backward_motion_above_the_limit(model):
    """The plane's slope is above max_backward_slope_deg: no motion walks backward."""
    from energy_planner.planning.plan import plan

    t = plane(25.0, size=14, azimuth_deg=30.0)
    s, g = (2.5, 2.5, None), (11.5, 8.5, None)
    req = Request.make(max_backward_slope_deg=20, max_crab_deg=60)
    res = plan(t, model, s, g, req, planner="search", progress=False)
    gs = gait_samples(t, res.states)
    assert gs.size and gs[:, 1].max() <= 90.0 + TOL_DEG
    assert crab_of(gs[:, 1]).max() <= 60.0 + TOL_DEG


def test_reach_honours_the_gait_limits(model):
    """One cell uphill (east) of the start with no crab and no backward walking: only the
    forward motion facing east is left, so reach's energy there is that 1 m motion's;
    without limits some lattice heading makes the move cheaper (it crabs). One cell
    downhill: facing west, not backing down."""
    from energy_planner.planning.reach import reach
    from energy_planner.planning.search import _Grid

    t = plane(SLOPE, size=12)
    x0, y0 = 5.5, 5.5
    free = reach(t, model, (x0, y0))
    lim = reach(t, model, (x0, y0), Request.make(max_backward_slope_deg=10, max_crab_deg=0))
    cost, _ = make_motion_cost(t, model)
    cx, cy = t.grid[0], t.grid[1]
    col = round((x0 - cx) / t.grid[2])
    row = round((y0 - cy) / t.grid[3])
    fwd_up = cost(x0, y0, 0.0, x0 + 1, y0, 0.0)
    fwd_down = cost(x0, y0, math.pi, x0 - 1, y0, math.pi)
    back_down = cost(x0, y0, 0.0, x0 - 1, y0, 0.0)
    headings = _Grid(cost, t, (x0, y0), None, 16, "all").headings
    best_up = min(cost(x0, y0, h, x0 + 1, y0, h) for h in headings)
    assert lim.energy_j[row, col + 1] == pytest.approx(fwd_up, rel=1e-5)
    assert free.energy_j[row, col + 1] == pytest.approx(best_up, rel=1e-5)
    assert best_up < 0.99 * fwd_up
    assert lim.energy_j[row, col - 1] == pytest.approx(fwd_down, rel=1e-5)
    assert free.energy_j[row, col - 1] <= min(fwd_down, back_down) * (1 + 1e-5)
    fin = np.isfinite(free.energy_j)
    assert np.all(lim.energy_j[fin] >= free.energy_j[fin] * (1 - 1e-5))


def test_compare_routes_honours_the_gait_limits(model):
    from energy_planner.planning.compare import compare_routes

    t = plane(25.0, size=12, azimuth_deg=30.0)
    req = Request.make(max_backward_slope_deg=20, max_crab_deg=0)
    comp = compare_routes(t, model, (2.5, 2.5), (9.5, 8.5), req, time=0.5, progress=False)
    assert comp.limits["max_crab_deg"] == 0.0 and comp.limits["max_backward_slope_deg"] == 20
    checked = 0
    for r in comp.routes:
        if not r.feasible:
            continue
        gs = gait_samples(t, r.states)
        assert crab_of(gs[:, 1]).max() < TOL_DEG, r.name
        assert gs[:, 1].max() < 90.0, r.name  # forward only: the plane is > 20 deg
        checked += 1
    assert checked >= 3
    assert comp.route("direct_best_yaw").body_yaw_deg in (0.0, -0.0)


# ----------------------------------------------------------------------- the energy map
def _map_bands(tmp_path, t, model, request, name):
    import rasterio

    from energy_planner.energymap import energy_map

    out = energy_map(t, tmp_path / f"{name}.tif", model, headings=8, request=request,
                     progress=False, encoding="float32").path  # fmt: skip
    with rasterio.open(out) as src:
        return {d: src.read(i + 1) for i, d in enumerate(src.descriptions)}


def test_energy_map_cheapest_band_takes_only_allowed_gaits(tmp_path):
    """With max_crab_deg=0 each best_* band is the least of walking 1 m forward or
    backward along the heading (hand-computed from two single motions); with backward
    walking forbidden as well, it is the forward one (= along_*). The model (explicit
    B1 terms) makes backward and sideways walking cheaper than forward on some headings,
    so that each limit changes the band somewhere."""
    model = b1_model(
        {"fwd_const": 900.0, "fwd_grade": 1000.0, "bwd_const": 700.0, "bwd_grade": 1000.0,
         "lat_const": 500.0, "lat_grade": 900.0, "turn_const": 250.0, "turn_slope": 300.0}
    )  # fmt: skip
    t = plane(SLOPE, size=12, azimuth_deg=30.0)
    cost, _ = make_motion_cost(t, model)
    free = _map_bands(tmp_path, t, model, Request(), "free")
    crab0 = _map_bands(tmp_path, t, model, Request.make(max_crab_deg=0), "crab0")
    fwd = _map_bands(
        tmp_path, t, model, Request.make(max_crab_deg=0, max_backward_slope_deg=10), "fwd"
    )
    r, c = 6, 6  # an interior cell; the plane's gradient is the same everywhere
    x, y = t.grid[0] + c * t.grid[2], t.grid[1] + r * t.grid[3]
    lower_somewhere = backward_used = False
    for j in range(8):
        h = 2 * math.pi * j / 8
        label = [k for k in crab0 if k.startswith("best_")][j]
        ux, uy = 0.5 * math.cos(h), 0.5 * math.sin(h)
        e_fwd = cost(x - ux, y - uy, h, x + ux, y + uy, h)
        e_back = cost(x - ux, y - uy, h + math.pi, x + ux, y + uy, h + math.pi)
        assert crab0[label][r, c] == pytest.approx(min(e_fwd, e_back), rel=1e-5)
        assert fwd[label][r, c] == pytest.approx(e_fwd, rel=1e-5)
        assert free[label][r, c] <= crab0[label][r, c] * (1 + 1e-6)
        lower_somewhere |= bool(free[label][r, c] < crab0[label][r, c] * (1 - 1e-3))
        backward_used |= bool(e_back < e_fwd * (1 - 1e-3))
    assert lower_somewhere and backward_used  # each limit changes some band
    assert np.nanmin(crab0["cheapest"]) >= np.nanmin(free["cheapest"])


# --------------------------------------------------------------------------- property
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    back=st.sampled_from([None, 0.0, 5.0, 15.0]),
    crab=st.sampled_from([None, 0.0, 20.0, 45.0]),
)
def test_adding_a_gait_limit_never_lowers_the_optimum(model, seed, back, crab):
    """On a small random map, the optimal energy with a limit is >= without: the exact
    search of the (x, y, heading) lattice (scipy's Dijkstra over every edge; the A*
    search finds the same optimum, tests/test_planning_search.py)."""
    from energy_planner.errors import PlanningError
    from energy_planner.planning.lattice import lattice_plan

    rng = np.random.default_rng(seed)
    k = rng.uniform(-0.4, 0.4, 2)
    h, w = rng.uniform(-3, 3), rng.uniform(2, 5)
    t = Terrain.from_function(
        lambda x, y: k[0] * x + k[1] * y + h * np.exp(-((x - 6) ** 2 + (y - 5) ** 2) / w**2),
        size=(12, 12),
    )
    s, g = (2.5, 2.5, None), (9.5, 8.5, None)
    free_cost, _ = make_motion_cost(t, model)
    lim_cost, _ = make_motion_cost(
        t, model, Request.make(max_backward_slope_deg=back, max_crab_deg=crab)
    )
    free = lattice_plan(free_cost, t, s, g, step=1.0).cost
    try:
        limited = lattice_plan(lim_cost, t, s, g, step=1.0).cost
    except PlanningError:
        limited = math.inf
    assert limited >= free * (1 - 1e-6)


# -------------------------------------------------------------------------------- CLI
GAIT_COMMANDS = ["plan", "compare-routes", "reach", "energy-map", "energy", "demo", "mission"]


@pytest.mark.parametrize("command", GAIT_COMMANDS)
def test_every_limit_command_takes_the_gait_options(command):
    out = CliRunner().invoke(main, [command, "--help"], terminal_width=200).output
    assert "--max-backward-slope" in out and "--max-crab" in out


def test_hill_plan_with_max_backward_slope_walks_no_backward_motion_on_steep_cells():
    """The paper's hill (the demo's start and goal). Without a limit the plan climbs
    walking backward up to 40.6 deg (measured: 100 of its 160 samples walk backward);
    with --max-backward-slope 20 it never walks backward on ground steeper than 20 deg,
    and plan --json lists the limits."""
    hill = map_path("hill")
    t = load_dem(hill)
    args = ["plan", "--dem", str(hill), "--start", "500058,5000046",
            "--goal", "500058,5000084", "--json"]  # fmt: skip

    def states(extra):
        r = CliRunner().invoke(main, [*args, *extra])
        assert r.exit_code == 0, r.output
        res = json.loads(r.stdout[r.stdout.index("{") :])
        w = res["waypoints"]
        xs, ys = t.to_work(np.array([p["x"] for p in w]), np.array([p["y"] for p in w]))
        st_ = np.column_stack([xs, ys, np.radians([p["yaw_deg"] for p in w])])
        return res, gait_samples(t, st_)

    res, gs = states(["--max-backward-slope", "20", "--max-crab", "80"])
    steep = gs[:, 0] > 20.0
    assert steep.any() and gs[steep, 1].max() <= 90.0 + TOL_DEG
    assert crab_of(gs[:, 1]).max() <= 80.0 + TOL_DEG
    assert res["limits"]["max_backward_slope_deg"] == 20.0
    assert res["limits"]["max_crab_deg"] == 80.0


def test_energy_command_reports_a_gait_violation(tmp_path):
    """`energy` of waypoints walked backward up the bundled 10 deg plane: exit 1 naming
    the limit; the same waypoints facing forward pass."""
    u = (math.cos(math.radians(30)), math.sin(math.radians(30)))  # the plane's uphill
    a = (500050.0, 5000050.0)
    b = (a[0] + 20 * u[0], a[1] + 20 * u[1])
    dem = str(map_path("plane"))

    def run(yaw_deg, *extra):
        p = tmp_path / "w.csv"
        p.write_text(f"x,y,yaw_deg\n{a[0]},{a[1]},{yaw_deg}\n{b[0]},{b[1]},{yaw_deg}\n")
        return CliRunner().invoke(main, ["energy", "--dem", dem, "--waypoints", str(p), *extra])

    bad = run(210.0, "--max-backward-slope", "5")
    assert bad.exit_code == 1 and "max_backward_slope_deg" in bad.output, bad.output
    assert "Traceback" not in bad.output
    assert run(210.0, "--max-backward-slope", "15").exit_code == 0
    assert run(30.0, "--max-backward-slope", "5", "--max-crab", "0").exit_code == 0
    crab = run(60.0, "--max-crab", "20")
    assert crab.exit_code == 1 and "max_crab_deg" in crab.output, crab.output
    usage = run(30.0, "--max-crab", "91")
    assert usage.exit_code == 2 and "--max-crab" in usage.output


def test_demo_names_the_gait_limits_it_was_given():
    from energy_planner.cli.demo import _limits_text

    lim = {"max_slope_deg": None, "max_backward_slope_deg": 20.0, "max_crab_deg": 0.0}
    assert _limits_text({"limits": lim}) == "no backward walking above 20 deg, max crab angle 0 deg"
    assert _limits_text({"limits": {"max_slope_deg": None}}).startswith("none")
