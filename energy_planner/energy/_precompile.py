"""Build a precompiled kernel module: ``python -m energy_planner.energy._precompile``.

Arguments: the kernel module's source file (written by
:func:`energy_planner.model._codegen.load_precompiled`), the extension's name, the
directory to write it to and what to build (``motion``, the default, ``map`` or
``search``, :func:`build_search`). The
functions :data:`energy_planner.energy.kernels.PRECOMPILED` of the module are compiled by
numba's ahead-of-time compiler (``numba.pycc``) with the types of
:attr:`energy_planner.energy.MotionCost.data`: the same code as the numba kernels, in a C
extension that imports without numba; ``map``: the energy map's
:data:`energy_planner.energy.kernels.PRECOMPILED_MAP`, which release the GIL (numba's
``nogil``) so that threads can share a block. Run in a child process so that the caller
never imports numba and a failed build cannot harm it.
"""

from __future__ import annotations

import importlib.util
import sys
import warnings


def data_type():
    """The numba type of :attr:`energy_planner.energy.MotionCost.data` (``IN_*`` order)."""
    from numba import types

    f8 = types.float64
    grid3 = types.Array(f8, 3, "C")
    return types.Tuple(
        (
            grid3,  # IN_GRAD
            types.Array(types.boolean, 2, "C"),  # IN_BLOCKED
            *(f8,) * 10,  # IN_X0 .. IN_SMAX
            grid3,  # IN_CHAN
            types.Array(types.boolean, 1, "C"),  # IN_NEAREST
            f8,  # IN_BTAN
            f8,  # IN_CMAX
            f8,  # IN_VMIN
            f8,  # IN_VMAX
            f8,  # IN_TIME_WEIGHT
            types.Array(f8, 1, "C"),  # IN_EXPS
            types.Array(f8, 1, "C"),  # IN_NODES
            types.Array(f8, 2, "C"),  # IN_VINV
        )
    )


def build(source: str, name: str, out_dir: str) -> None:
    """Compile the kernels of the module in ``source`` into ``out_dir/<name><ext>``."""
    from numba import types

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numba.pycc's pending-deprecation notice
        from numba.pycc import CC

    spec = importlib.util.spec_from_file_location(f"{name}_source", source)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    f8, a1 = types.float64, types.Array(types.float64, 1, "C")
    data = data_type()
    cc = CC(name)
    cc.output_dir = out_dir
    cc.verbose = False
    cc.export("motion_cost", f8(f8, f8, f8, f8, f8, f8, data))(mod.motion_cost.py_func)
    cc.export("motion_batch", a1(a1, a1, a1, a1, a1, a1, data))(mod.motion_batch.py_func)
    table = types.Array(f8, 2, "C")
    cc.export("path_table", table(a1, a1, a1, a1, data))(mod.path_table.py_func)
    cc.compile()


def build_map(source: str, name: str, out_dir: str) -> None:
    """Compile the energy map's kernels of the module in ``source`` (GIL released)."""
    from numba import types
    from numba.core.compiler import Flags

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import numba.pycc.compiler as pycc_compiler
        from numba.pycc import CC

    class _NoGil(Flags):  # numba.pycc has no option for it: its flags, with nogil
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            self.release_gil = True

    spec = importlib.util.spec_from_file_location(f"{name}_source", source)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    f8, f4 = types.float64, types.float32
    c1, c3 = types.Array(f8, 1, "C"), types.Array(f8, 3, "C")
    a2, a3, b3 = types.Array(f8, 2, "A"), types.Array(f8, 3, "A"), types.Array(f4, 3, "A")
    cc = CC(name)
    cc.output_dir = out_dir
    cc.verbose = False
    # map_costs(gx, gy, chan, consts, headings, speed, tmax, smax, btan, cmax, table,
    #           d_alpha, along, best): a block's rows may be any slice of the caller's
    sig = types.void(a2, a2, a3, c1, c1, f8, f8, f8, f8, f8, c3, f8, b3, b3)
    cc.export("map_costs", sig)(mod.map_costs.py_func)
    cc.export("summary", types.void(b3, c1, b3))(mod.summary.py_func)
    u3 = types.Array(types.uint16, 3, "A")
    cc.export("encode", types.int64(b3, c1, u3))(mod.encode.py_func)
    i8 = types.int64
    table = c3(f8, f8, f8, f8, i8, i8, i8, c1)  # heading_table(speed, smax, cmax, d_alpha,
    cc.export("heading_table", table)(mod.heading_table.py_func)  # i_start, n_rows, n_phi, chv)
    saved = pycc_compiler.Flags
    pycc_compiler.Flags = _NoGil
    try:
        cc.compile()
    finally:
        pycc_compiler.Flags = saved


