"""Axisymmetric profiles: normal laws and spring weights.

Sources: Popov & Hess, Method of Dimensionality Reduction (power law
g = kappa_n C |x|^n, kappa_n = sqrt(pi) Gamma(n/2+1)/Gamma(n/2+1/2), N ~ d^((n+1)/n));
Hertz (sphere N = (4/3) E* sqrt(R) d^(3/2)); Sneddon's cone N = (2/pi) E* tan(beta) d^2 ... in
normalized form N* = a*^2; docs/MODEL.md "Axisymmetric profiles".
"""

import math

import numpy as np
import pytest

from vibtrans.core.errors import InputError
from vibtrans.core.profiles import (
    FlatSphereProfile,
    PowerLawProfile,
    TabulatedProfile,
    mdr_g,
    parse_profile,
    tangential_force,
)


def test_sphere_is_hertz_and_cone_is_sneddon():
    a = np.linspace(0, 3, 31)
    np.testing.assert_allclose(parse_profile("sphere").normal_force(a), a**1.5, rtol=1e-15)
    np.testing.assert_allclose(parse_profile("cone").normal_force(a), a**2, rtol=1e-15)
    np.testing.assert_allclose(parse_profile("power:3").normal_force(a), a ** (4 / 3), rtol=1e-15)


@pytest.mark.parametrize("n", [1.0, 1.5, 2.0, 3.0])
def test_mdr_g_of_power_law_matches_kappa(n):
    # Popov & Hess: g(x) = kappa_n C x^n for z = C r^n; piecewise-linear table converges as O(dr^2)
    r = np.linspace(0, 1, 20001)
    x = np.array([0.2, 0.5, 0.9])
    kappa = math.sqrt(math.pi) * math.gamma(n / 2 + 1) / math.gamma(n / 2 + 0.5)
    np.testing.assert_allclose(mdr_g(r, r**n, x), kappa * x**n, rtol=2e-4)


@pytest.mark.parametrize("n", [1.0, 2.0, 3.0])
def test_tabulated_power_law_against_closed_form(n):
    r = np.linspace(0, 1e-6, 4001)
    C = 1.0 / (1e-6) ** (n - 1)  # z = C r^n in metres
    prof = TabulatedProfile(r, C * r**n, load_over_modulus=1e-16, a_max_star=4.0)
    a = np.linspace(0.05, 3.0, 40)
    np.testing.assert_allclose(prof.normal_force(a), a ** ((n + 1) / n), rtol=3e-3)
    np.testing.assert_allclose(prof.stiffness(a), PowerLawProfile(n).stiffness(a), rtol=3e-3)


def test_stiffness_is_derivative_of_normal_force():
    a = np.linspace(0.2, 3, 50)
    for prof in (PowerLawProfile(1.0), PowerLawProfile(2.7), FlatSphereProfile(0.0), FlatSphereProfile(1.3)):
        eps = 1e-6
        fd = (prof.normal_force(a + eps) - prof.normal_force(a - eps)) / (2 * eps)
        np.testing.assert_allclose(prof.stiffness(a), fd, rtol=1e-7)
        assert float(prof.normal_force(1.0)) == pytest.approx(1.0, rel=1e-15)


def test_flat_sphere_limits():
    a = np.linspace(0, 3, 31)
    np.testing.assert_allclose(FlatSphereProfile(0.0).normal_force(a), a**1.5, rtol=1e-14)
    # large flat: the flat punch, N linear in the approach
    np.testing.assert_allclose(FlatSphereProfile(1e4).normal_force(a), a, rtol=1e-6)


def test_flat_sphere_against_mdr_table():
    R, d0, gamma = 1e-3, 1e-9, 0.8
    L = math.sqrt(R * d0)
    c = gamma * L
    r = np.linspace(0, 6 * L, 6001)
    z = np.where(r > c, (r * r - c * c) / (2 * R), 0.0)
    flat = FlatSphereProfile(gamma)
    # the load N0/E* that gives static approach d0: N = (2E*/R) L^3 raw(sigma(1))
    load = 2.0 / R * L**3 * flat._raw(flat._sigma(1.0))
    prof = TabulatedProfile(r, z, load_over_modulus=load, a_max_star=4.0)
    assert prof.a0 == pytest.approx(d0, rel=2e-3)
    a = np.linspace(0.05, 3, 30)
    np.testing.assert_allclose(prof.normal_force(a), flat.normal_force(a), rtol=3e-3)


