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


@pytest.mark.xdist_group("load_discovery")  # shares conftest.load_discovery
def test_the_simulator_and_discover_report_through_the_same_callback(load_discovery):
    # the load campaign simulated and discovered with progress=seen.append / msgs.append
    c, _, seen, msgs = load_discovery
    assert all(isinstance(e, ProgressEvent) for e in seen + msgs)
    runs = [e for e in seen if e.stage == "simulating runs"]
    assert runs and runs[-1].done == runs[-1].total == len(c.runs)
    text = [e.message for e in msgs if e.message]
    assert text[0] == "data checks done"
    assert {e.stage for e in msgs} <= {"discover", "staircase"}
    assert [e.message for e in msgs if e.stage == "staircase"] == ["step 1 done"]


def test_in_a_log_a_shown_stage_writes_plain_lines_not_bars(capsys, monkeypatch):
    import energy_planner.progress as progress

    monkeypatch.setattr(progress, "LOG_EVERY_S", 0.0)  # a line at every update
    for _ in track(range(3), "blocks", True, unit="block"):
        pass
    err = capsys.readouterr().err  # capsys: stderr is not a terminal, as in a log
    assert "\r" not in err and "|" not in err  # no bar
    lines = err.splitlines()
    assert lines[-1].startswith("blocks: done, 100% (3/3 block)")
    assert any(line.startswith("blocks: running, 33% (1/3 block)") for line in lines)
    # a stage shorter than the log interval leaves no line; None never writes in a log
    monkeypatch.setattr(progress, "LOG_EVERY_S", 3600.0)
    list(track(range(3), "short", True))
    list(track(range(3), "library default", None))
    assert capsys.readouterr().err == ""


def test_quiet_silences_every_reporter_but_not_the_callbacks(capsys, monkeypatch):
    import energy_planner.progress as progress

    monkeypatch.setattr(progress, "LOG_EVERY_S", 0.0)
    seen: list[ProgressEvent] = []
    try:
        progress.quiet()
        list(track(range(2), "blocks", True))
        Reporter(show=True).say("loud")
        list(track(range(2), "blocks", seen.append))
    finally:
        progress.quiet(False)
    assert capsys.readouterr().err == ""
    assert [e.done for e in seen] == [0, 1, 2]


def test_a_command_reports_in_a_log_and_is_silent_with_quiet(tmp_path, monkeypatch):
    # mission's matrix and legs report through the one reporter: lines in a log (stderr
    # not a terminal), none with --quiet; stdout holds only the JSON either way
    import json

    from click.testing import CliRunner

    import energy_planner.progress as progress
    from energy_planner.cli import main
    from energy_planner.io import write_geotiff
    from energy_planner.terrain import Terrain

    monkeypatch.setattr(progress, "LOG_EVERY_S", 0.0)
    t = Terrain.from_function(lambda x, y: 0.05 * x + 0.02 * y, size=(30, 30))
    dem = tmp_path / "dem.tif"
    write_geotiff(dem, t.elevation, transform=t.transform, crs=t.crs)
    sites = tmp_path / "sites.csv"
    sites.write_text("name,x,y\na,5.5,5.5\nb,25.5,8.5\nc,12.5,24.5\n")
    args = ["mission", "--dem", str(dem), "--sites", str(sites), "--json"]
    loud = CliRunner().invoke(main, args)
    assert loud.exit_code == 0, loud.output
    assert json.loads(loud.stdout)["legs"]
    assert "matrix searches: running" in loud.stderr and "legs: done" in loud.stderr
    assert "\r" not in loud.stderr
    for quiet_args in (["-q", *args], [*args, "--quiet"]):
        q = CliRunner().invoke(main, quiet_args)
        assert q.exit_code == 0, q.output
        assert json.loads(q.stdout) == {**json.loads(loud.stdout), **_timing(json.loads(q.stdout))}
        assert q.stderr == ""
    # the flag holds for its own invocation only (one process, several CliRunner calls)
    assert CliRunner().invoke(main, ["terrain", str(dem), "--json"]).exit_code == 0
    assert progress._QUIET is False


def _timing(doc):
    # what differs between two runs of the same mission: wall times
    return {k: v for k, v in doc.items() if k.endswith("_s") and "duration" not in k}
