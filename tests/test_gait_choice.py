"""The gait as a per-motion decision, on planes where every number is calculus.

Two gaits with disjoint speed ranges; a metre in gait ``g`` on ground of slope ``alpha``
costs ``a_g + d_g sin(alpha) + b_g / v + c_g v^2`` (power ``(a_g + d_g sin(alpha)) v + b_g
+ c_g v^3``): least at ``v_g = (b_g / (2 c_g))^(1/3)`` clamped to the gait's range. The
trot is cheaper on the flat, the walk on a slope (the trot's ``d`` is large): the best
gait switches with the slope, by hand.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.cli import main
from energy_planner.energy import MotionCost
from energy_planner.model import EnergyModel
from energy_planner.problem import Problem
from energy_planner.terrain import Terrain

GAITS = {  # a, d, b, c, (vmin, vmax)
    "walk": (100.0, 0.0, 10.0, 100.0, (0.2, 0.5)),
    "trot": (30.0, 200.0, 60.0, 40.0, (0.6, 1.5)),
}


def _model() -> EnergyModel:
    aw, dw, bw, cw, _ = GAITS["walk"]
    at, dt, bt, ct, _ = GAITS["trot"]
    coefs = {
        "speed": aw, "1": bw, "speed ** 3": cw,
        "(gait == 'trot') * speed": at - aw, "gait == 'trot'": bt - bw,
        "(gait == 'trot') * speed ** 3": ct - cw,
        "(gait == 'trot') * speed * sin(alpha)": dt - dw,
    }  # fmt: skip
    m = EnergyModel(list(coefs), coefs)
    m.metadata = {"fit": {"domain": {
        "speed_m_s": [0.2, 1.5], "max_slope_deg": 30.0, "max_turn_rate_rad_s": 0.6,
        "gaits": {}, "channels": {"gait": ["trot", "walk"]},
        "gait_speed_m_s": {g: list(p[4]) for g, p in GAITS.items()},
    }}}  # fmt: skip
    return m


def _best(slope_rad: float) -> tuple[str, float, float]:
    """The hand-computed best (gait, speed, J per metre) on ground of that slope."""
    out = []
    for g, (a, d, b, c, (lo, hi)) in GAITS.items():
        v = min(max((b / (2 * c)) ** (1 / 3), lo), hi)
        out.append((a + d * math.sin(slope_rad) + b / v + c * v * v, g, v))
    cost, g, v = min(out)
    return g, v, cost


@pytest.mark.parametrize("grade", [0.0, 0.05, 0.3])
def test_each_motion_takes_the_hand_computed_gait_and_speed(grade):
    t = Terrain.from_function(lambda x, y: grade * x, size=(24, 12), resolution=1.0)
    cost = MotionCost(t, _model(), speed_range=(0.2, 1.5))
    x0, y0 = t.grid[0] + 3.0, t.grid[1] - 6.0
    x = np.array([x0, x0 + 10.0])
    y = np.array([y0, y0])
    dt, gaits = cost.best_timing(x, y, np.zeros(2))
    g, v, per_m = _best(math.atan(grade))
    ground = 10.0 * math.hypot(1.0, grade)
    assert gaits == [g]
    assert ground / dt[0] == pytest.approx(v, rel=0.01)
    assert cost(x[0], y[0], 0.0, x[1], y[1], 0.0) == pytest.approx(ground * per_m, rel=0.01)


def test_only_a_cost_that_chooses_its_gait_compiles_the_gait_choice():
    """A model without gaits (or with its gait given) over a speed range keeps the motion
    kernels' module and inputs (none of the gait choice is compiled for it); a model that
    chooses its gait adds the choice after those very kernels."""
    from energy_planner.energy.gait_kernels import gait_source
    from energy_planner.energy.kernels import N_IN, kernel_module, motion_source

    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(8, 8), resolution=1.0)
    for cost in (
        MotionCost(t, EnergyModel.default(), speed_range=(0.2, 1.0)),
        MotionCost(t, _model(), speed_range=(0.2, 1.5), constants={"gait": "trot"}),
    ):
        assert cost.gaits == () and len(cost.data) == N_IN
        assert "gait_best" not in motion_source(cost.source)
        assert cost._kernels() is kernel_module(cost.source)
    chooses = MotionCost(t, _model(), speed_range=(0.2, 1.5))
    assert chooses.gaits == ("trot", "walk") and len(chooses.data) == N_IN + 1
    assert motion_source(chooses.source) in gait_source(chooses.source)
    assert chooses.kernel.py_func.__name__ == "gait_cost"


def test_fixed_gait_channel_keeps_one_gait():
    """The gait given as a channel: no choice (today's behaviour), the range unclipped."""
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(24, 12), resolution=1.0)
    cost = MotionCost(t, _model(), speed_range=(0.2, 1.5), constants={"gait": "trot"})
    assert cost.gaits == ()
    x0, y0 = t.grid[0] + 3.0, t.grid[1] - 6.0
    dt, gaits = cost.best_timing(np.array([x0, x0 + 10]), np.array([y0, y0]), np.zeros(2))
    assert gaits is None
    assert 10.0 / dt[0] == pytest.approx((60.0 / 80.0) ** (1 / 3), rel=0.01)


