"""#19 point 2: channel values are typed by the model's formulas and checked, by every door.

A model with ``load_kg * speed`` reads a number; one with ``speed * (ground == 'mud')``
reads a category and names one, 'mud'. A unit typed into a number, a number or a
miscased name given for a category are errors naming the channel, the value and what is
valid, in the library (``Channels.resolve``, run by every kernel) and on the command line
of every command that takes ``--set`` (exit 2, no traceback). ``--allow-unknown-category``
prices an unknown category as none of the named ones, with a warning.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from b1_model import B1, b1_model  # tests/ helper
from click.testing import CliRunner
from hypothesis import example, given, settings
from hypothesis import strategies as st

from energy_planner.cli import main
from energy_planner.energy import path_energy
from energy_planner.energy.channels import Category, Channels, channel_kinds
from energy_planner.errors import ChannelError
from energy_planner.maps import map_path
from energy_planner.model import EnergyModel
from energy_planner.request import Request
from energy_planner.terrain import Terrain

X0, Y0, N = 500000.0, 5000000.0, 60  # a flat 60 m x 60 m DEM
F0, K_LOAD, K_MUD = 600.0, 7.0, 250.0  # N on level ground; W per kg m/s; extra N on mud
BASE = dict.fromkeys(B1, 0.0) | {"fwd_const": F0}
MUD = "speed * (ground == 'mud')"
LOAD_MODEL = b1_model(BASE, extra={"load_kg * speed": K_LOAD})
MUD_MODEL = b1_model(BASE, extra={MUD: K_MUD})
HILL = str(map_path("hill"))
START, GOAL = "500058,5000046", "500058,5000084"


@pytest.fixture(scope="module")
def flat():
    return Terrain.from_array(np.full((N, N), 100.0), origin=(X0, Y0))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("values")
    wp = d / "w.csv"
    wp.write_text(f"x,y\n{X0 + 10},{Y0 + 30}\n{X0 + 50},{Y0 + 30}\n")
    hill_wp = d / "hw.csv"
    hill_wp.write_text("x,y\n" + START + "\n" + GOAL + "\n")
    sites = d / "sites.csv"
    sites.write_text("x,y\n500058,5000046\n500058,5000084\n500090,5000060\n")
    flat_tif = d / "flat.tif"
    _write_tif(flat_tif, np.full((N, N), 100.0))
    return {
        "wp": wp,
        "hill_wp": hill_wp,
        "sites": sites,
        "flat": flat_tif,
        "load": LOAD_MODEL.save(d / "load.json"),
        "mud": MUD_MODEL.save(d / "mud.json"),
        "dir": d,
    }


def _write_tif(path, z, dtype="float32", nodata=None):
    import rasterio
    from affine import Affine

    z = np.asarray(z)
    with rasterio.open(
        path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype=dtype,
        crs="EPSG:32631", transform=Affine(1.0, 0, X0, 0, -1.0, Y0 + z.shape[0]), nodata=nodata,
    ) as dst:  # fmt: skip
        dst.write(z.astype(dtype), 1)
    return path


def _run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


# ------------------------------------------------------------------ kinds from formulas
def test_kinds_are_read_from_the_formulas():
    m = EnergyModel(
        [MUD, "load_kg * speed", "(air_temp > 30) * speed", "speed * (ground != 'rock')"]
    )
    kinds = channel_kinds(m)
    assert kinds["ground"].categories == ("mud", "rock")
    assert kinds["ground"].terms == (MUD, "speed * (ground != 'rock')")
    assert kinds["load_kg"].categories is None and kinds["air_temp"].categories is None
    assert set(kinds) == {"ground", "load_kg", "air_temp"}  # motion features are not channels


def test_a_channel_read_both_as_category_and_number_is_refused():
    m = EnergyModel([MUD, "ground * speed"])
    with pytest.raises(ChannelError, match=r"'ground' both as a category .*'mud'.*number"):
        channel_kinds(m)


# ------------------------------------------------------------------ numeric channels
@settings(max_examples=40, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, width=32))
def test_any_number_is_a_numeric_value(v):
    assert Channels({"load_kg": v}).resolve(LOAD_MODEL).constants == {"load_kg": float(v)}


@settings(max_examples=40, deadline=None)
@given(
    st.floats(min_value=0, max_value=1e4, allow_nan=False),
    st.sampled_from(["kg", " kg", "kilo", "lb", "%"]),
)
def test_a_unit_in_a_number_names_channel_value_and_a_number(v, unit):
    text = f"{v:g}{unit}"
    with pytest.raises(ChannelError) as ei:
        Channels.parse([f"load_kg={text}"]).resolve(LOAD_MODEL)
    msg = str(ei.value)
    assert "'load_kg'" in msg and repr(text.strip()) in msg and "a number" in msg
    assert ei.value.expected == "a number" and ei.value.channel == "load_kg"


def test_numeric_load_prices_coef_times_load_times_distance(flat):
    """Flat ground, straight line: E = (F0 + k m) L, independent of the speed."""
    e = path_energy(flat, LOAD_MODEL, np.array([[X0 + 10, Y0 + 30], [X0 + 50, Y0 + 30]]),
                    channels=Channels.parse(["load_kg=10"]))  # fmt: skip
    assert e.energy_j == pytest.approx((F0 + K_LOAD * 10) * 40.0, rel=1e-12)


# ------------------------------------------------------------------ categorical channels
@settings(max_examples=30, deadline=None)
@given(st.text(min_size=1, max_size=8).filter(lambda s: s.strip() and "=" not in s))
@example("NAN")  # drawn in CI: a non-finite number is refused before any category check
def test_only_the_named_category_is_accepted(text):
    try:
        nonfinite = not math.isfinite(float(text))
    except ValueError:
        nonfinite = False
    if nonfinite:
        with pytest.raises(ChannelError, match="is not finite"):
            Channels({"ground": text})
        return
    ch = Channels({"ground": text})
    value = ch.constants["ground"]
    as_text = value if isinstance(value, str) else f"{value:g}"
    if as_text == "mud":
        assert ch.resolve(MUD_MODEL).constants == {"ground": "mud"}
        return
    with pytest.raises(ChannelError, match=r"not a category the model names.*'mud'"):
        ch.resolve(MUD_MODEL)


@pytest.mark.parametrize("value", ["3", "Mud", " MUD", "müd"])
def test_number_or_miscased_category_lists_the_categories(value):
    with pytest.raises(ChannelError, match=r"compares ground with 'mud'") as ei:
        Channels.parse([f"ground={value}"]).resolve(MUD_MODEL)
    assert "--allow-unknown-category" in str(ei.value)
    if value.strip().lower() == "mud":
        assert "categories match exactly" in str(ei.value)


def test_a_number_naming_a_category_is_its_text():
    m = EnergyModel(["speed * (ground == '3')"])
    assert Channels.parse(["ground=3"]).resolve(m).constants == {"ground": "3"}
    assert isinstance(Channels.parse(["ground=3"]).resolve(m).constants["ground"], Category)


def test_allowed_unknown_category_is_priced_as_none(flat):
    """'Mud' (not 'mud') allowed: E = F0 L, the no-mud price, with a warning saying so."""
    line = np.array([[X0 + 10, Y0 + 30], [X0 + 50, Y0 + 30]])
    ch = Channels.parse(["ground=Mud"], allow_unknown_categories=True)
    with pytest.warns(UserWarning, match=r"'Mud' is not a category.*priced as none of them"):
        e = path_energy(flat, MUD_MODEL, line, channels=ch)
    assert e.energy_j == pytest.approx(F0 * 40.0, rel=1e-12)
    mud = path_energy(flat, MUD_MODEL, line, channels=Channels.parse(["ground=mud"]))
    assert mud.energy_j == pytest.approx((F0 + K_MUD) * 40.0, rel=1e-12)


# ------------------------------------------------------------------ rasters
def test_raster_kinds_are_checked(files, flat):
    d = files["dir"]
    codes = _write_tif(d / "codes.tif", np.ones((N, N)), dtype="uint8")
    (d / "miscased.csv").write_text("code,ground\n1,Mud\n2,rock\n")
    (d / "numbers.csv").write_text("code,load\n1,5\n2,10\n")
    (d / "cats.csv").write_text("code,load\n1,light\n2,heavy\n")
    (d / "cover.csv").write_text("code,ground\n1,mud\n2,asphalt\n")
    with pytest.raises(ChannelError, match=r"RASTER:TABLE.*--set ground=mud"):
        Channels.parse([], [f"ground={codes}"]).resolve(MUD_MODEL)
    with pytest.raises(ChannelError, match=r"maps codes to numbers"):
        Channels.parse([], [f"ground={codes}:{d / 'numbers.csv'}"]).resolve(MUD_MODEL)
    with pytest.raises(ChannelError, match=r"'Mud' is not a category.*'Mud' is not 'mud'"):
        Channels.parse([], [f"ground={codes}:{d / 'miscased.csv'}"]).resolve(MUD_MODEL)
    with pytest.raises(ChannelError, match=r"as a number.*'heavy', 'light'"):
        Channels.parse([], [f"load_kg={codes}:{d / 'cats.csv'}"]).resolve(LOAD_MODEL)
    # a land-cover table lists every class: those the model does not name are its baseline
    ok = Channels.parse([], [f"ground={codes}:{d / 'cover.csv'}"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok.resolve(MUD_MODEL)
        line = np.array([[X0 + 10, Y0 + 30], [X0 + 50, Y0 + 30]])
        assert path_energy(flat, MUD_MODEL, line, channels=ok).energy_j == pytest.approx(
            (F0 + K_MUD) * 40.0, rel=1e-12
        )


# ------------------------------------------------------------------ every door
def test_library_verbs_check_the_values(files, tmp_path):
    import energy_planner as ep

    bad = Request.make(channels=Channels.parse(["load_kg=10kg"]))
    with pytest.raises(ChannelError, match="'load_kg'.*a number"):
        ep.path_energy(HILL, [(500058, 5000046), (500058, 5000084)], model=LOAD_MODEL,
                       request=bad)  # fmt: skip
    with pytest.raises(ChannelError, match="'load_kg'.*a number"):
        ep.energy_map(HILL, tmp_path / "m.tif", model=LOAD_MODEL, request=bad)
    assert not (tmp_path / "m.tif").exists()
    with pytest.raises(ChannelError, match="'Mud' is not a category"):
        _ = ep.Problem.from_dem(HILL, MUD_MODEL, channels=Channels.parse(["ground=Mud"])).cost


def _cli_cases(files):
    out = files["dir"] / "out.tif"
    return {
        "energy": ["energy", "--dem", HILL, "--waypoints", files["hill_wp"]],
        "energy-map": ["energy-map", HILL, "--out", out],
        "plan": ["plan", "--dem", HILL, "--start", START, "--goal", GOAL],
        "compare-routes": ["compare-routes", "--dem", HILL, "--start", START, "--goal", GOAL],
        "demo": ["demo"],
        "reach": ["reach", HILL, "--start", START],
        "mission": ["mission", "--dem", HILL, "--sites", files["sites"]],
    }


@pytest.mark.parametrize(
    "cmd", ["energy", "energy-map", "plan", "compare-routes", "demo", "reach", "mission"]
)
def test_every_command_refuses_a_unit_and_an_unknown_category(files, cmd):
    args = _cli_cases(files)[cmd]
    r = _run([*args, "--model", files["load"], "--set", "load_kg=10kg"])
    assert r.exit_code == 2, r.output
    assert "'load_kg'" in r.output and "'10kg'" in r.output and "a number" in r.output
    assert "Traceback" not in r.output and "numba" not in r.output
    r = _run([*args, "--model", files["mud"], "--set", "ground=Mud"])
    assert r.exit_code == 2, r.output
    assert "'Mud'" in r.output and "'mud'" in r.output and "--allow-unknown-category" in r.output
    assert "Traceback" not in r.output


def test_cli_allow_unknown_category_prices_none_and_warns(files):
    base = ["energy", "--dem", files["flat"], "--waypoints", files["wp"], "--model",
            files["mud"], "--json"]  # fmt: skip
    r = _run([*base, "--set", "ground=3"])
    assert r.exit_code == 2 and "'3' is not a category" in r.output and "'mud'" in r.output
    r = _run([*base, "--set", "ground=3", "--allow-unknown-category"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert res["energy_j"] == pytest.approx(F0 * 40.0, rel=1e-9)
    assert any("priced as none of them" in n for n in res["notes"])


# ------------------------------------------------------------------ #21 point 3
def test_set_values_are_kernel_inputs_not_compiled_in(flat):
    """Two --set values share one compiled kernel and each gives (F0 + k m) L."""
    from energy_planner.energy import MotionCost

    line = np.array([[X0 + 10, Y0 + 30], [X0 + 50, Y0 + 30]])
    costs = {v: MotionCost(flat, LOAD_MODEL, channels=Channels({"load_kg": v})) for v in (3, 41)}
    assert costs[3].kernel is costs[41].kernel  # one module from the kernel cache
    sources = {
        LOAD_MODEL.kernel_source(c.constants, c.channels.kernel_layout(runtime=True))
        for c in costs.values()
    }
    assert len(sources) == 1 and "41" not in sources.pop()
    for v, cost in costs.items():
        e = path_energy(flat, LOAD_MODEL, line, cost=cost)
        assert e.energy_j == pytest.approx((F0 + K_LOAD * v) * 40.0, rel=1e-12)
    mud = MotionCost(flat, MUD_MODEL, channels=Channels({"ground": "mud"}))
    assert mud.channels.kernel_layout(runtime=True) == [("ground", ("mud",))]
    assert mud.channels.stack((N, N), runtime=True)[0].shape == (1, 1, 1)  # index 0: mud
    assert path_energy(flat, MUD_MODEL, line, cost=mud).energy_j == pytest.approx(
        (F0 + K_MUD) * 40.0, rel=1e-12
    )
