"""Slope and path energy do not depend on how the same ground is stored.

The ground is a quadratic surface in local ground metres ``(E, N)`` (east and north of a
point at 5.99 E, 45 N, on the ellipsoid): ``z = z0 + a E + b N + c E^2 + d E N + e N^2``.
Each storage evaluates it *exactly* at its own cell centres (their longitude and latitude
from the storage's CRS, then ``E``, ``N``), so the truth is known in every storage and no
resampling between CRSs enters the comparison. Storages: UTM zone 31 or 32 (the point is
on their boundary), longitude/latitude, web-mercator; north-up or south-up; pixel sizes
from 0.6 to 3 m; float32, float64 or an int32 of millimetres with a GDAL scale and offset.

Why the result is exact up to the tolerances: Horn's gradient is exact on a quadratic
(central differences), and bilinear sampling of a gradient that is linear in position is
exact, so a metric storage gives the true slope but for the map's scale factor (UTM at 3
deg from its central meridian at 45 N: ``k`` within 4e-4 of 1, read as metres, below the
loader's 0.5 % tolerance) and the rounding of the stored heights (float32: ~8e-6 m at 150
m; millimetres: 0.5 mm). Geographic and web-mercator storages get the per-row ground
spacing and are carried onto a UTM working grid (the gradient bilinear at the working
centres): the surface is quadratic in ``(E, N)``, which are not exactly linear in
longitude and latitude, so a few 1e-5 more.
"""

from __future__ import annotations

import math
import warnings
from functools import lru_cache

import numpy as np
import pytest
import rasterio
from affine import Affine
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from energy_planner.energy import path_energy
from energy_planner.model import EnergyModel
from energy_planner.terrain import Terrain, load_dem

LON0, LAT0 = 5.99, 45.0
A_WGS = 6378137.0
E2 = 6.69437999014e-3
SIZE = 48.0  # metres of ground on each side, centred on the point
CRSS = ("EPSG:32631", "EPSG:32632", "EPSG:4326", "EPSG:3857")

