"""Energy model: formulas, catalog, fit, JSON, compiled kernel."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.energy.grade import critical_grade
from energy_planner.errors import FitError, FormulaError, ModelError
from energy_planner.model import (
    BASE_TERMS,
    CATALOG,
    EFFECT_TERMS,
    EnergyModel,
    parse_formula,
)

#: B1-class coefficients (a mechanistic 50 kg quadruped; N, N m and W).
B1 = {
    "fwd_const": 130.0,
    "fwd_up": 720.0,
    "fwd_down": -300.0,
    "bwd_const": 150.0,
    "bwd_up": 720.0,
    "bwd_down": -100.0,
    "lat_const": 230.0,
    "lat_up": 720.0,
    "lat_down": -20.0,
    "turn_const": 105.0,
    "turn_slope": 255.0,
    "idle_power": 137.0,
    "tilt_x_sq": 1760.0,
    "tilt_y_sq": 370.0,
    "fwd_brake_sq": -1660.0,
    "bwd_brake_sq": -1120.0,
    "lat_tilt_sq": 1510.0,
}


def _features(rng, n):
    return {
        "alpha": rng.uniform(0, np.radians(30), n),
        "gamma": rng.uniform(-np.pi, np.pi, n),
        "vx": rng.uniform(-0.5, 0.5, n),
        "vy": rng.uniform(-0.5, 0.5, n),
        "wz": rng.uniform(-0.8, 0.8, n),
        "ax": rng.normal(0, 0.2, n),
        "ay": rng.normal(0, 0.2, n),
        "payload_kg": rng.choice([0.0, 5.0, 10.0], n),
    }


# ---------------------------------------------------------------- formulas
@pytest.mark.parametrize(
    "bad, fragment",
    [
        ("__import__('os').system('x')", "unknown function"),
        ("open('f')", "unknown function 'open'"),
        ("speed.real", "Attribute"),
        ("[1, 2]", "List"),
        ("lambda: 1", "Lambda"),
        ("sin(alpha, gamma)", "takes 1 argument"),
        ("speed +", "cannot parse"),
        ("sin", "is a function"),
        ("0 < speed < 1", "one comparison"),
    ],
)
def test_formula_rejects_unsafe_or_malformed(bad, fragment):
    with pytest.raises(FormulaError, match=fragment):
        parse_formula(bad)


def test_formula_names_the_missing_variable():
    f = parse_formula("payload_kg * speed * sin(alpha)")
    with pytest.raises(FormulaError, match="'payload_kg'.*available: alpha, speed"):
        f.evaluate({"alpha": np.zeros(2), "speed": np.ones(2)})


def test_formula_values_match_hand_computation():
    f = parse_formula("pos(-sin(alpha) * (vx * cos(gamma) - vy * sin(gamma)))")
    a, g, vx, vy = np.radians(20), np.radians(150), 0.3, 0.1
    descent = -np.sin(a) * (vx * np.cos(g) - vy * np.sin(g))
    assert f.evaluate({"alpha": a, "gamma": g, "vx": vx, "vy": vy}) == pytest.approx(
        max(descent, 0)
    )


# ---------------------------------------------------------------- physics of the base terms
@settings(max_examples=60, deadline=None)
@given(
    alpha=st.floats(0, np.radians(40)),
    gamma=st.floats(-np.pi, np.pi),
    vx=st.floats(-1, 1),
    vy=st.floats(-1, 1),
    wz=st.floats(-1, 1),
)
def test_every_catalog_term_is_mirror_symmetric(alpha, gamma, vx, vy, wz):
    """P(alpha, gamma, vx, vy, wz) == P(alpha, -gamma, vx, -vy, -wz) (design notes)."""
    m = EnergyModel([*BASE_TERMS, *EFFECT_TERMS], dict.fromkeys([*BASE_TERMS, *EFFECT_TERMS], 1.0))
    base = {"alpha": alpha, "gamma": gamma, "vx": vx, "vy": vy, "wz": wz, "ax": 0.1, "ay": 0.2}
    base["payload_kg"] = 3.0
    mirror = {**base, "gamma": -gamma, "vy": -vy, "wz": -wz, "ay": -0.2}
    np.testing.assert_allclose(m.design_matrix(mirror), m.design_matrix(base), atol=1e-12)


def test_base_model_is_the_wrench_dotted_with_the_twist():
    """Hand-computed power at 10 deg: per-metre forces times rates, plus per-second terms."""
    m = EnergyModel(BASE_TERMS, B1)
    a = np.radians(10)
    s = np.sin(a)

    def power(gamma, vx=0.0, vy=0.0, wz=0.0):
        return m.power({"alpha": a, "gamma": gamma, "vx": vx, "vy": vy, "wz": wz})[0]

    idle = 137.0
    assert power(0.0, vx=0.3) == pytest.approx((130 + 720 * s) * 0.3 + idle + 1760 * s**2)
    down = (130 - 300 * s) * 0.3 + idle + (1760 - 1660) * s**2
    assert power(np.pi, vx=0.3) == pytest.approx(down)
    # across the slope, uphill on either side: the same roll-holding cost
    across = 130 * 0.3 + idle + 370 * s**2
    assert power(np.pi / 2, vx=0.3) == pytest.approx(across)
    assert power(-np.pi / 2, vx=0.3) == pytest.approx(across)
    # backward facing downhill climbs (and does not brake)
    assert power(np.pi, vx=-0.3) == pytest.approx((150 + 720 * s) * 0.3 + idle + 1760 * s**2)
    # uphill on the right (gamma = +pi/2): stepping right (vy < 0) climbs, left descends
    lat_hold = idle + (370 + 1510) * s**2
    assert power(np.pi / 2, vy=-0.3) == pytest.approx((230 + 720 * s) * 0.3 + lat_hold)
    assert power(np.pi / 2, vy=0.3) == pytest.approx((230 - 20 * s) * 0.3 + lat_hold)
    # side-stepping with the slope along the body x axis
    assert power(0.0, vy=0.3) == pytest.approx(230 * 0.3 + idle + 1760 * s**2)
    turn = (105 + 255 * s) * 0.5 + idle + 1760 * (s * np.cos(1)) ** 2 + 370 * (s * np.sin(1)) ** 2
    assert power(1.0, wz=-0.5) == pytest.approx(turn)
    # walking diagonally on level ground: each gait's force weighted by cos^2 of its angle
    v = 0.3 / np.sqrt(2)
    diag = m.power({"alpha": 0.0, "gamma": 0.0, "vx": v, "vy": v, "wz": 0.0})[0]
    assert diag == pytest.approx(idle + (130 + 230) / 2 * 0.3)


def test_base_reproduces_the_shapes_of_fig4_and_fig5():
    """Paper Fig. 4/5: uphill cost rises with slope; downhill it falls only forward;
    lateral stays dearer and worsens with slope both ways; yaw torque grows with slope."""
    m = EnergyModel(BASE_TERMS, B1)
    a = np.radians(np.arange(0.0, 26.0, 5.0))
    n = len(a)

    def cost(gamma, vx=0.0, vy=0.0, wz=0.0):
        f = {
            "alpha": a,
            "gamma": np.full(n, gamma),
            "vx": np.full(n, vx),
            "vy": np.full(n, vy),
            "wz": np.full(n, wz),
        }
        return m.power(f) / max(abs(vx), abs(vy), abs(wz))

    assert np.all(np.diff(cost(0.0, vx=0.3)) > 0)  # forward uphill
    assert np.all(np.diff(cost(np.pi, vx=0.3)) < 0)  # forward downhill
    assert np.all(np.diff(cost(-np.pi / 2, vy=0.3)) > 0)  # lateral uphill
    assert np.all(np.diff(cost(np.pi / 2, vy=0.3)) > 0)  # lateral downhill: dearer too
    assert np.all(cost(np.pi / 2, vy=0.3) > cost(np.pi, vx=0.3))
    assert np.all(np.diff(cost(0.0, wz=0.5)) > 0)  # yaw torque


def test_convex_uphill_cost_has_a_critical_grade():
    """c(g) = c0 + c1 g + c2 g^2 per metre; c(g)/g is least at g* = sqrt(c0 / c2)."""
    m = EnergyModel(BASE_TERMS, B1)
    g = np.linspace(0.02, 0.7, 20000)
    f = {
        "alpha": np.arcsin(g),
        "gamma": np.zeros_like(g),
        "vx": np.full_like(g, 0.3),
        "vy": np.zeros_like(g),
        "wz": np.zeros_like(g),
    }
    c = m.power(f) / 0.3
    c0, c2 = 130 + 137 / 0.3, 1760 / 0.3
    assert g[np.argmin(c / g)] == pytest.approx(np.sqrt(c0 / c2), abs=1e-3)


def test_power_never_negative_without_a_regenerative_model():
    m = EnergyModel(["fwd_const", "fwd_down"], {"fwd_const": 100.0, "fwd_down": -1000.0})
    steep_descent = {"alpha": np.radians(30), "gamma": np.pi, "vx": 0.3, "vy": 0.0, "wz": 0.0}
    assert m.power(steep_descent)[0] == 0.0
    regen = EnergyModel(m.term_specs, m.coefficients, regenerative=True)
    assert regen.power(steep_descent)[0] == pytest.approx((100 - 500) * 0.3)


@pytest.mark.parametrize("direction", [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)])
def test_linearity_in_the_twist_per_direction(direction):
    """Paper III-B: along one direction of motion the wrench is fixed, so power is the
    per-second terms plus a force times the rate: lambda*w1 + w2 (same direction) costs
    lambda*(P1 - P0) + (P2 - P0) + P0, with P0 the per-second part of that gait (idle,
    holding the slope load; the gait's own holding terms are on from 0.05 m/s)."""
    m = EnergyModel(BASE_TERMS, B1)
    f = {"alpha": 0.2, "gamma": 0.7}

    def p(rate):
        return m.power(
            {
                **f,
                **dict(zip(("vx", "vy", "wz"), np.multiply(direction, rate), strict=True)),
                "speed": np.hypot(direction[0], direction[1]) * rate,
            }
        )[0]

    p1, p2 = p(0.2), p(0.1)
    p0 = 2 * p2 - p1  # affine in the rate: extrapolate to rate 0
    assert p(3 * 0.2 + 0.1) == pytest.approx(3 * (p1 - p0) + (p2 - p0) + p0)


# ---------------------------------------------------------------- fit
def test_fit_recovers_coefficients_from_noiseless_data():
    rng = np.random.default_rng(1)
    f = _features(rng, 400)
    truth = EnergyModel([*BASE_TERMS, "payload"], {**B1, "payload": 9.0})
    p = truth.power(f)
    fitted = EnergyModel(truth.term_specs).fit(f, p)
    for name, value in truth.coefficients.items():
        assert fitted.coefficients[name] == pytest.approx(value, rel=1e-8, abs=1e-8)


def test_fit_standard_errors_cover_the_truth_under_noise():
    rng = np.random.default_rng(2)
    f = _features(rng, 3000)
    truth = EnergyModel(BASE_TERMS, B1)
    p = truth.power(f) + rng.normal(0, 5.0, 3000)
    fitted = EnergyModel(BASE_TERMS).fit(f, p)
    z = [(fitted.coefficients[n] - B1[n]) / fitted.stderr[n] for n in BASE_TERMS]
    assert np.all(np.abs(z) < 4.5)


def test_fit_on_group_means():
    rng = np.random.default_rng(3)
    f = _features(rng, 600)
    groups = np.repeat(np.arange(60), 10)
    truth = EnergyModel(BASE_TERMS, B1)
    p = truth.power(f)
    per_group = EnergyModel(BASE_TERMS).fit(f, p, groups=groups)
    assert per_group.coefficients["lat_tilt_sq"] == pytest.approx(1510.0, rel=1e-7)


def test_fit_errors_are_specific():
    rng = np.random.default_rng(4)
    f = _features(rng, 5)
    with pytest.raises(FitError, match="too little data: 5 rows for 17 terms"):
        EnergyModel(BASE_TERMS).fit(f, np.ones(5))
    f = _features(rng, 200)
    f["vy"] = np.zeros(200)
    with pytest.raises(
        FitError, match="lat_const, lat_up, lat_down, lat_tilt_sq are zero on every"
    ):
        EnergyModel(BASE_TERMS).fit(f, np.ones(200))
    f = _features(rng, 200)
    with pytest.raises(FitError, match=r"cos\(gamma\) \(a combination of fwd_up, fwd_down\)"):
        EnergyModel(["fwd_up", "fwd_down", "pos(vx) * sin(alpha) * cos(gamma)"]).fit(
            f, np.ones(200)
        )
    with pytest.raises(ModelError, match="term 'payload'.*'payload_kg'"):
        EnergyModel(["payload"]).fit(
            {k: v for k, v in f.items() if k != "payload_kg"}, np.ones(200)
        )


# ---------------------------------------------------------------- JSON
def test_json_round_trip_with_custom_term(tmp_path):
    m = EnergyModel(
        [*BASE_TERMS, "payload_kg*speed*sin(alpha)"],
        {**B1, "payload_kg * speed * sin(alpha)": 3.5},
        metadata={"robot": "x"},
    )
    path = m.save(tmp_path / "m.json")
    back = EnergyModel.load(path)
    assert back.term_names == m.term_names
    assert back.coefficients == m.coefficients
    f = _features(np.random.default_rng(5), 50)
    np.testing.assert_array_equal(back.power(f), m.power(f))


def test_json_rejects_bad_documents(tmp_path):
    good = EnergyModel(BASE_TERMS, B1).to_dict()
    cases = [
        ({**good, "version": 99}, "version 99 is not supported"),
        ({**good, "terms": [*good["terms"], {"name": "warp_drive"}]}, "unknown term 'warp_drive'"),
        (
            {**good, "coefficients": {k: v for k, v in B1.items() if k != "lat_up"}},
            "coefficient of term 'lat_up' is missing",
        ),
        ({**good, "schema": "other"}, "not an energy_planner model"),
    ]
    for doc, msg in cases:
        p = tmp_path / "bad.json"
        p.write_text(json.dumps(doc))
        with pytest.raises(ModelError, match=msg):
            EnergyModel.load(p)
    with pytest.raises(ModelError, match="does not exist"):
        EnergyModel.load(tmp_path / "missing.json")


@pytest.mark.parametrize(
    "change, fragment",
    [
        ({"terms": True}, "'terms' must be a list"),
        ({"terms": [None]}, r"terms\[0\] must be a name or an object"),
        ({"terms": [["x"]]}, r"terms\[0\] must be a name or an object"),
        ({"terms": [{"name": ["a"]}]}, r"terms\[0\].name must be a string"),
        ({"terms": [{}]}, r"terms\[0\] has neither a name nor a formula"),
        ({"coefficients": [1]}, "'coefficients' must be an object"),
        ({"stderr": 5}, "'stderr' must be an object"),
        ({"stderr": {"fwd_const": "x"}}, "stderr of term 'fwd_const' must be a number"),
        ({"metadata": [1]}, "'metadata' must be a free-form object"),
    ],
)
def test_malformed_model_documents_raise_model_errors(tmp_path, change, fragment):
    """Each of these raised a builtin TypeError/AttributeError before (fuzzing, BUGS.md)."""
    p = tmp_path / "m.json"
    p.write_text(json.dumps({**EnergyModel(BASE_TERMS, B1).to_dict(), **change}))
    with pytest.raises(ModelError, match=fragment):
        EnergyModel.load(p)


def test_default_model_loads_and_is_physical():
    m = EnergyModel.default()
    assert set(BASE_TERMS) <= set(m.term_names)
    flat = {"alpha": 0.0, "gamma": 0.0, "vx": 0.3, "vy": 0.0, "wz": 0.0}
    assert 50 < m.power(flat)[0] < 500


# ---------------------------------------------------------------- compiled kernel
def test_compiled_kernel_matches_numpy_power():
    rng = np.random.default_rng(6)
    f = _features(rng, 200)
    terms = [*BASE_TERMS, *EFFECT_TERMS, "speed * (surface == 'mud')"]
    m = EnergyModel(terms, {t: float(i + 1) for i, t in enumerate(EnergyModel(terms).term_names)})
    kernel = m.power_kernel({"payload_kg": 7.0, "surface": "mud"})
    f["payload_kg"] = np.full(200, 7.0)
    f["surface"] = np.array(["mud"] * 200)
    expected = m.power(f)
    got = [
        kernel(*(f[k][i] for k in ("alpha", "gamma", "vx", "vy", "wz", "ax", "ay")))[0]
        for i in range(200)
    ]
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_kernel_needs_constants_for_extra_channels():
    m = EnergyModel(["payload"], {"payload": 1.0})
    with pytest.raises(FormulaError, match="needs 'payload_kg'"):
        m.kernel_source()


def test_catalog_terms_have_explanations():
    for term in CATALOG.values():
        assert len(term.explanation) > 20 and term.unit


def test_critical_grade_closed_form_matches_a_search():
    """g* = sqrt(fwd_const / fwd_up_sq) minimises the climbing energy per metre of height."""
    m = EnergyModel(BASE_TERMS, B1)
    c = critical_grade(m)
    assert c["method"] == "closed form"
    assert c["grade"] == pytest.approx(np.sqrt((130 * 0.3 + 137) / 1760))
    g = np.sin(np.radians(np.arange(0.5, 60.0, 0.001)))
    cost = (130 + 137 / 0.3 + 720 * g + 1760 / 0.3 * g**2) / g
    assert c["grade"] == pytest.approx(g[np.argmin(cost)], abs=1e-4)
    # a term constant at a fixed speed keeps c(g) quadratic: still the closed form
    fast = EnergyModel([*BASE_TERMS, "speed_dependence"], {**B1, "speed_dependence": 400.0})
    n = critical_grade(fast)
    cost = (130 + 137 / 0.3 + 720 * g + 1760 / 0.3 * g**2 + 400 * 0.3) / g
    assert n["method"] == "closed form"
    assert n["grade"] == pytest.approx(g[np.argmin(cost)], abs=1e-4)
    # a cubic term: the numeric minimum agrees with a brute-force search
    cubic = "pos(vx) * sin(alpha) ** 3"
    n = critical_grade(EnergyModel([*BASE_TERMS, cubic], {**B1, cubic: 3000.0}))
    cost = (130 + 137 / 0.3 + 720 * g + 1760 / 0.3 * g**2 + 3000 * g**3) / g
    assert n["method"] == "numeric" and n["grade"] == pytest.approx(g[np.argmin(cost)], abs=3e-4)
