"""The run plan of a field campaign (paper section IV-C).

Straight runs at every slope, heading, motion and speed; turns in place both ways; arcs
both ways; standing runs; and composite paths for the superposition test:

(a) leg A (forward ``dA``) then leg B (sideways ``dB``), each alone and as one
    continuous run AB, against the straight diagonal C with the same end points;
(b) yaw in place by ``dtheta`` (A) then a straight translation along the chord (B), each
    alone and as one run AB (with a momentary stop between), against the circular arc C
    of radius ``R`` with the same pose change.

Every condition comes with its mirror image (``gamma -> -gamma``, left <-> right), so
the design is mirror symmetric when the headings are (the default ones are).

Examples
--------
>>> from energy_planner.simulate.config import CampaignConfig
>>> plan = plan_runs(CampaignConfig.small())
>>> sorted({r.kind for r in plan})
['arc', 'composite', 'stand', 'straight', 'turn']
>>> len(plan)
95
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from energy_planner.angles import wrap_deg
from energy_planner.simulate.config import CampaignConfig, ConfigError

__all__ = ["RunSpec", "plan_runs", "nominal_speed"]


@dataclass(frozen=True)
class RunSpec:
    """One planned run.

    Attributes
    ----------
    run : str
        Unique run id.
    kind : str
        ``straight``, ``turn``, ``arc``, ``stand`` or ``composite``.
    motion : str
        ``forward``, ``backward``, ``left``, ``right``, ``turn_left``, ``turn_right``,
        ``arc_left``, ``arc_right``, ``stand``, or for composites e.g. ``forward+left``.
    slope_deg : float
        Slope, deg.
    heading_deg : float
        In-plane heading ``gamma`` at the start, deg, in ``(-180, 180]``.
    speed : float
        Nominal speed, m/s (0 for turns in place and standing).
    yaw_rate : float
        Nominal yaw-rate magnitude, rad/s (0 for straight runs).
    segments : tuple of (duration_s, vx, vy, wz)
        Commanded constant-twist pieces (before ramps).
    repeat : int
        Repeat index.
    composite : str
        Composite group id (empty for other runs).
    part : str
        ``A``, ``B``, ``AB`` or ``C`` for composites, else empty.
    start_after : str
        Run id whose end pose is this run's start pose (leg B of a composite), else empty.
    """

    run: str
    kind: str
    motion: str
    slope_deg: float
    heading_deg: float
    speed: float
    yaw_rate: float
    segments: tuple[tuple[float, float, float, float], ...]
    repeat: int = 0
    composite: str = ""
    part: str = ""
    start_after: str = ""

    @property
    def distance_m(self) -> float:
        """Commanded path length, m."""
        return float(sum(d * math.hypot(vx, vy) for d, vx, vy, _ in self.segments))

    @property
    def turn_rad(self) -> float:
        """Commanded signed yaw change, rad."""
        return float(sum(d * wz for d, _, _, wz in self.segments))


def nominal_speed(config: CampaignConfig) -> float:
    """The speed of the composite runs: the configured speed closest to 0.3 m/s.

    >>> nominal_speed(CampaignConfig(speeds=(0.2, 0.45)))
    0.2
    """
    return min(config.speeds, key=lambda v: (abs(v - 0.3), v))


def _q(d: float, dt: float) -> float:
    """Round a duration to a whole number of samples (at least one)."""
    return max(1, round(d / dt)) * dt


def _tag(slope: float, heading: float, speed: float) -> str:
    return f"a{slope:g}_g{heading:+g}_v{speed:g}"


_SIDES = (("left", 1), ("right", -1))
_DIRECTIONS = {"forward": (1, 0), "backward": (-1, 0), "left": (0, 1), "right": (0, -1)}

Segment = tuple[float, float, float, float]


def plan_runs(config: CampaignConfig) -> list[RunSpec]:
    """Every run of the campaign, in design order (leg A before leg B).

    Durations are whole numbers of samples; a composite part's speed is adjusted by at
    most half a sample so that its distance is exact.

    Raises
    ------
    ConfigError
        If two runs would get the same id (a heading, slope or speed listed twice).
    """
    dt = config.dt
    ramp = round(config.ramp_s / dt) * dt
    body = _q(config.run_s - ramp, dt)
    runs: list[RunSpec] = []
    for slope in config.slopes_deg:
        for rep in range(config.repeats):
            runs += _condition_runs(config, slope, rep, body)
    for slope in config.composite_slopes_deg:
        for heading in config.composite_headings_deg:
            for side, s in _SIDES:
                runs += _composite_a(config, slope, wrap_deg(heading), side, s)
                runs += _composite_b(config, slope, wrap_deg(heading), side, s, ramp)
    ids = [r.run for r in runs]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ConfigError(
            f"the campaign plans run {dup[0]!r} twice: a heading, slope or speed is listed "
            "twice (e.g. 0 and 360 deg); expected distinct values",
            value=dup[0],
            expected="distinct headings, slopes and speeds",
        )
    return runs


def _condition_runs(config: CampaignConfig, slope: float, rep: int, body: float) -> list[RunSpec]:
    """The straight runs, turns in place, arcs and standing run of one slope and repeat."""
    runs: list[RunSpec] = []

    def add(run: str, kind: str, motion: str, h: float, v: float, w: float, seg: Segment):
        runs.append(RunSpec(f"{run}_r{rep}", kind, motion, slope, h, v, w, (seg,), rep))

    for heading in config.headings_deg:
        h = wrap_deg(heading)
        for motion in config.motions:
            ux, uy = _DIRECTIONS[motion]
            for v in config.speeds:
                seg = (body, ux * v, uy * v, 0.0)
                add(f"straight_{motion}_{_tag(slope, h, v)}", "straight", motion, h, v, 0.0, seg)
    for heading in config.turn_headings_deg:
        h = wrap_deg(heading)
        for side, s in _SIDES:
            w = config.yaw_rate
            seg = (body, 0.0, 0.0, s * w)
            add(f"turn_{side}_{_tag(slope, h, 0.0)}", "turn", f"turn_{side}", h, 0.0, w, seg)
    if config.arcs:
        for v in config.speeds:
            w = v / config.arc_radius_m
            for side, s in _SIDES:
                seg = (body, v, 0.0, s * w)
                add(f"arc_{side}_{_tag(slope, 0.0, v)}", "arc", f"arc_{side}", 0.0, v, w, seg)
    if config.stand:
        seg = (body, 0.0, 0.0, 0.0)
        add(f"stand_{_tag(slope, 0.0, 0.0)}", "stand", "stand", 0.0, 0.0, 0.0, seg)
    return runs


def _quartet(
    cid: str,
    slope: float,
    v: float,
    parts: dict[str, tuple[str, float, float, tuple[Segment, ...]]],
) -> list[RunSpec]:
    """The runs A, B (starting where A ended), AB and C of one composite.

    ``parts[p]`` is ``(motion, heading_deg, yaw_rate, segments)`` of part ``p``.
    """
    return [
        RunSpec(
            f"{cid}_{part}",
            kind="composite",
            motion=motion,
            slope_deg=slope,
            heading_deg=h,
            speed=v,
            yaw_rate=w,
            segments=segments,
            composite=cid,
            part=part,
            start_after=f"{cid}_A" if part == "B" else "",
        )
        for part, (motion, h, w, segments) in parts.items()
    ]


def _composite_a(config: CampaignConfig, slope: float, h: float, side: str, s: int) -> list:
    """Composite (a): A forward, B sideways, C the diagonal between the same end points."""
    dt, v = config.dt, nominal_speed(config)
    d_a, d_b = config.composite_legs_m
    d_c = math.hypot(d_a, d_b)
    ta, tb, tc = _q(d_a / v, dt), _q(d_b / v, dt), _q(d_c / v, dt)
    seg_a = (ta, d_a / ta, 0.0, 0.0)
    seg_b = (tb, 0.0, s * d_b / tb, 0.0)
    seg_c = (tc, d_a / tc, s * d_b / tc, 0.0)
    parts = {
        "A": ("forward", h, 0.0, (seg_a,)),
        "B": (side, h, 0.0, (seg_b,)),
        "AB": (f"forward+{side}", h, 0.0, (seg_a, seg_b)),
        "C": (f"diagonal_{side}", h, 0.0, (seg_c,)),
    }
    return _quartet(f"supa_{side}_{_tag(slope, h, v)}", slope, v, parts)


def _composite_b(
    config: CampaignConfig, slope: float, h: float, side: str, s: int, ramp: float
) -> list:
    """Composite (b): A yaw in place, B straight along the chord, C the circular arc."""
    dt, v = config.dt, nominal_speed(config)
    turn = math.radians(abs(config.composite_turn_deg))
    radius = config.arc_radius_m
    chord = 2.0 * radius * math.sin(turn / 2.0)
    ta = _q(turn / config.yaw_rate, dt)
    tb = _q(chord / v, dt)
    tc = _q(radius * turn / v, dt)
    seg_a = (ta, 0.0, 0.0, s * turn / ta)
    # after yawing by s*turn the chord points at -s*turn/2 in the body frame
    seg_b = (tb, chord / tb * math.cos(turn / 2), -s * chord / tb * math.sin(turn / 2), 0.0)
    seg_c = (tc, radius * turn / tc, 0.0, s * turn / tc)
    ab = (seg_a, (ramp, 0.0, 0.0, 0.0), seg_b) if ramp > 0 else (seg_a, seg_b)
    parts = {
        "A": (f"turn_{side}", h, config.yaw_rate, (seg_a,)),
        "B": (f"chord_{side}", wrap_deg(h + s * math.degrees(turn)), 0.0, (seg_b,)),
        "AB": (f"turn_{side}+chord_{side}", h, config.yaw_rate, ab),
        "C": (f"arc_{side}", h, v / radius, (seg_c,)),
    }
    return _quartet(f"supb_{side}_{_tag(slope, h, v)}", slope, v, parts)
