"""A particle that rolls (docs/MODEL.md section 11).

Sources: the closed forms of section 11 (derived there from m* x*'' = -mu T*
and j m* (omega R)*' = -mu T*: from rest omega R = x*'/j and the contact
point at (1 + 1/j) x*; in full stick the centre follows u_x*/(1 + 1/j), the
ball on a tray's 2/7 for a solid sphere); an independent implementation
(tests/naive.py `rolling_run`: the rotation integrated as a degree of
freedom of its own, the spring bed for the memory); the bit-identity of a
particle that does not turn (its kernel and records as before rolling).
"""

import math
import re

import naive
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibtrans import simulate
from vibtrans.analysis.summary import summarize
from vibtrans.cli import main
from vibtrans.core import drivers
from vibtrans.core.errors import InputError, StoreMismatch
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R
from vibtrans.core.params import Scene, paper_scene
from vibtrans.core.simulate import SAMPLES_PER_PERIOD, hertz_params, memory_snapshot
from vibtrans.maps.sweep import Sweep, check_store, compute_point
from vibtrans.products import design

# the variables of a run of a particle that does not turn (as before rolling)
PLAIN_VARIABLES = {
    "x",
    "vx",
    "y",
    "vy",
    "a",
    "b",
    "bdot",
    "N",
    "T",
    "state",
    "stick_radius",
    "contact_radius",
    "event_time",
    "event_kind",
    "event_value",
    "time",
}
ROLLING_VARIABLES = {"roll", "roll_velocity", "slip_velocity"}
RANGE_TEXT = "rolling must be none, solid (j = 2/5), shell (j = 2/3) or a number j"


def _surface(t, scene):
    """(u_x*, u_x*') at the times t, from tests/naive.py (its own formulas)."""
    rows = [naive.surface(float(ti), scene.amplitude, scene.r, scene.tau) for ti in t]
    return np.array([r[0] for r in rows]), np.array([r[2] for r in rows])


# ------------------------------------------------------------------ the parameter
@pytest.mark.parametrize(
    "value, canonical, j",
    [
        ("none", "none", None),
        ("solid", "solid", 0.4),
        ("shell", "shell", 2.0 / 3.0),
        (0.5, 0.5, 0.5),
        ("0.25", 0.25, 0.25),
        (1, 1.0, 1.0),
        ("1", 1.0, 1.0),
        (np.float64(0.3), 0.3, 0.3),
        (" solid ", "solid", 0.4),
        (1e-300, 1e-300, 1e-300),
    ],
)
def test_rolling_takes_a_name_or_j_in_0_1(value, canonical, j):
    scene = Scene(rolling=value)
    assert scene.rolling == canonical and scene.inertia_ratio == j
    if canonical == "none":
        assert "rolling" not in scene.values()
    else:
        assert scene.values()["rolling"] == canonical
        assert Scene(**scene.values()).rolling == canonical
        assert scene.replace(mass=1.0).rolling == canonical


@pytest.mark.parametrize(
    "value",
    [
        "",
        "abc",
        "Solid",
        "none0",
        0,
        0.0,
        -0.4,
        1.0000001,
        2,
        math.nan,
        math.inf,
        -math.inf,
        "nan",
        "inf",
        "0",
        "-1",
        True,
        False,
        None,
        [0.4],
        (0.4,),
        {"j": 0.4},
        1j,
        b"solid",
        10**400,
    ],
)
def test_bad_rolling_is_refused_naming_the_parameter_and_range(value):
    with pytest.raises(
        InputError,
        match=r"rolling must be none, solid \(j = 2/5\), shell "
        r"\(j = 2/3\) or a number j = I/\(m R\^2\) in \(0, 1\]",
    ):
        Scene(rolling=value)


@pytest.mark.parametrize(
    "model, why",
    [("point-mass", "the material point has no size"), ("vertical", "the vertical model has no tangential")],
)
def test_only_the_deformable_particle_rolls(model, why):
    with pytest.raises(InputError, match=f"rolling applies to the deformable model only \\({why}"):
        Scene(model=model, rolling="solid")
    assert Scene(model=model, rolling="none").rolling == "none"


