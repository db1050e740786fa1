"""``energy-planner simulate``: write a simulated field campaign with a known truth."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options


def _names(what: str, plural: str, valid: Any, value: tuple[str, ...], ctx, param):
    """``value`` without repeats, each one of ``valid`` (``click.BadParameter`` listing them)."""
    for name in value:
        if name not in valid:
            raise click.BadParameter(
                f"unknown {what} {name!r}; valid {plural}: {', '.join(valid)} "
                "(see docs/simulate.md)",
                ctx=ctx,
                param=param,
            )
    return tuple(dict.fromkeys(value))


def _effects(ctx: click.Context, param: click.Parameter, value: tuple[str, ...]):
    from energy_planner.simulate import EFFECTS

    return _names("effect", "effects", sorted(EFFECTS), value, ctx, param)


def _faults(ctx: click.Context, param: click.Parameter, value: tuple[str, ...]):
    from energy_planner.simulate import FAULTS

    return _names("sensor fault", "faults", FAULTS, value, ctx, param)


def _speeds(ctx: click.Context, param: click.Parameter, value: str | None):
    if value is None:
        return None
    if ":" in value:  # a range LOW:HIGH[:N]
        from energy_planner.simulate.config import ConfigError, speed_grid

        parts = value.split(":")
        try:
            if len(parts) not in (2, 3):
                raise ValueError(value)
            n = int(parts[2]) if len(parts) == 3 else 8
            return speed_grid(float(parts[0]), float(parts[1]), n)
        except (ValueError, ConfigError):
            raise click.BadParameter(
                f"{value!r} is not a speed range LOW:HIGH[:N] with 0 < LOW < HIGH <= 3 m/s "
                "and N >= 2 speeds, e.g. 0.15:1.2 (8 speeds) or 0.15:1.2:5",
                ctx=ctx,
                param=param,
            ) from None
    try:
        speeds = tuple(float(v) for v in value.split(",") if v.strip())
    except ValueError:
        speeds = ()
    if not speeds or not all(0 < v <= 3 for v in speeds):
        raise click.BadParameter(
            f"{value!r} is not a comma-separated list of speeds in (0, 3] m/s, e.g. 0.2,0.3,0.45 "
            "(or a range LOW:HIGH[:N], e.g. 0.15:1.2)",
            ctx=ctx,
            param=param,
        )
    return speeds


def _gaits(ctx: click.Context, param: click.Parameter, value: str | None):
    if value is None:
        return None
    from energy_planner.simulate.gaits import GAITS

    names = tuple(v.strip() for v in value.split(",") if v.strip())
    bad = [n for n in names if n not in GAITS]
    if not names or bad or len(set(names)) != len(names):
        raise click.BadParameter(
            f"{value!r} is not a comma-separated list of distinct gaits from "
            f"{', '.join(GAITS)}, e.g. walk,trot",
            ctx=ctx,
            param=param,
        )
    return names


def _text(doc: dict[str, Any]) -> str:
    s = doc["summary"]
    what = "missions" if doc["missions"] else "runs"
    lines = [
        f"simulated {s['runs']} {what}, {s['samples']} samples, "
        f"{s['duration_s'] / 60:.1f} min of logs (seed {s['seed']})",
        "runs by kind: " + ", ".join(f"{k} {v}" for k, v in s["kinds"].items()),
        f"mean true power {s['mean_power_w']:.1f} W; battery packs used {s['battery_packs']}",
        "truth: mechanistic physics of a "
        f"{doc['robot']['mass_kg']:g} kg quadruped (parameters in physics.json)",
        f"effects: {', '.join(s['effects']) or 'none'}",
    ]
    for e in doc["effects"]:
        ch = f" [channel {e['channel']}]" if e["channel"] else ""
        lines.append(f"  {e['name']}{ch}: {e['explanation']}")
    if doc.get("gaits"):
        g = doc["gaits"]["schedule"]
        lines.append(
            f"gaits: {', '.join(g['gaits'])} (trot from {g['trot_speed']:g} m/s), logged as "
            "the channel gait; speeds " + ", ".join(f"{v:g}" for v in doc["speeds"]) + " m/s"
        )
    lines.append(f"sensor faults: {', '.join(s['faults']) or 'none'}")
    f = doc["files"]
    lines.append(
        f"wrote {f['logs']} {f['format']} logs, runs.csv, physics.json, campaign.json"
        + (", ground.tif, ground.csv" if doc["missions"] else "")
        + (f" and {f['bags']} ROS 2 bags" if f["bags"] else "")
        + f" to {f['out']}"
    )
    if f["plot"]:
        lines.append(f"plot written to {f['plot']}")
    return "\n".join(lines)


@options.command(
    "simulate",
    "energy-planner simulate --out campaign --small --effect load",
    "energy-planner simulate --out missions --missions 4 --dem hill --effect load",
)
@options.path_option(
    "--out",
    "out",
    required=True,
    folder=True,
    help="Output directory (created if missing; must be empty unless --overwrite).",
)
@click.option(
    "--overwrite",
    is_flag=True,
    help="Replace a non-empty --out folder whole (written beside it, then swapped in: "
    "never a mix of old and new files).",
)
@options.seed_option
@click.option(
    "--effect",
    "effects",
    multiple=True,
    metavar="NAME",
    callback=_effects,
    help="Switch on a physical effect the base model lacks (repeatable), e.g. "
    "--effect load --effect cold_joints (simulate.HIDDEN_EFFECTS lists them).",
)
@click.option(
    "--fault",
    "faults",
    multiple=True,
    metavar="NAME",
    callback=_faults,
    help="Add a sensor fault (repeatable): slope_slip, ros_current_sign, clock_offset.",
)
@click.option(
    "--missions",
    type=click.IntRange(min=1),
    metavar="N",
    help="Write N mission logs (a robot following smooth paths over a DEM, with speed "
    "changes, stops and turns) instead of the designed campaign.",
)
@click.option(
    "--dem",
    type=click.Path(dir_okay=False, path_type=Path),
    callback=options.bundled_existing,
    help="DEM for --missions (default: synthetic rolling hills), a file or a bundled map's "
    "name, e.g. hill.",
)
@click.option(
    "--speeds",
    callback=_speeds,
    metavar="V1,V2,...",
    help="Walking speeds, m/s, comma-separated (default 0.3, as in the paper), or a range "
    "LOW:HIGH[:N] of N evenly spaced speeds (default 8), e.g. 0.15:1.2.",
)
@click.option(
    "--gaits",
    callback=_gaits,
    metavar="G1,G2,...",
    help="The controller's gaits across speeds, logged as the channel gait: walk below "
    "--trot-speed, trot from it, crawl on steep ground (e.g. walk,trot). Stride and duty "
    "factor then follow the speed (docs/simulate.md). Default: the base robot's one gait.",
)
@click.option(
    "--trot-speed",
    type=click.FloatRange(0, 3, min_open=True),
    default=0.5,
    show_default=True,
    metavar="M/S",
    help="With --gaits: the speed from which the controller trots.",
)
@click.option(
    "--across-speeds",
    is_flag=True,
    help="Preset: 8 speeds from 0.15 to 1.2 m/s, walking and trotting (--speeds and "
    "--gaits override it); with --small a short campaign. Identifies the speed terms and "
    "the optimum speed (fit, figures --speed).",
)
@options.value_option(
    "--format",
    "fmt",
    type=click.Choice(["csv", "parquet"]),
    default="csv",
    help="Per-run log format.",
)
@click.option("--bag", is_flag=True, help="Also write one ROS 2 bag per run into OUT/bags/.")
@click.option(
    "--small", is_flag=True, help="A tiny campaign (about 100 short runs) for a quick look."
)
@options.path_option(
    "--plot",
    "plot",
    help="Also write a PNG of the force-equivalent cost versus slope (uphill and "
    "downhill, forward and lateral; measured points, truth lines).",
)
@click.option(
    "--noise-free", is_flag=True, help="Perfect sensors: no noise, spikes, slip or IMU bias."
)
@options.json_option
def command(
    out: Path,
    overwrite: bool,
    seed: int,
    effects: tuple[str, ...],
    faults: tuple[str, ...],
    missions: int | None,
    dem: Path | None,
    speeds: tuple[float, ...] | None,
    gaits: tuple[str, ...] | None,
    trot_speed: float,
    across_speeds: bool,
    fmt: str,
    bag: bool,
    small: bool,
    plot: Path | None,
    noise_free: bool,
    as_json: bool,
) -> None:
    """Simulate a field campaign (paper IV-C) in the canonical log format.

    Straight runs on planar slopes of 0-25 degrees at many headings, forward, backward
    and sideways, turns in place, arcs, standing, and composite paths for the
    superposition test, with a noisy battery monitor, slipping odometry and a biased
    IMU. The truth is mechanistic physics of a 50 kg quadruped (gravity work, copper
    losses, direction-dependent recovery downhill, swing, turning, ripple) with the
    effects switched on with --effect; its parameters go to OUT/physics.json. With
    --missions N the robot follows smooth paths over a DEM instead.
    """
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.io import check_folder_output
    from energy_planner.simulate import (
        EFFECTS,
        CampaignConfig,
        MissionConfig,
        SensorConfig,
        simulate_campaign,
        simulate_missions,
    )
    from energy_planner.simulate.gaits import GaitSchedule

    changes: dict[str, Any] = {}
    if speeds is not None:
        changes["speeds"] = speeds
    if gaits is not None:
        changes["gaits"] = GaitSchedule(gaits, trot_speed=trot_speed)
    elif across_speeds:
        changes["gaits"] = GaitSchedule(trot_speed=trot_speed)
    if noise_free:
        changes["sensors"] = SensorConfig.ideal()
    progress = True  # the one reporter: a bar on a terminal, lines in a log, none with -q
    if dem is not None and missions is None:
        raise click.BadParameter("--dem is only used with --missions N", param_hint="--dem")
    if plot is not None and missions is not None:
        raise click.BadParameter(
            "--plot draws the designed campaign's fall-line runs (Fig. 4); missions have "
            "none: drop --plot or --missions",
            param_hint="--plot",
        )
    common = dict(seed=seed, effects=effects, faults=faults, progress=progress)
    try:
        check_folder_output(out, overwrite=overwrite)  # before the work, not after
        if missions is not None:
            from energy_planner.terrain import load_dem

            terrain = load_dem(dem) if dem is not None else None
            mk = MissionConfig.small if small else MissionConfig
            if across_speeds:
                preset = MissionConfig.across_speeds()
                changes = {"speeds": preset.speeds, "gaits": preset.gaits, **changes}
            config = mk(missions=missions, **changes)
            camp = simulate_missions(config=config, terrain=terrain, **common)
        elif across_speeds:
            config = CampaignConfig.across_speeds(small=small, **changes)
        else:
            config = CampaignConfig.small(**changes) if small else CampaignConfig(**changes)
        if missions is None:
            camp = simulate_campaign(config=config, **common)
        files = camp.write(out, fmt=fmt, bag=bag, progress=progress, overwrite=overwrite)
        plot_path = camp.plot(plot) if plot is not None else None
    except EnergyPlannerError as exc:
        raise click.ClickException(
            f"{exc}\nhint: --out must be a writable, empty or new folder (--overwrite "
            "replaces it); "
            "`energy-planner simulate --help` lists the options"
        ) from exc
    doc = {
        "summary": camp.summary(),
        "missions": missions is not None,
        "robot": {r["name"]: r["value"] for r in camp.physics.params.table()},
        "effects": [
            {"name": n, "channel": EFFECTS[n].channel, "explanation": EFFECTS[n].explanation}
            for n in camp.effects
        ],
        "speeds": list(config.speeds),
        "gaits": camp.physics_dict().get("gaits"),
        "files": {
            "out": out,
            "format": fmt,
            "logs": sum(1 for p in files if p.suffix == f".{fmt}" and p.name != "runs.csv"),
            "runs": out / "runs.csv",
            "physics": out / "physics.json",
            "campaign": out / "campaign.json",
            "bags": sum(1 for p in files if p.parent == out / "bags"),
            "plot": plot_path,
        },
    }
    options.emit(doc, as_json, _text)
