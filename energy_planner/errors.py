"""Exception hierarchy with structured fields.

Every class here derives from :class:`EnergyPlannerError` and from the builtin that fits
it best, as rasterio does (``RasterioIOError(RasterioError, OSError)``), so callers can
catch either. Errors raised on purpose by the library use these classes; a bug may
still surface as a builtin exception (``tests/test_fuzz_loaders.py`` feeds malformed
files to the public loaders to catch those).

Messages name the offending value, the file and what was expected, for people. The same
facts are attributes, for programs: ``err.value``, ``err.path``, ``err.expected`` and any
other keyword given when raising (``err.endpoint``, ``err.limit``, ``err.column``, ...),
all collected in ``err.fields``. Callers (the CLI, the planner) read the fields and never
parse the message.

Field names used across the project (use these when they fit):

============  =================================================================
``value``     the offending value (a number, a coordinate pair, a cell value)
``path``      the file it came from (``str``)
``expected``  what was expected, in words (``"longitude, latitude in degrees"``)
``param``     the option or argument at fault (``"band"``, ``"start"``)
``endpoint``  ``"start"`` or ``"goal"``
``limit``     the limit broken: ``"map"``, ``"nodata"``, ``"max_slope_deg"``,
              ``"max_cross_slope_deg"``, ``"keep_out"``, ``"max_backward_slope_deg"``,
              ``"max_crab_deg"``
``column``    a table column; ``row`` its 0-based row; ``run`` a run id
``crs``       a CRS (``str``); ``bounds`` ``(xmin, ymin, xmax, ymax)`` in it
``hint``      a remedy, in words
============  =================================================================

Examples
--------
>>> try:
...     raise DEMError("band 3 is out of range", value=3, path="a.tif", param="band",
...                    expected="a band in 1..1")
... except ValueError as err:  # also an EnergyPlannerError
...     err.value, err.param, err.fields["path"], str(err)
(3, 'band', 'a.tif', 'band 3 is out of range')
>>> DEMError("no fields").fields
{}
>>> DEMError("x").endpoint is None  # a usual field not given reads as None
True
>>> DEMError("x", which=2).which
2
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "FIELD_NAMES",
    "ChannelError",
    "ChannelIOError",
    "CoordinateError",
    "DEMError",
    "DEMIOError",
    "EnergyMapError",
    "EnergyPlannerError",
    "FitError",
    "FormulaError",
    "EnergyPlannerWarning",
    "GeometryOutsideMapWarning",
    "ReachEdgeWarning",
    "InvalidStateError",
    "LogError",
    "LogIOError",
    "MissingChannelError",
    "ModelError",
    "MotionCostError",
    "NonPositivePowerError",
    "OutputError",
    "OutsideMapError",
    "PlanningConfigError",
    "PlanningError",
    "RasterTooLargeError",
    "RemovedAPIError",
    "RouteNameError",
    "UnknownNameError",
    "WaypointError",
    "WaypointIOError",
    "extent_text",
    "fmt_num",
]


#: The usual structured field names; an absent one reads as None on any error.
FIELD_NAMES: frozenset[str] = frozenset(
    {
        "value",
        "path",
        "expected",
        "param",
        "endpoint",
        "limit",
        "column",
        "row",
        "run",
        "crs",
        "bounds",
        "hint",
        "shape",
        "size_bytes",
        "cap_bytes",
        "values",
        "rows",
        "runs",
    }
)


class EnergyPlannerError(Exception):
    """Base class of all energy_planner errors.

    Parameters
    ----------
    message : str
        The human-readable message (``str(err)``): the value, the file, what was expected.
    value : object, optional
        The offending value.
    path : str or os.PathLike, optional
        The file the value came from (stored as ``str``).
    expected : str, optional
        What was expected, in words.
    **fields
        Any other structured facts (see the module docstring for the usual names,
        :data:`FIELD_NAMES`).

    Attributes
    ----------
    message : str
        As given.
    fields : dict
        Every structured field given (``value``, ``path``, ``expected`` only when not
        None). Each key is also readable as an attribute; a usual field name
        (:data:`FIELD_NAMES`) that was not given reads as None.
    """

    def __init__(
        self,
        message: str = "",
        *,
        value: Any = None,
        path: Any = None,
        expected: str | None = None,
        **fields: Any,
    ) -> None:
        super().__init__(message)
        self.message = str(message)
        known = {"value": value, "path": None if path is None else str(path), "expected": expected}
        self.fields: dict[str, Any] = {k: v for k, v in known.items() if v is not None}
        self.fields.update(fields)

    def __getattr__(self, name: str) -> Any:
        # only called when normal lookup fails: a given field, or None for a usual
        # field name not given; anything else is a real AttributeError (so that
        # hasattr() probes by other tools, e.g. IPython's _render_traceback_, stay False)
        fields = self.__dict__.get("fields", {})
        if name in fields:
            return fields[name]
        if name in FIELD_NAMES:
            return None
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __str__(self) -> str:
        return self.message

    def __reduce__(self) -> tuple[Any, ...]:
        # keep the fields through pickle/copy (keyword-only arguments are not in args)
        return (_rebuild, (type(self), self.message, self.fields))

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form for ``--json`` error output: type, message and fields.

        Values that are not JSON types are given as ``repr`` strings.

        Examples
        --------
        >>> d = OutsideMapError("start is off the map", endpoint="start", value=(1.0, 2.0))
        >>> d.to_dict()  # doctest: +NORMALIZE_WHITESPACE
        {'error': 'OutsideMapError', 'message': 'start is off the map',
         'value': [1.0, 2.0], 'endpoint': 'start'}
        """
        return {
            "error": type(self).__name__,
            "message": self.message,
            **{k: _plain(v) for k, v in self.fields.items()},
        }


