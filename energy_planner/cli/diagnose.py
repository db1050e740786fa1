"""``energy-planner diagnose``: how far a model is from the logs, and what it misses."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options


def fit_hint(
    logs: tuple[Path, ...] | list[str],
    model_terms: list[str],
    new_term: str,
    out: Path | str,
    window: float = 2.0,
) -> str:
    """The ``energy-planner fit`` command that adds ``new_term`` to a model, as printed.

    ``fit`` starts from the base terms, so the model's other terms are repeated; every
    argument is shell-quoted, so the line runs as printed.

    >>> fit_hint(("my logs",), ["fwd_const", "acceleration"], "pos(15 - t_c)", "m2.json")
    "energy-planner fit 'my logs' --out m2.json --term acceleration --term 'pos(15 - t_c)'"
    """
    import shlex

    from energy_planner.model import BASE_TERMS

    extra = [t for t in model_terms if t not in BASE_TERMS]
    parts = ["energy-planner", "fit", *map(str, logs), "--out", str(out)]
    if window != 2.0:
        parts += ["--window", f"{window:g}"]
    for t in [*extra, new_term]:
        parts += ["--term", t]
    return " ".join(shlex.quote(p) for p in parts)


def below_noise_lines(what: str, suspects: list[dict[str, Any]]) -> list[str]:
    """The first three candidates below noise, with the share of error each explains."""
    if not suspects:
        return []
    named = (f"{s['name']} ({100 * s['error_explained']:.1f}%)" for s in suspects[:3])
    return [f"{what}: " + ", ".join(named)]


def _text(doc: dict[str, Any], report: Path | None) -> str:
    def f(v: Any, fmt: str = ".1f") -> str:
        return "-" if v is None else format(v, fmt)

    lines = [
        f"model: {', '.join(doc['model_terms'])}",
        f"{doc['n_windows']} windows from {doc['n_runs']} runs",
        f"window power: RMSE {f(doc['rmse_w'])} W, MAE {f(doc['mae_w'])} W, "
        f"bias {f(doc['bias_w'])} W, R^2 {f(doc['r2'], '.3f')}; "
        f"held-out RMSE (refitted, by run) {f(doc['heldout_rmse_w'])} W",
        "",
    ]
    runs = sorted(doc["runs"], key=lambda r: -abs(r.get("error_rel") or 0.0))
    if runs:
        lines.append(f"run energy, worst {min(5, len(runs))} of {len(runs)} runs:")
        for r in runs[:5]:
            rel = r.get("error_rel")
            lines.append(
                f"  {r['run']:<28} measured {r['measured_j']:>9.1f} J  predicted "
                f"{r['predicted_j']:>9.1f} J  error {f(None if rel is None else 100 * rel)}%"
            )
        lines.append("")
    for kind in ("concatenation", "alternative"):
        sup = [s for s in doc["superposition"] if s["kind"] == kind]
        if not sup:
            continue
        rel = [abs(s["superposition_error_rel"] or 0.0) for s in sup]
        model = [abs(s["model_error_composite_j"]) for s in sup]
        what = "E(AB) vs E(A)+E(B)" if kind == "concatenation" else "E(C) vs E(A)+E(B)"
        lines.append(
            f"superposition, {kind} ({what}, {len(sup)} paths): measured difference mean "
            f"{100 * sum(rel) / len(rel):.1f}%, max {100 * max(rel):.1f}%; model error on the "
            f"composite run mean {sum(model) / len(model):.0f} J"
        )
    if doc["superposition"]:
        lines.append("")
    if doc["hotspots"]:
        lines.append("largest systematic errors (bin: bias, t = bias / its std error):")
        for h in doc["hotspots"]:
            lines.append(
                f"  {h['variable']:<16} {h['bin']:<32} {h['bias_w']:+8.1f} W  t {h['t']:+.1f}"
                f"  ({h['n']} windows)"
            )
        lines.append("")
    if doc["suspects"]:
        lines.append("suspects (above noise, best first):")
        for i, s in enumerate(doc["suspects"], 1):
            lines.append(
                f"  {i}. {s['name']}: explains {100 * s['error_explained']:.0f}% of the error, "
                f"held-out RMSE {s['heldout_rmse_before_w']:.1f} -> {s['heldout_rmse_w']:.1f} W"
            )
            lines.append(f"     term: {s['term']}   ({', '.join(s['variables'])})")
            lines.append(f"     {s['explanation']}")
        for a in doc.get("alternatives", []):
            lines.append(
                f"  or, equally well (the data cannot tell them apart): {a['name']}: "
                f"{a['term']} (held-out RMSE {a['heldout_rmse_w']:.1f} W)"
            )
        if doc.get("hint"):
            lines.append(f"add the first one with: {doc['hint']}")
    else:
        lines.append("no suspect above noise.")
    lines += below_noise_lines("best below noise", doc["below_noise"])
    if doc["unsupported"]:
        lines.append(f"unsupported by these logs ({len(doc['unsupported'])}):")
        for u in doc["unsupported"][:8]:
            lines.append(f"  {u['name']}: {u['reason']}")
    if len(doc["staircase"]) > 1:
        lines.append("")
        lines.append("staircase (held-out RMSE as the best suspects are added):")
        for s in doc["staircase"]:
            lines.append(
                f"  {s['step']}. {s['name'] or '(model as given)':<32} {s['heldout_rmse_w']:.1f} W"
            )
    for n in doc["notes"]:
        lines.append(f"note: {n}")
    if doc.get("data_findings") is not None:
        from energy_planner.calibration.prepare import findings_text

        lines += findings_text(doc["data_findings"])
    if report is not None:
        lines.append(f"report written to {report}")
    return "\n".join(lines)


def _runs_meta(runs_path: Path | None, logs: tuple[Path, ...]):
    """Read the run metadata (``--runs`` or ``runs.csv`` in a LOGS folder), if any."""
    import pandas as pd

    if runs_path is None:
        found = [p / "runs.csv" for p in logs if p.is_dir() and (p / "runs.csv").is_file()]
        if not found:
            return None
        runs_path = found[0]
    try:
        meta = pd.read_csv(runs_path)
    except (OSError, ValueError) as exc:
        raise click.BadParameter(
            f"cannot read {str(runs_path)!r}: {exc}", param_hint="--runs"
        ) from exc
    missing = sorted({"run", "composite", "part"} - set(meta.columns))
    if missing:
        raise click.BadParameter(
            f"{str(runs_path)!r} lacks column(s) {missing}; expected one row per run with "
            "run, composite, part (as `energy-planner simulate` writes runs.csv)",
            param_hint="--runs",
        )
    return meta


@options.command(
    "diagnose", "energy-planner diagnose campaign --model b1.json --report diagnosis.html"
)
@options.logs_argument
@options.model_option
@options.report_option
@options.path_option(
    "--runs",
    "runs_path",
    help="Run metadata CSV with columns run, composite, part (for the superposition check); "
    "default: runs.csv inside a LOGS folder, if there is one.",
)
@options.window_option
@options.staircase_options
@options.repair_option
@options.json_option
def command(
    logs: tuple[Path, ...],
    model_path: Path | None,
    report: Path | None,
    terms: tuple[str, ...],
    staircase: dict[str, Any],
    runs_path: Path | None,
    window: float,
    repair: bool,
    as_json: bool,
) -> None:
    """Compare a fitted model with LOGS and rank the physical effects it misses.

    Checks the logs for sensor problems first and repairs them (--no-repair: report
    only), as fit and discover do. Shows the error at the level of window power (RMSE,
    MAE, R^2) and of whole runs (energy per run, superposition of composite paths),
    where it fails (the residual by slope, heading, speed, motion and every extra log
    channel), and a ranked list of suspects: candidate effects from the catalog and
    from the extra channels, each validated on held-out runs. Add the best one with the
    printed `energy-planner fit` line and diagnose again, or let `energy-planner
    discover` walk the whole staircase.
    """
    from energy_planner.cli.fit import load_prepared, resolve_terms
    from energy_planner.diagnosis import diagnose
    from energy_planner.errors import EnergyPlannerError

    model = options.load_model_option(model_path)
    if not model.is_fitted:
        raise click.BadParameter(
            f"the model {str(model_path)!r} has no coefficients; fit it first "
            "(energy-planner fit LOGS --out model.json)",
            param_hint="--model",
        )
    resolve_terms(terms)  # syntax first: fail before loading any log
    prepared = load_prepared(logs, window, repair)[0]  # (prepared, reports, text, ...)
    extra = [t.name for t in resolve_terms(terms, set(prepared.windows.samples.columns))]
    runs_meta = _runs_meta(runs_path, logs)
    try:
        d = diagnose(
            model,
            prepared,
            runs_meta=runs_meta,
            **staircase,
            terms=extra,
            progress=True,  # a line per step on stderr (not with --quiet)
        )
    except EnergyPlannerError as exc:
        raise click.ClickException(
            f"{exc}\nhint: the model's features must be in the logs; see docs/diagnosis.md"
        ) from exc
    doc = d.to_dict()
    if doc["suspects"]:
        out = (
            Path("model.json")
            if model_path is None
            else model_path.with_name(f"{model_path.stem}_next.json")
        )
        from energy_planner.diagnosis.suspects import model_term

        top = doc["suspects"][0]
        new = model_term(top["name"], top["term"])  # a long formula by its short name
        new = getattr(new, "name", new)
        doc["hint"] = fit_hint(logs, doc["model_terms"], new, out, window)
    if report is not None:
        from energy_planner.diagnosis.report import write_report

        try:
            write_report(d, report)
        except OSError as exc:
            raise click.BadParameter(str(exc), param_hint="--report") from exc
        doc["report"] = str(report)
    options.emit(doc, as_json, lambda x: _text(x, report))
