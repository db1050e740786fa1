"""``energy-planner fit``: calibrate an energy model from robot logs."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options
from energy_planner.measurements.logs import log_files


def _as_dict(report: Any) -> Any:
    if report is None:
        return None
    if hasattr(report, "to_dict"):
        return report.to_dict()
    return str(report)


#: Files that sit next to logs but are not logs (the simulator's run table).


def status(message: str) -> None:
    """A progress line on stderr, on a terminal and in a log (not with ``--quiet``).

    Through the one progress reporter (:func:`energy_planner.progress.reporter`).
    """
    from energy_planner.progress import reporter

    reporter(True).say(message)


def load_windows(
    paths: tuple[Path, ...], window: float, repair: bool = True, *, prints_report: bool = False
) -> tuple[Any, dict[str, Any], str, Any]:
    """:func:`load_prepared`, with the windows in place of the prepared logs."""
    prepared, reports, text, samples = load_prepared(paths, window, repair, prints_report)
    return prepared.windows, reports, text, samples


def load_log_files(paths: tuple[Path, ...], report: bool = False) -> Any:
    """The samples of the log files in ``paths`` (and the load report, with ``report``).

    :func:`energy_planner.measurements.load_logs`; its errors become click errors naming
    LOGS (exit 2) or the canonical table (exit 1).
    """
    from energy_planner.errors import LogError, LogIOError
    from energy_planner.measurements import load_logs

    files = log_files(paths)
    status(f"loading {len(files)} log file(s) ...")
    try:
        return load_logs(files, report=report)
    except LogIOError as exc:
        raise click.BadParameter(str(exc), param_hint="LOGS") from exc
    except LogError as exc:
        raise click.ClickException(
            f"{exc}\nhint: logs follow the canonical table (docs/measurements.md)"
        ) from exc


def load_prepared(
    paths: tuple[Path, ...], window: float, repair: bool = True, prints_report: bool = False
) -> tuple[Any, dict[str, Any], str, Any]:
    """Load logs, run the data checks, preprocess and cut windows; errors become click errors.

    The one data pipeline of ``fit``, ``diagnose`` and ``discover``
    (:func:`energy_planner.calibration.prepare_logs`). Returns the ``PreparedLogs``, a
    dict of the load and preprocessing reports and the data findings, the preprocessing
    report as text, and the raw samples. A caller that prints the preprocessing report
    (``prints_report``), which lists the runs preprocessing dropped, gets no warning
    repeating them.
    """
    from energy_planner.calibration.prepare import prepare_logs
    from energy_planner.errors import EnergyPlannerError

    samples, load_report = load_log_files(paths, report=True)
    status(f"preprocessing {len(samples)} samples ...")
    try:
        with warnings.catch_warnings():
            if prints_report:  # the report printed lists the dropped runs: say it once
                warnings.filterwarnings("ignore", "preprocessing dropped", UserWarning)
            prepared = prepare_logs(samples, window=window, repair=repair)
    except EnergyPlannerError as exc:
        raise click.ClickException(f"preprocessing failed: {exc}") from exc
    prep_report = prepared.preprocess_report
    reports = {"load": _as_dict(load_report), "preprocessing": _as_dict(prep_report)}
    reports["windows"] = _as_dict(prepared.windows)
    reports["data_findings"] = prepared.findings_dicts()
    return prepared, reports, str(prep_report), samples


def resolve_terms(specs: tuple[str, ...], available: set[str] | None = None) -> list[Any]:
    """Resolve ``--term`` values; a bad one becomes ``click.BadParameter``.

    With ``available`` (the log's columns), also check that every variable a term reads
    is a channel of the logs.
    """
    from energy_planner.errors import FormulaError, ModelError
    from energy_planner.model import BASE_TERMS, CATALOG, resolve_term

    terms = []
    for spec in specs:
        try:
            term = resolve_term(spec)
        except (FormulaError, ModelError) as exc:
            raise click.BadParameter(str(exc), param_hint="--term") from exc
        if term.name in BASE_TERMS or term.name in {t.name for t in terms}:
            continue  # already in the model
        terms.append(term)
        if available is None:
            continue
        missing = sorted(set(term.variables) - available - {"speed"})
        if missing:
            known = [v for v in sorted(available) if v not in ("window", "run", "t")]
            raise click.BadParameter(
                f"term {spec!r} reads {', '.join(map(repr, missing))}, which is neither a "
                f"feature nor a channel of the logs. Log channels: {', '.join(known)}. "
                f"Catalog terms: {', '.join(CATALOG)}",
                param_hint="--term",
            )
    return terms


def discovered_names(specs: tuple[str, ...], windows: Any) -> tuple[Any, ...]:
    """``--term`` values with the names ``discover`` prints resolved on these windows.

    ``load_kg*P_base``, ``speed^2``, ``ground==mud``: see
    :func:`energy_planner.diagnosis.suspects.resolve_names`; other specs are kept as given.
    """
    from energy_planner.diagnosis import window_data
    from energy_planner.diagnosis.suspects import resolve_names
    from energy_planner.errors import EnergyPlannerError

    if all(" " in s for s in specs):
        return specs
    try:
        return tuple(resolve_names(specs, window_data(windows)))
    except EnergyPlannerError as exc:
        raise click.BadParameter(str(exc), param_hint="--term") from exc


def _runs_table(result: Any, limit: int = 12) -> str:
    cv = result.heldout
    if cv is None:
        return ""
    runs = cv.runs.assign(abs_rel=cv.runs["rel_error"].abs()).sort_values(
        "abs_rel", ascending=False
    )
    lines = [
        "",
        f"held-out run energies (worst {min(limit, len(runs))} of {len(runs)} runs):",
        f"  {'run':<36} {'fold':>4} {'measured J':>11} {'predicted J':>11} {'error':>8}",
    ]
    for _, r in runs.head(limit).iterrows():
        lines.append(
            f"  {str(r['run']):<36} {int(r['fold']):>4} {r['measured_j']:>11.1f} "
            f"{r['predicted_j']:>11.1f} {100 * r['rel_error']:>7.2f}%"
        )
    return "\n".join(lines)


@options.command(
    "fit",
    "energy-planner fit campaign --out b1.json",
    "energy-planner fit campaign --out load.json --term 'load_kg * speed'",
)
@options.logs_argument
@options.path_option("--out", "out", required=True, help="Where to write the fitted model (JSON).")
@click.option(
    "--term",
    "terms",
    multiple=True,
    metavar="NAME",
    help="Add a term to the base model: a catalog name (e.g. idle_power) or a formula "
    "(e.g. 'payload_kg * speed * sin(alpha)'). Repeatable.",
)
@options.window_option
@options.value_option(
    "--folds",
    type=click.IntRange(min=0),
    default=5,
    help="Folds of the cross-validation by run (0: none).",
)
@click.option(
    "--prior",
    "prior_spec",
    default=None,
    metavar="MODEL",
    help="Hold the terms these logs cannot identify (e.g. no backward runs) at this model's "
    "values: a model JSON, or 'default' for the bundled model. Without it such terms are "
    "left out of the fitted model and listed as not identified.",
)
@options.seed_option
@options.repair_option
@options.json_option
def command(
    logs: tuple[Path, ...],
    out: Path,
    terms: tuple[str, ...],
    window: float,
    folds: int,
    prior_spec: str | None,
    seed: int,
    repair: bool,
    as_json: bool,
) -> None:
    """Fit the energy model of your robot from its LOGS (files or folders).

    Checks the logs for sensor problems and repairs them (--no-repair: report only), as
    diagnose and discover do; preprocesses them (paper IV-B, keeping the stops), cuts
    windows, fits the base model (the paper's, and the gait's running power when the logs
    hold standing) plus any --term jointly by weighted least squares, validates it on held-out
    runs and writes the model to --out. Terms the logs cannot identify (no runs of
    their motion, or no slopes that tell them apart) are listed and left out of the
    model, or held at --prior's values; warnings say what else the data cannot support.
    """
    from energy_planner.calibration import fit_model
    from energy_planner.calibration.fit import base_terms
    from energy_planner.errors import EnergyPlannerError, FitError
    from energy_planner.model import EnergyModel

    if folds == 1:
        raise click.BadParameter("use 0 (no validation) or 2 or more folds", param_hint="--folds")
    prior = None
    if prior_spec is not None:
        try:
            prior = (
                EnergyModel.default() if prior_spec == "default" else EnergyModel.load(prior_spec)
            )
            prior.coef_array()
        except EnergyPlannerError as exc:
            raise click.BadParameter(
                f"{exc} (give a fitted model JSON or 'default')", param_hint="--prior"
            ) from exc
    # syntax first: fail before loading any log (a spec without spaces may be a name that
    # discover prints, such as speed^2 or load_kg*P_base: resolved on the windows below)
    resolve_terms(tuple(t for t in terms if " " in t))
    prepared, reports, prep_text, _ = load_prepared(logs, window, repair, prints_report=True)
    windows = prepared.windows
    base = base_terms(windows)  # the paper's, and gait_power when the logs hold standing
    extra = resolve_terms(discovered_names(terms, windows), set(windows.samples.columns))
    extra = [t for t in extra if t.name not in base]
    status(f"fitting {len(base) + len(extra)} terms on {len(windows.table)} windows ...")
    try:
        result = fit_model(
            prepared,
            [*base, *extra],
            n_splits=folds,
            seed=seed,
            metadata={"source": [str(p) for p in logs], "window_s": window},
            prior=prior,
        )
    except FitError as exc:
        raise click.ClickException(
            f"{exc}\nhint: see docs/calibration.md for the runs a calibration needs"
        ) from exc
    except EnergyPlannerError as exc:
        raise click.ClickException(str(exc)) from exc
    try:
        result.model.save(out)
    except OSError as exc:
        raise click.BadParameter(str(exc), param_hint="--out") from exc

    doc = {"model": str(out), **reports, "fit": result.to_dict()}

    def text(_: dict[str, Any]) -> str:
        return "\n".join(
            [
                prep_text,
                "",
                result.summary(),
                _runs_table(result),
                "",
                f"model written to {out}",
            ]
        )

    options.emit(doc, as_json, text)
