"""Every corner of the paper's map finishes, finite, without a warning.

Map (docs/MODEL.md section 1): log10 A* in [-3, 3], log10 m* in [-5, 5], mu in
[0.01, 1], theta in [1.0555, 1.3333]; observation time 2000 periods.  The
corners are the stiffest (m* = 1e-5: ~1.6e7 steps at A* = 1e3) and the most
violent (A* = 1e3, m* = 1e5: the substrate moves 1000 a0) scenes of the map.

Cost, measured on 2 cores (load average ~5 from other jobs), fidelity
'standard', 2000 periods, numba cache present (loading it: ~1 s; an empty
NUMBA_CACHE_DIR, i.e. compiling every kernel, made the file take 60 s):
    deformable  A*=1e3,  m*=1e-5  1.6e7 steps  ~1.0-1.3 s each (4 corners)
                A*=1e-3, m*=1e-5  4.9e6 steps  ~0.4 s each
                m* = 1e5          5e5 / 2.4e4 steps  < 0.05 s each
    vertical    same steps, ~0.8 s at most;  point mass < 0.05 s
so every corner runs the full 2000 periods at 'standard' (no reduction);
the whole file takes ~17-20 s (53 tests).

Physical sanity checked at every corner: all outputs finite, N* >= 0,
|T*| <= N* (Coulomb; T* is in units of mu N(a0)), contact states in {0,1,2,3}
with N* = 0 in flight, |x*'| bounded by the substrate's peak horizontal speed
2 pi A* r (friction only ever pulls towards the substrate's velocity), and the
contact regime where it is obvious: at A* = 1e-3 the substrate moves 1e-3 of
the static compression, so a Hertz particle never loses contact; at A* = 1e3,
m* = 1e5 it must jump; the point mass jumps iff m* > 1/(4 pi^2 A*).
"""

import itertools
import math
import warnings

import numpy as np
import pytest

from vibtrans.analysis.summary import summarize
from vibtrans.core.kernels import records as R
from vibtrans.core.simulate import simulate

PERIODS = 2000.0
LOG_A = (-3, 3)
LOG_M = (-5, 5)
MUS = (0.01, 1.0)
THETAS = (1.0555, 1.3333)
STATES = {0, 1, 2, 3}
PATTERNS = {None, "synchronous", "multi-synchronous", "chaotic", "irregular", "launched"}

DEFORMABLE = list(itertools.product(LOG_A, LOG_M, MUS, THETAS))
AM_CORNERS = list(itertools.product(LOG_A, LOG_M))


