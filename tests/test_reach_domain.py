"""A reach map's calibration domain: each cell's report is its least-energy path's.

Checked against ``path_domain`` of the path ``plan`` (the lattice planner, the same motions
and the same search) finds to a cell, priced by ``path_energy`` and cut back into its
lattice motions (``plan`` merges a straight run into one segment, whose per-metre samples
then fall elsewhere); against planes whose slope is known (every path wholly outside, or
wholly inside); and against a band of steep slope that every path beyond it crosses.
A channel constant outside the logs' range and a mean power beyond the runs' (worked out
by ``path_energy`` of the straight walk to the cell) put the cells outside and leave them
without a battery decision.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import energy_planner as ep
from energy_planner.energy import path_energy
from energy_planner.model import EnergyModel
from energy_planner.terrain import Terrain
from energy_planner.uncertainty.domain import path_domain
from energy_planner.uncertainty.errormodel import ErrorModel

#: every gait, any turning rate and heading: only the slope (and what a test adds) limits
ALL_GAITS = {g: {"windows": 9, "rel_heading_deg": None}
             for g in ("forward", "backward", "lateral", "turning")}  # fmt: skip


def _with_domain(model: EnergyModel, error_model: ErrorModel | None = None, **dom) -> EnergyModel:
    d = {"max_slope_deg": 15.0, "max_turn_rate_rad_s": 10.0, "gaits": ALL_GAITS, **dom}
    fit = dict(model.metadata.get("fit") or {}, domain=d)
    if error_model is not None:  # with the relative run errors confident_budget reads
        fit["error_model"] = error_model.to_dict()
        fit["heldout_run_rel_errors"] = np.linspace(-0.03, 0.03, 199).tolist()
    model.metadata = dict(model.metadata, fit=fit)
    return model


def _lattice_motions(states: np.ndarray, step: float) -> np.ndarray:
    """A lattice path's poses with each merged straight run cut back into its moves."""
    out = [states[0]]
    for a, b in zip(states[:-1], states[1:], strict=True):
        k = np.rint((b[:2] - a[:2]) / step).astype(int)
        n = max(math.gcd(abs(int(k[0])), abs(int(k[1]))), 1)
        out += [np.r_[a[:2] + (b[:2] - a[:2]) * s / n, b[2]] for s in range(1, n + 1)]
    return np.array(out)


def _hill(x, y):
    return 5.0 * np.exp(-((x - 17.0) ** 2 + (y - 14.0) ** 2) / (2 * 5.0**2)) + 0.05 * x


def test_a_cells_report_is_path_domain_of_the_plan_to_it():
    t = Terrain.from_function(_hill, size=(30, 30))
    m = _with_domain(EnergyModel.default(), speed_m_s=[0.2, 0.45],
                     gaits={"forward": {"windows": 9, "rel_heading_deg": [0.0, 120.0]},
                            "turning": {"windows": 3, "rel_heading_deg": None}})  # fmt: skip
    prob = ep.Problem(t, m)
    res = ep.reach(prob, (5.5, 5.5))
    x0, y0, dx, dy = t.grid
    # behind the hill, past its flank, and in the open (no slope beyond 15 deg on the way)
    cells = [(5, 25), (20, 20), (12, 27)]
    seen = []
    for r, c in cells:
        p = ep.plan(prob, res.start, (x0 + c * dx, y0 + r * dy), planner="lattice", step=1.0)
        st = _lattice_motions(p.states, 1.0)
        pe = path_energy(t, m, st[:, :2], yaw=st[:, 2], cost=prob.cost)
        assert pe.energy_j == pytest.approx(res.energy_j[r, c], rel=1e-6)  # the same path
        rep = path_domain(m, t, pe, prob.cost.channels)
        # path_domain rounds: metres to 3 decimals, shares to 4, excesses to 6
        assert res.outside_m[r, c] == pytest.approx(rep["outside_m"], rel=1e-6, abs=5e-4)
        assert res.outside_share[r, c] == pytest.approx(rep["outside_share"], abs=5e-5)
        for q, v in rep["shares"].items():
            assert res.shares[q][r, c] == pytest.approx(v, abs=5e-5), q
        for q, v in rep["excess"].items():
            assert res.excess[q][r, c] == pytest.approx(v, abs=5e-7), q
        seen.append(rep["outside_m"])
    assert seen[0] > 1.0 and seen[1] > 1.0 and seen[2] == 0.0
    d = res.to_dict()["domain"]
    assert d["reached_cells"] == int(np.isfinite(res.energy_j).sum())
    assert d["outside_cells"] == int((res.outside_share > 0).sum()) > 0
    assert d["quantities"]["slope"] == d["reasons"]["slope above 15 deg"]


