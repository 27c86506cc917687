"""Design charts in device units (vibtrans.products.design, `vibtrans design`)."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from vibtrans import cli
from vibtrans.analysis.summary import summarize
from vibtrans.core import units
from vibtrans.core.errors import InputError
from vibtrans.core.params import PAPER_POINTS, Scene
from vibtrans.core.simulate import simulate
from vibtrans.maps.shipped import maps_dir
from vibtrans.maps.sweep import open_map
from vibtrans.products import design

SHIPPED = maps_dir() / "deformable-mu0.3.zarr"
# a small chart window on the shipped map around the paper's device (cheap to read)
PAPER_X = ("frequency", 3e4, 3e5, 6)
PAPER_Y = ("amplitude", 1e-8, 3e-7, 5)


@pytest.fixture(scope="module")
def shipped():
    return open_map(str(SHIPPED))


@pytest.fixture(scope="module")
def paper_chart():
    dev = design.preset("paper").device
    return design.design_chart(dev.substrate, dev.particle, 0.0, PAPER_X, PAPER_Y, ("radius", dev.radius))


# ---------------------------------------------------------------- converter
@pytest.mark.parametrize(
    "substrate, particle, radius, f, A, preload",
    [
        ("glass", "steel", 0.5e-3, 1.083e5, 2.6e-7, 0.0),
        ("lithium niobate", "fused silica", 10e-6, 10e6, 1e-9, 0.0),
        ("aluminium", "PTFE", 2e-3, 400.0, 2e-6, 1e-3),
        ("LiNbO3", "E=200e9,nu=0.28,rho=7800", 0.5e-3, 10e6, 1e-8, 1.0),
    ],
)
def test_round_trip_si_normalized_si(substrate, particle, radius, f, A, preload):
    # SI -> (A*, m*) -> SI with the inverse relations of docs/MODEL.md 5:
    # f = sqrt(m* Mg / (a0 m)), A_y = A* a0.
    s = units.to_normalized(substrate, particle, radius, f, A, preload)
    f_back = units.frequency_for_mass_ratio(s.m_star, substrate, particle, radius, preload)
    A_back = units.amplitude_from_normalized(s.A_star, s.a0)
    assert f_back == pytest.approx(f, rel=1e-12)
    assert A_back == pytest.approx(A, rel=1e-12)
    # the chart's vectorized mapping agrees with the scalar converter
    a0, A_star, m_star = design.normalize_grid(
        substrate, particle, np.array([radius]), np.array([f]), np.array([A]), preload
    )
    assert a0[0] == pytest.approx(s.a0, rel=1e-12)
    assert A_star[0] == pytest.approx(s.A_star, rel=1e-12)
    assert m_star[0] == pytest.approx(s.m_star, rel=1e-12)


def test_issue_saw_example():
    # The issue's numbers: LiNbO3, 10 MHz, 1 nm, 10 um silica -> A* = 1820, a0 = 5.5e-13 m.
    q = design.device_quantities(design.preset("saw-powder").device)
    assert q.A_star == pytest.approx(1820, rel=5e-3)
    assert q.a0 == pytest.approx(5.5e-13, rel=1e-2)


# ---------------------------------------------------------------- materials
def test_materials_have_sources_and_common_names():
    for m in units.MATERIALS.values():
        assert len(m.source) > 10, m.name
    for written, name in [
        ("lithium niobate", "lithium niobate"),
        ("LiNbO3", "lithium niobate"),
        ("fused silica", "fused silica"),
        ("PTFE", "PTFE"),
        ("teflon", "PTFE"),
        ("steel", "steel"),
        ("glass", "glass"),
        ("aluminium", "aluminium"),
        ("silicon", "silicon"),
        ("lithium tantalate", "lithium tantalate"),
        ("stainless steel", "stainless steel"),
    ]:
        assert units.material(written).name == name
    custom = units.material("E=70e9, nu=0.3, rho=2500")
    glass = units.MATERIALS["glass"]
    for props in (custom, units.custom_material(70e9, 0.3, 2500)):
        assert (props.youngs_modulus, props.poisson_ratio, props.density) == (
            glass.youngs_modulus,
            glass.poisson_ratio,
            glass.density,
        )


@pytest.mark.parametrize(
    "text, word",
    [
        ("E=70e9,nu=0.3", "rho"),
        ("E=70e9,nu=0.7,rho=1", "0.5"),
        ("E=x,nu=0.3,rho=1", "e must be a number"),
        ("K=1,nu=0.3,rho=1", "unknown property"),
        ("unobtainium", "valid names"),
    ],
)
def test_bad_materials_refused(text, word):
    with pytest.raises(InputError, match=word):
        units.material(text)


# ---------------------------------------------------------------- paper example
def test_paper_worked_example_reproduced(paper_chart, shipped):
    # The paper (reference/vibrational-transport-paper.tex, paragraph justifying the
    # omission of k_R x): steel (8000 kg/m^3, 200 GPa, 0.3) on glass (2500, 70 GPa, 0.3),
    # no pre-load, point 4 (m* = 1, A* = 10^2.5): a0 ~ 9e-10 m, f ~ 1e5 Hz and
    # v_x = a0 f v_x* ~ 9 cm/s with |v_x*| ~ 1e3.
    dev = design.preset("paper").device
    q = design.device_quantities(dev)
    assert q.m_star == pytest.approx(1.0, rel=1e-12)
    assert q.A_star == pytest.approx(10**2.5, rel=1e-12)
    # the paper's arithmetic, to 2% (its "9 cm/s" and "9e-10 m" carry one digit;
    # docs/MODEL.md 5 has 9.06 cm/s, 8.36e-10 m)
    assert q.a0 * dev.frequency * 1e3 == pytest.approx(0.09, rel=0.02)
    # the chart at the device reads the map's point 4 itself (it lies on the grid)
    reading = design.read_device(dev)
    la, lm, _ = PAPER_POINTS[4]
    v_star_map = float(shipped["drift_velocity"].sel(log_amplitude=la, log_mass=lm, method="nearest"))
    assert reading["v_star"] == v_star_map
    assert reading["regime"] == "synchronous hopping"  # the paper's point 4
    v = design.device_quantities(dev, reading).drift_velocity
    # against the wave (-x, the paper's hopping drift), and of the paper's order:
    # "|v_x*| ~ 1e3" is an order of magnitude, so within a decade of 9 cm/s
    # (the 2000-period mean is v* = -299, docs/MODEL.md 6: v = -2.7 cm/s)
    assert v < 0
    assert 0.009 < abs(v) < 0.9


@pytest.mark.slow
def test_the_paper_presets_note_is_what_its_device_runs_to():
    # the paper gives v* ~ -1e3 (v ~ 9 cm/s), the device's 2000-period run
    # v* = -299 (-2.71 cm/s): the note says both and why (that run, the
    # explorer's and the maps', is still accelerating); its figures are these
    # runs' (the device's scene as the explorer runs it: its A*, m*, theta
    # and nu, mu = 0.3)
    p = design.preset("paper")
    n = p.device.normalized()
    a0f = n.a0 * p.device.frequency
    # the paper's "9 cm/s" is its |v*| ~ 1e3 times a0 f (docs/MODEL.md 5)
    assert "v* ~ -1e3, v ~ 9 cm/s" in p.note and f"{1e3 * a0f * 100:.1g}" == "9"

    def run(periods):
        ds = simulate(
            Scene(amplitude=n.A_star, mass=n.m_star, theta=n.theta, nu=n.nu, mu=0.3, periods=periods)
        )
        s = summarize(ds)
        return s.drift_velocity, s.final_drift_velocity, s.steady

    v, last, steady = run(2000.0)
    assert (
        f"2000-period run (the maps' and the Run's) gives v* = {v:.3g} ({v * a0f * 100:.2g} cm/s)" in p.note
    )
    assert steady is False and f"still accelerating at the run's end (last tenth {last:.3g})" in p.note
    # settled after about 5000 periods: its last tenth (4500 to 5000) within
    # 1% of the 10000-period run's last tenth, which the note gives
    _, last_5000, _ = run(5000.0)
    v, last, steady = run(10000.0)
    assert steady is True
    assert abs(last_5000 / last - 1) < 0.01
    assert f"it settles at {last:.4g} ({last * a0f * 100:.3g} cm/s) after about 5000 periods" in p.note
    assert f"over 10000 periods the mean is {v:.4g} ({v * a0f * 100:.2g} cm/s)" in p.note


# ---------------------------------------------------------------- chart reading
def test_chart_reads_the_nearest_map_point(paper_chart, shipped):
    ga, gm = shipped["log_amplitude"].values, shipped["log_mass"].values
    dev = design.preset("paper").device
    for j, amp in enumerate(paper_chart["amplitude"].values):
        for i, f in enumerate(paper_chart["frequency"].values):
            s = units.to_normalized(dev.substrate, dev.particle, dev.radius, f, amp)
            ia = np.argmin(np.abs(ga - math.log10(s.A_star)))
            im = np.argmin(np.abs(gm - math.log10(s.m_star)))
            point = paper_chart.isel(amplitude=j, frequency=i)
            assert float(point["v_star"]) == float(shipped["drift_velocity"][ia, im])
            assert int(point["drift"]) == int(shipped["drift"][ia, im])
            assert float(point["drift_velocity"]) == pytest.approx(
                s.a0 * f * float(shipped["drift_velocity"][ia, im]), rel=1e-12
            )
            # the stated reading error: at most half a grid step in each axis
            assert abs(ga[ia] - math.log10(s.A_star)) <= 0.025 + 1e-9
            assert abs(gm[im] - math.log10(s.m_star)) <= 0.025 + 1e-9
    assert paper_chart.attrs["map"] == "shipped: deformable-mu0.3.zarr"
    assert paper_chart.attrs["theta"] == pytest.approx(1.2142857, abs=1e-6)


def test_chart_equals_direct_simulation_within_grid_error(shipped):
    # A device between grid points (paper device at 1.3x its frequency and 0.8x
    # its amplitude), simulated directly with ITS OWN A*, m*, theta and nu and the
    # map's tau, periods and fidelity. Tolerance from the grid: the chart reads
    # one grid point, and the device lies within half a step of it, so the
    # direct value must lie within the spread of v* over that point and its 8
    # neighbours, widened by the map's stated standard-fidelity error (0.5%).
    base = design.preset("paper").device
    dev = replace(base, frequency=base.frequency * 1.3, amplitude=base.amplitude * 0.8)
    reading = design.read_device(dev)
    s = dev.normalized()
    scene = Scene(
        amplitude=s.A_star,
        mass=s.m_star,
        theta=s.theta,
        nu=s.nu,
        mu=shipped.attrs["scene_mu"],
        tau=shipped.attrs["scene_tau"],
        periods=shipped.attrs["scene_periods"],
        fidelity=shipped.attrs["scene_fidelity"],
    )
    direct = summarize(simulate(scene)).drift_velocity
    ia = int(np.argmin(np.abs(shipped["log_amplitude"].values - math.log10(s.A_star))))
    im = int(np.argmin(np.abs(shipped["log_mass"].values - math.log10(s.m_star))))
    block = shipped["drift_velocity"].values[ia - 1 : ia + 2, im - 1 : im + 2]
    assert not shipped["chaotic"].values[ia - 1 : ia + 2, im - 1 : im + 2].any()
    lo, hi = block.min(), block.max()
    slack = 0.005 * max(abs(lo), abs(hi))
    assert lo - slack <= direct <= hi + slack
    assert reading["v_star"] == shipped["drift_velocity"].values[ia, im]


# ---------------------------------------------------------------- warnings
def _codes(device, **kw):
    return {w.code for w in design.validity_warnings(device, **kw)}


def test_a0_warning_both_sides():
    # a0 ~ R^(5/3) with no pre-load (Hertz, m ~ R^3): the radius where a0 equals
    # the threshold, from the paper device's a0 by that closed-form scaling.
    base = design.preset("paper").device
    a0 = base.normalized().a0
    r_c = base.radius * (design.ATOMIC_SPACING / a0) ** 0.6
    assert "a0-subatomic" in _codes(replace(base, radius=r_c * 0.99))
    assert "a0-subatomic" not in _codes(replace(base, radius=r_c * 1.01))


def test_contact_radius_warning_both_sides():
    # contact radius sqrt(R a0) ~ R^(4/3) with no pre-load
    base = design.preset("paper").device
    a_c = math.sqrt(base.radius * base.normalized().a0)
    r_c = base.radius * (design.MIN_CONTACT_RADIUS / a_c) ** 0.75
    assert "contact-subatomic" in _codes(replace(base, radius=r_c * 0.99))
    assert "contact-subatomic" not in _codes(replace(base, radius=r_c * 1.01))


def test_adhesion_warning_both_sides():
    # DMT pull-off 2 pi w R is linear in w: the threshold w from the load
    dev = design.preset("paper").device
    w_c = design.ADHESION_RATIO * dev.normalized().load_N / (2 * math.pi * dev.radius)
    assert "adhesion" in _codes(dev, surface_energy=w_c * 1.01)
    assert "adhesion" not in _codes(dev, surface_energy=w_c * 0.99)
    msg = next(w.message for w in design.validity_warnings(dev, surface_energy=w_c * 2))
    assert "--preload" in msg


def test_travel_warning_both_sides():
    dev = design.preset("paper").device
    v_c = design.TRAVEL_FRACTION * dev.normalized().c_R
    assert "travel" in _codes(dev, drift_velocity=-v_c * 1.01)
    assert "travel" not in _codes(dev, drift_velocity=v_c * 0.99)
    assert "travel" not in _codes(dev)  # no drift given, nothing claimed


@pytest.mark.parametrize(
    "var, threshold, below, words",
    [
        ("a0", design.ATOMIC_SPACING, True, "a0 below the interatomic spacing"),
        ("contact_radius", design.MIN_CONTACT_RADIUS, True, "contact radius below ten interatomic spacings"),
        ("adhesion_ratio", design.ADHESION_RATIO, False, "DMT pull-off at least a tenth"),
        ("travel_over_wavelength", design.TRAVEL_FRACTION, False, "travel per period at least a hundredth"),
    ],
)
def test_chart_warnings_both_sides_of_each_threshold(paper_chart, var, threshold, below, words):
    """design.chart_warnings counts the chart points across each of
    validity_warnings' thresholds (below: strictly; at or above: >=)."""
    chart = paper_chart.copy(deep=True)
    n = chart["a0"].size
    safe = {
        "a0": design.ATOMIC_SPACING * 10,
        "contact_radius": design.MIN_CONTACT_RADIUS * 10,
        "adhesion_ratio": design.ADHESION_RATIO / 10,
        "travel_over_wavelength": design.TRAVEL_FRACTION / 10,
    }
    for k, v in safe.items():
        chart[k].values[...] = v
    assert design.chart_warnings(chart) == []
    vals = chart[var].values
    # the safe side, next to the threshold: at it (for "below") or just under it
    vals[...] = threshold if below else threshold * (1 - 1e-9)
    vals[0, 0] = np.nan  # a point without a value crosses nothing
    assert design.chart_warnings(chart) == []
    # three points across (just below; at the threshold for ">=")
    vals[0, 1:4] = threshold * (1 - 1e-9) if below else threshold
    got = design.chart_warnings(chart)
    assert got == [f"{words}{got[0][len(words) :]}"] and got[0].endswith(f" at 3 of {n} points")
    vals[...] = threshold * 0.5 if below else threshold * 2  # every point
    assert design.chart_warnings(chart)[0].endswith(f" at {n} of {n} points")
    # every threshold crossed: one line each, in validity_warnings' order
    chart["a0"].values[...] = 0.0
    chart["contact_radius"].values[...] = 0.0
    chart["adhesion_ratio"].values[...] = 1.0
    chart["travel_over_wavelength"].values[...] = 1.0
    lines = design.chart_warnings(chart)
    assert [line.rsplit(" at ", 1)[0] for line in lines] == [
        "a0 below the interatomic spacing",
        "contact radius below ten interatomic spacings",
        "DMT pull-off at least a tenth of the load",
        "travel per period at least a hundredth of the wavelength",
    ]
    assert not hasattr(cli, "_chart_warnings")  # the command line uses the library's


