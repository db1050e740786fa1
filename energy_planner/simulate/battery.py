"""The battery of a simulated robot: the current that delivers a power, and the discharge.

``V = OCV(soc) - R I`` (:class:`~energy_planner.simulate.BatteryConfig`); the current that
delivers an electrical power ``P`` solves ``P = V I``. Runs are laid out one after another
on one pack until a run would end below ``soc_swap``: then a fresh pack is put in.

Examples
--------
>>> from energy_planner.simulate import BatteryConfig
>>> d = discharge(np.full(11, 100.0), BatteryConfig(), 0.1, [slice(0, 5), slice(5, 11)])
>>> d.energy.round(6).tolist(), d.pack.tolist()
([40.0, 50.0], [0, 0])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.errors import LogError

__all__ = ["battery_current", "discharge", "Discharge"]


def battery_current(power: np.ndarray, ocv: np.ndarray | float, r_ohm: float) -> np.ndarray:
    """Current (A, positive discharging) that delivers ``power`` (W) from the pack.

    Solves ``P = (OCV - R I) I`` for the smaller root, written stably as
    ``I = 2 P / (OCV + sqrt(OCV^2 - 4 R P))`` (also right for ``R = 0``).

    Raises
    ------
    LogError
        If the power exceeds what the pack can deliver, ``OCV^2 / (4 R)``.

    Examples
    --------
    >>> i = battery_current(np.array([200.0]), 50.0, 0.1)
    >>> v = 50.0 - 0.1 * i
    >>> np.round(i, 4).tolist(), np.round(v * i, 9).tolist()
    ([4.0325], [200.0])
    """
    disc = np.asarray(ocv, float) ** 2 - 4.0 * r_ohm * np.asarray(power, float)
    if np.any(disc < 0):
        raise LogError(
            f"power {float(np.max(power)):.0f} W exceeds what the battery can deliver "
            f"(OCV^2 / 4R with R = {r_ohm} ohm); expected a smaller internal resistance",
            value=float(np.max(power)),
            expected="a power below OCV^2 / (4 R)",
        )
    return 2.0 * power / (ocv + np.sqrt(disc))


def cumtrapz(y: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoid integral of ``y`` sampled every ``dt``, starting at 0."""
    out = np.zeros_like(y)
    out[1:] = np.cumsum((y[1:] + y[:-1]) * (dt / 2))
    return out


@dataclass(frozen=True)
class Discharge:
    """The battery's true state per sample and per run (runs in log order).

    Attributes
    ----------
    current, voltage, soc : ndarray
        Per sample: current (A), terminal voltage (V), state of charge (1).
    pack : ndarray of int
        Per run: the pack it ran on (0 the first, one more at each swap).
    soc_start, soc_end, energy : ndarray
        Per run: state of charge at its start and end, electrical energy drawn (J).
    """

    current: np.ndarray
    voltage: np.ndarray
    soc: np.ndarray
    pack: np.ndarray
    soc_start: np.ndarray
    soc_end: np.ndarray
    energy: np.ndarray


def discharge(power: np.ndarray, bat: Any, dt: float, runs: list[slice]) -> Discharge:
    """Run ``power`` (W per sample; ``runs`` the slices of the runs, in order) off packs.

    A pack is swapped for a fresh one before a run that would end below
    ``bat.soc_swap`` (unless the pack is fresh already).
    """
    n, n_runs = len(power), len(runs)
    current, voltage, soc = np.empty(n), np.empty(n), np.empty(n)
    pack = np.zeros(n_runs, dtype=int)
    soc_start, soc_end, energy = np.zeros(n_runs), np.zeros(n_runs), np.zeros(n_runs)
    level, pack_id = bat.soc_start, 0
    charge_as = 3600.0 * bat.capacity_ah
    r = bat.internal_resistance_ohm
    for k, sl in enumerate(runs):
        p = power[sl]
        i0 = battery_current(p, bat.ocv(level), r)
        soc_t = level - cumtrapz(i0, dt) / charge_as
        if soc_t[-1] < bat.soc_swap and level < bat.soc_start:
            level, pack_id = bat.soc_start, pack_id + 1
            i0 = battery_current(p, bat.ocv(level), r)
            soc_t = level - cumtrapz(i0, dt) / charge_as
        ocv = bat.ocv(soc_t)
        i = battery_current(p, ocv, r)
        current[sl], voltage[sl], soc[sl] = i, ocv - r * i, soc_t
        pack[k], soc_start[k] = pack_id, level
        level = level - float(np.sum((i[1:] + i[:-1]) * dt / 2)) / charge_as
        soc_end[k] = level
        energy[k] = float(np.sum((p[1:] + p[:-1]) * dt / 2))
    return Discharge(current, voltage, soc, pack, soc_start, soc_end, energy)
