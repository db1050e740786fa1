"""Energy intervals and battery chances (``energy_planner.uncertainty``).

The coverage check is independent of the model's formulas: the model is fitted on one
simulated campaign (whose truth is mechanistic physics), its interval is calibrated on
that campaign's held-out runs, and the interval is then scored on the runs of a fresh
campaign (another seed: other noise, other sensor faults) that neither fit nor
calibration saw.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.calibration import fit_model
from energy_planner.calibration._windows import window_energy
from energy_planner.calibration.fit import model_features
from energy_planner.cli import main
from energy_planner.measurements import make_windows, preprocess
from energy_planner.model import EnergyModel
from energy_planner.simulate import CampaignConfig, simulate_campaign
from energy_planner.uncertainty import (
    BatteryError,
    battery_decision,
    interval,
    model_scores,
    predict_interval,
    success_probability,
)

CAMPAIGN = CampaignConfig.small(
    slopes_deg=(0.0, 8.0, 16.0, 24.0),
    headings_deg=(0.0, 45.0, 90.0, 135.0, 180.0, -135.0, -90.0, -45.0),
    run_s=10.0,
)


def _windows(seed):
    clean, _ = preprocess(simulate_campaign(seed=seed, config=CAMPAIGN).logs)
    return make_windows(clean, duration=2.0)


def test_interval_covers_fresh_runs_at_its_level():
    fit = fit_model(_windows(0), n_splits=5, seed=0)
    model = fit.model
    scores = model_scores(model)
    assert scores is not None and scores.size == fit.n_runs
    fresh = _windows(1)
    s = fresh.samples
    pred = model.power(model_features(s, model))
    win = pd.DataFrame({"measured": window_energy(s), "predicted": window_energy(s, pred)})
    win["duration"] = fresh.table.set_index("window")["duration"].reindex(win.index)
    run_of = s.groupby("window")["run"].first()
    per_run = win.groupby(run_of.reindex(win.index).to_numpy()).sum()
    assert len(per_run) > 80
    # the fit's run-to-run error model is calibrated on its held-out runs
    em = model.metadata["fit"]["error_model"]
    assert len(em["scores"]) == fit.n_runs and em["b"] + em["c_j2_per_s"] > 0
    for level in (0.8, 0.9):
        inside = [
            (iv := predict_interval(model, p, level, duration_s=t)).low_j <= m <= iv.high_j
            for p, m, t in zip(
                per_run["predicted"], per_run["measured"], per_run["duration"], strict=True
            )
        ]
        cov = float(np.mean(inside))
        print(f"coverage at {level}: {cov:.3f} over {len(inside)} fresh runs")
        assert level - 0.1 <= cov <= min(level + 0.08, 1.0), (level, cov)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-0.3, 0.3), min_size=5, max_size=200),
    st.floats(100.0, 1e6),
    st.floats(0.05, 0.95),
)
def test_interval_and_chance_properties(scores, energy, level):
    s = np.asarray(scores)
    iv = interval(energy, s, level)
    assert iv.low_j <= iv.high_j
    wider = interval(energy, s, min(level + 0.04, 0.99))
    assert wider.low_j <= iv.low_j and wider.high_j >= iv.high_j
    # the chance grows with the battery and reaches its most at the interval's top
    u = np.linspace(0.5 * energy, 2.0 * energy, 7)
    p = [success_probability(energy, s, x) for x in u]
    assert all(a <= b for a, b in zip(p, p[1:], strict=False))
    assert success_probability(energy, s, iv.high_j) == pytest.approx(
        np.count_nonzero(energy / (1 + s) <= iv.high_j) / (s.size + 1)
    )


def test_chance_is_a_half_at_the_median_of_symmetric_errors():
    s = np.linspace(-0.05, 0.05, 1001)
    assert success_probability(1000.0, s, 1000.0) == pytest.approx(0.5, abs=0.002)


def test_battery_decision_and_errors():
    m = EnergyModel.default()
    d = battery_decision(m, 3600.0 * 10, battery_wh=20, reserve_wh=2, confidence=0.9)
    assert d.ok and d.probability > 0.99
    d = battery_decision(m, 3600.0 * 10, battery_wh=10.05, confidence=0.9)
    assert not d.ok and 0 < d.probability < 0.9
    with pytest.raises(BatteryError):
        battery_decision(m, 1.0, battery_wh=1, reserve_wh=2)
    bare = EnergyModel.from_dict({**m.to_dict(), "metadata": {}})
    assert predict_interval(bare, 10.0) is None
    with pytest.raises(BatteryError, match="cross-validation"):
        battery_decision(bare, 1.0, battery_wh=1)


def test_cli_energy_prints_interval_and_battery_chance(tmp_path):
    wp = tmp_path / "w.csv"
    wp.write_text("x,y\n500010,5000050\n500090,5000050\n")
    r = CliRunner().invoke(main, ["energy", "--dem", "maps/plane.tif", "--waypoints", str(wp),
                                  "--battery-wh", "100", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout[r.stdout.index("{") :])
    iv = out["interval"]
    assert iv["low_j"] < out["energy_j"] < iv["high_j"] and iv["level"] == 0.9
    assert out["battery"]["probability"] > 0.9 and out["battery"]["ok"]
    # a battery far too small is refused with --refuse
    r = CliRunner().invoke(main, ["energy", "--dem", "maps/plane.tif", "--waypoints", str(wp),
                                  "--battery-wh", "1", "--refuse"])  # fmt: skip
    assert r.exit_code == 1 and "chance" in r.output


def test_reach_with_confidence_on_a_level_plane(tmp_path):
    """On level ground a straight walk costs c J/m (priced independently by path_energy),
    so the cells east of the start reached with chance p are those within
    confident_budget / c metres."""
    from energy_planner.energy import path_energy
    from energy_planner.planning.reach import reach
    from energy_planner.terrain import Terrain
    from energy_planner.uncertainty import confident_budget

    flat = Terrain.from_array(np.zeros((41, 61)), resolution=1.0)
    m = EnergyModel.default()
    x0, y0 = flat.grid[0], flat.grid[1]
    start = (x0 + 5.0, y0 - 20.0)
    c = path_energy(flat, m, np.array([start, (start[0] + 20.0, start[1])])).energy_j / 20.0
    rm = reach(flat, m, start)
    usable = 40.0 * c  # 40 m of walking
    budget = confident_budget(m, usable, 0.9)
    assert budget < usable  # 90 % sure needs a margin below the point estimate
    east = rm.energy_j[20, 5:-1]  # the start's row, going east (the edge cell has no slope)
    reached = np.nonzero(rm.mask(budget)[20, 5:])[0]
    assert abs(reached.max() - budget / c) <= 1.0
    chance = rm.chance(m, usable)
    np.testing.assert_array_equal(chance >= 0.9, rm.mask(budget) & np.isfinite(chance))
    assert np.all(np.diff(chance[20, 5:-1]) <= 1e-12) and np.all(np.diff(east) > 0)
    out = rm.write_chance_geotiff(flat, tmp_path / "chance.tif", m, usable)
    import rasterio

    with rasterio.open(out) as src:
        assert src.units == ("1",) and np.nanmax(src.read(1)) <= 1.0


def test_cli_reach_battery_confidence(tmp_path):
    r = CliRunner().invoke(main, ["reach", "maps/plane.tif", "--start", "500050,5000050",
                                  "--battery-wh", "5", "--reserve-wh", "1", "--confidence",
                                  "0.95", "--geojson", str(tmp_path / "a.geojson"),
                                  "--chance-out", str(tmp_path / "c.tif"), "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout[r.stdout.index("{") :])
    b = out["battery"]
    assert b["confident_budget_wh"] < b["usable_wh"] == 4.0 and b["cells"] > 100
    doc = json.loads((tmp_path / "a.geojson").read_text())
    assert "crs" not in doc and doc["features"][0]["properties"]["cells"] == b["cells"]
