"""The stroboscopic map, periodic orbits and their Floquet multipliers
(vibtrans/analysis/dynamics.py).

Sources: the closed form of the linearized contact oscillator (small A*:
the period-1 orbit's multipliers exp(+-i w0), w0 = sqrt(3 / (2 m*)), trace
2 cos w0, reaching 2 at the fundamental resonance m_c* = 3 / (8 pi^2) and
-2 at 4 m_c*); central finite differences of the map (its Jacobian);
det = 1 (the map is area preserving); the shipped map's synchronous points
(a synchronous hopping regime is a stable period-1 orbit).
"""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from vibtrans import Scene, paper_scene
from vibtrans.analysis import dynamics as Y
from vibtrans.core.errors import InputError

M_C = 1.5 / (4.0 * math.pi**2)  # w0 = 2 pi: the fundamental contact resonance


@pytest.mark.parametrize("mass", [0.3 * M_C, 0.9 * M_C, 1.1 * M_C, 2 * M_C, 4 * M_C, 0.5, 2.0, 20.0])
def test_small_amplitude_contact_orbit_has_the_linear_multipliers(mass):
    amplitude = 1e-4
    orbit = Y.periodic_orbit(amplitude, mass, Y.rest_guess(amplitude, mass))
    w0 = math.sqrt(1.5 / mass)
    assert orbit.found and orbit.residual < 1e-9
    assert orbit.trace == pytest.approx(2.0 * math.cos(w0), abs=2e-4)
    expected = np.exp(1j * w0)
    got = min(orbit.multipliers, key=lambda v: abs(v - expected))
    assert abs(got - expected) < 2e-2  # multipliers near a double root meet as sqrt
    assert orbit.determinant == pytest.approx(1.0, abs=1e-5)
    assert orbit.stable == (abs(2.0 * math.cos(w0)) < 2.0)


def test_period_doubling_tongue_opens_at_four_times_the_resonance_mass():
    """trace = -2 where the contact frequency is half the drive's (m* = 4
    m_c*): at small A* the trace touches -2 there; as A* grows a band of
    hyperbolic (trace < -2) orbits opens around it."""
    log_4mc = math.log10(4 * M_C)
    masses = np.linspace(log_4mc - 0.1, log_4mc + 0.1, 41)

    def traces(amplitude):
        return np.array(
            [Y.periodic_orbit(amplitude, 10**lm, Y.rest_guess(amplitude, 10**lm)).trace for lm in masses]
        )

    small = traces(1e-3)
    assert small.min() == pytest.approx(-2.0, abs=2e-3)
    assert abs(masses[np.argmin(small)] - log_4mc) <= 0.01
    wider = traces(0.1)
    band = masses[wider < -2.0]
    assert band.size >= 3 and band.min() < log_4mc < band.max()
    assert (traces(0.3) < -2.0).sum() > band.size


@pytest.mark.parametrize(
    "amplitude,mass,y,vy",
    [
        (1e-2, 0.5, 1.004, 0.01),  # contact start: the bootstrapped history
        (10**0.4, 10**1.3, -3.0, 1.0),  # flight start, landing, hopping
        (10**1.1, 10**0.4, 0.0, 0.0),
    ],
)
def test_jacobian_is_the_maps_derivative(amplitude, mass, y, vy):
    s = Y.strobe(amplitude, mass, y, vy, 2)
    eps = 1e-6
    fd = np.zeros((2, 2))
    for j, e in enumerate(np.eye(2)):
        plus = Y.strobe(amplitude, mass, y + eps * e[0], vy + eps * e[1], 2)
        minus = Y.strobe(amplitude, mass, y - eps * e[0], vy - eps * e[1], 2)
        fd[:, j] = (np.array([plus.y, plus.vy]) - np.array([minus.y, minus.vy])) / (2 * eps)
    assert np.linalg.norm(s.jacobian - fd) <= 5e-3 * np.linalg.norm(fd)
    assert np.linalg.det(s.jacobian) == pytest.approx(1.0, abs=1e-3)


def test_synchronous_points_of_the_shipped_map_are_stable_period_one_orbits():
    for la, lm in ((0.15, 0.9), (1.1, 0.4), (1.95, 0.9)):
        A, m = 10**la, 10**lm
        orbit = Y.periodic_orbit(A, m, Y.run_guess(Scene(amplitude=A, mass=m)))
        assert orbit.found and orbit.stable, (la, lm, orbit)
        assert orbit.y - A * 1.0 < 0.0  # at t = 0 mod 1 it is in flight (a* < 0)
        assert orbit.determinant == pytest.approx(1.0, abs=1e-5)


def test_continuation_finds_the_tongues_period_doublings():
    log_4mc = math.log10(4 * M_C)
    A = 0.3
    branch = Y.continue_orbit(
        math.log10(A),
        log_4mc + 0.15,
        "mass",
        log_4mc - 0.15,
        step=0.01,
        guess=Y.rest_guess(A, 10 ** (log_4mc + 0.15)),
    )
    assert branch.ended == "reached the end"
    assert len(branch.period_doublings) == 2
    lo, hi = sorted(branch.period_doublings)
    assert lo < log_4mc < hi
    for p in branch.points:
        assert p.orbit.stable == (abs(p.orbit.trace) < 2.0)


