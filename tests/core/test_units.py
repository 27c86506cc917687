"""Tests for vibtrans.core.units: materials, Rayleigh wave, Hertz contact, SI <-> normalized."""

import math

import numpy as np
import pytest

from vibtrans.core import units as u

# Paper's worked example (docs/MODEL.md section 5): steel sphere of DIAMETER 1 mm on glass.
R_EXAMPLE = 0.5e-3


# --------------------------------------------------------------------------- materials
def test_paper_materials():
    # Terzi et al.: steel 200 GPa / 0.3 / 8000, glass 70 GPa / 0.3 / 2500.
    assert u.material("steel") == u.Material("steel", 200e9, 0.3, 8000.0)
    assert u.material("Glass") == u.Material("glass", 70e9, 0.3, 2500.0)


def test_material_catalogue_and_aliases():
    for key in ["aluminium", "silicon", "quartz", "ptfe", "lithium_niobate"]:
        assert key in u.MATERIALS
    assert u.material("aluminum") is u.MATERIALS["aluminium"]
    assert u.material("Lithium Niobate") is u.MATERIALS["lithium_niobate"]


def test_unknown_material_lists_names():
    with pytest.raises(ValueError, match="valid names: .*steel"):
        u.material("unobtainium")
    with pytest.raises(TypeError):
        u.material(3)


@pytest.mark.parametrize(
    "field, kwargs",
    [
        ("youngs_modulus", dict(youngs_modulus=-1.0)),
        ("poisson_ratio", dict(poisson_ratio=0.5)),
        ("density", dict(density=float("nan"))),
    ],
)
def test_material_validates(field, kwargs):
    args = dict(name="x", youngs_modulus=1e9, poisson_ratio=0.3, density=1000.0) | kwargs
    with pytest.raises(ValueError, match=field):
        u.Material(**args)


# --------------------------------------------------------------------------- Rayleigh wave
def test_rayleigh_speed_glass():
    # docs/MODEL.md section 5: glass (70 GPa, 0.3, 2500) gives c_R = 3.04 km/s.
    assert u.rayleigh_speed(70e9, 0.3, 2500.0) == pytest.approx(3040.0, rel=2e-3)


def test_rayleigh_ratio_classic_values():
    # Closed form: nu = 0.25 (Poisson solid) gives c_R/c_t = sqrt(2 - 2/sqrt(3)) = 0.9194;
    # Viktorov's approximation (0.87 + 1.12 nu)/(1 + nu) is within 0.5 % over (0, 0.5).
    assert u.rayleigh_speed_ratio(0.25) == pytest.approx(math.sqrt(2 - 2 / math.sqrt(3)), abs=1e-10)
    nu = np.linspace(0.01, 0.49, 25)
    assert np.allclose(u.rayleigh_speed_ratio(nu), (0.87 + 1.12 * nu) / (1 + nu), rtol=5e-3)


@pytest.mark.parametrize("nu, r", [(0.1, 0.748), (0.25, 0.681), (0.3, 0.656), (0.4, 0.602)])
def test_amplitude_ratio_reference(nu, r):
    # docs/MODEL.md section 1 reference values of r(nu).
    assert u.amplitude_ratio(nu) == pytest.approx(r, abs=1e-3)
    assert isinstance(u.amplitude_ratio(nu), float)


def _secular(nu):
    gamma = (1 - 2 * nu) / (2 * (1 - nu))
    return lambda xi: (2 - xi**2) ** 2 - 4 * math.sqrt(1 - xi**2) * math.sqrt(1 - gamma * xi**2)


def test_brentq_port_is_scipys_to_the_bit():
    """units._brentq (a port of scipy's C brentq, to spare the ~0.55 s
    import of scipy.optimize) returns scipy's root exactly: over the whole
    range of nu (Scene's r(nu)) and over random brackets of other functions."""
    from scipy.optimize import brentq

    rng = np.random.default_rng(13)
    nus = np.concatenate(
        [
            np.linspace(1e-9, 0.5 - 1e-9, 20001),
            rng.uniform(0.0, 0.5, 20000),
            [5e-324, 1e-300, 0.5 - 2**-54, 0.1, 0.25, 0.3, 0.45],
        ]
    )
    for nu in nus[(nus > 0) & (nus < 0.5)]:
        f = _secular(float(nu))
        assert u._brentq(f, 0.5, 1.0, 1e-15, 1e-14) == brentq(f, 0.5, 1.0, xtol=1e-15, rtol=1e-14), nu
    for _ in range(3000):
        c, root = rng.normal(size=4), rng.uniform(-3, 3)
        lo, hi = root - rng.uniform(0.01, 5), root + rng.uniform(0.01, 5)

        def f(x):
            return (x - root) * (1 + c[0] ** 2 + (c[1] * x) ** 2 + c[2] * math.sin(c[3] * x))

        if f(lo) * f(hi) < 0:
            assert u._brentq(f, lo, hi, 2e-12, 8.881784197001252e-16) == brentq(f, lo, hi)