def run(model, log_a, log_m, periods=PERIODS, fidelity="standard", **values):
    """Simulate and summarize with every warning turned into an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = simulate(
            amplitude=10.0**log_a, mass=10.0**log_m, model=model, periods=periods, fidelity=fidelity, **values
        )
        summary = summarize(ds)
    return ds, summary


def check_finite(ds, summary):
    for name in list(ds.data_vars) + ["time"]:
        values = ds[name].values
        assert np.isfinite(values).all(), f"{name} has non-finite values"
    t = ds["time"].values
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    assert t[-1] == pytest.approx(float(ds.attrs["periods"]), abs=ds.attrs["h"] + 1e-9)

    s = summary
    for key in (
        "drift_velocity",
        "final_drift_velocity",
        "takeoffs_per_period",
        "contact_fraction",
        "seconds",
    ):
        assert math.isfinite(getattr(s, key)), key
    assert s.contact in ("permanent", "jumping")
    assert s.drift in ("with-wave", "against-wave", "none")
    assert s.pattern in PATTERNS
    assert (s.pattern is None) == (s.contact == "permanent")
    assert s.chaotic is None and s.divergence_time is None  # no twin
    assert s.takeoffs >= 0 and s.steps > 0
    assert 0.0 <= s.contact_fraction <= 1.0
    assert (s.takeoffs > 0) == (s.contact == "jumping")
    # the phase spread is NaN exactly when the final window has no take-off
    if s.takeoffs_per_period > 0:
        assert math.isfinite(s.takeoff_phase_spread) and s.takeoff_phase_spread >= 0
    else:
        assert math.isnan(s.takeoff_phase_spread)


def check_physics(ds):
    N = ds["N"].values
    T = ds["T"].values
    state = ds["state"].values
    assert N.min() >= 0.0
    assert np.all(np.abs(T) <= N + 1e-9), float(np.max(np.abs(T) - N))
    assert set(np.unique(state).tolist()) <= STATES
    assert np.all(N[state == 0] == 0.0)
    assert np.all(T[state == 0] == 0.0)
    # horizontal speed: friction pulls towards the substrate's velocity, whose
    # peak is 2 pi A* r (plus the ramp's G' A* r <= 0.3% of it at tau = 50)
    vmax = 2 * math.pi * ds.attrs["amplitude"] * ds.attrs["r"]
    assert np.abs(ds["vx"].values).max() <= 1.05 * vmax + 1e-9
    # events: known kinds, in time order, inside the run
    kinds = ds["event_kind"].values
    times = ds["event_time"].values
    assert set(np.unique(kinds).tolist()) <= {R.TAKEOFF, R.LANDING, R.STATE_CHANGE}
    assert np.all(np.diff(times) >= 0)
    if times.size:
        assert 0.0 <= times[0] and times[-1] <= ds.attrs["periods"] + ds.attrs["h"]
    state_values = ds["event_value"].values[kinds == R.STATE_CHANGE]
    assert set(np.unique(state_values).tolist()) <= STATES


def check_obvious_regime(ds, summary, log_a, log_m):
    if log_a == -3:
        # the substrate moves 1e-3 a0: a* = 1 +- ~1e-3, N* = 1 +- ~1.5e-3
        assert summary.contact == "permanent", summary
        assert summary.takeoffs == 0
        N = ds["N"].values
        assert np.abs(N - 1.0).max() < 0.01, (N.min(), N.max())
    if (log_a, log_m) == (3, 5):
        assert summary.contact == "jumping", summary


# ------------------------------------------------------------------ deformable
@pytest.mark.parametrize(
    "log_a, log_m, mu, theta", DEFORMABLE, ids=[f"A1e{a}-m1e{m}-mu{mu}-th{th}" for a, m, mu, th in DEFORMABLE]
)
def test_deformable_corner(log_a, log_m, mu, theta):
    ds, summary = run("deformable", log_a, log_m, mu=mu, theta=theta)
    check_finite(ds, summary)
    check_physics(ds)
    check_obvious_regime(ds, summary, log_a, log_m)
    s = ds["stick_radius"].values
    c = ds["contact_radius"].values
    assert np.all(s >= 0) and np.all(s <= c + 1e-12)
    assert np.all(c[ds["state"].values == 0] == 0)


# ------------------------------------------------------------------ vertical
@pytest.mark.parametrize("log_a, log_m", AM_CORNERS)
def test_vertical_corner(log_a, log_m):
    ds, summary = run("vertical", log_a, log_m)
    check_finite(ds, summary)
    check_physics(ds)
    check_obvious_regime(ds, summary, log_a, log_m)
    assert np.all(ds["x"].values == 0) and np.all(ds["vx"].values == 0)
    assert np.all(ds["T"].values == 0)
    assert summary.drift_velocity == 0.0 and summary.drift == "none"


# ------------------------------------------------------------------ point mass
@pytest.mark.parametrize("stick_rule", ["paper", "classical"])
@pytest.mark.parametrize("log_a, log_m", AM_CORNERS)
def test_point_mass_corner(log_a, log_m, stick_rule):
    ds, summary = run("point-mass", log_a, log_m, stick_rule=stick_rule)
    check_finite(ds, summary)
    check_physics(ds)
    # rigid contact (docs/MODEL.md section 3): jumping iff m* > 1 / (4 pi^2 A*)
    jumps = 10.0**log_m > 1.0 / (4 * math.pi**2 * 10.0**log_a)
    assert summary.contact == ("jumping" if jumps else "permanent"), summary


# ------------------------------------------------------------------ preview fidelity
@pytest.mark.parametrize("integrator", ["ab4", "verlet"])
@pytest.mark.parametrize("model", ["deformable", "vertical"])
@pytest.mark.parametrize("log_a, log_m", AM_CORNERS)
def test_preview_corner(log_a, log_m, model, integrator):
    # 'preview' is what the explorer shows first: it must be as stable as
    # 'standard', only less accurate.
    ds, summary = run(model, log_a, log_m, fidelity="preview", integrator=integrator)
    check_finite(ds, summary)
    check_physics(ds)
    check_obvious_regime(ds, summary, log_a, log_m)


# ------------------------------------------------------------------ short runs
@pytest.mark.parametrize("periods", [0.05, 0.5, 1.03])
@pytest.mark.parametrize("model", ["deformable", "vertical", "point-mass"])
def test_short_run_records_the_end(model, periods):
    # The drift velocity is x*(T_obs) / T_obs: the last sample must be at T_obs
    # (within one step), whatever T_obs is.
    ds, summary = run(model, 0.0, 0.0, periods=periods)
    t_end = float(ds["time"].values[-1])
    assert periods - 1e-9 <= t_end <= periods + ds.attrs["h"] + 1e-9, t_end
    check_finite(ds, summary)
