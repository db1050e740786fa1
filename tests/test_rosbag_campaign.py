"""Issue acceptance: simulate to ROS 2 bags and load them -> the same table as the CSV path."""

from __future__ import annotations

import numpy as np
import pandas as pd

from energy_planner.measurements import CANONICAL_COLUMNS, load_logs
from energy_planner.simulate import CampaignConfig, simulate_campaign


def test_bag_path_and_csv_path_give_the_same_table(tmp_path):
    cfg = CampaignConfig.small(
        slopes_deg=(0.0, 15.0), headings_deg=(0.0, 90.0), composite_slopes_deg=()
    )
    camp = simulate_campaign(seed=3, config=cfg)
    camp.write(tmp_path / "bag", bag=True)  # the CSV logs, and their bags under bags/
    from_csv = load_logs([tmp_path / "bag"]).sort_values(["run", "t"]).reset_index(drop=True)
    from_bag = load_logs([tmp_path / "bag" / "bags"]).sort_values(["run", "t"])
    from_bag = from_bag.reset_index(drop=True)
    assert len(from_bag) == len(from_csv) > 1000
    assert sorted(from_bag["run"].astype(str).unique()) == sorted(camp.runs["run"])
    for col in ("t", "qw", "qx", "qy", "qz", "vx", "vy", "wz", "x", "y", "yaw"):
        np.testing.assert_allclose(from_bag[col], from_csv[col], rtol=1e-9, atol=1e-9, err_msg=col)
    # BatteryState stores voltage and current as float32; the loader flips the sign back
    for col in ("voltage", "current"):
        np.testing.assert_allclose(from_bag[col], from_csv[col], rtol=1e-6, atol=1e-5, err_msg=col)
    # every extra channel the simulator writes (whatever their names), numeric or text
    extras = [c for c in from_csv.columns if c not in CANONICAL_COLUMNS]
    assert extras and sorted(extras) == sorted(
        c for c in from_bag.columns if c not in CANONICAL_COLUMNS
    )
    for col in extras:
        if pd.api.types.is_numeric_dtype(from_csv[col]):
            np.testing.assert_allclose(from_bag[col], from_csv[col], rtol=1e-6, err_msg=col)
        else:
            pd.testing.assert_series_equal(
                from_bag[col].astype(str), from_csv[col].astype(str), check_names=False
            )
