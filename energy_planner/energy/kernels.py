"""Numba kernels: the energy of one SE(2) motion over a terrain grid.

A motion from pose ``(x0, y0, th0)`` to ``(x1, y1, th1)`` (working CRS, metres; yaw in
radians CCW from +x) moves the position linearly in the map and the yaw along the
shortest arc. The robot walks on the ground, not on the map: it keeps a constant speed
along the surface (odometry's speed), so the motion lasts
``max(surface_length / speed, |dth| / yaw_rate)`` (or a given duration) and its body
frame is tilted with the ground. The body twist at each sub-step is the 3-D velocity
along the surface expressed in that tilted body frame, so a motion whose yaw differs from
its direction walks sideways. The energy is the midpoint-rule integral of the model power
over ``n`` sub-steps, short enough (a fraction of a cell) that a motion crossing a ridge
is charged for both sides.

Terrain is sampled by bilinear interpolation of the Horn gradient at cell centres; the
four corner cells must be valid (a NaN corner makes the sample invalid).

Violation codes returned by the kernels: 0 valid, 1 outside the map or on nodata,
2 slope above the limit, 3 cross-slope above the limit, 4 a blocked (keep-out) cell,
5 a channel raster has no value there, 6 walking backward on ground steeper than the
backward-walking limit, 7 a crab angle above its limit (the gait limits of
:class:`energy_planner.request.Limits`, checked at every sub-step of a translation from
the body-frame velocity; turns in place are never refused by them).

The per-motion result vector ``out`` of ``motion_full`` is read through the named
indices ``OUT_*`` below (plain module-level ints, which numba folds as constants), never
through bare numbers: ``out[OUT_ENERGY]``, ``table[:, OUT_CODE]``.

Extra channels (:class:`energy_planner.energy.channels.Channels`): rasters sit on the
terrain's grid in ``data`` and are sampled at every sub-step (numeric: bilinear, like the
gradient; categorical: the nearest cell's category index) and passed to ``power`` as its
eighth argument. Constants (``--set``) travel the same way, after the rasters (a
``(k, 1, 1)`` array when there is no raster): the kernels of :class:`MotionCost` depend on
the model, not on the values, so a new value needs no compilation. The heading kernels
(energy map, search heuristic, grade cost) take the same values as an input vector
``consts`` after the rasters.
"""

from __future__ import annotations

import hashlib
import re
from functools import lru_cache
from pathlib import Path

from energy_planner.request import GAIT_TOL_RAD

OK, OUTSIDE, TOO_STEEP, TOO_CROSS, BLOCKED, NO_CHANNEL = 0, 1, 2, 3, 4, 5
TOO_BACKWARD, TOO_CRAB = 6, 7
VIOLATIONS = {
    OUTSIDE: "outside the map or on nodata",
    TOO_STEEP: "slope above the limit",
    TOO_CROSS: "cross-slope above the limit",
    BLOCKED: "inside a keep-out area",
    NO_CHANNEL: "where a channel raster has no value (nodata)",
    TOO_BACKWARD: "walking backward on ground steeper than the backward-walking limit",
    TOO_CRAB: "with a crab angle (body x to the direction of travel) above the limit",
}
#: Slack of the gait checks, radians (see :class:`energy_planner.request.Limits`).
GAIT_TOL = GAIT_TOL_RAD

# Named indices of the kernels' input tuple ``data`` (:attr:`MotionCost.data`), read
# through these names on both sides (numba folds them as constants), never by number.
#: Horn gradient, (rows, cols, 2): dz/dx, dz/dy on the working grid
IN_GRAD = 0
#: keep-out mask, (rows, cols) bool (size 0: none)
IN_BLOCKED = 1
#: centre of cell (0, 0), x and y; cell size dx (> 0) and dy (< 0), m
IN_X0, IN_Y0, IN_DX, IN_DY = 2, 3, 4, 5
#: nominal speed m/s, yaw rate rad/s, integration sub-step m and rad
IN_SPEED, IN_YAW_RATE, IN_STEP, IN_ANG_STEP = 6, 7, 8, 9
#: tangent of the slope limit, sine of the cross-slope limit
IN_TMAX, IN_SMAX = 10, 11
#: channel values (k, rows, cols), and which channels are sampled at the nearest cell
IN_CHAN, IN_NEAREST = 12, 13
#: gait limits: tangent of the backward-walking slope limit, the crab limit in radians
IN_BTAN, IN_CMAX = 14, 15
#: the speed choice (:mod:`energy_planner.energy.speed`): ground speed range m/s (equal:
#: the nominal speed, fixed), the price of a second J/s (``lambda``), the Laurent
#: exponents of energy in speed, the speeds at which they are solved for (one more to check
#: the fit) and the inverse matrix of that solve
IN_VMIN, IN_VMAX, IN_TIME_WEIGHT, IN_EXPS, IN_NODES, IN_VINV = 16, 17, 18, 19, 20, 21
#: the gait choice (a model that names gaits, its gait channel not given): the index of
#: the gait channel among the sampled channels (-1: no choice, the arrays below empty),
#: per gait its category code, its speed range m/s (the range clipped to the speeds its
#: logs walked it at), the speeds its Laurent coefficients are solved at (one more to
#: check, ``(gaits, K + 1)``) and the inverse matrices of those solves
#: (``(gaits, K, K)``); the exponents are ``IN_EXPS`` (every gait's, together)
IN_GAIT_SLOT, IN_GAIT_CODES, IN_GAIT_LO, IN_GAIT_HI, IN_GAIT_NODES, IN_GAIT_VINV = (
    22,
    23,
    24,
    25,
    26,
    27,
)
#: length of ``data``
N_IN = 28

