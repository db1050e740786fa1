"""The project's one angle-wrapping convention.

Relative headings follow the design notes: ``gamma = wrap(theta - psi)`` lies in
``(-pi, pi]``, 0 facing uphill, ``pi`` facing downhill. Every module wraps angles with
these functions (the numba kernels use :func:`energy_planner.energy.kernels.wrap_angle`,
which implements the same convention for scalars inside compiled code).

Examples
--------
>>> float(wrap(-np.pi)), float(wrap(3 * np.pi / 2))
(3.141592653589793, -1.5707963267948966)
>>> wrap_deg(-180.0), wrap_deg(540.0), wrap_deg(-190.0)
(180.0, 180.0, 170.0)
>>> round(angle_diff(0.1, 2 * np.pi - 0.1), 12)
0.2
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap", "wrap_deg", "angle_diff"]


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles in radians to ``(-pi, pi]``.

    Parameters
    ----------
    a : float or array_like
        Angles in radians.

    Returns
    -------
    float or ndarray
        A float for a scalar input, an array otherwise.
    """
    arr = np.asarray(a, dtype=float)
    w = np.mod(arr + np.pi, 2.0 * np.pi) - np.pi
    w = np.where(w <= -np.pi, w + 2.0 * np.pi, w)
    return float(w) if arr.ndim == 0 else w


def wrap_deg(a: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles in degrees to ``(-180, 180]``."""
    arr = np.asarray(a, dtype=float)
    w = np.mod(arr + 180.0, 360.0) - 180.0
    w = np.where(w <= -180.0, w + 360.0, w)
    return float(w) if arr.ndim == 0 else w


def angle_diff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray | float:
    """The signed difference ``a - b`` wrapped to ``(-pi, pi]`` (radians)."""
    if np.ndim(a) == 0 and np.ndim(b) == 0:
        return wrap(math.fsum((float(a), -float(b))))
    return wrap(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))
