"""The chaos indicator: the vertical motion's largest Lyapunov exponent.

Sources: central finite differences of the kernel's own flow (the tangent
map), the independent DOP853 twin in tests/naive.py (the exponent), the
closed form det = 1 of an area-preserving flow (the tangent map of
m* y'' = 1 - N*(a*) has zero divergence), and the paper's regimes (regular
points 1-7, chaotic point 8).
"""

import json
import math
import subprocess
import sys

import naive
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vibtrans import Scene, paper_scene, simulate
from vibtrans.analysis.summary import CHAOS_LYAPUNOV, summarize, twin_scene
from vibtrans.core import drivers
from vibtrans.core.fidelity import time_step
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.substrate import vertical_displacement
from vibtrans.core.simulate import run_records
from vibtrans.core.threshold import threshold_amplitude


# ------------------------------------------------------------ the tangent map
def _flight_start(la, lm, t_s, t_end, y0, vy0, refine, direction=None):
    """The vertical kernel from a flight that starts at t_s at (y0, vy0) (a
    complete initial condition: the history is the flight's at landing) to
    t_end: ((y, y') at t_end, the tangent at t_end or None, the run)."""
    A, m = 10.0**la, 10.0**lm
    h = time_step(A, m, "standard", refine)
    p = D.kernel_params(A, m, 0.3, 1.2, 0.6, 50.0, h, t_end, 1e9)
    state, hist = D.rest_state()
    state[[D.S_T, D.S_T0, D.S_Y0, D.S_VY0, D.S_Y, D.S_VY]] = (t_s, t_s, y0, vy0, y0, vy0)
    tangent = None
    if direction is not None:
        tangent = np.zeros(D.NTANGENT)
        tangent[[D.L_FROM, D.L_START, D.L_END_T]] = (t_s, -1.0, -1.0)
        tangent[[D.L_DY0, D.L_DVY0]] = direction
        tangent[[D.L_DY, D.L_DVY]] = direction
    run = drivers.run_hertz(
        p,
        "ab4",
        tangential=False,
        samples_capacity=64,
        state=state,
        hist=hist,
        record_rest=False,
        tangent=tangent,
        in_flight=True,
    )
    if run.samples.shape[0] and run.samples[-1, R.T_] == t_end:  # ends in contact
        end = run.samples[-1, [R.Y, R.VY]]
    else:  # ends in a flight
        assert run.state[D.S_T] == t_end
        end = run.state[[D.S_Y, D.S_VY]]
    if tangent is None:
        return end, None, run
    t, dy, dvy = D.tangent_at_end(run.tangent, run.state)
    assert t == t_end
    return end, np.array([dy, dvy]), run


def _tangent_and_differences(la, lm, periods, refine, gap=0.3, eps=1e-6):
    """The tangent map over `periods` from a flight `gap` above the surface
    at t = 400.25 (after the ramp), and its central finite differences."""
    t_s = 400.25
    y0 = vertical_displacement(t_s, 10.0**la, 50.0) - gap
    tangent, differences = np.zeros((2, 2)), np.zeros((2, 2))
    for j, e in enumerate(np.eye(2)):
        _, tangent[:, j], run = _flight_start(la, lm, t_s, t_s + periods, y0, 0.0, refine, e)
        plus, _, _ = _flight_start(la, lm, t_s, t_s + periods, y0 + eps * e[0], eps * e[1], refine)
        minus, _, _ = _flight_start(la, lm, t_s, t_s + periods, y0 - eps * e[0], -eps * e[1], refine)
        differences[:, j] = (plus - minus) / (2.0 * eps)
    landings = int(np.sum(run.events[:, 1] == R.LANDING))
    return tangent, differences, landings


def _grazing_log_amplitude(lm):
    """Just above the jumping threshold: take-offs that barely leave."""
    return math.log10(1.02 * threshold_amplitude(10.0**lm, periods=200.0))


@pytest.mark.parametrize(
    "orbit,la,lm",
    [
        ("contact", -1.5, 0.0),  # lands, then stays in contact
        ("hopping", 0.5, -1.0),
        ("hopping, light", 1.0, -2.0),
        ("grazing", None, 0.5),
    ],
)
def test_tangent_map_is_the_flows_derivative(orbit, la, lm):
    """The tangent against central differences of the kernel's flow, over a
    step sweep: through landings, contact and take-offs it agrees to the
    step's accuracy and converges as the step shrinks; det = 1 (the flow is
    area preserving) to the same accuracy."""
    if la is None:
        la = _grazing_log_amplitude(lm)
    errors = []
    for refine in (1.0, 2.0, 4.0):
        tangent, differences, landings = _tangent_and_differences(la, lm, 5.1, refine)
        assert landings >= 1, f"{orbit}: no landing: the test would not cross a contact"
        errors.append(np.linalg.norm(tangent - differences) / np.linalg.norm(differences))
        assert abs(np.linalg.det(tangent) - 1.0) < 2e-3, (orbit, refine)
    assert errors[-1] < 2e-3, (orbit, errors)
    assert errors[-1] < errors[0], (orbit, errors)


