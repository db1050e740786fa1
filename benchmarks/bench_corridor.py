"""Planning and reach on DEMs larger than memory: windows against the whole map.

Usage::

    python benchmarks/bench_corridor.py [--size 3200] [--cap 1G] [--huge 10]
        [--budget-wh 60] [--timeout 1800]

Cases, each a fresh ``energy-planner`` process (its own peak RSS, from ``wait4``):

* ``whole``: ``plan`` on a hilly ``size x size`` DEM at 1 m (``benchmarks/_hilly.py``),
  with no memory cap, on a route of about a kilometre inside it (the baseline);
* ``windows``: the same route with ``--memory-cap CAP``, below what planning the whole
  DEM needs (160 bytes per cell): the corridor of ``energy_planner.planning.corridor``;
* with ``--exact``, both again with the optimal search (``--planner search --eps 1``),
  where a proven window must give the whole map's energy exactly (the default ``eps``
  1.05 and the refinement may land on different paths within their bounds);
* ``huge``: with ``--huge K``, the DEM tiled ``K x K`` times (the hilly field is
  periodic, so the tiling is seamless: ``K * size`` cells a side, 4 bytes per cell on
  disk), planned with the default cap on the same route: a DEM whose planning would need
  far more than this machine's memory;
* ``reach whole`` / ``reach window`` / ``reach huge``: ``reach --budget-wh B`` from the
  route's start the same three ways (the whole DEM searched as far as the budget,
  ``--within-budget``: exact within it, as ``tests/test_corridor.py`` checks against the
  unbounded search).

Printed: wall time, peak RSS, energy and its ratio to the whole-map plan (the eps=1 rows
to the whole-map eps=1 search), the windows
read and whether the window was proven to hold every cheaper path; for reach, the cells
within the budget and whether they equal the whole map's. ``uptime`` load is printed: the
machine is shared.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


#: Runs the CLI in this interpreter and prints its own peak RSS (``VmHWM``, kB) on exit.
#: Not ``ru_maxrss``: Linux carries it over from the forking parent across ``exec``, and the
#: parent's peak (tiling the huge DEM) would show up in every later child.
WRAP = (
    "import atexit, sys\n"
    "def _hwm():\n"
    "    for line in open('/proc/self/status'):\n"
    "        if line.startswith('VmHWM:'):\n"
    "            sys.stderr.write('\\nMAXRSS_KB ' + line.split()[1] + '\\n')\n"
    "atexit.register(_hwm)\n"
    "sys.argv = ['energy-planner', *sys.argv[1:]]\n"
    "from energy_planner.cli import main\n"
    "main()\n"
)


def run(args: list[str], timeout: float) -> dict:
    """Run the CLI with ``--json``: its result, wall time and peak RSS."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile("w+") as fo, tempfile.TemporaryFile("w+") as fe:
        p = subprocess.Popen(
            [sys.executable, "-c", WRAP, *args, "--json"], stdout=fo, stderr=fe, text=True
        )
        deadline = time.perf_counter() + timeout
        while True:
            pid, status, _ = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                p.kill()
                os.wait4(p.pid, 0)
                return {"error": f"killed at {timeout:.0f} s"}
            time.sleep(0.2)
        wall = time.perf_counter() - t0
        code = os.waitstatus_to_exitcode(status)
        fo.seek(0)
        fe.seek(0)
        out, err = fo.read(), fe.read()
    if code != 0:
        last = (err.strip().splitlines() or ["?"])[-1]
        return {"error": f"exit {code}: {last}", "wall_s": wall}
    res = json.loads(out)
    kb = [int(x.split()[1]) for x in err.splitlines() if x.startswith("MAXRSS_KB ")]
    res.update(wall_s=wall, rss_gb=kb[-1] / 1e6 if kb else float("nan"))
    return res


