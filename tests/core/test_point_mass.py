"""Tests for vibtrans.core.kernels.point_mass: the material point on a rigid substrate.

Sources: docs/MODEL.md sections 1, 3, 6 (the contract), and the paper's section
"Dynamics of a material point" (Terzi et al., eqs. sticking_sliding_condition,
sliding_jumping_condition; points 9 and 10).
"""

import itertools
import math
import time

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from vibtrans.core import drivers
from vibtrans.core.kernels import point_mass as pm
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import FLIGHT, SLIDING, STICK
from vibtrans.core.kernels.substrate import surface_motion

MU, R_NU, THETA = 0.3, 0.656, 1.2
P9 = (10**2.7, 10**-4.4)  # docs/MODEL.md section 6, point 9
P10 = (10**1.2, 10**-1.0)  # docs/MODEL.md section 6, point 10


def run_point_mass(
    A,
    m,
    mu=MU,
    theta=THETA,
    r=R_NU,
    tau=50.0,
    periods=2000.0,
    alpha_t=0.5,
    stick_rule=0,
    samples_per_period=8,
    scan_dt=1.0 / 64.0,
    window=(math.inf, math.inf),
    capture_t=None,
):
    """The material point from rest through the production driver
    (vibtrans.core.drivers.run_point_mass): (samples, events, counters, final
    state t, x, vx, y, vy).  samples_per_period = 0: no coarse samples;
    `window` = (t0, t1): every scan step and both sides of every event
    inside it; capture_t overrides point_mass.CAPTURE_T."""
    sample_dt = 1.0 / samples_per_period if samples_per_period > 0 else math.inf
    params = pm.make_params(
        A, m, mu, theta, r, tau, float(periods), alpha_t, sample_dt, window, scan_dt, capture_t
    )
    run = drivers.run_point_mass(params, stick_rule)
    return run.samples, run.events, run.ctr, run.state


def sliding_line(A, mu=MU, r=R_NU):
    # Paper eq. (sticking_sliding_condition), docs/MODEL.md section 3.
    return mu / math.sqrt(mu * mu + r * r) / (4 * math.pi**2 * A)


def jumping_line(A):
    # Paper eq. (sliding_jumping_condition), docs/MODEL.md section 3.
    return 1.0 / (4 * math.pi**2 * A)


def state_changes(events, code):
    return events[(events[:, 1] == R.STATE_CHANGE) & (events[:, 2] == code)]


def takeoffs(events):
    return events[events[:, 1] == R.TAKEOFF]


def assert_finite(*arrays):
    for a in arrays:
        assert np.isfinite(a).all()


@pytest.fixture(scope="module")
def point9():
    out = {}
    for rule in ("paper", "classical"):
        t0 = time.perf_counter()
        out[rule] = run_point_mass(*P9, stick_rule=rule)
        out[rule + "_time"] = time.perf_counter() - t0
    return out


@pytest.fixture(scope="module")
def point10():
    window = (300.0, 420.0)
    t0 = time.perf_counter()
    a = run_point_mass(*P10, tau=50.0, window=window)
    elapsed = time.perf_counter() - t0
    b = run_point_mass(*P10, tau=50.001, window=window)
    return a, b, window, elapsed


# --------------------------------------------------------------------------- regimes
def test_sticks_forever_below_sliding_line():
    # docs/MODEL.md section 3: below m* = mu/sqrt(mu^2+r^2)/(4 pi^2 A*) the point
    # never slides; then x - u_x stays at its initial value 0.
    for A in (10.0, 10**2.7):
        m = 0.9 * sliding_line(A)
        s, e, ctr, st = run_point_mass(A, m, tau=5.0, periods=300.0)
        assert_finite(s, e, st)
        assert len(e) == 1 and e[0, 1] == R.STATE_CHANGE and e[0, 2] == STICK
        assert np.all(s[:, R.STATE] == STICK)
        assert np.all(s[:, R.A] == 0.0)
        assert np.max(np.abs(s[:, R.B])) * THETA * MU <= 1e-9 * A
        assert ctr[R.C_MODE] == pm.MODE_STICK


def test_slides_between_lines_without_jumping():
    # docs/MODEL.md section 3: between the two analytic lines the point slides in
    # every period (stationary excitation) but never leaves the surface.
    A = 10.0
    m = math.sqrt(sliding_line(A) * jumping_line(A))
    s, e, _, st = run_point_mass(A, m, tau=5.0, periods=200.0)
    assert_finite(s, e, st)
    assert len(takeoffs(e)) == 0
    slides = state_changes(e, SLIDING)[:, 0]
    after = slides[slides > 6.5 * 5.0]  # ramp is exactly 1 after 6.5 tau
    assert len(np.unique(np.floor(after))) >= int(200 - 6.5 * 5.0) - 1
    assert np.all(s[:, R.A] == 0.0) and np.all(s[:, R.STATE] != FLIGHT)


