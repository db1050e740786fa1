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
import math
import re
from functools import lru_cache
from pathlib import Path

import numba

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
#: length of ``data``
N_IN = 16

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
#: Length of the per-motion result vector of ``motion_full``.
N_OUT = 13
#: Column names of ``out`` in index order (for tables and messages).
OUT_NAMES = (
    "energy_j", "duration_s", "distance_m", "turn_rad", "mean_slope_rad", "mean_gamma_rad",
    "max_slope_rad", "e_forward_j", "e_backward_j", "e_lateral_j", "e_turning_j", "e_other_j",
    "code",
)  # fmt: skip
#: Number of energy-by-kind entries (forward, backward, lateral, turning, other).
N_KINDS = 5


@numba.njit(cache=True)
def sample_gradient(grad, x0, y0, dx, dy, x, y):
    """Bilinear gradient at (x, y); returns (ok, dz/dx, dz/dy).

    ``grad[r, c]`` holds (dz/dx, dz/dy) of cell (r, c), interleaved so that one lookup
    touches one cache line per corner.
    """
    nrows, ncols = grad.shape[0], grad.shape[1]
    fc = (x - x0) / dx
    fr = (y - y0) / dy
    if not (fc >= 0.0 and fr >= 0.0 and fc <= ncols - 1 and fr <= nrows - 1):
        return False, 0.0, 0.0
    c = min(int(fc), ncols - 2) if ncols > 1 else 0
    r = min(int(fr), nrows - 2) if nrows > 1 else 0
    tc = fc - c
    tr = fr - r
    c1 = min(c + 1, ncols - 1)
    r1 = min(r + 1, nrows - 1)
    a00, b00 = grad[r, c, 0], grad[r, c, 1]
    a01, b01 = grad[r, c1, 0], grad[r, c1, 1]
    a10, b10 = grad[r1, c, 0], grad[r1, c, 1]
    a11, b11 = grad[r1, c1, 0], grad[r1, c1, 1]
    if not math.isfinite(a00 + a01 + a10 + a11 + b00 + b01 + b10 + b11):
        return False, 0.0, 0.0
    w00 = (1 - tr) * (1 - tc)
    w01 = (1 - tr) * tc
    w10 = tr * (1 - tc)
    w11 = tr * tc
    return (
        True,
        w00 * a00 + w01 * a01 + w10 * a10 + w11 * a11,
        w00 * b00 + w01 * b01 + w10 * b10 + w11 * b11,
    )


@numba.njit(cache=True)
def sample_channels(chan, nearest, x0, y0, dx, dy, x, y, values):
    """Fill ``values[k]`` with channel ``k`` at (x, y); False if one has no value there.

    ``chan[k, r, c]`` is channel ``k`` on the terrain grid (NaN = no value). A channel
    with ``nearest[k]`` (categorical: a category index) takes the nearest cell's value;
    the others are bilinear between cell centres, as :func:`sample_gradient`. A
    ``(k, 1, 1)`` array holds uniform channels (the ``--set`` constants, given at run
    time so that a new value needs no compilation): their values everywhere.
    """
    nch = chan.shape[0]
    if nch == 0:
        return True
    nrows, ncols = chan.shape[1], chan.shape[2]
    if nrows == 1 and ncols == 1:  # uniform channels (constants given at run time)
        for k in range(nch):
            values[k] = chan[k, 0, 0]
        return True
    fc = (x - x0) / dx
    fr = (y - y0) / dy
    if not (fc >= -0.5 and fr >= -0.5 and fc <= ncols - 0.5 and fr <= nrows - 0.5):
        return False
    rn = min(max(int(math.floor(fr + 0.5)), 0), nrows - 1)
    cn = min(max(int(math.floor(fc + 0.5)), 0), ncols - 1)
    fcb = min(max(fc, 0.0), ncols - 1.0)
    frb = min(max(fr, 0.0), nrows - 1.0)
    c = min(int(fcb), ncols - 2) if ncols > 1 else 0
    r = min(int(frb), nrows - 2) if nrows > 1 else 0
    tc = fcb - c
    tr = frb - r
    c1 = min(c + 1, ncols - 1)
    r1 = min(r + 1, nrows - 1)
    for k in range(nch):
        if nearest[k]:
            v = chan[k, rn, cn]
        else:
            v = (
                (1 - tr) * (1 - tc) * chan[k, r, c]
                + (1 - tr) * tc * chan[k, r, c1]
                + tr * (1 - tc) * chan[k, r1, c]
                + tr * tc * chan[k, r1, c1]
            )
        if not math.isfinite(v):
            return False
        values[k] = v
    return True


@numba.njit(cache=True)
def wrap_angle(a):
    """Wrap to (-pi, pi]."""
    two_pi = 2.0 * math.pi
    a = (a + math.pi) - two_pi * math.floor((a + math.pi) / two_pi)  # in [0, 2 pi)
    if a <= 0.0:
        a += two_pi
    return a - math.pi


_TEMPLATE = Path(__file__).with_name("_motion.py")
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
        data)`` gives the ``out`` rows of consecutive poses. ``data`` is the tuple built
        by :class:`energy_planner.energy.MotionCost`. ``map_costs(gx, gy, chan,
        consts, headings, speed, tmax, smax, btan, cmax, table, d_alpha, along, best)`` fills
        the energy-map costs of a block of cells (see
        :class:`energy_planner.energy.heading.HeadingCost`).
    """
    mod = kernel_module(power_source)
    return mod.motion_full, mod.motion_cost, mod.motion_batch, mod.path_table, mod.map_costs


@lru_cache(maxsize=64)
def kernel_module(power_source: str):
    """The compiled module of one model's kernels (see :func:`make_kernels`).

    Besides the functions :func:`make_kernels` returns, it holds the cheapest way to move
    along a heading over the body's yaw (``cheapest_at``, ``cheapest_batch``,
    ``heading_table``), which :mod:`energy_planner.energy.heading` wraps.
    """
    from energy_planner.model._codegen import load_generated_module

    block = (
        "# --- power: replaced per model ---\n@numba.njit(cache=True)\n"
        + power_source
        + "\n\n# --- end power ---\n"
    )
    text, n = _POWER_BLOCK.subn(lambda _: block, _TEMPLATE.read_text())
    assert n == 1, "the power markers of _motion.py are missing"
    # numba's cache does not see changes to the helpers this file defines: put their
    # hash into the generated text so that a change gives a new module name
    helpers = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]
    text = f"# kernels.py {helpers}\n" + text
    return load_generated_module(text, prefix="motion")
