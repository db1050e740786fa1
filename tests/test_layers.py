"""The package's layers import one way (#18 point 4; docs/architecture.md).

Every ``energy_planner.X`` import, at module level or inside a function (a call-time
import is still a dependency), is an edge between top-level units (subpackages and
modules); imports under ``if TYPE_CHECKING:`` (names for annotations, never run) are not.
The graph must have no cycle.
"""

from __future__ import annotations

import ast
import collections
import graphlib
from pathlib import Path

import energy_planner

ROOT = Path(energy_planner.__file__).parent


def _imports(node: ast.AST):
    """The import statements under ``node``, but those under ``if TYPE_CHECKING:``.

    Only statement lists are walked: an import is a statement, and the expressions (most
    of a module's nodes) hold none.
    """
    for field, value in ast.iter_fields(node):
        if not isinstance(value, list):
            continue
        if (
            field == "body"
            and isinstance(node, ast.If)
            and "TYPE_CHECKING" in ast.unparse(node.test)
        ):
            continue  # names for annotations, never run (its else: branch is walked)
        for child in value:
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child
            elif isinstance(child, (ast.stmt, ast.excepthandler, ast.match_case)):
                yield from _imports(child)


def _edges() -> dict[str, set[str]]:
    edges: dict[str, set[str]] = collections.defaultdict(set)
    for f in ROOT.rglob("*.py"):
        unit = f.relative_to(ROOT).parts[0].removesuffix(".py")
        if unit == "__init__":
            continue
        for node in _imports(ast.parse(f.read_text())):
            names = []
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                "energy_planner."
            ):
                names = [node.module]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names if a.name.startswith("energy_planner.")]
            for name in names:
                other = name.split(".")[1]
                if other != unit:
                    edges[unit].add(other)
    return edges


def test_the_units_import_one_way():
    edges = _edges()
    try:
        order = list(graphlib.TopologicalSorter(edges).static_order())
    except graphlib.CycleError as exc:  # the cycle, named
        raise AssertionError(f"import cycle between units: {' -> '.join(exc.args[1])}") from exc
    pos = {u: i for i, u in enumerate(order)}
    # the layers docs/architecture.md draws: each below the next
    for low, high in [("terrain", "energy"), ("model", "energy"), ("energy", "problem"),
                      ("problem", "planning"), ("measurements", "calibration"),
                      ("calibration", "diagnosis"), ("planning", "mission"),
                      ("uncertainty", "follow"), ("api", "cli")]:  # fmt: skip
        assert pos[low] < pos[high], (low, high)