def _threshold(pred, lo, hi, n=12):
    for _ in range(n):
        mid = math.sqrt(lo * hi)
        if pred(mid):
            hi = mid
        else:
            lo = mid
    return math.sqrt(lo * hi)


def test_numerical_boundaries_match_analytic_lines():
    # Paper: "The numerical results for these curves are in accordance with
    # their analytical definitions" (eqs. sticking_sliding_condition and
    # sliding_jumping_condition); here within 2 % at A* = 10.
    A = 10.0

    def run(m):
        return run_point_mass(A, m, tau=5.0, periods=100.0, samples_per_period=0)[1]

    m_s = _threshold(
        lambda m: len(state_changes(run(m), SLIDING)) > 0, sliding_line(A) / 1.5, sliding_line(A) * 1.5
    )
    m_j = _threshold(lambda m: len(takeoffs(run(m))) > 0, jumping_line(A) / 1.5, jumping_line(A) * 1.5)
    err_s = m_s / sliding_line(A) - 1
    err_j = m_j / jumping_line(A) - 1
    print(f"boundary errors: sliding {err_s:+.2e}, jumping {err_j:+.2e}")
    assert abs(err_s) < 0.02 and abs(err_j) < 0.02


# --------------------------------------------------------------------------- paper points
def test_point9_paper_rule_symmetric_sliding_no_drift(point9):
    # Paper point 9 / docs/MODEL.md section 6: continuous symmetric sliding, no
    # drift, with the paper's slide -> stick rule (docs/MODEL.md section 3).
    s, e, ctr, st = point9["paper"]
    assert_finite(s, e, st)
    assert st[0] == 2000.0
    assert len(takeoffs(e)) == 0 and np.all(s[:, R.STATE] != FLIGHT)
    slides = state_changes(e, SLIDING)[:, 0]
    periods = np.unique(np.floor(slides[slides >= 400.0]))
    assert len(periods) == 1600  # slides in every period
    drift = st[1] / st[0]
    print(f"point 9, paper rule: <v*> = {drift:+.4f}, {point9['paper_time'] * 1e3:.1f} ms")
    assert abs(drift) <= 0.1


def test_point9_classical_rule_drifts_with_the_wave(point9):
    # docs/MODEL.md section 3: with the classical rule (stick only at v_rel = 0)
    # point 9 drifts strongly "with the wave" (+x, docs/MODEL.md section 1 sign).
    s, e, ctr, st = point9["classical"]
    assert_finite(s, e, st)
    assert len(takeoffs(e)) == 0
    drift = st[1] / st[0]
    print(f"point 9, classical rule: <v*> = {drift:+.2f}, {point9['classical_time'] * 1e3:.1f} ms")
    assert drift > 1.0


def test_point10_chaotic_jumping(point10):
    # Paper point 10 / fig. chaos_MP: jumping, and tau = 50 vs 50.001 give
    # completely different trajectories.
    (s1, e1, c1, st1), (s2, e2, c2, st2), _, elapsed = point10
    assert_finite(s1, e1, st1, s2, e2, st2)
    assert len(takeoffs(e1)) > 20 and len(takeoffs(e2)) > 20
    coarse1 = s1[np.mod(s1[:, R.T_], 0.125) == 0]  # drop the window's extra rows
    coarse2 = s2[np.mod(s2[:, R.T_], 0.125) == 0]
    t = coarse1[:, R.T_]
    assert np.array_equal(t, coarse2[:, R.T_]) and len(t) == 16001
    dx = np.abs(coarse1[:, R.X] - coarse2[:, R.X])
    assert dx[t <= 10.0].max() < 0.1 * P10[0]  # same start ...
    assert dx[t >= 300.0].max() > 100.0 * P10[0]  # ... diverged after hundreds of periods
    print(
        f"point 10: <v*> = {st1[1] / st1[0]:+.2f} (tau 50), {st2[1] / st2[0]:+.2f} "
        f"(tau 50.001), {elapsed * 1e3:.1f} ms"
    )


# --------------------------------------------------------------------------- exactness
def _rows_at(samples, t):
    return samples[samples[:, R.T_] == t]


