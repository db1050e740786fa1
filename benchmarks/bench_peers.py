"""Peers side by side: GRASS r.walk, the project's search, the full lattice, OMPL planners.

Usage::

    python benchmarks/bench_peers.py [--sizes 400,1600] [--ompl-time 10]
        [--lattice-sizes 400] [--planners rrtstar,bitstar]
        [--notch-extent 3200] [--notch-rows 0,1,2,3,4] [--repeat 1] [--no-optimum]
        [--mission-size 2000] [--mission-sites 20] [--mission-max-slope 15]
        [--mission-eps 1.05] [--mission-workers 2] [--mission-legs 19] [--quick]

First issue 32's mission row (``--mission-size``, 0 to skip; :func:`mission_rows`): the
mission of 20 random sites on the 2000² hilly DEM (the energy matrix, the order settled
on ``plan``'s legs, every leg planned) against the GIS way to the pairs' costs, one
``r.walk`` per site with the other sites as stop points, the same barriers (cells steeper
than 15°), alternating; wall and CPU time with their ratios (target: the mission no
slower than the loop); the matrix on a dask LocalCluster, its CPU time over every process
against the serial run's (target: at most 10 % more); and the tour's legs against
``plan`` asked for each (target: within 0.5 %). ``--quick``: the mission row on 1000², the
notch rows at 800 m, no hilly rows.

Then issue 21's table (``--notch-extent``, 0 to skip; 800 for a reduced run): a ridge
with a narrow notch (``benchmarks/_notch.py``) at 1, 2 and 4 m, with and without
``--max-slope 30`` and a 30 m keep-out square over the notch (:data:`NOTCH_ROWS`): GRASS
``r.walk`` given the same barriers (null friction) beside the default planner, alternating,
wall and CPU time and peak RSS with their ratios, and each energy over the
full-resolution optimum (``search`` with ``eps = 1``; ``--no-optimum`` skips it, it is
slow at full size). Then the hilly rows:

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
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

NOTCH_CHILD = r"""
import json, resource, sys, time
spec = json.loads(sys.argv[1])
from shapely.geometry import shape
from energy_planner.model import EnergyModel
from energy_planner.planning.plan import plan
from energy_planner.request import Request
from energy_planner.terrain import load_dem
t = load_dem(spec["dem"]); m = EnergyModel.default()
req = Request.make(
    max_slope_deg=spec.get("max_slope"),
    keep_out=[shape(spec["keep_out"])] if spec.get("keep_out") else None,
)
s = t.to_work(*spec["start"]); g = t.to_work(*spec["goal"])
r0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
r = plan(t, m, s, g, req, planner=spec["planner"], eps=spec.get("eps"), progress=False)
wall = time.perf_counter() - t0
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps(dict(energy=r.energy_j, time_s=wall, distance=r.distance_m,
                      cpu_s=r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime,
                      rss_gb=r1.ru_maxrss / 1e6)))
"""

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


MISSION_CHILD = r"""
import json, resource, sys, time
import numpy as np
spec = json.loads(sys.argv[1])

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

def hwm():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1e6
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6

