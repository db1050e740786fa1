"""The ``energy-planner`` command line.

A click group whose sub-commands live one per module in this package (``terrain.py``,
``energy.py``, ...), each exposing a click command named ``command``. Modules are
imported only when their command runs, so ``energy-planner --help`` stays fast and a
command's heavy imports (rasterio, ompl, numba) are paid only by that command.
"""

from __future__ import annotations

import importlib
import importlib.util

import click

# command name -> (module in energy_planner.cli, one-line summary for the command list).
# The summaries live here so that ``energy-planner --help`` lists the commands without
# importing them (numpy, pandas and numba stay unloaded); a command's own ``--help``
# shows its docstring.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("demo", "Fig. 1 on the bundled hill: direct, shortest, optimal route."),
    "terrain": ("terrain", "Summarize a DEM; write slope and aspect rasters."),
    "energy": ("energy", "Energy of walking given waypoints over a DEM, per segment."),
    "energy-map": ("energy_map", "Heading-dependent energy map of a DEM (J/m per heading)."),
    "simulate": ("simulate", "Simulate a campaign or missions from mechanistic physics."),
    "fit": ("fit", "Fit the energy model of your robot from its logs."),
    "figures": ("figures", "The paper's Fig. 3, 4 and 5 from logs, as PNGs."),
    "diagnose": ("diagnose", "Compare a model with logs and rank the missing effects."),
    "discover": ("discover", "Find and add the effects the base model misses."),
    "plan": ("plan", "Plan an energy-minimal path on SE(2) from a start to a goal."),
    "compare-routes": ("compare_routes", "Direct line vs shortest vs energy-optimal route."),
    "reach": ("reach", "Least energy to every cell; the area a battery reaches."),
    "mission": ("mission", "Visit several sites in the least-energy order, legs planned."),
    "follow": ("follow", "Replay a log along a planned path: remaining energy, updated."),
}


class LazyGroup(click.Group):
    """A click group that imports a sub-command's module only when it is used."""

    def _available(self) -> dict[str, str]:
        return {
            name: mod
            for name, (mod, _) in COMMANDS.items()
            if importlib.util.find_spec(f"energy_planner.cli.{mod}") is not None
        }

    def list_commands(self, ctx: click.Context) -> list[str]:
        """Return the sorted names of the sub-commands whose modules are installed."""
        return sorted(self._available())

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        """Import and return the sub-command ``cmd_name``, or ``None`` if unavailable."""
        mod = self._available().get(cmd_name)
        if mod is None:
            return None
        cmd = importlib.import_module(f"energy_planner.cli.{mod}").command
        cmd.short_help = COMMANDS[cmd_name][1]
        return cmd

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """List the commands with their summaries from :data:`COMMANDS`, importing none."""
        rows = [(name, COMMANDS[name][1]) for name in self.list_commands(ctx)]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="energy_planner")
def main() -> None:
    """Plan energy-minimal routes for legged robots on sloping ground.

    Start with `energy-planner demo`.
    """
