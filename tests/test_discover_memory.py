"""#21 point 4: discover's memory does not grow with the number of candidates.

``WindowData`` keeps every candidate's window means but at most
``SAMPLE_CACHE_BYTES`` of per-sample columns, evaluating ``EVAL_CHUNK`` terms at a time;
a column let go is evaluated again. The staircase must not depend on either: with no
per-sample cache at all and one term at a time, discover chooses the same terms with the
same held-out numbers as with the defaults.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd


def _discover(logs):
    from energy_planner.diagnosis.discover import discover

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return discover(logs, max_steps=1, fit_final=False).to_dict()


def _same(a, b, path="") -> None:
    """Equal documents, floats to 1e-12 relative."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list | tuple):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-12), (path, a, b)
    else:
        assert a == b, path


def test_no_sample_cache_gives_the_same_staircase(monkeypatch):
    from energy_planner.calibration import windowdata as data
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(seed=1, effects=("load",), config=CampaignConfig.small())
    logs = camp.logs.drop(columns=["ground", "air_temp_c", "grass_height_m"])
    default = _discover(logs)
    monkeypatch.setattr(data, "SAMPLE_CACHE_BYTES", 0)
    monkeypatch.setattr(data, "EVAL_CHUNK", 1)
    bare = _discover(logs)
    _same(default, bare)
    assert len(default["added"]) >= 1  # the load was found: the comparison is not empty
    assert np.isfinite(default["staircase"][-1]["heldout_rmse_w"])


def test_the_sample_cache_is_bounded(monkeypatch):
    from energy_planner.calibration import windowdata as data
    from energy_planner.calibration.prepare import prepare_logs
    from energy_planner.calibration.windowdata import window_data
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(seed=2, config=CampaignConfig.small())
        wd = window_data(prepare_logs(camp.logs).windows)
    n = len(wd.samples)
    monkeypatch.setattr(data, "SAMPLE_CACHE_BYTES", 3 * 8 * n)  # three columns
    terms = [f"vx * {k}" for k in range(1, 11)]
    cols = wd.sample_columns(terms)
    # every column asked for is returned, right, though the cache keeps three
    vx = wd.samples["vx"].to_numpy(float)
    for k in range(10):
        np.testing.assert_array_equal(cols[:, k], vx * (k + 1))
    assert len(wd._sample_cache) == 3
    # window means of every term stay: the mean of k * vx is k times the mean of vx
    means = wd.columns(terms)
    np.testing.assert_allclose(means, wd.window_mean(vx)[:, None] * np.arange(1, 11), rtol=1e-12)


def test_sample_columns_into_a_slice_equal_the_stacked_columns():
    """Columns written into part of a larger array equal the ones returned, and vx * k."""
    from energy_planner.calibration.windowdata import window_data

    rng = np.random.default_rng(0)
    n = 600
    s = pd.DataFrame(
        {
            "run": np.repeat(["a", "b", "c"], n // 3),
            "t": np.tile(np.arange(n // 3) * 0.05, 3),
            "power": rng.uniform(100, 200, n),
            "window": np.tile(np.arange(n // 3) // 20, 3),
            "vx": rng.uniform(0.1, 0.4, n),
            "vy": 0.0,
            "wz": 0.0,
            "alpha": 0.1,
            "gamma": 0.0,
        }
    )
    wd = window_data(s)
    terms = ["vx", "vx * 2", "vx", "vx * 3"]  # a repeated term fills both columns
    big = np.full((len(wd.samples), 6), np.nan, order="F")
    got = wd.sample_columns(terms, out=big[:, 1:5])
    assert np.shares_memory(got, big)
    vx = wd.samples["vx"].to_numpy(float)
    np.testing.assert_array_equal(big[:, 1:5], vx[:, None] * np.array([1, 2, 1, 3]))
    assert np.isnan(big[:, [0, 5]]).all()  # nothing written outside the slice
    np.testing.assert_array_equal(wd.sample_columns(terms), big[:, 1:5])


def test_check_data_on_sorted_logs_equals_shuffled():
    """Sorted logs skip the sort's copy; the findings and repaired samples are the same."""
    from energy_planner.measurements.datacheck import check_data
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        logs = simulate_campaign(seed=3, config=CampaignConfig.small()).logs
        logs = logs.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
        shuffled = logs.sample(frac=1.0, random_state=0)
        f0, a = check_data(logs)
        f1, b = check_data(shuffled)
    assert [f.to_dict() for f in f0] == [f.to_dict() for f in f1]
    pd.testing.assert_frame_equal(
        a.reset_index(drop=True), b.reset_index(drop=True), check_exact=True
    )
    assert any(f.repaired for f in f0)  # a repair was applied: the comparison is not empty


def test_grouped_design_in_chunks_equals_the_window_means_of_the_whole_design():
    """design_matrix(groups=...) evaluates 8 terms at a time; same as grouping the whole."""
    from energy_planner.model import EnergyModel

    rng = np.random.default_rng(4)
    n = 500
    f = pd.DataFrame({"vx": rng.uniform(0, 0.5, n), "vy": rng.normal(0, 0.1, n),
                      "wz": rng.normal(0, 0.2, n), "alpha": rng.uniform(0, 0.4, n),
                      "gamma": rng.uniform(-3, 3, n)})  # fmt: skip
    f["speed"] = np.hypot(f["vx"], f["vy"])
    terms = [f"vx * {k}" for k in range(1, 12)] + ["abs(vy)", "abs(wz) * sin(alpha)"]
    m = EnergyModel(terms)
    groups = rng.integers(0, 37, n)
    whole = m.design_matrix(f)
    means = pd.DataFrame(whole).groupby(groups, sort=True).mean().to_numpy()
    got = m.design_matrix(f, groups=groups)
    assert got.shape == (37, len(terms))
    np.testing.assert_allclose(got, means, rtol=1e-12, atol=0)
    # and against the definition: column k of the first 11 is k times the mean of vx
    vx = pd.Series(f["vx"].to_numpy()).groupby(groups, sort=True).mean().to_numpy()
    np.testing.assert_allclose(got[:, :11], vx[:, None] * np.arange(1, 12), rtol=1e-12)
