"""Old home of the data checks: :mod:`energy_planner.measurements.datacheck`.

The checks moved to the measurements layer so that calibration (``fit``) runs them as
``diagnose`` and ``discover`` do, without importing the diagnosis (data flows one way:
measurements -> calibration -> diagnosis). Its public names are re-exported here, so
``from energy_planner.diagnosis.datacheck import check_data`` keeps working.
"""

from energy_planner.measurements.datacheck import *  # noqa: F403
