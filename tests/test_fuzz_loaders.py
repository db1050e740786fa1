"""Fuzzing the public loaders (issue 13): malformed files give a project error or a result.

Each test writes a file hypothesis made (a valid document with random parts replaced, or
text/bytes made from scratch) and calls the loader a user would: ``load_logs`` (CSV,
Parquet), ``read_waypoints`` (CSV, GeoJSON), ``EnergyModel.load`` (model JSON),
``load_keep_out`` (keep-out GeoJSON). The only allowed outcomes are a result or an
:class:`~energy_planner.errors.EnergyPlannerError`; anything else (``KeyError``,
``TypeError``, ``AttributeError``, a pandas or PROJ error, ...) fails the test. Warnings
are allowed except ``RuntimeWarning`` from the library (pytest makes those errors).

Bounded for the suite: ``MAX_EXAMPLES`` examples per loader, no deadline; about 10 s
in all on one core. ``FUZZ_EXAMPLES=2000 pytest tests/test_fuzz_loaders.py`` runs a
longer campaign.
"""

from __future__ import annotations

import copy
import io
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from energy_planner.errors import EnergyPlannerError
from energy_planner.measurements.schema import CANONICAL_COLUMNS

MAX_EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "60"))
# In the suite: no shrinking (a failure is reported as found; shrinking a loader failure
# costs tens of seconds). A long campaign (FUZZ_EXAMPLES set) shrinks to minimal examples.
_PHASES = (
    tuple(Phase) if "FUZZ_EXAMPLES" in os.environ else (Phase.explicit, Phase.reuse, Phase.generate)
)
FUZZ = settings(
    max_examples=MAX_EXAMPLES,
    deadline=None,
    database=None,
    phases=_PHASES,
    report_multiple_bugs=False,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.function_scoped_fixture,
    ],
)

# ---------------------------------------------------------------------- value strategies
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**30), 10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-1e3, 1e3),
    st.text(max_size=6),
    st.sampled_from(["", "nan", "inf", "-1e999", "1,5", "NaN", "0x10", " 3 ", "ten", "true"]),
)
json_values = st.recursive(
    scalars,
    lambda c: (
        st.lists(c, max_size=4)
        | st.dictionaries(
            st.sampled_from(
                [
                    "type",
                    "coordinates",
                    "features",
                    "geometry",
                    "properties",
                    "crs",
                    "name",
                    "yaw_deg",
                    "t",
                    "terms",
                    "coefficients",
                    "formula",
                    "x",
                    "y",
                ]
            )
            | st.text(max_size=4),
            c,
            max_size=4,
        )
    ),
    max_leaves=8,
)


def _paths(doc, prefix=()):
    """Every path (tuple of keys/indices) into a JSON document, the root included."""
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


def mutate(data, doc, n_max=3):
    """Replace or delete up to ``n_max`` random nodes of a JSON document."""
    doc = copy.deepcopy(doc)
    for _ in range(data.draw(st.integers(1, n_max))):
        paths = _paths(doc)
        path = data.draw(st.sampled_from(paths))
        new = data.draw(json_values)
        if not path:
            doc = new
            continue
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        if data.draw(st.booleans()) and isinstance(parent, dict):
            del parent[path[-1]]
        else:
            parent[path[-1]] = new
    return doc


def dump(doc) -> str:
    # allow_nan: NaN/Infinity literals are what a careless writer produces
    return json.dumps(doc, allow_nan=True)


