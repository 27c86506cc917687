"""Design charts with the particle's tip shape in SI (vibtrans.products.designtip,
`vibtrans design --profile`).

Sources: Hertz's a0 = (3 N / (4 E* sqrt R))^(2/3); Sneddon's cone N = (2/pi) E* tan(alpha) d^2,
contact radius a = (2/pi) d tan(alpha) (Johnson, Contact Mechanics, 1985, sec. 5.6);
the flat-ended sphere's N = (2E*/R)(c^2 s + (2/3) s^3), d = a s / R (Popov & Hess, MDR);
and, independent of the closed forms, the numerical MDR of a measured table
(profiles.TabulatedProfile: exact g(x) of the piecewise-linear table, trapezoid N)."""

import json
import math

import numpy as np
import pytest

from vibtrans import cli
from vibtrans.core import units
from vibtrans.core.errors import InputError
from vibtrans.core.params import Scene
from vibtrans.core.profiles import FlatSphereProfile, PowerLawProfile, TabulatedProfile
from vibtrans.products import design, designtip
from vibtrans.products.designtip import static_contact, tip_shape

E = units.effective_modulus(70e9, 0.3, 200e9, 0.3)  # steel on glass
R = 0.5e-3
LOAD = units.sphere_mass(R, 8000.0) * 9.81


def test_sphere_and_power2_are_hertz():
    a0 = (3 * LOAD / (4 * E * math.sqrt(R))) ** (2 / 3)
    for shape in (tip_shape(), tip_shape("power:2", tip_radius=R)):
        c = static_contact(shape, R, LOAD, E)
        assert float(c.a0) == pytest.approx(a0, rel=1e-12)
        assert float(c.contact_radius) == pytest.approx(math.sqrt(R * a0), rel=1e-12)
        assert c.profile == "sphere"


@pytest.mark.parametrize("alpha", [30.0, 60.0, 85.0])
def test_cone_is_sneddon(alpha):
    c = static_contact(tip_shape("cone", half_angle=alpha), R, LOAD, E)
    t = math.tan(math.radians(alpha))
    d = float(c.a0)
    assert 2 / math.pi * E * t * d * d == pytest.approx(LOAD, rel=1e-12)
    assert float(c.contact_radius) == pytest.approx(2 / math.pi * d * t, rel=1e-12)
    assert float(c.edge_slope) == pytest.approx(1 / t, rel=1e-12)
    assert float(c.mean_pressure) == pytest.approx(E / (2 * t), rel=1e-12)  # load-free
    assert c.profile == "cone"


@pytest.mark.parametrize("n, tip", [(1.5, 2e-4), (3.0, None), (4.0, 1e-3)])
def test_power_law_against_numerical_mdr_of_its_table(n, tip):
    shape = tip_shape(f"power:{n:g}", tip_radius=tip)
    c = static_contact(shape, R, LOAD, E)
    rt = R if tip is None else tip
    r = np.linspace(0.0, 12 * float(c.contact_radius), 6001)
    table = TabulatedProfile(r, r**n / (n * rt ** (n - 1)), LOAD / E, a_max_star=4.0)
    assert table.a0 == pytest.approx(float(c.a0), rel=2e-3)
    assert table.static_contact_radius == pytest.approx(float(c.contact_radius), rel=2e-3)
    assert float(c.edge_slope) == pytest.approx((float(c.contact_radius) / rt) ** (n - 1), rel=1e-12)
    assert c.profile == PowerLawProfile(n).name


@pytest.mark.parametrize("flat", [0.0, 2e-6, 2e-5])
def test_flat_sphere_closed_form_and_numerical_mdr(flat):
    c = static_contact(tip_shape("flat-sphere", flat_radius=flat), R, LOAD, E)
    a, d = float(c.contact_radius), float(c.a0)
    s = d * R / a  # d = a s / R (no cancellation in a^2 - c^2)
    assert 2 * E / R * (flat**2 * s + 2 / 3 * s**3) == pytest.approx(LOAD, rel=1e-12)
    assert a * a == pytest.approx(flat * flat + s * s, rel=1e-12)
    gamma = float(c.profile.split(":")[1])
    assert gamma == pytest.approx(flat / math.sqrt(R * d), rel=1e-9)
    FlatSphereProfile(gamma)
    r = np.linspace(0.0, 10 * a, 8001)
    table = TabulatedProfile(
        r, np.where(r > flat, (r * r - flat * flat) / (2 * R), 0.0), LOAD / E, a_max_star=4.0
    )
    assert table.a0 == pytest.approx(d, rel=3e-3)


