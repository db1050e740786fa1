"""Every ```python block of README.md runs as printed (in a fresh namespace, in a tmp cwd)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_has_a_python_example():
    assert BLOCKS and "import energy_planner as ep" in BLOCKS[0]


@pytest.mark.parametrize("code", BLOCKS, ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_readme_python_block_runs(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, str(README), "exec"), {"__name__": "readme"})  # noqa: S102


def test_import_is_cheap_and_names_resolve():
    import subprocess
    import sys

    code = (
        "import sys, energy_planner as ep; heavy = {'rasterio', 'numba', 'ompl'} & "
        "set(sys.modules); assert not heavy, heavy; "
        "assert callable(ep.plan) and ep.Problem and ep.mission and ep.battery_decision"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