def test_device_quantities_closed_forms():
    dev = design.preset("paper").device
    q = design.device_quantities(dev)
    omega = 2 * math.pi * dev.frequency
    assert q.peak_acceleration_g == pytest.approx(omega**2 * dev.amplitude / 9.81, rel=1e-12)
    assert q.peak_velocity == pytest.approx(omega * dev.amplitude, rel=1e-12)
    assert q.rayleigh_wavelength == pytest.approx(q.rayleigh_speed / dev.frequency, rel=1e-12)
    # Hertz: mean pressure = 2/3 of the peak p0 = (6 N E*^2 / (pi^3 R^2))^(1/3)
    E_eff = units.effective_modulus(70e9, 0.3, 200e9, 0.3)
    p0 = (6 * q.load * E_eff**2 / (math.pi**3 * dev.radius**2)) ** (1 / 3)
    assert q.mean_contact_pressure == pytest.approx(2 / 3 * p0, rel=1e-12)
    assert q.pull_off_dmt / q.pull_off_jkr == pytest.approx(4 / 3)


# ---------------------------------------------------------------- refusals
def test_outside_the_shipped_maps_is_refused_with_reasons(tmp_path):
    dev = design.preset("saw-powder").device
    with pytest.raises(InputError) as exc:
        design.design_chart(
            dev.substrate,
            dev.particle,
            0.0,
            ("amplitude", 1e-10, 2e-9, 3),
            ("radius", 2e-6, 2e-5, 3),
            ("frequency", 10e6),
        )
    text = str(exc.value)
    for word in ("theta", "nu 0.25", "log10 A*", "--compute"):
        assert word in text
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(x=("speed", 1, 2, 3)), "x quantity"),
        (dict(x=("frequency", 2e5, 1e5, 3)), "lo < hi"),
        (dict(x=("frequency", 1e4, 1e5, 1)), "points must be an integer"),
        (dict(x=("frequency", -1.0, 1e5, 3)), "x lo"),
        (dict(y=("frequency", 1e4, 1e5, 3)), "once each"),
        (dict(fixed=("radius", 0.0)), "fixed radius"),
        (dict(mu=0.0), "mu"),
        (dict(surface_energy=-1.0), "surface_energy"),
        (dict(preload=-1.0), "preload"),
        (dict(compute=True), "store_dir"),
    ],
)
def test_bad_chart_input_refused(kw, word):
    args = dict(substrate="glass", particle="steel", x=PAPER_X, y=PAPER_Y, fixed=("radius", 0.5e-3))
    args.update(kw)
    with pytest.raises(InputError, match=word):
        design.design_chart(**args)


