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

# command name -> module in energy_planner.cli
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "terrain": "terrain",
    "energy": "energy",
    "energy-map": "energy_map",
    "simulate": "simulate",
    "fit": "fit",
    "figures": "figures",
    "diagnose": "diagnose",
    "discover": "discover",
    "plan": "plan",
    "compare-routes": "compare_routes",
    "reach": "reach",
    "mission": "mission",
    "follow": "follow",
}


class LazyGroup(click.Group):
    """A click group that imports a sub-command's module only when it is used."""

    def _available(self) -> dict[str, str]:
        return {
            name: mod
            for name, mod in COMMANDS.items()
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
        return importlib.import_module(f"energy_planner.cli.{mod}").command


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="energy_planner")
def main() -> None:
    """Plan energy-minimal routes for legged robots on sloping ground.

    Start with `energy-planner demo`.
    """