@pytest.mark.parametrize("round_trip", [False, True])
def test_planes_steeper_than_the_domain_and_inside_it(round_trip):
    size = (13, 11)
    steep = Terrain.from_function(lambda x, y: math.tan(math.radians(20.0)) * x, size=size)
    gentle = Terrain.from_function(lambda x, y: math.tan(math.radians(5.0)) * x, size=size)
    m = _with_domain(EnergyModel.default())
    for t, want in ((steep, 1.0), (gentle, 0.0)):
        res = ep.reach(t, (6.5, 5.5), model=m, return_to_start=round_trip)
        reached = np.isfinite(res.energy_j)
        share = res.outside_share[reached]
        start = res.energy_j[reached] == 0.0  # a path of no motion has no share
        assert start.sum() == 1 and share[start] == 0.0
        np.testing.assert_allclose(share[~start], want, atol=1e-12)
        assert np.all(np.isnan(res.outside_share[~reached]))
        if want:
            # beyond the range by the plane's own slope, on every metre
            exc = res.excess["slope"][reached][~start]
            np.testing.assert_allclose(exc, 20.0 - 15.0, atol=1e-6)


def _band(x, y):
    """Level, then 26.6 deg up between x = 10 and 14 m, then level again."""
    return 0.5 * np.clip(x - 10.0, 0.0, 4.0)


def test_a_steep_band_puts_only_the_cells_beyond_it_outside():
    t = Terrain.from_function(_band, size=(24, 9))
    res = ep.reach(t, (3.5, 4.5), model=_with_domain(EnergyModel.default()))
    x0, _, dx, _ = t.grid
    xc = x0 + dx * np.arange(t.shape[1])
    share = res.outside_share
    before, beyond = xc < 9.0, xc > 15.0
    ok = np.isfinite(share)
    assert np.all(share[:, before][ok[:, before]] == 0.0)
    assert np.all(share[:, beyond][ok[:, beyond]] > 0.0)
    # every path beyond climbs the band: at least its 4 m of map (4.5 m of ground) outside
    assert np.nanmin(res.outside_m[:, beyond]) >= 4.0


def _load_model(error_model: ErrorModel, **dom) -> EnergyModel:
    """Level walking at 600 N plus 7 W per kg and m/s: tests/test_channel_values.py's
    model, whose kernels the suite compiles once."""
    from b1_model import B1, b1_model  # tests/ helper

    m = b1_model(dict.fromkeys(B1, 0.0) | {"fwd_const": 600.0}, extra={"load_kg * speed": 7.0})
    return _with_domain(m, error_model, channels={"load_kg": [0.0, 10.0]}, **dom)


#: sigma = 2 % of the energy, the outside term not fitted (d None), no growth measured
EM = ErrorModel(0.0, 4e-4, 0.0, None, np.linspace(-1.645, 1.645, 199), 100.0)


def test_a_channel_constant_outside_the_logs_puts_every_cell_outside_and_refuses_them():
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(12, 10))
    m = _load_model(EM)
    battery = {"battery_wh": 50.0, "reserve_wh": 1.0}
    inside = ep.reach(t, (5.5, 4.5), model=m, channels={"load_kg": 5.0}, **battery)
    out = ep.reach(t, (5.5, 4.5), model=m, channels={"load_kg": 20.0}, **battery)
    reached = np.isfinite(out.energy_j)
    moved = reached & (out.energy_j > 0)
    assert np.all(out.outside_share[moved] == 1.0)
    assert np.all(out.excess["channel load_kg"][moved] == pytest.approx(10.0))
    assert np.all(inside.outside_share[reached] == 0.0)
    # no battery decision where the growth beyond the range was never measured
    chance = out.chance(m, out.battery["usable_wh"] * 3600.0)
    assert np.all(np.isnan(chance[moved])) and np.all(np.isfinite(inside.chance(m, 1e5)[reached]))
    b = out.battery
    assert b["refused_cells"] == int(moved.sum()) and b["cells"] == 1  # the start only
    (why,) = b["refused"]
    assert why.startswith("channel load_kg:") and b["refused"][why] == b["refused_cells"]
    assert inside.battery["refused_cells"] == 0 and inside.battery["cells"] == reached.sum()


