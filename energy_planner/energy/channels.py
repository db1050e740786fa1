"""Extra channels a model's terms read: constants and rasters aligned to the terrain.

A fitted model may have terms such as ``load_kg * speed`` or ``speed * (ground ==
'meadow')`` that read channels the terrain does not give. :class:`Channels` gives them:

- **constants** (``--set NAME=VALUE``): a number (``load_kg=10``) or a category
  (``ground=meadow``), inputs of the compiled kernels at run time (a new value compiles
  nothing);
- **rasters** (``--channel NAME=RASTER`` or ``--channel NAME=RASTER:TABLE``): a map
  aligned to the terrain's working grid with rasterio (reprojected and resampled:
  bilinear for a numeric raster, nearest for a coded one) and sampled at every
  integration sub-step of the motion kernel. A numeric raster is interpolated bilinearly
  between cell centres, like the gradient. A raster with a value table (``code ->
  category`` or ``code -> number``, CSV or JSON) is coded: the kernel takes the nearest
  cell's code; with categories, the model's comparisons (``ground == 'meadow'``) are
  compiled once per category and chosen by the code at run time.

A term reading a channel that nobody gave is a
:class:`~energy_planner.errors.MissingChannelError` naming it and the channels given.

Channel values are typed by the model (:func:`channel_kinds`, the one place that decides):
a channel the formulas compare with strings (``ground == 'mud'``) is categorical and
takes only the categories they name; any other channel is numeric and takes numbers.
:meth:`Channels.resolve` checks the values against the model (every kernel calls it), so
``load_kg=10kg`` or ``ground=Mud`` is a :class:`~energy_planner.errors.ChannelError`
naming the channel, the value and what is valid. With ``allow_unknown_categories=True``
(``--allow-unknown-category``) a category the model does not name is priced as none of
the named ones, with a warning.

Examples
--------
>>> ch = Channels.parse(["load_kg=10", "ground=meadow"], [])
>>> ch.constants
{'load_kg': 10.0, 'ground': 'meadow'}
>>> Channels.parse(["speed=2"], [])  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
energy_planner.errors.ChannelError: --set 'speed=2': 'speed' is a motion feature ...
"""

from __future__ import annotations

import csv
import io
import json
import keyword
import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import ChannelError, ChannelIOError
from energy_planner.model.formula import MOTION_FEATURES

__all__ = [
    "Category",
    "ChannelKind",
    "ChannelRaster",
    "Channels",
    "channel_kinds",
    "read_value_table",
    "RESERVED",
]

#: Names a channel may not take: the kernel's motion features and formula constants.
RESERVED = MOTION_FEATURES | {"pi", "g"}
_TABLE_SUFFIXES = (".csv", ".json", ".txt", ".tsv")


def _check_name(name: str, where: str) -> str:
    name = name.strip()
    if not name.isidentifier() or keyword.iskeyword(name):
        raise ChannelError(
            f"{where}: channel name {name!r} is not a name (letters, digits and _, as the "
            "model's formulas write it, e.g. load_kg)"
        )
    if name in RESERVED:
        raise ChannelError(
            f"{where}: {name!r} is a motion feature or constant the kernel computes itself "
            f"({', '.join(sorted(RESERVED))}); a channel must have another name"
        )
    return name


def _parse_value(text: str, where: str) -> float | str:
    """A number if ``text`` parses as one (finite), else a category name."""
    text = text.strip()
    if not text:
        raise ChannelError(f"{where}: empty value; expected a number or a category name")
    try:
        v = float(text)
    except ValueError:
        return text
    if not math.isfinite(v):
        raise ChannelError(f"{where}: value {text!r} is not finite")
    return v


def read_value_table(path: str | Path) -> dict[float, float | str]:
    r"""Read a value table ``code -> category`` (or ``code -> number``).

    CSV (``,``, ``;`` or tab; optional header; ``#`` lines skipped): first column the
    raster code, second the category or number. JSON: an object ``{"1": "meadow", ...}``.

    Raises
    ------
    ChannelIOError
        The file does not exist or cannot be read.
    ChannelError
        A malformed line or entry (named with the file and line), a code given twice, an
        empty table, or a table mixing numbers and categories.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp(); p = os.path.join(d, "t.csv")
    >>> _ = open(p, "w").write("code,ground\n1,meadow\n2,asphalt\n")
    >>> read_value_table(p)
    {1.0: 'meadow', 2.0: 'asphalt'}
    """
    p = Path(path)
    try:
        return _read_value_table(p)
    except (ChannelError, ChannelIOError) as exc:
        exc.fields.setdefault("path", str(p))  # the file at fault, for callers
        raise


