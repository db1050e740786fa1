"""Compile generated scalar power functions with numba (cached by source text).

The source comes from :meth:`EnergyModel.kernel_source`, which renders whitelisted,
parsed formulas only (see :mod:`energy_planner.model.formula`); no user text reaches
``exec`` unparsed.
"""

from __future__ import annotations

import math
from typing import Any

_CACHE: dict[str, Any] = {}


def compile_kernel(source: str):
    """Return ``numba.njit`` of the single function defined by ``source``."""
    fn = _CACHE.get(source)
    if fn is None:
        import numba

        namespace: dict[str, Any] = {"math": math}
        exec(compile(source, "<energy_planner.model kernel>", "exec"), namespace)  # noqa: S102
        fn = numba.njit(cache=False, fastmath=False)(namespace["power"])
        _CACHE[source] = fn
    return fn
