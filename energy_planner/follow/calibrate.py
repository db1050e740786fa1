"""Split-conformal calibration of the follower's remaining-energy interval.

The model's held-out run errors (:func:`energy_planner.uncertainty.model_scores`) are the
errors of a whole run's energy predicted before it starts. A follower's remaining energy
is a different prediction: its error depends on how much of the path is left and on what
the follower has seen (nothing unusual, a change of conditions it is following, a stretch
where the DEM is wrong). This module measures those errors on simulated missions
(seeds disjoint from any benchmark's) and keeps them as split-conformal scores
``r = E_pred / E_true - 1`` per **group**: the follower's state (``steady``: no change
detected; ``adapting``: a change detected, the coefficients follow the log; ``dem``: a
slope finding was made), with ``adapting`` split in two by the relative size of the
detected change (:attr:`~energy_planner.follow.FollowUpdate.step`; ``adapting_small`` /
``adapting_large`` at the calibration's median, :func:`score_group`), and the remaining
share of the path at the checkpoint. Every
calibration mission is scored at the same checkpoints, so the scores of a state near one
remaining share are one per mission; with ``n`` of them exchangeable with a new mission's
error at that checkpoint, the interval :func:`energy_planner.uncertainty.interval` built on
them covers it with probability at least the level, by construction (Mondrian
split-conformal, per checkpoint: the coverage holds at each share, not only pooled).

Which checkpoints are scored: every one on a mission without an event, and on a mission
with one, those after the follower has **picked the event up** (its first change detection
or slope finding after the event's start). Before that no interval can hold a change it has
not seen; those checkpoints are neither scored nor counted in the coverage.

:func:`follow_simulated_mission` is the one implementation of "simulate a mission with an
event and follow it" that the calibration and ``benchmarks/bench_follow.py`` share.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "RemainingScores",
    "bundled_scores",
    "score_group",
    "calibrate_remaining",
    "follow_simulated_mission",
    "dem_stretch_lengths",
    "mission_events",
    "EVENT_NAMES",
]

#: The mid-mission events of the benchmark and the calibration.
EVENT_NAMES = ("none", "payload", "mud", "dem_bias")

#: Half-width of the remaining-share neighbourhood a score group is read from.
SHARE_WIDTH = 0.025

#: The bundled model's calibrated scores (in ``energy_planner/data``).
SCORES_FILE = "follow_scores.json"

#: The follower's states the scores are grouped by.
STATES = ("steady", "adapting", "dem")

#: The score groups: the states, ``adapting`` split by the detected change's size
#: (:func:`score_group`).
GROUPS = ("steady", "adapting_small", "adapting_large", "dem")


def score_group(state: str, step: float, step_split: float | None) -> str:
    """The score group of a follower in ``state`` whose largest detected change was ``step``.

    ``adapting`` is split by the relative size of the detected change (the short mean
    innovation at detection over the recent power,
    :attr:`~energy_planner.follow.FollowUpdate.step`): ``adapting_large`` above
    ``step_split``, else ``adapting_small``. A follower knows its step at run time (not the
    event's cause); the normalized errors of a large change (a payload) and of a small one
    (mud) differ in scale, so a Mondrian split by it covers each alike. Without a split
    (scores calibrated before it) the group is the state.

    Examples
    --------
    >>> score_group("adapting", 0.12, 0.08), score_group("adapting", 0.05, 0.08)
    ('adapting_large', 'adapting_small')
    >>> score_group("steady", 0.12, 0.08), score_group("adapting", 0.12, None)
    ('steady', 'adapting')
    """
    if state != "adapting" or step_split is None:
        return state
    return "adapting_large" if abs(step) > step_split else "adapting_small"


def group_state(group: str) -> str:
    """The follower's state a score group belongs to (``adapting_large`` -> ``adapting``)."""
    return group.split("_", 1)[0]


def mission_events(name: str) -> tuple:
    """The simulator's events of the named case (``none``, ``payload``, ``mud``, ``dem_bias``).

    Raises
    ------
    ValueError
        An unknown name (the valid ones are listed).
    """
    from energy_planner.simulate.config import MissionEvent

    table = {
        "none": (),
        "payload": (MissionEvent("payload", at=0.4, load_kg=15.0),),
        "mud": (MissionEvent("mud", at=0.4),),
        "dem_bias": (MissionEvent("dem_bias", at=0.3, until=0.6, slope_bias_deg=5.0),),
    }
    if name not in table:
        raise ValueError(f"unknown event {name!r}; valid: {', '.join(table)}")
    return table[name]


@dataclass(frozen=True)
class RemainingScores:
    """Held-out errors ``E_pred / E_true - 1`` of the follower's remaining energy, by group.

    Attributes
    ----------
    scores : dict
        ``{group: [(remaining share, score), ...]}``: each score with the share of the
        path's time still ahead at its checkpoint; the groups are :data:`GROUPS` (or
        :data:`STATES`, scores calibrated without ``step_split``).
    seeds : tuple of int
        The simulated missions' seeds they come from.
    conditions : dict
        What they were measured on (mission length, log rate, events, checkpoints).
    normalized : bool
        The scores are divided by the follower's own relative spread at their checkpoint
        (:attr:`~energy_planner.follow.FollowUpdate.spread`); a follower multiplies them
        by its current spread (normalized split-conformal: the interval is wide where
        the follower is unsure, e.g. soon after a large change, and narrow elsewhere,
        with the same guarantee).
    dem_lengths_m : tuple of float
        Lengths (ground metres along the path) of the DEM errors the calibration's
        followers found (:attr:`~energy_planner.follow.SlopeFinding.length_m`): a
        follower extrapolates an open DEM error over those longer than it
        (``Follower(stretch_lengths_m=...)``, which defaults to these).
    step_split : float or None
        The detected change's relative size that splits ``adapting`` into
        ``adapting_small`` and ``adapting_large`` (:func:`score_group`): the median of the
        calibration's adapting checkpoints (two equal groups, fixed by the calibration's
        steps, never by its scores). None: no split.
    """

    scores: dict[str, list[tuple[float, float]]]
    seeds: tuple[int, ...] = field(default=())
    conditions: dict[str, Any] = field(default_factory=dict)
    normalized: bool = False
    dem_lengths_m: tuple[float, ...] = field(default=())
    step_split: float | None = None

    def for_group(
        self, group: str, share: float, level: float, width: float = SHARE_WIDTH
    ) -> np.ndarray:
        """The scores of ``group`` whose remaining share is within ``width`` of ``share``.

        The calibration scores every mission at the same checkpoints, so the scores near
        a checkpoint are one per mission: exchangeable with a new mission's error there
        (split-conformal per checkpoint). Where they are fewer than a two-sided interval
        at ``level`` needs (``n >= 2 / (1 - level) - 1``), ``width`` doubles until they
        suffice; a group with too few at any width falls back to its state's (every group
        of the state, e.g. both ``adapting`` groups; a state's name reads them all), then
        to every state's.
        """
        # 1e-9: 2 / (1 - 0.9) is 20.000000000000004 in floating point (19 suffice at 0.9)
        need = math.ceil(2.0 / (1.0 - level) - 1.0 - 1e-9)
        state = group_state(group)
        pools = [
            self.scores.get(group, []),
            [p for k, v in self.scores.items() if group_state(k) == state for p in v],
            [p for v in self.scores.values() for p in v],
        ]
        for pool in pools:
            arr = np.asarray(pool, dtype=float).reshape(-1, 2)
            w = float(width)
            while True:
                near = arr[np.abs(arr[:, 0] - share) <= w + 1e-12, 1]
                if near.size >= need:
                    return near
                if w >= 1.0:
                    break
                w *= 2.0
        return np.asarray([p[1] for v in self.scores.values() for p in v], dtype=float)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "scores": {k: [list(p) for p in v] for k, v in self.scores.items()},
            "seeds": list(self.seeds),
            "conditions": dict(self.conditions),
            "normalized": self.normalized,
            "dem_lengths_m": list(self.dem_lengths_m),
            "step_split": self.step_split,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RemainingScores:
        """Back from :meth:`to_dict`."""
        scores = {k: [(float(a), float(b)) for a, b in v] for k, v in d["scores"].items()}
        return cls(
            scores,
            tuple(d.get("seeds", ())),
            dict(d.get("conditions", {})),
            bool(d.get("normalized", False)),
            tuple(float(v) for v in d.get("dem_lengths_m", ())),
            None if d.get("step_split") is None else float(d["step_split"]),
        )

    def save(self, path: Any) -> Any:
        """Write the scores as JSON (through :func:`energy_planner.io.write_json`)."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: Any) -> RemainingScores:
        """Read scores written by :meth:`save`.

        Raises
        ------
        FollowError
            The file is not a scores file (names it and what was expected).
        """
        import json
        from pathlib import Path

        from energy_planner.follow.core import FollowError

        p = Path(path)
        try:
            return cls.from_dict(json.loads(p.read_text()))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise FollowError(
                f"{p}: not a follower's calibrated scores file ({exc}); expected the JSON "
                "RemainingScores.save writes: scores {state: [[share, score], ...]}",
                value=str(p),
            ) from exc


def bundled_scores() -> RemainingScores:
    """The bundled model's calibrated scores (``energy_planner/data/follow_scores.json``).

    Made by ``python benchmarks/bench_follow.py --coverage-only --save-scores`` (see
    ``docs/follow.md``): the bundled model's follower on simulated missions of every
    event case, seeds from 1000 (disjoint from the benchmark's).

    The file is read once per process (again if it changes); each call returns its own
    copy, so that changing one does not change the next.
    """
    import copy
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "data" / SCORES_FILE
    st = path.stat()
    kept = _read_scores(str(path), st.st_mtime_ns, st.st_size)
    return RemainingScores(
        {k: list(v) for k, v in kept.scores.items()},  # lists of (share, score) tuples
        kept.seeds,
        copy.deepcopy(kept.conditions),
        kept.normalized,
        kept.dem_lengths_m,
        kept.step_split,
    )


@functools.lru_cache(maxsize=1)
def _read_scores(path: str, mtime_ns: int, size: int) -> RemainingScores:
    """:meth:`RemainingScores.load` of ``path`` as it is at ``mtime_ns`` and ``size``.

    Parsing the file (about 40 ms: a float per score) was most of a ``Follower``'s start
    with the bundled model, paid by every follower a process makes.
    """
    return RemainingScores.load(path)


def forward_mission(duration: float = 240.0, rate: float = 20.0, events: tuple = ()) -> Any:
    """One mission walked forward at 0.3 m/s on asphalt, unloaded, without stops.

    The follower's missions (benchmark, calibration, tests): a constant gait, so the
    plan's timing (the walked path with its times) is the log's.
    """
    from energy_planner.simulate import MissionConfig

    return MissionConfig(
        missions=1,
        duration_s=duration,
        rate_hz=rate,
        stop_prob=0.0,
        sideways_prob=0.0,
        backward_prob=0.0,
        speeds=(0.3,),
        loads_kg=(0.0,),
        grounds=("asphalt",),
        events=tuple(events),
    )


def follow_simulated_mission(
    seed: int,
    event: str,
    model: Any,
    duration: float = 240.0,
    rate: float = 20.0,
    known_stretch: bool = False,
    terrain: Any = None,
    **options: Any,
) -> dict[str, Any]:
    """Simulate one mission with ``event`` and follow it (the plan is the walked path).

    Parameters
    ----------
    seed : int
        Simulator seed (the mission and its synthetic hill).
    event : str
        One of :data:`EVENT_NAMES`.
    model : EnergyModel
        The model the follower starts from.
    duration, rate : float
        Mission length (s) and log rate (Hz).
    known_stretch : bool
        Tell the follower where a ``dem_bias`` stretch ends (``bias_until_m``: the
        distance along the path at the event's ``until``), as if the DEM's error were
        mapped; its size is still measured online.
    terrain : Terrain, optional
        The ground (default: the simulator's synthetic hill of ``seed``).
    **options
        Passed to :class:`~energy_planner.follow.Follower`.

    Returns
    -------
    dict
        ``follower``, ``updates``, ``t`` (update times), ``true`` (true remaining energy
        at each update, J), ``t0``, ``t1`` (the log's span), ``t_event`` (the event's start,
        None without one), ``picked_at`` (the follower's first change detection or slope
        finding after the event's start, None if none), ``wall_s``, ``cpu_s``.
    """
    import time

    from energy_planner.follow.core import Follower
    from energy_planner.simulate import simulate_missions, synthetic_dem

    options.setdefault("remaining_scores", None)  # the raw errors: no scores to start from
    events = mission_events(event)
    cfg = forward_mission(duration, rate, events)
    terrain = synthetic_dem(seed) if terrain is None else terrain
    logs = simulate_missions(seed=seed, config=cfg, terrain=terrain).logs
    step = max(1, int(round(0.5 * rate)))
    k = np.r_[np.arange(0, len(logs) - 1, step), len(logs) - 1]
    f = Follower(
        terrain,
        model,
        logs[["x", "y"]].to_numpy()[k],
        logs["yaw"].to_numpy()[k],
        logs["t"].to_numpy()[k],
        **options,
    )
    t = logs["t"].to_numpy()
    if known_stretch and events and events[0].kind == "dem_bias":
        t_end = t[0] + events[0].until * (t[-1] - t[0])
        along = np.r_[0.0, np.cumsum(f.path.duration_s)]
        f.bias_until_m = float(
            np.interp(t_end - t[0], along, np.r_[0.0, np.cumsum(f.path.distance_m)])
        )
    t0w, t0c = time.perf_counter(), time.process_time()
    ups = f.replay(logs, chunk_s=1.0)
    wall, cpu = time.perf_counter() - t0w, time.process_time() - t0c
    p = (logs["voltage"] * logs["current"]).to_numpy()
    total = float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))
    ut = np.array([u.t for u in ups])
    true = np.array([total - u.used_j for u in ups])
    t_ev = None if not events else float(t[0] + events[0].at * (t[-1] - t[0]))
    picked = None
    if t_ev is not None:
        hit = [u.t for u in ups if u.t >= t_ev and u.state != "steady"]
        picked = hit[0] if hit else None
    return {
        "follower": f,
        "updates": ups,
        "t": ut,
        "true": true,
        "t0": float(t[0]),
        "t1": float(t[-1]),
        "t_event": t_ev,
        "picked_at": picked,
        "wall_s": wall,
        "cpu_s": cpu,
    }


def dem_stretch_lengths(
    model: Any,
    seeds: Any,
    duration: float = 240.0,
    rate: float = 20.0,
    **options: Any,
) -> dict[int, list[float]]:
    """The lengths of the DEM errors a follower finds on ``dem_bias`` missions, by seed.

    What a follower's ``stretch_lengths_m`` is made of: the slope findings'
    :attr:`~energy_planner.follow.SlopeFinding.length_m` (ground metres), one list per
    simulator seed (keep the seeds disjoint from those a result is reported on). The
    findings do not depend on how the path ahead is priced.
    """
    out: dict[int, list[float]] = {}
    for seed in (int(v) for v in seeds):
        run = follow_simulated_mission(seed, "dem_bias", model, duration, rate, **options)
        out[seed] = [float(f.length_m) for f in run["follower"].findings]
    return out


def counted(run: dict[str, Any], t: float) -> bool:
    """Whether a checkpoint at ``t`` is scored/counted: no event, or after its pick-up."""
    if run["t_event"] is None:
        return True
    return run["picked_at"] is not None and t >= run["picked_at"]


def calibrate_remaining(
    model: Any,
    seeds: Any = range(1000, 1008),
    events: tuple[str, ...] = EVENT_NAMES,
    duration: float = 240.0,
    rate: float = 20.0,
    checkpoints: Any = None,
    **options: Any,
) -> RemainingScores:
    """The follower's held-out remaining-energy errors on simulated missions.

    Parameters
    ----------
    model : EnergyModel
        The model the follower starts from.
    seeds : iterable of int
        Simulator seeds (keep them disjoint from the seeds a result is reported on).
    events : tuple of str
        The event cases (:data:`EVENT_NAMES`); every seed runs every case.
    duration, rate : float
        Mission length (s) and log rate (Hz).
    checkpoints : array-like, optional
        Shares of each mission scored (default 0.2, 0.25, ..., 0.85).
    **options
        Passed to the :class:`~energy_planner.follow.Follower`.

    Returns
    -------
    RemainingScores
        Grouped by :data:`GROUPS` with ``step_split`` the median detected step of the
        ``adapting`` checkpoints (:func:`score_group`; by :data:`STATES` when none is
        adapting). With the DEM errors' lengths the followers found (``dem_lengths_m``). Each
        mission is scored by a follower that extrapolates DEM errors over the lengths
        found on the **other** seeds (cross-fitted: a mission's own length never
        informs its own score).
    """
    cps = np.arange(0.2, 0.851, 0.05) if checkpoints is None else np.asarray(checkpoints)
    rows: list[tuple[str, float, float, float]] = []  # state, step, share, score
    seeds = tuple(int(s) for s in seeds)
    lengths: dict[int, list[float]] = {}
    if "dem_bias" in events and "stretch_lengths_m" not in options:
        lengths = dem_stretch_lengths(model, seeds, duration, rate, **options)
    for seed in seeds:
        opts = dict(options)
        if lengths:
            opts["stretch_lengths_m"] = [v for k, ls in lengths.items() if k != seed for v in ls]
        for ev in events:
            run = follow_simulated_mission(seed, ev, model, duration, rate, **opts)
            for c in cps:
                tc = run["t0"] + c * (run["t1"] - run["t0"])
                i = int(np.argmin(np.abs(run["t"] - tc)))
                u = run["updates"][i]
                if not counted(run, u.t) or run["true"][i] <= 0:
                    continue
                score = float(u.model_j / run["true"][i] - 1.0) / u.spread
                rows.append((u.state, float(u.step), float(u.remaining_share), score))
    steps = [abs(r[1]) for r in rows if r[0] == "adapting"]
    split = float(np.median(steps)) if steps else None
    out: dict[str, list[tuple[float, float]]] = {
        g: [] for g in (GROUPS if split is not None else STATES)
    }
    for state, step, share, score in rows:
        out[score_group(state, step, split)].append((share, score))
    conditions = {
        "duration_s": float(duration),
        "rate_hz": float(rate),
        "events": list(events),
        "checkpoints": [round(float(c), 6) for c in cps],
    }
    found = tuple(v for ls in lengths.values() for v in ls)
    return RemainingScores(
        out, seeds, conditions, normalized=True, dem_lengths_m=found, step_split=split
    )
