"""Sweep cases: DEMs as GIS tools write them (scale/offset, units, voids, masks, CRSs).

Every DEM holds the same ground where it can: a plane rising to the north at grade 0.1
(slope ``atan 0.1 = 5.711 deg``), 64 x 64 cells of about 2 m, so the truth is known in
every storage. Slopes are read from ``terrain --json``; the energies of ``energy`` are
compared with the same walk on the plain metric DEM.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from _sweep import Run, Verdict, case, expect_error, expect_value, run

TOPIC = "rasters"
GRADE = 0.1
SLOPE = math.degrees(math.atan(GRADE))  # 5.7106 deg
N = 64
RES = 2.0
X0, Y0 = 500000.0, 5000000.0  # UTM 31N, south-west corner
UTM = "EPSG:32631"


def write(
    path: Path,
    z: np.ndarray,
    transform: Any,
    crs: Any = UTM,
    dtype: str = "float32",
    nodata: float | None = None,
    scale: float | None = None,
    offset: float | None = None,
    units: str | None = None,
    mask: np.ndarray | None = None,
) -> Path:
    """Write ``z`` (already in the stored units) as a GeoTIFF with the given metadata."""
    import rasterio

    prof = dict(
        driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype=dtype,
        crs=crs, transform=transform, nodata=nodata,
    )  # fmt: skip
    with rasterio.Env(GDAL_TIFF_INTERNAL_MASK=True), rasterio.open(path, "w", **prof) as dst:
        dst.write(z.astype(dtype), 1)
        if scale is not None or offset is not None:
            dst.scales = (scale if scale is not None else 1.0,)
            dst.offsets = (offset if offset is not None else 0.0,)
        if units is not None:
            dst.units = (units,)
        if mask is not None:
            dst.write_mask(np.where(mask, 255, 0).astype("uint8"))
    return path


def plane(n: int = N, res: float = RES) -> tuple[np.ndarray, Any]:
    """The plane on the UTM grid (row 0 north): elevation in metres and transform."""
    from rasterio.transform import from_origin

    y = Y0 + (n - np.arange(n) - 0.5) * res
    z = 100.0 + GRADE * (y - Y0)
    return np.repeat(z[:, None], n, axis=1), from_origin(X0, Y0 + n * res, res, res)


def slope_of(r: Run, key: str = "slope_max_deg") -> float | None:
    return None if r.data is None else r.data.get(key)


def terrain_slope(tmp: Path, dem: Path, warn: str | None = None, key: str = "slope_max_deg"):
    r = run(tmp, "terrain", dem, json_out=True)
    return expect_value(r, slope_of(r, key), SLOPE, 0.02, " deg", warn=warn)


def walk(tmp: Path, dem: Path, pts: list[tuple[float, float]], name: str = "walk.csv") -> Run:
    f = tmp / name
    f.write_text("x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in pts))
    return run(tmp, "energy", "--dem", dem, "--waypoints", f, json_out=True)


def energy_of(r: Run) -> float | None:
    if r.data is None:
        return None
    for k in ("energy_j", "total_energy_j"):
        if k in r.data:
            return float(r.data[k])
    return None


def reference_walk(tmp: Path, length: float = 60.0) -> float:
    """Energy (J) of walking ``length`` m north up the plane, on the plain metric DEM."""
    z, t = plane()
    dem = write(tmp / "reference.tif", z, t)
    x = X0 + N * RES / 2
    r = walk(tmp, dem, [(x, Y0 + 20.0), (x, Y0 + 20.0 + length)], "reference.csv")
    e = energy_of(r)
    if e is None:
        raise RuntimeError(f"reference walk failed: {r.error}")
    return e


# --------------------------------------------------------------------- stored values
@case(TOPIC, "int16 decimetres with GDAL scale 0.1 and offset 50 m")
def scale_offset(tmp: Path) -> Verdict:
    z, t = plane()
    stored = np.round((z - 50.0) / 0.1)
    return terrain_slope(tmp, write(tmp / "dm.tif", stored, t, dtype="int16", scale=0.1, offset=50))


@case(TOPIC, "int16 decimetres declared by the band unit 'dm' (no scale)")
def decimetre_unit(tmp: Path) -> Verdict:
    z, t = plane()
    return terrain_slope(tmp, write(tmp / "dm.tif", np.round(z * 10), t, dtype="int16", units="dm"))


@case(TOPIC, "elevations in feet (band unit 'ft') on a metric grid")
def feet_unit(tmp: Path) -> Verdict:
    z, t = plane()
    return terrain_slope(tmp, write(tmp / "ft.tif", z / 0.3048, t, units="ft"))


@case(TOPIC, "a band unit nobody knows ('furlong')")
def unknown_unit(tmp: Path) -> Verdict:
    z, t = plane()
    r = run(tmp, "terrain", write(tmp / "u.tif", z, t, units="furlong"))
    return expect_error(r, "furlong", "u.tif")


# --------------------------------------------------------------------- voids
def _voids(z: np.ndarray, value: float) -> np.ndarray:
    z = z.copy()
    z[20:30, 20:40] = value  # a 10 x 20 void in the middle
    return z


def _void_case(tmp: Path, value: float, dtype: str) -> Verdict:
    z, t = plane()
    dem = write(tmp / "voids.tif", _voids(z, value), t, dtype=dtype)
    return terrain_slope(tmp, dem, warn=f"{value:g}")


@case(TOPIC, "-9999 voids, no nodata declared (float32)")
def voids_9999(tmp: Path) -> Verdict:
    return _void_case(tmp, -9999.0, "float32")


@case(TOPIC, "-32768 voids, no nodata declared (int16, decimetres scaled)")
def voids_32768(tmp: Path) -> Verdict:
    z, t = plane()
    stored = _voids(np.round(z / 0.1), -32768)
    dem = write(tmp / "voids.tif", stored, t, dtype="int16", scale=0.1)
    return terrain_slope(tmp, dem, warn="-32768")


@case(TOPIC, "1e30 voids, no nodata declared (float32)")
def voids_1e30(tmp: Path) -> Verdict:
    return _void_case(tmp, 1e30, "float32")


@case(TOPIC, "an 80 m walk across undeclared -9999 voids (energy)")
def walk_over_voids(tmp: Path) -> Verdict:
    z, t = plane()
    dem = write(tmp / "voids.tif", _voids(z, -9999.0), t)
    x = X0 + 30 * RES
    r = walk(tmp, dem, [(x, Y0 + 10.0), (x, Y0 + 90.0)])
    return expect_error(r, "nodata")


@case(TOPIC, "declared nodata -9999")
def declared_nodata(tmp: Path) -> Verdict:
    z, t = plane()
    return terrain_slope(tmp, write(tmp / "nd.tif", _voids(z, -9999.0), t, nodata=-9999.0))


@case(TOPIC, "an internal mask band (no nodata value; masked cells hold 0)")
def internal_mask(tmp: Path) -> Verdict:
    z, t = plane()
    m = np.ones(z.shape, bool)
    m[20:30, 20:40] = False
    return terrain_slope(tmp, write(tmp / "mask.tif", np.where(m, z, 0.0), t, mask=m))


@case(TOPIC, "NaN holes (float32, no nodata declared)")
def nan_holes(tmp: Path) -> Verdict:
    z, t = plane()
    return terrain_slope(tmp, write(tmp / "nan.tif", _voids(z, np.nan), t))


# --------------------------------------------------------------------- grids and CRSs
def _mercator_plane(tmp: Path) -> tuple[Path, Any, float]:
    """The plane at 45 deg N in EPSG:3857: heights from the true ground distance north."""
    from pyproj import Geod, Transformer
    from rasterio.transform import from_origin

    fwd = Transformer.from_crs("EPSG:4326", "EPSG:3857", always_xy=True)
    inv = Transformer.from_crs("EPSG:3857", "EPSG:4326", always_xy=True)
    x0, y0 = fwd.transform(3.0, 45.0)
    res = 2.0  # map metres (about 1.41 ground metres)
    ys = y0 + (N - np.arange(N) - 0.5) * res
    _, lat = inv.transform(np.full(N, x0), ys)
    geod = Geod(ellps="WGS84")
    _, _, north = geod.inv(np.full(N, 3.0), np.full(N, 45.0), np.full(N, 3.0), lat)
    north = np.where(lat < 45.0, -north, north)
    z = np.repeat((100.0 + GRADE * north)[:, None], N, axis=1)
    dem = write(tmp / "merc.tif", z, from_origin(x0, y0 + N * res, res, res), "EPSG:3857")
    return dem, (x0, y0), res


@case(TOPIC, "web-mercator (EPSG:3857) at 45 deg N: 1.41 map metres per ground metre")
def web_mercator(tmp: Path) -> Verdict:
    dem, _, _ = _mercator_plane(tmp)
    return terrain_slope(tmp, dem, key="slope_mean_deg")


@case(TOPIC, "a 60 m walk on the web-mercator DEM (energy, against the metric DEM)")
def web_mercator_walk(tmp: Path) -> Verdict:
    from pyproj import Geod, Transformer

    want = reference_walk(tmp)
    dem, (x0, y0), res = _mercator_plane(tmp)
    inv = Transformer.from_crs("EPSG:3857", "EPSG:4326", always_xy=True)
    fwd = Transformer.from_crs("EPSG:4326", "EPSG:3857", always_xy=True)
    x = x0 + N * res / 2
    lon, lat = inv.transform(x, y0 + 15.0)
    lon1, lat1, _ = Geod(ellps="WGS84").fwd(lon, lat, 0.0, 60.0)
    x1, y1 = fwd.transform(lon1, lat1)
    r = walk(tmp, dem, [(x, y0 + 15.0), (x1, y1)])
    return expect_value(r, energy_of(r), want, 0.01 * want, " J")


@case(TOPIC, "geographic CRS (EPSG:4326), the plane at 45 deg N")
def geographic(tmp: Path) -> Verdict:
    from pyproj import Geod
    from rasterio.transform import from_origin

    d = 2.0e-5  # degrees (~1.6 m east, 2.2 m north)
    lat = 45.0 + (N - np.arange(N) - 0.5) * d
    _, _, north = Geod(ellps="WGS84").inv(np.full(N, 3.0), np.full(N, 45.0), np.full(N, 3.0), lat)
    z = np.repeat((100.0 + GRADE * north)[:, None], N, axis=1)
    dem = write(tmp / "ll.tif", z, from_origin(3.0, 45.0 + N * d, d, d), "EPSG:4326")
    return terrain_slope(tmp, dem, key="slope_mean_deg")


@case(TOPIC, "south-up grid (positive y pixel size)")
def south_up(tmp: Path) -> Verdict:
    from affine import Affine

    z, _ = plane()
    t = Affine(RES, 0.0, X0, 0.0, RES, Y0)  # row 0 is the southern edge
    return terrain_slope(tmp, write(tmp / "south.tif", z[::-1], t))


@case(TOPIC, "rotated geotransform")
def rotated(tmp: Path) -> Verdict:
    from affine import Affine

    z, _ = plane()
    t = Affine.translation(X0, Y0 + N * RES) * Affine.rotation(10.0) * Affine.scale(RES, -RES)
    r = run(tmp, "terrain", write(tmp / "rot.tif", z, t))
    return expect_error(r, "rotated", "gdalwarp")


# --------------------------------------------------------------------- endpoints
@case(TOPIC, "plan from a start inside the map, on a declared-nodata void")
def start_on_void(tmp: Path) -> Verdict:
    z, t = plane()
    dem = write(tmp / "nd.tif", _voids(z, -9999.0), t, nodata=-9999.0)
    start = f"{X0 + 30 * RES},{Y0 + (N - 25) * RES}"  # row 25, column 30: in the void
    goal = f"{X0 + 30 * RES},{Y0 + 10 * RES}"
    r = run(tmp, "plan", "--dem", dem, "--start", start, "--goal", goal, "--time", "1")
    v = expect_error(r, "nodata")
    if v.handled and "outside" in v.answer.lower():
        return Verdict(v.answer, False, "says 'outside' for a point inside the map")
    return v


@case(TOPIC, "plan from a start outside the map")
def start_outside(tmp: Path) -> Verdict:
    z, t = plane()
    dem = write(tmp / "p.tif", z, t)
    r = run(
        tmp, "plan", "--dem", dem, "--start", f"{X0 - 500},{Y0}", "--goal",
        f"{X0 + 60},{Y0 + 60}", "--time", "1",
    )  # fmt: skip
    return expect_error(r, "outside", "500000")


@case(TOPIC, "polar stereographic (EPSG:3031) at 60 S: 4 % from ground metres, not cylindrical")
def polar_stereographic(tmp: Path) -> Verdict:
    from pyproj import Transformer
    from rasterio.transform import from_origin

    x, y = Transformer.from_crs("EPSG:4326", "EPSG:3031", always_xy=True).transform(20.0, -60.0)
    z, _ = plane()
    r = run(tmp, "terrain", write(tmp / "polar.tif", z, from_origin(x, y, RES, RES), "EPSG:3031"))
    return expect_error(r, "ground metre", "gdalwarp -t_srs EPSG:32734")


@case(TOPIC, "energy-map (read by windows) of a DEM with undeclared -9999 voids")
def energy_map_voids(tmp: Path) -> Verdict:
    import rasterio

    z, t = plane()
    bad = write(tmp / "voids.tif", _voids(z, -9999.0), t)
    good = write(tmp / "declared.tif", _voids(z, -9999.0), t, nodata=-9999.0)
    maps = []
    for dem in (good, bad):
        r = run(tmp, "energy-map", dem, "--out", tmp / f"{dem.stem}_map.tif", "--headings", "4",
                json_out=True)  # fmt: skip
        if r.rc != 0 or r.traceback:
            return expect_value(r, None, 0.0, 0.0)
        with rasterio.open(tmp / f"{dem.stem}_map.tif") as src:
            maps.append(src.read())
    diff = float(np.nanmax(np.abs(maps[1] - maps[0])))
    same_mask = bool(np.array_equal(np.isnan(maps[0]), np.isnan(maps[1])))
    return expect_value(r, diff if same_mask else math.inf, 0.0, 1e-6, " J/m", warn="-9999")
