"""``energy-planner figures``: the paper's figures (Fig. 3, 4, 5) from robot logs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options


def _composite_meta(logs: tuple[Path, ...], samples: Any) -> Any:
    """Run -> composite/part from ``runs.csv`` next to the logs, or from log columns."""
    import pandas as pd

    frames = []
    seen: set[Path] = set()
    for p in logs:
        folder = p if p.is_dir() else p.parent
        f = folder / "runs.csv"
        if f.is_file() and f not in seen:
            seen.add(f)
            df = pd.read_csv(f)
            if {"run", "composite", "part"} <= set(df.columns):
                frames.append(df[["run", "composite", "part"]])
    if frames:
        meta = pd.concat(frames, ignore_index=True)
    elif {"composite", "part"} <= set(samples.columns):
        meta = (
            samples[["run", "composite", "part"]]
            .astype({"composite": object, "part": object})
            .dropna()
            .groupby("run", sort=True)
            .first()
            .reset_index()
        )
    else:
        return None
    meta = meta.dropna(subset=["composite", "part"])
    return meta if len(meta) else None


@options.command("figures", "energy-planner figures campaign --out figs --model b1.json")
@options.logs_argument
@options.path_option(
    "--out",
    "out",
    required=True,
    folder=True,
    help="Folder for the PNG figures (created if needed).",
)
@options.path_option(
    "--model",
    "model_path",
    help="Energy model JSON whose curves are drawn (default: the base model fitted to LOGS).",
)
@options.window_option
@options.json_option
def command(
    logs: tuple[Path, ...], out: Path, model_path: Path | None, window: float, as_json: bool
) -> None:
    """Reproduce the paper's figures from robot LOGS as PNGs in --out.

    force_slope.png (Fig. 4): force-equivalent cost P/v against slope, uphill and
    downhill, forward and lateral, with the model's curves; yaw_torque.png (Fig. 5):
    P/|w| of turns in place against slope; superposition.png (Fig. 3): energy of
    composite paths against the sum of their parts (needs runs.csv with columns run,
    composite, part next to the logs, or composite/part columns in the logs);
    speed_cost.png: cost per metre against speed per slope and relative heading (and per
    gait), windows over the model's curves and its optimum speed (logs across speeds).
    """
    from energy_planner.calibration import force_estimates
    from energy_planner.calibration.figures import typical_channels
    from energy_planner.cli.fit import load_windows
    from energy_planner.errors import EnergyPlannerError

    windows, reports, _, raw = load_windows(logs, window)
    notes: list[str] = []
    model, model_src = _model_for_curves(model_path, windows, notes)
    try:
        est = force_estimates(windows)
    except EnergyPlannerError as exc:
        raise click.ClickException(f"cannot estimate forces: {exc}") from exc
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise click.BadParameter(f"cannot create {str(out)!r}: {exc}", param_hint="--out") from exc
    consts = typical_channels(windows.samples, model) if model is not None else {}
    figures = _slope_figures(est, model, consts, out, notes)
    figures.update(_speed_figure(windows, model, consts, out, notes))
    figures.update(_superposition_figure(logs, raw, out, notes))
    doc = {"out": str(out), "model": model_src, "figures": figures, "notes": notes, **reports}
    options.emit(doc, as_json, _text)


def _model_for_curves(model_path: Path | None, windows, notes: list[str]):
    """The model whose curves are drawn and where it came from (None if none fits)."""
    from energy_planner.calibration import fit_model
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.model import EnergyModel

    if model_path is not None:
        try:
            return EnergyModel.load(model_path), str(model_path)
        except EnergyPlannerError as exc:
            raise click.BadParameter(str(exc), param_hint="--model") from exc
    try:
        return fit_model(windows, n_splits=0).model, "base model fitted to the logs"
    except EnergyPlannerError as exc:
        notes.append(f"no model curves: the base model cannot be fitted ({exc})")
        return None, "none"


def _slope_figures(est, model, consts, out: Path, notes: list[str]) -> dict[str, Any]:
    """Fig. 4 (force against slope) and Fig. 5 (yaw torque), when the logs have the motions."""
    from energy_planner.calibration.figures import plot_force_slope, plot_yaw_torque

    figures: dict[str, Any] = {}
    if (est["kind"].isin(["forward", "lateral"])).any():
        path = out / "force_slope.png"
        figures["force_slope"] = {
            "path": str(path),
            **plot_force_slope(est, model, path, constants=consts),
        }
    else:
        notes.append("no forward or lateral windows: force_slope.png (Fig. 4) not drawn")
    if (est["kind"] == "turning").any():
        path = out / "yaw_torque.png"
        figures["yaw_torque"] = {
            "path": str(path),
            **plot_yaw_torque(est, model, path, constants=consts),
        }
    else:
        notes.append("no turn-in-place windows: yaw_torque.png (Fig. 5) not drawn")
    return figures


def _speed_figure(windows, model, consts, out: Path, notes: list[str]) -> dict[str, Any]:
    """The cost per metre against speed, when the logs span a range of speeds."""
    from energy_planner.calibration._windows import aligned_table
    from energy_planner.calibration.figures import plot_speed_cost
    from energy_planner.calibration.fit import speed_support
    from energy_planner.errors import EnergyPlannerError

    support = speed_support(windows)
    if not support.supported:
        notes.append(f"speed_cost.png not drawn: speed terms unsupported ({support.reason})")
        return {}
    path = out / "speed_cost.png"
    try:
        got = plot_speed_cost(aligned_table(windows), model, path, constants=consts)
    except EnergyPlannerError as exc:
        notes.append(f"speed_cost.png not drawn: {exc}")
        return {}
    return {"speed_cost": {"path": str(path), **got}}


def _superposition_figure(logs, raw, out: Path, notes: list[str]) -> dict[str, Any]:
    """Fig. 3 (composite paths against the sum of their parts), when runs are labelled."""
    from energy_planner.calibration.figures import (
        plot_superposition,
        run_energy,
        superposition_table,
    )

    meta = _composite_meta(logs, raw)
    if meta is None:
        notes.append(
            "no composite/part labels (runs.csv or log columns): superposition.png (Fig. 3) "
            "not drawn"
        )
        return {}
    table = superposition_table(run_energy(raw), meta)
    if table.empty:
        notes.append("composite labels match no loaded run: superposition.png not drawn")
        return {}
    path = out / "superposition.png"
    fig = {"path": str(path), **plot_superposition(table, path)}
    fig["composites"] = table.to_dict(orient="records")
    return {"superposition": fig}


def _text(d: dict[str, Any]) -> str:
    lines = [f"figures in {d['out']} (model: {d['model']})"]
    f = d["figures"]
    if "force_slope" in f:
        s = f["force_slope"]
        lines.append(f"  {s['path']}: Fig. 4, force-equivalent cost against slope")
        for direction in ("uphill", "downhill"):
            for motion in ("forward", "lateral"):
                n = s[f"{direction}_{motion}_n"]
                med = s[f"{direction}_{motion}_median_n"]
                a = s[f"{direction}_{motion}_median_alpha_deg"]
                lines.append(
                    f"      {direction:<8} {motion:<8} {n:>4} windows; on slopes: median "
                    f"{med:7.1f} N at a median slope of {a:4.1f} deg"
                )
    if "yaw_torque" in f:
        s = f["yaw_torque"]
        lines.append(
            f"  {s['path']}: Fig. 5, {s['n']} turn windows, median yaw torque "
            f"{s['median_torque_nm']:.1f} N m"
        )
    if "speed_cost" in f:
        s = f["speed_cost"]
        lines.append(f"  {s['path']}: cost per metre against speed (optimum per panel)")
        for p in s["panels"]:
            best = (
                f"optimum {p['optimum_speed']:.2f} m/s ({p['optimum_gait'] or 'one gait'}), "
                f"{p['optimum_cost_n']:.0f} J/m" + ("" if p["interior"] else " (at a range end)")
                if "optimum_speed" in p
                else "no model curve"
            )
            lines.append(f"      {p['label']:<18} {p['windows']:>4} windows; {best}")
    if "superposition" in f:
        s = f["superposition"]
        rel = s["mean_abs_rel_ab"]
        rel_txt = "n/a" if rel is None else f"{100 * rel:.1f} %"
        lines.append(f"  {s['path']}: Fig. 3, {s['n']} composites, mean |AB - (A + B)| {rel_txt}")
    lines += [f"  note: {n}" for n in d["notes"]]
    return "\n".join(lines)