# ------------------------------------------------------ a particle that does not turn
def test_a_particle_that_does_not_turn_runs_as_before():
    # its dataset has no rolling variable or attribute; and the rolling
    # kernel, given 1/j so small that its contact point is x* exactly, records
    # what the plain kernel records bit for bit (the rolling code changes
    # nothing but the contact point)
    ds = simulate(Scene(periods=20.0, tau=2.0))
    assert set(ds.variables) == PLAIN_VARIABLES
    assert not {"rolling", "inertia_ratio", "max_episode_roll"} & set(ds.attrs)
    for point in (1, 6):
        sc = paper_scene(point, periods=40.0, tau=2.0)
        p, _, cap = hertz_params(sc, 30.0, 31.0, SAMPLES_PER_PERIOD, 1.0, D.SHORTCUTS_ALL, None)
        plain = drivers.run_hertz(p, "ab4", tangential=True, samples_capacity=cap)
        same = drivers.run_hertz(p._replace(roll_ratio=1e-300), "ab4", tangential=True, samples_capacity=cap)
        assert 1.0 + 1e-300 == 1.0
        assert np.array_equal(plain.samples, same.samples)
        assert np.array_equal(plain.events, same.events)


# ------------------------------------------------------------------ closed forms
@pytest.mark.parametrize("rolling, j", [("solid", 0.4), ("shell", 2.0 / 3.0), (1.0, 1.0)])
def test_in_full_stick_the_centre_follows_the_substrate_over_1_plus_1_over_j(rolling, j):
    # A ball on a tray: at A* = 1e-2, m* = 1e-4, mu = 1 the contact never
    # slides (stick and micro-slip at the edge only) and the centre follows
    # u_x*/(1 + 1/j): 2/7 of the substrate's motion for a solid sphere. The
    # contact's tangential compliance (T* ~ 1.5 sqrt(a*) b*) shifts the
    # amplitude to A* r / (1 + 1/j - theta m* (2 pi)^2 / 1.5), by
    # theta m* (2 pi)^2 / (1.5 (1 + 1/j)) = 0.09% (solid) to 0.16% (j = 1):
    # the quasi-static form holds to 0.2%, the compliant one to 1e-5
    # (measured 1.5e-6 solid, 4.7e-6 shell; the rest: a*'s 1% oscillation
    # and the memory's micro-slip).
    scene = Scene(amplitude=1e-2, mass=1e-4, mu=1.0, tau=1.0, periods=10.0, rolling=rolling)
    ds = simulate(scene, window=(7.0, 10.0))
    t = ds["time"].values
    late = t >= 7.0  # the ramp is over (G = 1 - 4e-22)
    kc = 1.0 + 1.0 / j
    ux, _ = _surface(t[late], scene)
    U = scene.amplitude * scene.r
    x = ds["x"].values[late]
    assert set(ds["state"].values.tolist()) <= {1, 2}  # stick and partial slip only
    assert np.abs(x - ux / kc).max() <= 2e-3 * U / kc
    X = U / (kc - scene.theta * scene.mass * (2 * math.pi) ** 2 / 1.5)
    assert np.abs(x - ux * X / U).max() <= 1e-5 * X
    if rolling == "solid":
        assert np.abs(x).max() / U == pytest.approx(2.0 / 7.0, rel=2e-3)


def test_the_contact_point_moves_1_plus_1_over_j_times_the_centre_from_rest():
    # hopping (paper point 6's scene): at every step, in contact and in
    # flight, b* theta mu = (1 + 1/j) x* - u_x*, the roll is x*/j, omega R is
    # x*'/j, and omega is constant in flight
    j = 2.0 / 3.0
    scene = paper_scene(6, periods=12.0, tau=2.0, rolling="shell")
    ds = simulate(scene, window=(0.0, 12.0))
    t, x, vx = ds["time"].values, ds["x"].values, ds["vx"].values
    ux, uxd = _surface(t, scene)
    scale = scene.theta * scene.mu
    contact_point = ds["b"].values * scale + ux
    assert np.allclose(contact_point, (1.0 + 1.0 / j) * x, rtol=0, atol=1e-12)
    assert np.allclose(ds["slip_velocity"].values, vx + ds["roll_velocity"].values - uxd, rtol=0, atol=1e-11)
    assert np.allclose(ds["roll"].values, x / j, rtol=1e-15, atol=0)
    assert np.allclose(ds["roll_velocity"].values, vx / j, rtol=1e-15, atol=0)
    flying = ds["state"].values == 0
    takeoffs = ds["event_time"].values[ds["event_kind"].values == R.TAKEOFF]
    assert takeoffs.size >= 5 and flying.sum() > 100
    flight = np.searchsorted(takeoffs, t[flying])  # which flight each sample is in
    w = ds["roll_velocity"].values[flying]
    for k in np.unique(flight):
        assert np.ptp(w[flight == k]) == 0.0  # omega constant in flight, exactly
    assert ds.attrs["rolling"] == "shell" and ds.attrs["inertia_ratio"] == j