@pytest.mark.parametrize(
    "prof", [PowerLawProfile(1.0), PowerLawProfile(2.0), PowerLawProfile(3.0), FlatSphereProfile(1.0)]
)
def test_total_sliding_gives_coulomb(prof):
    # all springs sliding: anchor w(h) = b - (a - h) (spring displacement = a - h in units theta mu a0)
    a, b = 1.7, 0.4
    h = np.linspace(0, a, 200001)
    T = tangential_force(prof, a, b, lambda hh: b - (a - hh), h)
    assert T == pytest.approx(float(prof.normal_force(a)), rel=1e-6)


def test_sphere_weight_matches_contact_module():
    # contact.py: T* = 1.5 b sqrt(a) - 0.75 int w h^-1/2 dh; a linear w(h) = w0 + s h integrates exactly
    a, b, w0, s = 1.3, 0.2, -0.1, 0.3
    h = np.linspace(0, a, 400001)
    T = tangential_force(PowerLawProfile(2.0), a, b, lambda hh: w0 + s * hh, h)
    exact = 1.5 * b * math.sqrt(a) - 0.75 * (2 * w0 * math.sqrt(a) + s * (2 / 3) * a**1.5)
    assert T == pytest.approx(exact, rel=1e-6)


@pytest.mark.parametrize(
    "text, words",
    [
        ("power:0.5", "exponent n"),
        ("power:x", "power parameter"),
        ("flat-sphere:-1", "flat radius"),
        ("ellipsoid", "profile must be one of"),
        ("power:nan", "exponent n"),
    ],
)
def test_bad_profile_names_parameter(text, words):
    with pytest.raises(InputError, match=words):
        parse_profile(text)


def test_table_validation():
    r = np.linspace(0, 1e-6, 101)
    with pytest.raises(InputError, match="convex"):
        TabulatedProfile(r, np.sqrt(r) * 1e-3, 1e-16)
    with pytest.raises(InputError, match="nondecreasing"):
        TabulatedProfile(r, -r * r, 1e-16)
    with pytest.raises(InputError, match="start at 0"):
        TabulatedProfile(r + 1e-9, r * r, 1e-16)
    with pytest.raises(InputError, match="too coarse"):
        TabulatedProfile(np.linspace(0, 1e-6, 30), np.linspace(0, 1e-6, 30) ** 2 * 1e6, 1e-16, a_max_star=1.0)


def test_tabulated_flat_atom_weight():
    # the flat part's springs all enter at a* = 0: N*'(0) = flat contact radius weight = a_c(0)/raw(1)
    R, d0, gamma = 1e-3, 1e-9, 0.8
    L = math.sqrt(R * d0)
    r = np.linspace(0, 6 * L, 6001)
    z = np.where(r > gamma * L, (r * r - (gamma * L) ** 2) / (2 * R), 0.0)
    flat = FlatSphereProfile(gamma)
    prof = TabulatedProfile(r, z, 2.0 / R * L**3 * flat._raw(flat._sigma(1.0)), a_max_star=4.0)
    assert float(prof.stiffness(0.0)) == pytest.approx(float(flat.stiffness(0.0)), rel=3e-3)
    assert float(flat.stiffness(0.0)) > 0


PROFILES = [PowerLawProfile(1.0), PowerLawProfile(2.0), PowerLawProfile(3.0), FlatSphereProfile(1.0)]


@pytest.mark.parametrize("prof", PROFILES, ids=lambda p: p.name)
def test_spring_bed_cattaneo_mindlin_closed_forms(prof):
    # Cattaneo-Mindlin through MDR (independent springs, limit a - h): monotonic loading at
    # fixed a gives T* = N*(a) - N*(a - b); unloading from b_max (Mindlin-Deresiewicz,
    # doubled limit) T* = T_max - 2 (N*(a) - N*(a - (b_max - b)/2)); total sliding T* = N*(a).
    from tests.naive import SpringBed

    a, bmax = 1.0, 0.6
    bed = SpringBed(40000, 2.0, a_start=a, profile=prof)
    N = prof.normal_force
    for b in np.linspace(0.05, bmax, 12):
        T = bed.force_step(a, b)
        assert T == pytest.approx(float(N(a) - N(a - b)), rel=2e-3, abs=2e-4)
    Tmax = float(N(a) - N(a - bmax))
    for b in np.linspace(bmax - 0.1, -0.4, 12):
        T = bed.force_step(a, b)
        assert T == pytest.approx(Tmax - 2 * float(N(a) - N(a - (bmax - b) / 2)), rel=2e-3, abs=2e-4)
    T = bed.force_step(a, -3.0)
    assert T == pytest.approx(-float(N(a)), rel=2e-3)


