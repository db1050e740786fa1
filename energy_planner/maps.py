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

__all__ = ["MAPS_DIR", "map_names", "map_path", "scenario", "scenario_names"]


def _maps_dir() -> Path:
    """The bundled maps: package data ``energy_planner/data/maps`` (importlib.resources).

    The same in a source checkout (where ``maps/`` at the root links to these files), an
    editable install, a wheel in a venv or ``pip install --user``.
    """
    from importlib.resources import files

    return Path(str(files("energy_planner") / "data" / "maps"))


#: The bundled maps folder (package data).
MAPS_DIR = _maps_dir()

_FILES = {
    "hill": "hill.tif",
    "plane": "plane.tif",
    "jacksboro": "jacksboro_fault_dem.tif",
}


def map_names() -> list[str]:
    """Names accepted by :func:`map_path`.

    >>> map_names()
    ['hill', 'jacksboro', 'plane']
    """
    return sorted(_FILES)


def map_path(name: str) -> Path:
    """Path of a bundled map by name (``hill``, ``plane``, ``jacksboro``).

    A file name (``"hill.tif"``) is accepted too.

    Raises
    ------
    DEMIOError
        Unknown name (the message lists the valid ones) or missing file.
    """
    key = name[:-4] if name.endswith(".tif") else name
    key = "jacksboro" if key == "jacksboro_fault_dem" else key
    if key not in _FILES:
        raise DEMIOError(f"no bundled map named {name!r}; valid names: {', '.join(map_names())}")
    path = MAPS_DIR / _FILES[key]
    if not path.exists():
        raise DEMIOError(
            f"bundled map {name!r} is missing at {path}; regenerate it with the scripts "
            "in maps/ of the source (make_synthetic.py, make_jacksboro.py)"
        )
    return path


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
