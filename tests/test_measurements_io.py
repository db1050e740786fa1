"""Loading and validating canonical robot logs (CSV, Parquet, folders) and bad input."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from energy_planner.errors import EnergyPlannerError, LogError, LogIOError
from energy_planner.measurements import REQUIRED_COLUMNS, load_logs, validate_log


def make_log(n=20, dt=0.1, run=None, t0=0.0, **over):
    t = t0 + dt * np.arange(n)
    d = {
        "t": t,
        "qw": 1.0,
        "qx": 0.0,
        "qy": 0.0,
        "qz": 0.0,
        "vx": 0.3,
        "vy": 0.0,
        "wz": 0.0,
        "voltage": 50.0,
        "current": 5.0 + 0.01 * np.arange(n),
    }
    if run is not None:
        d = {"run": run, **d}
    d.update(over)
    return pd.DataFrame(d)


def test_csv_and_parquet_one_run_per_file_run_id_is_stem(tmp_path):
    make_log(run=None, surface="grass", payload_kg=3.0).to_csv(tmp_path / "b.csv", index=False)
    make_log(run=None, t0=5.0, surface="mud", payload_kg=0.0).to_parquet(tmp_path / "a.parquet")
    s, rep = load_logs(tmp_path, report=True)
    assert list(pd.unique(s["run"])) == ["a", "b"]
    assert len(s) == 40 and rep.n_rows == 40
    assert [f["format"] for f in rep.files] == ["parquet", "csv"]
    for c in REQUIRED_COLUMNS:
        assert s[c].dtype == np.float64
    assert s["run"].map(type).eq(str).all()
    # extra columns kept: numeric as numeric, text as categorical
    assert rep.extra_columns == ["surface", "payload_kg"]
    assert s["payload_kg"].dtype.kind == "f"
    assert isinstance(s["surface"].dtype, pd.CategoricalDtype)
    assert set(s.loc[s.run == "a", "surface"]) == {"mud"}
    # values unchanged
    np.testing.assert_array_equal(s.loc[s.run == "b", "current"], make_log()["current"])
    assert "2 file(s), 40 samples, 2 run(s)" in str(rep)
    assert rep.to_dict()["validation"]["n_gaps"] == 0


def test_one_file_with_run_column_sorted_by_run_then_t(tmp_path):
    a, b = make_log(n=5, run="z"), make_log(n=5, run="y")
    df = pd.concat([a, b]).iloc[np.r_[0, 5, 1, 6, 2, 7, 3, 8, 4, 9]]  # interleaved
    df.to_csv(tmp_path / "all.csv", index=False)
    s = load_logs(tmp_path / "all.csv")
    assert list(s["run"]) == ["y"] * 5 + ["z"] * 5
    assert (np.diff(s["t"].to_numpy()[:5]) > 0).all()


def test_list_of_paths_and_duplicate_run_ids(tmp_path):
    (tmp_path / "x").mkdir()
    make_log().to_csv(tmp_path / "r1.csv", index=False)
    make_log().to_csv(tmp_path / "x" / "r1.csv", index=False)
    with pytest.raises(LogError, match=r"run id 'r1' found in both .*r1.csv.*x/r1.csv"):
        load_logs([tmp_path / "r1.csv", tmp_path / "x" / "r1.csv"])


def test_missing_column_names_column_file_and_required(tmp_path):
    p = tmp_path / "bad.csv"
    make_log().drop(columns=["voltage"]).to_csv(p, index=False)
    with pytest.raises(LogError) as ei:
        load_logs(p)
    msg = str(ei.value)
    assert "'voltage'" in msg and str(p) in msg
    assert "required columns are" in msg and "qw" in msg and "current" in msg
    assert isinstance(ei.value, ValueError) and isinstance(ei.value, EnergyPlannerError)


@pytest.mark.parametrize(
    "what,tvals", [("goes backwards", [0.0, 0.1, 0.05, 0.3]), ("repeats", [0.0, 0.1, 0.1, 0.3])]
)
def test_time_backwards_or_repeated_names_run_row_and_time(tmp_path, what, tvals):
    p = tmp_path / "r7.csv"
    make_log(n=4, t=tvals).to_csv(p, index=False)
    with pytest.raises(LogError, match=rf"time {what} in run 'r7' at row 2: t=0\.(05|1) s"):
        load_logs(p)


def test_non_numeric_value_is_an_error(tmp_path):
    p = tmp_path / "r.csv"
    df = make_log(n=3)
    df["vx"] = ["0.3", "fast", "0.3"]
    df.to_csv(p, index=False)
    with pytest.raises(LogError, match=r"column 'vx' is not numeric at row 1 \(value 'fast'\)"):
        load_logs(p)


def test_bad_paths(tmp_path):
    with pytest.raises(LogIOError, match="does not exist"):
        load_logs(tmp_path / "nope.csv")
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(LogIOError, match=r"unknown suffix '\.txt'"):
        load_logs(tmp_path / "notes.txt")
    with pytest.raises(LogIOError, match="holds no robot log"):
        load_logs(tmp_path)
    assert issubclass(LogIOError, OSError)


def test_validation_counts_nan_voltage_and_gaps_without_changing_data(tmp_path):
    df = make_log(n=10, run="r")
    df.loc[2, "current"] = np.nan
    df.loc[3, "qx"] = np.nan
    df.loc[5, "voltage"] = 0.0  # dead reading
    df.loc[6, "voltage"] = 4000.0  # absurd
    df.loc[7:, "t"] += 2.0  # one gap of 2.1 s between rows 6 and 7
    df.loc[8, ["qw", "qx", "qy", "qz"]] = 0.0  # no orientation
    before = df.copy()
    rep = validate_log(df, "r.csv")
    pd.testing.assert_frame_equal(df, before, check_exact=True)
    assert rep.n_nan == {"qx": 1, "current": 1}
    assert rep.n_bad_voltage == 2
    assert rep.n_bad_quaternion == 1
    assert len(rep.gaps) == 1
    g = rep.gaps[0]
    assert g["run"] == "r" and g["t_before"] == pytest.approx(0.6)
    assert g["dt"] == pytest.approx(2.1)
    # load_logs reports the same numbers and keeps every row
    df.drop(columns="run").to_csv(tmp_path / "r.csv", index=False)
    s, lrep = load_logs(tmp_path / "r.csv", report=True)
    assert len(s) == 10
    assert lrep.validation.n_nan == {"qx": 1, "current": 1}
    text = str(lrep)
    assert "voltage outside 5..1000 V" in text
    assert "1 time gap(s) (a step longer than 5 sample periods): run r split in 2" in text
    assert "IMU quaternions far from unit norm (dropped by preprocess): 1" in text


def test_folder_scan_skips_tables_that_are_not_logs_and_says_so(tmp_path):
    make_log().to_csv(tmp_path / "r1.csv", index=False)
    pd.DataFrame({"run": ["r1"], "slope_deg": [10.0]}).to_csv(tmp_path / "runs.csv", index=False)
    s, rep = load_logs(tmp_path, report=True)
    assert list(s["run"].unique()) == ["r1"]
    assert [k["path"] for k in rep.skipped] == [str(tmp_path / "runs.csv")]
    assert "skipped" in str(rep) and rep.to_dict()["skipped"][0]["reason"]
    # named explicitly it is an error, as is a partial log found in a folder
    with pytest.raises(LogError, match="runs.csv lacks required column"):
        load_logs(tmp_path / "runs.csv")
    make_log().drop(columns=["qw"]).to_csv(tmp_path / "r2.csv", index=False)
    with pytest.raises(LogError, match=r"r2.csv lacks required column\(s\) 'qw'"):
        load_logs(tmp_path)


def test_time_backwards_in_an_interleaved_multi_run_file_names_the_file_row(tmp_path):
    a, b = make_log(n=5, run="z"), make_log(n=5, run="y")
    df = pd.concat([a, b]).iloc[np.r_[0, 5, 1, 6, 2, 7, 3, 8, 4, 9]].reset_index(drop=True)
    df.loc[7, "t"] = 0.05  # run y: rows 1, 3, 5, 7 have t 0, 0.1, 0.2, 0.05
    df.to_csv(tmp_path / "all.csv", index=False)
    with pytest.raises(
        LogError,
        match=r"goes backwards in run 'y' at row 7: t=0.05 s after "
        r"t=0.2 s",
    ):
        load_logs(tmp_path / "all.csv")