def test_outlines_si_and_normalized():
    r = np.linspace(0, 1e-5, 11)
    assert np.allclose(
        designtip.outline(tip_shape("cone", half_angle=60), r, R), r / math.tan(math.radians(60)), rtol=1e-14
    )
    assert np.allclose(designtip.outline(tip_shape(), r, R), r * r / (2 * R), rtol=1e-14)
    flat = designtip.outline(tip_shape("flat-sphere", flat_radius=5e-6), r, R)
    assert np.all(flat[r <= 5e-6] == 0) and np.all(flat[r > 5e-6] > 0)
    # normalized outline z / a0 at r / a_c agrees with the SI one
    for shape, prof in (
        (tip_shape("cone", half_angle=60), PowerLawProfile(1.0)),
        (tip_shape("power:3"), PowerLawProfile(3.0)),
    ):
        c = static_contact(shape, R, LOAD, E)
        rho = np.array([0.3, 1.0, 2.0])
        z = designtip.outline(shape, rho * float(c.contact_radius), R) / float(c.a0)
        assert np.allclose(prof.outline(rho), z, rtol=1e-12)
    c = static_contact(tip_shape("flat-sphere", flat_radius=2e-6), R, LOAD, E)
    prof = FlatSphereProfile(float(c.profile.split(":")[1]))
    rho = np.array([0.1, 0.5, 1.0, 1.7])
    z = designtip.outline(
        tip_shape("flat-sphere", flat_radius=2e-6), rho * float(c.contact_radius), R
    ) / float(c.a0)
    assert np.allclose(prof.outline(rho), z, rtol=1e-9, atol=1e-12)
    assert prof.contact_radius(1.0) == pytest.approx(1.0)


def _device(**kw):
    dev = design.preset("paper").device
    return units.DeviceSpec(
        dev.substrate, dev.particle, kw.get("radius", dev.radius), dev.frequency, dev.amplitude
    )


def test_tip_slope_warning_both_sides():
    dev = _device()
    codes = lambda shape: [w.code for w in design.validity_warnings(dev, shape=shape)]
    # power:3 with a tip radius R_t: slope (a_c / R_t)^2 at the edge
    q = design.device_quantities(dev, shape=tip_shape("power:3", tip_radius=1e-3))
    assert q.edge_slope < designtip.MAX_EDGE_SLOPE
    assert "tip-slope" not in codes(tip_shape("power:3", tip_radius=1e-3))
    sharp = tip_shape("power:3", tip_radius=1e-7)  # slope 0.25
    assert design.device_quantities(dev, shape=sharp).edge_slope > designtip.MAX_EDGE_SLOPE
    assert "tip-slope" in codes(sharp)
    # a cone: slope cot(alpha) at any size; its apex always warned
    assert codes(tip_shape("cone", half_angle=87.0))[:1] == ["cone-apex"]
    assert codes(tip_shape("cone", half_angle=60.0))[:2] == ["tip-slope", "cone-apex"]
    assert "cone-apex" not in codes(None) and "tip-slope" not in codes(None)


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(profile="cone"), r"needs half_angle \(--half-angle, degrees, in \(0, 90\)\)"),
        (dict(profile="cone", half_angle=90.0), r"half_angle must be a real number in \(0, 90\)"),
        (dict(profile="cone", tip_radius=1e-3, half_angle=60), "tip_radius does not apply"),
        (dict(profile="sphere", flat_radius=1e-6), "flat_radius does not apply"),
        (dict(profile="flat-sphere"), r"needs flat_radius \(--flat-radius, m, in \[0, inf\)\)"),
        (dict(profile="flat-sphere", flat_radius=-1e-6), r"flat_radius must be a real number in \[0"),
        (dict(profile="flat-sphere:1"), "flat radius in metres"),
        (dict(profile="power:0.5"), r"exponent n must be a real number in \[1, inf\)"),
        (dict(profile="power:3", tip_radius=0.0), r"tip_radius must be a real number in \(0"),
        (dict(profile="ellipsoid"), "profile must be one of"),
    ],
)
def test_bad_tip_refused(kw, word):
    with pytest.raises(InputError, match=word):
        tip_shape(**kw)


def test_cli_refuses_a_bad_tip(capsys):
    assert cli.main(["design", "--preset", "paper", "--profile", "cone"]) == 2
    assert "half_angle" in capsys.readouterr().err
    assert cli.main(["design", "--preset", "paper", "--half-angle", "60"]) == 2
    assert "does not apply to profile 'sphere'" in capsys.readouterr().err


def test_flat_sphere_chart_over_radius_refused():
    dev = design.preset("paper").device
    with pytest.raises(InputError, match="gamma = c / sqrt"):
        design.chart_needs(
            dev.substrate,
            dev.particle,
            0.0,
            ("radius", 1e-4, 1e-3, 3),
            ("amplitude", 1e-8, 1e-7, 3),
            ("frequency", dev.frequency),
            shape=tip_shape("flat-sphere", flat_radius=5e-6),
        )


def test_a_cone_chart_does_not_read_the_sphere_s_map():
    dev = design.preset("paper").device
    with pytest.raises(design.NoMapCovers) as exc:
        design.design_chart(
            dev.substrate,
            dev.particle,
            0.0,
            ("frequency", 3e4, 3e5, 3),
            ("amplitude", 1e-8, 1e-7, 3),
            ("radius", dev.radius),
            shape=tip_shape("cone", half_angle=70),
        )
    assert "profile cone" in str(exc.value) and exc.value.need.profile == "cone"
    # the sphere's chart keeps the shipped map
    need = design.chart_needs(
        dev.substrate,
        dev.particle,
        0.0,
        ("frequency", 3e4, 3e5, 3),
        ("amplitude", 1e-8, 1e-7, 3),
        ("radius", dev.radius),
    )
    assert need.profile == "sphere" and not need.shipped_problems


