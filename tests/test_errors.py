"""The error hierarchy: every project error class has the base and a builtin base,
and the structured fields survive raising, pickling and JSON."""

from __future__ import annotations

import importlib
import json
import pickle
import pkgutil

import pytest

import energy_planner
from energy_planner import errors
from energy_planner.errors import (
    CoordinateError,
    DEMError,
    DEMIOError,
    EnergyPlannerError,
    InvalidStateError,
    OutsideMapError,
    RasterTooLargeError,
)

BUILTINS = (
    ValueError,
    OSError,
    RuntimeError,
    MemoryError,
    KeyError,
    TypeError,
    LookupError,
    ImportError,
    UserWarning,  # project warnings (GeometryOutsideMapWarning)
)


def _project_error_classes() -> list[type]:
    """Every public exception class defined in an importable energy_planner module."""
    found = {}
    for info in pkgutil.walk_packages(energy_planner.__path__, "energy_planner."):
        try:
            mod = importlib.import_module(info.name)
        except ImportError:  # an optional dependency (e.g. OMPL) is missing
            continue
        for obj in list(vars(mod).values()):  # a snapshot: a background import may add names
            # private classes (leading underscore) are internal control flow that never
            # leaves its module (e.g. rosbag's fallback signal), not errors users see
            if (
                isinstance(obj, type)
                and issubclass(obj, BaseException)
                and obj.__module__.startswith("energy_planner")
                and not obj.__name__.startswith("_")
            ):
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return [found[k] for k in sorted(found)]


@pytest.mark.parametrize("cls", _project_error_classes(), ids=lambda c: c.__qualname__)
def test_every_error_has_project_and_builtin_base(cls):
    assert issubclass(cls, EnergyPlannerError), f"{cls} does not derive from the base"
    if cls is not EnergyPlannerError:
        assert issubclass(cls, BUILTINS), f"{cls} has no builtin base besides Exception"


def test_errors_module_lists_its_classes():
    classes = {
        n for n, o in vars(errors).items() if isinstance(o, type) and issubclass(o, BaseException)
    }
    assert classes <= set(errors.__all__)


def test_fields_are_attributes_and_message_is_str():
    e = InvalidStateError(
        "goal is too steep: 31.2 deg > 20 deg",
        endpoint="goal",
        limit="max_slope_deg",
        value=31.2,
        expected="<= 20 deg",
    )
    assert (e.endpoint, e.limit, e.value, e.expected) == (
        "goal",
        "max_slope_deg",
        31.2,
        "<= 20 deg",
    )
    assert str(e) == "goal is too steep: 31.2 deg > 20 deg"
    assert e.path is None and e.row is None
    with pytest.raises(AttributeError):
        _ = e.not_a_field_name


def test_fields_survive_pickle_and_json():
    e = DEMIOError("cannot open 'a.tif'", path="a.tif", hint="check the path")
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is DEMIOError and back.fields == e.fields and str(back) == str(e)
    import numpy as np

    c = CoordinateError("bad", value=np.array([1.5, 2.0]), bounds=(0, 0, 1, 1))
    assert json.loads(json.dumps(c.to_dict())) == {
        "error": "CoordinateError",
        "message": "bad",
        "value": [1.5, 2.0],
        "bounds": [0, 0, 1, 1],
    }


def test_builtin_catch_still_works():
    with pytest.raises(OSError):
        raise DEMIOError("x", path="p")
    with pytest.raises(MemoryError):
        raise RasterTooLargeError("x", size_bytes=1)
    with pytest.raises(DEMError):
        raise RasterTooLargeError("x")
    with pytest.raises(OutsideMapError):
        raise CoordinateError("x")
