"""The report figures (``diagnose --report``, ``discover --report``, ``figures``).

They are figures of their own (:func:`energy_planner.plotting.new_figure`: no pyplot
figure left open, the backend left as it was), laid out once
(:func:`energy_planner.plotting.fit_layout`, the same subplot parameters as matplotlib's
``tight_layout``), so that saving one draws it once, with every label inside the image.
"""

from __future__ import annotations

import io
from types import SimpleNamespace

import matplotlib
import matplotlib.figure
import numpy as np
import pandas as pd
import pytest
from PIL import Image

from energy_planner.calibration.figures import plot_superposition
from energy_planner.diagnosis import report
from energy_planner.plotting import fit_layout, new_figure

#: Long names: a layout that ignored the tick labels would cut them at the left edge.
NAMES = ["load_kg * speed * sin(alpha)", "grass_height_m * abs(vx)", "motor_temp * pos(vx)"]


@pytest.fixture(scope="module")
def diag():
    """What the report's plots read of a ``Diagnosis``: 120 windows of 12 runs, two
    numeric and one categorical extra channel, three staircase steps, six candidates."""
    rng = np.random.default_rng(0)
    n = 120
    table = pd.DataFrame(
        {
            "alpha_deg": rng.uniform(-20, 20, n),
            "gamma_deg": rng.uniform(-180, 180, n),
            "speed": rng.uniform(0, 0.6, n),
            "wz": rng.normal(0, 0.3, n),
            "motion": rng.choice(["forward", "lateral", "turn_left"], n),
            "load_kg": rng.uniform(0, 10, n),
            "motor_temp": rng.uniform(20, 60, n),
            "ground": rng.choice(["grass", "gravel", "asphalt"], n),
        }
    )
    power = rng.uniform(100, 400, n)
    predicted = power + rng.normal(0, 15, n)
    runs = pd.DataFrame(
        {"measured_j": rng.uniform(1e3, 5e3, 12), "predicted_j": rng.uniform(1e3, 5e3, 12)}
    )
    runs["error_rel"] = runs["predicted_j"] / runs["measured_j"] - 1
    steps = [
        SimpleNamespace(name=name, heldout_rmse_w=rmse, fold_rmse_w=[rmse - 2, rmse + 3])
        for name, rmse in zip(["base", *NAMES[:2]], [30.0, 18.0, 15.0], strict=True)
    ]
    cands = [
        SimpleNamespace(name=f"{name} ({i})", error_explained=0.4 / (i + 1), above_noise=i < 2)
        for i, name in enumerate(NAMES * 2)
    ]
    discovery = [
        {"name": s.name, "heldout_rmse_w": s.heldout_rmse_w, "fold_rmse_w": s.fold_rmse_w,
         "run_energy_error_median": 0.05 / (i + 1), "run_energy_error_p90": 0.1 / (i + 1)}
        for i, s in enumerate(steps)
    ]  # fmt: skip
    return SimpleNamespace(
        data=SimpleNamespace(
            table=table,
            power=power,
            numeric_extras=["load_kg", "motor_temp"],
            categorical_extras=["ground"],
        ),
        predicted=predicted,
        residual=power - predicted,
        metrics={"rmse_w": 15.0, "r2": 0.9},
        runs=runs,
        steps=steps,
        ranking=SimpleNamespace(suspects=cands[:2], below_noise=cands[2:]),
        discovery=discovery,
    )


PLOTS = {
    "predicted_vs_measured": report.plot_predicted_vs_measured,
    "residuals": report.plot_residuals,
    "runs": report.plot_runs,
    "staircase": report.plot_staircase,
    "suspects": report.plot_suspects,
    "discovery": lambda d: report.plot_discovery(d.discovery),
}


@pytest.fixture(scope="module")
def made(diag):
    """Each of :data:`PLOTS` made once, never saved, with pyplot's open figures and the
    backend before and after they were made."""
    import matplotlib.pyplot as plt

    before = plt.get_fignums(), matplotlib.get_backend()
    figs = {name: plot(diag) for name, plot in PLOTS.items()}
    return SimpleNamespace(
        figs=figs, before=before, after=(plt.get_fignums(), matplotlib.get_backend())
    )


@pytest.mark.parametrize("name", PLOTS)
def test_a_report_figure_is_drawn_once_with_every_label_inside(made, name):
    fig = made.figs[name]  # made by the plot and not saved before
    draws = []
    fig.canvas.mpl_connect("draw_event", draws.append)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    assert len(draws) == 1  # laid out before: no pass without rendering first
    # the image is the figure at 80 dpi, and every axes with its labels is inside it
    width, height = Image.open(buf).size
    assert (width, height) == tuple(np.round(fig.get_size_inches() * 80).astype(int))
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        if ax.get_visible():
            box = ax.get_tightbbox(renderer)
            assert box.x0 >= -1 and box.y0 >= -1, (name, ax.get_xlabel(), box)
            assert box.x1 <= fig.bbox.x1 + 1 and box.y1 <= fig.bbox.y1 + 1, (name, box)