def test_spring_bed_sphere_profile_matches_default_weights():
    from tests.naive import SpringBed

    rng = np.random.default_rng(34)
    bed0 = SpringBed(20000, 3.0)
    bed1 = SpringBed(20000, 3.0, profile=PowerLawProfile(2.0))
    for a, b in zip(0.5 + 1.5 * rng.random(30), rng.normal(0, 0.5, 30)):
        assert bed1.force_step(a, b) == pytest.approx(bed0.force_step(a, b), rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("prof", PROFILES, ids=lambda p: p.name)
def test_linearized_contact_frequency(prof):
    # small free oscillation on a rigid substrate, m* a'' = 1 - N*(a): angular frequency
    # sqrt(N*'(1) / m*) (linearization), checked against a numerical solution
    from scipy.integrate import solve_ivp

    m, eps = 2.0, 1e-4
    sol = solve_ivp(
        lambda t, y: [y[1], (1.0 - float(prof.normal_force(y[0]))) / m],
        (0, 40),
        [1.0 + eps, 0.0],
        rtol=1e-11,
        atol=1e-14,
        dense_output=True,
        events=lambda t, y: y[1],
    )
    crossings = sol.t_events[0]
    crossings = crossings[crossings > 1e-9]
    period = 2 * (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert 2 * math.pi / period == pytest.approx(math.sqrt(float(prof.stiffness(1.0)) / m), rel=1e-4)


def test_file_profile(tmp_path):
    r = np.linspace(0, 1e-6, 4001)
    path = tmp_path / "cone.txt"
    np.savetxt(path, np.column_stack([r, r]))
    prof = parse_profile(f"file:{path}", load_over_modulus=1e-16)
    a = np.linspace(0.1, 3, 20)
    np.testing.assert_allclose(prof.normal_force(a), a**2, rtol=3e-3)  # the cone (Sneddon)
    with pytest.raises(InputError, match="needs the load"):
        parse_profile(f"file:{path}")
    with pytest.raises(InputError, match="readable"):
        parse_profile(f"file:{tmp_path / 'missing.txt'}", load_over_modulus=1e-16)


@pytest.mark.parametrize("n", [1.0, 2.0, 3.0, 340.0, 400.0, 1e9, 1e300, 1.7976931348623157e308])
def test_power_law_outline_is_finite_within_the_contact_for_every_valid_exponent(n):
    """The tip's outline z / a0 = rho^n / kappa_n, kappa_n = sqrt(pi)
    Gamma(n/2 + 1) / Gamma(n/2 + 1/2) (Popov & Hess), for any n >= 1: the
    two Gammas overflow from n = 341, their ratio does not (~ sqrt(n/2)).
    Inside the static contact it is finite; beyond, +inf where it passes the
    largest float, without a warning (the suite makes warnings errors)."""
    shape = PowerLawProfile(n)
    rho = np.array([0.0, 0.5, 1.0, 1.6])
    z = shape.outline(rho)
    if n < 341:
        kappa = math.sqrt(math.pi) * math.gamma(n / 2 + 1) / math.gamma(n / 2 + 0.5)
    else:  # the ratio's asymptotic series (DLMF 5.11.13), to O(x^-5)
        u = 2 / n
        kappa = (
            math.sqrt(math.pi)
            * math.sqrt(n / 2)
            * (1 + u / 8 + u**2 / 128 - 5 * u**3 / 1024 - 21 * u**4 / 32768)
        )
    assert z[0] == 0.0 and z[2] == pytest.approx(1 / kappa, rel=1e-12)
    assert np.all(np.isfinite(z[:3])) and z[1] == pytest.approx(0.5**n / kappa, rel=1e-12)
    assert z[3] > z[2] and not np.isnan(z[3])
