"""Speed chosen by the planner, priced by the simulator's own physics.

A simulated robot that trots at every speed (``GaitSchedule(("trot",))``: one gait, since
the planner chooses the speed but not the ``gait`` channel) walks the across-speeds
campaign (``CampaignConfig.across_speeds``: 8 speeds 0.15-1.2 m/s); ``calibration.fit_model``
fits its speed terms (the truth's optimum is interior: ~0.69 m/s on level ground, ~1.07
m/s up 20 deg). On the bundled hill, for several start/goal pairs, every plan is priced by
the TRUTH (``simulate.true_path_energy`` with the plan's speed profile, the speed of each
segment = its surface length / its duration) and checked against the targets:

(a) the plan with the speed chosen (``speed="auto"``) costs no more than the best
    constant speed over the same route (15 constant speeds scanned over the range) and
    at least 5 % less than the plan at the nominal 0.3 m/s (its own route);
(b) every point of a ``--pareto`` front (7 points) lies within its interval of the
    truth's energy for its path and speed profile (coverage reported);
(c) ``deadline=`` (halfway between the auto plan's duration and the front's fastest
    point's) is met by the returned path's physics
    duration;
(d) the energy of held-out across-speed missions' logged poses, with their times
    (``bench_field_logs.mission_energy``: ``follow.walked_path`` then
    ``energy.path_energy`` and the ``energy`` command's interval), holds their measured
    battery energy at the nominal 90 % coverage (read against the binomial band); by the
    planning model and by ``discover`` on training missions across speeds (the path of
    single-speed logs, ``bench_field_logs.run_dataset``).

Usage::

    python benchmarks/bench_speed_physics.py            # full campaign, 3 pairs, 12 missions
    python benchmarks/bench_speed_physics.py --small --forward-only  # the test's campaign

Measured (seed 0, ``--missions 8 --duration 60 --train 12``; 3 pairs; fit 109 s and plans
108 s on 2 shared cores)::

    pair  (a) vs best constant  (a) vs 0.3 m/s  model/physics  (b) front in  (c) physics <= deadline
    0     -1.05 %               -39.0 %         1.004          7/7           39.9 <= 40.3 s
    1     -0.19 %               -25.3 %         0.994          3/7           131.2 <= 133.4 s
    2     -0.04 %               -22.1 %         0.995          7/7           141.6 <= 142.9 s
    (d) held-out missions in 90 %: campaign fit 8/8, discover on 12 missions 6/8 (band 5-8)

Pair 1's four misses are one path (the front's fastest, every motion at the top speed
1.21 m/s, repeated for the last four lambdas): the truth is 0.92 % above the model and the
interval's half-width for that 101 s path is 0.70 %. The fitted speed terms approximate
the truth's non-polynomial laws and under-predict it at the top of the range (-1.0 % on
level ground at 1.2 m/s, against -0.5 % at 0.3 m/s): a systematic error at the range's
end that does not average out over a path, while the interval narrows with the duration.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: The nominal speed of today's plans, m/s.
NOMINAL = 0.3
#: Start/goal pairs on the bundled hill (EPSG:32631; the hill spans 500000-500200,
#: 5000000-5000200): the README's climb, across the summit, along the flank.
PAIRS = (
    ((500058.0, 5000046.0), (500058.0, 5000084.0)),
    ((500040.0, 5000100.0), (500160.0, 5000100.0)),
    ((500060.0, 5000150.0), (500150.0, 5000060.0)),
)


def robot(seed: int = 0, small: bool = False) -> tuple[Any, Any]:
    """The across-speeds campaign of a trotting robot and the model fitted on it."""
    from energy_planner.calibration import fit_model
    from energy_planner.calibration.fit import base_terms
    from energy_planner.calibration.prepare import prepare_logs
    from energy_planner.simulate import CampaignConfig, simulate_campaign
    from energy_planner.simulate.gaits import GaitSchedule

    cfg = CampaignConfig.across_speeds(small=small, gaits=GaitSchedule(("trot",)))
    camp = simulate_campaign(seed=seed, config=cfg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # standing runs dropped by preprocessing
        # the fit command's path: the data checks repair the odometry's slip (the legged
        # odometry under-reports speed by 2 % + 10 % sin(slope)); without it the model
        # prices the true ground speed 2-6 % high and its intervals cannot know
        w = prepare_logs(camp.logs).windows
    return camp, fit_model(w, base_terms(w), n_splits=5, seed=seed).model


def physics_speeds(terrain: Any, camp: Any, res: Any) -> np.ndarray | float:
    """The speed of each segment of a plan (surface length / duration); nominal without times.

    A segment that only turns keeps any positive speed (its duration is the turn's).
    """
    from energy_planner.simulate import true_path_energy

    if res.times is None:
        return NOMINAL
    d = true_path_energy(terrain, res.states, camp.effects, speed=1.0,
                         gaits=camp.physics.gaits).segments["distance_m"].to_numpy()  # fmt: skip
    dt = np.diff(res.times)
    return np.where(d > 1e-9, d / np.where(dt > 0, dt, 1.0), 1.0)


def truth(terrain: Any, camp: Any, states: Any, speed: Any) -> Any:
    """The simulator's energy and duration of walking ``states`` at ``speed``."""
    from energy_planner.simulate import true_path_energy

    return true_path_energy(terrain, states, camp.effects, speed=speed, gaits=camp.physics.gaits)


def plan_truth(terrain: Any, camp: Any, res: Any) -> Any:
    """The truth of a plan with its own speed profile."""
    return truth(terrain, camp, res.states, physics_speeds(terrain, camp, res))


def run_pair(terrain, camp, model, start, goal, vrange, kw, n_pareto) -> dict[str, Any]:
    """Targets (a)-(c) on one start and goal."""
    import energy_planner as ep
    from energy_planner.errors import PlanningError

    out: dict[str, Any] = {"start": list(start), "goal": list(goal)}
    nom = ep.plan(terrain, start, goal, model=model, **kw)
    auto = ep.plan(terrain, start, goal, model=model, speed="auto", **kw)
    t_nom, t_auto = plan_truth(terrain, camp, nom), plan_truth(terrain, camp, auto)
    scan = np.linspace(vrange[0], vrange[1], 15)
    const = [truth(terrain, camp, auto.states, v).energy_j for v in scan]
    k = int(np.argmin(const))
    walk = [p["speed_m_s"] for p in auto.speed_profile() if p["speed_m_s"] > 0]
    out["a"] = {
        "nominal_j": t_nom.energy_j, "nominal_model_j": nom.energy_j,
        "auto_j": t_auto.energy_j, "auto_model_j": auto.energy_j,
        "auto_speeds": [min(walk), max(walk)] if walk else None,
        "best_const_j": const[k], "best_const_speed": float(scan[k]),
        "vs_const": t_auto.energy_j / const[k] - 1.0,
        "vs_nominal": t_auto.energy_j / t_nom.energy_j - 1.0,
        "duration_s": t_auto.duration_s,
    }  # fmt: skip
    front = ep.pareto(terrain, start, goal, n_pareto, model=model, **kw)
    pts = []
    for p in front.plans:
        iv = p.assessment.interval
        e = plan_truth(terrain, camp, p).energy_j
        pts.append({"model_j": p.energy_j, "low_j": iv.low_j, "high_j": iv.high_j,
                    "truth_j": e, "in": bool(iv.low_j <= e <= iv.high_j),
                    "duration_s": p.duration_s})  # fmt: skip
    out["b"] = pts
    # halfway between the least-energy plan's duration and the front's fastest point (a
    # path the planner found), so a path in time exists
    deadline = 0.5 * (auto.duration_s + front.plans[-1].duration_s)
    try:
        d = ep.plan(terrain, start, goal, model=model, deadline=deadline, **kw)
    except PlanningError as err:
        out["c"] = {
            "deadline_s": deadline,
            "plan_s": float("nan"),
            "physics_s": float("nan"),
            "truth_j": float("nan"),
            "met": False,
            "error": str(err),
        }
        return out
    td = plan_truth(terrain, camp, d)
    out["c"] = {
        "deadline_s": deadline,
        "plan_s": d.duration_s,
        "physics_s": td.duration_s,
        "truth_j": td.energy_j,
        "met": bool(td.duration_s <= deadline * (1 + 1e-9)),
    }
    return out  # fmt: skip


def heldout_missions(
    model: Any, seed: int, n: int, duration: float, train: int = 0, max_steps: int = 4
) -> dict[str, dict[str, Any]]:
    """Target (d): held-out across-speed missions against their intervals.

    Two models: the planning model (fitted on the campaign) and, with ``train`` > 0, the
    single-speed logs' path (``bench_field_logs.run_dataset``: ``ep.discover`` on
    ``train`` training missions across speeds, its model written and read back).
    """
    from bench_field_logs import binomial_band, mission_energy, run_dataset

    from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem
    from energy_planner.simulate.gaits import GaitSchedule

    terrain = synthetic_dem(seed)
    cfg = MissionConfig.across_speeds(gaits=GaitSchedule(("trot",)), missions=n,
                                      duration_s=duration)  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        held = simulate_missions(seed=seed + 1000, config=cfg, terrain=terrain)
    tests = [g for _, g in held.logs.drop(columns="z").groupby("run", sort=True)]
    sets = {"campaign fit": [mission_energy(terrain, model, g, 0.5) for g in tests]}
    if train:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            camp = simulate_missions(seed=seed, config=cfg.replace(missions=train),
                                     terrain=terrain)  # fmt: skip
        ds = run_dataset("discover", camp.logs.drop(columns="z"), tests, terrain, max_steps,
                         0.5, camp=camp)  # fmt: skip
        sets[f"discover on {train} missions"] = ds.missions
    out = {}
    for name, ms in sets.items():
        if not ms:
            continue
        err = np.array([m.error for m in ms])
        covered = int(sum(m.covered for m in ms))
        lo, hi = binomial_band(len(ms))
        width = np.median([(m.high_j - m.low_j) / (2 * m.predicted_j) for m in ms])
        out[name] = {"n": len(ms), "covered": covered, "band": [lo, hi],
                     "median": float(np.median(err)), "half_width": float(width),
                     "p90_abs": float(np.quantile(np.abs(err), 0.9)),
                     "met": bool(lo <= covered <= hi)}  # fmt: skip
    return out


def _met(ok: bool) -> str:
    return "met" if ok else "NOT met"


def report(doc: dict[str, Any]) -> str:
    """The table: each target beside its number."""
    lines = [f"robot: trot only, across-speeds campaign ({doc['campaign']}), model "
             f"{doc['terms']} terms, speed range {doc['range'][0]:.2f}-{doc['range'][1]:.2f} "
             f"m/s; fit {doc['fit_s']:.0f} s, plans {doc['plan_s']:.0f} s", "",
             f"{'pair':<5}{'target':<46}{'number':<36}{'':<8}"]  # fmt: skip
    for i, p in enumerate(doc["pairs"]):
        a, c = p["a"], p["c"]
        sp = "-" if a["auto_speeds"] is None else "{:.2f}-{:.2f}".format(*a["auto_speeds"])
        cov = sum(q["in"] for q in p["b"])
        rows = [
            ("(a) auto <= best constant on its route",
             f"{100 * a['vs_const']:+.2f}% (best {a['best_const_speed']:.2f} m/s)",
             a["vs_const"] <= 0),
            ("(a) auto <= 0.95 x nominal 0.3 m/s plan",
             f"{100 * a['vs_nominal']:+.1f}% ({a['auto_j']:.0f} vs {a['nominal_j']:.0f} J)",
             a["vs_nominal"] <= -0.05),
            ("    auto speeds; model/physics energy",
             f"{sp} m/s; {a['auto_model_j'] / a['auto_j']:.3f}", None),
            ("(b) every front point's physics in interval",
             f"{cov}/{len(p['b'])} in", cov == len(p["b"])),
            ("(c) deadline met by physics duration",
             f"{c['physics_s']:.1f} s <= {c['deadline_s']:.1f} s", c["met"]),
        ]  # fmt: skip
        for name, num, ok in rows:
            lines.append(f"{i:<5}{name:<46}{num:<36}{'' if ok is None else _met(ok)}")
    for name, d in doc["d"].items():
        lines.append(
            f"{'all':<5}{'(d) held-out missions in 90%, ' + name:<46}"
            f"{d['covered']}/{d['n']} (band {d['band'][0]}-{d['band'][1]})".ljust(36)
            + _met(d["met"])
        )
        lines.append(
            f"{'':<5}{'    error median; interval half-width':<46}"
            f"{100 * d['median']:+.2f}%; +-{100 * d['half_width']:.2f}%"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the table (or JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--small", action="store_true", help="the test's short campaign")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pairs", type=int, default=len(PAIRS), help="start/goal pairs used")
    ap.add_argument("--pareto", type=int, default=7, help="front points")
    ap.add_argument("--step", type=float, default=2.0, help="search spacing, m")
    ap.add_argument(
        "--forward-only",
        action="store_true",
        help="max_crab_deg=0 and max_backward_slope_deg=0 (the small campaign walks only "
        "forward and to the left: its model extrapolates the rest)",
    )
    ap.add_argument("--missions", type=int, default=12, help="held-out missions (0: skip d)")
    ap.add_argument("--train", type=int, default=20, help="training missions for discover")
    ap.add_argument("--duration", type=float, default=120.0, help="s per mission")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--save", type=Path, default=None, help="also write the JSON here")
    args = ap.parse_args(argv)  # fmt: skip

    import energy_planner as ep
    from energy_planner.planning.speed import speed_range_of

    t0 = time.perf_counter()
    camp, model = robot(args.seed, args.small)
    fit_s = time.perf_counter() - t0
    terrain = ep.open_terrain("hill")
    kw: dict[str, Any] = {"step": args.step}
    if args.forward_only:
        kw.update(max_crab_deg=0.0, max_backward_slope_deg=0.0)
    vrange = speed_range_of(model)
    t1 = time.perf_counter()
    pairs = [run_pair(terrain, camp, model, s, g, vrange, kw, args.pareto)
             for s, g in PAIRS[: args.pairs]]  # fmt: skip
    plan_s = time.perf_counter() - t1
    d = (heldout_missions(model, args.seed, args.missions, args.duration, args.train)
         if args.missions else {})  # fmt: skip
    doc = {"campaign": "small" if args.small else "full", "terms": len(model.term_names),
           "range": list(vrange), "fit_s": fit_s, "plan_s": plan_s, "pairs": pairs,
           "d": d}  # fmt: skip
    if args.save is not None:
        from energy_planner.io.atomic import write_text

        write_text(args.save, json.dumps(doc, indent=2))
    print(json.dumps(doc, indent=2) if args.json else report(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