def _rebuild(cls: type, message: str, fields: dict[str, Any]) -> EnergyPlannerError:
    """Unpickle an :class:`EnergyPlannerError` with its fields."""
    return cls(message, **fields)


def _plain(v: Any) -> Any:
    """JSON-friendly copy of a field value."""
    if v is None or isinstance(v, bool | int | float | str):
        return v
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    try:  # numpy scalars and arrays
        import numpy as np

        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, np.ndarray):
            return _plain(v.tolist())
    except ImportError:  # pragma: no cover
        pass
    return repr(v)


class DEMError(EnergyPlannerError, ValueError):
    """A DEM cannot be used as given (bad band, all nodata, unusable CRS, ...)."""


class DEMIOError(EnergyPlannerError, OSError):
    """A DEM file cannot be found or opened."""


class OutsideMapError(EnergyPlannerError, ValueError):
    """A position lies outside the map or on nodata."""


class ModelError(EnergyPlannerError, ValueError):
    """An energy model is malformed: unknown term, bad coefficient, bad schema version."""


class FormulaError(ModelError):
    """A term formula cannot be parsed or names an unknown variable or function."""


class NonPositivePowerError(ModelError):
    """A model prices a walking motion at zero or negative power (names the term)."""


class LogError(EnergyPlannerError, ValueError):
    """A robot log is malformed: missing column, time going backwards, absurd values."""


class LogIOError(EnergyPlannerError, OSError):
    """A robot log file cannot be found or read."""


class OutputError(EnergyPlannerError, OSError):
    """An output cannot be written: an unwritable folder, a full disk, a folder as a file."""


class FitError(EnergyPlannerError, ValueError):
    """A fit cannot be made: too little data, a term the data cannot support."""


class PlanningError(EnergyPlannerError, RuntimeError):
    """No valid plan: start/goal invalid, no solution within the budget."""


class PlanningConfigError(PlanningError, ValueError):
    """A planning request is malformed: unknown planner, bad keep-out file, bad pose."""


class InvalidStateError(PlanningError, ValueError):
    """A start or goal breaks a limit (outside the map, too steep, in a keep-out area)."""


class RemovedAPIError(EnergyPlannerError, ImportError):
    """A name that was removed; the message says what replaces it."""


class CoordinateError(OutsideMapError):
    """Coordinates that cannot be converted to the map's working grid.

    Typically metric coordinates given for a DEM in longitude/latitude (or the other way
    round). Fields: ``value`` (the coordinates), ``crs`` and ``bounds`` (the DEM's CRS and
    its bounds in that CRS), ``expected``.
    """


class RasterTooLargeError(DEMError, MemoryError):
    """A raster whose decoded size would pass the memory cap; refused before reading.

    Fields: ``shape``, ``size_bytes`` (decoded, float64), ``cap_bytes``, ``path``, ``hint``.
    The cap is ``ENERGY_PLANNER_MEMORY_CAP`` (see :func:`energy_planner.terrain.memory_cap`).
    """


class WaypointError(EnergyPlannerError, ValueError):
    """A waypoint or path file is malformed: missing column, bad value, wrong geometry."""


class WaypointIOError(EnergyPlannerError, OSError):
    """A waypoint or path file cannot be found, read or written."""


class UnknownNameError(EnergyPlannerError, KeyError):
    """A name looked up among a fixed set (a preprocessing step, ...) does not exist.

    ``str(err)`` is the message (not ``KeyError``'s quoted repr). Fields: ``value`` (the
    name), ``expected`` (the valid names).
    """


class ChannelError(EnergyPlannerError, ValueError):
    """An extra channel (``--set`` / ``--channel``) is malformed, unreadable or missing."""


