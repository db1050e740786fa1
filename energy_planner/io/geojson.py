"""GeoJSON in and out, with the CRS of every coordinate known.

Reading (:func:`read_geometries`) follows RFC 7946: coordinates are WGS 84 longitude,
latitude (``OGC:CRS84``) unless the document declares another CRS with the 2008 ``crs``
member (what GDAL and QGIS write for projected data) or ``properties.crs``. The
geometries come back as :class:`Geometries`, a list that carries that CRS, so that
whoever places them on a map reprojects them (:func:`reproject_geometries`).

Writing (:func:`feature_collection`, :func:`write_geojson`) gives RFC 7946 by default:
coordinates reprojected to longitude, latitude and no ``crs`` member, which every GeoJSON
reader (QGIS, geopandas, web maps) places correctly. ``native=True`` keeps the
coordinates in their own (the DEM's) CRS and declares it with the ``crs`` member.

Examples
--------
>>> from shapely.geometry import Point
>>> doc = feature_collection([(Point(500000, 0), {"name": "a"})], crs="EPSG:32631")
>>> doc["features"][0]["geometry"]["coordinates"], "crs" in doc
((3.0, 0.0), False)
>>> doc = feature_collection([(Point(500000, 0), {})], crs="EPSG:32631", native=True)
>>> doc["features"][0]["geometry"]["coordinates"], doc["crs"]["properties"]["name"]
((500000.0, 0.0), 'EPSG:32631')
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import PlanningConfigError
from energy_planner.io.atomic import write_text

__all__ = [
    "RFC7946_CRS",
    "Geometries",
    "crs_name",
    "declared_crs",
    "feature_collection",
    "read_geometries",
    "reproject_geometries",
    "reproject_xy",
    "write_geojson",
    "x_axis_angle",
]

#: The CRS of RFC 7946 GeoJSON: WGS 84 longitude, latitude (in that order).
RFC7946_CRS = "OGC:CRS84"


class Geometries(tuple):
    """Shapely geometries (a tuple) with the CRS of their coordinates (``.crs``).

    ``source`` names the file they came from, for messages.

    Examples
    --------
    >>> from shapely.geometry import Point
    >>> g = Geometries([Point(3, 45)], crs="OGC:CRS84", source="ko.geojson")
    >>> len(g), g.crs, isinstance(g, tuple)
    (1, 'OGC:CRS84', True)
    """

    crs: str | None
    source: str

    def __new__(
        cls, geoms: Iterable[Any] = (), crs: str | None = None, source: str = ""
    ) -> Geometries:
        """The geometries ``geoms`` in CRS ``crs``, read from ``source``."""
        obj = super().__new__(cls, tuple(geoms))
        obj.crs = crs
        obj.source = source
        return obj


def crs_name(crs: Any) -> str | None:
    """Short name of a CRS: ``"EPSG:n"`` when it has one, else its WKT; None for None.

    Examples
    --------
    >>> crs_name("EPSG:4326"), crs_name(None)
    ('EPSG:4326', None)
    """
    if crs is None:
        return None
    if isinstance(crs, str):
        return crs
    try:
        epsg = crs.to_epsg()
    except Exception:  # noqa: BLE001 - any CRS object without an EPSG code
        epsg = None
    if epsg:
        return f"EPSG:{epsg}"
    to_wkt = getattr(crs, "to_wkt", None)
    return to_wkt() if callable(to_wkt) else str(crs)


def declared_crs(doc: Mapping[str, Any], props: Mapping[str, Any] | None = None) -> str | None:
    """The CRS a GeoJSON document names (2008 ``crs`` member, else ``props["crs"]``).

    URNs are shortened: ``urn:ogc:def:crs:EPSG::32631`` -> ``EPSG:32631``,
    ``urn:ogc:def:crs:OGC:1.3:CRS84`` -> ``OGC:CRS84``.

    Examples
    --------
    >>> declared_crs({"crs": {"type": "name",
    ...               "properties": {"name": "urn:ogc:def:crs:EPSG::32631"}}})
    'EPSG:32631'
    >>> declared_crs({}) is None
    True
    """
    name = None
    crs = doc.get("crs")
    if isinstance(crs, dict) and isinstance(crs.get("properties"), dict):
        name = crs["properties"].get("name")
    if (not isinstance(name, str) or not name) and props:
        name = props.get("crs")
    if not isinstance(name, str) or not name:
        return None
    parts = name.split(":")
    if name.lower().startswith("urn:ogc:def:crs:") and len(parts) >= 6 and parts[-1]:
        return f"{parts[4]}:{parts[-1]}"
    return name


def _same_crs(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return True
    from rasterio.crs import CRS

    ca, cb = CRS.from_user_input(a), CRS.from_user_input(b)
    if ca == cb:
        return True
    wgs = CRS.from_epsg(4326)
    # OGC:CRS84 and EPSG:4326 are the same datum; only the axis order differs, and
    # rasterio/PROJ transforms use x = longitude for both
    return {ca.to_epsg() or ca.to_string(), cb.to_epsg() or cb.to_string()} <= {
        4326,
        wgs.to_string(),
        "OGC:CRS84",
    }


def reproject_xy(src: Any, dst: Any, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates from CRS ``src`` to CRS ``dst`` (x = longitude for geographic CRSs).

    A point PROJ cannot convert (a latitude beyond 90 degrees, ...) comes back as NaN
    or infinity; callers check and name it.

    Examples
    --------
    >>> x, y = reproject_xy("OGC:CRS84", "EPSG:32631", [3.0], [0.0])
    >>> round(float(x[0]), 3), round(float(y[0]), 3)
    (500000.0, 0.0)
    """
    xa = np.atleast_1d(np.asarray(x, dtype=float))
    ya = np.atleast_1d(np.asarray(y, dtype=float))
    if _same_crs(src, dst):
        return xa.copy(), ya.copy()
    from rasterio.warp import transform

    xl, yl = xa.ravel().tolist(), ya.ravel().tolist()
    try:
        xs, ys = transform(src, dst, xl, yl)
    except Exception:  # noqa: BLE001 - PROJ refuses a point: NaN for those, one by one
        xs, ys = [], []
        for a, b in zip(xl, yl, strict=True):
            try:
                (u,), (v,) = transform(src, dst, [a], [b])
            except Exception:  # noqa: BLE001
                u = v = math.nan
            xs.append(u)
            ys.append(v)
    return np.asarray(xs, float).reshape(xa.shape), np.asarray(ys, float).reshape(ya.shape)


