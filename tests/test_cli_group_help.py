"""``energy-planner --help`` printed without click: the same text, nothing heavy loaded.

The console script's ``main()`` prints the group's help from the package's tables
(:func:`energy_planner.cli.group_help`); these tests hold that text to click's own
rendering of the group (``main.get_help``) and the process to importing neither click
nor the scientific stack.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import click
import pytest

from energy_planner.cli import COMMANDS, group_help, main

#: The console script as pip writes it, its argv[0] named like the installed one.
SCRIPT = (
    "import json, sys\n"
    "sys.argv = ['/some/bin/energy-planner', *sys.argv[1:]]\n"
    "from energy_planner.cli import main\n"
    "try:\n"
    "    main()\n"
    "except SystemExit as exc:\n"
    "    code = exc.code\n"
    "heavy = ('click', 'typing', 'numpy', 'pandas', 'scipy', 'numba', 'rasterio')\n"
    "sys.stdout.flush()\n"
    "print(json.dumps({'code': code, 'loaded': [m for m in heavy if m in sys.modules]}))\n"
)


def _clicks_help(prog: str, width: int) -> str:
    """The group's help as click renders it, ``width`` columns wide."""
    with main.make_context(prog, [], resilient_parsing=True, terminal_width=width) as ctx:
        return main.get_help(ctx)


@pytest.mark.parametrize("prog", ["energy-planner", "-c", "x" * 40])
def test_group_help_is_clicks_at_every_width(prog):
    """The text click would print, wrapped alike from the narrowest width (50) to wide
    ones, with short and long program names (a long one puts the usage on its own line)."""
    for width in range(50, 141):
        assert group_help(prog, width) == _clicks_help(prog, width), width


@pytest.mark.parametrize("flag", ["--help", "-h"])
def test_console_help_loads_neither_click_nor_the_scientific_stack(flag):
    """The console script's --help: click's text for the terminal's width, exit 0, and
    not one of click, typing, numpy, pandas, scipy, numba or rasterio imported."""
    env = dict(os.environ, COLUMNS="100")  # 80 columns at most, less 2: width 78
    out = subprocess.run([sys.executable, "-c", SCRIPT, flag], capture_output=True,
                         text=True, env=env, check=True)  # fmt: skip
    text, _, last = out.stdout.rstrip("\n").rpartition("\n")
    report = json.loads(last)
    assert report == {"code": 0, "loaded": []}
    assert text == _clicks_help("energy-planner", 78)
    assert out.stderr == ""
    for name, (_, summary) in COMMANDS.items():
        assert f"  {name} " in text and summary.split()[0] in text


@pytest.mark.parametrize("args", [["--help", "energy"], ["-q"], ["energy", "--help"]])
def test_other_command_lines_are_clicks(args):
    """Anything but a bare --help or -h goes to click (loaded), as before."""
    out = subprocess.run([sys.executable, "-c", SCRIPT, *args], capture_output=True,
                         text=True, check=False)  # fmt: skip
    report = json.loads(out.stdout.rstrip("\n").rpartition("\n")[2])
    assert "click" in report["loaded"]


def test_main_is_the_click_group():
    """``main`` behaves as the click group it loads: isinstance, attributes, CliRunner."""
    from click.testing import CliRunner

    assert isinstance(main, click.Group)
    assert main.name == "main" and "energy" in main.list_commands(click.Context(main))
    r = CliRunner().invoke(main, ["--help"], prog_name="energy-planner")
    assert r.exit_code == 0
    assert r.output == _clicks_help("energy-planner", 80) + "\n"
