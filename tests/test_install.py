"""#19 installs: bundled data as package data found with importlib.resources, py.typed,
the version stated once, and --memory-cap no accepted like the environment variable."""

from __future__ import annotations

import fnmatch
import tomllib
from importlib.resources import files
from pathlib import Path

import pytest
from click.testing import CliRunner

import energy_planner
from energy_planner.cli import main
from energy_planner.maps import MAPS_DIR, map_names, map_path

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _package_data() -> list[str]:
    return PYPROJECT["tool"]["setuptools"]["package-data"]["energy_planner"]


def _shipped(rel: str) -> bool:
    return any(fnmatch.fnmatch(rel, pat) for pat in _package_data())


def test_maps_are_package_data_found_with_importlib_resources():
    res = files("energy_planner") / "data" / "maps"
    for name in map_names():
        p = map_path(name)
        assert (res / p.name).is_file()
        assert p.parent == MAPS_DIR == Path(str(res))
        assert _shipped(f"data/maps/{p.name}"), p.name  # in the wheel
    assert _shipped("data/maps/scenarios.json")
    assert "data-files" not in PYPROJECT["tool"]["setuptools"]  # no sys.prefix copy
    assert "sys.prefix" not in (ROOT / "energy_planner" / "maps.py").read_text()


def test_py_typed_is_shipped():
    assert (files("energy_planner") / "py.typed").is_file()
    assert _shipped("py.typed")


def test_version_is_stated_once():
    project = PYPROJECT["project"]
    assert "version" not in project and "version" in project["dynamic"]
    attr = PYPROJECT["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    assert attr == "energy_planner.__version__" and energy_planner.__version__


def test_editable_install_is_a_path_not_an_import_finder():
    """``pip install -e .`` writes the checkout's folder in a ``.pth`` file: setuptools does
    so for ``package-dir = {"" = "."}`` when every package sits under that folder; without
    it a flat layout gets setuptools' import finder, whose imports (pathlib, urllib) cost
    every start of every command ~10 ms (``energy-planner --help`` has 0.1 s)."""
    assert PYPROJECT["tool"]["setuptools"]["package-dir"] == {"": "."}
    assert PYPROJECT["tool"]["setuptools"]["packages"]["find"]["include"] == ["energy_planner*"]
    assert (ROOT / "energy_planner" / "__init__.py").is_file()  # under that folder


def test_memory_cap_no_is_accepted_like_the_variable():
    from energy_planner.terrain.memory import parse_cap

    assert parse_cap("no") is None  # the environment variable's parser: no cap
    r = CliRunner().invoke(main, ["plan", "--dem", str(map_path("hill")), "--start",
                                  "500058,5000046", "--goal", "500058,5000084",
                                  "--memory-cap", "no", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output


def test_help_lists_every_command_without_importing_them():
    """``energy-planner --help`` lists all commands from the static table, loading none."""
    import subprocess
    import sys

    from energy_planner.cli import COMMANDS

    code = (
        "import sys\n"
        "from click.testing import CliRunner\n"
        "from energy_planner.cli import main\n"
        "r = CliRunner().invoke(main, ['--help'])\n"
        "assert r.exit_code == 0, r.output\n"
        "print(r.output)\n"
        "heavy = [m for m in ('numpy', 'pandas', 'numba', 'rasterio') if m in sys.modules]\n"
        "cmds = [m for m in sys.modules if m.startswith('energy_planner.cli.')\n"
        "        and m != 'energy_planner.cli._group']\n"
        "print('LOADED', heavy, cmds)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "LOADED [] []" in out.stdout
    for name, (_, summary) in COMMANDS.items():
        assert name in out.stdout
        assert summary.split()[0] in out.stdout
        assert len(summary) <= 62, f"{name}: summary wraps in an 80-column terminal"


@pytest.mark.parametrize("columns", ["100", "60", "30", "0", "x", None])
def test_help_is_as_wide_as_clicks(monkeypatch, columns):
    """The command list's help formatter (computed without importing shutil) is as wide
    as click's own, from ``COLUMNS`` or, off a terminal, 80 columns."""
    import click

    from energy_planner.cli import main

    if columns is None:
        monkeypatch.delenv("COLUMNS", raising=False)
    else:
        monkeypatch.setenv("COLUMNS", columns)
    ctx = main.context_class(main)
    assert ctx.make_formatter().width == click.HelpFormatter().width


def test_command_summaries_name_real_modules():
    """Each listed command imports, and its own help shows the same summary in the list."""
    from click.testing import CliRunner

    from energy_planner.cli import COMMANDS, main

    for name in COMMANDS:
        r = CliRunner().invoke(main, [name, "--help"])
        assert r.exit_code == 0, (name, r.output)