# Named indices of the per-motion result vector ``out`` of ``motion_full``.
#: energy, J
OUT_ENERGY = 0
#: duration, s
OUT_DURATION = 1
#: distance along the ground, m
OUT_DISTANCE = 2
#: |turn|, rad
OUT_TURN = 3
#: mean slope, rad
OUT_MEAN_SLOPE = 4
#: mean |relative heading gamma|, rad
OUT_MEAN_GAMMA = 5
#: steepest slope sampled, rad
OUT_MAX_SLOPE = 6
#: energy of the forward terms, J (the next four follow in :data:`KINDS` order)
OUT_E_FORWARD = 7
#: energy of the backward terms, J
OUT_E_BACKWARD = 8
#: energy of the lateral terms, J
OUT_E_LATERAL = 9
#: energy of the turning terms, J
OUT_E_TURNING = 10
#: energy of the other terms (idle power, effects), J
OUT_E_OTHER = 11
#: violation code (:data:`OK` or a key of :data:`VIOLATIONS`), stored as a float
OUT_CODE = 12
#: the gait walked: its index in the gait choice (``IN_GAIT_CODES``), -1 without one
OUT_GAIT = 13
#: Length of the per-motion result vector of ``motion_full``.
N_OUT = 14
#: Column names of ``out`` in index order (for tables and messages).
OUT_NAMES = (
    "energy_j", "duration_s", "distance_m", "turn_rad", "mean_slope_rad", "mean_gamma_rad",
    "max_slope_rad", "e_forward_j", "e_backward_j", "e_lateral_j", "e_turning_j", "e_other_j",
    "code", "gait",
)  # fmt: skip
#: Number of energy-by-kind entries (forward, backward, lateral, turning, other).
N_KINDS = 5


_TEMPLATE = Path(__file__).with_name("_motion.py")
#: The files whose functions the kernel modules call (their hash names the modules).
_HELPERS = (
    Path(__file__),
    Path(__file__).with_name("_sampling.py"),
    Path(__file__).with_name("_laurent.py"),
)
_POWER_BLOCK = re.compile(r"# --- power: replaced per model ---\n.*?# --- end power ---\n", re.S)


def make_kernels(power_source: str):
    """Build (or load from the kernel cache) the motion kernels of one model.

    Parameters
    ----------
    power_source : str
        Source of ``power(alpha, gamma, vx, vy, wz, ax, ay) -> (total, by_kind)`` from
        :meth:`energy_planner.model.EnergyModel.kernel_source` with ``channels`` given
        (eight arguments: the last one holds the sampled raster channels).

    Returns
    -------
    motion_full, motion_cost, motion_batch, path_table, map_costs : numba dispatchers
        ``motion_full(x0, y0, th0, x1, y1, th1, duration, data, out)`` fills ``out``
        (length :data:`N_OUT` plus one scratch entry per raster channel, indices
        ``OUT_*``): energy J, duration s, surface
        distance m, |turn| rad, mean slope rad, mean |gamma| rad, max slope rad, energy
        by kind (forward, backward, lateral, turning, other), violation code.
        ``motion_cost(x0, y0, th0, x1, y1, th1, data)`` returns the energy or ``inf`` if
        invalid; ``motion_batch`` maps it over arrays; ``path_table(x, y, th, durations,
        gaits, data)`` gives the ``out`` rows of consecutive poses (each motion in its
        gait of ``gaits``, an index of the gait choice, or -1). ``data`` is the tuple built
        by :class:`energy_planner.energy.MotionCost`. ``map_costs(gx, gy, chan,
        consts, headings, speed, tmax, smax, btan, cmax, table, d_alpha, along, best)`` fills
        the energy-map costs of a block of cells (see
        :class:`energy_planner.energy.heading.HeadingCost`).
    """
    mod = kernel_module(power_source)
    return mod.motion_full, mod.motion_cost, mod.motion_batch, mod.path_table, mod.map_costs


