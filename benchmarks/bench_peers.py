"""Peers side by side: GRASS r.walk, the project's search, the full lattice, OMPL planners.

Usage::

    python benchmarks/bench_peers.py [--sizes 400,1600] [--ompl-time 10]
        [--lattice-sizes 400] [--planners rrtstar,bitstar]

On each hilly synthetic DEM (``benchmarks/_hilly.py``, 1 m, corner to corner) it runs,
each in its own process (peak RSS is its own):

* GRASS ``r.walk -k`` (anisotropic cumulative cost with 16 directions: Naismith's walking
  time plus Langmuir's slope corrections, GRASS's default coefficients, zero friction)
  and ``r.drain`` for the path. r.walk cannot express the robot's energy model (its cost
  is walking time as a function of the slope along the move), so this is "the best
  off-the-shelf slope-aware route"; GRASS is installed with ``apt-get install
  grass-core`` if missing (not a runtime dependency; the reason is printed if it fails);
* the project's default planner (``plan``, ``auto``) and the search alone;
* the full lattice at 1 m where ``--lattice-sizes`` asks for it;
* OMPL planners (tuned, see ``plan.OMPL_TUNING``) for ``--ompl-time`` seconds.

Every path's energy is re-evaluated by :func:`energy_planner.energy.path_energy` (the
``energy`` command's evaluation) with the same model: r.walk's path facing along each
segment, the others with their own yaw. Printed: wall time, peak RSS and energy, each as a
ratio to the project's search. ``uptime`` load is printed with the table.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, sys.argv[1])
from energy_planner.model import EnergyModel
from energy_planner.planning.plan import plan
from energy_planner.terrain import load_dem
from _hilly import corners
path, size, planner, budget = sys.argv[2], int(sys.argv[3]), sys.argv[4], float(sys.argv[5])
t = load_dem(path); m = EnergyModel.default()
a, b = corners(size); s = t.to_work(*a); g = t.to_work(*b)
t0 = time.perf_counter()
kw = dict(step=1.0) if planner == "lattice" else {}
if planner in ("rrtstar", "sorrtstar", "bitstar"):
    kw["time"] = budget
r = plan(t, m, s, g, planner=planner, progress=False, **kw)
print(json.dumps(dict(energy=r.energy_j, time_s=time.perf_counter() - t0,
                      rss_gb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6)))
"""

ENERGY = r"""
import json, sys
import numpy as np
from energy_planner.energy import path_energy
from energy_planner.model import EnergyModel
from energy_planner.terrain import load_dem
t = load_dem(sys.argv[1]); m = EnergyModel.default()
xy = np.array(json.loads(sys.argv[2]))
x, y = t.to_work(xy[:, 0], xy[:, 1])
print(path_energy(t, m, np.column_stack([x, y])).energy_j)
"""


def ensure_grass() -> str | None:
    """The ``grass`` executable, installing grass-core if needed; None with the reason."""
    exe = shutil.which("grass")
    if exe:
        return exe
    print("# grass not found: apt-get update && apt-get install -y grass-core ...", flush=True)
    try:
        subprocess.run(["apt-get", "update"], check=True, capture_output=True, timeout=600)
        subprocess.run(
            ["apt-get", "install", "-y", "--no-install-recommends", "grass-core"],
            check=True, capture_output=True, timeout=1200,
            env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"},
        )  # fmt: skip
    except (OSError, subprocess.SubprocessError) as exc:
        err = getattr(exc, "stderr", b"") or b""
        print(f"# cannot install grass-core: {exc} {err.decode()[-300:]}")
        return None
    return shutil.which("grass")


