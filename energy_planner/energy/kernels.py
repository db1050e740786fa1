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
2 slope above the limit, 3 cross-slope above the limit, 4 a blocked (keep-out) cell.
"""

from __future__ import annotations

import hashlib
import math
import re
from functools import lru_cache
from pathlib import Path

import numba

OK, OUTSIDE, TOO_STEEP, TOO_CROSS, BLOCKED = 0, 1, 2, 3, 4
VIOLATIONS = {
    OUTSIDE: "outside the map or on nodata",
    TOO_STEEP: "slope above the limit",
    TOO_CROSS: "cross-slope above the limit",
    BLOCKED: "inside a keep-out area",
}
#: Length of the per-motion result vector of ``motion_full``.
N_OUT = 13


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
def wrap_angle(a):
    """Wrap to (-pi, pi]."""
    two_pi = 2.0 * math.pi
    a = (a + math.pi) - two_pi * math.floor((a + math.pi) / two_pi)  # in [0, 2 pi)
    if a <= 0.0:
        a += two_pi
    return a - math.pi


_TEMPLATE = Path(__file__).with_name("_motion.py")
_POWER_BLOCK = re.compile(r"# --- power: replaced per model ---\n.*?# --- end power ---\n", re.S)


@lru_cache(maxsize=64)
def make_kernels(power_source: str):
    """Build (or load from the kernel cache) the motion kernels of one model.

    Parameters
    ----------
    power_source : str
        Source of ``power(alpha, gamma, vx, vy, wz, ax, ay) -> (total, by_kind)`` from
        :meth:`energy_planner.model.EnergyModel.kernel_source`.

    Returns
    -------
    motion_full, motion_cost, motion_batch, path_table : numba dispatchers
        ``motion_full(x0, y0, th0, x1, y1, th1, duration, data, out)`` fills ``out``
        (length :data:`N_OUT`): energy J, duration s, surface distance m, |turn| rad,
        mean slope rad, mean |gamma| rad, max slope rad, energy by kind (forward,
        backward, lateral, turning, other), violation code.
        ``motion_cost(x0, y0, th0, x1, y1, th1, data)`` returns the energy or ``inf`` if
        invalid; ``motion_batch`` maps it over arrays; ``path_table(x, y, th, durations,
        data)`` gives the ``out`` rows of consecutive poses. ``data`` is the tuple built
        by :class:`energy_planner.energy.MotionCost`.
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
    mod = load_generated_module(text, prefix="motion")
    return mod.motion_full, mod.motion_cost, mod.motion_batch, mod.path_table