@pytest.mark.parametrize(
    "argv, word",
    [
        (["--preset", "nope"], "preset must be one of"),
        (["--substrate", "glass"], "substrate and particle"),
        (["--preset", "paper", "--x", "frequency:1e4:1e6"], "QUANTITY:LO:HI:N"),
        (["--preset", "paper", "--out", "chart.gif"], ".png, .svg"),
        (["--preset", "paper", "--surface-energy", "-1"], "surface_energy"),
        (["--preset", "paper", "--particle", "E=1e9,nu=0.9,rho=1000"], "0.5"),
        (
            [
                "--substrate",
                "glass",
                "--particle",
                "steel",
                "--x",
                "frequency:1e4:1e6:5",
                "--y",
                "amplitude:1e-9:1e-7:5",
            ],
            "needs a value",
        ),
    ],
)
def test_cli_refuses_bad_input(argv, word, capsys):
    assert cli.main(["design", *argv]) == 2
    assert word in capsys.readouterr().err


# ---------------------------------------------------------------- headless export
def test_cli_paper_preset_exports(tmp_path, capsys):
    outs = [tmp_path / f"chart.{e}" for e in ("png", "nc", "csv")]
    argv = [
        "design",
        "--preset",
        "paper",
        "--x",
        "frequency:3e4:3e5:6",
        "--y",
        "amplitude:1e-8:3e-7:5",
        "--json",
    ]
    for o in outs:
        argv += ["--out", str(o)]
    assert cli.main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["regime"] == "synchronous hopping"
    assert report["device"]["drift_velocity"] < 0
    assert [w["code"] for w in report["warnings"]] == ["adhesion"]
    assert np.shape(report["chart"]["drift_velocity"]) == (5, 6)
    assert outs[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import xarray as xr

    with xr.open_dataset(outs[1]) as back:
        assert back["drift_velocity"].shape == (5, 6)
        assert back.attrs["map"] == "shipped: deformable-mu0.3.zarr"
    assert outs[2].read_text().splitlines()[0].startswith("amplitude,frequency,")
    # the chart-wide warnings are the library's (design.chart_warnings)
    dev = design.preset("paper").device
    chart = design.design_chart(dev.substrate, dev.particle, 0.0, PAPER_X, PAPER_Y, ("radius", dev.radius))
    assert report["chart_warnings"] == design.chart_warnings(chart)
    assert report["chart_warnings"] and "DMT pull-off" in report["chart_warnings"][0]


@pytest.mark.parametrize("name", ["saw-motor", "saw-powder", "feeder"])
def test_cli_computed_presets_export(name, tmp_path, capsys):
    # outside the shipped maps: a coarse, short preview window (cheap), cost printed first
    out = tmp_path / f"{name}.png"
    p = design.preset(name)
    argv = [
        "design",
        "--preset",
        name,
        "--compute",
        "--store",
        str(tmp_path / "store"),
        "--step",
        "0.5",
        "--periods",
        "60",
        "--out",
        str(out),
        "--x",
        f"{p.x[0]}:{p.x[1]}:{p.x[2]}:4",
        "--y",
        f"{p.y[0]}:{p.y[1]}:{p.y[2]}:4",
    ]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "points x 60 periods" in captured.err
    assert "integration steps" in captured.err
    assert "map computed:" in captured.out
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_parser_loads_no_numerics():
    # `vibtrans serve` re-executes itself after building the parser: the
    # design subcommand's options must not import numpy (tests/project/test_lazy_import.py)
    import subprocess
    import sys

    code = (
        "import sys, vibtrans.cli; vibtrans.cli.build_parser(); "
        "print([m for m in ('numpy', 'vibtrans.products.design') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