def test_brentq_port_refuses_a_bracket_without_a_sign_change():
    with pytest.raises(ValueError, match="different signs"):
        u._brentq(lambda x: x * x + 1, -1.0, 1.0, 1e-15, 1e-14)


def test_amplitude_ratio_vectorized_and_monotonic():
    # r decreases with nu (docs/MODEL.md section 1 reference values are decreasing).
    nu = np.linspace(0.1, 0.4, 31)
    r = u.amplitude_ratio(nu)
    assert r.shape == nu.shape
    assert np.all(np.diff(r) < 0)
    assert r[0] == pytest.approx(u.amplitude_ratio(0.1))


# --------------------------------------------------------------------------- contact
@pytest.mark.parametrize("nu, theta", [(0.1, 1.0556), (0.3, 1.2143), (0.4, 1.3333)])
def test_stiffness_ratio_equal_materials(nu, theta):
    # docs/MODEL.md section 1: equal materials give (2 - nu)/(2 (1 - nu)).
    assert u.stiffness_ratio(70e9, nu, 70e9, nu) == pytest.approx(theta, abs=1e-4)
    assert u.stiffness_ratio(1e9, nu, 5e11, nu) == pytest.approx((2 - nu) / (2 * (1 - nu)))


def test_stiffness_ratio_in_model_range():
    # docs/MODEL.md section 1: theta in [1, 1.5] for any pair of materials.
    for a in u.MATERIALS.values():
        for b in u.MATERIALS.values():
            th = u.stiffness_ratio(a.youngs_modulus, a.poisson_ratio, b.youngs_modulus, b.poisson_ratio)
            assert 1.0 <= th <= 1.5


def test_hertz_inverts_load_law():
    # Closed form: load = (4/3) E_eff sqrt(R) a0^(3/2).
    E_eff = u.effective_modulus(200e9, 0.3, 70e9, 0.3)
    assert 1 / E_eff == pytest.approx(0.91 / 200e9 + 0.91 / 70e9)
    a0 = u.hertz_compression(1e-3, 2e-3, E_eff)
    assert 4 / 3 * E_eff * math.sqrt(2e-3) * a0**1.5 == pytest.approx(1e-3)


# --------------------------------------------------------------------------- SI <-> normalized
def test_paper_worked_example():
    # docs/MODEL.md section 5 (Terzi et al. worked example, diameter 1 mm): a0 = 8.4e-10 m,
    # f(m* = 1) = 1.08e5 Hz, v = 9.1 cm/s at v* = 1e3.
    f1 = u.frequency_for_mass_ratio(1.0, "glass", "steel", R_EXAMPLE)
    assert f1 == pytest.approx(1.08e5, rel=0.02)
    scene = u.to_normalized("glass", "steel", R_EXAMPLE, f1, amplitude=1e-8)
    assert scene.a0 == pytest.approx(8.4e-10, rel=0.02)
    assert scene.drift_velocity_si(1e3) == pytest.approx(0.091, rel=0.02)
    assert scene.m_star == pytest.approx(1.0)
    # Substrate-derived quantities (glass, nu = 0.3; equal Poisson ratios -> closed-form theta).
    assert scene.nu == 0.3
    assert scene.r == pytest.approx(0.656, abs=1e-3)
    assert scene.theta == pytest.approx(1.2143, abs=1e-4)
    assert scene.c_R == pytest.approx(3040.0, rel=2e-3)
    assert scene.mass_kg == pytest.approx(4 / 3 * math.pi * R_EXAMPLE**3 * 8000)
    assert scene.load_N == pytest.approx(scene.mass_kg * 9.81)


@pytest.mark.parametrize("m_star", [1e-5, 3.7e-2, 1.0, 1e5])
@pytest.mark.parametrize("preload", [0.0, 1e-3])
def test_round_trip_mass_ratio(m_star, preload):
    f = u.frequency_for_mass_ratio(m_star, "silicon", u.MATERIALS["ptfe"], 1e-4, preload=preload)
    scene = u.to_normalized("silicon", "ptfe", 1e-4, f, amplitude=0.0, preload=preload)
    assert scene.m_star == pytest.approx(m_star, rel=1e-12)


