"""The motion primitives every planner shares: lattice positions, headings and moves.

The full-resolution search (:mod:`energy_planner.planning.search`), the lattice planner
(:mod:`energy_planner.planning.lattice`), reach's lattice graph
(:mod:`energy_planner.planning.reach`) and the corridor's cost bound
(:mod:`energy_planner.planning.corridor`) all walk the same primitives:

* positions on a square grid of spacing ``step`` aligned so that the start lies on a
  node (:func:`lattice_geometry`);
* ``n_headings`` headings per position (:func:`lattice_headings`; with 16 they are the
  directions of the 16 moves);
* translations at constant heading to the neighbours :data:`MOVES_16`, of which a move
  set (:data:`MOVE_SETS`) allows some at each heading (:func:`move_table`), and turns in
  place to the next heading on either side.
"""

from __future__ import annotations

import math

import numpy as np

from energy_planner.angles import wrap
from energy_planner.errors import PlanningConfigError

__all__ = [
    "MOVES_16",
    "MOVE_SETS",
    "check_headings",
    "check_moves",
    "exact_ends",
    "lattice_geometry",
    "lattice_headings",
    "move_table",
    "terrain_extent",
]

#: The 16 neighbour displacements (in lattice steps), counter-clockwise from +x.
MOVES_16: np.ndarray = np.array(
    [
        (1, 0), (2, 1), (1, 1), (1, 2), (0, 1), (-1, 2), (-1, 1), (-2, 1),
        (-1, 0), (-2, -1), (-1, -1), (-1, -2), (0, -1), (1, -2), (1, -1), (2, -1),
    ],
    dtype=np.int64,
)  # fmt: skip

#: The move sets: the 4 moves closest to the body axes (forward, left, backward, right),
#: also the 4 obliques at 45 degrees to them, or all 16 at every heading (crab walking).
MOVE_SETS = ("axes", "crab", "all")


def check_moves(moves: str) -> None:
    """:class:`PlanningConfigError` unless ``moves`` is one of :data:`MOVE_SETS`."""
    if moves not in MOVE_SETS:
        raise PlanningConfigError(
            f"moves {moves!r} is not one of {', '.join(map(repr, MOVE_SETS))}",
            value=moves,
            param="moves",
        )


def check_headings(n_headings: int) -> None:
    """:class:`PlanningConfigError` for fewer than 4 headings (the body axes need 4)."""
    if int(n_headings) < 4:
        raise PlanningConfigError(
            f"n_headings={n_headings} is too small; use at least 4 (e.g. 16)",
            value=n_headings,
            param="n_headings",
        )


def terrain_extent(terrain) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the terrain's cell centres in the working CRS."""
    x0, y0, dx, dy = terrain.grid
    rows, cols = np.shape(terrain.elevation)
    xs = (x0, x0 + (cols - 1) * dx)
    ys = (y0, y0 + (rows - 1) * dy)
    return min(xs), max(xs), min(ys), max(ys)


def lattice_geometry(terrain, start_xy: tuple[float, float], step: float):
    """Lattice positions covering the terrain, aligned so that ``start_xy`` is a node.

    Returns
    -------
    xs, ys : ndarray
        The lattice's x (columns) and y (rows) coordinates, increasing.
    """
    xmin, xmax, ymin, ymax = terrain_extent(terrain)
    sx, sy = start_xy
    i0 = math.floor((sx - xmin) / step + 1e-9)
    j0 = math.floor((sy - ymin) / step + 1e-9)
    i1 = math.floor((xmax - sx) / step + 1e-9)
    j1 = math.floor((ymax - sy) / step + 1e-9)
    xs = sx + step * np.arange(-i0, i1 + 1)
    ys = sy + step * np.arange(-j0, j1 + 1)
    return xs, ys


def lattice_headings(n_headings: int) -> np.ndarray:
    """The lattice's headings, radians in [0, 2 pi).

    With 16 headings they are the directions of :data:`MOVES_16` (0, 26.6, 45, 63.4,
    90 deg, ...), so that every heading has a move straight ahead, behind and to
    either side; otherwise they are evenly spaced.

    Examples
    --------
    >>> np.round(np.degrees(lattice_headings(16)[:5]), 1).tolist()
    [0.0, 26.6, 45.0, 63.4, 90.0]
    >>> np.degrees(lattice_headings(8)).tolist()
    [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]
    """
    if n_headings == len(MOVES_16):
        return np.arctan2(MOVES_16[:, 1], MOVES_16[:, 0]) % (2 * np.pi)
    return 2 * np.pi * np.arange(n_headings) / n_headings


def move_table(headings: np.ndarray, moves: str) -> np.ndarray:
    """Boolean (heading, move) table of the translations allowed at each heading.

    Examples
    --------
    >>> t = move_table(lattice_headings(16), "axes")
    >>> t.sum(axis=1).tolist() == [4] * 16
    True
    >>> [tuple(MOVES_16[m].tolist()) for m in np.nonzero(t[1])[0]]
    [(2, 1), (-1, 2), (-2, -1), (1, -2)]
    >>> move_table(lattice_headings(16), "crab").sum(axis=1).tolist() == [8] * 16
    True
    """
    n_headings = len(headings)
    if moves == "all":
        return np.ones((n_headings, len(MOVES_16)), dtype=bool)
    ang = np.arctan2(MOVES_16[:, 1], MOVES_16[:, 0])
    table = np.zeros((n_headings, len(MOVES_16)), dtype=bool)
    n_dirs = 8 if moves == "crab" else 4
    for h in range(n_headings):
        for k in range(n_dirs):
            axis = headings[h] + k * 2 * np.pi / n_dirs
            table[h, int(np.argmin(np.abs(wrap(ang - axis))))] = True
    return table


def exact_ends(states: np.ndarray, start, goal) -> np.ndarray:
    """Put the exact start and goal poses around a lattice path's poses.

    ``start``, ``goal``: ``(x, y, yaw)`` with yaw None when free; a pose is added only
    where the lattice path does not already begin (end) there.
    """
    first = states[0]
    syaw = float(wrap(start[2])) if start[2] is not None else first[2]
    if (
        abs(start[0] - first[0]) > 1e-9
        or abs(start[1] - first[1]) > 1e-9
        or abs(float(wrap(syaw - first[2]))) > 1e-12
    ):
        states = np.vstack([[start[0], start[1], syaw], states])
    last = states[-1]
    gyaw = float(wrap(goal[2])) if goal[2] is not None else last[2]
    if (
        abs(goal[0] - last[0]) > 1e-9
        or abs(goal[1] - last[1]) > 1e-9
        or abs(float(wrap(gyaw - last[2]))) > 1e-12
    ):
        states = np.vstack([states, [goal[0], goal[1], gyaw]])
    return states
