"""Hilly synthetic DEMs for the planning benchmarks (written to a temporary directory).

``hilly_dem(size, path)``: ``size x size`` cells at 1 m (EPSG:32631), a sum of smooth
random hills (Gaussian-filtered white noise at three scales, seed fixed), scaled so that
the steepest slope is about 25 degrees and typical slopes are 5-12 degrees: a landscape of
knolls and valleys at every size, the same statistics per square kilometre.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

X0, Y0 = 500_000.0, 5_000_000.0


def hilly_elevation(size: int, seed: int = 7) -> np.ndarray:
    """Elevation (m), ``size x size``, row 0 north."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    z = np.zeros((size, size), np.float32)
    for sigma, amp in ((60.0, 1.0), (20.0, 0.35), (6.0, 0.08)):
        n = gaussian_filter(rng.standard_normal((size, size)).astype(np.float32), sigma,
                            mode="wrap")  # fmt: skip
        z += amp * n / n.std()
    gy, gx = np.gradient(z)
    s = np.hypot(gx, gy)
    z *= np.tan(np.radians(12.0)) / float(np.percentile(s, 95))
    return z.astype(np.float32)


def hilly_dem(size: int, path: Path, seed: int = 7) -> Path:
    """Write the DEM as a GeoTIFF and return its path."""
    import rasterio
    from rasterio.transform import from_origin

    z = hilly_elevation(size, seed)
    with rasterio.open(
        path, "w", driver="GTiff", width=size, height=size, count=1, dtype="float32",
        crs="EPSG:32631", transform=from_origin(X0, Y0 + size, 1.0, 1.0), tiled=True,
        compress="deflate",
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    return Path(path)


def corners(size: int, margin: int = 5) -> tuple[tuple[float, float], tuple[float, float]]:
    """Start (south-west) and goal (north-east) cell centres, ``margin`` cells inside."""
    a = margin + 0.5
    b = size - margin - 0.5
    return (X0 + a, Y0 + a), (X0 + b, Y0 + b)
