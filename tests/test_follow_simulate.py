"""Mid-mission events of the simulator, checked against its own physics and geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from energy_planner.simulate import MissionConfig, Physics, simulate_missions, synthetic_dem
from energy_planner.simulate.config import ConfigError, MissionEvent

CFG = MissionConfig.small(
    missions=1, duration_s=40.0, stop_prob=0.0, sideways_prob=0.0, backward_prob=0.0,
    speeds=(0.3,), loads_kg=(0.0,), grounds=("asphalt",),
)  # fmt: skip


def _features(ts, logs, **channels):
    f = {c: ts[c].to_numpy() for c in ("alpha", "gamma", "vx", "vy", "wz", "ax", "ay", "t_gait")}
    f.update({"load_kg": logs["load_kg"].to_numpy(), "ground": logs["ground"].astype(str)})
    f.update(channels)
    return f


def _frac(logs):
    t = logs["t"].to_numpy() - logs["t"].iloc[0]
    return t / t[-1]


def test_payload_changes_the_load_after_the_event_only():
    base = simulate_missions(seed=3, config=CFG)
    ev = simulate_missions(seed=3, config=CFG.replace(events=(MissionEvent("payload", at=0.5),)))
    on = _frac(ev.logs) >= 0.5
    load = ev.logs["load_kg"].to_numpy()
    assert np.all(load[on] == 15.0) and np.all(load[~on] == 0.0)
    p0, p1 = base.true_samples["power_expected"].to_numpy(), ev.true_samples["power_expected"]
    # before the pick-up the same robot walks the same path
    np.testing.assert_allclose(p1.to_numpy()[~on], p0[~on], rtol=1e-12)
    # after it, the power is that of the physics carrying 15 kg (its own parameters)
    loaded = Physics(effects=("load",)).expected_power(
        _features(ev.true_samples, ev.logs, load_kg=np.full(len(load), 15.0))
    )
    np.testing.assert_allclose(p1.to_numpy()[on], loaded[on], rtol=1e-9)
    assert p1.to_numpy()[on].mean() > 1.1 * p0[on].mean()  # 30 % more mass


def test_mud_turns_the_ground_after_the_event():
    ev = simulate_missions(seed=3, config=CFG.replace(events=(MissionEvent("mud", at=0.3),)))
    on = _frac(ev.logs) >= 0.3
    g = ev.logs["ground"].astype(str).to_numpy()
    assert set(g[on]) == {"mud"} and set(g[~on]) == {"asphalt"}
    mud = Physics(effects=("ground",)).expected_power(_features(ev.true_samples, ev.logs))
    np.testing.assert_allclose(ev.true_samples["power_expected"].to_numpy(), mud, rtol=1e-9)
    asphalt = Physics().expected_power(_features(ev.true_samples, ev.logs))
    assert np.all(mud[on] > asphalt[on])  # sinkage costs on every sample


def test_dem_bias_tilts_the_true_ground_over_its_stretch_only():
    bias_deg = 5.0
    cfg = CFG.replace(events=(MissionEvent("dem_bias", at=0.25, until=0.75,
                                           slope_bias_deg=bias_deg),))  # fmt: skip
    ev = simulate_missions(seed=3, config=cfg)
    ter = synthetic_dem(3)
    lg, ts = ev.logs, ev.true_samples
    dem = ter.sample(lg["x"].to_numpy(), lg["y"].to_numpy())
    on = (_frac(lg) >= 0.25) & (_frac(lg) < 0.75)
    a_true, a_dem = ts["alpha"].to_numpy(), np.asarray(dem.slope)
    np.testing.assert_allclose(a_true[~on], a_dem[~on], atol=1e-9)
    # |grad_true - grad_dem| = tan(bias): the slopes differ by at most that (triangle)
    d = np.abs(np.tan(a_true[on]) - np.tan(a_dem[on]))
    assert d.max() <= math.tan(math.radians(bias_deg)) + 1e-9
    # walking along the biased heading at its start, the whole bias shows as grade
    assert d[:5].max() > 0.9 * math.tan(math.radians(bias_deg))
    # the true altitude leaves the DEM's over the stretch and keeps the offset after it
    dz = lg["z"].to_numpy() - np.asarray(dem.elevation)
    assert np.allclose(dz[: np.flatnonzero(on)[0]], 0.0, atol=1e-9)
    after = np.flatnonzero(~on & (_frac(lg) >= 0.75))
    assert np.ptp(dz[after]) < 1e-9 and abs(dz[after[0]]) > 0.1


@pytest.mark.parametrize(
    ("kw", "field"),
    [({"kind": "flood"}, "kind"), ({"kind": "mud", "at": 1.2}, "at"),
     ({"kind": "dem_bias", "at": 0.5, "until": 0.4}, "until")],
)  # fmt: skip
def test_event_fields_are_validated(kw, field):
    with pytest.raises(ConfigError, match=f"MissionEvent.{field}"):
        MissionEvent(**kw)