def is_lonlat(crs: Any) -> bool:
    """True for WGS 84 longitude/latitude (``OGC:CRS84``, ``EPSG:4326``).

    Examples
    --------
    >>> is_lonlat("OGC:CRS84"), is_lonlat("EPSG:4326"), is_lonlat("EPSG:32631")
    (True, True, False)
    """
    return crs is not None and _same_crs(crs, RFC7946_CRS)


def x_axis_angle(src: Any, dst: Any, x: Any, y: Any) -> np.ndarray:
    """Angle (rad, CCW) of CRS ``src``'s +x direction at ``(x, y)``, seen in CRS ``dst``.

    For a geographic ``dst`` the angle is in the local east/north frame (degree steps
    scaled to metres on the WGS 84 ellipsoid); for a projected ``dst``, from its +x axis.
    Measured by transforming a point a small step along +x. A yaw from ``src``'s x
    axis plus this angle is the yaw from ``dst``'s.

    Examples
    --------
    >>> float(x_axis_angle("EPSG:32631", "OGC:CRS84", [500000.0], [5e6])[0])  # on the
    ... # central meridian, UTM's grid north is true north
    0.0
    """
    xa = np.atleast_1d(np.asarray(x, dtype=float))
    ya = np.atleast_1d(np.asarray(y, dtype=float))
    if _same_crs(src, dst):
        return np.zeros(np.broadcast(xa, ya).shape)
    from rasterio.crs import CRS

    h = 1e-7 * np.maximum(1.0, np.abs(xa))  # central difference: error O(h^2)
    x0, y0 = reproject_xy(src, dst, xa - h, ya)
    x1, y1 = reproject_xy(src, dst, xa + h, ya)
    dx, dy = x1 - x0, y1 - y0
    y0 = 0.5 * (y0 + y1)
    if CRS.from_user_input(dst).is_geographic:
        # metres per degree east / north on the WGS 84 ellipsoid: N cos(lat) / M
        e2 = 0.00669437999014
        s2 = np.sin(np.radians(y0)) ** 2
        dx = dx * np.cos(np.radians(y0)) * (1.0 - e2 * s2) / (1.0 - e2)
    return np.arctan2(dy, dx)


