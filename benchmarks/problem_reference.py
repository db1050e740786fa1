"""Reference numbers of every planner and product on a small hill (tests/test_problem.py).

Usage::

    python benchmarks/problem_reference.py > ref.json

Runs ``plan`` with every planner but ``auto`` (OMPL ones for 100 iterations),
``compare_routes``, ``reach``, ``energy_matrix`` and ``energy_map`` on a 24 x 24 Gaussian
hill with a slope limit and a keep-out box, in the older call forms (terrain, model,
..., request), and prints their numbers as JSON (about 6 s). Run on main at ade1759, before
the Problem moved below planning (``git archive ade1759 energy_planner`` unpacked and put
first on PYTHONPATH), it gave the literal values of ``tests/test_problem.py``.
"""

import json
import sys
import tempfile
import warnings

import numpy as np
from shapely.geometry import box

from energy_planner.energymap import energy_map
from energy_planner.mission import Sites, energy_matrix
from energy_planner.model import EnergyModel
from energy_planner.planning.compare import compare_routes
from energy_planner.planning.plan import RUNNERS, plan
from energy_planner.planning.reach import reach
from energy_planner.request import Request
from energy_planner.terrain import Terrain

y, x = np.mgrid[0:24, 0:24]
z = 3.0 * np.exp(-((x - 12.0) ** 2 + (y - 11.0) ** 2) / (2 * 4.0**2))
t = Terrain.from_array(z, resolution=1.0, origin=(0.0, 0.0))
m = EnergyModel.default()
req = Request.make(max_slope_deg=25, keep_out=[box(15.2, 4.2, 17.8, 9.8)])
S, G = (3.0, 4.0, 0.0), (20.0, 18.0)
out = {}
for name in RUNNERS:
    if name == "auto":
        continue
    kw = {"iterations": 100} if name not in ("search", "lattice") else {}
    r = plan(t, m, S, G, req, planner=name, progress=False, seed=1, **kw)
    out[f"plan_{name}"] = [r.energy_j, r.distance_m, len(r.states)]
c = compare_routes(t, m, S, G, req, time=1.0, progress=False, planner="search")
out["compare"] = {r.name: r.energy_j for r in c.routes}
rm = reach(t, m, (5.0, 5.0), req, n_headings=8)
e = rm.energy_j
out["reach"] = [float(np.nansum(e)), int(np.isfinite(e).sum()), float(e[18, 20])]
s = Sites(np.array([[3.0, 4.0], [20.0, 18.0], [12.0, 20.0]]), ["a", "b", "c"]).on_cells(t)
E = energy_matrix(t, m, s, req, n_headings=8)
out["energy_matrix"] = E.tolist()
with tempfile.TemporaryDirectory() as d:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = energy_map(t, f"{d}/em.tif", m, request=req, headings=8, progress=False)
    import rasterio

    with rasterio.open(f"{d}/em.tif") as src:
        a = src.read()
    out["energy_map"] = [float(np.nansum(a)), int(np.isfinite(a).sum()), a.shape[0]]
json.dump(out, sys.stdout, indent=1)