def test_flight_is_an_exact_parabola(point10):
    # Free flight: x'' = 0, m y'' = 1 (docs/MODEL.md section 1 with N* = T* = 0).
    (s, e, _, _), _, (w0, w1), _ = point10
    m = P10[1]
    offs = takeoffs(e)[:, 0]
    lands = e[e[:, 1] == R.LANDING][:, 0]
    checked = 0
    for t0 in offs[(offs > w0) & (offs < w1)]:
        nxt = lands[lands > t0]
        t1 = nxt[0] if len(nxt) else np.inf
        r0 = _rows_at(s, t0)[-1]  # post-takeoff row
        inside = s[(s[:, R.T_] > t0) & (s[:, R.T_] < min(t1, w1))]
        dt = inside[:, R.T_] - t0
        y = r0[R.Y] + r0[R.VY] * dt + dt**2 / (2 * m)
        scale = 1.0 + np.abs(inside[:, R.Y]).max()
        np.testing.assert_allclose(
            inside[:, R.X], r0[R.X] + r0[R.VX] * dt, rtol=0, atol=1e-11 * (1 + np.abs(inside[:, R.X]).max())
        )
        np.testing.assert_allclose(inside[:, R.VX], r0[R.VX], rtol=1e-14)
        np.testing.assert_allclose(inside[:, R.Y], y, rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(inside[:, R.VY], r0[R.VY] + dt / m, rtol=1e-12)
        assert np.all(inside[:, R.A] < 0) and np.all(inside[:, R.N] == 0)
        checked += len(inside)
    assert checked > 100


def test_rebound_is_elastic_with_tangential_restitution(point10):
    # docs/MODEL.md section 3, event 1: alpha_n = 1 (relative normal velocity
    # reversed), tangential relative velocity multiplied by alpha_t = 0.5.
    (s, e, _, _), _, (w0, w1), _ = point10
    A = P10[0]
    lands = e[(e[:, 1] == R.LANDING) & (e[:, 0] >= w0) & (e[:, 0] <= w1)][:, 0]
    assert len(lands) >= 2
    for t in lands:
        pre, post = _rows_at(s, t)
        _, uy, dux, duy = surface_motion(t, A, R_NU, 50.0)
        assert abs(pre[R.A]) < 1e-9 * A and post[R.A] == 0.0
        vn_in, vn_out = pre[R.VY] - duy, post[R.VY] - duy
        assert vn_in > 0
        assert vn_out == pytest.approx(-vn_in, rel=1e-12, abs=1e-12 * A)
        assert post[R.VX] - dux == pytest.approx(0.5 * (pre[R.VX] - dux), rel=1e-12, abs=1e-12 * A)
        assert t in takeoffs(e)[:, 0]  # LANDING then TAKEOFF at once


def _surface(t, A, r, tau):
    # Independent re-derivation of the ramped Rayleigh motion (docs/MODEL.md section 1).
    q = t / tau
    ex = math.exp(-q * q)
    G, G1, G2 = 1 - ex, 2 * t / tau**2 * ex, (2 / tau**2 - 4 * t * t / tau**4) * ex
    w = 2 * math.pi
    c, s = math.cos(w * t), math.sin(w * t)
    return (
        G * A * r * s,
        G * A * c,
        A * r * (G1 * s + w * G * c),
        A * (G1 * c - w * G * s),
        A * r * (G2 * s + 2 * w * G1 * c - w * w * G * s),
        A * (G2 * c - 2 * w * G1 * s - w * w * G * c),
    )


def _reference(A, m, rule, tau, T, mu=MU, r=R_NU, alpha_t=0.5):
    """Event-driven numerical integration with scipy's DOP853 (no closed forms)."""

    def N(t):
        return 1 - m * _surface(t, A, r, tau)[5]

    def f(t):
        return mu * N(t) - m * abs(_surface(t, A, r, tau)[4])

    def ev(fun, direction):
        fun.terminal, fun.direction = True, direction
        return fun

    kw = dict(max_step=1 / 256, rtol=1e-12, atol=1e-12, method="DOP853")
    t, x, vx = 0.0, 0.0, 0.0
    y, vy = _surface(0.0, A, r, tau)[1], 0.0
    mode, s, kinds = "stick", 0, []
    while t < T:
        if mode == "stick":
            c = x - _surface(t, A, r, tau)[0]
            sol = solve_ivp(
                lambda tt, z: [0.0],
                (t, T),
                [0.0],
                **kw,
                events=[ev(lambda tt, z: f(tt), -1), ev(lambda tt, z: N(tt), -1)],
            )
            t = sol.t[-1]
            ux, uy, dux, duy, ax, _ = _surface(t, A, r, tau)
            x, vx, y, vy = c + ux, dux, uy, duy
            if sol.status == 1:
                if len(sol.t_events[1]):
                    mode = "flight"
                    kinds.append("takeoff")
                else:
                    mode, s = "slide", (-1 if ax > 0 else 1)
                    kinds.append("slide")
        elif mode == "slide":
            evs = [ev(lambda tt, z: s * (z[1] - _surface(tt, A, r, tau)[2]), -1), ev(lambda tt, z: N(tt), -1)]
            if rule == "paper":
                evs.append(ev(lambda tt, z: f(tt), 1))
            sol = solve_ivp(lambda tt, z: [z[1], -mu * s * N(tt) / m], (t, T), [x, vx], events=evs, **kw)
            t = sol.t[-1]
            x, vx = sol.y[:, -1]
            _, y, dux, vy, ax, _ = _surface(t, A, r, tau)
            if sol.status == 1:
                k = int(np.argmin([te[0] if len(te) else np.inf for te in sol.t_events]))
                if k == 1:
                    mode = "flight"
                    kinds.append("takeoff")
                elif k == 2 or f(t) >= 0:
                    vx, mode = dux, "stick"
                    kinds.append("stick")
                else:
                    vx, s = dux, (-1 if ax > 0 else 1)
        else:
            sol = solve_ivp(
                lambda tt, z: [z[1], 0.0, z[3], 1 / m],
                (t, T),
                [x, vx, y, vy],
                events=[ev(lambda tt, z: z[2] - _surface(tt, A, r, tau)[1], 1)],
                **kw,
            )
            t = sol.t[-1]
            x, vx, y, vy = sol.y[:, -1]
            if sol.status == 1:
                _, y, dux, duy, _, _ = _surface(t, A, r, tau)
                vx, vy = dux + alpha_t * (vx - dux), duy - abs(vy - duy)
                kinds.append("landing")
    return np.array([t, x, vx, y, vy]), kinds


@pytest.mark.parametrize(
    "A,m,rule,tau,T",
    [
        (10.0, 1.5e-3, "paper", 2.0, 12.0),
        (10.0, 1.5e-3, "classical", 2.0, 12.0),
        (P9[0], P9[1], "classical", 3.0, 8.0),
        (P10[0], P10[1], "paper", 5.0, 30.0),
    ],
)
def test_closed_forms_match_numerical_integration(A, m, rule, tau, T):
    # The closed forms and event logic against an independent DOP853
    # integration of docs/MODEL.md section 3's equations with the same rules.
    ref, kinds = _reference(A, m, rule, tau, T)
    s, e, _, st = run_point_mass(A, m, tau=tau, periods=T, stick_rule=rule)
    assert ref[0] == T and e[0, 1] == R.STATE_CHANGE and e[0, 2] == STICK
    # the kernel writes LANDING + TAKEOFF for a rebound (the reference: landing)
    # and STATE_CHANGE(flight) after a detachment's TAKEOFF
    names = {STICK: "stick", SLIDING: "slide"}
    mine = []
    for i, (_t, k, v) in enumerate(e[1:], start=1):
        if k == R.LANDING:
            mine.append("landing")
        elif k == R.TAKEOFF and e[i - 1, 1] != R.LANDING:
            mine.append("takeoff")
        elif k == R.STATE_CHANGE and v != FLIGHT:
            mine.append(names[int(v)])
    assert mine == kinds
    scale = np.abs(ref).max()
    np.testing.assert_allclose(st, ref, rtol=0, atol=1e-7 * scale)


def test_no_landing_hidden_between_scan_points():
    # The landing search proves that no landing-and-exit hides inside a scan
    # step: coarse scans (1/8) and fine scans (1/1024) see the same events.
    kw = dict(periods=100.0, samples_per_period=0)
    fine = run_point_mass(*P10, scan_dt=1 / 1024, **kw)[1]
    coarse = run_point_mass(*P10, scan_dt=1 / 8, **kw)[1]
    assert np.array_equal(coarse[:, 1], fine[:, 1])
    # rounding differences grow chaotically, but stay small over 100 periods
    assert np.abs(coarse[:, 0] - fine[:, 0]).max() < 1e-3


# --------------------------------------------------------------------------- restarts
def _chunked(A, m, stops, rule, window, grow=3, periods=None):
    params = pm.make_params(A, m, t_end=periods, sample_dt=0.125, window=window)
    state = np.zeros(5)
    work = pm.new_work()
    ctr = R.new_counters()
    samples = np.empty((1, R.NCOL))
    events = np.empty((1, 3))
    returns = {R.SAMPLES_FULL: 0, R.EVENTS_FULL: 0}
    for t_stop in stops:
        while True:
            code = pm.point_mass_kernel(params, rule, state, work, samples, events, ctr, t_stop)
            if code == R.DONE:
                break
            returns[code] += 1
            if code == R.SAMPLES_FULL:
                new = np.empty((samples.shape[0] + grow, R.NCOL))
                new[: ctr[R.C_NSAMP]] = samples[: ctr[R.C_NSAMP]]
                samples = new
            else:
                new = np.empty((events.shape[0] + grow, 3))
                new[: ctr[R.C_NEVT]] = events[: ctr[R.C_NEVT]]
                events = new
    return samples[: ctr[R.C_NSAMP]], events[: ctr[R.C_NEVT]], ctr, state, returns


@pytest.mark.parametrize("point,rule", [(P10, 0), (P9, 1)])
def test_chunked_runs_are_bit_identical(point, rule):
    # Restartability contract (records.py): stopping at t_stop or at a full
    # buffer and resuming gives exactly the single-run result.
    window = (100.0, 104.0)
    T = 300.0
    one = run_point_mass(*point, periods=T, stick_rule=rule, window=window)
    many = _chunked(
        *point, stops=[0.0, 7.0, 50.0, 100.5, 102.25, 211.0, T], rule=rule, window=window, periods=T
    )
    assert many[4][R.SAMPLES_FULL] > 100 and many[4][R.EVENTS_FULL] > 10
    for a, b in zip(one, many[:4]):
        assert np.array_equal(a, b)


# --------------------------------------------------------------------------- robustness
def test_corners_finish_finite():
    # Domain corners (docs/MODEL.md section 1: log10 A* in [-3, 3], log10 m* in
    # [-5, 5], mu in [0.01, 1]): full 2000-period runs, finite everything.
    for A, m, mu in itertools.product((1e-3, 1e3), (1e-5, 1e5), (0.01, 1.0)):
        t0 = time.perf_counter()
        s, e, ctr, st = run_point_mass(A, m, mu=mu)
        dt = time.perf_counter() - t0
        assert_finite(s, e, st)
        assert st[0] == 2000.0 and len(s) == 16001
        assert np.all(s[:, R.A] <= 1e-9 * (1 + A))  # never below the surface
        print(
            f"A*={A:g} m*={m:g} mu={mu:g}: {dt * 1e3:.1f} ms, <v*>={st[1] / 2000:+.3g}, "
            f"steps={ctr[R.C_STEPS]}, events={len(e)}"
        )


def test_chatter_near_jumping_line_is_bounded():
    # Just above the jumping line the elastic point lands almost tangentially
    # and would bounce forever with shrinking flights; the chatter capture
    # (CAPTURE_T) turns that into contact and keeps the event count bounded.
    A = 10.0
    for factor in (1.0001, 1.001, 1.003, 1.01):
        s, e, ctr, st = run_point_mass(A, factor * jumping_line(A), tau=5.0, periods=200.0)
        assert_finite(s, e, st)
        assert len(takeoffs(e)) > 0
        assert len(e) < 200 * 1000
        assert np.all(s[:, R.A] <= 1e-9 * A)
        # a coarser capture (capture_t) is accepted and bounded too
        s2, e2, _, st2 = run_point_mass(A, factor * jumping_line(A), tau=5.0, periods=200.0, capture_t=1e-2)
        assert_finite(s2, e2, st2)
        assert len(e2) < 200 * 100


def test_stick_rule_names():
    assert pm.rule_code("paper") == pm.RULE_PAPER == 0
    assert pm.rule_code("Classical") == pm.RULE_CLASSICAL == 1
    assert pm.rule_code(1) == 1
    for bad in ("sticky", 2, -1, 0.5):
        with pytest.raises(ValueError):
            pm.rule_code(bad)


def test_make_params_names_every_field_as_a_float():
    # all floats: one kernel signature whatever the caller passes (ints here)
    p = pm.make_params(1, 2, window=(3, 4), scan_dt=0.5)
    assert isinstance(p, pm.PointMassParams)
    assert all(type(v) is float for v in p)
    assert (p.amplitude, p.mass, p.win_t0, p.win_t1, p.scan_dt) == (1.0, 2.0, 3.0, 4.0, 0.5)
    assert p.capture_t == pm.CAPTURE_T
    assert pm.make_params(1, 2, capture_t=1e-2).capture_t == 1e-2
