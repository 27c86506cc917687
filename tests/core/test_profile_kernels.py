"""Profiles through the kernels: the memory diagram's profile path,
the deformable/vertical *_profile_* kernels, Scene(profile=...).

Sources: the independent spring-bed twin (tests/naive.py, SpringBed(profile=));
Cattaneo-Mindlin through MDR for each normal law N*(a*) (monotonic loading at
fixed a*: T* = N*(a) - N*(a - b); unloading from b_max (Mindlin-Deresiewicz):
T* = T_max - 2 (N*(a) - N*(a - (b_max - b)/2)); total sliding T* = N*(a));
the linearized contact oscillation m* dy'' = -N*'(1) dy (the small-amplitude
period-1 orbit's Floquet trace 2 cos(sqrt(N*'(1)/m*)), time in periods);
docs/MODEL.md section 10.
"""

import math

import numpy as np
import pytest

from tests.naive import SpringBed
from vibtrans.core.drivers import scene_law
from vibtrans.core.errors import InputError
from vibtrans.core.kernels.contact import kernel_law, law_eval, power_kernel_law, tangential_force_history
from vibtrans.core.params import Scene
from vibtrans.core.profiles import FlatSphereProfile, PowerLawProfile, TabulatedProfile


def _cone_table():
    r = np.linspace(0, 1e-6, 4001)
    return TabulatedProfile(r, r.copy(), load_over_modulus=1e-16, a_max_star=4.0)


PROFILES = [PowerLawProfile(1.0), PowerLawProfile(3.0), FlatSphereProfile(1.0)]
IDS = ["cone", "power3", "flat-sphere1"]


def _random_history(seed, n=80):
    rng = np.random.default_rng(seed)
    a = np.clip(1.0 + np.cumsum(rng.normal(0, 0.15, n)), -0.2, 2.5)
    b = np.cumsum(rng.normal(0, 0.2, n))
    return a, b


@pytest.mark.parametrize("prof", PROFILES + [_cone_table()], ids=IDS + ["tabulated-cone"])
@pytest.mark.parametrize("seed", [1, 34])
def test_kernel_matches_spring_bed_twin(prof, seed):
    # random loading histories, contact losses included (a* < 0 clears the memory);
    # the bed's error is O(dh) in the springs' spacing: 40000 springs on [0, 3]
    a, b = _random_history(seed)
    T, _, _ = tangential_force_history(a, b, law=kernel_law(prof))
    bed = SpringBed(40000, 3.0, profile=prof)
    Tn = np.array([bed.force_step(x, y) for x, y in zip(a, b)])
    scale = max(1.0, float(np.max(np.abs(Tn))))
    assert np.max(np.abs(T - Tn)) < 2e-4 * scale


@pytest.mark.parametrize("prof", PROFILES, ids=IDS)
def test_kernel_cattaneo_mindlin_closed_forms(prof):
    a, bmax = 1.3, 0.7
    N = prof.normal_force
    up = np.linspace(0.02, bmax, 15)
    down = np.linspace(bmax - 0.05, -bmax, 15)
    bs = np.concatenate((up, down, [-4.0]))
    T, _, st = tangential_force_history(np.full(bs.size, a), bs, a_start=a, law=kernel_law(prof))
    # a flat-sphere's law is a table (ds = 1/1024 in sqrt a*): N* to ~1e-7 relative
    tol = 1e-12 if isinstance(prof, PowerLawProfile) else 1e-6
    np.testing.assert_allclose(T[:15], N(a) - N(a - up), rtol=tol, atol=tol)
    Tmax = float(N(a) - N(a - bmax))
    np.testing.assert_allclose(T[15:30], Tmax - 2 * (N(a) - N(a - (bmax - down) / 2)), rtol=tol, atol=tol)
    assert T[-1] == pytest.approx(-float(N(a)), rel=tol)
    assert st[-1] == 3  # total sliding


@pytest.mark.parametrize("history", ["random", "smooth"])
def test_sphere_as_a_power_law_agrees_with_the_sphere_path(history):
    # the profile path with p = 3/2 (n = 2: the warm-started root where the
    # history is smooth, law_eval_warm) against Hertz's own (Simpson-in-sqrt) path
    if history == "random":
        a, b = _random_history(7, 400)
    else:
        t = np.arange(4000) / 256.0
        a = 1.0 + 0.8 * np.cos(2 * np.pi * t)
        b = 0.5 * np.sin(2 * np.pi * t) + 1e-3 * t
    T0, s0, st0 = tangential_force_history(a, b)
    T1, s1, st1 = tangential_force_history(a, b, law=power_kernel_law(2.0))
    np.testing.assert_allclose(T1, T0, rtol=0, atol=1e-13)
    assert np.array_equal(st0, st1)


@pytest.mark.parametrize("n", [1.0, 2.0])
def test_tabulated_law_against_analytic(n):
    # a measured z = C r^n through MDR and the kernel's table: N* = a*^((n+1)/n)
    r = np.linspace(0, 1e-6, 4001)
    C = 1.0 / (1e-6) ** (n - 1)
    law = kernel_law(TabulatedProfile(r, C * r**n, 1e-16, a_max_star=4.0))
    p = (n + 1) / n
    for a in (0.1, 0.5, 1.0, 2.0, 3.5):
        N, k = law_eval(law, a)
        assert N == pytest.approx(a**p, rel=3e-3)
        assert k == pytest.approx(p * a ** (p - 1), rel=3e-3)


