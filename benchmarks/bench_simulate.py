"""Simulator numbers for docs/simulate.md: timings, noise floors, critical grade, effect shares.

Usage::

    python benchmarks/bench_simulate.py [--seed 0] [--json]

Prints (1) the wall time of simulating the default campaign, the small one and the
default missions, (2) the noise floor (:meth:`Campaign.noise_floor`) of each on the
windows of the preprocessed logs (``measurements.preprocess`` then ``make_windows``),
against the expected and the instantaneous truth, and on raw windows, (3) the critical
grade and the slope from which a zig-zag across a plane pays, (4) the force-equivalent
cost along the fall line (Fig. 4), (5) every effect's share where it acts on the default
campaign and on a three-speed campaign.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np


def detour_slope(physics, speed: float = 0.3) -> tuple[float, float]:
    """Smallest plane slope (deg) where climbing obliquely beats the fall line.

    Also returns the best heading there (deg); the criterion is energy per metre of height
    ``P / (v sin(a) cos(gamma))``.
    """
    gam = np.radians(np.linspace(0.0, 89.0, 891))
    for deg in np.arange(5.0, 45.0, 0.25):
        a = math.radians(deg)
        n = len(gam)
        f = {
            "alpha": np.full(n, a),
            "gamma": gam,
            "vx": np.full(n, speed),
            "vy": np.zeros(n),
            "wz": np.zeros(n),
        }
        per_height = physics.expected_power(f) / (speed * math.sin(a) * np.cos(gam))
        k = int(np.argmin(per_height))
        if k > 0:
            return float(deg), float(np.degrees(gam[k]))
    return float("nan"), float("nan")


def main(argv: list[str] | None = None) -> int:
    from energy_planner.measurements import make_windows, preprocess
    from energy_planner.simulate import (
        EFFECTS,
        CampaignConfig,
        Physics,
        critical_grade,
        simulate_campaign,
        simulate_missions,
    )

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    out: dict = {"load_avg": os.getloadavg()[0]}

    rows = []
    for name, make in (
        ("default campaign", lambda: simulate_campaign(args.seed, config=CampaignConfig())),
        ("small campaign", lambda: simulate_campaign(args.seed, config=CampaignConfig.small())),
        ("default missions", lambda: simulate_missions(args.seed)),
    ):
        t0 = time.perf_counter()
        camp = make()
        dt = time.perf_counter() - t0
        clean, _ = preprocess(camp.logs)
        w = make_windows(clean)
        raw = make_windows(camp.logs)
        rows.append(
            {
                "what": name,
                "seconds": dt,
                "runs": len(camp.runs),
                "samples": len(camp.logs),
                "mean_power_w": float(camp.true_samples["power"].mean()),
                "windows": len(w.table),
                "floor_expected_w": camp.noise_floor(w).rmse_w,
                "floor_instantaneous_w": camp.noise_floor(w, "instantaneous").rmse_w,
                "floor_raw_windows_w": camp.noise_floor(raw).rmse_w,
            }
        )
        if name == "default campaign":
            default = camp
    out["campaigns"] = rows

    phys = Physics()
    crit = critical_grade(phys)
    deg, best = detour_slope(phys)
    out["critical_grade"] = {**crit, "plane_detour_from_deg": deg, "plane_detour_heading_deg": best}

    a = np.radians([0.0, 5.0, 10.0, 15.0, 20.0, 25.0])
    n = len(a)
    fig4 = {}
    for label, gamma, vx, vy in (
        ("forward up", 0.0, 0.3, 0.0),
        ("forward down", 180.0, 0.3, 0.0),
        ("backward up", 180.0, -0.3, 0.0),
        ("backward down", 0.0, -0.3, 0.0),
        ("lateral up", -90.0, 0.0, 0.3),
        ("lateral down", 90.0, 0.0, 0.3),
        ("forward across", 90.0, 0.3, 0.0),
    ):
        f = {
            "alpha": a,
            "gamma": np.full(n, math.radians(gamma)),
            "vx": np.full(n, vx),
            "vy": np.full(n, vy),
            "wz": np.zeros(n),
        }
        fig4[label] = (phys.expected_power(f) / 0.3).round(1).tolist()
    out["cost_n_at_0_5_10_15_20_25_deg"] = fig4

    three = simulate_campaign(args.seed, config=CampaignConfig(speeds=(0.2, 0.3, 0.45)))
    s1 = default.effect_shares().set_index("effect")
    s3 = three.effect_shares().set_index("effect")
    out["effects"] = [
        {
            "effect": e,
            "channel": EFFECTS[e].channel,
            "share_default": float(s1.loc[e, "share_active"]),
            "active_default": float(s1.loc[e, "active_fraction"]),
            "mean_active_w_default": float(s1.loc[e, "mean_active_w"]),
            "share_3_speeds": float(s3.loc[e, "share_active"]),
        }
        for e in EFFECTS
    ]
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"load average at start: {out['load_avg']:.2f}")
    print(
        f"{'what':<18}{'time s':>8}{'runs':>6}{'samples':>9}{'mean W':>8}{'windows':>8}"
        f"{'floor exp':>10}{'floor inst':>11}{'floor raw':>10}"
    )
    for r in rows:
        print(
            f"{r['what']:<18}{r['seconds']:>8.2f}{r['runs']:>6}{r['samples']:>9}"
            f"{r['mean_power_w']:>8.1f}{r['windows']:>8}{r['floor_expected_w']:>10.2f}"
            f"{r['floor_instantaneous_w']:>11.2f}{r['floor_raw_windows_w']:>10.2f}"
        )
    c = out["critical_grade"]
    print(
        f"critical grade: g* = {c['grade']:.3f} = {c['slope_deg']:.1f} deg (c(g*) = "
        f"{c['cost_n']:.0f} N, level {c['level_cost_n']:.0f} N); zig-zag across a plane "
        f"pays from {c['plane_detour_from_deg']:.2f} deg (best heading there "
        f"{c['plane_detour_heading_deg']:.1f} deg)"
    )
    print("force-equivalent cost, N, at 0 5 10 15 20 25 deg:")
    for k, v in fig4.items():
        print(f"  {k:<15}" + "".join(f"{x:>8.0f}" for x in v))
    print(f"{'effect':<20}{'channel':<16}{'share':>7}{'active':>8}{'mean W':>8}{'share 3v':>9}")
    for e in out["effects"]:
        print(
            f"{e['effect']:<20}{e['channel'] or '-':<16}{e['share_default']:>7.1%}"
            f"{e['active_default']:>8.0%}{e['mean_active_w_default']:>8.1f}"
            f"{e['share_3_speeds']:>9.1%}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
