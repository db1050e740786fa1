"""The diagnosis as one self-contained HTML page (plots embedded as base64 PNG).

The page works offline: no script, no stylesheet or image is fetched from anywhere.
Its plots (the ``plot_*`` functions, which return the figure) are laid out for the
resolution the page embeds them at (:data:`REPORT_DPI`).
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.diagnosis.core import Diagnosis
from energy_planner.diagnosis.suspects import RUN_TEST_NAME
from energy_planner.plotting import fit_layout, new_figure

#: Resolution of the page's images (dpi); each plot is laid out for it (``fit_layout``).
REPORT_DPI = 80

_CSS = """
body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.6em}
table{border-collapse:collapse;margin:.5em 0;font-size:.9em}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}
th{background:#f0f0f0}td.l,th.l{text-align:left}
tr.hot td{background:#fde2e2}
.note{color:#555;font-size:.9em}.big{font-size:1.1em}
img{max-width:100%;border:1px solid #eee}
code{background:#f5f5f5;padding:0 3px}
"""


def _png(fig) -> str:
    """Encode a matplotlib figure as an ``<img>`` tag with a base64 PNG."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=REPORT_DPI)  # laid out by each plot for it: one draw
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return f'<img alt="plot" src="data:image/png;base64,{data}">'


def _fmt(v: Any, digits: int = 3) -> str:
    if v is None:
        return "-"
    if isinstance(v, float | np.floating):
        if not math.isfinite(v):
            return "-"
        return f"{v:.{digits}g}" if abs(v) < 1e4 else f"{v:.0f}"
    return html.escape(str(v))


def _table(rows: Sequence[dict], cols: Sequence[tuple[str, str]], hot=None) -> str:
    if not rows:
        return '<p class="note">(none)</p>'
    head = "".join(  # text columns (judged by the first row) are left-aligned
        f'<th class="{"l" if i == 0 or isinstance(rows[0].get(k), str) else ""}">'
        f"{html.escape(label)}</th>"
        for i, (k, label) in enumerate(cols)
    )
    body = []
    for r in rows:
        cls = ' class="hot"' if hot is not None and hot(r) else ""
        cells = "".join(
            f'<td class="{"l" if i == 0 or isinstance(r.get(k), str) else ""}">'
            f"{_fmt(r.get(k))}</td>"
            for i, (k, _) in enumerate(cols)
        )
        body.append(f"<tr{cls}>{cells}</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def plot_predicted_vs_measured(d: Diagnosis, dpi: float | None = REPORT_DPI):
    """Scatter of window mean power, predicted against measured, by motion type.

    Laid out for ``dpi`` (None: the figure's), as every plot of the report.
    """
    fig, ax = new_figure(figsize=(5.5, 5))
    y, p = d.data.power, d.predicted
    motion = d.data.table.get("motion")
    groups = ["all"] if motion is None else sorted(map(str, set(motion.dropna())))
    for g in groups:
        m = np.ones(len(y), bool) if motion is None else motion.astype(str).to_numpy() == g
        ax.scatter(y[m], p[m], s=8, alpha=0.6, label=g)
    ok = np.isfinite(y) & np.isfinite(p)
    if ok.any():
        lo, hi = float(min(y[ok].min(), p[ok].min())), float(max(y[ok].max(), p[ok].max()))
        ax.plot([lo, hi], [lo, hi], "k--", lw=1, label="y = x")
    ax.set_xlabel("measured window power (W)")
    ax.set_ylabel("predicted window power (W)")
    ax.set_title(f"RMSE {d.metrics['rmse_w']:.1f} W, R$^2$ {d.metrics['r2']:.3f}")
    ax.legend(fontsize=7, markerscale=1.5)
    return fit_layout(fig, dpi=dpi)


def plot_residuals(d: Diagnosis, dpi: float | None = REPORT_DPI):
    """Window residual (measured - predicted) against every variable."""
    t = d.data.table
    r = d.residual
    variables = [c for c in ("alpha_deg", "gamma_deg", "speed", "wz") if c in t.columns]
    variables += list(d.data.numeric_extras)
    cats = [c for c in ("motion",) if c in t.columns] + list(d.data.categorical_extras)
    n = len(variables) + len(cats)
    ncol = 3
    nrow = max(1, math.ceil(n / ncol))
    fig, axes = new_figure(nrow, ncol, cells=n, figsize=(12, 3.0 * nrow))  # no empty axes
    for ax, col in zip(axes, variables, strict=False):
        ax.scatter(t[col].to_numpy(float), r, s=5, alpha=0.5)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel(col)
        ax.set_ylabel("residual (W)")
    for ax, col in zip(axes[len(variables) :], cats, strict=False):
        vals = t[col].astype(object).where(t[col].notna(), "(missing)").astype(str).to_numpy()
        labels = sorted(set(vals))
        data = [r[vals == v] for v in labels]
        data = [x[np.isfinite(x)] for x in data]
        ax.boxplot(data, showfliers=False)
        ax.set_xticks(range(1, len(labels) + 1), labels, rotation=30, fontsize=7)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel(col)
        ax.set_ylabel("residual (W)")
    return fit_layout(fig, dpi=dpi)


def plot_runs(d: Diagnosis, dpi: float | None = REPORT_DPI):
    """Per-run energy: relative error of the prediction, and predicted against measured."""
    runs = d.runs
    fig, (a1, a2) = new_figure(1, 2, figsize=(12, 4))
    m = runs["measured_j"].to_numpy(float)
    p = runs["predicted_j"].to_numpy(float)
    a1.scatter(m, p, s=10)
    if len(m):
        lo, hi = float(np.nanmin([m.min(), p.min()])), float(np.nanmax([m.max(), p.max()]))
        a1.plot([lo, hi], [lo, hi], "k--", lw=1)
    a1.set_xlabel("measured run energy (J)")
    a1.set_ylabel("predicted run energy (J)")
    rel = 100 * runs["error_rel"].to_numpy(float)
    order = np.argsort(np.nan_to_num(rel))
    a2.bar(np.arange(len(rel)), rel[order], width=1.0)
    a2.axhline(0, color="k", lw=0.8)
    a2.set_xlabel("runs, sorted by error")
    a2.set_ylabel("energy error, % of measured")
    return fit_layout(fig, dpi=dpi)


def plot_staircase(d: Diagnosis, dpi: float | None = REPORT_DPI):
    """Held-out RMSE as the best suspects are added one by one."""
    fig, ax = new_figure(figsize=(7, 3.8))
    steps = d.steps
    rows = [
        {"name": s.name, "heldout_rmse_w": s.heldout_rmse_w, "fold_rmse_w": s.fold_rmse_w}
        for s in steps
    ]
    _rmse_bars(ax, rows, "model as given", "pooled held-out RMSE", "held-out RMSE (W)", 20)
    ax.legend(fontsize=8)
    return fit_layout(fig, dpi=dpi)


def _rmse_bars(ax, rows: Sequence[dict], first: str, label: str, ylabel: str, rotation: float):
    """Held-out RMSE per staircase step as bars with the fold range; the x positions.

    ``rows``: ``name``, ``heldout_rmse_w`` and ``fold_rmse_w`` of each step; the first
    bar is labelled ``first``, the others ``+ name``.
    """
    x = np.arange(len(rows))
    y = np.array([r["heldout_rmse_w"] for r in rows], float)
    lo = np.array([min(r["fold_rmse_w"]) for r in rows], float)
    hi = np.array([max(r["fold_rmse_w"]) for r in rows], float)
    ax.bar(x, y, width=0.6, color="C0", label=label)
    ax.errorbar(x, y, yerr=[y - lo, hi - y], fmt="none", ecolor="k", capsize=4, label="fold range")
    for xi, yi in zip(x, y, strict=True):
        ax.annotate(f"{yi:.1f} W", (xi, yi), textcoords="offset points", xytext=(12, 3), fontsize=8)
    ax.set_xticks(x, [first] + [f"+ {r['name']}" for r in rows[1:]], rotation=rotation, fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_ylim(bottom=0)
    return x


def plot_suspects(d: Diagnosis, top: int = 12, dpi: float | None = REPORT_DPI):
    """Fraction of the held-out error each candidate explains (above-noise ones in red)."""
    r = d.ranking
    rows = [] if r is None else (r.suspects + r.below_noise)[:top]
    fig, ax = new_figure(figsize=(7, 0.35 * max(len(rows), 3) + 1))
    names = [s.name for s in rows][::-1]
    vals = [s.error_explained for s in rows][::-1]
    colors = ["C3" if s.above_noise else "C7" for s in rows][::-1]
    ax.barh(np.arange(len(rows)), vals, color=colors)
    ax.set_yticks(np.arange(len(rows)), names, fontsize=8)
    ax.set_xlabel("error_explained (fraction of held-out MSE removed)")
    ax.set_title("candidates, best first (red: above noise, grey: below)", fontsize=9)
    ax.axvline(0, color="k", lw=0.8)
    return fit_layout(fig, dpi=dpi)


def render_html(d: Diagnosis, title: str = "energy_planner diagnosis") -> str:
    """The full report as an HTML string."""
    doc = d.to_dict()
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
        f"</title><style>{_CSS}</style></head><body><h1>{html.escape(title)}</h1>"
    ]
    parts.append(
        f"<p class='big'>Model terms: <code>{html.escape(', '.join(doc['model_terms']))}</code>"
        f"<br>{doc['n_windows']} windows from {doc['n_runs']} runs. Window power: RMSE "
        f"<b>{_fmt(doc['rmse_w'])} W</b>, MAE {_fmt(doc['mae_w'])} W, bias "
        f"{_fmt(doc['bias_w'])} W, R<sup>2</sup> {_fmt(doc['r2'])}; held-out RMSE (refitted, "
        f"by run) <b>{_fmt(doc['heldout_rmse_w'])} W</b>.</p>"
    )
    for n in doc["notes"]:
        parts.append(f"<p class='note'>{html.escape(n)}</p>")
    parts += _suspects_section(d, doc)
    parts += _staircase_section(d, doc)
    parts += _residuals_section(d, doc)
    parts += _runs_section(d, doc)
    parts += _superposition_section(doc)
    parts.append("</body></html>")
    return "\n".join(parts)


def _suspects_section(d: Diagnosis, doc: dict[str, Any]) -> list[str]:
    """The suspects found, those below noise and those the logs cannot test."""
    parts: list[str] = []
    th = doc["thresholds"]
    parts.append("<h2>Suspects: which effect is missing</h2>")
    parts.append(
        f"<p class='note'>Each candidate is one more term, refitted and validated on held-out "
        f"runs ({th['n_splits']} folds by run). A suspect is <i>above noise</i> when "
        f"choosing at all passes (each fold's choice, made on its training runs alone, "
        f"lowers the error of the runs it did not see: a {RUN_TEST_NAME} at p &lt; "
        f"{th['alpha']}), then a {RUN_TEST_NAME} of its own held-out error reduction has "
        f"p &lt; {th['alpha']} for the best and p &lt; {th['alpha']} / {doc['n_tested']} "
        f"candidates (Bonferroni) for the others, and the pooled held-out "
        f"RMSE falls by at least {100 * th['min_rel']:.0f}%. Add one with <code>energy-planner "
        f"fit LOGS --out model.json --term TERM</code>, or let <code>energy-planner discover"
        f"</code> walk the staircase.</p>"
    )
    cols = [
        ("name", "suspect"),
        ("term", "term"),
        ("error_explained", "error explained"),
        ("heldout_rmse_w", "held-out RMSE with it (W)"),
        ("z_by_run", "z (by run)"),
        ("p_value", "p"),
        ("explanation", "physical explanation"),
    ]
    parts.append(_table(doc["suspects"], cols))
    if doc["suspects"] or doc["below_noise"]:
        parts.append(_png(plot_suspects(d)))
    parts.append("<h3>Below noise (not findings)</h3>")
    parts.append(_table(doc["below_noise"][:15], cols))
    parts.append("<h3>Unsupported by these logs</h3>")
    parts.append(
        _table(doc["unsupported"], [("name", "candidate"), ("term", "term"), ("reason", "why not")])
    )
    return parts


def _staircase_section(d: Diagnosis, doc: dict[str, Any]) -> list[str]:
    """Held-out error as suspects are added one by one."""
    parts: list[str] = []
    parts.append("<h2>Staircase: held-out error as suspects are added</h2>")
    steps = [dict(s, added=s["added"] or "(model as given)") for s in doc["staircase"]]
    parts.append(
        _table(
            steps,
            [
                ("step", "step"),
                ("added", "term added"),
                ("heldout_rmse_w", "held-out RMSE (W)"),
                ("error_explained", "error explained by it"),
            ],
        )
    )
    if d.steps:
        parts.append(_png(plot_staircase(d)))
    return parts


def _residuals_section(d: Diagnosis, doc: dict[str, Any]) -> list[str]:
    """Predicted against measured power, and where the residuals concentrate."""
    parts: list[str] = []
    parts.append("<h2>Predicted against measured power</h2>")
    parts.append(_png(plot_predicted_vs_measured(d)))
    parts.append("<h2>Where it fails: residuals by variable</h2>")
    parts.append(_png(plot_residuals(d)))
    parts.append("<h3>Largest systematic errors (bias / its standard error)</h3>")
    bcols = [
        ("bin", "bin"),
        ("n", "windows"),
        ("bias_w", "bias (W)"),
        ("rmse_w", "RMSE (W)"),
        ("share_sq_error", "share of sq. error"),
        ("t", "t"),
    ]
    parts.append(_table(doc["hotspots"], [("variable", "variable"), *bcols]))
    for var, info in doc["breakdown"].items():
        parts.append(f"<h3>{html.escape(var)} ({info['kind']})</h3>")
        parts.append(_table(info["bins"], bcols, hot=lambda r: abs(r.get("t") or 0) > 3))
    return parts


def _runs_section(d: Diagnosis, doc: dict[str, Any]) -> list[str]:
    """Energy of whole runs, measured and predicted."""
    parts: list[str] = []
    parts.append("<h2>Energy of whole runs</h2>")
    parts.append(_png(plot_runs(d)))
    parts.append(
        _table(
            doc["runs"],
            [
                ("run", "run"),
                ("duration_s", "duration (s)"),
                ("measured_j", "measured (J)"),
                ("predicted_j", "predicted (J)"),
                ("error_j", "error (J)"),
                ("error_rel", "error (rel.)"),
            ],
        )
    )
    return parts


def _superposition_section(doc: dict[str, Any]) -> list[str]:
    """How well the energies of composite runs add up."""
    parts: list[str] = []
    parts.append("<h2>Superposition of composite paths</h2>")
    parts.append(
        "<p class='note'>Measured energy of a composite run (AB: the legs in one go; "
        "alternative: another path between the same poses) against E(A) + E(B): how well "
        "energies add (the model assumes they do), and the model's error on both.</p>"
    )
    sup = [dict(s, parts=" + ".join(s["parts"])) for s in doc["superposition"]]
    parts.append(
        _table(
            sup,
            [
                ("composite", "composite"),
                ("kind", "kind"),
                ("parts", "parts"),
                ("measured_composite_j", "measured E(composite) (J)"),
                ("measured_parts_j", "measured sum of parts (J)"),
                ("superposition_error_rel", "superposition error (rel.)"),
                ("model_error_composite_j", "model error, composite (J)"),
                ("model_error_parts_j", "model error on parts (J)"),
            ],
        )
    )
    return parts


def write_report(d: Diagnosis, path: str | Path, title: str = "energy_planner diagnosis") -> Path:
    """Write the self-contained HTML report; returns the path."""
    from energy_planner.io import write_text

    return write_text(Path(path), render_html(d, title))


# --------------------------------------------------------------------------- discover


def plot_discovery(table: Sequence[dict], dpi: float | None = REPORT_DPI):
    """The staircase of ``discover`` as a plot.

    Held-out power RMSE (bars) and run-energy error (median and 90th percentile, lines)
    after each step; laid out for ``dpi`` (None: the figure's).
    """
    fig, ax = new_figure(figsize=(8, 4.2))
    x = _rmse_bars(
        ax, table, "base model", "held-out power RMSE (W)", "held-out power RMSE (W)", 15
    )
    ax2 = ax.twinx()
    med = 100 * np.array([r["run_energy_error_median"] for r in table], float)
    p90 = 100 * np.array([r["run_energy_error_p90"] for r in table], float)
    ax2.plot(x, med, "o-", color="C3", label="run energy error, median (%)")
    ax2.plot(x, p90, "s--", color="C1", label="run energy error, p90 (%)")
    ax2.set_ylabel("held-out run energy error (%)")
    ax2.set_ylim(bottom=0)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper right")
    ax.set_title("discovery staircase (every number held out by run)", fontsize=10)
    return fit_layout(fig, dpi=dpi)


def render_discovery_html(doc: dict, title: str = "energy_planner discover") -> str:
    """The ``discover`` report (``Discovery.to_dict()``) as one self-contained page."""
    th = doc["thresholds"]
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
        f"</title><style>{_CSS}</style></head><body><h1>{html.escape(title)}</h1>"
    ]
    parts.append(
        f"<p class='big'>{doc['n_windows']} windows from {doc['n_runs']} runs. Base model: "
        f"<code>{html.escape(', '.join(doc['base_terms']))}</code>.<br>Terms added: "
        f"<code>{html.escape(', '.join(doc['added']) or '(none)')}</code></p>"
    )
    fl = doc.get("noise_floor")
    if fl:
        parts.append(
            f"<p>Noise floor estimated from the logs: <b>{_fmt(fl['rmse_w'])} W</b> over "
            f"{fl['n_windows']} windows (sensor noise {_fmt(fl['sensor_noise_w'])} W, "
            f"smoothing shift {_fmt(fl['smoothing_shift_w'])} W). Method: "
            f"{html.escape(fl['method'])}.</p>"
        )
    for n in doc["notes"]:
        parts.append(f"<p class='note'>{html.escape(n)}</p>")
    parts.append("<h2>Data findings (sensor problems, not physical effects)</h2>")
    parts.append(
        _table(
            doc["data_findings"],
            [("name", "check"), ("finding", "found"), ("repaired", "repaired"),
             ("summary", "what was measured")],
            hot=lambda r: r.get("finding"),
        )
    )  # fmt: skip
    parts.append("<h2>Staircase</h2>")
    table = doc["staircase"]
    parts.append(_png(plot_discovery(table)))
    rows = []
    for r in table:
        alts = "; ".join(f"{a['name']} ({a['term']})" for a in r["alternatives"])
        left = "; ".join(f"{d['name']}: {d['reason']}" for d in r.get("dropped", []))
        rows.append(
            dict(
                r,
                added=r["added"] or "(base model)",
                alternatives=alts or "-",
                left_out=left or "-",
                med=None if r["run_energy_error_median"] is None
                else 100 * r["run_energy_error_median"],
                p90=None if r["run_energy_error_p90"] is None else 100 * r["run_energy_error_p90"],
                removed=None if r["error_removed"] is None else 100 * r["error_removed"],
                removed_total=100 * r["error_removed_total"],
            )
        )  # fmt: skip
    parts.append(
        _table(
            rows,
            [
                ("step", "step"),
                ("added", "term added"),
                ("explanation", "physical explanation"),
                ("alternatives", "or equally (confounded)"),
                ("left_out", "tried first, left out by the refit"),
                ("heldout_rmse_w", "held-out RMSE (W)"),
                ("floor_ratio", "x noise floor"),
                ("med", "run energy error, median (%)"),
                ("p90", "run energy error, p90 (%)"),
                ("removed", "error removed by the step (%)"),
                ("removed_total", "error removed so far (%)"),
            ],
        )
    )
    parts.append(
        f"<p class='note'>Rule: at each step, choosing a candidate must lower the error "
        f"of the runs no choice saw (each fold's choice made on its training runs alone: a "
        f"{RUN_TEST_NAME} at p below {th['alpha']}); then the best candidate is added when "
        f"its own test has p below {th['alpha']} (another: below {th['alpha']} / "
        f"candidates tested, {', '.join(map(str, doc['n_tested']))} at each step) and it "
        f"lowers the held-out RMSE by at least {100 * th['min_rel']:.0f}%. Folds: "
        f"{th['n_splits']} by run.</p>"
    )
    parts.append("<h2>Best candidates left below noise</h2>")
    parts.append(
        _table(
            doc["below_noise_at_end"],
            [("name", "candidate"), ("term", "term"), ("error_explained", "error explained"),
             ("z_by_run", "z (by run)"), ("p_value", "p"), ("explanation", "explanation")],
        )
    )  # fmt: skip
    fit = doc.get("final_fit")
    if fit:
        parts.append("<h2>Final model (all windows)</h2>")
        coef = [
            {"term": k, "coefficient": v, "stderr": (fit["stderr"] or {}).get(k)}
            for k, v in fit["coefficients"].items()
        ]
        parts.append(
            _table(coef, [("term", "term"), ("coefficient", "coefficient"), ("stderr", "stderr")])
        )
    parts.append("</body></html>")
    return "\n".join(parts)
