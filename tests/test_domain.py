"""The calibration's domain (issue 20 point 2): what a fit records, the share of a path
outside each recorded range, and plans kept inside it.

Shares are checked against durations worked by hand; the plan on a level plane with a
channel raster is checked by sampling the raster along the planned path (independently
of the planner).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from b1_model import B1, b1_model  # tests/ helper
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.calibration.fit import calibration_domain, heldout_outside_shares
from energy_planner.energy.channels import ChannelRaster, Channels
from energy_planner.model import EnergyModel
from energy_planner.request import Request
from energy_planner.terrain import Terrain
from energy_planner.uncertainty import domain_report, stay_in_domain
from energy_planner.uncertainty.domain import (
    DomainError,
    path_channel_values,
    report_against,
)

DOM = {
    "max_slope_deg": 20.0,
    "speed_m_s": [0.2, 0.4],
    "max_turn_rate_rad_s": 0.5,
    "gaits": {
        "forward": {"windows": 50, "rel_heading_deg": [0.0, 90.0]},
        "turning": {"windows": 9, "rel_heading_deg": None},
    },
    "channels": {"load_kg": [0.0, 5.0], "ground": ["asphalt", "meadow"]},
}


def _segs(**cols):
    n = len(cols["duration_s"])
    base = {"distance_m": 0.3 * np.asarray(cols["duration_s"], float), "turn_deg": np.zeros(n),
            "max_slope_deg": np.full(n, 10.0), "mean_slope_deg": np.full(n, 10.0),
            "mean_rel_heading_deg": np.zeros(n), "gait": ["forward"] * n}  # fmt: skip
    return pd.DataFrame({**base, **cols})


def test_each_quantity_has_its_share():
    # durations 1, 2, 3, 4 s (total 10): each segment breaks one range
    seg = _segs(
        duration_s=[1.0, 2.0, 3.0, 4.0],
        distance_m=[0.3, 2.0 * 0.6, 0.9, 1.2],  # segment 1 at 0.6 m/s: too fast
        max_slope_deg=[25.0, 10.0, 10.0, 10.0],  # segment 0 too steep
        mean_rel_heading_deg=[0.0, 0.0, -150.0, 0.0],  # segment 2 forward facing downhill
        turn_deg=[0.0, 0.0, 0.0, np.degrees(4.0 * 0.8)],  # segment 3 turns at 0.8 rad/s
    )
    rep = report_against(DOM, seg)
    assert rep["shares"] == {"slope": 0.1, "gait": 0.0, "relative_heading": 0.3,
                             "speed": 0.2, "turning_rate": 0.4}  # fmt: skip
    assert rep["outside_share"] == 1.0


def test_gait_and_channels():
    seg = _segs(duration_s=[1.0, 1.0, 2.0], gait=["forward", "lateral", "forward"])
    rep = report_against(
        DOM, seg, {"ground": "gravel"}, channel_values={"load_kg": [1.0, 2.0, 7.0]}
    )
    assert rep["shares"]["gait"] == 0.25
    assert rep["shares"]["channel load_kg"] == 0.5
    assert rep["shares"]["channel ground"] == 1.0  # a category the logs never had
    rep = report_against(DOM, seg, {"ground": "meadow"}, channel_values={"load_kg": [1, 2, 3]})
    assert rep["shares"]["channel ground"] == 0.0 and rep["shares"]["channel load_kg"] == 0.0


@settings(max_examples=40, deadline=None)
@given(gamma=st.floats(-180.0, 180.0), slope=st.floats(0.0, 19.0))
def test_relative_heading_is_checked_on_sloped_ground_only(gamma, slope):
    seg = _segs(duration_s=[5.0], mean_rel_heading_deg=[gamma], mean_slope_deg=[slope],
                max_slope_deg=[slope])  # fmt: skip
    share = report_against(DOM, seg)["shares"]["relative_heading"]
    outside = slope > 3.0 and abs(gamma) > 92.0
    assert share == (1.0 if outside else 0.0)


def _table(alpha_deg, gamma_deg, kind, load):
    n = len(alpha_deg)
    return pd.DataFrame(
        {
            "run": [f"r{i % 4}" for i in range(n)],
            "alpha": np.radians(alpha_deg),
            "gamma": np.radians(gamma_deg),
            "kind": kind,
            "speed": np.full(n, 0.3),
            "wz": np.zeros(n),
            "duration": np.full(n, 2.0),
            "load_kg": load,
        }
    )


def test_fit_records_each_quantity():
    """calibration_domain of hand-made windows: the relative heading of a gait comes
    from its windows on slopes only (level ground has no heading)."""
    m = b1_model(dict(B1), extra={"load_kg * speed": 5.0})
    t = _table([0.0, 10.0, 12.0, 0.0, 8.0], [170.0, 20.0, -60.0, 10.0, 100.0],
               ["forward", "forward", "forward", "lateral", "lateral"],
               [0.0, 2.0, 4.0, 1.0, 3.0])  # fmt: skip
    dom = calibration_domain(t, m)
    assert dom["max_slope_deg"] == pytest.approx(12.0)
    assert dom["gaits"]["forward"]["rel_heading_deg"] == [20.0, 60.0]
    assert dom["gaits"]["lateral"]["rel_heading_deg"] == [100.0, 100.0]
    assert dom["channels"]["load_kg"] == [0.0, 4.0]
    assert dom["speed_m_s"] == [0.3, 0.3] and dom["max_turn_rate_rad_s"] == 0.0


def test_heldout_runs_are_judged_against_their_folds_domain():
    """Run r3 carries 9 kg; the other folds saw 1-2 kg: r3 is wholly outside, the others
    inside (each within the range of the other three)."""
    m = b1_model(dict(B1), extra={"load_kg * speed": 5.0})
    t = _table([5.0] * 8, [0.0] * 8, ["forward"] * 8, [1.0, 1.0, 2.0, 9.0] * 2)
    fold = np.array([int(r[1]) for r in t["run"]])
    share = heldout_outside_shares(t, m, fold)
    assert share["r3"] == 1.0 and share[["r0", "r1"]].eq(0.0).all()


# ------------------------------------------------------------------ planning in the domain
N = 40
X0, Y0 = 500000.0, 5000000.0


def _load_raster():
    """0 kg everywhere but a wall of 9 kg across x = 28-32 m, open for y in 28-36 m."""
    v = np.zeros((N, N))
    rows_y = Y0 + N - 0.5 - np.arange(N)  # row 0 is north
    cols_x = np.arange(N) + 0.5
    wall = (cols_x >= 28) & (cols_x <= 32)
    gap = (rows_y >= Y0 + 28) & (rows_y <= Y0 + 36)
    v[np.ix_(~gap, wall)] = 9.0
    return v


def _domain_model():
    m = b1_model(dict(B1), extra={"load_kg * speed": 5.0})  # the 5 kg model other tests compile
    return EnergyModel(m.terms, m.coefficients, metadata={"fit": {"domain": DOM}})


def test_stay_in_domain_on_a_plane_with_a_channel_raster():
    import energy_planner as ep

    flat = Terrain.from_array(np.full((N, N), 10.0), origin=(X0, Y0))
    model = _domain_model()
    ch = Channels(rasters={"load_kg": ChannelRaster("load_kg", values=_load_raster())})
    req = Request.make(speed=0.6, yaw_rate=1.0, channels=ch)
    inside, notes = stay_in_domain(req, model, flat)
    assert inside.robot.speed == 0.4 and inside.robot.yaw_rate == 0.5
    assert inside.limits.max_crab_deg == 45.0 and inside.limits.max_backward_slope_deg == 0.0
    assert inside.limits.max_slope_deg == 20.0
    assert any("clamped" in n for n in notes) and any("impassable" in n for n in notes)
    start, goal = (X0 + 18.0, Y0 + 12.0), (X0 + 38.0, Y0 + 12.0)
    loads = {}
    for name, r in (("free", req), ("inside", inside)):
        res = ep.plan(ep.Problem(flat, model, r), start, goal, step=2.0)
        along = path_channel_values(flat, ch.bind(flat), res.states)["load_kg"]
        loads[name] = np.concatenate(along)
    assert loads["free"].max() == 9.0  # the straight route crosses the wall
    assert loads["inside"].max() == 0.0  # kept inside: through the gap


def test_stay_in_domain_refuses_a_constant_outside_and_a_model_without_domain():
    model = _domain_model()
    req = Request.make(channels=Channels({"load_kg": 8.0}))
    with pytest.raises(DomainError, match="load_kg = 8"):
        stay_in_domain(req, model)
    with pytest.raises(DomainError, match="records no calibration domain"):
        stay_in_domain(Request.make(), EnergyModel(["idle_power"], {"idle_power": 1.0}))


def test_energy_reports_a_raster_channel_outside():
    from energy_planner.energy import path_energy

    flat = Terrain.from_array(np.full((N, N), 10.0), origin=(X0, Y0))
    model = _domain_model()
    ch = Channels(rasters={"load_kg": ChannelRaster("load_kg", values=_load_raster())})
    xy = [[X0 + 5.0, Y0 + 15.5], [X0 + 35.0, Y0 + 15.5]]
    pe = path_energy(flat, model, xy, channels=ch)
    along = path_channel_values(flat, ch.bind(flat), pe.poses)
    rep = domain_report(model, pe.segments, None, pe.poses, along)
    # 30 m, 4 of them in the wall (the cells centred at x = 28.5-31.5 m), sampled every
    # half metre
    assert rep["shares"]["channel load_kg"] == pytest.approx(4.0 / 30.0, abs=0.02)
