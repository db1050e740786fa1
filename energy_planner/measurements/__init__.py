"""Robot logs: loading (CSV, Parquet, ROS bags), validation, cleaning, windows.

>>> from energy_planner.measurements import load_logs, preprocess, make_windows
>>> # samples = load_logs("logs/"); clean, report = preprocess(samples)
>>> # windows = make_windows(clean, duration=2.0)

The canonical log table and the conventions (frames, sign of the battery current) are
described in :mod:`energy_planner.measurements.schema` and ``docs/measurements.md``.
"""

from energy_planner.measurements.datacheck import DataFinding, check_data
from energy_planner.measurements.imu import imu_slope_heading, up_in_body, wrap_angle
from energy_planner.measurements.logs import LoadReport, load_logs
from energy_planner.measurements.poses import fresh_poses, walked_path
from energy_planner.measurements.preprocess import (
    STEPS,
    PreprocessParams,
    PreprocessReport,
    StepRecord,
    add_power,
    add_slope_heading,
    body_accelerations,
    consistency_bound,
    discard_low_speed,
    drop_invalid,
    ema,
    ema_smooth,
    hampel_filter,
    hampel_mask,
    mechanical_lower_bound,
    preprocess,
    split_segments,
)
from energy_planner.measurements.rosbag import DEFAULT_TOPICS, load_rosbag, write_rosbag
from energy_planner.measurements.schema import (
    CANONICAL_COLUMNS,
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    ValidationReport,
    validate_log,
)
from energy_planner.measurements.windows import (
    MOTIONS,
    Windows,
    classify_motion,
    make_windows,
    run_energies,
)

__all__ = [
    "CANONICAL_COLUMNS",
    "DEFAULT_TOPICS",
    "MOTIONS",
    "OPTIONAL_COLUMNS",
    "REQUIRED_COLUMNS",
    "STEPS",
    "DataFinding",
    "LoadReport",
    "PreprocessParams",
    "PreprocessReport",
    "StepRecord",
    "ValidationReport",
    "Windows",
    "add_power",
    "add_slope_heading",
    "body_accelerations",
    "check_data",
    "classify_motion",
    "consistency_bound",
    "discard_low_speed",
    "drop_invalid",
    "ema",
    "ema_smooth",
    "hampel_filter",
    "hampel_mask",
    "imu_slope_heading",
    "load_logs",
    "load_rosbag",
    "make_windows",
    "mechanical_lower_bound",
    "preprocess",
    "run_energies",
    "split_segments",
    "up_in_body",
    "validate_log",
    "wrap_angle",
    "write_rosbag",
    "fresh_poses",
    "walked_path",
]
