"""Compile generated kernels with numba, cached on disk.

Generated source (from :meth:`EnergyModel.kernel_source`, which renders whitelisted,
parsed formulas only: no user text reaches Python unparsed) is written to a file named
by its hash in the kernel cache directory and imported from there, so numba's
``cache=True`` keeps the machine code between runs: a model is compiled once per
machine, not once per command.

The directory is ``$ENERGY_PLANNER_CACHE`` if set, else ``$XDG_CACHE_HOME/energy_planner``
or ``~/.cache/energy_planner``, else a temporary directory.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
from pathlib import Path
from types import ModuleType

_MODULES: dict[str, ModuleType] = {}


def cache_dir() -> Path:
    """The directory that holds generated kernel modules (created if needed)."""
    env = os.environ.get("ENERGY_PLANNER_CACHE")
    if env:
        candidates = [Path(env)]
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        candidates = [Path(base) / "energy_planner"]
    candidates.append(Path(tempfile.gettempdir()) / f"energy_planner-{os.getuid()}")
    for d in candidates:
        try:
            (d / "kernels").mkdir(parents=True, exist_ok=True)
            probe = d / "kernels" / ".write-test"
            probe.write_text("")
            probe.unlink()
            return d / "kernels"
        except OSError:
            continue
    raise OSError(f"no writable kernel cache directory among {candidates}")


def load_generated_module(text: str, prefix: str) -> ModuleType:
    """Write ``text`` to ``<cache>/<prefix>_<hash>.py`` (once) and import it."""
    key = hashlib.sha256(text.encode()).hexdigest()[:20]
    name = f"energy_planner_kernel_{prefix}_{key}"
    mod = _MODULES.get(name)
    if mod is not None:
        return mod
    path = cache_dir() / f"{prefix}_{key}.py"
    if not path.exists() or path.read_text() != text:
        from energy_planner.io import write_text

        write_text(path, text)  # atomic: parallel processes never read half a file
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    _MODULES[name] = mod
    return mod


def compile_kernel(source: str):
    """The numba-compiled ``power`` function defined by ``source``."""
    # formulas render with math and numpy (energy_planner.model.formula.FUNCTIONS)
    text = "import math\n\nimport numba\nimport numpy as np\n\n\n@numba.njit(cache=True)\n" + source
    return load_generated_module(text, prefix="power").power