def test_bad_arguments_are_refused():
    with pytest.raises(InputError, match="period must be an integer in"):
        Y.periodic_orbit(1.0, 1.0, (1.0, 0.0), period=0)
    with pytest.raises(InputError, match="amplitude"):
        Y.periodic_orbit(-1.0, 1.0, (1.0, 0.0))
    with pytest.raises(InputError, match="parameter must be amplitude or mass"):
        Y.continue_orbit(0.0, 0.0, "tau", 1.0)


def test_cli_orbit_prints_the_orbit():
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "vibtrans.cli",
            "orbit",
            "--log-amplitude",
            "0.15",
            "--log-mass",
            "0.9",
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    got = json.loads(out.stdout)
    assert got["found"] is True and got["stable"] is True and abs(got["trace"]) < 2
    assert len(got["multipliers"]) == 2 and {"y", "vy"} <= set(got)
    bad = subprocess.run(
        [
            sys.executable,
            "-m",
            "vibtrans.cli",
            "orbit",
            "--log-amplitude",
            "0.15",
            "--log-mass",
            "0.9",
            "--period",
            "0",
        ],
        capture_output=True,
        text=True,
    )
    assert bad.returncode != 0 and "period" in bad.stderr and "Traceback" not in bad.stderr


def test_orbit_diagram_shows_one_phase_on_a_synchronous_line_and_many_in_chaos():
    """Paper point 6 (synchronous) along A*: one take-off per period at one
    phase (spread < 0.02, the synchronous criterion); paper point 8's
    neighbourhood (chaotic by the exponent): phases spread over the period."""
    d = Y.orbit_diagram(paper_scene(6), "amplitude", [0.2, 0.25, 0.3], final_periods=50)
    for v in d.values:
        p = d.phase[d.phase_value == v]
        assert p.size == 50 and np.ptp(p) < 0.02
        assert (d.section_value == v).sum() == 51
    c = Y.orbit_diagram(paper_scene(8), "mass", [-2.05, -2.0], final_periods=1000)
    for v in c.values:  # long flights: 10-22 take-offs in 1000 periods
        p = c.phase[c.phase_value == v]
        assert p.size >= 5 and np.ptp(p) > 0.3
    with pytest.raises(InputError, match="values must be 1 to"):
        Y.orbit_diagram(paper_scene(6), "amplitude", [])


@pytest.mark.parametrize(
    "args",
    [
        ["lyapunov-map"],
        ["section", "--point", "6", "--section-periods", "50"],
        [
            "orbit-diagram",
            "--point",
            "6",
            "--along",
            "amplitude",
            "--to",
            "0.5",
            "--runs",
            "4",
            "--final",
            "20",
        ],
        [
            "continuation",
            "--log-amplitude",
            "-1",
            "--log-mass",
            "-0.7",
            "--along",
            "mass",
            "--to",
            "-0.9",
            "--step",
            "0.05",
        ],
    ],
)
def test_dynamics_figures_export(tmp_path, args):
    from vibtrans.cli import main

    out = tmp_path / "fig.png"
    assert main(["export", *args, "--out", str(out), "--dpi", "40"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args,message",
    [
        (["orbit-diagram", "--point", "6", "--to", "1"], "needs --along amplitude|mass and --to"),
        (
            ["orbit-diagram", "--point", "6", "--along", "mass", "--to", "1", "--runs", "1"],
            "runs must be an integer in [2, 2000]",
        ),
        (
            ["section", "--point", "6", "--section-periods", "0"],
            "section_periods must be an integer in [1, 20000]",
        ),
        (
            ["continuation", "--point", "6", "--along", "mass", "--to", "1", "--step", "2"],
            "step must be a number in [0.0001, 0.5]",
        ),
    ],
)
def test_dynamics_exports_refuse_bad_input(tmp_path, capsys, args, message):
    from vibtrans.cli import main

    assert main(["export", *args, "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize(
    "amplitude,mass,guess",
    [
        (1e-3, 0.01, None),
        (1e-3, 0.1, None),
        (1e-3, 1.0, None),
        (10**0.15, 10**0.9, (0.619, 0.0)),  # a synchronous hopping orbit
    ],
)
def test_multipliers_product_is_one_at_reference_fidelity(amplitude, mass, guess):
    """det = 1 (area preserving) to 1e-8 at the reference step; the standard
    step's AB4 damping of stiff contact leaves up to 3e-6 (m* = 0.01)."""
    guess = guess or Y.rest_guess(amplitude, mass)
    orbit = Y.periodic_orbit(amplitude, mass, guess, fidelity="reference")
    assert orbit.found
    assert abs(orbit.determinant - 1.0) < 1e-8
    m1, m2 = orbit.multipliers
    assert abs(m1 * m2 - 1.0) < 1e-8


def test_point_six_hop_is_elliptic_not_an_attractor():
    # the researcher's tutorial states it: the period-1 hop of point 6 has a
    # complex pair of multipliers ON the unit circle (an area-preserving map:
    # product 1), so nearby motions circle it and its exponent is ~0
    from pathlib import Path

    scene = paper_scene(6)
    orbit = Y.periodic_orbit(scene.amplitude, scene.mass, Y.run_guess(scene))
    assert orbit.found and orbit.stable and abs(orbit.trace) < 2
    assert all(abs(abs(m) - 1.0) < 1e-6 for m in orbit.multipliers), orbit.multipliers
    text = (Path(__file__).resolve().parents[2] / "docs/tutorials/researcher.md").read_text()
    assert "inside the unit circle" not in text and "is *elliptic*" in text
