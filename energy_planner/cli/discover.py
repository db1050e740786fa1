"""``energy-planner discover``: the whole diagnosis staircase in one command."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options
from energy_planner.cli.diagnose import below_noise_lines


def _pct(v: Any) -> str:
    return "-" if v is None else f"{100 * v:.1f}%"


def _text(doc: dict[str, Any]) -> str:
    from energy_planner.diagnosis.suspects import LONG_FORMULA

    lines = [f"{doc['n_windows']} windows from {doc['n_runs']} runs", ""]
    found = [f for f in doc["data_findings"] if f["finding"]]
    if found:
        lines.append("data findings (sensor problems, not physical effects):")
        for f in found:
            lines.append(f"  {f['name']}: {f['summary']}")
        lines.append("")
    fl = doc.get("noise_floor") or {}
    if fl and math.isfinite(fl["rmse_w"]):
        lines.append(
            f"noise floor estimated from the logs: {fl['rmse_w']:.2f} W over "
            f"{fl['n_windows']} windows (white sensor noise within windows "
            f"{fl['sensor_noise_w']:.2f} W, smoothing shift at window edges "
            f"{fl['smoothing_shift_w']:.2f} W; docs/diagnosis.md)"
        )
    elif fl:
        lines.append(f"noise floor: {fl['method']}")
    if doc.get("speed_terms"):
        lines.append(doc["speed_terms"]["line"])
    lines.append("")
    lines.append(
        f"  {'step':<5}{'term added':<40}{'held-out RMSE':>14}{'x floor':>9}"
        f"{'run energy err':>16}{'p90':>8}{'error removed':>15}"
    )
    for r in doc["staircase"]:
        name = r["name"] or "(base model)"
        removed = "" if r["error_removed"] is None else _pct(r["error_removed"])
        ratio = r.get("floor_ratio")
        ratio = math.nan if ratio is None else ratio
        lines.append(
            f"  {r['step']:<5}{name[:39]:<40}{r['heldout_rmse_w']:>11.2f} W"
            f"{'-' if not math.isfinite(ratio) else f'{ratio:.2f}':>9}"
            f"{_pct(r['run_energy_error_median']):>16}{_pct(r['run_energy_error_p90']):>8}"
            f"{removed:>15}"
        )
        if r["added"]:
            term = r["added"]
            if len(term) > LONG_FORMULA:  # a channel times the fitted base: the formula is long
                lines.append(
                    f"       term: {len(term)} characters of formula, in the model file and the "
                    f"report as {name!r} (fit --term {name} rebuilds it from the same logs)"
                )
            elif term != name:
                lines.append(f"       term: {term}")
            lines.append(f"       {r['explanation']}")
        for a in r["alternatives"]:
            lines.append(f"       or, equally well (the data cannot tell them apart): {a['name']}")
        for d in r.get("dropped", []):
            lines.append(f"       tried first, left out by the refit: {d['name']} ({d['reason']})")
    last = doc["staircase"][-1]["step"] if doc["staircase"] else 0
    for d in doc.get("dropped", []):
        if d["step"] > last:
            lines.append(f"  not added, left out by the refit: {d['name']} ({d['reason']})")
    out = doc["staircase"][-1].get("outside_support") if doc["staircase"] else None
    if out and out["n_windows"]:
        sup = doc["staircase"][-1].get("supported_rmse_w")
        lines.append(
            f"{out['n_windows']} window(s) of {out['n_runs']} run(s) walk in a way their "
            f"fold's training runs do not (direction, grade along the travel): held-out "
            f"RMSE {out['rmse_w']:.2f} W there ({_pct(out['share_sq_error'])} of the squared "
            f"error), an extrapolation; the candidates are scored on the others "
            f"({sup:.2f} W)"
        )
    if len(doc["staircase"]) > 1:
        lines.append(
            f"error removed in total: {_pct(doc['staircase'][-1]['error_removed_total'])} of "
            "the base model's held-out squared error"
        )
    lines.append("")
    lines += below_noise_lines("best left below noise", doc["below_noise_at_end"])
    for n in doc["notes"]:
        lines.append(f"note: {n}")
    lines += options.written_lines(doc, {"model": "model", "report": "report"})
    return "\n".join(lines)


@options.command(
    "discover", "energy-planner discover campaign --out model.json --report discover.html"
)
@options.logs_argument
@options.path_option(
    "--out",
    "out",
    required=True,
    help="Where to write the discovered model (JSON), fitted on all windows.",
)
@options.report_option
@options.window_option
@options.staircase_options
@options.repair_option
@options.path_option(
    "--dem",
    "dem",
    callback=options.bundled,
    help="The map the logs' poses lie on (their x, y in its CRS): logs without altitude get "
    "it from the map, and the IMU's tilt is checked against the pose.",
)
@options.json_option
def command(
    logs: tuple[Path, ...],
    out: Path,
    report: Path | None,
    terms: tuple[str, ...],
    staircase: dict[str, Any],
    window: float,
    repair: bool,
    dem: Path | None,
    as_json: bool,
) -> None:
    """Find the effects the base model misses in LOGS and write the model that has them.

    Checks the logs for sensor problems first (current sign, clock offset between power
    and motion, odometry slip growing with slope, twist noise) and repairs them; then
    starts from the base model, adds the best candidate effect above noise, refits and
    repeats until none is left (or --max-steps). Every number is held out by run. Prints
    the staircase: term added, its physical explanation, held-out power RMSE, run-energy
    error (median, p90) and the share of the error removed.
    """
    from energy_planner.cli.fit import load_log_files, resolve_terms
    from energy_planner.diagnosis.discover import discover
    from energy_planner.errors import EnergyPlannerError

    resolve_terms(terms)  # syntax first: fail before loading any log
    from energy_planner.cli.energy import load_terrain

    terrain = None if dem is None else load_terrain(dem, None)
    samples = load_log_files(logs)
    from energy_planner.measurements.windows import DERIVED_COLUMNS

    extra = [t.name for t in resolve_terms(terms, set(samples.columns) | set(DERIVED_COLUMNS))]
    try:
        d = discover(
            samples,
            **staircase,
            terms=extra,
            window=window,
            repair=repair,
            terrain=terrain,
            progress=True,  # a line per stage on stderr (not with --quiet)
        )
    except EnergyPlannerError as exc:
        raise click.ClickException(f"{exc}\nhint: see docs/diagnosis.md") from exc
    doc = d.to_dict()
    if d.model is None:
        raise click.ClickException("the final model could not be fitted: " + "; ".join(d.notes))
    d.model.metadata = {
        **d.model.metadata,
        "source": [str(p) for p in logs],
        "window_s": window,
        "discover": {"added": d.added, "data_findings": [
            f.name for f in d.data_findings if f.finding]},
    }  # fmt: skip
    try:
        d.model.save(out)
    except OSError as exc:
        raise click.BadParameter(str(exc), param_hint="--out") from exc
    doc["model"] = str(out)
    if report is not None:
        from energy_planner.diagnosis.report import render_discovery_html

        try:
            from energy_planner.io import write_text

            write_text(report, render_discovery_html(doc))
        except OSError as exc:
            raise click.BadParameter(str(exc), param_hint="--report") from exc
        doc["report"] = str(report)
    options.emit(doc, as_json, _text)
