"""Heading-dependent energy maps (the paper's first contribution) as GeoTIFFs.

:func:`energy_map` writes, for every cell of a DEM, the energy per metre of walking in
each of ``N`` map headings (facing along, and with the cheapest gait), the cheapest and
dearest heading cost, their ratio and the cheapest heading; :func:`plot_energy_map`
draws it over a hillshade; :func:`read_band` reads a band of a written map as values
(the default storage is scaled 16-bit integers, :mod:`energy_planner.energymap.encoding`).
See ``docs/energy_map.md``.
"""

from energy_planner.energymap.core import (
    BAND_SETS,
    DEFAULT_BANDS,
    SUMMARY_BANDS,
    EnergyMapError,
    EnergyMapResult,
    band_names,
    energy_map,
    memory_cap,
    parse_size,
)
from energy_planner.energymap.encoding import ENCODINGS, read_band
from energy_planner.energymap.plot import plot_energy_map

__all__ = [
    "BAND_SETS",
    "DEFAULT_BANDS",
    "ENCODINGS",
    "SUMMARY_BANDS",
    "EnergyMapError",
    "EnergyMapResult",
    "band_names",
    "energy_map",
    "memory_cap",
    "parse_size",
    "plot_energy_map",
    "read_band",
]
