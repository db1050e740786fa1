"""The one data pipeline of ``fit``, ``diagnose`` and ``discover``: checks, cleaning, windows.

Raw canonical samples go through

1. the data checks (:func:`energy_planner.measurements.datacheck.check_data`): sensor
   problems (current sign, clock offset between power and motion, odometry slip growing
   with slope, IMU tilt, twist noise), each reported as a *data finding* and, with
   ``repair=True`` (the default), corrected;
2. cleaning (:func:`~energy_planner.measurements.preprocess.preprocess`, paper IV-B);
3. windows (:func:`~energy_planner.measurements.windows.make_windows`).

Every command and Python verb that starts from logs calls :func:`prepare_logs`, so the
same logs give the same findings, repairs and windows whichever command reads them.

Examples
--------
>>> import numpy as np, pandas as pd
>>> t = np.arange(0, 8, 0.05)
>>> s = pd.DataFrame({"run": np.repeat(["a", "b"], len(t) // 2), "t": np.r_[t[:80], t[:80]],
...                   "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0, "vx": 0.3, "vy": 0.0,
...                   "wz": 0.0, "voltage": 50.0, "current": -4.0 + 0.1 * np.sin(7 * t)})
>>> p = prepare_logs(s)
>>> [f.name for f in p.found], p.repair, len(p.windows.table) > 0
(['current_sign'], True, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pandas as pd

from energy_planner.measurements.datacheck import DataFinding, check_data

__all__ = ["PreparedLogs", "prepare_logs", "findings_text"]


@dataclass
class PreparedLogs:
    """Raw samples after the data checks, cleaning and windows (:func:`prepare_logs`).

    Attributes
    ----------
    windows : Windows
        The windows every fit and diagnosis works on.
    findings : list of DataFinding
        Every data check's result (finding or not, with its evidence).
    repair : bool
        Whether the findings were corrected before cleaning.
    preprocess_report : PreprocessReport
        What cleaning removed, step by step.
    """

    windows: Any
    findings: list[DataFinding]
    repair: bool
    preprocess_report: Any

    @property
    def found(self) -> list[DataFinding]:
        """The checks that found a problem."""
        return [f for f in self.findings if f.finding]

    def findings_dicts(self) -> list[dict[str, Any]]:
        """Every check's result, JSON-ready (the ``data_findings`` of each command)."""
        return [f.to_dict() for f in self.findings]


def prepare_logs(
    samples: pd.DataFrame, *, window: float = 2.0, repair: bool = True
) -> PreparedLogs:
    """Run the data checks on raw samples, repair (optionally), clean and cut windows.

    Parameters
    ----------
    samples : pandas.DataFrame
        Raw canonical samples (``load_logs`` or a simulated campaign's ``logs``).
    window : float
        Window length, s.
    repair : bool
        Correct what the checks find before cleaning (they are reported either way).

    Returns
    -------
    PreparedLogs

    Raises
    ------
    LogError
        Missing columns or a non-positive window (from cleaning and windows).
    """
    from energy_planner.measurements.preprocess import preprocess
    from energy_planner.measurements.windows import make_windows

    findings, fixed = check_data(samples, repair=repair)
    clean, report = preprocess(fixed)
    del fixed  # a repaired copy of the samples: not held while the windows are cut (memory)
    return PreparedLogs(make_windows(clean, duration=window), findings, repair, report)


def findings_text(findings: list[dict[str, Any]] | list[DataFinding]) -> list[str]:
    """Lines for a person: each data finding and whether it was repaired (none: one line)."""
    rows = [f if isinstance(f, dict) else f.to_dict() for f in findings]
    found = [f for f in rows if f["finding"]]
    if not found:
        return [f"data checks: no sensor problem found ({len(rows)} checks)"]
    lines = ["data findings (sensor problems, not physical effects):"]
    for f in found:
        done = "repaired" if f["repaired"] else "not repaired"
        lines.append(f"  {f['name']} [{done}]: {f['summary']}")
    return lines
