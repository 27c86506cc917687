"""Derived quantities of a trajectory: drift, contact, rebounds, regime.

All in normalized units (docs/MODEL.md section 4).  Functions take the Dataset of
`simulate` and return plain numbers; `summarize` gathers them in one
named tuple for the CLI, the sweeps and the app, with one plain-language
verdict (`Summary.regime`) that never contradicts its numbers.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

# V0 (|v*| <= V0: no drift) and CHAOS_LYAPUNOV (the chaos threshold) are the
# core's (its stopping rule uses them); named here for every caller
from vibtrans.core.fidelity import CHAOS_LYAPUNOV, V0  # noqa: F401
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import FLIGHT
from vibtrans.core.stopping import (
    DECIDED_FRACTION,
    MIN_WINDOW,
    STOP_RECURRENT,
    STOP_REGULAR,
    DecidedRule,
    ballistic_reach_time,
    replay,
    stroboscope,
    weighted_birkhoff,
)

if TYPE_CHECKING:
    import xarray as xr

    from vibtrans.core.params import Scene
    from vibtrans.core.trajectory import RunArrays

TWIN_TAU_OFFSET = 1e-3  # the chaos twin: the same scene with tau + 1e-3
FINAL_FRACTION = 0.1  # the final window: last 10% of the run
SYNC_TOL = 0.05  # |interval - 1| between synchronous take-offs, periods
SYNC_SPREAD = 0.02  # circular spread of synchronous take-off phases, periods
LONG_FLIGHT = 3.0  # a flight this long (periods) separates bursts
LAUNCH_FRACTION = 0.5  # launched: still in flight at the end, since before this fraction of the run


def twin_scene(scene: Scene) -> Scene:
    """The chaos check's twin: the scene with its ramp time moved by
    TWIN_TAU_OFFSET (a regular regime does not notice; a chaotic one ends
    elsewhere)."""
    return scene.replace(tau=scene.tau + TWIN_TAU_OFFSET)


def jumped(ds: Any) -> bool:
    """True if the particle lost contact at least once during the run."""
    return bool((ds["event_kind"].values == R.TAKEOFF).any())


def drift_velocity(ds: xr.Dataset | RunArrays) -> float:
    """<v_x*> = x*(T_obs) / T_obs, the paper's definition (a run stopped as
    regular by the `decided` rule: its extrapolation to T_obs, attribute
    decided_drift_velocity, stopping.DecidedRule)."""
    decided = ds.attrs.get("decided_drift_velocity")
    if decided is not None:
        return float(decided)
    t = float(ds["time"].values[-1])
    return float(ds["x"].values[-1]) / t


def final_drift_velocity(ds: xr.Dataset | RunArrays, fraction: float = FINAL_FRACTION) -> float:
    """Mean velocity over the last `fraction` of the run (a run stopped as
    regular by the `decided` rule: its asymptotic drift rate)."""
    rate = ds.attrs.get("asymptotic_drift_velocity")
    if rate is not None:
        return float(rate)
    t = ds["time"].values
    x = ds["x"].values
    t1 = float(t[-1])
    t0 = t1 * (1.0 - fraction)
    return float((x[-1] - np.interp(t0, t, x)) / (t1 - t0))


def steadiness(
    ds: xr.Dataset | RunArrays, v0: float = V0, chaotic: bool | None = None
) -> tuple[bool | None, str]:
    """Whether a run's drift is steady, by the `decided` stop's own test.

    Steady when stopping.DecidedRule decides the drift: what the drift per
    period has left to change moves x*(T)/T by less than DECIDED_FRACTION
    of the fidelity's stated drift error, relative to |v*| (at least v0).
    A run the rule stopped is what it said; a run to T_obs is checked by
    the rule afterwards (stopping.replay).

    Parameters
    ----------
    ds : xarray.Dataset or RunArrays
        A run, as `simulate` returns it.
    v0 : float
        The rule's floor of |v*|, a0 per period.
    chaotic : bool, optional
        The run's chaos verdict (`Summary.chaotic`); a chaotic run, or one
        whose Lyapunov exponent exceeds CHAOS_LYAPUNOV, has no steady
        drift, nor has a launched one.

    Returns
    -------
    tuple
        (steady, words): True, False, or None for a run too short for the
        test; the verdict in words, with the test's tolerance.
    """
    attrs = ds.attrs
    lyapunov, measured = lyapunov_verdict(ds)
    if chaotic or measured or attrs.get("stop_reason") == "chaotic":
        return False, f"chaotic: no steady drift ({chaos_words(lyapunov)})"
    launch = launch_time(ds)
    if launch is not None:
        return False, (
            f"launched: no steady drift (in flight from t* = {launch:.4g} to the "
            "end; <v*> is mostly that flight's horizontal velocity)"
        )
    fidelity = str(attrs.get("fidelity", "standard"))
    rule = DecidedRule(
        attrs["periods"], attrs.get("tau", 0.0), attrs["amplitude"], attrs["mass"], fidelity, v0=v0
    )
    test = (
        f"by the decided stop's test: what the drift per period has left to change "
        f"moves <v*> by less than {rule.tolerance:.2%} of |v*| (at least v0* = {v0:g}), "
        f"{DECIDED_FRACTION:g} of the {fidelity} fidelity's stated drift error"
    )
    reason = attrs.get("stop_reason")
    if reason in ("regular", "recurrent"):
        return True, (
            f"steady: known from t* = {math.floor(attrs['periods_run'])} (drift per "
            f"period {float(attrs['asymptotic_drift_velocity']):.4g}), {test}"
        )
    t = ds["time"].values
    samples = np.zeros((t.size, R.NCOL))
    for column, name in (
        (R.T_, "time"),
        (R.X, "x"),
        (R.VX, "vx"),
        (R.Y, "y"),
        (R.VY, "vy"),
        (R.STATE, "state"),
    ):
        samples[:, column] = ds[name].values
    k_end = math.floor(float(t[-1]) + 1e-9)
    third = (k_end - rule.t_settle) // 3
    if third < MIN_WINDOW // 3:
        return None, (
            f"not judged: the run is too short for the decided stop's test (after "
            f"the ramp, from t* = {rule.t_settle}, it needs {MIN_WINDOW} periods)"
        )
    if reason is None:  # a run to T_obs: the rule checks it now
        events = np.column_stack([ds["event_time"].values, ds["event_kind"].values, ds["event_value"].values])
        replay(rule, samples, events)
        if rule.reason in (STOP_REGULAR, STOP_RECURRENT):
            return True, (
                f"steady: known from t* = {rule.t_strobe:.0f} (drift per period {rule.rate:.4g}), {test}"
            )
    k0 = k_end - 3 * third
    drift = np.diff(stroboscope(samples, np.arange(k0, k_end + 1, dtype=float)))
    v1, v2, v3 = (weighted_birkhoff(drift[i * third : (i + 1) * third]) for i in range(3))
    word = (
        "accelerating"
        if abs(v1) < abs(v2) < abs(v3)
        else "decelerating"
        if abs(v1) > abs(v2) > abs(v3)
        else "changing"
    )
    return False, (
        f"not steady: still {word} (drift per period {v1:.4g}, {v2:.4g}, then "
        f"{v3:.4g} over three equal windows from t* = {k0} to {k_end}); "
        f"not decided {test}; the mean depends on the run's length"
    )


def flights(ds: xr.Dataset | RunArrays) -> tuple[np.ndarray, np.ndarray]:
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


def contact_fraction(ds: xr.Dataset | RunArrays, t0: float | None = None, t1: float | None = None) -> float:
    """Fraction of [t0, t1] spent in contact (default: the final window)."""
    t_end = float(ds["time"].values[-1])
    t1 = t_end if t1 is None else t1
    t0 = t_end * (1.0 - FINAL_FRACTION) if t0 is None else t0
    starts, ends = flights(ds)
    if _starts_in_flight(ds):
        la, _ = _events(ds, R.LANDING)
        starts = np.concatenate([[0.0], starts])
        ends = np.concatenate([[la[0] if la.size else np.inf], ends])
    lo = np.clip(starts, t0, t1)
    hi = np.clip(ends, t0, t1)
    return float(1.0 - np.sum(hi - lo) / (t1 - t0))


def _starts_in_flight(ds):
    """A run can start in flight (point mass under a fast ramp): its first
    state, at t = 0, is FLIGHT."""
    st_t, st_v = _events(ds, R.STATE_CHANGE)
    return bool(st_t.size and st_t[0] == 0.0 and st_v[0] == FLIGHT)


def open_flight_start(ds: xr.Dataset | RunArrays) -> float | None:
    """Start time of the flight still in progress at the end of the run
    (periods), or None if the run ends in contact.  A run that starts in
    flight and never lands has been in flight since t* = 0."""
    starts, ends = flights(ds)
    if starts.size:
        return float(starts[-1]) if math.isinf(ends[-1]) else None
    no_landing = not (ds["event_kind"].values == R.LANDING).any()
    return 0.0 if _starts_in_flight(ds) and no_landing else None


def launch_time(ds: xr.Dataset | RunArrays, fraction: float = LAUNCH_FRACTION) -> float | None:
    """Take-off time (periods) of a launched run, else None.

    Launched: the flight still in progress at the end began before
    `fraction` of the run, so more than half of the run (by default) is one
    unfinished flight and <v*> is mostly that flight's horizontal velocity,
    not a transport regime.  Such a run has no contact in the whole final
    window (fraction <= 1 - FINAL_FRACTION).  A hopping run that merely ends
    mid-flight is not launched, even when that flight spans the final
    window: its flights are shorter (synchronous about 1 period, the long
    flights between the bursts near paper point 5 about 400).
    """
    t0 = open_flight_start(ds)
    t_end = float(ds["time"].values[-1])
    if ds.attrs.get("stop_reason") == "flight":
        # stopped by the `decided` rule in a flight that lasts past T_obs
        t_end = float(ds.attrs["periods"])
    return t0 if t0 is not None and t0 < fraction * t_end else None


def earliest_landing(ds: xr.Dataset | RunArrays) -> float:
    """Earliest time (periods) at which the flight in progress at the end
    can reach the substrate again, continued ballistically (in flight
    m* y*'' = 1, docs/MODEL.md sections 1 and 3): when y* first reaches
    -A*, the highest the surface ever comes (G <= 1; y* points down).
    The end of the run if the particle is already within reach."""
    t_end = float(ds["time"].values[-1])
    return t_end + ballistic_reach_time(
        float(ds["y"].values[-1]),
        float(ds["vy"].values[-1]),
        float(ds.attrs["mass"]),
        float(ds.attrs["amplitude"]),
    )


def takeoff_phases(ds: xr.Dataset | RunArrays, t0: float = 0.0) -> np.ndarray:
    """Phases (t mod 1) of the take-offs after t0."""
    t, phase = _events(ds, R.TAKEOFF)
    return phase[t >= t0]


def phase_spread(phases: np.ndarray | list[float]) -> float:
    """Circular standard deviation of phases, in periods (0 = all equal)."""
    if len(phases) == 0:
        return math.nan
    z = np.mean(np.exp(2j * np.pi * np.asarray(phases)))
    rho = min(float(abs(z)), 1.0)
    return math.sqrt(-2.0 * math.log(rho)) / (2.0 * math.pi) if rho > 0 else math.inf


def rebound_pattern(ds: Any) -> str | None:
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
    if gaps.size >= 2 and np.all(np.abs(gaps - 1.0) < SYNC_TOL) and phase_spread(phase[last]) < SYNC_SPREAD:
        return "synchronous"
    tau = float(ds.attrs.get("tau", 0.0))
    after = t_to >= min(3.0 * tau, 0.5 * t_end)
    gaps = np.diff(t_to[after])
    if gaps.size >= 4:
        sync = np.abs(gaps - 1.0) < SYNC_TOL
        long_ = gaps > LONG_FLIGHT
        if (
            sync.sum() >= 0.5 * gaps.size
            and long_.any()
            and np.all(sync | long_)
            and phase_spread(phase[after][1:][sync]) < SYNC_SPREAD
        ):
            return "multi-synchronous"
    return "irregular"


def drift_class(v: float, v0: float = V0) -> str:
    """'with-wave' (v > v0), 'against-wave' (v < -v0) or 'none'."""
    if v > v0:
        return "with-wave"
    if v < -v0:
        return "against-wave"
    return "none"


def chaos_verdict(
    ds: xr.Dataset | RunArrays, twin: xr.Dataset | RunArrays, rel_tol: float = 0.1, v0: float = V0
) -> bool:
    """Does the tau + 1e-3 twin disagree? (True: chaotic, the drift is not a
    property of the scene.)  Disagreement: different drift class, or drift
    velocities differing by more than rel_tol of the larger plus v0."""
    v1 = drift_velocity(ds)
    v2 = drift_velocity(twin)
    if drift_class(v1, v0) != drift_class(v2, v0):
        return True
    return abs(v1 - v2) > rel_tol * max(abs(v1), abs(v2)) + v0


def lyapunov_verdict(
    ds: xr.Dataset | RunArrays, threshold: float = CHAOS_LYAPUNOV
) -> tuple[None, None] | tuple[float, bool]:
    """(lambda, chaotic) from a run's measured Lyapunov exponent: (None,
    None) when the run did not measure one."""
    value = ds.attrs.get("lyapunov")
    if value is None:
        return None, None
    return float(value), bool(value > threshold)


def divergence_time(
    ds: xr.Dataset | RunArrays, twin: xr.Dataset | RunArrays, threshold: float = 1.0
) -> float:
    """First time the twins' x* differ by more than `threshold` (a0 units);
    inf if never.  Compared on the coarse sample grid."""
    t = ds["time"].values
    dx = np.abs(ds["x"].values - np.interp(t, twin["time"].values, twin["x"].values))
    i = np.flatnonzero(dx > threshold)
    return float(t[i[0]]) if i.size else math.inf


DIRECTIONS = {"with-wave": "with the wave (+x)", "against-wave": "against the wave (-x)"}


def _drift_words(v, v_final, v0):
    """The drift in words; the final window's too where its class differs
    (a regime still settling)."""

    def words(cls):
        return f"drift {DIRECTIONS[cls]}" if cls in DIRECTIONS else f"no drift (|v*| <= {v0:g})"

    run, final = drift_class(v, v0), drift_class(v_final, v0)
    if final == run:
        return words(run)
    return f"{words(run)} over the run, {words(final)} over its final {FINAL_FRACTION:.0%}"


def chaos_words(lyapunov: Any) -> str:
    """Why a run is called chaotic: its Lyapunov exponent, or (None) its twin."""
    if lyapunov is None:
        return f"the tau + {TWIN_TAU_OFFSET:g} twin ends elsewhere"
    return f"the vertical motion's Lyapunov exponent is {lyapunov:.3g} per period (> {CHAOS_LYAPUNOV:g})"


def regime(
    contact: Any,
    pattern: Any,
    chaotic: Any,
    v: float,
    v_final: float,
    launch: float | None = None,
    landing: float | None = None,
    t_end: float | None = None,
    v0: float = V0,
    lyapunov: Any = None,
) -> str:
    """One plain-language verdict, consistent with the other fields of
    `Summary`.  A launched run gets no transport regime and a chaotic one no
    drift direction (its drift is not a property of the scene).  lyapunov:
    the exponent that decided `chaotic` (None: the twin decided)."""
    if launch is not None:
        text = (
            f"launched: leaves the substrate at t* = {launch:.4g} and is still in flight "
            f"at the end (t* = {t_end:.4g}); continued ballistically it cannot land "
            f"again before t* = {landing:.3g}; no transport regime, <v*> is mostly "
            "its flight's horizontal velocity"
        )
        if chaotic:
            text += f"; {chaos_words(lyapunov)}"
        return text
    where = "permanent contact" if contact == "permanent" else "jumping"
    if pattern not in (None, "chaotic"):
        where += f", {pattern}"
    if chaotic:
        return f"{where}, chaotic: {chaos_words(lyapunov)}, the drift is not a property of the scene"
    text = f"{where}, {_drift_words(v, v_final, v0)}"
    if chaotic is None and contact == "jumping":
        text += "; chaos not checked (no twin run)"
    return text


class Summary(NamedTuple):
    """Derived quantities of one run, all produced by `model`; velocities in
    a0 per period, times in periods.  `chaotic` comes from the measured
    Lyapunov exponent where the run has one, else from the twin (tau +
    TWIN_TAU_OFFSET), which also gives `twin_chaotic` and `divergence_time`;
    the twin's cost is listed apart."""

    drift_velocity: float  # <v*> = x*(T)/T of this run
    final_drift_velocity: float
    contact: str  # "permanent" | "jumping" (a take-off, or launched)
    drift: str  # class of drift_velocity: "with-wave" | "against-wave" | "none"
    pattern: str | None  # first that applies: launched | chaotic | synchronous |
    #                              multi-synchronous | irregular; None: never left the surface
    chaotic: bool | None  # lyapunov > CHAOS_LYAPUNOV, else the twin's; None: neither
    divergence_time: float | None
    takeoffs: int
    takeoffs_per_period: float  # final window
    takeoff_phase_spread: float  # final window, periods
    contact_fraction: float  # final window
    steps: int  # this run's integration steps
    seconds: float  # this run's wall time, s
    model: str | None  # the model that produced every number ("deformable" | "point-mass")
    regime: str  # the verdict in words (`regime`)
    launched: bool  # in flight from before LAUNCH_FRACTION of the run to its end
    launch_time: float | None  # launched: the take-off, periods
    earliest_landing: float | None  # launched: earliest ballistic return within reach, periods
    twin_steps: int  # the twin's steps (0: no twin ran)
    twin_seconds: float  # the twin's wall time, s (0.0: no twin ran)
    lyapunov: float | None = None  # the vertical motion's exponent, per period (None: not measured)
    twin_chaotic: bool | None = None  # the twin's verdict (None: no twin ran)
    steady: bool | None = None  # the drift steady at the run's end (`steadiness`)
    steadiness: str = ""  # that, in words
    rolling: str = "none"  # how the particle turns (docs/MODEL.md section 11), in words
    max_episode_roll: float | None = None  # rolling: the largest rolled arc of a contact
    #                                         episode, a0 (None: the particle does not turn)


