"""Derived quantities of a trajectory: drift, contact, rebounds, regime.

All in normalized units (docs/MODEL.md section 4).  Functions take the Dataset of
`simulate` and return plain numbers; `summarize` gathers them in one
named tuple for the CLI, the sweeps and the app.
"""
import math
from typing import NamedTuple

import numpy as np

from . import records as R
from .contact import FLIGHT

V0 = 0.1                 # |v*| <= V0: "no drift" (the paper's white band)
TWIN_TAU_OFFSET = 1e-3   # the chaos twin: the same scene with tau + 1e-3
FINAL_FRACTION = 0.1     # the final window: last 10% of the run
SYNC_TOL = 0.05          # |interval - 1| between synchronous take-offs, periods
SYNC_SPREAD = 0.02       # circular spread of synchronous take-off phases, periods
LONG_FLIGHT = 3.0        # a flight this long (periods) separates bursts


def twin_scene(scene):
    """The chaos check's twin: the scene with its ramp time moved by
    TWIN_TAU_OFFSET (a regular regime does not notice; a chaotic one ends
    elsewhere)."""
    return scene.replace(tau=scene.tau + TWIN_TAU_OFFSET)


def jumped(ds):
    """True if the particle lost contact at least once during the run."""
    return bool((ds["event_kind"].values == R.TAKEOFF).any())


def drift_velocity(ds):
    """<v_x*> = x*(T_obs) / T_obs, the paper's definition."""
    t = float(ds["time"].values[-1])
    return float(ds["x"].values[-1]) / t


def final_drift_velocity(ds, fraction=FINAL_FRACTION):
    """Mean velocity over the last `fraction` of the run."""
    t = ds["time"].values
    x = ds["x"].values
    t1 = float(t[-1])
    t0 = t1 * (1.0 - fraction)
    return float((x[-1] - np.interp(t0, t, x)) / (t1 - t0))


def flights(ds):
    """(take-off, landing) times of every flight; landing = inf if still flying."""
    to, _ = _events(ds, R.TAKEOFF)
    la, _ = _events(ds, R.LANDING)
    starts = np.sort(to)
    ends = np.full(starts.shape, np.inf)
    j = np.searchsorted(la, starts, side="right")  # a rebound lands and leaves at once
    ok = j < la.size
    ends[ok] = la[j[ok]]
    return starts, ends


def _events(ds, kind):
    sel = ds["event_kind"].values == kind
    return ds["event_time"].values[sel], ds["event_value"].values[sel]


def contact_fraction(ds, t0=None, t1=None):
    """Fraction of [t0, t1] spent in contact (default: the final window)."""
    t_end = float(ds["time"].values[-1])
    t1 = t_end if t1 is None else t1
    t0 = t_end * (1.0 - FINAL_FRACTION) if t0 is None else t0
    starts, ends = flights(ds)
    # A run can start in flight (point mass under a fast ramp): state at t = 0.
    st_t, st_v = _events(ds, R.STATE_CHANGE)
    if st_t.size and st_t[0] == 0.0 and st_v[0] == FLIGHT:
        la, _ = _events(ds, R.LANDING)
        starts = np.concatenate([[0.0], starts])
        ends = np.concatenate([[la[0] if la.size else np.inf], ends])
    lo = np.clip(starts, t0, t1)
    hi = np.clip(ends, t0, t1)
    return float(1.0 - np.sum(hi - lo) / (t1 - t0))


def takeoff_phases(ds, t0=0.0):
    """Phases (t mod 1) of the take-offs after t0."""
    t, phase = _events(ds, R.TAKEOFF)
    return phase[t >= t0]


def phase_spread(phases):
    """Circular standard deviation of phases, in periods (0 = all equal)."""
    if len(phases) == 0:
        return math.nan
    z = np.mean(np.exp(2j * np.pi * np.asarray(phases)))
    rho = min(abs(z), 1.0)
    return math.sqrt(-2.0 * math.log(rho)) / (2.0 * math.pi) if rho > 0 else math.inf


