"""Energy of each model term along a path, so that any coefficients price it at once.

Power is linear in the coefficients, ``P = sum_k c_k x_k``, so a path's energy is
``sum_k c_k E_k`` with ``E_k`` the integral of term ``k`` along the path (as long as the
power stays above the model's zero floor). :func:`path_term_energies` computes every
``E_k`` per motion with the project's own motion integrator
(:class:`energy_planner.energy.MotionCost`, the kernel of ``path_energy``): the terms are
put, five at a time, in the five "kind" slots the kernel integrates separately, each with
a coefficient of 1 and no floor. A follower then re-prices the rest of a path with new
coefficients by a dot product, with no new kernel.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.energy.channels import Channels
from energy_planner.energy.kernels import OK, OUT_CODE, OUT_DISTANCE, OUT_DURATION, OUT_E_FORWARD
from energy_planner.energy.path import path_poses
from energy_planner.errors import OutsideMapError
from energy_planner.model.terms import KINDS
from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE

__all__ = ["PathTerms", "motion_term_energies", "path_term_energies"]


@dataclass
class PathTerms:
    """Per-motion term energies of a path (see :func:`path_term_energies`).

    Attributes
    ----------
    poses : ndarray, shape (n, 3)
        The executed poses ``(x, y, yaw)`` (working CRS), turns in place included.
    energy : ndarray, shape (n - 1, k)
        Integral of each term over each motion, in the term's unit times seconds.
    distance_m, duration_s : ndarray, shape (n - 1,)
        Ground distance and duration of each motion.
    term_names : list of str
    """

    poses: np.ndarray
    energy: np.ndarray
    distance_m: np.ndarray
    duration_s: np.ndarray
    term_names: list[str]

    def __post_init__(self) -> None:
        # suffix sums: tail[i] = sum of motions i.. (tail[n-1] = 0)
        self.tail = np.vstack(
            [np.cumsum(self.energy[::-1], axis=0)[::-1], np.zeros((1, self.energy.shape[1]))]
        )
        self.tail_s = np.r_[np.cumsum(self.duration_s[::-1])[::-1], 0.0]
        d = np.hypot(*np.diff(self.poses[:, :2], axis=0).T)
        self.map_length = d
        self.s_vertex = np.concatenate([[0.0], np.cumsum(d)])

    def remaining(self, motion: int, frac: float) -> np.ndarray:
        """Term energies of the rest of the path from ``frac`` of motion ``motion`` on."""
        if motion >= self.energy.shape[0]:
            return np.zeros(self.energy.shape[1])
        return self.tail[motion + 1] + (1.0 - frac) * self.energy[motion]

    def remaining_s(self, motion: int, frac: float) -> float:
        """Duration of the rest of the path from ``frac`` of motion ``motion`` on, s."""
        if motion >= self.duration_s.size:
            return 0.0
        return float(self.tail_s[motion + 1] + (1.0 - frac) * self.duration_s[motion])

    def locate(self, x: float, y: float, start: int = 0, ahead: int = 200) -> tuple[int, float]:
        """The motion and fraction of it closest to ``(x, y)``, searched from ``start``."""
        lo = max(0, start - 2)
        hi = min(self.energy.shape[0], start + ahead)
        p0 = self.poses[lo:hi, :2]
        d = self.poses[lo + 1 : hi + 1, :2] - p0
        L2 = np.einsum("ij,ij->i", d, d)
        q = np.array([x, y]) - p0
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(L2 > 0, np.clip(np.einsum("ij,ij->i", q, d) / L2, 0.0, 1.0), 1.0)
        r = q - u[:, None] * d
        j = int(np.argmin(np.einsum("ij,ij->i", r, r)))
        return lo + j, float(u[j])


def _slot_models(model: Any) -> list[tuple[Any, list[int]]]:
    """Unfloored unit-coefficient models of up to five terms, one term per kind slot."""
    from energy_planner.model import EnergyModel

    terms = list(model.terms)
    out = []
    for g in range(0, len(terms), len(KINDS)):
        chunk = terms[g : g + len(KINDS)]
        slotted = [dataclasses.replace(t, kind=k) for t, k in zip(chunk, KINDS, strict=False)]
        m = EnergyModel(slotted, {t.name: 1.0 for t in slotted}, regenerative=True)
        out.append((m, list(range(g, g + len(chunk)))))
    return out


def motion_term_energies(
    terrain: Any,
    model: Any,
    poses: np.ndarray,
    durations: np.ndarray,
    speed: float = DEFAULT_SPEED,
    yaw_rate: float = DEFAULT_YAW_RATE,
    channels: Channels | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Term energies, ground distance and duration of each motion between ``poses``.

    ``poses`` and ``durations`` as :func:`energy_planner.energy.path.path_poses` gives
    them. Returns ``(energy (m - 1, k), distance_m, duration_s)``.

    Raises
    ------
    OutsideMapError
        A motion leaves the valid map.
    """
    from energy_planner.energy import MotionCost

    energy = np.zeros((len(poses) - 1, len(model.terms)))
    out = None
    for m, cols in _slot_models(model):
        cost = MotionCost(terrain, m, speed, yaw_rate, channels=channels)
        out = cost.details(poses[:, 0], poses[:, 1], poses[:, 2], durations)
        bad = np.flatnonzero(out[:, OUT_CODE] != OK)
        if bad.size:
            i = int(bad[0])
            raise OutsideMapError(
                f"motion {i} of the path, from ({poses[i, 0]:.2f}, {poses[i, 1]:.2f}), "
                "leaves the valid map"
            )
        energy[:, cols] = out[:, OUT_E_FORWARD : OUT_E_FORWARD + len(cols)]
    assert out is not None
    return energy, out[:, OUT_DISTANCE].copy(), out[:, OUT_DURATION].copy()