def tile_dem(src_path: Path, k: int, out: Path) -> Path:
    """``src`` tiled ``k x k`` times, written band-row by band-row (never whole in memory)."""
    import rasterio
    from rasterio.transform import from_origin

    with rasterio.open(src_path) as src:
        z = src.read(1)
        t = src.transform
    n = z.shape[0]
    with rasterio.open(
        out, "w", driver="GTiff", width=k * n, height=k * n, count=1, dtype="float32",
        crs="EPSG:32631", transform=from_origin(t.c, t.f + (k - 1) * n, 1.0, 1.0),
        tiled=True, blockxsize=512, blockysize=512, BIGTIFF="YES",
    ) as dst:  # fmt: skip
        from rasterio.windows import Window

        row = np.tile(z, (1, k))
        for i in range(k):
            dst.write(row, 1, window=Window(0, i * n, k * n, n))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=3200)
    ap.add_argument("--cap", default="1G", help="memory cap of the 'windows' case")
    ap.add_argument("--huge", type=int, default=0, help="tile the DEM K x K times (0: skip)")
    ap.add_argument("--budget-wh", type=float, default=60.0)
    ap.add_argument("--timeout", type=float, default=1800.0)
    ap.add_argument("--no-reach", action="store_true")
    ap.add_argument(
        "--exact", action="store_true", help="also plan whole and by windows with the eps=1 search"
    )
    a = ap.parse_args()

    from _hilly import X0, Y0, hilly_dem

    from energy_planner.terrain.memory import format_bytes, memory_cap

    tmp = Path(tempfile.mkdtemp(prefix="bench_corridor_"))
    dem = hilly_dem(a.size, tmp / f"hilly_{a.size}.tif")
    # a route of ~1 km across the middle of the DEM
    n = a.size
    s = (X0 + 0.30 * n + 0.5, Y0 + 0.35 * n + 0.5)
    g = (X0 + 0.30 * n + 0.5 + 0.22 * n, Y0 + 0.35 * n + 0.5 + 0.22 * n)
    route = ["--start", f"{s[0]},{s[1]}", "--goal", f"{g[0]},{g[1]}"]
    rows: list[tuple[str, dict]] = []
    print(f"DEM {n} x {n} at 1 m, route {np.hypot(g[0] - s[0], g[1] - s[1]):.0f} m", flush=True)
    rows.append(("whole", run(["plan", "--dem", str(dem), *route, "--memory-cap", "1T"],
                                  a.timeout)))  # fmt: skip
    rows.append(("windows", run(["plan", "--dem", str(dem), *route, "--memory-cap", a.cap],
                                    a.timeout)))  # fmt: skip
    if a.exact:
        ex = ["--planner", "search", "--eps", "1"]
        rows.append(("whole, search eps=1", run(["plan", "--dem", str(dem), *route, *ex,
                                                 "--memory-cap", "1T"], a.timeout)))  # fmt: skip
        rows.append(("windows, search eps=1", run(["plan", "--dem", str(dem), *route, *ex,
                                                   "--memory-cap", a.cap], a.timeout)))  # fmt: skip
    huge = None
    if a.huge > 1:
        t0 = time.perf_counter()
        huge = tile_dem(dem, a.huge, tmp / "huge.tif")
        print(
            f"tiled DEM {a.huge * n} x {a.huge * n} ({huge.stat().st_size / 1e9:.1f} GB on disk) "
            f"written in {time.perf_counter() - t0:.0f} s; default cap "
            f"{format_bytes(memory_cap() or 0)}",
            flush=True,
        )
        rows.append(("huge", run(["plan", "--dem", str(huge), *route], a.timeout)))
    reach_rows: list[tuple[str, dict]] = []
    if not a.no_reach:
        rr = ["--start", f"{s[0]},{s[1]}", "--budget-wh", f"{a.budget_wh:g}"]
        tifs = {}
        cases = [("reach whole", dem, "1T"), ("reach window", dem, a.cap)]
        if huge is not None:
            cases.append(("reach huge", huge, None))
        for name, path, cap in cases:
            tif = tmp / f"{name.replace(' ', '_')}.tif"
            extra = ["--memory-cap", cap] if cap else []
            if name == "reach whole":  # the whole DEM, searched as far as the budget
                extra.append("--within-budget")
            reach_rows.append(
                (name, run(["reach", str(path), *rr, *extra, "--out", str(tif)], a.timeout))
            )
            tifs[name] = tif
        ref = _cells_within(tifs["reach whole"], a.budget_wh * 3600.0)
        for name, r in reach_rows:
            if "error" not in r and name != "reach whole":
                mine = _cells_within(tifs[name], a.budget_wh * 3600.0)
                r["same_as_whole"] = bool(
                    mine.keys() == ref.keys()
                    and all(abs(mine[k] - ref[k]) <= 1e-6 * ref[k] + 1e-9 for k in ref)
                )

    base = rows[0][1].get("energy_j")
    print(f"\nload: {os.getloadavg()[0]:.1f} {os.getloadavg()[1]:.1f} (2 cores)")
    print("| case | wall s | peak RSS GB | energy J | / whole | windows (last) | proven |")
    print("|---|---|---|---|---|---|---|")
    for name, r in rows:
        if "error" in r:
            print(f"| {name} | - | - | {r['error']} | | | |")
            continue
        c = r.get("corridor") or {}
        w = c.get("windows") or []
        last = f"{len(w)} ({w[-1]['shape'][0]} x {w[-1]['shape'][1]})" if w else "whole DEM"
        ref = rows[2][1].get("energy_j") if "eps=1" in name else base
        ratio = r["energy_j"] / ref if ref else float("nan")
        print(
            f"| {name} | {r['wall_s']:.1f} | {r['rss_gb']:.2f} | {r['energy_j']:.0f} | "
            f"{ratio:.4f} | {last} | {c.get('proven', '-')} |"
        )
    if reach_rows:
        print("\n| reach | wall s | peak RSS GB | cells within budget | window | = whole |")
        print("|---|---|---|---|---|---|")
        for name, r in reach_rows:
            if "error" in r:
                print(f"| {name} | - | - | {r['error']} | | |")
                continue
            w = r.get("window")
            win = f"{w['shape'][0]} x {w['shape'][1]}" if w else "whole DEM"
            print(
                f"| {name} | {r['wall_s']:.1f} | {r['rss_gb']:.2f} | {r['budget_cells']} | "
                f"{win} | {r.get('same_as_whole', '-')} |"
            )


def _cells_within(tif: Path, budget_j: float) -> dict[tuple[float, float], float]:
    """``{(x, y) of cell centre: J}`` for the cells within the budget."""
    import rasterio

    with rasterio.open(tif) as src:
        e = src.read(1, masked=True).filled(np.nan)
        t = src.transform
    r, c = np.nonzero(e <= budget_j)
    xs = t.c + (c + 0.5) * t.a
    ys = t.f + (r + 0.5) * t.e
    return {(round(x, 3), round(y, 3)): float(v) for x, y, v in zip(xs, ys, e[r, c], strict=True)}


if __name__ == "__main__":
    main()