def rebound_pattern(ds):
    """'synchronous', 'multi-synchronous', 'irregular', or None (no jumping).

    Synchronous: in the final window, one take-off per period at one phase.
    Multi-synchronous: after the ramp, take-offs come in runs one period
    apart at one phase, separated by flights of more than LONG_FLIGHT
    periods.  Chaos is judged separately, by a twin run (`chaos_verdict`).
    """
    t_to, phase = _events(ds, R.TAKEOFF)
    if t_to.size == 0:
        return None
    t_end = float(ds["time"].values[-1])
    tw = t_end * (1.0 - FINAL_FRACTION)
    last = t_to >= tw
    gaps = np.diff(t_to[last])
    if gaps.size >= 2 and np.all(np.abs(gaps - 1.0) < SYNC_TOL) \
            and phase_spread(phase[last]) < SYNC_SPREAD:
        return "synchronous"
    tau = float(ds.attrs.get("tau", 0.0))
    after = t_to >= min(3.0 * tau, 0.5 * t_end)
    gaps = np.diff(t_to[after])
    if gaps.size >= 4:
        sync = np.abs(gaps - 1.0) < SYNC_TOL
        long_ = gaps > LONG_FLIGHT
        if sync.sum() >= 0.5 * gaps.size and long_.any() and np.all(sync | long_) \
                and phase_spread(phase[after][1:][sync]) < SYNC_SPREAD:
            return "multi-synchronous"
    return "irregular"


def drift_class(v, v0=V0):
    """'with-wave' (v > v0), 'against-wave' (v < -v0) or 'none'."""
    if v > v0:
        return "with-wave"
    if v < -v0:
        return "against-wave"
    return "none"


def chaos_verdict(ds, twin, rel_tol=0.1, v0=V0):
    """Does the tau + 1e-3 twin disagree? (True: chaotic, the drift is not a
    property of the scene.)  Disagreement: different drift class, or drift
    velocities differing by more than rel_tol of the larger plus v0."""
    v1 = drift_velocity(ds)
    v2 = drift_velocity(twin)
    if drift_class(v1, v0) != drift_class(v2, v0):
        return True
    return abs(v1 - v2) > rel_tol * max(abs(v1), abs(v2)) + v0


def divergence_time(ds, twin, threshold=1.0):
    """First time the twins' x* differ by more than `threshold` (a0 units);
    inf if never.  Compared on the coarse sample grid."""
    t = ds["time"].values
    dx = np.abs(ds["x"].values - np.interp(t, twin["time"].values, twin["x"].values))
    i = np.flatnonzero(dx > threshold)
    return float(t[i[0]]) if i.size else math.inf


class Summary(NamedTuple):
    drift_velocity: float
    final_drift_velocity: float
    contact: str                 # "permanent" | "jumping"
    drift: str                   # "with-wave" | "against-wave" | "none"
    pattern: str | None          # jumping: synchronous | multi-synchronous | chaotic | irregular
    chaotic: bool | None         # None if no twin was run
    divergence_time: float | None
    takeoffs: int
    takeoffs_per_period: float   # final window
    takeoff_phase_spread: float  # final window, periods
    contact_fraction: float      # final window
    steps: int
    seconds: float


def summarize(ds, twin=None, v0=V0):
    """All derived quantities of a run (and of its tau + 1e-3 twin, if given)."""
    t_to, _ = _events(ds, R.TAKEOFF)
    t_end = float(ds["time"].values[-1])
    tw = t_end * (1.0 - FINAL_FRACTION)
    v = drift_velocity(ds)
    jumping = t_to.size > 0
    pattern = rebound_pattern(ds)
    chaotic = None if twin is None else chaos_verdict(ds, twin, v0=v0)
    if jumping and chaotic:
        pattern = "chaotic"
    seconds = float(ds.attrs.get("seconds", 0.0)) + (
        float(twin.attrs.get("seconds", 0.0)) if twin is not None else 0.0)
    return Summary(
        drift_velocity=v,
        final_drift_velocity=final_drift_velocity(ds),
        contact="jumping" if jumping else "permanent",
        drift=drift_class(v, v0),
        pattern=pattern,
        chaotic=chaotic,
        divergence_time=None if twin is None else divergence_time(ds, twin),
        takeoffs=int(t_to.size),
        takeoffs_per_period=float(np.sum(t_to >= tw) / (t_end - tw)),
        takeoff_phase_spread=phase_spread(takeoff_phases(ds, tw)),
        contact_fraction=contact_fraction(ds),
        steps=int(ds.attrs.get("steps", 0)) + (int(twin.attrs.get("steps", 0)) if twin is not None else 0),
        seconds=seconds,
    )