@pytest.mark.parametrize("point, rolling", [(6, "solid"), (1, "shell"), (4, 0.5)])
def test_max_episode_roll_is_the_largest_rolled_arc_of_a_contact_episode(point, rolling):
    # against the full-resolution records: each contact episode (landing to
    # take-off) its span of x*/j; the kernel also sees the take-off point,
    # between records, and the step after T_obs: at most a step's motion more
    scene = paper_scene(point, periods=30.0, tau=2.0, rolling=rolling)
    ds = simulate(scene, window=(0.0, 30.0))
    j = scene.inertia_ratio
    t, x, st_ = ds["time"].values, ds["x"].values, ds["state"].values
    kinds, times = ds["event_kind"].values, ds["event_time"].values
    starts = np.concatenate([[0.0], times[kinds == R.LANDING]])
    ends = np.concatenate([times[kinds == R.TAKEOFF], [np.inf]])
    spans = [
        np.ptp(x[(t >= a) & (t <= b) & (st_ != 0)])
        for a, b in zip(starts, ends)
        if ((t >= a) & (t <= b) & (st_ != 0)).any()
    ]
    step_motion = np.abs(np.diff(x)).max()
    got = ds.attrs["max_episode_roll"]
    assert max(spans) / j <= got <= (max(spans) + 2 * step_motion) / j
    assert summarize(ds).max_episode_roll == got


# --------------------------------------------------------- property: from rest
@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much]
)
@given(
    log_a=st.floats(-2.0, 2.0),
    log_m=st.floats(-3.0, 2.0),
    mu=st.floats(0.05, 2.0),
    theta=st.floats(1.0, 1.5),
    j=st.floats(0.05, 1.0),
    integrator=st.sampled_from(["ab4", "verlet"]),
)
def test_from_rest_the_contact_point_and_omega_follow_the_centre(log_a, log_m, mu, theta, j, integrator):
    # both start at zero and are driven by the same force: at every sample
    # the contact point's displacement (what the memory diagram sees) is
    # (1 + 1/j) x*, and omega R is x*'/j
    scene = Scene(
        amplitude=10.0**log_a,
        mass=10.0**log_m,
        mu=mu,
        theta=theta,
        tau=0.5,
        periods=3.0,
        fidelity="preview",
        integrator=integrator,
        rolling=j,
    )
    ds = simulate(scene, window=(2.0, 2.5))
    t, x = ds["time"].values, ds["x"].values
    ux, uxd = _surface(t, scene)
    contact_point = ds["b"].values * (theta * mu) + ux
    size = 1.0 + np.abs(contact_point).max() + np.abs(ux).max()
    assert np.abs(contact_point - (1.0 + 1.0 / j) * x).max() <= 1e-13 * size
    assert np.array_equal(ds["roll_velocity"].values, ds["vx"].values * (1.0 / j))
    assert np.array_equal(ds["roll"].values, x * (1.0 / j))
    slip = ds["vx"].values + ds["roll_velocity"].values - uxd
    assert np.abs(ds["slip_velocity"].values - slip).max() <= 1e-12 * (1.0 + np.abs(slip).max())
    assert ds.attrs["max_episode_roll"] >= 0.0


# ------------------------------------------------------------------ the naive twin
# id: (A*, m*, periods, twin step, hmax, j, the largest |kernel - twin| in
#      (x*, y*, x*', roll, omega R) at the standard step and at refine 4).
# Measured (standard; refine 4): p1 solid 1.6e-5, 2.3e-9, 4.6e-6, 3.9e-5,
# 1.1e-5; 7.1e-6, 1.8e-9, 2.3e-6, 1.8e-5, 5.7e-6.  p6 shell 7.5e-5, 9.6e-6,
# 1.5e-5, 1.1e-4, 2.2e-5; 7.8e-6, 1.1e-7, 1.6e-6, 1.2e-5, 2.4e-6.  p2 solid
# 9.5e-6, 2.1e-5, 3.2e-4, 2.4e-5, 8.1e-4; 3.6e-6, 6.3e-6, 5.9e-5, 9.0e-6,
# 1.5e-4.  Bounds: twice those, fixed (the kernel converges towards the twin:
# the refine-4 bound is below the standard one).
TWIN = {
    "p1-solid": (
        10**-0.3,
        10.0,
        10.0,
        1 / 2048,
        4.0,
        0.4,
        (3.2e-5, 5e-9, 9.2e-6, 7.8e-5, 2.3e-5),
        (1.5e-5, 4e-9, 4.6e-6, 3.6e-5, 1.2e-5),
    ),
    "p6-shell": (
        10**0.25,
        10**0.8,
        10.0,
        1 / 2048,
        4.0,
        2.0 / 3.0,
        (1.5e-4, 2e-5, 3e-5, 2.3e-4, 4.5e-5),
        (1.6e-5, 2.2e-7, 3.2e-6, 2.4e-5, 4.8e-6),
    ),
    "p2-solid": (
        10.0,
        10**-2.7,
        4.0,
        1 / 4096,
        2.0,
        0.4,
        (1.9e-5, 4.2e-5, 6.4e-4, 4.8e-5, 1.6e-3),
        (7.2e-6, 1.3e-5, 1.2e-4, 1.8e-5, 3e-4),
    ),
}