def test_flat_sphere_law_table_matches_closed_form():
    prof = FlatSphereProfile(1.0)
    law = kernel_law(prof)
    assert law_eval(law, 1.0)[0] == 1.0  # the rest state's balance, exactly
    for a in (0.01, 0.3, 1.0, 2.7, 9.0, 40.0):
        N, k = law_eval(law, a)
        assert N == pytest.approx(float(prof.normal_force(a)), rel=1e-6)
        assert k == pytest.approx(float(prof.stiffness(a)), rel=1e-6)


def test_scene_profile_validation():
    assert Scene().profile == "sphere" and scene_law(Scene()) is None
    assert scene_law(Scene(profile="power:2")) is None  # the sphere's own path
    assert Scene(profile="cone").values()["profile"] == "cone"
    with pytest.raises(InputError, match=r"exponent n must be a real number in \[1, inf\)"):
        Scene(profile="power:0.5")
    with pytest.raises(InputError, match="profile must be one of"):
        Scene(profile="ellipsoid")
    with pytest.raises(InputError, match=r"flat radius .* \[0, 1e\+50\]"):
        Scene(profile="flat-sphere:-1")
    with pytest.raises(InputError, match=r"flat radius .* \[0, 1e\+50\]"):
        Scene(profile="flat-sphere:1e51")
    scene = Scene()
    with pytest.raises(InputError, match="exponent n"):
        scene.profile = "power:0.9"


def test_scene_file_profile_validation(tmp_path):
    r = np.linspace(0, 1e-6, 4001)
    good = tmp_path / "cone.txt"
    np.savetxt(good, np.column_stack([r, r]))
    with pytest.raises(InputError, match="needs the load"):
        Scene(profile=f"file:{good}")
    scene = Scene(profile=f"file:{good}", load_over_modulus=1e-16)
    assert law_eval(scene_law(scene), 2.0)[0] == pytest.approx(4.0, rel=3e-3)
    bumpy = tmp_path / "bumpy.txt"
    np.savetxt(bumpy, np.column_stack([r, r * (1 + 0.3 * np.sin(40 * r / 1e-6))]))
    with pytest.raises(InputError, match="nondecreasing|convex"):
        Scene(profile=f"file:{bumpy}", load_over_modulus=1e-16)
    coarse = tmp_path / "coarse.txt"
    rc = np.linspace(0, 1e-6, 30)
    np.savetxt(coarse, np.column_stack([rc, rc]))
    with pytest.raises(InputError, match="too coarse"):
        Scene(profile=f"file:{coarse}", load_over_modulus=1e-16)
    with pytest.raises(InputError, match=r"load_over_modulus must be in \(0, inf\)"):
        Scene(profile=f"file:{good}", load_over_modulus=-1.0)


@pytest.mark.parametrize("profile, k1", [("sphere", 1.5), ("cone", 2.0), ("power:3", 4.0 / 3.0)])
def test_small_amplitude_floquet_trace(profile, k1):
    # the period-1 orbit at A* = 1e-6 is the linearized contact oscillation:
    # monodromy a rotation by sqrt(N*'(1)/m*) radians per period, trace 2 cos of it
    from vibtrans.analysis.dynamics import periodic_orbit, rest_guess

    scene = Scene(profile=profile)
    law = scene_law(scene)
    mass = 10**0.5
    orbit = periodic_orbit(1e-6, mass, rest_guess(1e-6, mass, law), law=law)
    assert orbit.found
    assert orbit.trace == pytest.approx(2 * math.cos(math.sqrt(k1 / mass)), abs=1e-6)


def test_material_point_ignores_the_profile():
    from vibtrans.core.simulate import simulate

    kw = dict(amplitude=10**1.2, mass=0.1, model="point-mass", periods=60.0)
    a = simulate(Scene(**kw))
    b = simulate(Scene(profile="cone", **kw))
    assert np.array_equal(a["x"].values, b["x"].values)
    assert b.attrs["profile"] == "cone"


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--profile", "power:0.5", "--amplitude", "1", "--mass", "1"],
        ["threshold", "--profile", "power:0.5", "--mass", "0.05"],
        ["orbit", "--profile", "power:0.5", "--amplitude", "1", "--mass", "1"],
        ["sweep", "--profile", "power:0.5", "--log-amplitude", "0:0:1", "--log-mass", "0:0:1"],
    ],
)
def test_cli_refuses_a_bad_profile(capsys, argv):
    from vibtrans.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "exponent n must be a real number in [1, inf)" in err, err


def test_sweep_names_the_profile_and_keeps_the_sphere_keys():
    from vibtrans.maps.sweep import Sweep

    grid = (np.array([0.0]), np.array([0.0]))
    sphere = Sweep(*grid, model="deformable").attrs()
    assert not any(k.startswith("scene_profile") or k.startswith("scene_load") for k in sphere)
    cone = Sweep(*grid, model="deformable", profile="cone").attrs()
    assert cone["scene_profile"] == "cone"


def test_sweep_store_of_another_profile_is_refused(tmp_path):
    from vibtrans.core.errors import StoreMismatch
    from vibtrans.maps.sweep import Sweep, check_store

    grid = (np.array([0.0]), np.array([0.0]))
    cone_store = Sweep(*grid, model="deformable", profile="cone").empty_dataset()
    with pytest.raises(StoreMismatch, match="profile: store 'cone', command 'sphere'"):
        check_store(cone_store, Sweep(*grid, model="deformable"), "store")
    with pytest.raises(StoreMismatch, match="profile"):
        check_store(cone_store, Sweep(*grid, model="deformable", profile="power:3"), "store")