def run_grass(grass: str, dem: Path, size: int, work: Path) -> dict:
    sys.path.insert(0, str(HERE))
    from _hilly import corners

    (sx, sy), (gx, gy) = corners(size)
    db = work / "grassdb"
    shutil.rmtree(db, ignore_errors=True)
    subprocess.run([grass, "-c", "EPSG:32631", str(db), "-e"], check=True, capture_output=True)
    timing = work / "timing.txt"
    script = work / "run.sh"
    script.write_text(
        "set -e\n"
        f"r.in.gdal -o input={dem} output=dem --overwrite --quiet\n"
        "g.region raster=dem\n"
        "r.mapcalc 'friction = 0' --overwrite --quiet\n"
        f"/usr/bin/time -f '%e %M' -o {timing} r.walk -k elevation=dem friction=friction "
        f"output=cost outdir=dir start_coordinates={sx},{sy} stop_coordinates={gx},{gy} "
        "--overwrite --quiet\n"
        f"/usr/bin/time -a -f '%e %M' -o {timing} r.drain -d input=cost direction=dir "
        f"output=drain drain=drainv start_coordinates={gx},{gy} --overwrite --quiet\n"
        "v.out.ascii input=drainv format=wkt\n"
    )
    out = subprocess.run(
        [grass, str(db / "PERMANENT"), "--exec", "bash", str(script)],
        capture_output=True, text=True,
    )  # fmt: skip
    m = re.search(r"LINESTRING\(([^)]*)\)", out.stdout)
    if out.returncode != 0 or not m:
        return {"error": f"r.walk failed: {out.stderr.strip()[-200:]}"}
    xy = [[float(v) for v in p.split()[:2]] for p in m.group(1).split(",")]
    xy.reverse()  # r.drain walks from the goal down to the start
    rows = [ln.split() for ln in timing.read_text().split("\n") if ln.strip()]
    secs = sum(float(r[0]) for r in rows)
    rss = max(float(r[1]) for r in rows) / 1e6  # KB -> GB
    e = subprocess.run(
        [sys.executable, "-c", ENERGY, str(dem), json.dumps(xy)], capture_output=True, text=True
    )
    if e.returncode != 0:
        return {"error": f"energy of the r.walk path failed: {e.stderr.strip()[-200:]}"}
    return {"energy": float(e.stdout.strip().splitlines()[-1]), "time_s": secs, "rss_gb": rss}


def run_plan(dem: Path, size: int, planner: str, budget: float, timeout: float) -> dict:
    try:
        out = subprocess.run(
            [sys.executable, "-c", CHILD, str(HERE), str(dem), str(size), planner, str(budget)],
            capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return {"error": f"killed at {timeout:.0f} s"}
    if out.returncode != 0:
        return {"error": (out.stderr.strip().splitlines() or ["?"])[-1][:200]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    sys.path.insert(0, str(HERE))
    from _hilly import hilly_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="400,1600")
    ap.add_argument("--lattice-sizes", default="400")
    ap.add_argument("--planners", default="rrtstar,bitstar")
    ap.add_argument("--ompl-time", type=float, default=10.0)
    ap.add_argument("--timeout", type=float, default=900.0)
    args = ap.parse_args()
    grass = ensure_grass()
    print(f"# uptime: {os.popen('uptime').read().strip()}  (2 cores shared with other jobs)")
    print("# hilly DEMs at 1 m, corner to corner; energy = path_energy of each path, default "
          "model; ratios are to the project's search")  # fmt: skip
    print("| DEM | tool | time s | peak RSS GB | energy J | time ratio | RSS ratio | "
          "energy ratio |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        work = Path(d)
        for size in [int(v) for v in args.sizes.split(",") if v]:
            dem = hilly_dem(size, work / f"hilly_{size}.tif")
            rows: dict[str, dict] = {}
            rows["project: search"] = run_plan(dem, size, "search", 0, args.timeout)
            rows["project: plan (auto)"] = run_plan(dem, size, "auto", 0, args.timeout)
            if str(size) in args.lattice_sizes.split(","):
                rows["full lattice, 1 m"] = run_plan(dem, size, "lattice", 0, args.timeout)
            for p in [v for v in args.planners.split(",") if v]:
                rows[f"OMPL {p} ({args.ompl_time:g} s)"] = run_plan(
                    dem, size, p, args.ompl_time, args.timeout
                )
            if grass is None:
                rows["GRASS r.walk"] = {"error": "grass-core not installed (see above)"}
            else:
                rows["GRASS r.walk"] = run_grass(grass, dem, size, work)
            ref = rows["project: search"]
            for name, r in rows.items():
                if "error" in r:
                    print(f"| {size} x {size} | {name} | {r['error']} | | | | | |")
                    continue
                ratios = (
                    ("", "", "")
                    if "error" in ref
                    else (
                        f"{r['time_s'] / ref['time_s']:.2f}",
                        f"{r['rss_gb'] / ref['rss_gb']:.2f}",
                        f"{r['energy'] / ref['energy']:.4f}",
                    )
                )
                print(
                    f"| {size} x {size} | {name} | {r['time_s']:.1f} | {r['rss_gb']:.2f} | "
                    f"{r['energy']:.0f} | {ratios[0]} | {ratios[1]} | {ratios[2]} |",
                    flush=True,
                )
    print(f"# uptime: {os.popen('uptime').read().strip()}")


if __name__ == "__main__":
    main()