def _read_value_table(p: Path) -> dict[float, float | str]:
    """:func:`read_value_table` without the ``path`` field on its errors."""
    try:
        text = p.read_text()
    except FileNotFoundError as exc:
        raise ChannelIOError(
            f"value table {str(p)!r} does not exist (expected CSV code,category or JSON)"
        ) from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise ChannelIOError(f"cannot read value table {str(p)!r}: {exc}") from exc
    entries: list[tuple[str, Any, str]] = []  # (code text, value, where)
    if p.suffix.lower() == ".json":
        try:
            obj = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ChannelError(f"value table {str(p)!r} is not valid JSON: {exc}") from exc
        if not isinstance(obj, dict):
            raise ChannelError(
                f'value table {str(p)!r}: expected a JSON object {{"code": "category", '
                f"...}}, got {type(obj).__name__}"
            )
        for k, v in obj.items():
            if not isinstance(v, str | int | float) or isinstance(v, bool):
                raise ChannelError(
                    f"value table {str(p)!r}: code {k!r} maps to {v!r}; expected a category "
                    "name or a number"
                )
            entries.append((str(k), v, f"{str(p)!r} key {k!r}"))
    else:
        sample = text[:4096]
        delim = "\t" if "\t" in sample else (";" if ";" in sample and "," not in sample else ",")
        rows = [
            (i, row)
            for i, row in enumerate(csv.reader(io.StringIO(text), delimiter=delim), start=1)
            if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")
        ]
        if rows:
            try:
                float(rows[0][1][0])
            except (ValueError, IndexError):
                rows = rows[1:]  # a header row
        for i, row in rows:
            if len(row) < 2:
                raise ChannelError(
                    f"value table {str(p)!r} line {i}: {delim.join(row)!r} has one column; "
                    "expected code,category"
                )
            entries.append((row[0].strip(), row[1].strip(), f"{str(p)!r} line {i}"))
    table: dict[float, float | str] = {}
    for code_text, value, where in entries:
        try:
            code = float(code_text)
        except ValueError:
            raise ChannelError(
                f"value table {where}: code {code_text!r} is not a number (the raster's cell value)"
            ) from None
        if code in table:
            raise ChannelError(f"value table {where}: code {code_text} is given twice")
        val = value if isinstance(value, int | float) else _parse_value(value, where)
        table[code] = float(val) if isinstance(val, int | float) else val
    if not table:
        raise ChannelError(f"value table {str(p)!r} has no entries (expected code,category rows)")
    kinds = {isinstance(v, str) for v in table.values()}
    if len(kinds) > 1:
        raise ChannelError(
            f"value table {str(p)!r} mixes numbers and category names; use one kind "
            "(categories for a land-cover map, numbers for a coded quantity)"
        )
    return table


class Category(str):
    """A category name that is never read as a number (``Category("3")`` stays ``'3'``).

    :meth:`Channels.resolve` gives the values of categorical channels as this type.
    """

    __slots__ = ()


@dataclass(frozen=True)
class ChannelKind:
    """How a model reads one channel.

    Attributes
    ----------
    name : str
        The channel.
    categories : tuple of str or None
        The categories the model's formulas compare it with (sorted); ``None`` for a
        numeric channel.
    terms : tuple of str
        The terms that read it.
    """

    name: str
    categories: tuple[str, ...] | None
    terms: tuple[str, ...]

    @property
    def is_categorical(self) -> bool:
        """True if the formulas compare the channel with category names."""
        return self.categories is not None

    def expected(self) -> str:
        """What a value of this channel must be, in words (for messages)."""
        if self.categories is None:
            return "a number"
        return "one of the categories " + ", ".join(map(repr, self.categories))

    def reader(self) -> str:
        """The terms that read the channel, for messages."""
        return f"term(s) {', '.join(map(repr, self.terms))}"