def build_search(source: str, name: str, out_dir: str) -> None:
    """Compile the search functions a plan calls (``search_module``'s ``path`` group).

    ``source``: the model's kernel module followed by ``planning/_search.py`` whose kernel
    is the fixed-speed ``motion_full`` (:func:`energy_planner.planning.search.
    precompiled_search`). The types are those the numba search is called with.
    """
    from numba import types

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from numba.pycc import CC

    spec = importlib.util.spec_from_file_location(f"{name}_source", source)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    f8, f4, i8, i4 = types.float64, types.float32, types.int64, types.int32
    u1, i1, b1 = types.uint8, types.int8, types.boolean

    def a(dt, nd):
        return types.Array(dt, nd, "C")

    cc = CC(name)
    cc.output_dir = out_dir
    cc.verbose = False
    # heuristic_chunk(grad, blocked, unsafe, geo, sampling, lat, moves, move_len, table,
    #                 tgeo, h, pos, keys, vals, n, max_pops, margin, stop_p, stop_factor, limit)
    sig = types.UniTuple(i8, 2)(
        a(f8, 3), a(b1, 2), a(u1, 2), a(f8, 1), a(f8, 1), a(f8, 1), a(i8, 2), a(f8, 1),
        a(f4, 3), a(f8, 1), a(f4, 1), a(i4, 1), a(f8, 1), a(i8, 1), a(i8, 1), i8, f8, i8, f8,
        a(f8, 1),
    )  # fmt: skip
    cc.export("heuristic_chunk", sig)(mod.heuristic_chunk.py_func)
    # astar_chunk(data, lat, headings, moves, moves_of, move_lb, h2d, eps, g, code, goal_p,
    #             goal_h, keys, vals, n, max_pops, max_key, out)
    sig = types.UniTuple(i8, 3)(
        data_type(), a(f8, 1), a(f8, 1), a(i8, 2), a(i8, 2), a(f8, 1), a(f4, 1), f8, a(f4, 1),
        a(i1, 1), i8, i8, a(f8, 1), a(i8, 1), a(i8, 1), i8, f8, a(i8, 1),
    )  # fmt: skip
    cc.export("astar_chunk", sig)(mod.astar_chunk.py_func)
    cc.export("heap_push", b1(a(f8, 1), a(i8, 1), a(i8, 1), f8, i8))(mod.heap_push.py_func)
    cc.export("trace", a(i8, 1)(a(i1, 1), a(i8, 2), i8, i8, i8))(mod.trace.py_func)
    cc.export("unsafe_cells", a(u1, 2)(a(f8, 3), a(b1, 2), f8))(mod.unsafe_cells.py_func)
    sig = types.void(a(f4, 1), a(i4, 1), i8, i8, f8, f8, f8)
    cc.export("cap_unsettled", sig)(mod.cap_unsettled.py_func)
    cc.compile()


if __name__ == "__main__":
    builders = {"map": build_map, "search": build_search}
    builders.get(sys.argv[4] if len(sys.argv) > 4 else "motion", build)(*sys.argv[1:4])