def test_fit_layout_gives_the_subplot_parameters_of_tight_layout():
    def figure():
        fig = matplotlib.figure.Figure(figsize=(7, 3))
        axes = fig.subplots(1, 2)
        axes[0].barh(range(3), [1, 2, 3])
        axes[0].set_yticks(range(3), NAMES)
        axes[1].set_xlabel("speed (m/s)")
        axes[1].set_title("a title")
        return fig

    tight, fitted = figure(), figure()
    tight.tight_layout()
    fit_layout(fitted)
    assert vars(fitted.subplotpars) == vars(tight.subplotpars)
    assert vars(fitted.subplotpars) != vars(figure().subplotpars)  # it did move them
    assert fitted.get_layout_engine() is None


def test_fit_layout_at_a_dpi_is_tight_layout_of_the_figure_drawn_at_it():
    """Laid out for 80 dpi: the subplot parameters ``tight_layout`` gives the figure made
    at 80 dpi (text measured as drawn there, not at the figure's 100 dpi), and the figure
    keeps its own dpi."""

    def figure(dpi):
        fig = matplotlib.figure.Figure(figsize=(7, 3), dpi=dpi)
        axes = fig.subplots(1, 2)
        axes[0].barh(range(3), [1, 2, 3])
        axes[0].set_yticks(range(3), NAMES)
        axes[1].set_xlabel("speed (m/s)")
        return fig

    at80 = figure(80)
    at80.tight_layout()
    fitted = fit_layout(figure(100), dpi=80)
    assert fitted.dpi == 100 and fitted.get_layout_engine() is None
    assert vars(fitted.subplotpars) == pytest.approx(vars(at80.subplotpars), abs=1e-12)
    at100 = figure(100)
    at100.tight_layout()
    assert vars(fitted.subplotpars) != pytest.approx(vars(at100.subplotpars), abs=1e-4)


def test_the_figures_leave_pyplot_and_its_backend_alone(made, tmp_path):
    import matplotlib.pyplot as plt

    assert made.after == made.before  # no pyplot figure opened, the backend as it was
    assert all(type(f.canvas).__name__ == "FigureCanvasAgg" for f in made.figs.values())
    open_before, backend = plt.get_fignums(), matplotlib.get_backend()
    table = pd.DataFrame(
        {"composite": ["AB1", "AB2"], "A": [100.0, 120.0], "B": [80.0, 90.0],
         "AB": [185.0, 205.0], "C": [190.0, 230.0]}
    )  # fmt: skip
    table["sum_ab"] = table["A"] + table["B"]
    table["rel_ab"] = table["AB"] / table["sum_ab"] - 1
    table["rel_c"] = table["C"] / table["sum_ab"] - 1
    plot_superposition(table, tmp_path / "superposition.png")
    assert plt.get_fignums() == open_before
    assert matplotlib.get_backend() == backend
    assert Image.open(tmp_path / "superposition.png").size[0] > 500


def test_new_figure_is_subplots_without_pyplot():
    fig, axes = new_figure(2, 3, figsize=(6, 4), squeeze=False, sharey=True)
    assert axes.shape == (2, 3) and list(fig.get_size_inches()) == [6.0, 4.0]
    assert axes[0, 1].get_shared_y_axes().joined(axes[0, 1], axes[1, 2])


@pytest.mark.parametrize("layout", ["constrained", "tight_layout", "none"])
def test_save_figure_draws_once_the_image_savefig_draws(layout, tmp_path, monkeypatch):
    """``save_figure`` runs a figure's layout engine once, as ``savefig``'s first pass
    would (at the saved dpi), and removes it: the PNG is byte for byte ``savefig``'s, drawn
    once instead of twice, and the figure keeps its engine; with ``bbox_inches="tight"``
    (which needs that pass) both passes stay, and the image is the same too."""
    import matplotlib.figure

    from energy_planner.io import save_figure

    def figure():
        fig = matplotlib.figure.Figure(
            figsize=(6, 3), layout="constrained" if layout == "constrained" else None
        )
        axes = fig.subplots(1, 2)
        im = axes[0].imshow(np.arange(20.0).reshape(4, 5))
        fig.colorbar(im, ax=axes[0], label="a colour bar")
        axes[1].barh(range(3), [1, 2, 3])
        axes[1].set_yticks(range(3), NAMES)
        axes[1].set_title("a title")
        if layout == "tight_layout":
            fig.tight_layout()
        return fig

    draws = []
    real = matplotlib.figure.Figure.draw

    def counted(self, renderer):
        draws.append(self)
        return real(self, renderer)

    monkeypatch.setattr(matplotlib.figure.Figure, "draw", counted)
    for tight in (False, True):
        kw = {"dpi": 90, **({"bbox_inches": "tight"} if tight else {})}
        ref, ours = figure(), figure()
        ref.savefig(tmp_path / "ref.png", **kw)
        assert len(draws) == (2 if tight or layout != "none" else 1)  # savefig's passes
        draws.clear()
        save_figure(ours, tmp_path / "ours.png", **kw)
        assert len(draws) == (2 if tight else 1)
        draws.clear()
        # the figure keeps its engine (changed and saved again, it is laid out again)
        assert type(ours.get_layout_engine()) is type(ref.get_layout_engine())
        assert (tmp_path / "ours.png").read_bytes() == (tmp_path / "ref.png").read_bytes()