from energy_planner.mission import Sites, mission
from energy_planner.mission.matrix import matrix_search
from energy_planner.model import EnergyModel
from energy_planner.request import Request
from energy_planner.terrain import load_dem
m = EnergyModel.default()
req = Request.make(max_slope_deg=spec.get("max_slope"))
xy = np.array(spec["sites"], float)
names = [f"s{i}" for i in range(len(xy))]
client = None
if spec.get("workers"):
    import dask
    from distributed import Client, LocalCluster
    from energy_planner.mission.matrix import CLUSTER_CONFIG
    dask.config.set(CLUSTER_CONFIG)  # what docs/routes.md tells a cluster's user to set
    cluster = LocalCluster(n_workers=spec["workers"], threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    t = load_dem(spec["dem"])
    two = Sites(xy[:2], names[:2]).on_cells(t)
    matrix_search(t, m, two, req, eps=spec["eps"], client=client)  # load the kernels

    import psutil

    def wcpu():  # the workers and their nannies (the scheduler runs in this process)
        return sum(sum(p.cpu_times()[:2]) for p in psutil.Process().children(recursive=True))
    w0 = wcpu()

    def threads():  # each thread of a worker: the task thread and the event loop apart
        import threading
        names = {t.native_id: t.name for t in threading.enumerate()}
        return {names.get(t.id, str(t.id)): t.user_time + t.system_time
                for t in psutil.Process().threads()}
    th0 = client.run(threads)
else:  # the same warm-up in this process: the kernels loaded before the clock starts
    t = load_dem(spec["dem"])
    matrix_search(t, m, Sites(xy[:2], names[:2]).on_cells(t), req, eps=spec["eps"])
c0, t0 = cpu(), time.perf_counter()
t = load_dem(spec["dem"])
sites = Sites(np.column_stack(t.to_work(xy[:, 0], xy[:, 1])), names)
# the whole mission: the matrix, the order settled on plan's legs, the legs planned
res = mission(t, m, sites, req, eps=spec["eps"], client=client, progress=False)
wall = time.perf_counter() - t0
c = cpu() - c0
E = res.matrix_j
i = res.info
out = dict(time_s=wall, cpu_s=c, rss_gb=hwm(), info={**i["matrix"], **{
           k: i[k] for k in ("matrix_s", "matrix_cpu_s", "legs_s", "legs_cpu_s")},
           "order_check": i.get("order_check"), "method": res.method},
           finite=int(np.isfinite(E).sum()))
if client is not None:
    out["worker_cpu_s"] = wcpu() - w0
    out["cpu_s"] = c + out["worker_cpu_s"]
    out["workers_rss_gb"] = sorted(client.run(hwm).values())
    th1 = client.run(threads)
    d = [(k, v - th0[w].get(k, 0.0)) for w in th1 for k, v in th1[w].items()]
    out["task_cpu_s"] = sum(v for k, v in d if "Dask-Default-Threads" in k)
    out["loop_cpu_s"] = sum(v for k, v in d if k == "MainThread")
    client.close()
    cluster.close()
legs = []
if spec.get("legs"):  # each leg the mission reports against plan asked for it
    from energy_planner.planning.plan import plan
    for leg in res.legs[: spec["legs"]]:
        a, b = tuple(sites.xy[leg.a]), tuple(sites.xy[leg.b])
        auto = plan(t, m, a, b, req, progress=False)
        legs.append([leg.a, leg.b, float(E[leg.a, leg.b]), leg.energy_j, float(auto.energy_j)])
out["legs"] = legs
print(json.dumps(out))
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


def run_grass(
    grass: str,
    dem: Path,
    size: int,
    work: Path,
    ends: tuple | None = None,
    friction: str = "0",
) -> dict:
    """r.walk -k and r.drain on ``dem`` (``ends``: start and goal, default the corners).

    ``friction``: an r.mapcalc expression for the friction map (``null()`` cells are
    barriers r.walk never enters; ``slope``, Horn's slope in degrees by r.slope.aspect,
    may be used). Returns energy (path_energy of the drained path, no limits), wall and
    CPU time (r.walk + r.drain; the slope and friction maps are the barrier input, not
    counted), peak RSS and length.
    """
    sys.path.insert(0, str(HERE))
    from _hilly import corners

    (sx, sy), (gx, gy) = ends if ends is not None else corners(size)
    db = work / "grassdb"
    shutil.rmtree(db, ignore_errors=True)
    subprocess.run([grass, "-c", "EPSG:32631", str(db), "-e"], check=True, capture_output=True)
    timing = work / "timing.txt"
    script = work / "run.sh"
    script.write_text(
        "set -e\n"
        f"r.in.gdal -o input={dem} output=dem --overwrite --quiet\n"
        "g.region raster=dem\n"
        "r.slope.aspect elevation=dem slope=slope --overwrite --quiet\n"
        f"r.mapcalc 'friction = {friction}' --overwrite --quiet\n"
        f"/usr/bin/time -f '%e %M %U %S' -o {timing} r.walk -k elevation=dem friction=friction "
        f"output=cost outdir=dir start_coordinates={sx},{sy} stop_coordinates={gx},{gy} "
        "--overwrite --quiet\n"
        f"/usr/bin/time -a -f '%e %M %U %S' -o {timing} r.drain -d input=cost direction=dir "
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
    cpu = sum(float(r[2]) + float(r[3]) for r in rows)
    rss = max(float(r[1]) for r in rows) / 1e6  # KB -> GB
    length = float(sum(math.dist(p, q) for p, q in zip(xy[:-1], xy[1:], strict=True)))
    e = subprocess.run(
        [sys.executable, "-c", ENERGY, str(dem), json.dumps(xy)], capture_output=True, text=True
    )
    if e.returncode != 0:
        return {"error": f"energy of the r.walk path failed: {e.stderr.strip()[-200:]}"}
    return {
        "energy": float(e.stdout.strip().splitlines()[-1]), "time_s": secs, "rss_gb": rss,
        "cpu_s": cpu, "distance": length,
    }  # fmt: skip


def run_grass_loop(grass: str, dem: Path, sites: list, work: Path, friction: str = "0") -> dict:
    """One ``r.walk -k`` per site over ``dem``: the GIS way to a mission's matrix.

    Each run starts at its site with the other sites as stop points (r.walk stops once
    they are all reached) and writes no direction map (the matrix needs only the costs,
    read with ``r.what``, not timed). ``friction`` as :func:`run_grass` (barriers: null).
    Returns the wall and CPU time of the runs together, their peak RSS and how many of
    the n (n - 1) costs are finite.
    """
    db = work / "grassdb"
    shutil.rmtree(db, ignore_errors=True)
    subprocess.run([grass, "-c", "EPSG:32631", str(db), "-e"], check=True, capture_output=True)
    timing = work / "timing.txt"
    timing.unlink(missing_ok=True)
    lines = [
        "set -e",
        f"r.in.gdal -o input={dem} output=dem --overwrite --quiet",
        "g.region raster=dem",
        "r.slope.aspect elevation=dem slope=slope --overwrite --quiet",
        f"r.mapcalc 'friction = {friction}' --overwrite --quiet",
    ]
    for k, (x, y) in enumerate(sites):
        stops = ",".join(f"{a},{b}" for j, (a, b) in enumerate(sites) if j != k)
        lines += [
            f"/usr/bin/time -a -f '%e %M %U %S' -o {timing} r.walk -k elevation=dem "
            f"friction=friction output=cost start_coordinates={x},{y} "
            f"stop_coordinates={stops} --overwrite --quiet",
            f"r.what map=cost coordinates={stops}",
        ]
    script = work / "loop.sh"
    script.write_text("\n".join(lines) + "\n")
    out = subprocess.run([grass, str(db / "PERMANENT"), "--exec", "bash", str(script)],
                         capture_output=True, text=True)  # fmt: skip
    if out.returncode != 0 or not timing.exists():
        return {"error": f"r.walk failed: {out.stderr.strip()[-200:]}"}
    rows = [ln.split() for ln in timing.read_text().split("\n") if ln.strip()]
    vals = [ln.split("|")[-1] for ln in out.stdout.split("\n") if ln.count("|") >= 3]
    finite = sum(1 for v in vals if v.strip() not in ("", "*") and math.isfinite(float(v)))
    return {
        "time_s": sum(float(r[0]) for r in rows), "runs": len(rows), "finite": finite,
        "cpu_s": sum(float(r[2]) + float(r[3]) for r in rows),
        "rss_gb": max(float(r[1]) for r in rows) / 1e6,
    }  # fmt: skip


def _child(args: list[str], timeout: float) -> dict:
    """``python -c ARGS...`` in its own process, so that its peak RSS is its own.

    Its last stdout line is the JSON result; ``{"error": ...}`` when it fails or times out.
    """
    try:
        out = subprocess.run([sys.executable, "-c", *args], capture_output=True, text=True,
                             timeout=timeout)  # fmt: skip
    except subprocess.TimeoutExpired:
        return {"error": f"killed at {timeout:.0f} s"}
    if out.returncode != 0:
        return {"error": (out.stderr.strip().splitlines() or ["?"])[-1][:200]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_plan(dem: Path, size: int, planner: str, budget: float, timeout: float) -> dict:
    return _child([CHILD, str(HERE), str(dem), str(size), planner, str(budget)], timeout)


#: issue 21's rows: (label, cell m, max slope deg or None, 30 m keep-out over the notch,
#: the most the default planner may take as a multiple of r.walk's time)
NOTCH_ROWS = [
    ("1 m, notch open, --max-slope 30", 1, 30.0, False, 1.0),
    ("2 m, no limit (through the notch)", 2, None, False, 1.5),
    ("2 m, --max-slope 30 closes the notch", 2, 30.0, False, 1.5),
    ("4 m, --max-slope 30 closes the notch", 4, 30.0, False, 1.5),
    ("1 m, 30 m keep-out over the notch", 1, None, True, 1.5),
]


def run_spec(spec: dict, timeout: float) -> dict:
    """The project's planner on one notch row, in its own process (:data:`NOTCH_CHILD`)."""
    return _child([NOTCH_CHILD, json.dumps(spec)], timeout)


def _median(runs: list[dict]) -> dict:
    ok = [r for r in runs if "error" not in r]
    if not ok:
        return runs[-1]
    ok.sort(key=lambda r: r["time_s"])
    return ok[len(ok) // 2]


def notch_rows(grass: str | None, extent: int, work: Path, args) -> None:
    """Issue 21's table: the notch DEM at 1, 2 and 4 m, r.walk beside the default planner.

    Per row, ``--repeat`` times alternating: r.walk (barriers: the cells steeper than the
    limit, or the keep-out square, as null friction), the default planner (``auto``);
    then once the full-resolution optimum (``search``, ``eps = 1``) the energies are
    compared with. Ratios: the planner's over r.walk's (time: wall and CPU; RSS).
    """
    sys.path.insert(0, str(HERE))
    from _notch import endpoints, keep_out_square, notch_dem

    print(f"# notch DEM ({extent} m square; benchmarks/_notch.py); wall and CPU s; ratio = "
          "project / r.walk; quality = energy / the eps = 1 search's")  # fmt: skip
    print("| row | tool | wall s | CPU s | peak RSS GB | energy J | length m | wall ratio | "
          "CPU ratio | RSS ratio | quality | target |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    chosen = {int(v) for v in args.notch_rows.split(",") if v}
    for k, (label, cell, max_slope, keep, target) in enumerate(NOTCH_ROWS):
        if k not in chosen:
            continue
        dem = work / f"notch_{extent}_{cell}.tif"
        if not dem.exists():
            notch_dem(extent, cell, dem)
        (sx, sy), (gx, gy) = endpoints(extent, cell)
        spec = {"dem": str(dem), "start": [sx, sy], "goal": [gx, gy], "planner": "auto"}
        friction = "0"
        if max_slope is not None:
            spec["max_slope"] = max_slope
            friction = f"if(slope > {max_slope:g}, null(), 0)"
        if keep:
            sq = keep_out_square(extent)
            spec["keep_out"] = sq
            (x0, y0), _, (x1, y1) = sq["coordinates"][0][:3]
            friction = f"if(x() > {x0} && x() < {x1} && y() > {y0} && y() < {y1}, null(), 0)"
        walks, autos = [], []
        for _ in range(args.repeat):
            if grass is None:
                walks.append({"error": "grass-core not installed (see above)"})
            else:
                walks.append(run_grass(grass, dem, 0, work, ((sx, sy), (gx, gy)), friction))
            autos.append(run_spec(spec, args.timeout))
        rows = {"GRASS r.walk": _median(walks), "plan (auto)": _median(autos)}
        if not args.no_optimum:
            rows["search --eps 1 (optimum)"] = run_spec(
                {**spec, "planner": "search", "eps": 1.0}, args.timeout
            )
        ref, opt = rows["GRASS r.walk"], rows.get("search --eps 1 (optimum)", {"error": ""})
        n = extent // cell
        for name, r in rows.items():
            head = f"| {n}² at {cell} m: {label.split(', ', 1)[1]} | {name} |"
            if "error" in r:
                print(f"{head} {r['error']} | | | | | | | | | |", flush=True)
                continue
            rat = ["", "", ""]
            if "error" not in ref and name != "GRASS r.walk":
                rat = [f"{r['time_s'] / ref['time_s']:.2f}", f"{r['cpu_s'] / ref['cpu_s']:.2f}",
                       f"{r['rss_gb'] / ref['rss_gb']:.2f}"]  # fmt: skip
            q = "" if "error" in opt else f"{r['energy'] / opt['energy']:.4f}"
            tgt = ""
            if name == "plan (auto)":
                tgt = f"time <= {target:g}x" + (", RSS <= 1.5x" if target == 1.0 else "")
                tgt += ", quality <= 1.01"
            print(
                f"{head} {r['time_s']:.2f} | {r['cpu_s']:.2f} | {r['rss_gb']:.2f} | "
                f"{r['energy']:.0f} | {r['distance']:.0f} | {rat[0]} | {rat[1]} | {rat[2]} | "
                f"{q} | {tgt} |",
                flush=True,
            )


def mission_sites(size: int, n: int, seed: int = 0) -> list[tuple[float, float]]:
    """``n`` random cell centres of the ``size``² hilly DEM, 5 cells inside its edges."""
    import numpy as np
    from _hilly import X0, Y0

    rng = np.random.default_rng(seed)
    cells = np.floor(rng.uniform(5, size - 5, (n, 2)))
    return [(X0 + i + 0.5, Y0 + j + 0.5) for i, j in cells]


def mission_rows(grass: str | None, work: Path, args) -> None:
    """Issue 32's mission row: the mission of ``--mission-sites`` sites against r.walk per site.

    On the hilly DEM of ``--mission-size`` (1 m), the same barriers on both sides (cells
    steeper than ``--mission-max-slope``: null friction for r.walk, the slope limit for
    the project), ``--repeat`` times alternating: the r.walk loop (:func:`run_grass_loop`)
    and the project's whole mission (:func:`energy_planner.mission.mission` with the
    matrix at ``--mission-eps``: the matrix, the order settled on ``plan``'s legs, every
    leg planned; in its own process, the DEM's loading included), its matrix's share
    apart. Then the mission with the matrix on a dask LocalCluster of
    ``--mission-workers`` processes (0: skip; configured with
    :data:`~energy_planner.mission.matrix.CLUSTER_CONFIG`, as docs/routes.md tells a
    cluster's user), its CPU time (this process with the
    scheduler, plus the workers and their nannies) against the serial run's, whole and
    the matrix's; and the first ``--mission-legs`` legs of the tour against ``plan``
    asked for each (its defaults, the same limit).
    """
    from _hilly import hilly_dem

    size, n = args.mission_size, args.mission_sites
    dem = hilly_dem(size, work / f"hilly_{size}.tif")
    sites = mission_sites(size, n)
    lim = args.mission_max_slope
    spec = {"dem": str(dem), "sites": sites, "max_slope": lim, "eps": args.mission_eps}
    friction = f"if(slope > {lim:g}, null(), 0)"
    _child(
        [MISSION_CHILD, json.dumps({**spec, "sites": sites[:2]})], args.mission_timeout
    )  # warm-up
    walks, mats = [], []
    for k in range(args.repeat):
        if args.no_grass:
            walks.append({"error": "skipped (--no-grass)"})
        elif grass is None:
            walks.append({"error": "grass-core not installed (see above)"})
        else:
            walks.append(run_grass_loop(grass, dem, sites, work, friction))
        last = k == args.repeat - 1
        mats.append(_child([MISSION_CHILD, json.dumps({**spec, "legs": args.mission_legs
                                                       if last else 0})],
                           args.mission_timeout))  # fmt: skip
    print(f"# mission: {n} sites on the {size}² hilly DEM at 1 m, cells steeper than "
          f"{lim:g}° are barriers on both sides; {args.repeat} run(s) each, alternating, "
          "median; ratio = project / r.walk loop")  # fmt: skip
    print("| run | wall s | CPU s | peak RSS GB | costs found | wall ratio | CPU ratio | target |")
    print("|---|---|---|---|---|---|---|---|")
    walk, mat = _median(walks), _median(mats)
    if "error" in walk:
        print(f"| {n} × r.walk -k (one per site, the others as stop points) | {walk['error']} "
              "| | | | | | |")  # fmt: skip
    else:
        print(f"| {n} × r.walk -k (one per site, the others as stop points) | "
              f"{walk['time_s']:.1f} | {walk['cpu_s']:.1f} | {walk['rss_gb']:.2f} | "
              f"{walk['finite']} of {n * (n - 1)} | | | |")  # fmt: skip
    name = f"mission (matrix eps {args.mission_eps:g}, order settled on plan's legs, legs planned)"
    if "error" in mat:
        print(f"| {name} | {mat['error']} | | | | | | |")
    else:
        rat = ["", ""]
        if "error" not in walk:
            rat = [f"{mat['time_s'] / walk['time_s']:.2f}", f"{mat['cpu_s'] / walk['cpu_s']:.2f}"]
        i = mat["info"]
        print(f"| {name}, serial | {mat['time_s']:.1f} | {mat['cpu_s']:.1f} | "
              f"{mat['rss_gb']:.2f} | {mat['finite']} of {n * (n - 1) + n}"
              f" | {rat[0]} | {rat[1]} | no slower than the loop (<= 1.00) |")  # fmt: skip
        oc = i.get("order_check") or {}
        print(f"# mission: matrix {i['matrix_s']:.1f} s / {i['matrix_cpu_s']:.1f} CPU s "
              f"({i['expanded']:,} states expanded, {i['priced']:,} edges priced, {i['edges']}"
              f"), order and legs {i['legs_s']:.1f} s / {i['legs_cpu_s']:.1f} CPU s "
              f"({oc.get('legs_planned')} legs planned, {oc.get('orders')} orders, "
              f"{i['method']}); runs: " + ", ".join(
                  f"{r['time_s']:.1f} s / {r['cpu_s']:.1f} CPU s" for r in mats if "error" not in r)
              + "; r.walk loops: " + ", ".join(
                  f"{r['time_s']:.1f} s / {r['cpu_s']:.1f} CPU s" for r in walks
                  if "error" not in r))  # fmt: skip
    if args.mission_workers and "error" not in mat:
        d = _child([MISSION_CHILD, json.dumps({**spec, "workers": args.mission_workers})],
                   args.mission_timeout)  # fmt: skip
        if "error" in d:
            print(f"| dask LocalCluster, {args.mission_workers} workers | {d['error']} "
                  "| | | | | | |")  # fmt: skip
        else:
            # the matrix's CPU over every process: the whole less the legs (this process)
            dm = d["cpu_s"] - d["info"]["legs_cpu_s"]
            sm = mat["info"]["matrix_cpu_s"]
            print(f"| the mission, matrix on a dask LocalCluster of {args.mission_workers} "
                  f"workers (CPU: all processes) | {d['time_s']:.1f} | {d['cpu_s']:.1f} | "
                  f"{'/'.join(f'{v:.2f}' for v in d['workers_rss_gb'])} | {d['finite']} | "
                  f"{d['time_s'] / mat['time_s']:.2f} (to serial) | "
                  f"{d['cpu_s'] / mat['cpu_s']:.2f} (to serial; the matrix's: {dm:.1f} / "
                  f"{sm:.1f} = {dm / sm:.2f}) | CPU <= 1.10x serial |"
            )  # fmt: skip
            print(f"# dask: matrix {d['info']['matrix_s']:.1f} s wall, {d['info']['priced']:,} "
                  f"edges priced (serial {mat['info']['priced']:,}), workers "
                  f"{d['worker_cpu_s']:.1f} CPU s (their tasks' threads {d['task_cpu_s']:.1f}, "
                  f"their event loops {d['loop_cpu_s']:.1f}), this process (client and "
                  f"scheduler, the legs included) {d['cpu_s'] - d['worker_cpu_s']:.1f} CPU s; "
                  f"serial matrix {sm:.1f} CPU s")  # fmt: skip
    if "error" not in mat and mat["legs"]:
        legs = mat["legs"]
        worst = max(abs(e / p - 1.0) for _, _, _, e, p in legs)
        print("# the mission's legs against plan asked for each (its defaults, the same "
              "limit), leg / plan - 1: "
              + ", ".join(f"s{i}->s{j} {e / p - 1.0:+.3%}" for i, j, _, e, p in legs)
              + f"; largest {worst:.3%} (target <= 0.5 %); the matrix entries (bounds the "
              "order is settled on) over plan's: "
              + ", ".join(f"{m / p - 1.0:+.3%}" for _, _, m, _, p in legs))  # fmt: skip


def main() -> None:
    sys.path.insert(0, str(HERE))
    from _hilly import hilly_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="400,1600")
    ap.add_argument("--lattice-sizes", default="400")
    ap.add_argument("--planners", default="rrtstar,bitstar")
    ap.add_argument("--ompl-time", type=float, default=10.0)
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("--notch-extent", type=int, default=3200,
                    help="side of the notch DEM in metres (0: no notch rows)")  # fmt: skip
    ap.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="runs per notch row, r.walk and the planner alternating (median)",
    )
    ap.add_argument(
        "--notch-rows", default="0,1,2,3,4", help="which rows of NOTCH_ROWS to run (indices)"
    )
    ap.add_argument(
        "--no-optimum",
        action="store_true",
        help="skip the eps = 1 search (the quality reference) of the notch rows",
    )
    ap.add_argument(
        "--mission-size",
        type=int,
        default=2000,
        help="side of the mission row's hilly DEM, cells (0: no mission row)",
    )
    ap.add_argument("--mission-sites", type=int, default=20)
    ap.add_argument(
        "--mission-max-slope",
        type=float,
        default=15.0,
        help="barriers of the mission row: cells steeper than this, degrees",
    )
    ap.add_argument(
        "--mission-eps",
        type=float,
        default=1.05,
        help="the matrix's eps (mission --eps; plan's default 1.05)",
    )
    ap.add_argument(
        "--mission-workers",
        type=int,
        default=2,
        help="dask LocalCluster workers of the mission row's CPU check (0: skip)",
    )
    ap.add_argument("--mission-legs", type=int, default=19,
                    help="legs of the tour checked against plan")  # fmt: skip
    ap.add_argument("--mission-timeout", type=float, default=3600.0,
                    help="seconds for each run of the mission row (the matrix at load 10 on "
                    "2 cores took 1123 s)")  # fmt: skip
    ap.add_argument(
        "--no-grass",
        action="store_true",
        help="the mission row without the r.walk loop (the dask check alone)",
    )
    ap.add_argument("--quick", action="store_true",
                    help="reduced sizes: notch 800, mission 1000², no hilly rows")  # fmt: skip
    args = ap.parse_args()
    if args.quick:
        args.notch_extent, args.mission_size, args.sizes = 800, 1000, ""
    grass = ensure_grass()
    print(f"# uptime: {os.popen('uptime').read().strip()}  (2 cores shared with other jobs)")
    if args.mission_size:
        with tempfile.TemporaryDirectory() as d:
            mission_rows(grass, Path(d), args)
        print()
    if args.notch_extent:
        with tempfile.TemporaryDirectory() as d:
            notch_rows(grass, args.notch_extent, Path(d), args)
        print()
    if not [v for v in args.sizes.split(",") if v]:
        print(f"# uptime: {os.popen('uptime').read().strip()}")
        return
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