def test_cli_cone_chart_computed_names_the_profile(tmp_path, capsys):
    # a coarse, short preview window of the cone's own map; its reading at a grid
    # point is the direct run of that scene
    argv = [
        "design",
        "--preset",
        "paper",
        "--profile",
        "cone",
        "--half-angle",
        "80",
        "--compute",
        "--store",
        str(tmp_path / "store"),
        "--step",
        "0.5",
        "--periods",
        "60",
        "--x",
        "frequency:3e4:3e5:2",
        "--y",
        "amplitude:1e-8:1e-7:2",
        "--json",
    ]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "profile cone" in captured.err
    report = json.loads(captured.out)
    assert report["profile"] == "cone (half-angle 80 deg)" and report["map_profile"] == "cone"
    assert report["chart"]["attrs"]["profile"] == "cone (half-angle 80 deg)"
    assert report["device"]["profile"] == "cone (half-angle 80 deg)"
    assert "cone-apex" in [w["code"] for w in report["warnings"]]
    from vibtrans.maps.sweep import open_map

    store = next((tmp_path / "store").iterdir())
    ds = open_map(str(store))
    assert ds.attrs["scene_profile"] == "cone"
    la, lm = float(ds["log_amplitude"].values[0]), float(ds["log_mass"].values[0])
    from vibtrans.analysis.summary import drift_velocity
    from vibtrans.core.simulate import simulate

    scene = Scene(
        amplitude=10**la,
        mass=10**lm,
        profile="cone",
        mu=0.3,
        theta=ds.attrs["scene_theta"],
        nu=ds.attrs["scene_nu"],
        tau=50.0,
        periods=60.0,
        fidelity="preview",
    )
    v = drift_velocity(simulate(scene))
    assert float(ds["drift_velocity"].values[0, 0]) == pytest.approx(v, rel=1e-9, abs=1e-12)


def test_a_measured_sphere_table_reads_as_the_sphere(tmp_path):
    # the sphere's parabola written as a table (metres): the numerical MDR's a0 and
    # contact radius against Hertz's, and the chart asks for that table's own map
    dev = design.preset("paper").device
    r = np.linspace(0, 4e-5, 4001)
    path = tmp_path / "sphere.txt"
    np.savetxt(path, np.column_stack([r, r * r / (2 * dev.radius)]))
    shape = tip_shape(f"file:{path}")
    q, q0 = design.device_quantities(dev, shape=shape), design.device_quantities(dev)
    assert q.a0 == pytest.approx(q0.a0, rel=1e-4)
    assert q.contact_radius == pytest.approx(q0.contact_radius, rel=1e-4)
    need = design.chart_needs(
        dev.substrate,
        dev.particle,
        0.0,
        ("frequency", 3e4, 3e5, 3),
        ("amplitude", 1e-8, 1e-7, 3),
        ("radius", dev.radius),
        shape=shape,
    )
    assert need.profile == f"file:{path}"
    assert need.load_over_modulus == pytest.approx(q0.load / E, rel=1e-12)
    with pytest.raises(InputError, match="N0/E\\* spans"):
        design.chart_needs(
            dev.substrate,
            dev.particle,
            0.0,
            ("radius", 2e-4, 1e-3, 3),
            ("amplitude", 1e-8, 1e-7, 3),
            ("frequency", dev.frequency),
            shape=shape,
        )


def test_kappa_of_a_steep_power_law_is_the_gamma_ratio_and_finite_past_its_overflow():
    """MDR's kappa_n = sqrt(pi) Gamma(n/2 + 1) / Gamma(n/2 + 1/2): where the
    Gammas overflow (n > 341) the ratio's asymptotic series (DLMF 5.11.13)
    takes over; it meets the ratio within 3e-14 where both are computed and
    grows as sqrt(pi n / 2) beyond."""
    import math

    from vibtrans.products.designtip import kappa

    def series(n):
        y = 1.0 / (n / 2 + 0.5)
        return (
            math.sqrt(math.pi)
            / math.sqrt(y)
            * (1 - y / 8 + y * y / 128 + 5 * y**3 / 1024 - 21 * y**4 / 32768)
        )

    for n in (300.0, 340.0):
        exact = math.sqrt(math.pi) * math.gamma(n / 2 + 1) / math.gamma(n / 2 + 0.5)
        assert kappa(n) == exact
        assert abs(series(n) / exact - 1) < 3e-14
    for n in (342.0, 1e6, 1e300):
        assert math.isfinite(kappa(n))
        assert abs(kappa(n) / math.sqrt(math.pi * n / 2) - 1) < 1 / n + 1e-15
