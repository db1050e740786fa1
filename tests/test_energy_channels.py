"""Extra channels (``--set`` / ``--channel``): hand-worked energies of models that read a
constant payload, a numeric raster and a categorical land-cover raster, and errors that
name the channel."""

from __future__ import annotations

import json

import numpy as np
import pytest
from affine import Affine
from b1_model import B1, b1_model  # tests/ helper
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.energy import MotionCost, path_energy
from energy_planner.energy.channels import ChannelRaster, Channels, read_value_table
from energy_planner.errors import (
    ChannelError,
    ChannelIOError,
    MissingChannelError,
    OutsideMapError,
)
from energy_planner.terrain import Terrain

X0, Y0, N = 500000.0, 5000000.0, 100  # south-west corner of a flat 100 m x 100 m DEM
F0 = 600.0  # N, forward on level ground
K_LOAD = 7.0  # W per (kg m/s)
K_MEADOW = 250.0  # extra N on meadow
BASE = dict.fromkeys(B1, 0.0) | {"fwd_const": F0}
LOAD_MODEL = b1_model(BASE, extra={"load_kg * speed": K_LOAD})
GROUND = "speed * (ground == 'meadow')"
GROUND_MODEL = b1_model(BASE, extra={GROUND: K_MEADOW})


def write_tif(path, z, res=1.0, x0=X0, y0=Y0, crs="EPSG:32631", nodata=None, dtype="float32"):
    """A one-band GeoTIFF whose south-west outer corner is (x0, y0); row 0 is north."""
    import rasterio

    z = np.asarray(z)
    profile = dict(
        driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype=dtype, crs=crs,
        transform=Affine(res, 0.0, x0, 0.0, -res, y0 + res * z.shape[0]), nodata=nodata,
    )  # fmt: skip
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z.astype(dtype), 1)
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("channels")
    out = {"dem": write_tif(d / "flat.tif", np.full((N, N), 100.0))}
    # land cover at 5 m (a coarser grid than the DEM): code 1 (meadow) west of x0 + 50 m,
    # code 2 (asphalt) east of it
    codes = np.where(np.arange(20) < 10, 1, 2)[None, :].repeat(20, axis=0)
    out["cover"] = write_tif(d / "cover.tif", codes, res=5.0, dtype="uint8", nodata=0)
    out["table"] = d / "cover.csv"
    out["table"].write_text("code,ground\n1,meadow\n2,asphalt\n")
    # load over the map: 0.1 kg per metre eastward, on the DEM's own grid
    xc = 0.5 + np.arange(N)
    out["load"] = write_tif(d / "load.tif", np.tile(0.1 * xc, (N, 1)))
    out["load_model"] = LOAD_MODEL.save(d / "load_model.json")
    out["ground_model"] = GROUND_MODEL.save(d / "ground_model.json")
    return out


@pytest.fixture(scope="module")
def flat():
    return Terrain.from_array(np.full((N, N), 100.0), origin=(X0, Y0))


def line(x_from, x_to, y=50.0):
    return np.array([[X0 + x_from, Y0 + y], [X0 + x_to, Y0 + y]])


# ------------------------------------------------------------------------ hand-worked energies
def test_constant_load_adds_k_load_times_distance(flat):
    """P = F0 vx + k m v on flat ground: E = (F0 + k m) L, whatever the speed."""
    for speed in (0.3, 0.6):
        e = path_energy(flat, LOAD_MODEL, line(20, 80), speed=speed,
                        channels=Channels({"load_kg": 10.0}))  # fmt: skip
        assert e.energy_j == pytest.approx((F0 + K_LOAD * 10.0) * 60.0, rel=1e-12)


