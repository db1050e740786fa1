"""The payoff of discovery: a plan made with the discovered model really costs less.

A campaign is simulated with a physical effect hidden from the base model (the simulator's
truth is mechanistic physics). The base model is fitted (``fit``) and ``discover`` walks the
staircase on the same logs. Both models then plan the same route on a bundled DEM, and each
plan is charged its TRUE energy (``simulate.true_path_energy``: the simulator's physics
integrated along the path, with the same channel values).

Two cases, each planned with the channel option a user would give on the command line:

- ``load``: the robot carries 15 kg (``--set load_kg=15``); the discovered model knows
  what a load costs on slopes, the base model does not.
- ``ground``: the ground varies over the map (``--channel ground=ground.tif:ground.csv``);
  the discovered model knows which ground costs more, the base model plans as if all were
  alike. Two layouts (``--ground``): ``strip`` (default), meadow with a mud strip 8 m wide
  lying on the middle half of the straight start-goal line, so that a slight detour avoids
  it; ``patches``, random 25 m patches of meadow, gravel, mud and asphalt
  (``simulate.ground_map``). Mud costs only ~10 % more per metre than meadow, and the
  planner crab-walks (``moves="all"``), so on ``patches`` both models usually walk the same
  straight line: a detour around a 25 m patch costs more than the mud it avoids.

Each plan also gets the prediction interval ``energy-planner plan`` prints (``--level``,
90 % by default; ``plan_interval``), whether the TRUE energy lies inside it, and the share
of the route outside the model's calibration domain.

Run::

    python benchmarks/payoff_corrected_model.py [--case load|ground] [--small] [--level L] [--json]
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # thousands of small solves; see bench_discover.py

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from energy_planner.uncertainty import DEFAULT_LEVEL  # noqa: E402

CASES = {
    "load": {"effects": ("load",), "sets": ["load_kg=15"], "raster": False},
    "ground": {"effects": ("ground",), "sets": [], "raster": True},
}


@dataclass
class Payoff:
    """One payoff case: what discovery added and what each model's plan truly costs."""

    case: str
    effects: tuple[str, ...]
    added: list[str]
    added_terms: list[str]
    channel_options: list[str]
    heldout_rmse_base_w: float
    heldout_rmse_discovered_w: float
    plans: dict[str, dict[str, float]]
    seconds: float

    @property
    def saving(self) -> float:
        """True energy saved by the discovered model's plan, as a share of the base plan's."""
        b = self.plans["base"]["true_energy_j"]
        c = self.plans["discovered"]["true_energy_j"]
        return (b - c) / b


def mud_strip(gm, start, goal, half_width_m: float = 4.0, span=(0.25, 0.75)):
    """Meadow everywhere but a mud strip on the middle of the straight start-goal line.

    Avoiding the mud is a real choice there: a sideways shift of ~4-5 m, spread over a quarter
    of the route, lengthens it by ~1 m, while crossing the strip costs ~40 m of mud.
    """
    from energy_planner.simulate import GroundMap

    t = gm.terrain
    x_min, _, _, y_max = t.bounds
    rx, ry = (abs(r) for r in t.resolution)
    rows, cols = np.indices(gm.codes.shape)
    x, y = x_min + (cols + 0.5) * rx, y_max - (rows + 0.5) * ry
    d = np.asarray(goal[:2], float) - np.asarray(start[:2], float)
    length = float(np.hypot(*d))
    u = d / length
    along = ((x - start[0]) * u[0] + (y - start[1]) * u[1]) / length
    across = np.abs(-(x - start[0]) * u[1] + (y - start[1]) * u[0])
    codes = np.full(gm.codes.shape, gm.names.index("meadow") + 1, dtype=np.int16)
    mud = (across < half_width_m) & (along > span[0]) & (along < span[1])
    codes[mud] = gm.names.index("mud") + 1
    return GroundMap(codes, gm.names, t)


