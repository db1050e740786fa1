"""Validation of the simulator's configs: one rule per field, shared by campaign and missions."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.errors import EnergyPlannerError
from energy_planner.simulate import (
    BatteryConfig,
    CampaignConfig,
    ConfigError,
    MissionConfig,
    SensorConfig,
)

#: Values that a MissionConfig accepted before its validation was shared with the campaign.
DRIFTED = [
    ("gap_s", -3),
    ("gap_s", math.inf),
    ("loads_kg", (-5.0,)),
    ("loads_kg", ()),
    ("air_temp_range_c", (30.0, -5.0)),
    ("motor_temp_range_c", (75.0,)),
    ("motor_warming_k_s", -0.01),
    ("grass_height_range_m", (-0.1, 0.2)),
    ("sensors", "ideal"),
    ("battery", None),
]


@pytest.mark.parametrize(("name", "value"), DRIFTED)
def test_missions_refuse_what_the_campaign_refuses(name, value):
    for cls in (MissionConfig, CampaignConfig):
        with pytest.raises(ConfigError) as info:
            cls(**{name: value})
        err = info.value
        assert isinstance(err, EnergyPlannerError) and isinstance(err, ValueError)
        assert err.param == f"{cls.__name__}.{name}"
        assert err.value == value or (value != value and err.value != err.value)
        assert err.expected and err.expected in str(err)
        assert f"{cls.__name__}.{name} = {value!r}" in str(err)


def test_gap_message_names_field_value_and_expectation():
    expected = r"MissionConfig\.gap_s = -3 is invalid: expected .*>= 0 s"
    with pytest.raises(ConfigError, match=expected):
        MissionConfig(gap_s=-3)


@pytest.mark.parametrize(
    ("cls", "name", "value"),
    [
        (MissionConfig, "duration_s", "long"),
        (MissionConfig, "missions", 2.0),
        (MissionConfig, "missions", True),
        (MissionConfig, "phase_s", (0.0, 5.0)),
        (MissionConfig, "stop_s", -1.0),
        (MissionConfig, "rate_hz", math.nan),
        (CampaignConfig, "rate_hz", "50"),
        (CampaignConfig, "repeats", 0),
        (CampaignConfig, "headings_deg", (0.0, math.nan)),
        (SensorConfig, "spike_prob", 1.5),
        (SensorConfig, "ros_current_sign", "yes"),
        (BatteryConfig, "cell_full_v", "4.2"),
        (BatteryConfig, "soc_swap", 1.0),
    ],
)
def test_wrong_types_and_ranges_are_config_errors(cls, name, value):
    """A value of the wrong type is named like a value out of range (never a TypeError)."""
    with pytest.raises(ConfigError, match=rf"{cls.__name__}\.{name} = "):
        cls(**{name: value})


def test_sideways_plus_backward_at_most_one():
    MissionConfig(sideways_prob=0.5, backward_prob=0.5)
    with pytest.raises(ConfigError, match="backward_prob .*sideways_prob = 0.6"):
        MissionConfig(sideways_prob=0.6, backward_prob=0.5)


def test_presets_and_lists_are_accepted():
    for cfg in (MissionConfig(), MissionConfig.small(), MissionConfig.varied(), CampaignConfig()):
        assert isinstance(cfg.speeds, tuple)
    cfg = MissionConfig(speeds=[0.2, 0.4], loads_kg=[0, 5], grounds=["mud"])  # lists -> tuples
    assert cfg.speeds == (0.2, 0.4) and cfg.loads_kg == (0, 5) and cfg.grounds == ("mud",)


def _outcome(cls, name, value):
    """'ok', or the field a ConfigError names (another field's rule may fail: ok for this one)."""
    try:
        cls(**{name: value})
    except ConfigError as err:
        return err.param.split(".", 1)[1] == name
    return False


_ANY = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-10, 3000),
    st.booleans(),
    st.none(),
    st.text(max_size=3),
)
_SEQ = st.one_of(
    st.tuples(), st.tuples(_ANY), st.tuples(_ANY, _ANY), st.lists(st.floats(-50, 50), max_size=3)
)


