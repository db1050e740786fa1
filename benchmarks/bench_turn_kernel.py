"""The motion kernel on turns in place and translations, against a baseline ``_motion.py``.

A turn in place has every sub-step at its start: ``motion_full`` samples the gradient (and
the channels) there once, and the slope's own angles (``alpha``, the gradient's
direction, ``cos(alpha)``) once, instead of at each of its sub-steps (a sixteenth of a
turn at 0.05 rad per sub-step: 8). The same operations on the same numbers, so the same
energies bit for bit; the sums below are compared exactly.

Both kernel modules are built in this process from the bundled model's ``power`` (the
baseline from ``--baseline``, a copy of ``energy_planner/energy/_motion.py`` before, e.g.
``git show 95425f4:energy_planner/energy/_motion.py > /tmp/_motion_old.py``) and timed
alternately on the bundled hill: every turn in place of 2500 positions x 16 headings, and
every translation of the 16 moves from them. Printed: ns per kernel call (median of
``--repeat``) and the ratio.

Measured (2026-11-30, 2 cores shared with other jobs; the baseline the template of
95425f4), four runs: at load about 4.7 (``--repeat 5``; a first version of this loop)::

    turn in place: baseline 2387 ns, this tree 2088 ns per call, ratio 1.143, same sums
    translation:   baseline  700 ns, this tree  669 ns per call, ratio 1.046, same sums

and at load 0.3-0.7 (``--repeat 5``, then twice ``--repeat 7``)::

    turn in place: baseline 2386 ns, this tree 1906 ns per call, ratio 1.252, same sums
    translation: baseline 1229 ns, this tree 1399 ns per call, ratio 0.879, same sums
    turn in place: baseline 2638 ns, this tree 1988 ns per call, ratio 1.327, same sums
    translation: baseline 1358 ns, this tree 1337 ns per call, ratio 1.016, same sums
    turn in place: baseline 2506 ns, this tree 1683 ns per call, ratio 1.489, same sums
    translation: baseline 1155 ns, this tree 1150 ns per call, ratio 1.004, same sums

Turns 1.14-1.49 x; translations unchanged within the run-to-run noise (0.88-1.05).

Usage::

    python benchmarks/bench_turn_kernel.py --baseline /tmp/_motion_old.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

TIMERS = """

from energy_planner.energy.kernels import IN_CHAN, N_OUT


@numba.njit(cache=True)
def time_turns(data, lat, headings, reps):
    xs0, ys0, step = lat[0], lat[1], lat[2]
    H = headings.shape[0]
    buf = np.empty(N_OUT + data[IN_CHAN].shape[0])
    tot = 0.0
    for _ in range(reps):
        for j in range(10, 60):
            for i in range(10, 60):
                x = xs0 + i * step
                y = ys0 + j * step
                for hh in range(H):
                    motion_full(x, y, headings[hh], x, y, headings[(hh + 1) % H], -1.0, data,
                                buf)
                    tot += buf[0]
    return tot


@numba.njit(cache=True)
def time_moves(data, lat, headings, moves, reps):
    xs0, ys0, step = lat[0], lat[1], lat[2]
    H = headings.shape[0]
    buf = np.empty(N_OUT + data[IN_CHAN].shape[0])
    tot = 0.0
    for _ in range(reps):
        for j in range(10, 60):
            for i in range(10, 60):
                x = xs0 + i * step
                y = ys0 + j * step
                for hh in range(H):
                    for m in range(moves.shape[0]):
                        motion_full(x, y, headings[hh], x + moves[m, 0] * step,
                                    y + moves[m, 1] * step, headings[hh], -1.0, data, buf)
                        tot += buf[0]
    return tot
"""


def main(argv: list[str] | None = None) -> dict:
    import numpy as np

    from energy_planner import api
    from energy_planner.energy import kernels
    from energy_planner.model._codegen import load_generated_module
    from energy_planner.planning.search import _Grid

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, help="a copy of _motion.py to compare with")
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args(argv)
    prob = api._problem("hill", None, None)
    cost = prob.cost
    own = Path(sys.modules[cost.kernel.py_func.__module__].__file__).read_text()
    block = re.search(r"# --- power: replaced per model ---\n.*?# --- end power ---\n", own,
                      re.S).group(0)  # fmt: skip
    mods = {}
    for name, path in (("baseline", Path(a.baseline)),
                       ("this tree", ROOT / "energy_planner/energy/_motion.py")):  # fmt: skip
        text = kernels._POWER_BLOCK.sub(lambda _: block, path.read_text())
        mods[name] = load_generated_module(f"# {name}\n{text}{TIMERS}", prefix="benchturn")
    start = api._pose(prob, (500058, 5000046), None)[:2]
    grid = _Grid(cost, prob.terrain, start, None, 16, "all")
    args = {"turn in place": (cost.data, grid.lat, grid.headings, 2),
            "translation": (cost.data, grid.lat, grid.headings, grid.moves, 1)}  # fmt: skip
    calls = {"turn in place": 2 * 2500 * 16, "translation": 2500 * 16 * 16}
    fn = {"turn in place": "time_turns", "translation": "time_moves"}
    for m in mods.values():  # compiled (or loaded) before the clock
        m.time_turns(*args["turn in place"][:-1], 1)
        m.time_moves(*args["translation"][:-1], 1)
    times = {(n, k): [] for n in mods for k in args}
    sums = {(n, k): None for n in mods for k in args}
    for _ in range(a.repeat):  # alternated: both see the same load
        for n, m in mods.items():
            for k, arg in args.items():
                t = time.process_time()
                sums[n, k] = getattr(m, fn[k])(*arg)
                times[n, k].append(time.process_time() - t)
    out = {}
    for k in args:
        b, o = (float(np.median(times[n, k])) / calls[k] * 1e9 for n in mods)
        same = sums["baseline", k] == sums["this tree", k]
        out[k] = {"baseline_ns": b, "this_tree_ns": o, "ratio": b / o, "same": same}
        print(f"{k}: baseline {b:.0f} ns, this tree {o:.0f} ns per call, ratio {b / o:.3f}, "
              f"{'same sums' if same else 'SUMS DIFFER'}")  # fmt: skip
    return out


if __name__ == "__main__":
    main()
