"""Bad robot logs (issue 13): a stray text value in a numeric channel, ROS-signed current,
runs too short for a window. Each is named (file, column, row, run) or fixed with a note."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.errors import LogError
from energy_planner.measurements import load_logs, make_windows, preprocess


def run_table(n=250, current=6.0, run=None, dt=0.02, **extra):
    """Walking forward at 0.3 m/s on level ground, 50 V, ``current`` A."""
    t = np.arange(n) * dt
    df = pd.DataFrame(
        {
            "t": t,
            "qw": 1.0,
            "qx": 0.0,
            "qy": 0.0,
            "qz": 0.0,
            "vx": 0.3,
            "vy": 0.0,
            "wz": 0.0,
            "voltage": 50.0,
            "current": current,
            **extra,
        }
    )
    if run is not None:
        df.insert(0, "run", run)
    return df


# ---------------------------------------------------------------------- numeric channels
def test_one_text_value_in_a_numeric_channel_is_named(tmp_path):
    payload = [10.0] * 250
    payload[42] = "ten"
    run_table(payload_kg=payload).to_csv(tmp_path / "ramp1.csv", index=False)
    with pytest.raises(LogError) as exc:
        load_logs(tmp_path)
    e, msg = exc.value, str(exc.value)
    for needle in (
        "ramp1.csv",
        "'payload_kg'",
        "'ten'",
        "row 42",
        "run ramp1",
        "249 of 250",
        "expected a number",
    ):
        assert needle in msg, needle
    assert (e.column, e.value, e.rows, e.runs) == ("payload_kg", "ten", [42], ["ramp1"])
    assert e.path.endswith("ramp1.csv")


def test_fit_with_the_channel_gives_the_message_not_a_traceback(tmp_path):
    payload = [10.0] * 250
    payload[7] = "n/a kg"
    run_table(payload_kg=payload).to_csv(tmp_path / "r.csv", index=False)
    res = CliRunner().invoke(
        main,
        ["fit", str(tmp_path), "--out", str(tmp_path / "m.json"), "--term", "payload_kg * speed"],
    )
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit), res.output
    assert "'payload_kg'" in res.output and "'n/a kg'" in res.output and "row 7" in res.output


def test_text_channels_stay_categorical(tmp_path):
    surface = ["grass"] * 100 + ["gravel"] * 100 + ["3"] * 50  # a code among the labels
    run_table(surface=surface, note=[None] * 250).to_csv(tmp_path / "a.csv", index=False)
    s = load_logs(tmp_path)
    assert s["surface"].dtype.name == "category"
    assert set(s["surface"].cat.categories) == {"grass", "gravel", "3"}


def test_channel_numeric_in_one_file_text_in_another(tmp_path):
    run_table(payload_kg=10.0).to_csv(tmp_path / "a.csv", index=False)
    run_table(payload_kg="heavy").to_csv(tmp_path / "b.csv", index=False)
    with pytest.raises(
        LogError,
        match=r"'payload_kg' is numeric in .*a\.csv but text in "
        r".*b\.csv",
    ) as exc:
        load_logs(tmp_path)
    assert exc.value.column == "payload_kg"


# ---------------------------------------------------------------------- current sign
def test_ros_signed_current_in_a_csv_is_named_and_negated(tmp_path):
    run_table(current=-6.0).to_csv(tmp_path / "ros.csv", index=False)
    run_table(current=6.0).to_csv(tmp_path / "ok.csv", index=False)
    with pytest.warns(UserWarning, match=r"ros\.csv.*negative in 100% .*ROS BatteryState") as w:
        s, rep = load_logs(tmp_path, report=True)
    assert len(w) == 1 and "ok.csv" not in str(w[0].message)
    assert rep.current_sign_flipped
    assert [f["path"].rsplit("/", 1)[1] for f in rep.current_negated_files] == ["ros.csv"]
    assert rep.current_negated_files[0]["median_current_a"] == -6.0
    assert (s["current"] == 6.0).all()
    json.dumps(rep.to_dict())
    clean, _ = preprocess(s)
    by_run = make_windows(clean).table["run"].value_counts().to_dict()
    assert by_run == {"ok": 3, "ros": 3}  # 5 s per run: 2 + 2 + 1 s (>= half a window)


def test_discharge_positive_keeps_the_sign_but_says_why_windows_vanish(tmp_path):
    run_table(current=-6.0).to_csv(tmp_path / "ros.csv", index=False)
    with pytest.warns(UserWarning, match=r"ros\.csv.*table_current='ros' or 'auto'"):
        s = load_logs(tmp_path, table_current="discharge_positive")
    assert (s["current"] == -6.0).all()
    with (
        pytest.warns(UserWarning, match=r"'ros'.*every sample removed.*consistency_bound"),
        pytest.raises(LogError, match=r"every one of the 250 samples.*consistency_bound: power"),
    ):
        preprocess(s)  # nothing left: the error lists each removal


def test_regenerative_moments_do_not_flip(tmp_path):
    cur = np.full(250, 6.0)
    cur[100:140] = -3.0  # braking downhill: 16 % negative
    run_table(current=cur).to_csv(tmp_path / "a.csv", index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = load_logs(tmp_path)
    assert (s["current"].to_numpy() == cur).all()


def test_table_current_option_is_checked(tmp_path):
    run_table().to_csv(tmp_path / "a.csv", index=False)
    with pytest.raises(LogError, match="table_current='neg'"):
        load_logs(tmp_path, table_current="neg")
    s = load_logs(tmp_path, table_current="ros")
    assert (s["current"] == -6.0).all()


# ---------------------------------------------------------------------- dropped runs
def test_a_run_of_three_samples_is_named_with_its_reason():
    df = pd.concat([run_table(run="long"), run_table(n=3, run="tiny")], ignore_index=True)
    clean, _ = preprocess(df)
    with pytest.warns(UserWarning, match=r"'tiny' \(3 samples\): no window long enough"):
        w = make_windows(clean)
    assert [d["run"] for d in w.dropped_runs] == ["tiny"]
    d = w.dropped_runs[0]
    assert d["n_samples"] == 3 and d["longest_window_s"] == pytest.approx(0.06)
    assert "1 s and 3 samples" in d["reason"]
    assert json.loads(json.dumps(w.to_dict()))["dropped_runs"][0]["run"] == "tiny"


def test_a_run_removed_by_preprocessing_is_named_with_the_step():
    dead = run_table(run="dead", voltage=0.0)  # voltmeter unplugged
    df = pd.concat([run_table(run="good"), dead], ignore_index=True)
    with pytest.warns(UserWarning, match=r"'dead' \(250 samples\).*drop_invalid"):
        clean, rep = preprocess(df)
    assert rep.dropped_runs == [
        {
            "run": "dead",
            "n_samples": 250,
            "step": "drop_invalid",
            "reason": "every sample removed; the last ones by drop_invalid (voltage outside "
            "5..1000 V)",
        }
    ]
    assert "run 'dead' dropped" in str(rep) and rep.to_dict()["dropped_runs"][0]["run"] == "dead"
    assert set(clean["run"]) == {"good"}


def test_fit_json_lists_dropped_runs(tmp_path):
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    cfg = CampaignConfig.small(
        slopes_deg=(0.0, 15.0), headings_deg=(0.0, 90.0), composite_slopes_deg=()
    )
    camp = simulate_campaign(seed=3, config=cfg)
    logs = tmp_path / "logs"
    logs.mkdir()
    for r, g in camp.logs.groupby("run"):
        g.drop(columns="run").to_csv(logs / f"{r}.csv", index=False)
    run_table(n=3).to_csv(logs / "stub.csv", index=False)
    res = CliRunner().invoke(
        main, ["fit", str(logs), "--out", str(tmp_path / "m.json"), "--folds", "0", "--json"]
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout[res.stdout.index("{") :])
    assert [d["run"] for d in doc["windows"]["dropped_runs"]] == ["stub"]


def test_missing_run_id_is_named(tmp_path):
    """Found by tests/test_fuzz_loaders.py: an empty ``run`` cell reached ``sorted`` as NaN
    (pandas 3 keeps NaN through ``astype(str)``) and raised a TypeError."""
    df = run_table(n=4, run=["a", None, "a", "a"])
    df.to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(LogError, match=r"r\.csv: the run id is missing at row\(s\) 1") as exc:
        load_logs(tmp_path)
    assert exc.value.rows == [1] and exc.value.column == "run"
    with pytest.raises(LogError, match="run id is missing"):
        preprocess(df)