def test_tangent_in_flight_is_exact():
    """A flight alone: dy(t) = dy0 + dy0' t, dy' = dy0' (closed form)."""
    tangent, differences, landings = _tangent_and_differences(-1.5, 0.0, 0.2, 1.0, gap=5.0)
    assert landings == 0
    np.testing.assert_allclose(tangent, [[1.0, 0.2], [0.0, 1.0]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(differences, tangent, rtol=0, atol=1e-7)


# ---------------------------------------------------------- the exponent itself
def _lyapunov(scene, **kw):
    ds = simulate(scene, lyapunov=True, **kw)
    return ds.attrs.get("lyapunov"), ds


@pytest.mark.parametrize("la,lm", [(1.7, -2.0), (0.5, -2.0), (1.0, -2.7), (-0.3, 1.0), (0.25, 0.8)])
@pytest.mark.parametrize("periods", [8.0, 16.0])
def test_exponent_against_the_independent_twin(la, lm, periods):
    """Short horizons, no ramp (tau = 0: measured from t = 0), where the two
    integrations still follow one orbit: at a fine step (refine 4) the
    kernel's finite-time exponent is the DOP853 twin's within 5%, chaotic
    or regular.  (At the standard step the chaotic ones differ by up to
    ~20%: the step's trajectory error, amplified; over long runs both are
    statistical estimates of the same exponent, test below.)"""
    scene = dict(model="vertical", amplitude=10.0**la, mass=10.0**lm, periods=periods, tau=0.0)
    value, ds = _lyapunov(Scene(**scene), refine=4.0)
    assert ds.attrs["lyapunov_from"] == 0.0
    twin = naive.vertical_lyapunov(10.0**la, 10.0**lm, 0.0, periods, 0.0)
    assert abs(value - twin) <= 0.05 * abs(twin) + 2e-5, (value, twin)


@pytest.mark.slow
def test_long_run_exponents_agree_with_the_twin_statistically():
    """2000 periods from the end of the ramp: different integrators follow
    different chaotic orbits after ~100 periods, so their exponents are two
    finite-time samples of one average, and near islands (sticky chaos)
    such samples scatter: both well above the threshold, within a factor 3
    (measured: 0.042 vs 0.081, 0.140 vs 0.098)."""
    for la, lm in ((1.7, -2.0), (0.5, -2.0)):
        value, ds = _lyapunov(paper_scene(8).replace(model="vertical", amplitude=10.0**la, mass=10.0**lm))
        twin = naive.vertical_lyapunov(10.0**la, 10.0**lm, 50.0, 2000.0, ds.attrs["lyapunov_from"])
        assert min(value, twin) > 3 * CHAOS_LYAPUNOV
        assert max(value, twin) / min(value, twin) < 3.0, (la, lm, value, twin)


def test_records_are_unchanged_and_the_exponent_is_the_vertical_motions():
    """Measuring the exponent changes no record bit.  The deformable run's
    exponent is the vertical-only run's, whatever mu (the vertical motion
    does not feel the tangential one), to rounding: the runs' kernel calls
    differ (a memory diagram that grows ends a call, which restarts the
    wave's sin/cos rotation), so on a regular orbit they agree to ~1e-8 and
    on a chaotic one (point 8) only in the verdict."""
    for k, integrator in ((2, "ab4"), (6, "verlet"), (8, "ab4")):
        scene = paper_scene(k).replace(periods=400.0, integrator=integrator)
        plain = simulate(scene, window=(390.0, 391.0))
        value, measured = _lyapunov(scene, window=(390.0, 391.0))
        for name in plain.variables:
            assert np.array_equal(plain[name].values, measured[name].values, equal_nan=True), (k, name)
        assert value == _lyapunov(scene)[0]  # the window records, nothing more
        others = [_lyapunov(scene.replace(model="vertical"))[0], _lyapunov(scene.replace(mu=1.0))[0]]
        if k == 8:
            assert min(value, *others) > CHAOS_LYAPUNOV
        else:
            np.testing.assert_allclose(others, value, rtol=1e-6, atol=1e-10)


@pytest.mark.slow
def test_paper_points_keep_their_regimes():
    """Regular points 1-7: |lambda| within 2 log(T') / T' (T' = the measured
    time; a regular orbit's tangent grows at most linearly) at two lengths;
    chaotic point 8: above the threshold at every length, converged within
    30% of the median (measured 0.051, 0.042, 0.040, 0.052 at 1000-8000)."""
    for k in range(1, 9):
        scene = paper_scene(k).replace(model="vertical")
        got = []
        for periods in (1000.0, 3000.0) if k <= 7 else (1000.0, 2000.0, 4000.0, 8000.0):
            value, ds = _lyapunov(scene.replace(periods=periods))
            measured = periods - ds.attrs["lyapunov_start"]
            got.append(value)
            if k <= 7:
                assert abs(value) <= 2 * math.log(measured) / measured, (k, periods, value)
                assert value < CHAOS_LYAPUNOV
            else:
                assert value > 2 * CHAOS_LYAPUNOV, (k, periods, value)
        if k == 8:
            assert np.all(np.abs(np.array(got) / np.median(got) - 1.0) < 0.3), got


def test_the_issue_example_is_chaotic_though_the_twin_agreed():
    """log10 A* = 0.5, log10 m* = -2: the twin's drift lands within the
    tolerance (twin_chaotic False) but its x* departs from the run's after
    ~92 periods; the exponent says chaotic, and the summary says why."""
    scene = paper_scene(1).replace(amplitude=10**0.5, mass=10**-2.0)
    value, ds = _lyapunov(scene)
    s = summarize(ds, simulate(twin_scene(scene)))
    assert value > 5 * CHAOS_LYAPUNOV
    assert s.chaotic is True and s.twin_chaotic is False and s.lyapunov == value
    assert s.pattern == "chaotic" and "Lyapunov exponent" in s.regime
    assert s.divergence_time < 200


def test_without_a_measurement_the_twin_decides():
    scene = paper_scene(8).replace(periods=300.0)
    ds = simulate(scene)
    assert "lyapunov" not in ds.attrs
    s = summarize(ds, simulate(twin_scene(scene)))
    assert s.lyapunov is None and s.chaotic == s.twin_chaotic


# --------------------------------------------------------- the material point
def _impacts(scene):
    ds = simulate(scene, lyapunov=True)
    t = ds["event_time"].values[ds["event_kind"].values == R.LANDING]
    return ds, t[t >= ds.attrs["lyapunov_from"]]


@pytest.mark.slow
def test_impact_map_jacobian_against_an_independent_bouncing_ball():
    """Paper point 10 (chaotic hopping): from each of its first impacts after
    the ramp, the independent scan-and-brentq flight of tests/naive.py lands
    where the kernel's event says (to 1e-12), and central differences of
    that flight equal lyapunov.impact_jacobian (to 1e-5)."""
    from vibtrans.core.lyapunov import impact_jacobian

    scene = paper_scene(10)
    _, t = _impacts(scene)
    A, m, tau = scene.amplitude, scene.mass, scene.tau
    for n in range(6):
        J, v0, approach = impact_jacobian(t[n], t[n + 1], A, m, tau)
        assert approach > 0.0
        t1, _ = naive.bouncing_ball_flight(t[n], v0, A, m, tau)
        assert abs(t1 - t[n + 1]) < 1e-12
        eps, fd = 1e-7, np.zeros((2, 2))
        for j, e in enumerate(np.eye(2)):
            p = naive.bouncing_ball_flight(t[n] + eps * e[0], v0 + eps * e[1], A, m, tau)
            q = naive.bouncing_ball_flight(t[n] - eps * e[0], v0 - eps * e[1], A, m, tau)
            fd[:, j] = (np.array(p) - np.array(q)) / (2 * eps)
        assert np.abs(J - fd).max() <= 1e-5 * np.abs(fd).max(), n


@pytest.mark.slow
def test_point_mass_exponent_is_the_impact_maps():
    """The exponent is the growth of the impact map's tangent over the
    run's impacts after the ramp: over its first 12 impacts, recomputed
    here with the naive flights' finite-difference Jacobians along the
    kernel's impacts; and paper point 10 is chaotic by it."""
    from vibtrans.core.lyapunov import impact_lyapunov

    scene = paper_scene(10)
    ds, t = _impacts(scene)
    assert ds.attrs["lyapunov"] > 2 * CHAOS_LYAPUNOV
    assert summarize(ds).chaotic is True
    t = t[:12]
    events = np.stack([ds["event_time"].values, ds["event_kind"].values, ds["event_value"].values], axis=1)
    value, start = impact_lyapunov(
        events[events[:, 0] <= t[-1]], scene.amplitude, scene.mass, scene.tau, ds.attrs["lyapunov_from"]
    )
    assert start == t[0]
    A, m, tau = scene.amplitude, scene.mass, scene.tau
    d, total = np.array([1.0, 0.0]), 0.0
    for t0, t1 in zip(t[:-1], t[1:]):
        v0 = (
            naive.surface(t1, A, 0.0, tau)[1] - naive.surface(t0, A, 0.0, tau)[1] - 0.5 * (t1 - t0) ** 2 / m
        ) / (t1 - t0)
        eps, fd = 1e-7, np.zeros((2, 2))
        for j, e in enumerate(np.eye(2)):
            p = naive.bouncing_ball_flight(t0 + eps * e[0], v0 + eps * e[1], A, m, tau)
            q = naive.bouncing_ball_flight(t0 - eps * e[0], v0 - eps * e[1], A, m, tau)
            fd[:, j] = (np.array(p) - np.array(q)) / (2 * eps)
        d = fd @ d
        total += math.log(np.linalg.norm(d))
        d /= np.linalg.norm(d)
    assert value == pytest.approx(total / (t[-1] - t[0]), rel=1e-4)


def test_point_mass_without_impacts_has_no_exponent():
    """Paper point 9: the point rides the surface throughout (no impacts):
    nothing to measure, and the twin decides as before."""
    ds = simulate(paper_scene(9).replace(periods=400.0), lyapunov=True)
    assert "lyapunov" not in ds.attrs


def test_a_capture_forgets_every_perturbation():
    """A landing without a take-off (the point rides the surface) after the
    ramp: the detachment's phase is the surface's alone, so the exponent
    is -inf (superstable), and the run is not chaotic."""
    from vibtrans.core.lyapunov import impact_lyapunov

    ev = np.array(
        [
            [400.0, R.LANDING, 0.0],
            [400.0, R.TAKEOFF, 0.0],
            [401.3, R.LANDING, 0.3],
            [401.9, R.TAKEOFF, 0.9],
            [403.1, R.LANDING, 0.1],
            [403.1, R.TAKEOFF, 0.1],
        ]
    )
    value, start = impact_lyapunov(ev, 1.0, 0.1, 50.0, 325.0)
    assert value == -math.inf and start == 400.0


@pytest.fixture(scope="module")
def hopping_events():
    """The events of the material point's chaotic hopping (paper point 10)."""
    scene = paper_scene(10).replace(periods=600.0)
    return scene, run_records(scene)[1]


@settings(max_examples=30, deadline=None, derandomize=True)
@given(cuts=st.lists(st.integers(0, 10**6), max_size=12), t_from=st.sampled_from([0.0, 180.0, 325.0]))
def test_the_exponent_grown_along_the_run_equals_the_whole_runs(hopping_events, cuts, t_from):
    """The `decided` rule reads the impact exponent at each check from the
    events so far (ImpactGrowth.update): at any chunking of the run, the
    last value equals the exponent of the whole run's events, bit for bit,
    and each value so far is the whole computation on that prefix (its
    last landing left for the next rows)."""
    from vibtrans.core.lyapunov import ImpactGrowth, impact_lyapunov

    scene, events = hopping_events
    growth = ImpactGrowth(scene.amplitude, scene.mass, scene.tau, t_from)
    for cut in sorted(c % (events.shape[0] + 1) for c in cuts):
        so_far = growth.update(events[:cut])
        prefix = events[:cut]
        if cut and prefix[-1, 1] == R.LANDING:
            prefix = prefix[:-1]  # its take-off not yet seen
        value, start = impact_lyapunov(prefix, scene.amplitude, scene.mass, scene.tau, t_from)
        if so_far is None:
            assert math.isnan(value)
        else:
            assert so_far[0] == start and so_far[1] / growth_span(growth) == value
    growth.update(events, final=True)
    assert growth.exponent() == impact_lyapunov(events, scene.amplitude, scene.mass, scene.tau, t_from)


def growth_span(growth):
    return growth.last - growth.first


def test_a_capture_seen_in_pieces_is_a_capture():
    from vibtrans.core.lyapunov import ImpactGrowth

    ev = np.array(
        [
            [400.0, R.LANDING, 0.0],
            [400.0, R.TAKEOFF, 0.0],
            [401.3, R.LANDING, 0.3],
            [401.9, R.TAKEOFF, 0.9],
            [403.1, R.LANDING, 0.1],
            [403.1, R.TAKEOFF, 0.1],
        ]
    )
    growth = ImpactGrowth(1.0, 0.1, 50.0, 325.0)
    assert growth.update(ev[:3]) is None  # the landing at 401.3 waits
    assert growth.update(ev[:4]) == (400.0, -math.inf)
    assert growth.update(ev) == (400.0, -math.inf)


def test_bad_flag_is_refused():
    with pytest.raises(Exception, match="lyapunov must be True or False"):
        simulate(paper_scene(1).replace(periods=10.0), lyapunov="yes")


def test_cli_reports_the_exponent_and_both_verdicts():
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "vibtrans.cli",
            "simulate",
            "--log-amplitude",
            "0.5",
            "--log-mass",
            "-2",
            "--periods",
            "600",
            "--twin",
            "always",
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    got = json.loads(out.stdout)
    assert got["lyapunov"] > CHAOS_LYAPUNOV and got["chaotic"] is True
    assert got["twin_chaotic"] in (True, False)
    assert "Lyapunov exponent" in got["regime"]


# ------------------------------------------------------------------ the sweeps
def test_sweeps_store_the_exponent_and_judge_chaos_by_it(tmp_path):
    """A transport sweep (chaos "lyapunov", the default) stores each point's
    exponent and its verdict, runs no twin (steps are the run's alone); a
    lyapunov sweep of the vertical model stores the same exponents; both
    verify, resume, and refuse a command of the other kind or source."""
    from vibtrans.core.errors import StoreMismatch
    from vibtrans.maps.sweep import Sweep, open_map, run_sweep

    la, lm = np.array([0.5, 1.7]), np.array([-2.0, 0.0])
    common = dict(periods=400.0, chunk_rows=1)
    transport = Sweep(la, lm, model="deformable", **common)
    lyapunov = Sweep(la, lm, kind="lyapunov", model="vertical", **common)
    paths = {name: str(tmp_path / f"{name}.zarr") for name in ("transport", "lyapunov")}
    run_sweep(transport, paths["transport"], workers=1, progress=False)
    run_sweep(lyapunov, paths["lyapunov"], workers=1, progress=False)
    t, v = open_map(paths["transport"]), open_map(paths["lyapunov"])
    assert t.attrs["chaos"] == "lyapunov" and v.attrs["kind"] == "lyapunov"
    for i in range(2):
        for j in range(2):
            scene = Scene(amplitude=10 ** la[i], mass=10 ** lm[j], periods=400.0)
            value, ds = _lyapunov(scene)
            assert t["lyapunov"].values[i, j] == value
            assert t["chaotic"].values[i, j] == int(value > CHAOS_LYAPUNOV)
            assert t["steps"].values[i, j] == ds.attrs["steps"]  # no twin
            np.testing.assert_allclose(
                v["lyapunov"].values[i, j], value, rtol=1e-6
            ) if value < CHAOS_LYAPUNOV else None
    assert (t["chaotic"].values == (v["lyapunov"].values > CHAOS_LYAPUNOV)).all()
    run_sweep(transport, paths["transport"], workers=1, progress=False)  # all done: resumes
    with pytest.raises(StoreMismatch, match="chaos: store lyapunov, command twin"):
        run_sweep(
            Sweep(la, lm, model="deformable", chaos="twin", **common),
            paths["transport"],
            workers=1,
            progress=False,
        )
    with pytest.raises(StoreMismatch, match="kind: store lyapunov, command transport"):
        run_sweep(Sweep(la, lm, model="vertical", **common), paths["lyapunov"], workers=1, progress=False)


def test_a_lyapunov_sweep_needs_the_vertical_model():
    from vibtrans.core.errors import InputError
    from vibtrans.maps.sweep import Sweep

    with pytest.raises(InputError, match="vertical model"):
        Sweep(np.array([0.0]), np.array([0.0]), kind="lyapunov", model="deformable")
    Sweep(np.array([0.0]), np.array([0.0]), kind="lyapunov", model="point-mass")
    with pytest.raises(InputError, match="chaos must be one of lyapunov, twin"):
        Sweep(np.array([0.0]), np.array([0.0]), chaos="eyeball")
