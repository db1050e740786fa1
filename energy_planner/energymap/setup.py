"""What every way of computing an energy map shares: the model's kernel, limits, channels."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.energymap.bands import BAND_SETS, DEFAULT_BANDS, band_names, first_band
from energy_planner.energymap.encoding import DEFAULT_ENCODING, ENCODINGS
from energy_planner.errors import EnergyMapError

#: Compression of a map's GeoTIFF unless asked otherwise (see :func:`energy_map`).
#: zstd: 9.5 CPU s to compress a 4096^2 map's 36 bands where deflate takes 16.6, at the
#: same size (1.34 GB); every GDAL since 2.3 (2018) reads it (``--compress deflate`` for
#: older readers).
DEFAULT_COMPRESS = "zstd"


@dataclass
class _Setup:
    """Model, kernel and settings shared by every way of computing a map."""

    heading: Any
    channels: Any
    headings: int
    speed: float
    tmax: float
    smax: float
    notes: list[str]
    compress: str = DEFAULT_COMPRESS
    bands: str = DEFAULT_BANDS
    encoding: str = DEFAULT_ENCODING
    #: ``(vmin, vmax)`` m/s where each cell and heading is priced at its best speed
    speed_range: tuple[float, float] | None = None

    @property
    def extra(self) -> tuple[str, ...]:
        """The bands after the summary bands.

        :data:`~energy_planner.energymap.bands.SPEED_BANDS` at the best speed of a range,
        else none.
        """
        from energy_planner.energymap.bands import speed_bands

        return speed_bands(self.heading)

    @property
    def gaits(self) -> tuple[str, ...]:
        """The gaits each cell chooses among (codes of ``cheapest_gait``), else none."""
        return tuple(getattr(self.heading, "gaits", ()))

    @property
    def full(self) -> int:
        """Number of bands of the full layout (every band computed)."""
        return 2 * self.headings + 4 + len(self.extra)

    @property
    def first(self) -> int:
        """Index in the full band layout of the first band written (``first_band``)."""
        return first_band(self.headings, self.bands)

    @property
    def along(self) -> bool:
        """Whether the ``along_*`` bands are written, so computed into the windows' bands.

        Without them :func:`~energy_planner.energymap.bands.block_bands` leaves them out
        (``along=False``): the windows' bands start at ``best_*`` (:attr:`computed`).
        """
        return self.first == 0

    @property
    def computed(self) -> int:
        """Index in the full band layout of a computed block's first band (see :attr:`along`)."""
        return 0 if self.along else self.headings

    @property
    def nbands(self) -> int:
        """Number of bands written."""
        return self.full - self.first

    @property
    def steps(self) -> np.ndarray:
        """The ``uint16`` scale of each band written (``encoding.band_steps``)."""
        from energy_planner.energymap.encoding import band_steps

        return band_steps(self.headings, band_names(self.headings, self.bands, self.extra))


def _setup(
    model: Any, request: Any, channels: Any, headings: int, compress: str = DEFAULT_COMPRESS,
    bands: str = DEFAULT_BANDS, encoding: str = DEFAULT_ENCODING, speed_range: Any = None,
) -> _Setup:  # fmt: skip
    """The shared setup; ``speed_range``: a resolved ``(vmin, vmax)`` (m/s) or None."""
    from energy_planner.energy.channels import Channels
    from energy_planner.energy.heading import HeadingCost
    from energy_planner.errors import ModelError
    from energy_planner.model import EnergyModel
    from energy_planner.request import Request

    if not (isinstance(headings, int | np.integer) and 1 <= headings <= 360):
        raise EnergyMapError(
            f"headings {headings!r} must be a whole number in 1..360",
            value=headings,
            expected="1..360",
        )
    from energy_planner.io import COMPRESSIONS

    if str(compress).lower() not in COMPRESSIONS:
        raise EnergyMapError(
            f"compression {compress!r} is not one of {', '.join(COMPRESSIONS)}",
            value=compress,
            expected=", ".join(COMPRESSIONS),
        )
    if bands not in BAND_SETS:
        raise EnergyMapError(
            f"bands {bands!r} is not one of {', '.join(BAND_SETS)}",
            value=bands,
            expected=", ".join(BAND_SETS),
        )
    if encoding not in ENCODINGS:
        raise EnergyMapError(
            f"encoding {encoding!r} is not one of {', '.join(ENCODINGS)}",
            value=encoding,
            expected=", ".join(ENCODINGS),
        )
    model = EnergyModel.default() if model is None else model
    if not model.is_fitted:
        raise ModelError("the energy model has no coefficients: fit or load a fitted model")
    request = Request() if request is None else request
    if channels is None:
        channels = request.channels if request.channels is not None else Channels()
    elif request.channels is not None:
        raise EnergyMapError("give channels either in the request or as channels=, not both")
    notes = []
    lim = request.limits
    if getattr(lim, "keep_out", None) is not None:
        notes.append("keep-out areas do not change an energy map (it prices every cell); ignored")
    tmax = math.inf if lim.max_slope_deg is None else math.tan(math.radians(lim.max_slope_deg))
    smax = (
        math.inf
        if lim.max_cross_slope_deg is None
        else math.sin(math.radians(lim.max_cross_slope_deg))
    )
    channels = channels.resolve(model)  # values of the kinds the model reads
    unused = channels.unused(model)
    if unused:
        notes.append(f"the model does not read channel(s) {', '.join(unused)}; ignored")
    if speed_range is None:
        heading = HeadingCost.of_request(model, request, channels)
    else:
        from energy_planner.energy.speed_map import gait_choice, ranged_heading_cost

        limits = dict(
            max_slope_deg=lim.max_slope_deg, max_cross_slope_deg=lim.max_cross_slope_deg,
            max_crab_deg=getattr(lim, "max_crab_deg", None),
            max_backward_slope_deg=getattr(lim, "max_backward_slope_deg", None),
        )  # fmt: skip
        # where the model names gaits and the channels do not give one: each in its best
        heading = gait_choice(model, speed_range, channels, **limits)
        if heading is None:
            heading = ranged_heading_cost(model, speed_range, channels=channels, **limits)
    return _Setup(
        heading=heading,
        channels=channels,
        headings=int(headings),
        speed=float(request.robot.speed),
        tmax=tmax,
        smax=smax,
        notes=notes,
        compress=str(compress).lower(),
        bands=bands,
        encoding=encoding,
        speed_range=None if speed_range is None else tuple(speed_range),
    )