def channel_kinds(model: Any) -> dict[str, ChannelKind]:
    """Every channel ``model`` reads and its kind, decided from the model's formulas.

    A channel compared with a string anywhere (``ground == 'mud'``) is categorical, its
    categories the strings it is compared with; any other channel is numeric. This is the
    one place that types channel values; CLI and library call it through
    :meth:`Channels.resolve`.

    Raises
    ------
    ChannelError
        A channel read both as a category and as a number (the model contradicts itself).

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> m = EnergyModel(["load_kg * speed", "speed * (ground == 'mud')"])
    >>> {k: v.categories for k, v in channel_kinds(m).items()}
    {'ground': ('mud',), 'load_kg': None}
    """
    cats: dict[str, set[str]] = {}
    numeric: dict[str, list[str]] = {}
    terms: dict[str, list[str]] = {}
    for term in model.terms:
        term_cats, term_numeric = term.parsed.channel_uses
        for name in term.parsed.variables - RESERVED:
            terms.setdefault(name, []).append(term.name)
            if name in term_cats:
                cats.setdefault(name, set()).update(term_cats[name])
            if name in term_numeric:
                numeric.setdefault(name, []).append(term.name)
    both = sorted(set(cats) & set(numeric))
    if both:
        name = both[0]
        raise ChannelError(
            f"the model reads channel {name!r} both as a category (compared with "
            f"{', '.join(map(repr, sorted(cats[name])))}) and as a number (term(s) "
            f"{', '.join(map(repr, numeric[name]))}); a channel is one or the other",
            value=name,
        )
    return {
        name: ChannelKind(
            name, tuple(sorted(cats[name])) if name in cats else None, tuple(terms[name])
        )
        for name in sorted(terms)
    }