def rolling_words(attrs: Any) -> str:
    """Whether a run's particle rolls, in words: "none" (it slides without
    turning, the paper's particle), else its rolling and j = I/(m R^2)
    (e.g. "solid sphere, j = 0.4")."""
    j = attrs.get("inertia_ratio")
    if j is None:
        return "none"
    name = {"solid": "solid sphere", "shell": "thin shell"}.get(str(attrs.get("rolling")))
    return f"{name}, j = {float(j):.4g}" if name else f"j = {float(j):.4g}"


def summarize(
    ds: xr.Dataset | RunArrays, twin: xr.Dataset | RunArrays | None = None, v0: float = V0
) -> Summary:
    """All derived quantities of a run, and of its tau + 1e-3 twin if given.

    Parameters
    ----------
    ds : xarray.Dataset
        A run, as `simulate` returns it.
    twin : xarray.Dataset, optional
        The same scene run with tau + TWIN_TAU_OFFSET, for the chaos verdict
        when the run has no measured Lyapunov exponent.
    v0 : float
        Drift speeds below this (a0 per period) count as no drift.

    Returns
    -------
    Summary
        Drift velocities, contact fraction, rebound pattern, regime, chaos
        verdict and the run's costs.

    Raises
    ------
    ValueError
        If the twin comes from another model, or rolls otherwise (a
        comparison run of another particle is not a twin).
    """
    model = ds.attrs.get("model")
    if twin is not None and twin.attrs.get("model") != model:
        raise ValueError(f"the chaos twin must be a {model} run, got {twin.attrs.get('model')}")
    if twin is not None and twin.attrs.get("inertia_ratio") != ds.attrs.get("inertia_ratio"):
        raise ValueError(
            f"the chaos twin must roll as the run does (j = "
            f"{ds.attrs.get('inertia_ratio')}), got j = "
            f"{twin.attrs.get('inertia_ratio')}"
        )
    t_to, _ = _events(ds, R.TAKEOFF)
    t_end = float(ds["time"].values[-1])
    tw = t_end * (1.0 - FINAL_FRACTION)
    v = drift_velocity(ds)
    v_final = final_drift_velocity(ds)
    jumping = t_to.size > 0
    pattern = rebound_pattern(ds)
    twin_chaotic = None if twin is None else chaos_verdict(ds, twin, v0=v0)
    lyapunov, chaotic = lyapunov_verdict(ds)
    if chaotic is None:
        chaotic = twin_chaotic
    steady, steady_words = steadiness(ds, v0=v0, chaotic=chaotic)
    if jumping and chaotic:
        pattern = "chaotic"
    launch = launch_time(ds)  # a launched run's take-offs are no rebound pattern
    landing = None
    if launch is not None:
        pattern = "launched"
        landing = earliest_landing(ds)
    # a run that starts in flight and never lands has no take-off event
    contact = "jumping" if jumping or launch is not None else "permanent"
    verdict = regime(contact, pattern, chaotic, v, v_final, launch, landing, t_end, v0, lyapunov)
    rolls = rolling_words(ds.attrs)
    if rolls != "none":
        verdict += f"; rolls ({rolls})"
    return Summary(
        drift_velocity=v,
        final_drift_velocity=v_final,
        contact=contact,
        drift=drift_class(v, v0),
        pattern=pattern,
        chaotic=chaotic,
        divergence_time=None if twin is None else divergence_time(ds, twin),
        takeoffs=int(t_to.size),
        takeoffs_per_period=float(np.sum(t_to >= tw) / (t_end - tw)),
        takeoff_phase_spread=phase_spread(takeoff_phases(ds, tw)),
        contact_fraction=contact_fraction(ds),
        steps=int(ds.attrs.get("steps", 0)),
        seconds=float(ds.attrs.get("seconds", 0.0)),
        model=model,
        regime=verdict,
        launched=launch is not None,
        launch_time=launch,
        earliest_landing=landing,
        twin_steps=int(twin.attrs.get("steps", 0)) if twin is not None else 0,
        twin_seconds=float(twin.attrs.get("seconds", 0.0)) if twin is not None else 0.0,
        lyapunov=lyapunov,
        twin_chaotic=twin_chaotic,
        steady=steady,
        steadiness=steady_words,
        rolling=rolls,
        max_episode_roll=(
            None if ds.attrs.get("max_episode_roll") is None else float(ds.attrs["max_episode_roll"])
        ),
    )