def motion_source(power_source: str) -> str:
    """The text of one model's kernel module: ``_motion.py`` with the model's ``power``.

    The hash of the helpers (this file and ``_sampling.py``) heads the text: numba's cache
    does not see changes to the functions a cached function calls, so a change to them
    gives a new module name (and a new compilation).
    """
    block = (
        "# --- power: replaced per model ---\n@numba.njit(cache=True)\n"
        + power_source
        + "\n\n# --- end power ---\n"
    )
    text, n = _POWER_BLOCK.subn(lambda _: block, _TEMPLATE.read_text())
    assert n == 1, "the power markers of _motion.py are missing"
    helpers = hashlib.sha256(b"".join(p.read_bytes() for p in _HELPERS)).hexdigest()[:16]
    return f"# kernels.py {helpers}\n" + text


@lru_cache(maxsize=64)
def kernel_module(power_source: str):
    """The compiled module of one model's kernels (see :func:`make_kernels`).

    Besides the functions :func:`make_kernels` returns, it holds the cheapest way to move
    along a heading over the body's yaw (``cheapest_at``, ``cheapest_batch``,
    ``heading_table``), which :mod:`energy_planner.energy.heading` wraps. Its functions
    compile on first use, or load from numba's cache on disk.
    """
    from energy_planner.model._codegen import load_generated_module

    return load_generated_module(motion_source(power_source), prefix="motion")


#: The functions of a precompiled kernel module (:func:`precompiled_module`).
PRECOMPILED = ("motion_cost", "motion_batch", "path_table")


def precompiled_module(power_source: str, build: bool = True):
    """One model's motion kernels compiled ahead of time, or None where they cannot be.

    A command that prices given motions (``energy``) spends more on loading numba (its
    import, its typing registries, the cached kernels' index) than on its work. A
    precompiled module (numba's ahead-of-time compiler, a C extension in the kernel cache
    directory) holds :data:`PRECOMPILED` of the model's kernels, the same code as
    :func:`kernel_module`'s, and imports in milliseconds without numba. It is built once
    per machine and model (about 10 s of compilation, said on stderr) and then loaded.

    Parameters
    ----------
    power_source : str
        The model's ``power`` source, as for :func:`make_kernels`.
    build : bool
        Build the module when it is not in the cache yet (else return None then).

    Returns
    -------
    module or None
        None when it is not built and ``build`` is False, when building is switched off
        (``ENERGY_PLANNER_PRECOMPILE=0``) or when it failed on this machine (no C
        compiler, say; the reason is kept beside it as ``<name>.failed`` and the numba
        kernels serve instead).
    """
    import os

    from energy_planner.model._codegen import load_precompiled

    build = build and os.environ.get("ENERGY_PLANNER_PRECOMPILE", "1") != "0"
    return load_precompiled(motion_source(power_source), prefix="aot", build=build)


#: The functions of a precompiled energy-map module (:func:`precompiled_map_module`).
PRECOMPILED_MAP = ("map_costs", "summary", "heading_table")
_SUMMARY = Path(__file__).parents[1] / "energymap" / "_summary.py"


def map_source(power_source: str) -> str:
    """The text of one model's energy-map module: its kernel module and the summary bands.

    :func:`motion_source` followed by ``energymap/_summary.py`` (read as text, so that
    this stays numba-free): the functions :data:`PRECOMPILED_MAP` compile from it, and
    its hash names the extension.
    """
    summary = _SUMMARY.read_text().replace("from __future__ import annotations\n", "")
    return (
        f"# precompiled: {', '.join(PRECOMPILED_MAP)}\n"
        + motion_source(power_source)
        + "\n\n# --- the energy map's summary bands (energymap/_summary.py) ---\n"
        + summary.replace("_summary(", "summary(")
    )


def precompiled_map_module(power_source: str, build: bool = True):
    """One model's energy-map kernels compiled ahead of time, or None where they cannot be.

    As :func:`precompiled_module` (built once per machine and model, said on stderr;
    ``ENERGY_PLANNER_PRECOMPILE=0`` switches building off), for :data:`PRECOMPILED_MAP`:
    ``map_costs`` (the kernel of :meth:`~energy_planner.energy.heading.HeadingCost.
    map_bands`), ``summary`` (:func:`energy_planner.energymap._summary.summary_bands`)
    and ``heading_table`` (the table of a new speed or limit, when it is not on disk).
    They release the GIL, so that threads share a block's rows: a map then loads no numba
    (its import and its cache's typing take about 1.4 s, more than a 2048^2 map's kernel).
    """
    import os

    from energy_planner.model._codegen import load_precompiled

    build = build and os.environ.get("ENERGY_PLANNER_PRECOMPILE", "1") != "0"
    return load_precompiled(map_source(power_source), prefix="aotmap", build=build, kind="map")


def __getattr__(name: str):
    # the numba helpers, imported on first use (importing this module stays numba-free)
    if name in ("sample_gradient", "sample_channels", "wrap_angle"):
        from energy_planner.energy import _sampling

        return getattr(_sampling, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
