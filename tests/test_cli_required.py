"""A required option left out is a usage error naming it (exit 2), never a traceback.

click >= 8.3 fills a required option from an explicit ``default=None``; the shared
``options.path_option`` must not give one (found when ``discover`` without ``--out``
ended in ``AttributeError``).
"""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from energy_planner.cli import main

CASES = [
    (["discover", "logs"], "--out"),
    (["fit", "logs"], "--out"),
    (["figures", "logs"], "--out"),
    (["energy-map", "maps/hill.tif"], "--out"),
    (["energy", "--dem", "maps/hill.tif"], "--waypoints"),
    (["mission", "--dem", "maps/hill.tif"], "--sites"),
    (["plan", "--start", "1,2", "--goal", "3,4"], "--dem"),
]


@pytest.mark.parametrize(("args", "option"), CASES)
def test_a_missing_required_option_is_named(args, option):
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2, r.output
    assert f"Missing option '{option}'" in r.output
    assert r.exception is None or isinstance(r.exception, SystemExit)