def check(loader, path):
    """Call the loader: a result or an EnergyPlannerError, nothing else."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        try:
            return loader(path)
        except EnergyPlannerError as exc:
            assert str(exc)  # a message, always
            return exc


@pytest.fixture(scope="module")
def fuzzdir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


# ---------------------------------------------------------------------- robot logs
LOG_COLUMNS = [c for c in CANONICAL_COLUMNS if c != "run"]
column_names = st.sampled_from([*LOG_COLUMNS, "run", "payload_kg", "surface", "t", "x.1"])


@st.composite
def log_tables(draw):
    """A log table: mostly the canonical columns, some cells and columns broken."""
    n = draw(st.integers(0, 8))
    good = {
        "t": np.arange(n) * 0.02,
        "qw": np.ones(n),
        "qx": np.zeros(n),
        "qy": np.zeros(n),
        "qz": np.zeros(n),
        "vx": np.full(n, 0.3),
        "vy": np.zeros(n),
        "wz": np.zeros(n),
        "voltage": np.full(n, 50.0),
        "current": np.full(n, 6.0),
    }
    cols = {k: list(v) for k, v in good.items()}
    for name in draw(st.sets(st.sampled_from(list(cols)), max_size=2)):
        del cols[name]  # a missing column
    for name in draw(st.lists(column_names, max_size=3)):
        cols[name] = [draw(scalars) for _ in range(n)]  # a column of anything
    for _ in range(draw(st.integers(0, 4))):  # single broken cells
        if n and cols:
            name = draw(st.sampled_from(sorted(cols)))
            cols[name][draw(st.integers(0, n - 1))] = draw(scalars)
    return pd.DataFrame(cols)


@FUZZ
@given(df=log_tables(), fmt=st.sampled_from(["csv", "parquet"]))
def test_load_logs_tables(fuzzdir, df, fmt):
    from energy_planner.measurements import load_logs, make_windows, preprocess

    p = fuzzdir / f"log.{fmt}"
    if fmt == "csv":
        df.to_csv(p, index=False)
    else:
        try:
            df.to_parquet(p, index=False)
        except Exception:  # noqa: BLE001 - pyarrow cannot store this frame: nothing to load
            return
    res = check(load_logs, p)
    if isinstance(res, pd.DataFrame):  # a loaded log must also go through the pipeline
        res = check(lambda s: make_windows(preprocess(s)[0]), res)


@FUZZ
@given(text=st.text(st.sampled_from('t,qwxyzvcurnlage0123456789.-e\n"; \tx'), max_size=200))
def test_load_logs_csv_text(fuzzdir, text):
    from energy_planner.measurements import load_logs

    p = fuzzdir / "text.csv"
    p.write_text("t,qw,qx,qy,qz,vx,vy,wz,voltage,current\n" + text)
    check(load_logs, p)


@FUZZ
@given(blob=st.binary(max_size=300), suffix=st.sampled_from([".csv", ".parquet"]))
def test_load_logs_bytes(fuzzdir, blob, suffix):
    from energy_planner.measurements import load_logs

    p = fuzzdir / f"bytes{suffix}"
    p.write_bytes(blob)
    check(load_logs, p)


# ---------------------------------------------------------------------- waypoints / paths
VALID_PATH = {
    "type": "FeatureCollection",
    "crs": {"type": "name", "properties": {"name": "EPSG:32631"}},
    "features": [
        {
            "type": "Feature",
            "properties": {
                "format": "energy_planner/path",
                "format_version": 1,
                "crs": "EPSG:32631",
                "yaw_frame": "crs_x_ccw",
                "yaw_deg": [0.0, 90.0, 90.0],
                "t": [0.0, 1.0, 2.0],
            },
            "geometry": {"type": "LineString", "coordinates": [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]},
        }
    ],
}


@FUZZ
@given(data=st.data())
def test_read_waypoints_geojson(fuzzdir, data):
    from energy_planner.energy.waypoints import read_waypoints

    p = fuzzdir / "path.geojson"
    p.write_text(dump(mutate(data, VALID_PATH)))
    check(read_waypoints, p)


@FUZZ
@given(
    header=st.lists(st.sampled_from(["x", "y", "yaw_deg", "t", "X", "yaw", ""]), max_size=5),
    rows=st.lists(
        st.lists(scalars.map(lambda v: "" if v is None else str(v)), max_size=5), max_size=5
    ),
    sep=st.sampled_from([",", ";", "\t"]),
)
def test_read_waypoints_csv(fuzzdir, header, rows, sep):
    from energy_planner.energy.waypoints import read_waypoints

    buf = io.StringIO()
    buf.write(sep.join(header) + "\n")
    for r in rows:
        buf.write(sep.join(r) + "\n")
    p = fuzzdir / "w.csv"
    p.write_text(buf.getvalue())
    check(read_waypoints, p)


@FUZZ
@given(blob=st.binary(max_size=200), suffix=st.sampled_from([".csv", ".geojson", ".dat"]))
def test_read_waypoints_bytes(fuzzdir, blob, suffix):
    from energy_planner.energy.waypoints import read_waypoints

    p = fuzzdir / f"w{suffix}"
    p.write_bytes(blob)
    check(read_waypoints, p)


# ---------------------------------------------------------------------- model JSON
@pytest.fixture(scope="module")
def model_doc():
    from energy_planner.model import EnergyModel

    return EnergyModel.default().to_dict()


@FUZZ
@given(data=st.data())
def test_model_load(fuzzdir, model_doc, data):
    from energy_planner.model import EnergyModel

    p = fuzzdir / "model.json"
    p.write_text(dump(mutate(data, model_doc)))
    check(EnergyModel.load, p)


# ---------------------------------------------------------------------- keep-out GeoJSON
VALID_KEEP_OUT = {
    "type": "FeatureCollection",
    "features": [
        {
            "type": "Feature",
            "properties": {},
            "geometry": {
                "type": "Polygon",
                "coordinates": [[[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]]],
            },
        }
    ],
}


@FUZZ
@given(data=st.data())
def test_load_keep_out(fuzzdir, data):
    from energy_planner.planning.limits import load_keep_out

    p = fuzzdir / "keep_out.geojson"
    p.write_text(dump(mutate(data, VALID_KEEP_OUT)))
    check(load_keep_out, p)


# ---------------------------------------------------------------------- the harness itself
def test_mutate_reaches_every_node():
    """The mutation can touch any node (the fuzz would be blind to parts it cannot)."""
    paths = _paths(VALID_PATH)
    assert ("features", 0, "geometry", "coordinates", 2, 1) in paths
    assert ("crs", "properties", "name") in paths and () in paths
    assert len(paths) == len(set(paths))


def test_check_lets_other_exceptions_through(tmp_path):
    def bad(_):
        raise KeyError("x")

    with pytest.raises(KeyError):
        check(bad, tmp_path)
    assert math.isnan(check(lambda _: float("nan"), Path(".")))


# ---------------------------------------------------------------------- DEM rasters
@FUZZ
@given(blob=st.binary(max_size=400), suffix=st.sampled_from([".tif", ".asc", ".img"]))
def test_load_dem_bytes(fuzzdir, blob, suffix):
    from energy_planner.terrain import load_dem

    p = fuzzdir / f"dem{suffix}"
    p.write_bytes(blob)
    check(load_dem, p)


@FUZZ
@given(
    rows=st.lists(
        st.lists(scalars.map(lambda v: "" if v is None else str(v)), min_size=1, max_size=4),
        min_size=1,
        max_size=4,
    ),
    ncols=st.integers(-2, 5),
    cellsize=st.sampled_from(["1", "0", "-1", "nan", "x"]),
    nodata=st.sampled_from(["", "NODATA_value -9999\n", "NODATA_value nan\n"]),
)
def test_load_dem_ascii_grid(fuzzdir, rows, ncols, cellsize, nodata):
    """Esri ASCII grids (a text raster GDAL reads) with broken headers and cells."""
    from energy_planner.terrain import load_dem

    p = fuzzdir / "grid.asc"
    head = (
        f"ncols {ncols}\nnrows {len(rows)}\nxllcorner 0\nyllcorner 0\ncellsize {cellsize}\n{nodata}"
    )
    p.write_text(head + "\n".join(" ".join(r) for r in rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # no CRS: local metres
        check(load_dem, p)
