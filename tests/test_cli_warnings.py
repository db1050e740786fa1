"""#19 point 3: warnings on the command line are one line per kind, with a count, without
Python source, and their hints name options the command has.

The simulator's campaign with ROS-signed current (``simulate --small --fault
ros_current_sign``) used to make ``fit`` and ``discover`` print one warning per log file
(93 warnings, 186 lines with their lines of source), each advising ``table_current=``, a
Python argument; and ``fit`` reported the standing runs it drops twice.
"""

from __future__ import annotations

import re
import warnings

import click
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.cli import WarningSummary, main, summarized_warnings
from energy_planner.errors import EnergyPlannerWarning
from energy_planner.measurements import load_logs


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """A third of the small ROS-signed campaign: its 3 standing runs and 36 others."""
    import shutil

    out = tmp_path_factory.mktemp("ros_campaign")
    r = CliRunner().invoke(
        main, ["simulate", "--out", str(out), "--small", "--fault", "ros_current_sign"]
    )
    assert r.exit_code == 0, r.output
    sub = tmp_path_factory.mktemp("ros_logs")
    logs = sorted(p for p in out.glob("*.csv") if p.name != "runs.csv")
    straight = [p for p in logs if p.name.startswith("straight_")]
    keep = [p for p in logs if p.name.startswith(("stand_", "arc_", "turn_"))] + straight[::2]
    for p in keep:
        shutil.copy(p, sub / p.name)
    return sub


def _options(cmd_name: str) -> set[str]:
    cmd = main.get_command(click.Context(main), cmd_name)
    return {o for p in cmd.params for o in getattr(p, "opts", []) if o.startswith("--")}


def _check_warning_lines(stderr: str, cmd: str) -> list[str]:
    """Every stderr line of a warning is one 'warning: ...' line naming real options."""
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    warn = [ln for ln in lines if ln.startswith("warning: ")]
    assert warn, stderr
    for ln in lines:
        assert ln.startswith("warning: "), f"a line that is not a warning: {ln!r}"
        assert ".py:" not in ln and "warnings.warn" not in ln  # no Python source
    named = set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", stderr))
    assert named <= _options(cmd), (named - _options(cmd), cmd)
    assert "table_current" not in stderr  # a Python argument no option sets
    return warn


@pytest.mark.parametrize("cmd", ["fit", "discover"])
def test_ros_signed_campaign_gives_one_warning_line_with_the_count(campaign, tmp_path, cmd):
    n_logs = len(list(campaign.glob("*.csv")))
    # --quiet: no progress lines (a log gets them otherwise), the warnings still printed
    args = [cmd, str(campaign), "--out", str(tmp_path / "m.json"), "--quiet"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    warn = _check_warning_lines(r.stderr, cmd)
    sign = [ln for ln in warn if "battery current" in ln]
    assert len(sign) == 1, warn
    # the standing runs never move, so their current is not judged: the others are
    assert re.search(rf"in {n_logs - 3} logs \(", sign[0]), sign[0]
    assert "ROS BatteryState" in sign[0] and f"and {n_logs - 6} more" in sign[0]
    # the standing runs dropped by preprocessing are reported once, stdout or stderr
    assert r.output.count("stand_a0_g+0_v0_r0") == 1, r.output


def test_the_python_door_keeps_its_argument_hint(campaign):
    with pytest.warns(EnergyPlannerWarning) as rec:
        load_logs(campaign)
    sign = [w for w in rec if "battery current" in str(w.message)]
    assert len(sign) == 1
    assert "table_current='discharge_positive'" in str(sign[0].message)
    assert "table_current" not in sign[0].message.cli_text()


@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 10**6), st.floats(-1e3, 1e3, allow_nan=False)),
        min_size=1,
        max_size=40,
    )
)
def test_warnings_alike_but_for_numbers_and_paths_are_one_line(values):
    s = WarningSummary()
    for k, v in values:
        s.add(f"log /data/run_{k}.csv: current {v:g} A is odd", UserWarning)
    s.add("the DEM has no CRS", UserWarning)
    lines = s.lines()
    assert len(lines) == 2 and lines[1] == "warning: the DEM has no CRS"
    distinct = len({f"log /data/run_{k}.csv: current {v:g} A is odd" for k, v in values})
    if len(values) == 1:
        assert lines[0].startswith("warning: log /data/run_") and lines[0].endswith("odd")
    elif distinct == 1:
        assert lines[0].endswith(f"({len(values)} times)")
    else:
        assert lines[0].endswith(f"(and {len(values) - 1} more like it)")


def test_summary_prints_on_stderr_without_source(capsys):
    with summarized_warnings():
        for _ in range(3):
            warnings.warn("same thing", UserWarning, stacklevel=1)
        warnings.warn(EnergyPlannerWarning("flipped.", api_hint="Pass x=1."), stacklevel=1)
        warnings.warn("old API", DeprecationWarning, stacklevel=1)  # not for CLI users
    err = capsys.readouterr().err
    assert err.splitlines() == ["warning: same thing (3 times)", "warning: flipped."]