def test_round_trip_amplitude_and_device_spec():
    spec = u.DeviceSpec("lithium niobate", "aluminium", 2e-4, 2e7, 1e-9, preload=1e-4)
    scene = spec.normalized()
    assert u.amplitude_from_normalized(scene.A_star, scene.a0) == pytest.approx(1e-9)
    assert scene.load_N == pytest.approx(scene.mass_kg * 9.81 + 1e-4)
    assert scene.wavelength == pytest.approx(scene.c_R / 2e7)


def test_preload_only_load():
    # g = 0 is allowed when a pre-load supplies the load; with neither there is no a0.
    assert u.to_normalized("glass", "steel", 1e-3, 1e5, 0.0, preload=1.0, g=0.0).load_N == 1.0
    with pytest.raises(ValueError, match="preload"):
        u.to_normalized("glass", "steel", 1e-3, 1e5, 0.0, preload=0.0, g=0.0)


# --------------------------------------------------------------------------- bad input
NAN, INF = float("nan"), float("inf")
BAD_CALLS = [
    (u.rayleigh_speed_ratio, (0.7,), "nu"),
    (u.rayleigh_speed_ratio, (0.0,), "nu"),
    (u.amplitude_ratio, (NAN,), "nu"),
    (u.amplitude_ratio, (np.array([0.2, 0.6]),), "nu"),
    (u.rayleigh_speed, (0.0, 0.3, 2500.0), "E"),
    (u.rayleigh_speed, (70e9, 0.3, -1.0), "rho"),
    (u.stiffness_ratio, (70e9, 0.3, INF, 0.3), "E_p"),
    (u.stiffness_ratio, (70e9, 0.3, 70e9, 0.5), "nu_p"),
    (u.effective_modulus, (70e9, -0.1, 70e9, 0.3), "nu"),
    (u.hertz_compression, (-1.0, 1e-3, 1e10), "load_N"),
    (u.hertz_compression, (1.0, 0.0, 1e10), "radius_m"),
    (u.hertz_compression, (1.0, 1e-3, NAN), "E_eff"),
    (u.sphere_mass, (1e-3, 0.0), "density"),
    (u.to_normalized, ("glass", "steel", 0.0, 1e5, 1e-9), "radius"),
    (u.to_normalized, ("glass", "steel", 1e-3, 0.0, 1e-9), "frequency"),
    (u.to_normalized, ("glass", "steel", 1e-3, INF, 1e-9), "frequency"),
    (u.to_normalized, ("glass", "steel", 1e-3, 1e5, -1e-9), "amplitude"),
    (u.to_normalized, ("glass", "steel", 1e-3, 1e5, 1e-9, -1.0), "preload"),
    (u.to_normalized, ("glass", "steel", 1e-3, 1e5, 1e-9, 0.0, NAN), "g"),
    (u.to_normalized, ("glas", "steel", 1e-3, 1e5, 1e-9), "valid names"),
    (u.frequency_for_mass_ratio, (0.0, "glass", "steel", 1e-3), "m_star"),
    (u.frequency_for_mass_ratio, (-1.0, "glass", "steel", 1e-3), "m_star"),
    (u.amplitude_from_normalized, (-1.0, 1e-9), "A_star"),
    (u.amplitude_from_normalized, (1.0, 0.0), "a0"),
]


@pytest.mark.parametrize("func, args, name", BAD_CALLS)
def test_bad_input_raises_value_error(func, args, name):
    with pytest.raises(ValueError, match=name):
        func(*args)


def test_error_message_names_range():
    with pytest.raises(ValueError, match=r"nu must be in \(0, 0\.5\), got 0\.7"):
        u.amplitude_ratio(0.7)
    with pytest.raises(ValueError, match=r"amplitude must be in \[0, inf\), got -1"):
        u.to_normalized("glass", "steel", 1e-3, 1e5, -1.0)


@pytest.mark.parametrize(
    "func, args",
    [
        (u.amplitude_ratio, ("0.3",)),
        (u.amplitude_ratio, (None,)),
        (u.rayleigh_speed, (70e9, True, 2500.0)),
        (u.hertz_compression, (1.0, 1e-3 + 0j, 1e10)),
        (u.to_normalized, ("glass", 42, 1e-3, 1e5, 1e-9)),
        (u.to_normalized, ("glass", "steel", [1e-3], {}, 1e-9)),
    ],
)
def test_bad_types_raise(func, args):
    with pytest.raises((TypeError, ValueError)):
        func(*args)
