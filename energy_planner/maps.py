"""Bundled maps (package data, linked from ``maps/`` in a checkout) and their scenarios.

>>> map_path("hill").name
'hill.tif'
>>> scenario("hill")["start"]
[500058.0, 5000046.0]
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from energy_planner.errors import DEMIOError

__all__ = ["MAPS_DIR", "map_names", "map_path", "resolve", "scenario", "scenario_names"]


def _maps_dir() -> Path:
    """The bundled maps: package data ``energy_planner/data/maps``, beside this module.

    The same in a source checkout (where ``maps/`` at the root links to these files), an
    editable install, a wheel in a venv or ``pip install --user``: the package is always
    installed as files (``importlib.resources.files`` would give this same folder, at the
    cost of importing ``tempfile``, ``zipfile``, ``shutil``, ``bz2`` and ``random`` in
    every command that resolves a map name).
    """
    return Path(__file__).parent / "data" / "maps"


#: The bundled maps folder (package data).
MAPS_DIR = _maps_dir()

_FILES = {
    "hill": "hill.tif",
    "plane": "plane.tif",
    "jacksboro": "jacksboro_fault_dem.tif",
}
#: Other bundled files :func:`map_path` finds by name (not DEMs: not in :func:`map_names`).
_OTHER = {"hill_sites": "hill_sites.csv", "scenarios": "scenarios.json"}


def map_names() -> list[str]:
    """Names accepted by :func:`map_path`.

    >>> map_names()
    ['hill', 'jacksboro', 'plane']
    """
    return sorted(_FILES)


def map_path(name: str) -> Path:
    """Path of a bundled map by name (``hill``, ``plane``, ``jacksboro``).

    A file name (``"hill.tif"``) is accepted too, and the other bundled files by name:
    ``hill_sites`` (the hill's mission sites, CSV).

    >>> map_path("hill_sites").name
    'hill_sites.csv'

    Raises
    ------
    DEMIOError
        Unknown name (the message lists the valid ones) or missing file.
    """
    key = Path(name).stem if Path(name).suffix in (".tif", ".csv", ".json") else name
    key = "jacksboro" if key == "jacksboro_fault_dem" else key
    files = {**_FILES, **_OTHER}
    if key not in files:
        raise DEMIOError(
            f"no bundled map named {name!r}; valid names: {', '.join(map_names())} "
            f"(and the files {', '.join(sorted(_OTHER))})"
        )
    path = MAPS_DIR / files[key]
    if not path.exists():
        raise DEMIOError(
            f"bundled map {name!r} is missing at {path}; regenerate it with the scripts "
            "in maps/ of the source (make_synthetic.py, make_jacksboro.py)"
        )
    return path


def resolve(path_or_name: str | Path) -> Path:
    """A file that exists, else a bundled file by name, else the path as given.

    What every door that takes a DEM or a sites file does with its argument, so that
    ``--dem hill`` and ``ep.Problem.from_dem("hill")`` work from any folder; a path that
    exists always wins over a name.

    >>> resolve("hill") == map_path("hill")
    True
    >>> str(resolve("no/such/file.tif"))
    'no/such/file.tif'
    """
    p = Path(path_or_name)
    if p.exists() or len(p.parts) != 1:
        return p
    try:
        return map_path(str(path_or_name))
    except DEMIOError:
        return p


def _scenarios() -> dict[str, Any]:
    path = MAPS_DIR / "scenarios.json"
    if not path.exists():
        raise DEMIOError(f"scenario file {path} is missing; run maps/make_synthetic.py")
    return json.loads(path.read_text())


def scenario_names() -> list[str]:
    """Names accepted by :func:`scenario`."""
    return sorted(_scenarios())


def scenario(name: str) -> dict[str, Any]:
    """A demo scenario by name.

    The dict holds the ``map`` name, ``crs``, ``start``/``goal`` (x, y in the map's CRS,
    metres) and a one-line ``description``; ``path`` is added (the map file).

    Raises
    ------
    KeyError
        Unknown name; the message lists the valid ones.
    """
    data = _scenarios()
    if name not in data:
        raise KeyError(f"no scenario named {name!r}; valid names: {', '.join(sorted(data))}")
    sc = dict(data[name])
    sc["path"] = map_path(sc["map"])
    return sc
