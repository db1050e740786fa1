"""A fast Python-callable motion cost, and the cost of a pose sequence (no OMPL needed).

:func:`bind_kernel` wraps :attr:`MotionCost.kernel` (which takes the terrain/limit data
tuple as a seventh argument) into ``f(x0, y0, th0, x1, y1, th1) -> J`` at about 1 us per
call; the OMPL objective, the ``auto`` refinement and the lattice planner's reporting use
it. :func:`path_cost` sums it over consecutive poses.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bind_kernel", "path_cost"]

_BOUND: dict = {}
_HOLDERS: dict = {}  # str(numba type of the data tuple) -> its jitclass


def bind_kernel(cost):
    """A fast Python-callable ``f(x0, y0, th0, x1, y1, th1) -> J`` for ``cost``.

    ``MotionCost.kernel`` takes the terrain/limit data tuple as a seventh argument;
    passing that tuple from Python unboxes three arrays per call (about 14 us). Here the
    tuple sits in a numba jitclass, which unboxes as one pointer, and a small njit
    wrapper calls the kernel with it (about 1 us per call, most of it numba's dispatch).
    A cost whose ``kernel`` takes six arguments is returned as is.
    """
    data = getattr(cost, "data", None)
    kernel = cost.kernel
    if data is None:
        return kernel
    import numba
    from numba.experimental import jitclass

    dtype = numba.typeof(data)
    key = (id(kernel), str(dtype))
    if key not in _BOUND:
        # one holder class per data type, shared by the kernels (its compiled constructor
        # and accessor are about half of a binding's compile time)
        holder_cls = _HOLDERS.get(str(dtype))
        if holder_cls is None:
            holder_cls = _HOLDERS[str(dtype)] = jitclass([("data", dtype)])(_make_holder_class())

        @numba.njit
        def call(x0, y0, th0, x1, y1, th1, holder):
            return kernel(x0, y0, th0, x1, y1, th1, holder.data)

        _BOUND[key] = (holder_cls, call, kernel)  # keep kernel alive: the key uses its id
    holder_cls, call, _ = _BOUND[key]
    cache = getattr(cost, "_planning_bound", None)
    if cache is not None and cache[0] is data:
        return cache[1]
    holder = holder_cls(data)

    def f(x0, y0, th0, x1, y1, th1):
        return call(x0, y0, th0, x1, y1, th1, holder)

    try:
        cost._planning_bound = (data, f)
    except AttributeError:
        pass
    return f


def _make_holder_class():
    class _Holder:
        def __init__(self, data):
            self.data = data

    return _Holder


def path_cost(kernel, states: np.ndarray) -> float:
    """Sum of the kernel over consecutive poses (the objective's cost of the path)."""
    s = np.asarray(states, float)
    return float(sum(kernel(*s[k], *s[k + 1]) for k in range(len(s) - 1)) if len(s) > 1 else 0.0)