SETTINGS = settings(
    max_examples=100,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


def ground(lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ground metres east and north of ``(LON0, LAT0)`` (ellipsoid radii at each latitude;
    the meridian arc by Simpson's rule over the few metres involved)."""
    phi = np.radians(lat)
    w = np.sqrt(1.0 - E2 * np.sin(phi) ** 2)
    east = np.radians(lon - LON0) * A_WGS / w * np.cos(phi)
    phi0 = math.radians(LAT0)

    def m(p):
        return A_WGS * (1.0 - E2) / (1.0 - E2 * np.sin(p) ** 2) ** 1.5

    north = (phi - phi0) / 6.0 * (m(phi0) + 4.0 * m(0.5 * (phi + phi0)) + m(phi))
    return east, north


@lru_cache(maxsize=8)
def _transformers(crs: str):
    from pyproj import Transformer

    fwd = Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    inv = Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    return fwd, inv


def to_crs(crs: str, east: np.ndarray, north: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ground ``(E, N)`` near the point -> coordinates in ``crs`` (local inverse of
    :func:`ground`, refined by two Newton steps)."""
    phi0 = math.radians(LAT0)
    w = math.sqrt(1.0 - E2 * math.sin(phi0) ** 2)
    lon = LON0 + np.degrees(np.asarray(east) / (A_WGS / w * math.cos(phi0)))
    lat = LAT0 + np.degrees(np.asarray(north) / (A_WGS * (1 - E2) / w**3))
    for _ in range(2):
        e, n = ground(lon, lat)
        lon = lon + np.degrees((east - e) / (A_WGS / w * math.cos(phi0)))
        lat = lat + np.degrees((north - n) / (A_WGS * (1 - E2) / w**3))
    fwd, _ = _transformers(crs)
    x, y = fwd.transform(lon, lat)
    return np.asarray(x), np.asarray(y)


class Surface:
    """``z = z0 + a E + b N + c E^2 + d E N + e N^2`` (metres)."""

    def __init__(self, coef: tuple[float, ...]) -> None:
        self.z0, self.a, self.b, self.c, self.d, self.e = coef

    def __call__(self, east, north):
        return (
            self.z0 + self.a * east + self.b * north
            + self.c * east**2 + self.d * east * north + self.e * north**2
        )  # fmt: skip

    def tan_slope(self, east, north):
        gx = self.a + 2 * self.c * east + self.d * north
        gy = self.b + 2 * self.e * north + self.d * east
        return np.hypot(gx, gy)


def store(path, surface, crs, res_m, south_up=False, encoding="float32", nodata=None):
    """Write ``surface`` on a grid of ``crs`` covering the patch, ``res_m`` ground metres."""
    xs, ys = to_crs(crs, np.array([-SIZE / 2, SIZE / 2, -SIZE / 2, SIZE / 2]),
                    np.array([-SIZE / 2, -SIZE / 2, SIZE / 2, SIZE / 2]))  # fmt: skip
    left, right, bottom, top = xs.min(), xs.max(), ys.min(), ys.max()
    # pixel size in the CRS's units for res_m ground metres (per axis)
    px = (right - left) / SIZE * res_m
    py = (top - bottom) / SIZE * res_m
    cols, rows = round((right - left) / px), round((top - bottom) / py)
    t = Affine(px, 0.0, left, 0.0, -py, top)
    cc, rr = np.meshgrid(np.arange(cols) + 0.5, np.arange(rows) + 0.5)
    x, y = t @ (cc, rr)
    _, inv = _transformers(crs)
    lon, lat = inv.transform(x, y)
    z = surface(*ground(np.asarray(lon), np.asarray(lat)))
    prof = dict(driver="GTiff", width=cols, height=rows, count=1, crs=crs)
    if encoding == "int32mm":
        offset = 100.0
        stored = np.round((z - offset) / 0.001)
        prof.update(dtype="int32")
    else:
        stored = z
        prof.update(dtype=encoding)
    if south_up:
        stored = stored[::-1]
        t = Affine(px, 0.0, left, 0.0, py, top - rows * py)
    with rasterio.open(path, "w", transform=t, nodata=nodata, **prof) as dst:
        dst.write(stored.astype(prof["dtype"]), 1)
        if encoding == "int32mm":
            dst.scales, dst.offsets = (0.001,), (offset,)
    return path


surfaces = st.tuples(
    st.floats(50.0, 500.0),  # z0
    st.floats(-0.4, 0.4),  # a
    st.floats(-0.4, 0.4),  # b
    st.floats(-2e-3, 2e-3),  # c
    st.floats(-2e-3, 2e-3),  # d
    st.floats(-2e-3, 2e-3),  # e
)
storages = st.tuples(
    st.sampled_from(CRSS),
    st.sampled_from([0.6, 1.0, 1.5, 2.0, 3.0]),
    st.booleans(),
    st.sampled_from(["float32", "float64", "int32mm"]),
)


def _quant(encoding: str, res: float) -> float:
    """Bound on the error of tan(slope) from rounding the stored heights.

    Horn divides a sum of eight weighted heights (weights summing to 8 in absolute value)
    by 8 cells, so each component moves by at most the height error over the cell size.
    """
    dz = {"float32": 1.6e-5, "float64": 1e-9, "int32mm": 5e-4}[encoding]
    return math.sqrt(2.0) * dz / res


@lru_cache(maxsize=1)
def _model():
    return EnergyModel.default()  # one model for every example (its kernels stay warm)


@SETTINGS
@given(coef=surfaces, storage=storages)
def test_slope_and_path_energy_do_not_depend_on_storage(coef, storage):
    crs, res, south_up, encoding = storage
    s = Surface(coef)
    dem = load_dem(store("/vsimem/invariance.tif", s, crs, res, south_up, encoding))
    # slope at five ground points against the surface's own gradient
    pe = np.array([-10.0, 0.0, 7.5, 12.0, -4.0])
    pn = np.array([-12.0, 0.0, 9.0, -3.0, 14.0])
    x, y = dem.to_work(*to_crs(crs, pe, pn))
    got = np.tan(np.asarray(dem.sample(x, y).slope))
    want = s.tan_slope(pe, pn)
    # map scale (UTM within 4e-4 of 1 here) + the quadratic in (E, N) not exactly
    # quadratic in the storage's coordinates (1e-5 over 48 m) + rounding
    tol = 5e-4 * want + 2e-5 + _quant(encoding, res)
    assert np.all(np.abs(got - want) <= tol), (got, want, tol)
    # the energy of a walk against the same surface on a metric grid in ground metres
    ref = Terrain.from_function(
        lambda e, n: s(e, n), size=(SIZE, SIZE), resolution=0.5, origin=(-SIZE / 2, -SIZE / 2)
    )
    walk_e, walk_n = np.array([-14.0, 3.0, 13.0]), np.array([-11.0, 12.0, -2.0])
    e_want = path_energy(ref, _model(), np.column_stack([walk_e, walk_n])).energy_j
    x, y = dem.to_work(*to_crs(crs, walk_e, walk_n))
    e_got = path_energy(dem, _model(), np.column_stack([x, y])).energy_j
    # distances in UTM map metres are up to 4e-4 long, slopes as above; the energy of a
    # walk moves with both (a 1e-3 change of grade moves the J/m by < 1e-3 relative
    # on these grades)
    assert e_got == pytest.approx(e_want, rel=2e-3), (e_got, e_want)


# ---------------------------------------------------------------------- nodata conventions
CONVENTIONS = ("nan", "declared", "undeclared", "mask", "int16_scaled")


def _store_voids(path, z, t, holes, convention):
    prof = dict(driver="GTiff", width=z.shape[1], height=z.shape[0], count=1,
                crs="EPSG:32631", transform=t)  # fmt: skip
    stored, nodata, dtype, scale = z.copy(), None, "float64", None
    if convention == "nan":
        stored[holes] = np.nan
    elif convention in ("declared", "undeclared"):
        stored[holes] = -9999.0
        nodata = -9999.0 if convention == "declared" else None
    elif convention == "mask":
        stored[holes] = 0.0
    else:  # decimetres in int16, voids -32768, nothing declared
        stored = np.round(z / 0.1)
        stored[holes] = -32768
        dtype, scale = "int16", 0.1
    with (
        rasterio.Env(GDAL_TIFF_INTERNAL_MASK=True),
        rasterio.open(path, "w", dtype=dtype, nodata=nodata, **prof) as dst,
    ):
        dst.write(stored.astype(dtype), 1)
        if scale is not None:
            dst.scales = (scale,)
        if convention == "mask":
            dst.write_mask(np.where(holes, 0, 255).astype("uint8"))
    return path


@SETTINGS
@given(
    coef=surfaces,
    box=st.tuples(st.integers(0, 20), st.integers(0, 20), st.integers(1, 10), st.integers(1, 10)),
    convention=st.sampled_from(CONVENTIONS),
)
def test_nodata_convention_does_not_change_the_terrain(coef, box, convention):
    s = Surface(coef)
    n, res = 24, 2.0
    e = (np.arange(n) + 0.5) * res - n
    east, north = np.meshgrid(e, e[::-1])
    z = s(east, north)
    if convention == "int16_scaled":
        z = np.round(z / 0.1) * 0.1  # the same decimetre heights in both
    t = Affine(res, 0.0, 500000.0, 0.0, -res, 5000000.0 + n * res)
    holes = np.zeros(z.shape, bool)
    r0, c0, h, w = box
    holes[r0 : r0 + h, c0 : c0 + w] = True
    ref_z = z.copy()
    ref_z[holes] = np.nan
    ref = Terrain(ref_z, t, "EPSG:32631")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        dem = load_dem(_store_voids("/vsimem/voids.tif", z, t, holes, convention))
    np.testing.assert_allclose(dem.elevation, ref.elevation, rtol=0, atol=1e-9)
    np.testing.assert_allclose(dem.dzdx, ref.dzdx, rtol=0, atol=1e-9)
    np.testing.assert_allclose(dem.dzdy, ref.dzdy, rtol=0, atol=1e-9)
    named = [w for w in caught if "declares no nodata" in str(w.message)]
    if convention in ("undeclared", "int16_scaled"):  # masked, and said so with the count
        value = "-9999" if convention == "undeclared" else "-32768"
        assert len(named) == 1 and f"{int(holes.sum())} cells of {value}" in str(named[0].message)
    else:
        assert not named
