"""Edge midpoints of the map, fidelity agreement there, energy at the mass
extremes, and the step budget's refusal (test_map_corners.py has the corners).

Map (docs/MODEL.md section 1): log10 A* in [-3, 3], log10 m* in [-5, 5], mu in
[0.01, 1], theta in [1.0555, 1.3333], nu in [0.1, 0.4], tau in [0, 500].
An edge midpoint puts one parameter at its min or max and every other one at
the middle of its range (A* = 1, m* = 1, mu = 0.505, theta = 1.1944,
nu = 0.25, tau = 50); a few pairs of extremes are added where they matter
physically (tau = 0 with A* = 1e3 or m* = 1e-5: the wave is on at t = 0 with
no ramp; tau = 500 with 2000 periods: the ramp's exp() runs to the end, never
reaching RAMP_OFF = 6.5 tau; nu = 0.1 / 0.4 with A* = 1e3, m* = 1e-5: the
stiffest violent scene at both Rayleigh ratios).

Cost, measured on 2 shared cores with the numba cache present: each scene
(standard + tau twin + reference) takes < 0.4 s; the whole file 5.7 s of CPU,
7-15 s wall (load average 3-4 from other jobs).

Measured (200 periods unless said; 100 for the nu pairs, 2000 for tau500-P2000):
* standard vs reference drift, non-chaotic scenes, error relative to
  max(|v_ref|, v0 = 0.1): deformable <= 1.0e-4 (mu = 1), point mass
  <= 1.1e-12 (A* = 1e3); one case misses STATED_DRIFT_ERROR['standard'] = 5e-3 and is
  xfail(strict) with the measured reason (see XFAIL_DRIFT below).  Two more
  (nu = 0.1 and 0.4 at A* = 1e3, m* = 1e-5: errors 3.5e-2 and 2.8e-2) missed it
  because the Hertz kernel's last sample fell up to a step after T_obs, where
  x* follows u_x* at 2 pi A* r per period; the kernel now records the run's end
  at T_obs exactly (Hermite within the last step) and both pass.
* free Hertz oscillator energy: m* = 1e5 at rounding level (<= 1e-10);
  m* = 1e-5 (standard step = 40 steps per oscillation) AB4 loses the whole
  oscillation energy over 1e4 oscillations, and with flights both integrators
  lose 11-15%: xfail(strict) against the existing bounds, with passing tests
  of what does hold there (dissipative, convergent at the method's order).
"""

import functools
import importlib
import math
import time
import warnings

import numpy as np
import pytest
from kernel_harness import hertz_energy

from vibtrans.analysis.summary import V0, chaos_verdict, drift_velocity, summarize
from vibtrans.core.drivers import grow
from vibtrans.core.fidelity import STATED_DRIFT_ERROR, time_step
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import STICK
from vibtrans.core.kernels.dispatch import kernel_for
from vibtrans.core.kernels.integrators import INTEGRATORS
from vibtrans.core.params import Scene
from vibtrans.core.simulate import DEFAULT_MAX_STEPS, StepBudgetExceeded, estimate_steps, simulate

# the module itself: `vibtrans.core.simulate` as an attribute is the function
S = importlib.import_module("vibtrans.core.simulate")

STATES = {0, 1, 2, 3}
MID = dict(amplitude=1.0, mass=1.0, mu=0.505, theta=1.1944, nu=0.25, tau=50.0)
EDGES = dict(
    amplitude=(1e-3, 1e3),
    mass=(1e-5, 1e5),
    mu=(0.01, 1.0),
    theta=(1.0555, 1.3333),
    nu=(0.1, 0.4),
    tau=(0.0, 500.0),
)
PERIODS = 200.0