@settings(max_examples=150, deadline=None)
@given(
    name=st.sampled_from(("yaw_rate", "ramp_s", "rate_hz", "gap_s", "motor_warming_k_s")),
    value=_ANY,
)
def test_shared_scalar_fields_agree(name, value):
    assert _outcome(MissionConfig, name, value) == _outcome(CampaignConfig, name, value)


@settings(max_examples=150, deadline=None)
@given(
    name=st.sampled_from(
        ("speeds", "loads_kg", "air_temp_range_c", "motor_temp_range_c", "grass_height_range_m")
    ),
    value=_SEQ,
)
def test_shared_tuple_fields_agree(name, value):
    assert _outcome(MissionConfig, name, value) == _outcome(CampaignConfig, name, value)


def test_the_truth_imports_nothing_from_the_model():
    """The truth is physics: simulating, and a path's true energy, never load the model."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from energy_planner.simulate import (CampaignConfig, MissionConfig, simulate_campaign,\n"
        "    simulate_missions, synthetic_dem, true_path_energy)\n"
        "simulate_campaign(seed=0, effects=('load', 'ground'), config=CampaignConfig.small())\n"
        "t = synthetic_dem(seed=1, size_m=60.0)\n"
        "simulate_missions(seed=0, config=MissionConfig.small(duration_s=20.0), terrain=t)\n"
        "true_path_energy(t, [[20.0, 20.0, 0.0], [30.0, 25.0, 0.0]])\n"
        "print(sorted(m for m in sys.modules if m.startswith('energy_planner.model')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_log_columns_are_the_canonical_ones():
    """The simulator writes the canonical log (its own copy of the names, to import light)."""
    from energy_planner.measurements.schema import CANONICAL_COLUMNS
    from energy_planner.simulate import LOG_COLUMNS

    assert LOG_COLUMNS == CANONICAL_COLUMNS


@pytest.mark.parametrize("kind", ["campaign", "missions"])
def test_run_records_agree_with_the_logs(kind):
    """Each run record's clock, size, battery and pose fields, recomputed from the logs."""
    import numpy as np

    from energy_planner.simulate import simulate_campaign, simulate_missions, synthetic_dem

    if kind == "campaign":
        cfg = CampaignConfig.small(slopes_deg=(0.0, 20.0), composite_slopes_deg=())
        camp = simulate_campaign(seed=2, config=cfg)
    else:
        cfg = MissionConfig.small(missions=3, duration_s=15.0)
        terrain = synthetic_dem(seed=3, size_m=60.0)
        camp = simulate_missions(seed=2, config=cfg, terrain=terrain)
    runs, logs, ts = camp.runs, camp.logs, camp.true_samples
    assert runs["order"].tolist() == list(range(len(runs)))
    assert logs["run"].unique().tolist() == runs["run"].tolist()  # log order = record order
    first = logs.groupby("run", sort=False).head(1).set_index("run")
    last = logs.groupby("run", sort=False).tail(1).set_index("run")
    r = runs.set_index("run")
    assert (logs.groupby("run", sort=False).size() == r["n_samples"]).all()
    np.testing.assert_allclose(first["t"], r["t_start"], atol=1e-9)
    np.testing.assert_allclose(last["t"] - first["t"], r["duration_s"], atol=1e-9)
    gaps = r["t_start"].to_numpy()[1:] - (r["t_start"] + r["duration_s"]).to_numpy()[:-1]
    np.testing.assert_allclose(gaps, cfg.gap_s, atol=1e-9)
    np.testing.assert_allclose(first[["x", "y"]], r[["start_x", "start_y"]], atol=1e-12)
    np.testing.assert_allclose(last[["x", "y"]], r[["end_x", "end_y"]], atol=1e-12)
    for run, g in ts.groupby("run", sort=False):
        p, t = g["power"].to_numpy(), g["t"].to_numpy()
        energy = float(np.sum((p[1:] + p[:-1]) * np.diff(t) / 2))
        assert energy == pytest.approx(r.loc[run, "true_energy_j"], rel=1e-6)
        assert r.loc[run, "true_mean_power_w"] == pytest.approx(energy / np.ptp(t), rel=1e-6)
    soc = ts.groupby("run", sort=False)["soc"]
    np.testing.assert_allclose(soc.first(), r["soc_start"], atol=1e-12)
    assert (r["soc_end"] < r["soc_start"]).all()