def test_a_path_above_the_runs_mean_power_is_outside_by_mean_power_and_refused():
    """Up a 10 deg plane the robot works harder than down it: the runs' range is put
    between the two mean powers (each the straight walk's energy over its duration, by
    ``path_energy`` at the body yaw of least energy), so the cells east of the start
    (uphill) lie above it."""
    from energy_planner.planning.lattice import lattice_headings

    slope = math.tan(math.radians(10.0))
    t = Terrain.from_function(lambda x, y: slope * x, size=(21, 7))
    s = (10.5, 3.5)
    base = EnergyModel.default()

    def walk(dx: float):  # the straight walk at its cheapest yaw (crabbing uphill)
        legs = [path_energy(t, base, [s, (s[0] + dx, s[1])], yaw=[h, h])
                for h in lattice_headings(16)]  # fmt: skip
        return min(legs, key=lambda pe: pe.energy_j)

    up, down = walk(6.0), walk(-6.0)
    p_up, p_down = up.energy_j / up.duration_s, down.energy_j / down.duration_s
    assert p_up > 1.2 * p_down
    m = _with_domain(EnergyModel.default(), EM, max_slope_deg=30.0,
                     mean_power_w=[0.5 * p_down, 0.5 * (p_up + p_down)])  # fmt: skip
    res = ep.reach(t, s, model=m, battery_wh=50.0)
    r = 3  # the start's row
    assert res.energy_j[r, 16] == pytest.approx(up.energy_j, rel=1e-6)  # the same walk
    east, west = slice(12, 18), slice(4, 10)
    assert np.all(res.shares["mean_power"][r, east] == 1.0)
    assert np.all(res.outside_share[r, east] == 1.0)
    assert np.all(res.shares["mean_power"][r, west] == 0.0)
    assert res.excess["mean_power"][r, 16] == pytest.approx(p_up - 0.5 * (p_up + p_down),
                                                            rel=1e-6)  # fmt: skip
    chance = res.chance(m, 50.0 * 3600.0)
    assert np.all(np.isnan(chance[r, east])) and np.all(chance[r, west] > 0.9)
    why = [k for k in res.battery["refused"] if k.startswith("mean_power")]
    assert why and res.battery["refused"][why[0]] >= 6
    # the area the battery's GeoJSON draws is the cells decided with the chance required
    sure = chance >= 0.9
    assert res.battery["cells"] == int(sure.sum()) > 0
    props = res.area_geojson()["features"][0]["properties"]
    assert props["cells"] == res.battery["cells"] and props["area_m2"] == res.battery["area_m2"]


@pytest.mark.parametrize("with_error_model", [True, False])
def test_each_cells_interval_is_predict_interval_of_its_path(with_error_model):
    """Every reached cell's interval is the one ``predict_interval`` gives its path (the
    scalar door, from the cell's energy, duration and domain report), and holds the cell's
    own estimate; across the steep band the measured growth of the slope widens it."""
    from energy_planner.uncertainty import predict_interval

    t = Terrain.from_function(_band, size=(24, 9))
    em = ErrorModel(0.0, 4e-4, 0.0, None, np.linspace(-1.645, 1.645, 199), 100.0,
                    extrapolation={"slope": {"growth_per_unit": 0.01}})  # fmt: skip
    m = _with_domain(EnergyModel.default(), em if with_error_model else None)
    if not with_error_model:
        m.metadata["fit"]["heldout_run_rel_errors"] = np.linspace(-0.03, 0.03, 199).tolist()
    res = ep.reach(t, (3.5, 4.5), model=m)
    low, high = res.interval(0.9)
    reached = np.isfinite(res.energy_j)
    assert np.all(np.isnan(low[~reached])) and np.all(np.isnan(high[~reached]))
    e = res.energy_j[reached]
    assert np.all(low[reached] <= e) and np.all(e <= high[reached])
    beyond = reached & (res.outside_share > 0)
    assert beyond.sum() > 10
    for r, c in [*np.argwhere(beyond)[::7], *np.argwhere(reached & ~beyond)[::7]]:
        dom = {"outside_share": float(res.outside_share[r, c]),
               "shares": {q: float(v[r, c]) for q, v in res.shares.items()},
               "excess": {q: float(v[r, c]) for q, v in res.excess.items()}}  # fmt: skip
        iv = predict_interval(m, float(res.energy_j[r, c]), 0.9,
                              duration_s=float(res.duration_s[r, c]), domain=dom)  # fmt: skip
        assert (low[r, c], high[r, c]) == pytest.approx((iv.low_j, iv.high_j), rel=1e-12)
    # the widening grows with the metres beyond: relative half-width beyond > before
    moved = reached & (res.energy_j > 0)
    rel = np.full(low.shape, np.nan)
    rel[moved] = (high - low)[moved] / res.energy_j[moved]
    assert np.nanmin(rel[beyond]) > np.nanmax(rel[moved & ~beyond])