class MissingChannelError(ChannelError, FormulaError):
    """A model term reads a channel that was not given.

    Attributes
    ----------
    missing : list of str
        Names of the channels nobody gave.
    """

    def __init__(self, message: str = "", *, missing: list[str] | None = None, **fields) -> None:
        super().__init__(message, missing=list(missing or []), **fields)


class MotionCostError(EnergyPlannerError, ValueError):
    """A motion cost is configured with bad values (speed, yaw rate, mask shape)."""


class ChannelIOError(EnergyPlannerError, OSError):
    """A channel raster or value table cannot be found or opened."""


class RouteNameError(EnergyPlannerError, KeyError):
    """A route comparison has no route of that name (the message names the valid ones)."""


class EnergyMapError(EnergyPlannerError, ValueError):
    """An energy map cannot be made as asked (bad headings, out-of-core on a lon/lat DEM)."""


class EnergyPlannerWarning(EnergyPlannerError, UserWarning):
    """A warning with structured fields, and a remedy for each door.

    ``api_hint`` is a remedy in Python terms (a function argument): ``str()`` ends with
    it. The command line, which has no such argument, shows :meth:`cli_text` instead:
    the message and ``cli_hint`` (an option the command has), or no remedy.

    Examples
    --------
    >>> w = EnergyPlannerWarning("sign flipped.", api_hint="Pass keep=True.")
    >>> str(w), w.cli_text()
    ('sign flipped. Pass keep=True.', 'sign flipped.')
    """

    def __str__(self) -> str:
        hint = self.fields.get("api_hint")
        return f"{self.message} {hint}" if hint else self.message

    def cli_text(self) -> str:
        """The message as the command line prints it (with ``cli_hint`` if given)."""
        hint = self.fields.get("cli_hint")
        return f"{self.message} {hint}" if hint else self.message


class GeometryOutsideMapWarning(EnergyPlannerError, UserWarning):
    """A geometry input (a keep-out polygon, ...) lies wholly outside the map.

    It cannot affect the result; most often its coordinates are in another CRS than
    the one it declares (or, without a declaration, than RFC 7946's longitude/latitude).
    """


class ReachEdgeWarning(EnergyPlannerError, UserWarning):
    """The area reached within a budget runs into the edge of the map or of its nodata.

    Beyond that edge the map says nothing: the true reachable area may be larger than the
    one reported. Fields: ``cells`` (reached cells within the budget that touch the edge),
    ``map_edge_cells`` and ``nodata_edge_cells`` (the two kinds; a cell may be both) and
    ``budget_j``.
    """


def fmt_num(v: float, sig: int = 7, max_decimals: int = 6) -> str:
    """A number for people: fixed notation, about ``sig`` significant digits, no exponent.

    Examples
    --------
    >>> fmt_num(5000000.0), fmt_num(5000200.25), fmt_num(3.123456789), fmt_num(-0.5)
    ('5000000', '5000200', '3.123457', '-0.5')
    >>> fmt_num(float("nan")), fmt_num(12.0)
    ('nan', '12')
    """
    import math

    v = float(v)
    if not math.isfinite(v):
        return str(v)
    if v == 0:
        return "0"
    mag = int(math.floor(math.log10(abs(v))))
    dec = min(max_decimals, max(0, sig - 1 - mag))
    text = f"{v:.{dec}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def extent_text(bounds: tuple[float, float, float, float], crs: Any) -> str:
    """``(xmin, ymin, xmax, ymax)`` in ``crs`` for messages, with a lon/lat hint.

    Examples
    --------
    >>> extent_text((499980.0, 5e6, 500200.0, 5000200.0), "EPSG:32631")
    'x 499980 .. 500200, y 5000000 .. 5000200 in EPSG:32631 (projected, metres: give x,y in this CRS, not longitude/latitude)'
    >>> extent_text((2.5, 44.0, 2.6, 44.1), "EPSG:4326")
    'lon 2.5 .. 2.6, lat 44 .. 44.1 in EPSG:4326 (geographic: give longitude,latitude in degrees)'
    """  # noqa: E501
    x0, y0, x1, y1 = (fmt_num(b) for b in bounds)
    geographic = False
    if crs is not None:
        try:
            from rasterio.crs import CRS

            geographic = bool(CRS.from_user_input(crs).is_geographic)
        except Exception:  # noqa: BLE001 - an unknown CRS: say it is projected
            geographic = False
    if crs is None:
        return f"x {x0} .. {x1}, y {y0} .. {y1} (local metres, no CRS)"
    if geographic:
        return (
            f"lon {x0} .. {x1}, lat {y0} .. {y1} in {crs} (geographic: give longitude,latitude "
            "in degrees)"
        )
    return (
        f"x {x0} .. {x1}, y {y0} .. {y1} in {crs} (projected, metres: give x,y in this CRS, "
        "not longitude/latitude)"
    )