def test_cli_set_load_equals_the_analytic_value(files, tmp_path):
    wp = tmp_path / "w.csv"
    wp.write_text(f"x,y\n{X0 + 20},{Y0 + 50}\n{X0 + 80},{Y0 + 50}\n")
    args = ["energy", "--dem", files["dem"], "--waypoints", wp, "--model", files["load_model"]]
    r = CliRunner().invoke(main, [*map(str, args), "--set", "load_kg=10", "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert res["energy_j"] == pytest.approx((F0 + K_LOAD * 10.0) * 60.0, rel=1e-9)
    assert res["channels"]["constants"] == {"load_kg": 10.0}


def test_numeric_raster_is_integrated_along_the_path(files, flat):
    """load = 0.1 x (bilinear, exact for a linear field): E = F0 L + k 0.1 (x1^2 - x0^2)/2."""
    ch = Channels.parse([], [f"load_kg={files['load']}"]).bind(flat)
    assert not ch.rasters["load_kg"].nearest
    e = path_energy(flat, LOAD_MODEL, line(20, 80), channels=ch)
    assert e.energy_j == pytest.approx(F0 * 60 + K_LOAD * 0.1 * (80**2 - 20**2) / 2, rel=1e-9)


def test_categorical_raster_half_meadow_half_asphalt(files):
    """30 m of meadow then 30 m of asphalt: E = F0 60 + K_MEADOW 30, either way."""
    spec = f"ground={files['cover']}:{files['table']}"
    from energy_planner.terrain import load_dem

    t = load_dem(files["dem"])
    ch = Channels.parse([], [spec]).bind(t)
    for a, b in [(20, 80), (80, 20), (45, 55)]:
        e = path_energy(t, GROUND_MODEL, line(a, b), channels=ch)
        meadow = max(0.0, min(50, max(a, b)) - min(a, b))
        assert e.energy_j == pytest.approx(F0 * abs(b - a) + K_MEADOW * meadow, rel=1e-12)


def test_cli_channel_with_value_table(files, tmp_path):
    wp = tmp_path / "w.csv"
    wp.write_text(f"x,y\n{X0 + 20},{Y0 + 50}\n{X0 + 80},{Y0 + 50}\n")
    args = ["energy", "--dem", files["dem"], "--waypoints", wp, "--model", files["ground_model"],
            "--channel", f"ground={files['cover']}:{files['table']}", "--json"]  # fmt: skip
    r = CliRunner().invoke(main, list(map(str, args)))
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert res["energy_j"] == pytest.approx(F0 * 60 + K_MEADOW * 30, rel=1e-9)
    (desc,) = res["channels"]["rasters"]
    assert desc["categories"] == ["asphalt", "meadow"] and desc["sampling"] == "nearest"
    # the same ground given as a constant everywhere
    args[-3:-1] = ["--set", "ground=meadow"]
    r = CliRunner().invoke(main, list(map(str, args)))
    assert json.loads(r.stdout)["energy_j"] == pytest.approx((F0 + K_MEADOW) * 60, rel=1e-9)


def test_lower_bound_covers_every_category(files, flat):
    """The planners' admissible bound is the cheaper category's (asphalt), not meadow's."""
    m = b1_model(BASE | {"bwd_const": F0, "lat_const": F0}, extra={GROUND: K_MEADOW})
    ch = Channels.parse([], [f"ground={files['cover']}:{files['table']}"])
    assert MotionCost(flat, m, channels=ch).min_cost_per_metre == pytest.approx(0.95 * F0)
    meadow = MotionCost(flat, m, channels=Channels({"ground": "meadow"}))
    assert meadow.min_cost_per_metre == pytest.approx(0.95 * (F0 + K_MEADOW))


# ------------------------------------------------------------------------ errors
def test_missing_channel_names_it_and_the_options(flat, files, tmp_path):
    with pytest.raises(MissingChannelError, match=r"'load_kg'.*channels given: ground") as ei:
        MotionCost(flat, LOAD_MODEL, channels=Channels({"ground": "meadow"}))
    assert ei.value.missing == ["load_kg"] and "--set" in str(ei.value)
    wp = tmp_path / "w.csv"
    wp.write_text(f"x,y\n{X0 + 20},{Y0 + 50}\n{X0 + 80},{Y0 + 50}\n")
    args = ["energy", "--dem", files["dem"], "--waypoints", wp, "--model", files["load_model"]]
    r = CliRunner().invoke(main, list(map(str, args)))
    assert r.exit_code == 2 and "load_kg" in r.output and "--set NAME=VALUE" in r.output
    assert "Traceback" not in r.output


@pytest.mark.parametrize(
    "sets, channels, match",
    [
        (["load_kg"], [], "expected NAME=VALUE"),
        (["vx=1"], [], "motion feature"),
        (["2kg=1"], [], "not a name"),
        (["load_kg=inf"], [], "not finite"),
        (["a=1", "a=2"], [], "set twice"),
        (["a=1"], ["a=x.tif"], "given twice"),
        ([], ["ground"], "NAME=RASTER"),
    ],
)
def test_bad_channel_strings(sets, channels, match):
    with pytest.raises(ChannelError, match=match):
        Channels.parse(sets, channels)


def test_bad_files(files, flat, tmp_path):
    with pytest.raises(ChannelIOError, match="nope.tif"):
        Channels.parse([], ["ground=nope.tif"])
    with pytest.raises(ChannelIOError, match="nope.csv"):
        Channels.parse([], [f"ground={files['cover']}:nope.csv"])
    bad = tmp_path / "bad.csv"
    bad.write_text("code,ground\n1,meadow\nx,asphalt\n")
    with pytest.raises(ChannelError, match="line 3: code 'x' is not a number"):
        read_value_table(bad)
    short = tmp_path / "short.json"
    short.write_text('{"1": "meadow"}')
    with pytest.raises(ChannelError, match=r"code\(s\) 2 that value table .*short.json"):
        Channels.parse([], [f"ground={files['cover']}:{short}"]).bind(flat)
    r = CliRunner().invoke(main, ["energy", "--dem", str(files["dem"]), "--waypoints", "w.csv",
                                  "--set", "speed=3"])  # fmt: skip
    assert r.exit_code == 2 and "--set" in r.output and "motion feature" in r.output


def test_motion_where_a_raster_has_no_value_is_named(files, tmp_path):
    """The land-cover raster covers x < 100 m only of a wider DEM."""
    from energy_planner.terrain import load_dem

    wide = write_tif(tmp_path / "wide.tif", np.full((N, 2 * N), 100.0))
    t = load_dem(wide)
    with pytest.warns(UserWarning, match="no value on 5"):
        ch = Channels.parse([], [f"ground={files['cover']}:{files['table']}"]).bind(t)
    assert ch.rasters["ground"].coverage == pytest.approx(0.5, abs=0.02)
    with pytest.raises(OutsideMapError, match="channel raster has no value"):
        path_energy(t, GROUND_MODEL, line(80, 120), channels=ch)


def test_raster_given_as_values_on_the_grid(flat):
    values = np.where(np.arange(N) < 50, 1.0, 0.0)[None, :].repeat(N, axis=0)
    ch = Channels(rasters={"ground": ChannelRaster("ground", values=values,
                                                    categories=("asphalt", "meadow"))})  # fmt: skip
    e = path_energy(flat, GROUND_MODEL, line(20, 80), channels=ch)
    assert e.energy_j == pytest.approx(F0 * 60 + K_MEADOW * 30, rel=1e-12)
