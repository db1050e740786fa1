"""The kernels of a model that chooses its gait: its motion kernels and the gait choice.

Where a model names gaits (:attr:`energy_planner.energy.MotionCost.gaits`), its kernel
module is the text of :func:`energy_planner.energy.kernels.motion_source` (the same
motion kernels as a model without gaits) followed by ``_gait.py``: functions that price
a motion in each gait with those kernels and keep the cheapest. A model without gaits
compiles none of it: its module, and so numba's cache of it, is that of
:func:`~energy_planner.energy.kernels.kernel_module`.

The gait choice travels in ``data`` (:attr:`~energy_planner.energy.MotionCost.data`):
its first :data:`~energy_planner.energy.kernels.N_IN` entries are the nominal gait's
inputs (as a cost without gaits has them) and entry :data:`IN_GAITS` holds one such
tuple per gait, in the order of :attr:`~energy_planner.energy.MotionCost.gaits`: the
channels with that gait, its speed range (the cost's, clipped to the speeds its logs
walked it at) and its speed law's nodes. So the motion kernels are compiled once, for
one tuple type, and every gait reuses them.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path

from energy_planner.energy.kernels import N_IN, motion_source

#: Index in ``data`` of the per-gait input tuples (after the nominal gait's inputs).
IN_GAITS = N_IN

_TEMPLATE = Path(__file__).with_name("_gait.py")
#: The line of ``_gait.py`` that imports the motion kernels when it is imported as it is;
#: in a generated module they are defined above it.
_IMPORT_LINE = (
    "from energy_planner.energy._motion import motion_best, motion_full  # --- motion ---\n"
)


def gait_source(power_source: str) -> str:
    """The text of the kernel module of a model that chooses its gait.

    :func:`~energy_planner.energy.kernels.motion_source` of ``power_source``, then
    ``_gait.py`` (without its import of the motion kernels); the hash of this file
    heads it (the gait functions read :data:`IN_GAITS` from here).
    """
    text = _TEMPLATE.read_text().replace("from __future__ import annotations\n", "")
    assert _IMPORT_LINE in text, "the motion import marker of _gait.py is missing"
    here = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]
    return (
        f"# gait_kernels.py {here}\n"
        + motion_source(power_source)
        + "\n\n# --- the gait choice (energy/_gait.py) ---\n"
        + text.replace(_IMPORT_LINE, "")
    )


@lru_cache(maxsize=16)
def gait_kernel_module(power_source: str):
    """The compiled module of :func:`gait_source` (numba's disk cache, as the others)."""
    from energy_planner.model._codegen import load_generated_module

    return load_generated_module(gait_source(power_source), prefix="gait")
