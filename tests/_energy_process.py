"""Run ``energy --json`` in a fresh Python process and say which modules it imported."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

CODE = (
    "import json, sys\n"
    "from click.testing import CliRunner\n"
    "from energy_planner.cli import main\n"
    "r = CliRunner().invoke(main, ['energy', '--dem', sys.argv[1], '--waypoints', sys.argv[2],"
    " '--json'])\n"
    "assert r.exit_code == 0, r.output\n"
    "print(json.dumps({'imported': {m: m in sys.modules for m in sys.argv[3:]},"
    " 'out': json.loads(r.stdout)}))\n"
)


def energy_in_process(dem: str | Path, waypoints: str | Path, *modules: str) -> dict[str, Any]:
    """``{"imported": {module: bool}, "out": <energy --json>}`` of one new process."""
    done = subprocess.run(
        [sys.executable, "-c", CODE, str(dem), str(waypoints), *modules],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(done.stdout.strip().splitlines()[-1])