def reproject_geometries(geoms: Iterable[Any], src: Any, dst: Any) -> list[Any]:
    """Shapely geometries from CRS ``src`` to CRS ``dst`` (vertex by vertex)."""
    import shapely

    def fwd(c: np.ndarray) -> np.ndarray:
        x, y = reproject_xy(src, dst, c[:, 0], c[:, 1])
        return np.column_stack([x, y])

    geoms = list(geoms)
    if _same_crs(src, dst):
        return geoms
    return [shapely.transform(g, fwd) for g in geoms]


def _round(g: Any, digits: int | None) -> Any:
    if digits is None:
        return g
    import shapely

    return shapely.transform(g, lambda c: np.round(c, digits))


def feature_collection(
    features: Iterable[tuple[Any, Mapping[str, Any]]],
    *,
    crs: Any,
    native: bool = False,
    digits: int | None = None,
) -> dict[str, Any]:
    """A GeoJSON FeatureCollection of ``(geometry, properties)`` pairs.

    Parameters
    ----------
    features : iterable of (geometry, dict)
        Shapely geometries (or GeoJSON geometry dicts) in ``crs``, with their properties.
    crs : CRS, str or None
        The CRS of the geometries. None (a local grid without a CRS): written as given,
        with no ``crs`` member.
    native : bool
        False (default): RFC 7946, longitude/latitude, no ``crs`` member. True: keep the
        coordinates in ``crs`` and declare it with the ``crs`` member.
    digits : int, optional
        Round coordinates to this many decimals (default: 9 for lon/lat, none otherwise).

    Returns
    -------
    dict
    """
    from shapely.geometry import mapping, shape

    name = crs_name(crs)
    to_wgs = name is not None and not native
    if digits is None and to_wgs:
        digits = 9
    out: list[dict[str, Any]] = []
    for geom, props in features:
        g = shape(geom) if isinstance(geom, Mapping) else geom
        if to_wgs:
            g = reproject_geometries([g], name, RFC7946_CRS)[0]
        out.append(
            {"type": "Feature", "properties": dict(props), "geometry": mapping(_round(g, digits))}
        )
    doc: dict[str, Any] = {"type": "FeatureCollection"}
    if name is not None and native:
        doc["crs"] = {"type": "name", "properties": {"name": name}}
    doc["features"] = out
    return doc


def write_geojson(
    dest: str | os.PathLike[str],
    features: Mapping[str, Any] | Iterable[tuple[Any, Mapping[str, Any]]],
    *,
    crs: Any = None,
    native: bool = False,
    indent: int | None = 1,
) -> Path:
    """Write GeoJSON to ``dest`` atomically (RFC 7946 lon/lat unless ``native``).

    Parameters
    ----------
    dest : str or path-like
    features : dict or iterable of (geometry, properties)
        A finished GeoJSON document (written as is), or features for
        :func:`feature_collection`.
    crs, native
        As in :func:`feature_collection`.
    indent : int or None
        JSON indentation.

    Returns
    -------
    pathlib.Path
    """
    if isinstance(features, Mapping):
        doc = dict(features)
    else:
        doc = feature_collection(features, crs=crs, native=native)
    return write_text(dest, json.dumps(doc, indent=indent) + "\n")


# ---------------------------------------------------------------------- reading
def _bad(p: Path, msg: str, **fields: Any) -> PlanningConfigError:
    return PlanningConfigError(msg, path=str(p), **fields)


def _load(path: Path, what: str) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError as exc:
        raise PlanningConfigError(
            f"{what} file {str(path)!r} does not exist (expected a GeoJSON file of Polygons)",
            path=str(path),
            expected="an existing GeoJSON file",
        ) from exc
    except OSError as exc:
        raise PlanningConfigError(
            f"cannot read {what} file {str(path)!r}: {exc.strerror or exc}",
            path=str(path),
        ) from exc
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise PlanningConfigError(
            f"{what} file {str(path)!r} is not JSON ({exc}); expected a GeoJSON "
            "FeatureCollection of Polygons",
            path=str(path),
        ) from exc


def _raw_geometries(data: Any, src: str, p: Path) -> list[Any]:
    if isinstance(data, dict) and data.get("type") == "FeatureCollection":
        features = data.get("features")
        if not isinstance(features, list) or not all(isinstance(f, dict) for f in features):
            raise _bad(
                p,
                f"{src}: 'features' is {type(features).__name__}, expected a list of GeoJSON "
                "Feature objects",
                expected="a list of Features",
            )
        return [f.get("geometry") for f in features]
    if isinstance(data, dict) and data.get("type") == "Feature":
        return [data.get("geometry")]
    return [data]


