"""A path whose predicted mean power lies above every calibration run's (issue 28 point 3).

Each quantity of such a path (slope, speed, load) may lie inside its range while their
combination, heavy and steep uphill, lies beyond every run the model and its error model
saw; the fit cannot measure how the error grows there. The domain report counts it as the
quantity ``mean_power``: the interval widens by the assumed factor ``1 + share`` (here
share 1: sigma x 2) whatever the fitted outside term ``d`` is, it says it is not
calibrated, and no battery decision is given.

Checked by hand: the path's mean power is its segments' energy over their duration
(worked out below), the recorded range is written in the domain, and the widening is the
ratio of two intervals of the same error model (exactly 2 with sigma's assumed factor).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from energy_planner.model import EnergyModel
from energy_planner.uncertainty import conformal_bounds, path_trust, predict_interval
from energy_planner.uncertainty.assess import sum_domain
from energy_planner.uncertainty.domain import report_against
from energy_planner.uncertainty.errormodel import ErrorModel

#: every other quantity inside: 10 deg slopes, 0.3 m/s, no turning, forward
DOM = {
    "max_slope_deg": 20.0,
    "speed_m_s": [0.2, 0.4],
    "max_turn_rate_rad_s": 0.5,
    "gaits": {"forward": {"windows": 50, "rel_heading_deg": [0.0, 90.0]}},
    "channels": {},
    "mean_power_w": [150.0, 400.0],
}


def _segs(mean_power_w: float) -> pd.DataFrame:
    """Four segments of 1, 2, 3, 4 s (10 s) at 0.3 m/s whose energies sum to 10 P.

    Their powers are in the ratio 0.5 : 1 : 1 : 1.25 (the energies then scaled to sum to
    10 P): the mean is the energy over the duration, not the mean of the segments' powers.
    """
    dur = np.array([1.0, 2.0, 3.0, 4.0])
    rel = np.array([0.5, 1.0, 1.0, 1.25]) * dur  # sums to 10.5
    energy = rel / rel.sum() * 10.0 * mean_power_w
    n = dur.size
    return pd.DataFrame({"energy_j": energy, "duration_s": dur, "distance_m": 0.3 * dur,
                         "turn_deg": np.zeros(n), "max_slope_deg": np.full(n, 10.0),
                         "mean_slope_deg": np.full(n, 10.0),
                         "mean_rel_heading_deg": np.zeros(n),
                         "gait": ["forward"] * n})  # fmt: skip


Z = np.linspace(-1.645, 1.645, 199)
#: the interval's upper bound over sigma: minus the lower conformal order statistic of Z
Z_HI = -conformal_bounds(Z, 0.9)[0]


def _error_model(d: float | None) -> ErrorModel:
    """sigma = 1 % of E (b = 1e-4, no noise term), scores Z."""
    return ErrorModel(0.0, 1e-4, 0.0, d, Z, 250.0)


def _model(dom: dict, d: float | None = 0.0) -> EnergyModel:
    fit = {"domain": dom, "error_model": _error_model(d).to_dict()}
    return EnergyModel(["idle_power"], {"idle_power": 100.0}, metadata={"fit": fit})


@pytest.mark.parametrize("d", [0.0, None, 0.5])
def test_just_above_the_recorded_max_is_outside_and_refused_just_below_is_inside(d):
    m = _model(DOM, d)
    above, below = 400.0 * (1 + 1e-6), 400.0 * (1 - 1e-6)
    rep_a = report_against(DOM, _segs(above))
    rep_b = report_against(DOM, _segs(below))
    assert rep_a["mean_power_w"] == pytest.approx(above, abs=1e-3)
    assert rep_a["shares"]["mean_power"] == 1.0 and rep_a["outside_share"] == 1.0
    assert rep_b["shares"]["mean_power"] == 0.0 and rep_b["outside_share"] == 0.0
    (why,) = rep_a["reasons"]
    assert "mean power 400 W above every calibration run's (150-400 W)" in why
    assert "log runs at that power" in why
    e, t = 10.0 * above, 10.0
    inside = path_trust(m, e, t, rep_b, battery_wh=2 * e / 3600)
    outside = path_trust(m, e, t, rep_a, battery_wh=2 * e / 3600)
    # inside: sigma = 1 % of E, the bound E + Z_HI sigma; a battery decision given
    assert inside.interval.high_j - e == pytest.approx(Z_HI * 0.01 * e, rel=1e-9)
    assert inside.interval.calibrated and inside.battery is not None
    # above: sigma x (1 + 1) whatever d is (d = 0 would not widen at all through d)
    ratio = (outside.interval.high_j - outside.interval.low_j) / (
        inside.interval.high_j - inside.interval.low_j
    )
    assert ratio == pytest.approx(2.0, rel=1e-9)
    assert not outside.interval.calibrated
    (nc,) = outside.interval.not_calibrated
    assert nc.startswith("mean_power: the path's mean power 400 W lies above every "
                         "calibration run's (150-400 W)")  # fmt: skip
    assert outside.battery is None and "no battery decision" in outside.battery_refused
    assert "mean_power" in outside.battery_refused
    # the result objects' JSON carries the same
    js = json.loads(json.dumps(outside.to_dict()))
    assert js["battery"] is None and js["interval"]["calibrated"] is False
    assert js["domain"]["shares"]["mean_power"] == 1.0


def test_with_another_quantity_outside_the_larger_share_widens():
    """Slope outside on 40 % of the path (no measured growth, d not fitted: sigma x 1.4)
    and the mean power above (x 2): the larger, as for several quantities without growth."""
    m = _model(DOM, None)
    seg = _segs(500.0)
    seg.loc[[0, 2], "max_slope_deg"] = 25.0  # 1 + 3 s of 10 s
    rep = report_against(DOM, seg)
    assert rep["shares"]["slope"] == 0.4 and rep["shares"]["mean_power"] == 1.0
    iv = predict_interval(m, 5000.0, duration_s=10.0, domain=rep)
    assert iv.high_j - 5000.0 == pytest.approx(2 * Z_HI * 50.0, rel=1e-9)
    assert [q.split(":")[0] for q in iv.not_calibrated] == ["slope", "mean_power"]
    # only the slope: sigma x 1.4, and without d not calibrated either
    rep_s = report_against({**DOM, "mean_power_w": [150.0, 600.0]}, seg)
    iv_s = predict_interval(m, 5000.0, duration_s=10.0, domain=rep_s)
    assert iv_s.high_j - 5000.0 == pytest.approx(1.4 * Z_HI * 50.0, rel=1e-9)


def test_an_old_model_file_without_the_runs_power_checks_nothing_and_says_nothing(tmp_path):
    old_dom = {k: v for k, v in DOM.items() if k != "mean_power_w"}
    _model(old_dom).save(tmp_path / "old.json")
    m = EnergyModel.load(tmp_path / "old.json")
    rep = report_against(m.metadata["fit"]["domain"], _segs(900.0))
    assert "mean_power" not in rep["shares"] and "mean_power_w" not in rep
    assert rep["outside_share"] == 0.0 and rep["reasons"] == {}
    t = path_trust(m, 9000.0, 10.0, rep, battery_wh=5.0)
    assert t.interval.calibrated and t.battery is not None
    assert t.interval.high_j - 9000.0 == pytest.approx(Z_HI * 90.0, rel=1e-9)
    # calibration windows (no energy per segment) are not checked either
    assert "mean_power" not in report_against(DOM, _segs(900.0).drop(columns="energy_j"))["shares"]


def test_a_mission_of_legs_reports_its_whole_mean_power():
    """Two legs of 10 s: one at 300 W (inside), one at 500 W (above): the whole mission's
    mean power is 400 W and half its duration lies beyond."""
    legs = [(report_against(DOM, _segs(p)), 10.0) for p in (300.0, 500.0)]
    whole = sum_domain(legs)
    assert whole["mean_power_w"] == pytest.approx(400.0)
    assert whole["shares"]["mean_power"] == 0.5


# ------------------------------------------------------------------ at the doors
def _hill_model(tmp_path, power_range):
    """The bundled model with a domain that the hill leaves by its mean power only, and an
    error model (d = 0 fitted: through d the path would not widen at all)."""
    import energy_planner as ep

    m = ep.load_model()
    dom = {"max_slope_deg": 60.0, "speed_m_s": [0.1, 1.0], "max_turn_rate_rad_s": 5.0,
           "gaits": {"forward": {"windows": 9, "rel_heading_deg": [0.0, 180.0]},
                     "turning": {"windows": 9, "rel_heading_deg": None}},
           "mean_power_w": list(power_range)}  # fmt: skip
    fit = dict(m.metadata.get("fit") or {}, domain=dom, error_model=_error_model(0.0).to_dict())
    m.metadata = dict(m.metadata, fit=fit)
    return m.save(tmp_path / f"m{power_range[1]:.0f}.json")


def test_the_energy_command_and_the_python_result_refuse_above_the_runs_power(tmp_path):
    from click.testing import CliRunner

    import energy_planner as ep
    from energy_planner.cli import main
    from energy_planner.cli.options import _jsonable

    pts = [(500058.0, 5000046.0), (500058.0, 5000062.0), (500066.0, 5000066.0)]
    wp = tmp_path / "wp.csv"
    wp.write_text("x,y\n" + "\n".join(f"{x},{y}" for x, y in pts) + "\n")
    p = ep.path_energy(ep.map_path("hill"), pts).energy_j
    p /= ep.path_energy(ep.map_path("hill"), pts).duration_s
    for top, above in ((0.999 * p, True), (1.001 * p, False)):
        mf = _hill_model(tmp_path, (0.5 * p, top))
        pe = ep.path_energy(ep.map_path("hill"), pts, model=mf, battery_wh=10.0)
        d = _jsonable(pe.to_dict())
        assert d["domain"]["mean_power_w"] == pytest.approx(p, abs=1e-3)
        assert d["domain"]["shares"]["mean_power"] == (1.0 if above else 0.0)
        assert (d["battery"] is None) == above and d["interval"]["calibrated"] is not above
        res = CliRunner().invoke(main, ["energy", "--dem", str(ep.map_path("hill")),
                                        "--waypoints", str(wp), "--model", str(mf),
                                        "--battery-wh", "10", "--json"])  # fmt: skip
        assert res.exit_code == 0, res.output
        printed = json.loads(res.stdout)
        for k in ("interval", "domain", "battery"):
            assert printed[k] == d[k], k
        text = CliRunner().invoke(main, ["energy", "--dem", str(ep.map_path("hill")),
                                         "--waypoints", str(wp), "--model", str(mf),
                                         "--battery-wh", "10"]).output  # fmt: skip
        assert ("log runs at that power" in text) == above
        assert ("no battery decision" in text) == above


def test_the_refusal_names_the_share_and_no_remedy_the_planner_lacks():
    """d fitted (0): the mean power's share is not the d-share; the refusal still says
    100 % and does not offer --stay-in-domain, which cannot keep a path below a power."""
    from energy_planner.uncertainty import ExtrapolationError, battery_decision

    rep = report_against(DOM, _segs(500.0))
    with pytest.raises(ExtrapolationError, match=r"no battery decision: 100 % of the route") as e:
        battery_decision(_model(DOM, 0.0), 5000.0, 10.0, domain=rep)
    assert "stay-in-domain" not in str(e.value) and "log runs at that power" in str(e.value)


def test_just_below_the_recorded_min_is_outside_too():
    """Light missions on level ground or downhill: below every run's power the held-out
    missions of benchmarks/bench_field_logs.py held 8 of 14 (seeds 0-4, three draws)."""
    m = _model(DOM, 0.0)
    below, above = 150.0 * (1 - 1e-6), 150.0 * (1 + 1e-6)
    rep_b, rep_a = report_against(DOM, _segs(below)), report_against(DOM, _segs(above))
    assert rep_b["shares"]["mean_power"] == 1.0 and rep_a["shares"]["mean_power"] == 0.0
    assert rep_b["excess"]["mean_power"] == pytest.approx(150.0 - below, abs=1e-6)
    (why,) = rep_b["reasons"]
    assert "mean power 150 W below every calibration run's (150-400 W)" in why
    t = path_trust(m, 10 * below, 10.0, rep_b, battery_wh=1.0)
    assert t.battery is None and "lies below every calibration run's" in t.battery_refused
    assert path_trust(m, 10 * above, 10.0, rep_a, battery_wh=1.0).battery is not None
