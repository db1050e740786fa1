"""README.md leads with a Python example; ``tests/test_examples.py`` runs its blocks in order."""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_has_a_python_example():
    assert BLOCKS and "import energy_planner as ep" in BLOCKS[0]


def test_import_is_cheap_and_names_resolve():
    import subprocess
    import sys

    code = (
        "import sys, energy_planner as ep; heavy = {'rasterio', 'numba', 'ompl'} & "
        "set(sys.modules); assert not heavy, heavy; "
        "assert callable(ep.plan) and ep.Problem and ep.mission and ep.battery_decision"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
