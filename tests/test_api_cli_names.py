"""Every option of the commands with a Python verb is a keyword of that verb (or an output).

The Python API reads like the command line: ``energy-planner plan --max-slope 30
--battery-wh 40`` is ``ep.plan(..., max_slope_deg=30, battery_wh=40)``. An option is found
in the verb's signature under its own name (dashes as underscores) or through the one
table :data:`energy_planner.api.CLI_NAMES` (another keyword name, or the result's method
that writes the output). Adding an option to a command without its keyword fails here.
"""

from __future__ import annotations

import inspect
import re

import click
import pytest

import energy_planner as ep
from energy_planner import api
from energy_planner.cli import main
from energy_planner.energy.path import PathEnergy
from energy_planner.energymap.result import EnergyMapResult
from energy_planner.mission import MissionResult
from energy_planner.planning.plan import PlanResult
from energy_planner.planning.reach import ReachMap
from energy_planner.planning.routes import RouteComparison

#: command -> (its verb, the verb's result class)
VERBS = {
    "plan": (api.plan, PlanResult),
    "energy": (api.path_energy, PathEnergy),
    "compare-routes": (api.compare_routes, RouteComparison),
    "reach": (api.reach, ReachMap),
    "mission": (api.mission, MissionResult),
    "energy-map": (api.energy_map, EnergyMapResult),
}


def command_of(name: str) -> click.Command:
    """The click command ``name`` (the group loads its commands on first use)."""
    return main.get_command(click.Context(main), name)


def option_name(param: click.Parameter) -> str:
    """``--max-slope`` for an option (its long name), ``dem`` for an argument."""
    if isinstance(param, click.Argument):
        return param.name
    longs = [o for o in param.opts if o.startswith("--")]
    return max(longs, key=len) if longs else param.opts[0]


def python_name(command: str, option: str) -> str:
    """Where ``option`` of ``command`` reaches Python: a keyword, ``result.X`` or ``output``."""
    keywords = inspect.signature(VERBS[command][0]).parameters
    own = option.lstrip("-").replace("-", "_")
    if own in keywords:
        return own
    alias = api.CLI_NAMES.get(option)
    if isinstance(alias, dict):
        alias = alias.get(command)
    assert alias is not None, (
        f"{command} {option}: no keyword {own!r} in ep.{VERBS[command][0].__name__} and no "
        "entry in energy_planner.api.CLI_NAMES"
    )
    return alias


@pytest.mark.parametrize("command", sorted(VERBS))
def test_every_option_has_its_python_keyword_or_writer(command):
    verb, result = VERBS[command]
    keywords = inspect.signature(verb).parameters
    params = command_of(command).params
    assert len(params) > 5
    for param in params:
        option = option_name(param)
        name = python_name(command, option)
        if name == "output":
            continue
        if name.startswith("result."):
            assert callable(getattr(result, name.split(".", 1)[1], None)), (command, option, name)
        elif name.startswith("ep."):  # another verb: plan --pareto N is ep.pareto(n=N)
            other, keyword = name[3:].split(":")
            assert keyword in inspect.signature(getattr(api, other)).parameters, (option, name)
            assert getattr(ep, other) is getattr(api, other), name
        else:
            assert name in keywords, (command, option, name)
            kind = keywords[name].kind
            assert kind is not inspect.Parameter.VAR_KEYWORD, (command, option)


def test_the_name_table_has_no_stale_entry():
    used = {option_name(p) for c in VERBS for p in command_of(c).params}
    assert set(api.CLI_NAMES) <= used, set(api.CLI_NAMES) - used
    for option, alias in api.CLI_NAMES.items():
        if isinstance(alias, dict):
            for command in alias:
                opts = {option_name(p) for p in command_of(command).params}
                assert option in opts, (option, command)


def test_the_top_level_names_are_the_verbs():
    assert ep.plan is api.plan and ep.reach is api.reach and ep.energy_map is api.energy_map
    # ep.mission may be the missions package (imported above): it calls the verb
    assert inspect.signature(ep.mission) == inspect.signature(api.mission)
    assert "return_to_start : bool" in inspect.getdoc(ep.mission)  # help(ep.mission) too


@pytest.mark.parametrize("command", sorted(VERBS))
def test_help_lists_every_keyword_and_hides_none(command):
    verb = VERBS[command][0]
    sig = inspect.signature(verb)
    assert all(p.kind is not inspect.Parameter.VAR_KEYWORD for p in sig.parameters.values())
    doc = inspect.getdoc(verb)
    assert not re.search(r"\{(dem|common|trust|planning)\}", doc)  # filled by api._doc
    # numpydoc: the entries of the Parameters section stand at the left margin
    section = doc.split("Parameters\n----------\n")[1].split("\n\nReturns")[0]
    entries = [ln.split(" : ")[0] for ln in section.splitlines() if ln and ln[0] != " "]
    documented = {name.strip() for e in entries for name in e.split(",")}
    assert set(sig.parameters) <= documented, set(sig.parameters) - documented
    assert all(ln.startswith("    ") for ln in section.splitlines() if ln and ln[0] == " ")