@pytest.mark.parametrize(
    "case", [pytest.param(c, marks=() if c == "p1-solid" else pytest.mark.slow) for c in TWIN]
)
def test_rolling_run_agrees_with_its_naive_twin(case):
    # the twin integrates omega R and the rolled arc as a degree of freedom of
    # their own (j m* (omega R)' = -mu T*), the kernel derives them from x*
    A, m, T, hn, hmax, j, bound_std, bound_fine = TWIN[case]
    scene = Scene(amplitude=A, mass=m, tau=2.0, periods=T, rolling=j)
    twin = naive.rolling_run(
        A, m, scene.mu, scene.theta, scene.r, scene.tau, T, hn, j, springs=2000, hmax=hmax
    )
    for refine, bound in ((1, bound_std), (4, bound_fine)):
        ds = simulate(scene, window=(0.0, T), refine=refine)
        t = ds["time"].values
        diff = np.array(
            [
                np.abs(ds[v].values - np.interp(t, twin["t"], twin[w])).max()
                for v, w in (("x", "x"), ("y", "y"), ("vx", "vx"), ("roll", "q"), ("roll_velocity", "w"))
            ]
        )
        print(f"{case} refine {refine}: {diff}")
        assert np.all(diff <= np.array(bound)), (refine, diff, bound)
    # the twin's own rotation obeys the closed form too
    assert np.allclose(twin["w"], twin["vx"] / j, rtol=0, atol=1e-9 * (1 + np.abs(twin["vx"]).max()))


# ------------------------------------------------------------------ everywhere a scene goes
def test_summary_says_whether_the_particle_rolls():
    plain = summarize(simulate(Scene(periods=20.0, tau=2.0)))
    assert plain.rolling == "none" and plain.max_episode_roll is None
    assert "rolls" not in plain.regime
    rolled = summarize(simulate(Scene(periods=20.0, tau=2.0, rolling="solid")))
    assert rolled.rolling == "solid sphere, j = 0.4" and rolled.max_episode_roll > 0
    assert rolled.regime.endswith("; rolls (solid sphere, j = 0.4)")
    other = summarize(simulate(Scene(periods=20.0, tau=2.0, rolling=0.3)))
    assert other.rolling == "j = 0.3"


def test_memory_snapshot_of_a_rolling_particle_sees_the_contact_point():
    scene = Scene(periods=10.0, tau=2.0, rolling="solid")
    snap = memory_snapshot(scene, t=6.0)
    ds = simulate(scene.replace(periods=snap["t"]))
    assert snap["b"] == pytest.approx(float(ds["b"].values[-1]), abs=1e-12)


def test_sweep_keys_a_rolling_map_and_keeps_the_keys_of_one_that_does_not(tmp_path):
    grid = ([0.0], [0.0])
    plain = Sweep(*grid, model="deformable", mu=0.3)
    assert "rolling" not in plain.values and "scene_rolling" not in plain.attrs()
    rolled = Sweep(*grid, model="deformable", mu=0.3, rolling="shell")
    assert rolled.values["rolling"] == "shell" and rolled.attrs()["scene_rolling"] == "shell"
    with pytest.raises(StoreMismatch, match="rolling: store 'shell', command 'none'"):
        check_store(rolled.empty_dataset(), plain, "store")
    with pytest.raises(StoreMismatch, match="rolling: store None, command 'shell'"):
        check_store(plain.empty_dataset(), rolled, "store")
    with pytest.raises(InputError, match="rolling applies to the deformable model only"):
        Sweep(*grid, model="vertical", kind="lyapunov", rolling="solid")
    point = compute_point({**rolled.values, "periods": 20.0, "tau": 2.0}, -0.3, 1.0, chaos="lyapunov")
    ds = simulate(Scene(amplitude=10**-0.3, mass=10.0, periods=20.0, tau=2.0, rolling="shell"))
    assert point["drift_velocity"] == float(ds["x"].values[-1]) / 20.0