def plan_interval(terrain, model, result, request, true_j: float, level: float) -> dict:
    """A plan's prediction interval as ``energy-planner plan`` gives it; does it hold the truth.

    The plan's own domain report (``result.domain``) and the interval of the fit's error model
    at the route's duration and share outside the calibration's domain
    (``uncertainty.predict_interval``), the way the ``plan`` command computes them; the
    interval at share 0 is kept beside it. No
    interval (``None``) when the model carries no held-out scores.
    """
    from energy_planner.uncertainty import model_scores, predict_interval

    dom = result.domain
    share = float((dom or {}).get("outside_share", 0.0))
    out: dict = {
        "heldout_scores": 0 if model_scores(model) is None else int(model_scores(model).size),
        "outside_share": None if dom is None else share,
        "outside_reasons": None if dom is None else dom["reasons"],
    }
    for key, s in (("interval", share), ("interval_plain", 0.0)):
        iv = predict_interval(model, float(result.energy_j), level, outside_share=s,
                              duration_s=float(result.duration_s))  # fmt: skip
        out[key] = None if iv is None else iv.to_dict()
        out[f"true_inside_{key}"] = None if iv is None else bool(iv.low_j <= true_j <= iv.high_j)
    return out


def run(
    case: str = "ground",
    seed: int = 0,
    config=None,
    scenario_name: str = "hill_crossing",
    planner: str = "auto",
    out_dir: str | Path | None = None,
    ground: str = "strip",
    level: float = DEFAULT_LEVEL,
) -> Payoff:
    """Simulate, fit the base, discover, plan with both models, charge the truth."""
    from energy_planner.calibration import fit_model
    from energy_planner.diagnosis.discover import discover
    from energy_planner.energy.channels import Channels
    from energy_planner.energy.path import path_energy
    from energy_planner.maps import map_path, scenario
    from energy_planner.measurements import make_windows, preprocess
    from energy_planner.model import BASE_TERMS
    from energy_planner.planning import plan
    from energy_planner.request import Request
    from energy_planner.simulate import (
        CampaignConfig,
        ground_map,
        simulate_campaign,
        true_path_energy,
    )
    from energy_planner.terrain import load_dem

    spec = CASES[case]
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(
            seed=seed, effects=spec["effects"], config=config or CampaignConfig()
        )
        windows = make_windows(preprocess(camp.logs)[0])
        base = fit_model(windows, BASE_TERMS, seed=seed)
        d = discover(camp.logs)
    if d.model is None:
        raise RuntimeError(f"discover could not fit its final model: {d.notes}")

    sc = scenario(scenario_name)
    terrain = load_dem(map_path(sc["map"]))
    start = terrain.to_work(*sc["start"])
    goal = terrain.to_work(*sc["goal"])
    options = [f"--set {s}" for s in spec["sets"]]
    truth_channels: dict = {}
    channel_args: list[str] = []
    for s in spec["sets"]:
        name, value = s.split("=", 1)
        truth_channels[name] = float(value)
    if spec["raster"]:
        gm = ground_map(terrain, seed=seed)
        if ground == "strip":
            gm = mud_strip(gm, start, goal)
        elif ground != "patches":
            raise ValueError(f"ground layout {ground!r} is not 'strip' or 'patches'")
        out = Path(out_dir or tempfile.mkdtemp(prefix="payoff_"))
        tif, csv = gm.write(out / "ground.tif", out / "ground.csv")
        channel_args.append(f"ground={tif}:{csv}")
        options.append(f"--channel ground={tif.name}:{csv.name}")
        truth_channels["ground"] = gm
    channels = Channels.parse(spec["sets"], channel_args)  # what --set / --channel give
    plans = {}
    models = {"base": base.model, "discovered": d.model}
    for name, model in models.items():
        request = Request.make(channels=channels)
        p = plan(terrain, model, start, goal, request, planner=planner, seed=seed,
                 progress=False)  # fmt: skip
        truth = true_path_energy(terrain, p.states, effects=camp.effects,
                                 channels=truth_channels)  # fmt: skip
        plans[name] = {
            "predicted_energy_j": float(p.energy_j),
            "true_energy_j": float(truth.energy_j),
            "distance_m": float(p.distance_m),
            **plan_interval(terrain, model, p, request, float(truth.energy_j), level),
        }
        states = np.asarray(p.states, dtype=float)
        for other, m in models.items():  # each model's prediction of this route
            plans[name][f"predicted_by_{other}_j"] = float(
                path_energy(terrain, m, states[:, :2], yaw=states[:, 2], channels=channels).energy_j
            )
    return Payoff(
        case=case,
        effects=tuple(spec["effects"]),
        added=[s.name for s in d.steps[1:]],
        added_terms=list(d.added),
        channel_options=options,
        heldout_rmse_base_w=float(base.heldout.rmse_w),
        heldout_rmse_discovered_w=float(d.fit.heldout.rmse_w),
        plans=plans,
        seconds=time.perf_counter() - t0,
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=sorted(CASES), action="append")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--small", action="store_true", help="CampaignConfig.small(repeats=2)")
    ap.add_argument("--planner", default="auto")
    ap.add_argument("--scenario", default="hill_crossing", help="bundled scenario name")
    ap.add_argument(
        "--ground",
        choices=("strip", "patches"),
        default="strip",
        help="ground layout of the ground case (see the module docstring)",
    )
    ap.add_argument("--level", type=float, default=DEFAULT_LEVEL, help="interval level")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from energy_planner.simulate import CampaignConfig

    config = CampaignConfig.small(repeats=2) if args.small else CampaignConfig()
    results = [
        run(c, args.seed, config, args.scenario, args.planner, ground=args.ground, level=args.level)
        for c in args.case or sorted(CASES)
    ]
    load = os.getloadavg()
    if args.json:
        print(json.dumps([{**r.__dict__, "saving": r.saving} for r in results], indent=2))
        return 0
    size = "CampaignConfig.small(repeats=2)" if args.small else "CampaignConfig()"
    print(f"campaigns: {size}, seed {args.seed}; scenario {args.scenario}; planner "
          f"{args.planner}; ground layout {args.ground}")  # fmt: skip
    lv = f"{100 * args.level:g}% interval kJ"
    print(
        f"{'case':<8}{'planned with':<46}{'model':<12}{'predicted kJ':>13}{'TRUE kJ':>10}"
        f"{'distance m':>12}{lv:>22}{'TRUE inside':>13}{'outside domain':>16}"
    )
    for r in results:
        for name, p in r.plans.items():
            iv = p["interval"]
            iv_s = (
                "(no scores)"
                if iv is None
                else f"{iv['low_j'] / 1e3:.2f} .. {iv['high_j'] / 1e3:.2f}"
            )
            inside = {None: "-", True: "yes", False: "NO"}[p["true_inside_interval"]]
            share = p["outside_share"]
            print(
                f"{r.case:<8}{' '.join(r.channel_options):<46}{name:<12}"
                f"{p['predicted_energy_j'] / 1e3:>13.2f}{p['true_energy_j'] / 1e3:>10.2f}"
                f"{p['distance_m']:>12.1f}{iv_s:>22}{inside:>13}"
                f"{'(no domain)' if share is None else f'{100 * share:.0f}%':>16}"
            )
            if p["outside_reasons"]:
                why = "; ".join(f"{k} {100 * v:.0f}%" for k, v in p["outside_reasons"].items())
                print(f"{'':<8}  {name} route outside the calibration: {why}")
            pl = p["interval_plain"]
            if pl is not None and pl != iv:
                print(
                    f"{'':<8}  {name} interval without the domain widening: "
                    f"{pl['low_j'] / 1e3:.2f} .. {pl['high_j'] / 1e3:.2f} kJ, TRUE inside: "
                    f"{'yes' if p['true_inside_interval_plain'] else 'NO'}"
                )
            print(f"{'':<8}  {name} model: {p['heldout_scores']} held-out run scores")
        print(
            f"{'':<8}discovered: {', '.join(r.added) or '(nothing)'}; held-out RMSE base "
            f"{r.heldout_rmse_base_w:.2f} W -> {r.heldout_rmse_discovered_w:.2f} W; TRUE "
            f"energy saved by the discovered model's plan: {100 * r.saving:.1f}% "
            f"({r.seconds:.0f} s)"
        )
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    raise SystemExit(main())