# id -> (overrides of MID, periods)
SCENES = {f"{k}={v:g}": ({k: v}, PERIODS) for k, pair in EDGES.items() for v in pair}
SCENES.update(
    {
        "tau0-A1e3": ({"tau": 0.0, "amplitude": 1e3}, PERIODS),
        "tau0-m1e-5": ({"tau": 0.0, "mass": 1e-5}, PERIODS),
        "tau500-P2000": ({"tau": 500.0}, 2000.0),
        # the stiffest scenes (8.2e5 standard / 6.6e6 reference steps): kept short
        "nu0.1-A1e3-m1e-5": ({"nu": 0.1, "amplitude": 1e3, "mass": 1e-5}, 100.0),
        "nu0.4-A1e3-m1e-5": ({"nu": 0.4, "amplitude": 1e3, "mass": 1e-5}, 100.0),
    }
)
MODELS = ("deformable", "point-mass")
CASES = [(model, sid) for model in MODELS for sid in SCENES]


def scene(model, sid, **changes):
    values, periods = SCENES[sid]
    return Scene(model=model, periods=periods, **{**MID, **values, **changes})


@functools.cache
def run(model, sid, fidelity="standard", twin=False):
    """Simulate (and summarize) with every warning an error; cached, so the
    sanity and the fidelity tests share the standard runs."""
    sc = scene(model, sid, fidelity=fidelity)
    if twin:
        sc = sc.replace(tau=sc.tau + 1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = simulate(sc)
        summary = summarize(ds)
    return ds, summary


# ------------------------------------------------------------------ 1. sanity
@pytest.mark.parametrize("model, sid", CASES, ids=[f"{m}-{s}" for m, s in CASES])
def test_edge_midpoint_is_finite_and_physical(model, sid):
    # Source: closed forms of the model's laws (Hertz N* >= 0, Coulomb
    # |T*| <= N*, the rigid jumping criterion) and of the run's definition
    # (T_obs, state codes); no warning anywhere (warnings are errors).
    ds, s = run(model, sid)
    sc = scene(model, sid)
    # finite everything, time increasing and ending at T_obs (within a step)
    for name in list(ds.data_vars) + ["time"]:
        assert np.isfinite(ds[name].values).all(), f"{name} has non-finite values"
    t = ds["time"].values
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    assert sc.periods - 1e-9 <= t[-1] <= sc.periods + ds.attrs["h"] + 1e-9, t[-1]
    for key in ("drift_velocity", "final_drift_velocity", "takeoffs_per_period", "contact_fraction"):
        assert math.isfinite(getattr(s, key)), key
    assert 0.0 <= s.contact_fraction <= 1.0
    assert (s.takeoffs > 0) == (s.contact == "jumping")

    # Coulomb and Hertz (closed-form laws of the model): N* >= 0, |T*| <= N*
    # (T* is in units of mu N(a0)); N* = T* = 0 in flight.  Measured: |T*| - N*
    # <= 0 exactly at every edge (N* up to 4e4 at tau = 0, A* = 1e3).
    N, T, state = ds["N"].values, ds["T"].values, ds["state"].values
    assert N.min() >= 0.0
    assert np.all(np.abs(T) <= N * (1 + 1e-12) + 1e-9), float(np.max(np.abs(T) - N))
    assert set(np.unique(state).tolist()) <= STATES
    assert np.all(N[state == 0] == 0.0) and np.all(T[state == 0] == 0.0)
    kinds = ds["event_kind"].values
    assert set(np.unique(kinds).tolist()) <= {R.TAKEOFF, R.LANDING, R.STATE_CHANGE}
    assert set(np.unique(ds["event_value"].values[kinds == R.STATE_CHANGE]).tolist()) <= STATES
    assert np.all(np.diff(ds["event_time"].values) >= 0)

    # friction pulls towards the substrate's velocity, peak 2 pi A* r (+ the
    # ramp's G' A* r): the bound test_extremes uses.  Measured max ratio 1.0068
    # (deformable, tau = 0, m* = 1e-5: the sudden start's tangential transient).
    vmax = 2 * math.pi * sc.amplitude * sc.r
    assert np.abs(ds["vx"].values).max() <= 1.05 * vmax + 1e-9

    if model == "deformable":
        srad, crad = ds["stick_radius"].values, ds["contact_radius"].values
        assert np.all(srad >= 0) and np.all(srad <= crad + 1e-12)
        assert np.all(crad[state == 0] == 0)
        if sid == "amplitude=0.001":
            # closed form: the substrate moves 1e-3 a0, a* = 1 +- 1e-3, no take-off
            assert s.contact == "permanent" and np.abs(N - 1.0).max() < 0.01
    else:
        # closed form (docs/MODEL.md section 3): a rigid contact loses N* > 0 iff
        # m* |u_y''| > 1, |u_y''| ~ 4 pi^2 A* G(t); G's largest value is at T_obs.
        g_end = 1.0 if sc.tau == 0 else 1.0 - math.exp(-((sc.periods / sc.tau) ** 2))
        jumps = 4 * math.pi**2 * sc.mass * sc.amplitude * g_end > 1.0
        assert s.contact == ("jumping" if jumps else "permanent"), s


# ------------------------------------------------------------------ 2. fidelities
# Cases measured to miss the stated error; each keeps its own measured reason.
XFAIL_DRIFT = {
    ("point-mass", "tau=500"): (
        "chaos the twin verdict cannot see: standard v*=-0.0311, twin -0.0332 (both "
        "inside the no-drift band |v*| < v0, so chaos_verdict's tolerance 0.1|v*| + v0 "
        "says 'not chaotic'), yet divergence_time(twin) = 122.9 and (reference) = 122.6 "
        "periods < T_obs = 200: reference v*=+0.0189, error 0.50 of the floor 0.1 "
        "(stated 5e-3)"
    ),
}
FIDELITY_CASES = [
    pytest.param(
        m,
        s,
        id=f"{m}-{s}",
        marks=[pytest.mark.xfail(strict=True, raises=AssertionError, reason=XFAIL_DRIFT[m, s])]
        if (m, s) in XFAIL_DRIFT
        else [],
    )
    for m, s in CASES
]


# Chaotic by the tau + 1e-3 twin (measured at 200 periods, standard
# fidelity; v* and the twin's): the material point hops chaotically at A* =
# m* = 1 whatever mu and theta, so every point-mass edge that keeps that
# scene is here.  These, and only these, are skipped; every other case must
# be judged regular (so a chaos verdict broken either way fails).
KNOWN_CHAOTIC = {
    ("point-mass", "mu=0.01"): "v* -0.787, twin +1.228",
    ("point-mass", "mu=1"): "v* -0.789, twin +1.227",
    ("point-mass", "theta=1.0555"): "v* -0.789, twin +1.227",
    ("point-mass", "theta=1.3333"): "v* -0.789, twin +1.227",
    ("point-mass", "nu=0.1"): "v* -0.866, twin +1.348",
    ("point-mass", "nu=0.4"): "v* -0.697, twin +1.085",
    ("point-mass", "tau=0"): "v* +0.397, twin +0.963",
    ("point-mass", "tau0-A1e3"): "v* +2156, twin +0.067 (tau = 0: starts stuck to a surface "
    "moving at 2 pi A* r; tau > 0: at rest)",
    ("point-mass", "tau500-P2000"): "v* +0.091, twin -0.405",
}


@pytest.mark.parametrize("model, sid", FIDELITY_CASES)
def test_standard_agrees_with_reference_at_edge_midpoint(model, sid):
    # Source: twin.  The tau + 1e-3 twin decides whether the drift is a
    # property of the scene (chaos_verdict); where it is, 'standard' must be
    # within its stated drift error of an independent, ~8x finer 'reference'
    # run, relative to max(|v*|, v0) as the error is stated (fidelity.py).
    # The chaotic cases are a fixed list (KNOWN_CHAOTIC): the verdict must
    # say so for them and only for them.
    ds, _ = run(model, sid)
    twin, _ = run(model, sid, twin=True)
    chaotic = chaos_verdict(ds, twin)
    assert isinstance(chaotic, bool)
    v, v_twin = drift_velocity(ds), drift_velocity(twin)
    assert chaotic == ((model, sid) in KNOWN_CHAOTIC), (v, v_twin)
    if chaotic:
        pytest.skip(
            f"chaotic by the tau + 1e-3 twin: v*={v:+.4g}, twin {v_twin:+.4g} "
            f"(KNOWN_CHAOTIC: {KNOWN_CHAOTIC[model, sid]})"
        )
    ref, _ = run(model, sid, fidelity="reference")
    v_ref = drift_velocity(ref)
    err = abs(v - v_ref) / max(abs(v_ref), V0)
    assert err <= STATED_DRIFT_ERROR["standard"], (v, v_ref, err)


# ------------------------------------------------------------------ 3. energy
# The free Hertz oscillator (A* = 0, docs/MODEL.md section 7): E = m* y'^2/2 - y*
# + (2/5) a*^(5/2) is exact (tests/kernel_harness.py, tests/core/test_integrators.py).
# kernel_harness.free_oscillator sizes its event buffer for <= 8 events per
# period and has no `refine`; at m* = 1e-5 the particle bounces ~40 times per
# period, so this driver grows the buffer as simulate() does.
def free_oscillator(y0, mass, periods, integrator, refine=1.0, samples_per_period=4):
    h = time_step(0.0, mass, "standard") / refine
    p = D.kernel_params(0.0, mass, 1.0, 1.0, 0.0, 0.0, h, periods, 1.0 / samples_per_period)
    state, hist = D.rest_state(y0)
    ay = (1.0 - max(y0, 0.0) ** 1.5) / mass  # at rest before t = 0: constant force
    hist[:, 3] = ay
    hist[:, 2] = -np.arange(4) * h * ay
    samples = np.empty((int(periods * samples_per_period) + 16, R.NCOL))
    events = np.empty((1024, 3))
    ctr = R.new_counters()
    ctr[R.C_STATE] = STICK
    vertical_kernel = kernel_for("vertical")
    while True:
        code = vertical_kernel(
            p,
            INTEGRATORS[integrator],
            False,
            state,
            hist,
            np.empty(0),
            *D.unused_memory(),
            samples,
            events,
            ctr,
            periods,
            np.empty(0),
        )
        if code == R.DONE:
            break
        assert code == R.EVENTS_FULL, code
        events = grow(events)
    return samples[: ctr[R.C_NSAMP]], events[: ctr[R.C_NEVT]]


def linear_period(mass):
    return 2 * math.pi * math.sqrt(2 * mass / 3)


def oscillator_run(mass, y0, integrator, refine=1.0):
    """Relative energy error |E - E0| / |E0| at ~4 samples per oscillation, and
    the number of flights.  m* = 1e-5: 1e4 oscillations (162 periods), as the
    existing test; m* = 1e5: 10 oscillations (16,220 periods, 4.2e6 steps; the
    step there is 1/256 period = 4e5 steps per oscillation)."""
    T1 = linear_period(mass)
    n_osc = 1e4 if mass < 1 else 10
    spp = max(1, int(round(4 / T1)))
    s, e = free_oscillator(y0, mass, n_osc * T1, integrator, refine, spp)
    energy = hertz_energy(s, mass)
    rel = (energy - energy[0]) / abs(energy[0])
    return rel, int(np.sum(e[:, 1] == R.TAKEOFF))


# (mass, integrator): bound, measured.  The existing bounds (AB4 2e-4, Verlet
# 1e-4) were set at 256 steps per oscillation; at m* = 1e5 there are 4e5.
IN_CONTACT = [
    pytest.param(1e5, "ab4", 2e-4, id="m1e5-ab4"),  # measured 6.2e-14
    pytest.param(1e5, "verlet", 1e-4, id="m1e5-verlet"),  # measured 8.0e-12
    # Verlet is symplectic: its energy error is bounded, O((omega h)^2).  At
    # m* = 1e-5 the standard step is 1/40 of the oscillation (contact time
    # scale / 40), so the existing 1e-4 scales to 1e-4 (256/40)^2 = 4.1e-3.
    # Measured 8.28e-4 (8.28e-4 after 100 oscillations already: no growth);
    # refine 2: 2.1e-4, refine 4: 5.3e-5 (second order).
    pytest.param(1e-5, "verlet", 1e-4 * (256 / 40) ** 2, id="m1e-5-verlet"),
    pytest.param(
        1e-5,
        "ab4",
        2e-4,
        id="m1e-5-ab4",
        marks=pytest.mark.xfail(
            strict=True,
            raises=AssertionError,
            reason="AB4 damps the free oscillation at the standard step of m*=1e-5"
            " (40 steps per oscillation): |E-E0|/|E0| = 8.5e-3 after 100 "
            "oscillations, 6.4e-2 after 1e3, 0.134 after 1e4 = all of the oscillation "
            "energy (E0 - E_eq = 0.071 of |E0| = 0.529): the particle comes to rest. "
            "Existing bound 2e-4; scaling it as AB4's (omega h)^5 per oscillation gives "
            "2.1, a vacuous bound.  refine 2: 2.5e-2, refine 4: 8.6e-4",
        ),
    ),
]


@pytest.mark.parametrize("mass, integrator, bound", IN_CONTACT)
def test_free_oscillator_energy_in_contact_at_mass_extremes(mass, integrator, bound):
    # Source: closed form (exact energy).  Released at rest from a* = 1.3 the
    # particle stays in contact (a* in [0.72, 1.3]).
    rel, flights = oscillator_run(mass, 1.3, integrator)
    assert flights == 0
    drift = np.abs(rel).max()
    assert drift < bound, drift
    if integrator == "verlet" and mass < 1:
        # method property (symplectic): no secular growth after the first 1%
        assert drift <= 1.05 * np.abs(rel[: rel.size // 100]).max()


def test_ab4_at_m_1e_5_only_loses_energy_and_converges_at_fifth_order():
    # Source: method property.  What does hold for AB4 at m* = 1e-5 (see the
    # xfail above): it never gains energy (so stiff scenes cannot blow up;
    # measured max(E - E0) = 0 exactly), and its loss per oscillation falls as
    # h^5: halving the step cuts the loss after 100 oscillations 30x
    # (8.54e-3 -> 2.84e-4); asserted >= 16x.
    rel1, _ = oscillator_run(1e-5, 1.3, "ab4")
    rel2, _ = oscillator_run(1e-5, 1.3, "ab4", refine=2)
    assert rel1.max() <= 1e-12 and rel2.max() <= 1e-12
    k = rel1.size // 100
    loss1, loss2 = -rel1[:k].min(), -rel2[:k].min()
    assert loss1 > 0 and loss2 <= loss1 / 16, (loss1, loss2)


WITH_FLIGHTS = [
    pytest.param(1e5, "ab4", id="m1e5-ab4"),  # measured 4.1e-12, 7 flights
    pytest.param(1e5, "verlet", id="m1e5-verlet"),  # measured 8.6e-11, 7 flights
    pytest.param(
        1e-5,
        "ab4",
        id="m1e-5-ab4",
        marks=pytest.mark.xfail(
            strict=True,
            raises=AssertionError,
            reason="m*=1e-5, standard step, ~6600 flights in 1e4 "
            "oscillations: |E-E0|/|E0| = 0.145 (energy lost at the non-smooth landings), "
            "existing bound 0.02; refine 2, 4, 8: 4.3e-2, 1.0e-2, 2.5e-3",
        ),
    ),
    pytest.param(
        1e-5,
        "verlet",
        id="m1e-5-verlet",
        marks=pytest.mark.xfail(
            strict=True,
            raises=AssertionError,
            reason="m*=1e-5, standard step, ~6600 flights in 1e4 "
            "oscillations: |E-E0|/|E0| = 0.110, existing bound 0.02; refine 2, 4, 8: "
            "4.6e-2, 1.5e-2, 1.6e-4",
        ),
    ),
]


@pytest.mark.parametrize("mass, integrator", WITH_FLIGHTS)
def test_free_oscillator_energy_with_flights_at_mass_extremes(mass, integrator):
    # Source: closed form (exact energy), existing bound 0.02 (test_integrators:
    # measured there AB4 0.9%, Verlet 0.6% at 256 steps per oscillation).
    # Released from a* = 3 the particle bounces.
    rel, flights = oscillator_run(mass, 3.0, integrator)
    assert flights >= (5 if mass > 1 else 5000), flights
    drift = np.abs(rel).max()
    assert drift < 0.02, drift


@pytest.mark.parametrize("integrator", ["ab4", "verlet"])
def test_energy_with_flights_at_m_1e_5_converges(integrator):
    # Source: method property (convergence).  The xfails above are the
    # standard step's error, not a bug: a 4x finer step meets the existing 2%
    # bound (measured AB4 1.04%, Verlet 1.51%) and cuts the error >= 4x
    # (measured 14x, 7.3x).
    err1 = np.abs(oscillator_run(1e-5, 3.0, integrator)[0]).max()
    err4 = np.abs(oscillator_run(1e-5, 3.0, integrator, refine=4)[0]).max()
    assert err4 < 0.02 and err4 < err1 / 4, (err1, err4)


# ------------------------------------------------------------------ 4. budget
def hertz_steps(amplitude, mass, periods, per_period, per_contact):
    """Closed form of the step (fidelity.py docstring): the smaller of one
    period / per_period and the shortest contact time scale / per_contact."""
    t_lin = 2 * math.pi * math.sqrt(2 * mass / 3)
    v = 4 * math.pi * amplitude
    t_c = 2.94 * (1.25 * mass * v * v) ** 0.4 / v
    return periods / min(1 / per_period, t_lin / per_contact, t_c / per_contact)


BUDGET = [
    # model, fidelity, periods, max_steps, (per period, per contact)
    pytest.param("deformable", "standard", 1e5, DEFAULT_MAX_STEPS, (256, 40), id="deformable"),
    pytest.param("vertical", "standard", 1e5, DEFAULT_MAX_STEPS, (256, 40), id="vertical"),
    pytest.param("deformable", "reference", 1e4, DEFAULT_MAX_STEPS, (2048, 320), id="reference"),
    # the server's lower budget: the map's own 2000 periods (1.6e7 steps)
    pytest.param("deformable", "standard", 2000.0, 1e7, (256, 40), id="server-budget"),
]


@pytest.mark.parametrize("model, fidelity, periods, max_steps, preset", BUDGET)
def test_over_budget_scene_is_refused_before_it_runs(
    model, fidelity, periods, max_steps, preset, monkeypatch
):
    # Source: closed form of the step count at the stiffest corner (A* = 1e3,
    # m* = 1e-5: the impact time scale sets h = 1.2e-4 at standard), and the
    # method property that simulate() estimates before it runs: the runners
    # are replaced by a trap (so the refusal cannot have run the scene; its
    # time is printed, not asserted: wall-clock limits belong to the benches).
    def trap(*args, **kwargs):
        raise AssertionError("the scene ran")

    monkeypatch.setattr(S, "_run_hertz", trap)
    monkeypatch.setattr(S, "_run_point_mass", trap)
    sc = Scene(model=model, fidelity=fidelity, amplitude=1e3, mass=1e-5, periods=periods)
    expected = hertz_steps(1e3, 1e-5, periods, *preset)
    n = estimate_steps(sc)
    assert n == pytest.approx(expected, rel=1e-9, abs=1)
    assert n > max_steps
    progress = []
    t0 = time.perf_counter()
    with pytest.raises(StepBudgetExceeded) as info:
        simulate(sc, max_steps=max_steps, progress=progress.append)
    print(f"refused in {time.perf_counter() - t0:.4f} s")
    assert progress == []
    message = str(info.value)
    assert f"{n:.3g} steps" in message and f"{max_steps:.3g}" in message, message
    assert isinstance(info.value, ValueError)  # callers that catch ValueError see it
