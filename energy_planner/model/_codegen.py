"""Compile generated kernels with numba, cached on disk.

Generated source (from :meth:`EnergyModel.kernel_source`, which renders whitelisted,
parsed formulas only: no user text reaches Python unparsed) is written to a file named
by its hash in the kernel cache directory and imported from there, so numba's
``cache=True`` keeps the machine code between runs: a model is compiled once per
machine, not once per command.

A module whose numba cache is empty says so on stderr, once per process ("compiling the
model's kernels, once: ~10 s"): the wait is once per machine and model. A module can
also be compiled ahead of time into a C extension (:func:`load_precompiled`), which
loads without numba.

The directory is ``$ENERGY_PLANNER_CACHE`` if set, else ``$XDG_CACHE_HOME/energy_planner``
or ``~/.cache/energy_planner``. When it cannot be written (a read-only folder, a full
disk) a warning names it and the kernels are compiled into a temporary directory
instead; nothing in the unwritable folder is touched. Generated files are written
atomically (:func:`energy_planner.io.write_text`) and numba writes its cache files
through a temporary name too, so processes sharing the cache never read half a file.
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
#: What a process prints on stderr before its first compilation of a model's kernels.
COMPILING_NOTE = "compiling the model's kernels, once: ~10 s"
_NOTED: list[bool] = []


def note_compiling() -> None:
    """Say on stderr, once per process, that the model's kernels compile now."""
    if not _NOTED:
        _NOTED.append(True)
        print(COMPILING_NOTE, file=sys.stderr, flush=True)


def cache_dir() -> Path:
    """The directory that holds generated kernel modules (created if needed)."""
    from energy_planner.io.atomic import cache_root

    candidates = [cache_root()]
    candidates.append(Path(tempfile.gettempdir()) / f"energy_planner-{os.getuid()}")
    failed: list[str] = []
    for d in candidates:
        try:
            (d / "kernels").mkdir(parents=True, exist_ok=True)
            probe = d / "kernels" / f".write-test.{os.getpid()}"
            probe.write_text("")
            probe.unlink()
        except OSError as exc:
            failed.append(f"{d}: {exc.strerror or exc}")
            continue
        if failed:
            _warn_cache_fallback(failed[0], d)
        return d / "kernels"
    from energy_planner.errors import OutputError

    raise OutputError(
        f"no writable kernel cache folder ({'; '.join(failed)}); expected a writable "
        "folder: set ENERGY_PLANNER_CACHE to one",
        value=[str(c) for c in candidates],
        expected="a writable folder (ENERGY_PLANNER_CACHE)",
        hint="set ENERGY_PLANNER_CACHE to a writable folder",
    )


_WARNED: set[str] = set()


def _warn_cache_fallback(failed: str, used: Path) -> None:
    """Say once per process that the configured kernel cache could not be written."""
    if failed in _WARNED:
        return
    _WARNED.add(failed)
    import warnings

    from energy_planner.errors import EnergyPlannerWarning

    warnings.warn(
        EnergyPlannerWarning(
            f"the kernel cache folder cannot be written ({failed}): compiling into {used} "
            "instead (nothing in the read-only folder is changed; set ENERGY_PLANNER_CACHE "
            "to a writable folder to keep the compiled kernels)",
            path=failed.split(":")[0],
        ),
        stacklevel=3,
    )


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
    if not any(path.parent.joinpath("__pycache__").glob(f"{path.stem}.*.nbi")):
        note_compiling()  # numba has cached none of its functions yet
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    _MODULES[name] = mod
    return mod


def load_precompiled(
    text: str, prefix: str, build: bool = True, kind: str = "motion"
) -> ModuleType | None:
    """The ahead-of-time compiled C extension of the kernel module ``text``, or None.

    The extension (``<cache>/energy_planner_<prefix>_<hash><ext>``, named by the hash
    of the text and the numpy version it was built against) is built once by
    :mod:`energy_planner.energy._precompile` in a child process, into a temporary
    directory renamed into place when complete. None: not built and ``build`` is False,
    or the build failed on this machine (its output is kept in ``<name>.failed``, and
    it is not tried again). ``kind``: the functions built, ``motion``
    (:data:`~energy_planner.energy.kernels.PRECOMPILED`), ``map``
    (:data:`~energy_planner.energy.kernels.PRECOMPILED_MAP`) or ``search``
    (:data:`~energy_planner.planning.search.PRECOMPILED_SEARCH`).
    """
    import importlib.machinery
    import subprocess

    import numpy as np

    key = hashlib.sha256(f"{text}\nnumpy {np.__version__}".encode()).hexdigest()[:20]
    name = f"energy_planner_{prefix}_{key}"
    mod = _MODULES.get(name)
    if mod is not None:
        return mod
    d = cache_dir()
    path = d / (name + importlib.machinery.EXTENSION_SUFFIXES[0])
    failed = d / f"{name}.failed"
    if not path.exists():
        if not build or failed.exists():
            return None
        source = d / f"{prefix}_{key}.py"
        from energy_planner.io import write_text

        write_text(source, text)
        note_compiling()
        with tempfile.TemporaryDirectory(dir=d) as tmp:
            run = subprocess.run(
                [sys.executable, "-m", "energy_planner.energy._precompile", str(source),
                 name, tmp, kind],
                capture_output=True, text=True,
            )  # fmt: skip
            built = Path(tmp) / path.name
            if run.returncode != 0 or not built.exists():
                write_text(failed, f"{run.stdout}\n{run.stderr}")
                return None
            os.replace(built, path)  # atomic: other processes see all of it or nothing
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    _MODULES[name] = mod
    return mod


def compile_kernel(source: str):
    """The numba-compiled ``power`` function defined by ``source``."""
    # formulas render with math and numpy (energy_planner.model.formula.FUNCTIONS)
    text = "import math\n\nimport numba\nimport numpy as np\n\n\n@numba.njit(cache=True)\n" + source
    return load_generated_module(text, prefix="power").power
