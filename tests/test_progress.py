"""One progress reporter: every door takes ``progress=`` the same way (energy_planner.progress)."""

from __future__ import annotations

import math

import pytest

from energy_planner.progress import ProgressEvent, Reporter, reporter, track


def test_reporter_accepts_the_documented_forms_and_names_the_others():
    assert reporter(None).show is None and reporter(True).show is True
    assert reporter(False).show is False
    rep = Reporter(show=False)
    assert reporter(rep) is rep
    seen: list[ProgressEvent] = []
    assert reporter(seen.append).callback is not None
    with pytest.raises(TypeError, match="expected True, False, None, a callable"):
        reporter("yes")  # type: ignore[arg-type]


def test_iterate_reports_each_item_once_and_counts_to_the_total():
    seen: list[ProgressEvent] = []
    items = list(track(range(5), "blocks", seen.append, unit="block"))
    assert items == [0, 1, 2, 3, 4]
    assert [e.done for e in seen] == [0, 1, 2, 3, 4, 5]
    assert {e.total for e in seen} == {5} and {e.unit for e in seen} == {"block"}
    assert all(b.elapsed >= a.elapsed for a, b in zip(seen, seen[1:], strict=False))
    assert list(track(iter([1, 2]), "x", False)) == [1, 2]  # False: the iterable as is


def test_say_prints_only_when_shown(capsys):
    Reporter(show=False).say("quiet")
    Reporter(show=True).say("loud", stage="corridor")
    err = capsys.readouterr().err
    assert "quiet" not in err and "corridor: loud" in err


def test_the_search_reports_its_stages_through_a_callback():
    from energy_planner.model import EnergyModel
    from energy_planner.planning.plan import plan
    from energy_planner.terrain import Terrain

    t = Terrain.from_function(lambda x, y: 0.1 * x, size=(20, 20))
    seen: list[ProgressEvent] = []
    r = plan(t, EnergyModel.default(), (3.0, 3.0), (15.0, 12.0), planner="search",
             progress=seen.append)  # fmt: skip
    assert math.isfinite(r.energy_j)
    stages = {e.stage for e in seen}
    assert "heuristic (2-D)" in stages and "search (x, y, heading)" in stages
    heur = [e.done for e in seen if e.stage == "heuristic (2-D)"]
    assert heur[-1] <= 20 * 20  # cells settled, at most every cell once


def test_the_simulator_and_discover_report_through_the_same_callback():
    from energy_planner.diagnosis import discover
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    seen: list[ProgressEvent] = []
    c = simulate_campaign(0, ["load"], CampaignConfig.small(), progress=seen.append)
    runs = [e for e in seen if e.stage == "simulating runs"]
    assert runs and runs[-1].done == runs[-1].total == len(c.runs)
    msgs: list[ProgressEvent] = []
    discover(c.logs, max_steps=1, fit_final=False, progress=msgs.append)
    text = [e.message for e in msgs if e.message]
    assert text[0] == "data checks done"
    assert {e.stage for e in msgs} <= {"discover", "staircase"}
    assert [e.message for e in msgs if e.stage == "staircase"] == ["step 1 done"]