@pytest.fixture(scope="module")
def two_regimes(tmp_path_factory):
    """Flat for x < 14 m, a 30 % grade beyond (a DEM file): the plan trots, then walks."""
    from rasterio.transform import from_origin

    from energy_planner.io.geotiff import write_geotiff

    d = tmp_path_factory.mktemp("gaits")
    cols = np.arange(30) + 0.5
    z = np.tile(0.3 * np.maximum(cols - 14.0, 0.0), (10, 1))
    dem = write_geotiff(d / "dem.tif", z, transform=from_origin(500000, 5000010, 1, 1),
                        crs="EPSG:32631")  # fmt: skip
    model = d / "m.json"
    _model().save(model)
    p = Problem(ep.open_terrain(dem), _model())
    return p, dem, model


def test_plan_changes_gait_mid_path_and_energy_reads_it_back(two_regimes, tmp_path):
    p, dem, model = two_regimes
    res = ep.plan(p, (500002.5, 5000005.5, 0.0), (500027.5, 5000005.5), speed=(0.2, 1.5),
                  planner="search", progress=False)  # fmt: skip
    walked = [(seg["gait"], seg["speed_m_s"]) for seg in res.speed_profile()
              if seg["speed_m_s"] > 0]  # fmt: skip
    assert walked[0][0] == "trot" and walked[-1][0] == "walk"
    for gait, v in walked:  # each within its gait's logged speeds
        lo, hi = GAITS[gait][4]
        assert lo * 0.999 <= v <= hi * 1.001
    d = res.to_dict()
    assert [seg.get("gait") for seg in d["speed_profile"]] == res.gaits
    # the Python API: the same poses, times and gaits give the plan's energy
    pe = p.path_energy(res.states[:, :2], res.states[:, 2], res.times, segment_gaits=res.gaits)
    assert pe.energy_j == pytest.approx(res.energy_j, rel=1e-3)
    # the CLI: the written GeoJSON carries the gaits, energy --waypoints reads them back
    out = tmp_path / "plan.geojson"
    res.write_geojson(out)
    props = json.loads(out.read_text())["features"][0]["properties"]
    assert props["gait"][:-1] == res.gaits and props["gait"][-1] is None
    run = CliRunner().invoke(main, ["energy", "--dem", str(dem), "--waypoints", str(out),
                                    "--model", str(model), "--json"])  # fmt: skip
    assert run.exit_code == 0, run.output
    assert json.loads(run.stdout)["energy_j"] == pytest.approx(res.energy_j, rel=1e-3)
    # without the gaits the file cannot be priced as planned: a bad gait is named
    props["gait"][0] = "gallop"
    bad = tmp_path / "bad.geojson"
    bad.write_text(
        json.dumps(
            {
                **json.loads(out.read_text()),
                "features": [{**json.loads(out.read_text())["features"][0], "properties": props}],
            }
        )
    )
    run = CliRunner().invoke(main, ["energy", "--dem", str(dem), "--waypoints", str(bad),
                                    "--model", str(model)])  # fmt: skip
    assert run.exit_code != 0 and "gallop" in run.output and "walk" in run.output


def test_mission_legs_carry_their_gaits_as_plan_prices_them(two_regimes):
    """A mission's leg is the plan between its sites: its JSON gives each segment's gait."""
    from energy_planner.mission import Sites

    p, _, _ = two_regimes
    sites = Sites(np.array([[500002.5, 5000005.5], [500027.5, 5000005.5]]), ["flat", "slope"])
    res = ep.mission(p, sites, order="given", speed=(0.2, 1.5), planner="search")
    (leg,) = res.to_dict()["legs"]
    alone = ep.plan(p, (500002.5, 5000005.5), (500027.5, 5000005.5), speed=(0.2, 1.5),
                    planner="search", progress=False)  # fmt: skip
    assert leg["gaits"] == alone.gaits and len(leg["gaits"]) == len(leg["times_s"]) - 1
    assert leg["gaits"][0] == "trot" and leg["gaits"][-1] == "walk"
    assert leg["energy_j"] == pytest.approx(alone.energy_j, rel=1e-6)
