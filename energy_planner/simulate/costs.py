"""Force-equivalent cost of a campaign's straight runs along the fall line (paper Fig. 4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from energy_planner.errors import LogIOError
from energy_planner.simulate.result import Campaign

__all__ = ["cost_table", "plot_costs"]


def cost_table(campaign: Campaign) -> pd.DataFrame:
    """Force-equivalent cost (J/m) of the straight runs along the fall line.

    One row per straight run whose travel direction is straight uphill or downhill:
    slope_deg, direction (uphill/downhill), motion (forward/lateral), measured cost
    (logged energy / distance) and true cost (truth energy / distance).
    """
    r = campaign.runs[campaign.runs["kind"] == "straight"].copy()
    offset = r["motion"].map({"forward": 0.0, "backward": 180.0, "left": 90.0, "right": -90.0})
    travel = np.mod(r["heading_deg"] + offset, 360.0)
    r["direction"] = np.select(
        [np.isclose(travel, 0.0) | np.isclose(travel, 360.0), np.isclose(travel, 180.0)],
        ["uphill", "downhill"],
        "",
    )
    r = r[r["direction"] != ""]
    r["motion"] = np.where(r["motion"].isin(["left", "right"]), "lateral", r["motion"])
    measured = campaign.run_energies()
    return pd.DataFrame(
        {
            "run": r["run"],
            "slope_deg": r["slope_deg"],
            "direction": r["direction"],
            "motion": r["motion"],
            "speed": r["speed"],
            "measured_cost_n": measured.loc[r["run"]].to_numpy() / r["distance_m"],
            "true_cost_n": r["true_energy_j"] / r["distance_m"],
        }
    ).reset_index(drop=True)


def plot_costs(campaign: Campaign, path: str | Path) -> Path:
    """PNG of the force-equivalent cost versus slope (as the paper's Fig. 4).

    Uphill (left) and downhill (right) straight runs along the fall line, forward and
    lateral: measured cost per run (points) and the truth (lines).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = campaign.cost_table()
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True, constrained_layout=True)
    colours = {"forward": "tab:red", "backward": "tab:orange", "lateral": "tab:blue"}
    for ax, direction in zip(axes, ("uphill", "downhill"), strict=True):
        sub = table[table["direction"] == direction]
        for motion, g in sub.groupby("motion"):
            c = colours.get(str(motion), "k")
            ax.scatter(
                g["slope_deg"],
                g["measured_cost_n"],
                s=12,
                alpha=0.6,
                color=c,
                label=f"{motion} (measured)",
            )
            truth = g.groupby("slope_deg")["true_cost_n"].mean()
            ax.plot(truth.index, truth.to_numpy(), color=c, lw=1.5, label=f"{motion} (truth)")
        ax.set_title(direction)
        ax.set_xlabel("slope alpha (deg)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("force-equivalent cost (J/m = N)")
    axes[1].legend(fontsize=7)
    effects = ", ".join(campaign.effects) or "none"
    fig.suptitle(f"simulated campaign (seed {campaign.seed}, effects: {effects})", fontsize=9)
    path = Path(path)
    try:
        from energy_planner.io import save_figure

        save_figure(fig, path, dpi=120)
    except OSError as exc:
        raise LogIOError(f"cannot write the plot {str(path)!r}: {exc}") from exc
    finally:
        plt.close(fig)
    return path