@dataclass(frozen=True)
class ChannelRaster:
    """One raster channel: a file (with an optional value table) or aligned values.

    Parameters
    ----------
    name : str
        Channel name, as the model's formulas write it.
    path : pathlib.Path or None
        Raster file (any single-band raster rasterio opens).
    table : pathlib.Path or None
        Value table file (``code -> category`` or ``code -> number``); ``None`` for a
        numeric raster.
    values : ndarray or None
        Values on the terrain's working grid (set by :meth:`Channels.bind`, or given
        directly for a channel already on that grid): numbers, or category indices
        into ``categories`` (NaN = no value).
    categories : tuple of str or None
        Category names of a categorical channel, in index order.
    coverage : float or None
        Share of the terrain's valid cells where the channel has a value (after binding).
    """

    name: str
    path: Path | None = None
    table: Path | None = None
    values: np.ndarray | None = field(default=None, repr=False, compare=False)
    categories: tuple[str, ...] | None = None
    coverage: float | None = None

    @property
    def is_bound(self) -> bool:
        """True once the values sit on a grid."""
        return self.values is not None

    @property
    def nearest(self) -> bool:
        """True if sampled at the nearest cell (a coded raster), False if bilinear."""
        return self.table is not None or self.categories is not None

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (name, file, table, kind, sampling, coverage)."""
        return {
            "name": self.name,
            "raster": None if self.path is None else str(self.path),
            "table": None if self.table is None else str(self.table),
            "kind": "categorical" if self.categories is not None else "numeric",
            "categories": None if self.categories is None else list(self.categories),
            "sampling": "nearest" if self.nearest else "bilinear",
            "coverage": self.coverage,
        }


@dataclass(frozen=True)
class Channels:
    """Values of the extra channels a model reads: constants and rasters.

    Parameters
    ----------
    constants : mapping
        Channel name -> number or category name (``--set NAME=VALUE``).
    rasters : mapping
        Channel name -> :class:`ChannelRaster` (``--channel NAME=RASTER[:TABLE]``).
    allow_unknown_categories : bool
        Accept a category the model's formulas do not name (``--allow-unknown-category``):
        it is priced as none of the named categories, with a warning. Default: an error
        listing the valid categories.
    runtime : mapping, optional
        Set by :meth:`resolve` (leave it out): the constants the model reads and the
        categories the kernel renders for each (``None`` for a number). With it, the
        constants are kernel inputs (:meth:`kernel_layout` ``runtime=True``,
        :meth:`stack`), so a new value needs no compilation.

    Examples
    --------
    >>> Channels({"load_kg": 10}).names
    ['load_kg']
    """

    constants: Mapping[str, float | str] = field(default_factory=dict)
    rasters: Mapping[str, ChannelRaster] = field(default_factory=dict)
    allow_unknown_categories: bool = False
    #: Set by :meth:`resolve`: the constants the model reads, each with the categories
    #: the kernel renders (``None`` for a number); they enter the kernels at run time.
    runtime: Mapping[str, tuple[str, ...] | None] | None = field(
        default=None, compare=False, repr=False
    )

    def __post_init__(self) -> None:
        consts: dict[str, float | str] = {}
        for k, v in dict(self.constants).items():
            name = _check_name(str(k), f"constant {k!r}")
            if isinstance(v, bool) or not isinstance(v, int | float | str | np.number):
                raise ChannelError(
                    f"constant {name!r}: value {v!r} is not a number or a category name"
                )
            if isinstance(v, Category):
                consts[name] = v
                continue
            consts[name] = (
                _parse_value(str(v), f"constant {name!r}") if isinstance(v, str) else float(v)
            )
            if isinstance(consts[name], float) and not math.isfinite(consts[name]):
                raise ChannelError(f"constant {name!r}: value {v!r} is not finite")
        rasters: dict[str, ChannelRaster] = {}
        for k, r in dict(self.rasters).items():
            if not isinstance(r, ChannelRaster):
                raise ChannelError(f"raster channel {k!r}: expected a ChannelRaster, got {r!r}")
            rasters[_check_name(str(k), f"raster channel {k!r}")] = r
        both = sorted(set(consts) & set(rasters))
        if both:
            raise ChannelError(
                f"channel(s) {', '.join(both)} given both as a constant and as a raster; "
                "give each once"
            )
        object.__setattr__(self, "constants", consts)
        object.__setattr__(self, "rasters", rasters)

    # ------------------------------------------------------------------ building
    @classmethod
    def coerce(cls, value: Any, allow_unknown_categories: bool = False) -> Channels | None:
        """The channels of a verb's ``channels=`` keyword (None stays None).

        A :class:`Channels` as it is; a mapping of channel name to a number or a category
        name (``--set``), a :class:`pathlib.Path` of a raster or ``(raster, table)``
        paths (``--channel``), or a :class:`ChannelRaster`.

        >>> Channels.coerce({"load_kg": 10, "ground": "meadow"}).constants
        {'load_kg': 10.0, 'ground': 'meadow'}
        """
        if value is None:
            return cls(allow_unknown_categories=True) if allow_unknown_categories else None
        if isinstance(value, Channels):
            if allow_unknown_categories and not value.allow_unknown_categories:
                import dataclasses

                return dataclasses.replace(value, allow_unknown_categories=True)
            return value
        consts: dict[str, Any] = {}
        rasters: dict[str, ChannelRaster] = {}
        for name, v in dict(value).items():
            if isinstance(v, ChannelRaster):
                rasters[name] = v
            elif isinstance(v, Path):
                rasters[name] = ChannelRaster(name, v, None)
            elif isinstance(v, tuple) and len(v) == 2:
                rasters[name] = ChannelRaster(name, Path(v[0]),
                                              None if v[1] is None else Path(v[1]))  # fmt: skip
            else:
                consts[name] = v
        return cls(consts, rasters, allow_unknown_categories=allow_unknown_categories)

    @classmethod
    def parse(
        cls,
        sets: Sequence[str] = (),
        channels: Sequence[str] = (),
        *,
        allow_unknown_categories: bool = False,
    ) -> Channels:
        """Channels from the CLI strings ``NAME=VALUE`` and ``NAME=RASTER[:TABLE]``.

        A value that parses as a number is a number, anything else a category. A raster
        string ending in ``:FILE.csv`` / ``.json`` / ``.tsv`` / ``.txt`` names a value
        table (the raster is coded). Files are checked for existence here (the table
        is read); rasters are opened by :meth:`bind`.

        Raises
        ------
        ChannelError
            Malformed string (names it and the expected form), reserved or repeated name.
        ChannelIOError
            A raster or table file that does not exist.
        """
        consts: dict[str, float | str] = {}
        for s in sets:
            where = f"--set {s!r}"
            if "=" not in s:
                raise ChannelError(
                    f"{where}: expected NAME=VALUE, e.g. load_kg=10 or ground=meadow"
                )
            name, value = s.split("=", 1)
            name = _check_name(name, where)
            if name in consts:
                raise ChannelError(f"{where}: channel {name!r} is set twice")
            consts[name] = _parse_value(value, where)
        rasters: dict[str, ChannelRaster] = {}
        for s in channels:
            where = f"--channel {s!r}"
            if "=" not in s:
                raise ChannelError(
                    f"{where}: expected NAME=RASTER or NAME=RASTER:TABLE, e.g. "
                    "ground=landcover.tif:landcover.csv"
                )
            name, spec = s.split("=", 1)
            name = _check_name(name, where)
            if name in rasters or name in consts:
                raise ChannelError(f"{where}: channel {name!r} is given twice")
            raster, table = spec.strip(), None
            head, sep, tail = raster.rpartition(":")
            if sep and tail.lower().endswith(_TABLE_SUFFIXES):
                raster, table = head, tail
            if not raster:
                raise ChannelError(f"{where}: no raster file given")
            rp = Path(raster)
            if not raster.startswith("/vsi") and "://" not in raster and not rp.exists():
                raise ChannelIOError(
                    f"{where}: raster {raster!r} does not exist (expected a single-band "
                    "raster, e.g. GeoTIFF)",
                    path=raster,
                )
            tp = None if table is None else Path(table)
            if tp is not None:
                read_value_table(tp)  # fail early, naming the line
            rasters[name] = ChannelRaster(name, rp, tp)
        return cls(consts, rasters, allow_unknown_categories=allow_unknown_categories)

    # ------------------------------------------------------------------ queries
    @property
    def names(self) -> list[str]:
        """Every channel given, constants first."""
        return [*self.constants, *self.rasters]

    @property
    def is_bound(self) -> bool:
        """True when every raster has values on a grid."""
        return all(r.is_bound for r in self.rasters.values())

    def __bool__(self) -> bool:
        return bool(self.constants or self.rasters)

    def kernel_layout(self, runtime: bool = False) -> list[tuple[str, tuple[str, ...] | None]]:
        """``(name, categories or None)`` of the kernel's channel inputs, in order.

        The rasters; with ``runtime`` (channels from :meth:`resolve`) also the constants
        the model reads, after them, so that their values are inputs of the compiled
        kernel (:meth:`stack` gives them) instead of being compiled in: the kernel's
        source then depends on the model only, not on the values.
        """
        out = []
        for name, r in self.rasters.items():
            cats = r.categories
            if cats is None and r.table is not None and not r.is_bound:
                table = read_value_table(r.table)
                if all(isinstance(v, str) for v in table.values()):
                    cats = tuple(sorted(set(table.values())))  # type: ignore[arg-type]
            out.append((name, cats))
        if runtime and self.runtime is not None:
            out.extend(self.runtime.items())
        return out

    def check(self, model: Any) -> None:
        """Raise if the channels do not serve ``model``.

        A :class:`~energy_planner.errors.MissingChannelError` names every channel the
        model reads and nobody gave (and the channels given); a
        :class:`~energy_planner.errors.ChannelError` a value of the wrong kind
        (:meth:`resolve`).
        """
        ch = self.resolve(model)
        model.kernel_source(ch.constants, ch.kernel_layout())

    def resolve(self, model: Any) -> Channels:
        """These channels with their values checked against the kinds ``model`` reads.

        Numeric channels (:func:`channel_kinds`) must be numbers; categorical ones one of
        the categories the model's formulas name (a number given for a category is
        read as its text, ``3`` -> ``'3'``). A raster of a categorical channel needs a
        value table of categories; a numeric channel's table maps codes to numbers.
        Channels the model does not read are kept as they are (:meth:`unused`).

        Raises
        ------
        ChannelError
            Naming the channel, the value given and the valid values (numbers, or the
            model's categories), unless ``allow_unknown_categories`` lets an unknown
            category through (then a ``UserWarning`` says it is priced as none of them).

        Examples
        --------
        >>> from energy_planner.model import EnergyModel
        >>> m = EnergyModel(["load_kg * speed"], {"load_kg * speed": 7.0})
        >>> Channels({"load_kg": "10kg"}).resolve(m)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        energy_planner.errors.ChannelError: channel 'load_kg' = '10kg': ... expected a number...
        """
        kinds = channel_kinds(model)
        consts: dict[str, float | str] = {}
        runtime: dict[str, tuple[str, ...] | None] = {}
        for name, v in self.constants.items():
            kind = kinds.get(name)
            if kind is None:
                consts[name] = v
                continue
            runtime[name] = kind.categories
            if not kind.is_categorical:
                if isinstance(v, str):
                    unit = re.fullmatch(r"\s*[-+]?[\d.]+(?:e[-+]?\d+)?\s*([^\d\s].*)", v, re.I)
                    hint = (
                        f" (give the number alone, in the unit the model was fitted with; "
                        f"{unit.group(1)!r} is not part of it)"
                        if unit
                        else ""
                    )
                    raise ChannelError(
                        f"channel {name!r} = {v!r}: the model reads {name} as a number "
                        f"({kind.reader()}); expected a number, e.g. --set {name}=10{hint}",
                        value=v,
                        expected="a number",
                        param="--set",
                        channel=name,
                    )
                consts[name] = v
            else:
                text = v if isinstance(v, str) else f"{v:g}"
                self._check_categories(kind, [text], f"channel {name!r}")
                consts[name] = Category(text)
                if text not in (kind.categories or ()):  # allowed unknown: its own slot
                    runtime[name] = (*(kind.categories or ()), text)
        for name, r in self.rasters.items():
            kind = kinds.get(name)
            if kind is not None:
                self._check_raster(kind, r)
        return replace(self, constants=consts, runtime=runtime)

    def _check_categories(
        self, kind: ChannelKind, given: Sequence[str], where: str, table: bool = False
    ) -> None:
        """Error (or warning when allowed) for categories ``kind`` does not name.

        With ``table`` (the categories of a raster's value table, which lists every class
        of the map) a category the model does not name is its baseline and accepted; only
        a near miss (equal to a named category but for case or spaces) or a table that
        names none of the model's categories is refused.
        """
        cats = kind.categories or ()
        unknown = [c for c in given if c not in cats]
        near = {c: [k for k in cats if k.casefold() == c.strip().casefold()] for c in unknown}
        if table and not any(near.values()) and len(unknown) < len(given):
            return
        if table and any(near.values()):
            unknown = [c for c in unknown if near[c]]
        if not unknown:
            return
        alike = "; ".join(f"{c!r} is not {k[0]!r} (categories match exactly)" for c, k in
                          near.items() if k)  # fmt: skip
        msg = (
            f"{where}: {', '.join(map(repr, unknown))} "
            f"{'is not a category' if len(unknown) == 1 else 'are not categories'} the model "
            f"names; the model compares {kind.name} with {', '.join(map(repr, cats))} "
            f"({kind.reader()})" + (f"; {alike}" if alike else "")
        )
        if not self.allow_unknown_categories:
            raise ChannelError(
                f"{msg}. Give one of them, or --allow-unknown-category to price "
                "an unknown category as none of them",
                value=unknown[0],
                expected=kind.expected(),
                param="--channel" if where.startswith("raster") else "--set",
                channel=kind.name,
            )
        warnings.warn(
            f"{msg}: priced as none of them (--allow-unknown-category)",
            UserWarning,
            stacklevel=4,
        )

    def _check_raster(self, kind: ChannelKind, r: ChannelRaster) -> None:
        """A raster channel's kind (numeric or coded categories) against the model's."""
        cats = r.categories
        table_kind = None
        if cats is None and r.table is not None:
            table = read_value_table(r.table)
            if all(isinstance(v, str) for v in table.values()):
                cats = tuple(sorted(set(table.values())))  # type: ignore[arg-type]
            else:
                table_kind = "numbers"
        where = f"raster channel {kind.name!r}" + ("" if r.path is None else f" ({r.path})")
        if not kind.is_categorical:
            if cats is not None:
                raise ChannelError(
                    f"{where}: the model reads {kind.name} as a number ({kind.reader()}), "
                    f"but the raster's value table {str(r.table)!r} maps codes to the "
                    f"categories {', '.join(map(repr, cats))}; give a numeric raster, or a "
                    "table of code,number rows",
                    value=list(cats),
                    expected="a number",
                    param="--channel",
                    channel=kind.name,
                )
            return
        if cats is None:
            got = (
                f"its value table {str(r.table)!r} maps codes to numbers"
                if table_kind
                else "it is given as numbers per cell (no value table)"
            )
            raise ChannelError(
                f"{where}: the model compares {kind.name} with the categories "
                f"{', '.join(map(repr, kind.categories or ()))} ({kind.reader()}), but "
                f"{got}; a raster of category codes needs a table of code,category rows: "
                f"--channel {kind.name}=RASTER:TABLE (e.g. a CSV with the line "
                f"1,{(kind.categories or ('category',))[0]}); or give one category for the "
                f"whole map, --set {kind.name}={(kind.categories or ('category',))[0]}",
                expected=kind.expected(),
                param="--channel",
                channel=kind.name,
            )
        self._check_categories(kind, list(cats), where, table=True)

    def unused(self, model: Any) -> list[str]:
        """Channels given that the model does not read (worth a note)."""
        return [n for n in self.names if n not in model.variables]

    def runtime_values(self) -> np.ndarray:
        """The constants' kernel inputs, in :meth:`kernel_layout` ``runtime=True`` order.

        A number, or the index of the category in its layout; empty before
        :meth:`resolve`. The kernels read them after the rasters.
        """
        out = [
            float(cats.index(self.constants[name])) if cats is not None
            else float(self.constants[name])
            for name, cats in (self.runtime or {}).items()
        ]  # fmt: skip
        return np.array(out, dtype=np.float64)

    def stack(self, shape: tuple[int, int], runtime: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The channels for the kernel: ``(values (k, rows, cols) float64, nearest (k,))``.

        The rasters; with ``runtime``, also the constants of :meth:`kernel_layout`
        ``runtime=True`` (a number, or the index of the category in its layout). Without
        rasters the constants are a ``(k, 1, 1)`` array, which the kernels read as
        uniform (:func:`energy_planner.energy.kernels.sample_channels`); with rasters
        each is a layer of ``shape`` holding its value.
        """
        consts = []
        if runtime and self.runtime is not None:
            values = self.runtime_values()
            consts = list(zip(values.tolist(), self.runtime.values(), strict=True))
        if not self.rasters:
            if not consts:
                return np.zeros((0, 1, 1)), np.zeros(0, dtype=np.bool_)
            values = np.array([v for v, _ in consts], dtype=np.float64).reshape(-1, 1, 1)
            return values, np.array([c is not None for _, c in consts], dtype=np.bool_)
        arrays = []
        for r in self.rasters.values():
            if r.values is None:
                raise ChannelError(f"raster channel {r.name!r} is not aligned yet: call bind()")
            if r.values.shape != tuple(shape):
                raise ChannelError(
                    f"raster channel {r.name!r} has shape {r.values.shape}, the terrain grid "
                    f"{tuple(shape)}; bind it to this terrain"
                )
            arrays.append(np.asarray(r.values, dtype=np.float64))
        arrays += [np.full(tuple(shape), v) for v, _ in consts]
        nearest = np.array(
            [r.nearest for r in self.rasters.values()] + [c is not None for _, c in consts],
            dtype=np.bool_,
        )
        return np.ascontiguousarray(np.stack(arrays)), nearest

    def value_samples(self, n: int = 5) -> dict[str, np.ndarray]:
        """A few values of each channel.

        Constants: the value; numeric rasters: ``n`` values from their minimum to their
        maximum; categorical: every category.
        """
        out: dict[str, np.ndarray] = {k: np.array([v]) for k, v in self.constants.items()}
        for name, r in self.rasters.items():
            v = None if r.values is None else np.asarray(r.values, dtype=float)
            if r.categories is not None:
                out[name] = np.array(r.categories)
            elif v is not None and np.isfinite(v).any():
                out[name] = np.linspace(np.nanmin(v), np.nanmax(v), n)
            else:
                out[name] = np.array([0.0])
        return out

    def describe(self) -> dict[str, Any]:
        """JSON-ready description of the channels."""
        return {
            "constants": dict(self.constants),
            "rasters": [r.describe() for r in self.rasters.values()],
        }

    # ------------------------------------------------------------------ alignment
    def bind(self, terrain: Any) -> Channels:
        """These channels with every raster aligned to ``terrain``'s working grid.

        Rasters already bound to a grid of the terrain's shape are kept as they are.

        Raises
        ------
        ChannelIOError
            A raster cannot be opened.
        ChannelError
            Several bands; codes missing from the value table; no overlap with the DEM.
        """
        return self.bind_grid(
            terrain.shape,
            terrain.transform,
            terrain.crs,
            default_crs=getattr(terrain, "source_crs", None),
            valid=getattr(terrain, "valid", None),
        )

    def bind_grid(
        self,
        shape: tuple[int, int],
        transform: Any,
        crs: Any,
        *,
        default_crs: Any = None,
        valid: np.ndarray | None = None,
        quiet: bool = False,
    ) -> Channels:
        """As :meth:`bind`, onto any north-up grid ``(shape, transform, crs)``.

        ``default_crs`` is assumed for a raster without a CRS; ``valid`` (mask of the
        grid's valid cells) is used to report coverage; ``quiet`` skips the warnings
        (used per block by the out-of-core energy map).
        """
        rasters = {}
        for name, r in self.rasters.items():
            if r.values is not None and r.values.shape == tuple(shape):
                rasters[name] = r
                continue
            if r.path is None:
                raise ChannelError(
                    f"raster channel {name!r} has values of shape {r.values.shape} (not the "
                    f"grid's {tuple(shape)}) and no file to resample from"
                )
            values, cats = _align(r, shape, transform, crs, default_crs, quiet)
            cov = None
            if valid is not None and valid.any():
                cov = float(np.isfinite(values[valid]).mean())
                if cov == 0.0:
                    raise ChannelError(
                        f"raster channel {name!r} ({r.path}) has no value on any cell of "
                        "the DEM: do they overlap (CRS, extent)?"
                    )
                if cov < 1.0 and not quiet:
                    warnings.warn(
                        f"raster channel {name!r} ({r.path}) has no value on "
                        f"{100 * (1 - cov):.1f}% of the DEM's valid cells; motions there "
                        "cost inf (not walkable)",
                        UserWarning,
                        stacklevel=2,
                    )
            rasters[name] = replace(r, values=values, categories=cats, coverage=cov)
        return replace(self, rasters=rasters)


def _align(
    r: ChannelRaster, shape: Any, transform: Any, crs: Any, default_crs: Any, quiet: bool
) -> tuple[np.ndarray, tuple[str, ...] | None]:
    """Reproject/resample one raster onto the grid; map codes through its table."""
    import rasterio
    from rasterio.crs import CRS
    from rasterio.errors import RasterioIOError
    from rasterio.warp import Resampling, reproject

    name = str(r.path)
    try:
        src = rasterio.open(name)
    except RasterioIOError as exc:
        raise ChannelIOError(
            f"cannot open channel raster {name!r} ({r.name}): {exc}", path=name
        ) from exc
    with src:
        if src.count != 1:
            raise ChannelError(
                f"channel raster {name!r} ({r.name}) has {src.count} bands; give a "
                "single-band raster (gdal_translate -b N in.tif out.tif)"
            )
        src_crs = src.crs
        if src_crs is None:
            src_crs = default_crs if default_crs is not None else crs
            if not quiet:
                warnings.warn(
                    f"channel raster {name!r} ({r.name}) has no CRS; taking it as the DEM's "
                    f"({src_crs or 'local metres'})",
                    UserWarning,
                    stacklevel=4,
                )
        if src_crs is None and crs is None:
            src_crs = dst_crs = CRS.from_epsg(3857)  # both local: any common frame will do
        else:
            dst_crs = crs if crs is not None else src_crs
        coded = r.table is not None
        dst = np.full(tuple(shape), np.nan, dtype=np.float64)
        reproject(
            source=rasterio.band(src, 1),
            destination=dst,
            src_transform=src.transform,
            src_crs=src_crs,
            src_nodata=src.nodata,
            dst_transform=transform,
            dst_crs=dst_crs,
            dst_nodata=np.nan,
            resampling=Resampling.nearest if coded else Resampling.bilinear,
        )
        scale = float(src.scales[0]) if src.scales and src.scales[0] is not None else 1.0
        offset = float(src.offsets[0]) if src.offsets and src.offsets[0] is not None else 0.0
    if not coded:  # values as GDAL describes them (codes are the stored ones)
        if scale != 1.0 or offset != 0.0:
            dst = dst * scale + offset
        return dst, None
    table = read_value_table(r.table)  # type: ignore[arg-type]
    codes = np.array(sorted(table), dtype=np.float64)
    ok = np.isfinite(dst)
    idx = np.searchsorted(codes, dst[ok]).clip(0, len(codes) - 1)
    known = codes[idx] == dst[ok]
    if not known.all():
        bad = np.unique(dst[ok][~known])
        raise ChannelError(
            f"channel raster {name!r} ({r.name}) has code(s) "
            f"{', '.join(f'{b:g}' for b in bad[:10])} that value table {str(r.table)!r} does "
            f"not list (it has {', '.join(f'{c:g}' for c in codes[:20])}); add them to the "
            "table or make them the raster's nodata"
        )
    values = [table[c] for c in codes]
    out = np.full(dst.shape, np.nan)
    if all(isinstance(v, str) for v in values):
        cats = tuple(sorted(set(values)))  # type: ignore[arg-type]
        lut = np.array([cats.index(v) for v in values], dtype=np.float64)  # type: ignore[arg-type]
        out[ok] = lut[idx]
        return out, cats
    out[ok] = np.array(values, dtype=np.float64)[idx]
    return out, None