def test_design_reads_no_shipped_map_for_a_particle_that_turns():
    args = (
        "glass",
        "steel",
        0.0,
        ("frequency", 1e4, 1e5, 3),
        ("amplitude", 1e-9, 1e-8, 3),
        ("radius", 0.5e-3),
    )
    need = design.chart_needs(*args, rolling="solid")
    assert need.rolling == "solid"
    assert any("rolling solid needs a map of its own" in p for p in need.shipped_problems)
    with pytest.raises(design.NoMapCovers, match="rolling solid needs a map of its own"):
        design.design_chart(*args, rolling="solid")
    with pytest.raises(InputError, match=re.escape(RANGE_TEXT)):
        design.chart_needs(*args, rolling="hollow")


def test_cli_takes_rolling(capsys):
    import json

    assert (
        main(
            [
                "simulate",
                "--log-amplitude",
                "-0.3",
                "--log-mass",
                "1",
                "--periods",
                "20",
                "--tau",
                "2",
                "--rolling",
                "solid",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["scene"]["rolling"] == "solid" and out["rolling"] == "solid sphere, j = 0.4"
    assert out["max_episode_roll"] > 0
    assert (
        main(
            [
                "simulate",
                "--log-amplitude",
                "-0.3",
                "--log-mass",
                "1",
                "--periods",
                "20",
                "--tau",
                "2",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert "rolling" not in out["scene"] and out["rolling"] == "none"
    for argv, message in (
        (["simulate", "--log-amplitude", "0", "--log-mass", "0", "--rolling", "2"], RANGE_TEXT),
        (
            [
                "simulate",
                "--log-amplitude",
                "0",
                "--log-mass",
                "0",
                "--rolling",
                "solid",
                "--model",
                "point-mass",
            ],
            "rolling applies to the deformable model only",
        ),
        (["orbit", "--log-amplitude", "0", "--log-mass", "0", "--rolling", "2"], RANGE_TEXT),
        (["sweep", "--rolling", "x"], RANGE_TEXT),
        (["design", "--preset", "paper", "--rolling", "0"], RANGE_TEXT),
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err


def test_orbit_takes_rolling_and_says_the_vertical_orbit_is_the_same(capsys):
    """Rolling turns the particle, not its height (the normal contact does
    not see the tangential motion): the vertical orbit of a rolling scene is
    the non-rolling one's, number for number, and the output says why."""
    import json

    argv = [
        "orbit",
        "--log-amplitude",
        "0.3",
        "--log-mass",
        "0",
        "--tau",
        "5",
        "--periods",
        "200",
        "--fidelity",
        "preview",
        "--json",
    ]
    outs = {}
    for rolling in ("none", "shell"):
        assert main([*argv, "--rolling", rolling]) == 0
        outs[rolling] = json.loads(capsys.readouterr().out)
    none, shell = outs["none"], outs["shell"]
    assert shell.pop("rolling") == "shell" and none.pop("rolling") == "none"
    assert "same for every rolling" in shell.pop("rolling_note")
    assert "rolling_note" not in none
    assert shell == none


def test_sweep_names_a_rolling_store():
    from vibtrans.cli import _sweep_name

    assert _sweep_name("deformable", 0.3, "sphere") == "sweep-deformable-mu0.3.zarr"
    assert _sweep_name("deformable", 0.3, "sphere", "solid") == "sweep-deformable-mu0.3-rolling-solid.zarr"
    assert (
        _sweep_name("deformable", 0.5, "power:3", 0.25) == "sweep-deformable-mu0.5-power3-rolling-0.25.zarr"
    )


def test_bench_times_the_rolling_kernel_on_the_same_motion():
    # what `vibtrans bench`'s rolling ratio rests on: the rolling kernel, its
    # contact point at x* exactly, runs the plain kernel's steps and records
    from vibtrans.tools import bench

    c = bench.rolling_cost(1, points=(1,))["point 1"]
    assert c["same_motion_records_equal"] is True
    for key in ("same_motion_over_none", "solid_over_none", "shell_over_none"):
        assert math.isfinite(c[key]) and c[key] > 0, key
    assert set(c["ns_per_step"]) == {"none", "same_motion", "solid", "shell"}