def path_term_energies(
    terrain: Any,
    model: Any,
    xy: Any,
    yaw: Any = None,
    t: Any = None,
    speed: float = DEFAULT_SPEED,
    yaw_rate: float = DEFAULT_YAW_RATE,
    *,
    channels: Channels | None = None,
) -> PathTerms:
    """The integral of every term of ``model`` along each motion of a path.

    The path is walked as :func:`energy_planner.energy.path_energy` walks it (its
    :func:`~energy_planner.energy.path.path_poses`: working CRS, optional yaw and
    times); ``PathTerms.energy @ model.coef_array()`` is that function's per-motion
    energy wherever the model's power is above zero. ``channels``: the values of the
    channels the model reads (``--set`` / ``--channel``).

    Raises
    ------
    OutsideMapError
        A motion leaves the valid map.
    EnergyPlannerError
        Malformed waypoints, yaw or times.
    """
    poses, _, durations = path_poses(xy, yaw, t, yaw_rate)
    energy, distance, duration = motion_term_energies(
        terrain, model, poses, durations, speed, yaw_rate, channels
    )
    return PathTerms(poses, energy, distance, duration, list(model.term_names))


#: Prefix of the channels that carry a runtime-coefficient model's coefficients.
COEF_CHANNEL = "follow_coef_"


def runtime_coefficient_model(model: Any) -> Any:
    """``model`` with its coefficients moved out of the compiled kernel.

    Term ``k`` becomes ``follow_coef_k * (formula_k)`` with a coefficient of 1 (same name,
    kind and explanation); the coefficients travel as the constant channels
    ``follow_coef_k`` (:func:`coefficient_channels`), which the motion kernel takes as
    run-time inputs. The kernel's source is then the same for any coefficients: a
    follower that replans with updated coefficients compiles it once, not per update.
    """
    from energy_planner.model import EnergyModel

    terms = [
        dataclasses.replace(t, formula=f"{COEF_CHANNEL}{k} * ({t.formula})")
        for k, t in enumerate(model.terms)
    ]
    return EnergyModel(
        terms,
        {t.name: 1.0 for t in terms},
        regenerative=model.regenerative,
        metadata=model.metadata,
    )


def coefficient_channels(coef: np.ndarray, channels: Channels | None = None) -> Channels:
    """The channels of :func:`runtime_coefficient_model` for coefficients ``coef``.

    ``channels``: the channels the model itself reads, kept.
    """
    base = channels if channels is not None else Channels()
    consts = {f"{COEF_CHANNEL}{k}": float(c) for k, c in enumerate(coef)}
    return dataclasses.replace(base, constants={**dict(base.constants), **consts})
