"""Old home of the data checks: :mod:`energy_planner.measurements.datacheck`.

The checks moved to the measurements layer so that calibration (``fit``) runs them as
``diagnose`` and ``discover`` do, without importing the diagnosis (data flows one way:
measurements -> calibration -> diagnosis). This name is the same module object, so
``from energy_planner.diagnosis.datacheck import check_data`` keeps working.
"""

import sys

from energy_planner.measurements import datacheck as _datacheck

sys.modules[__name__] = _datacheck