def _check_lonlat(geoms: list[Any], crs: str, src: str, p: Path) -> None:
    """An undeclared CRS means lon/lat: coordinates beyond it name the fix."""
    import shapely

    c = np.concatenate([shapely.get_coordinates(g) for g in geoms])
    if np.all((np.abs(c[:, 0]) <= 360.0) & (np.abs(c[:, 1]) <= 90.0)):
        return
    k = int(np.flatnonzero((np.abs(c[:, 0]) > 360.0) | (np.abs(c[:, 1]) > 90.0))[0])
    raise _bad(
        p,
        f"{src}: coordinates ({c[k, 0]:.10g}, {c[k, 1]:.10g}) are not longitude, latitude, "
        "which a GeoJSON file without a 'crs' member holds (RFC 7946). If they are in the "
        'DEM\'s projected CRS, declare it: "crs": {"type": "name", "properties": '
        '{"name": "EPSG:XXXXX"}}',
        value=(float(c[k, 0]), float(c[k, 1])),
        crs=crs,
        expected="longitude, latitude in degrees, or a declared CRS",
    )


def read_geometries(
    path: str | os.PathLike[str],
    *,
    what: str = "keep-out",
    types: tuple[str, ...] = ("Polygon", "MultiPolygon"),
) -> Geometries:
    """Read the geometries of a GeoJSON file with their CRS.

    Parameters
    ----------
    path : str or path-like
        A FeatureCollection, a Feature or a bare geometry.
    what : str
        What the file is, for messages (``"keep-out"``).
    types : tuple of str
        Accepted geometry types.

    Returns
    -------
    Geometries
        Shapely geometries; ``.crs`` is the declared CRS, or ``"OGC:CRS84"`` (longitude,
        latitude, RFC 7946) when the file declares none.

    Raises
    ------
    PlanningConfigError
        Missing or unreadable file, not JSON/GeoJSON, a geometry of another type, a
        non-finite vertex, coordinates that are not lon/lat in a file without a CRS, a
        CRS that PROJ does not know. Its ``param`` field is ``what`` with ``_`` for
        ``-`` (``"keep_out"``), so that a command names its option.
    """
    try:
        return _read_geometries(Path(path), what, types)
    except PlanningConfigError as exc:
        exc.fields.setdefault("param", what.replace("-", "_"))
        raise


def _read_geometries(p: Path, what: str, types: tuple[str, ...]) -> Geometries:
    import shapely
    from shapely.geometry import shape

    src = f"{what} file {str(p)!r}"
    data = _load(p, what)
    crs = None
    if isinstance(data, dict):
        props = data.get("properties") if data.get("type") == "Feature" else None
        crs = declared_crs(data, props if isinstance(props, dict) else None)
    if crs is not None:
        from rasterio.crs import CRS
        from rasterio.errors import CRSError

        try:
            CRS.from_user_input(crs)
        except CRSError as exc:
            raise _bad(p, f"{src} declares CRS {crs!r}, which PROJ does not know ({exc})",
                       value=crs, expected="an EPSG code or a PROJ CRS name") from exc  # fmt: skip
    out: list[Any] = []
    for k, g in enumerate(_raw_geometries(data, src, p)):
        fields = {"value": k, "expected": " or ".join(types)}
        try:
            geom = shape(g)
        except Exception as exc:  # noqa: BLE001 - shapely raises several types for bad GeoJSON
            raise _bad(p, f"{src}: geometry {k} is not valid GeoJSON ({exc})", **fields) from exc
        if geom.geom_type not in types:
            raise _bad(p, f"{src}: geometry {k} is a {geom.geom_type}; expected "
                       f"{' or '.join(types)}", **fields)  # fmt: skip
        if not np.isfinite(shapely.get_coordinates(geom)).all():
            raise _bad(p, f"{src}: geometry {k} has a vertex that is not a finite number "
                       "(NaN or infinity)", **fields)  # fmt: skip
        out.append(geom)
    if not out:
        raise _bad(p, f"{src} holds no {' or '.join(types)}")
    if crs is None:
        _check_lonlat(out, RFC7946_CRS, src, p)
    return Geometries(out, crs=crs or RFC7946_CRS, source=str(p))
