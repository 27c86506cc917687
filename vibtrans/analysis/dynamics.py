"""The vertical motion as a dynamical system (docs/DYNAMICS.md): after the
ramp, m* y'' = 1 - N*(y* - u_y*(t)) is a forced oscillator whose
stroboscopic map P: (y*, y*') at t = k -> t = k + 1 is area preserving; the
vertical kernel's tangent map gives its Jacobian.  The wave is on from t = 0
(tau = 0), so P is the post-ramp map of any tau.  A state at an integer time
starts the kernel: in flight directly, in contact with the multistep history
integrated backwards by RK4 (`_contact_history`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from vibtrans.core import drivers
from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import time_step
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels.contact import LAW_K1, law_eval, law_scales
from vibtrans.core.kernels.substrate import TWO_PI
from vibtrans.core.params import Scene

if TYPE_CHECKING:
    import numpy.typing as npt
    import xarray as xr

RK4_SUBSTEPS = 16  # per step of the backward history integration
SHOOTING_TOL = 1e-10  # Newton's stop: |P^k(z) - z| below this (a0, a0/period)
SHOOTING_ITERATIONS = 40


def _field(t, z, A, m, law=None):
    """d/dt of (y, y', dy, dy'): the vertical equation and its variational one
    (law: a profile's kernel law, None: Hertz)."""
    y, vy, dy, dvy = z
    a = y - A * math.cos(TWO_PI * t)
    if law is not None:
        n, dn = law_eval(law, a) if a > 0.0 else (0.0, 0.0)
    else:
        n, dn = (a * math.sqrt(a), 1.5 * math.sqrt(a)) if a > 0.0 else (0.0, 0.0)
    return np.array([vy, (1.0 - n) / m, dvy, -dn * dy / m])


def _rk4(t, z, dt, A, m, law=None):
    k1 = _field(t, z, A, m, law)
    k2 = _field(t + 0.5 * dt, z + 0.5 * dt * k1, A, m, law)
    k3 = _field(t + 0.5 * dt, z + 0.5 * dt * k2, A, m, law)
    k4 = _field(t + dt, z + dt * k3, A, m, law)
    return z + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def _contact_history(t, y, vy, d, h, A, m, law=None):
    """The AB4 histories (state's [4, 4], tangent's [4, 2]) of the solution
    through (y, vy), tangent d at t: F at t, t - h, t - 2h, t - 3h."""
    hist = np.zeros((4, 4))
    thist = np.zeros((4, 2))
    z = np.array([y, vy, d[0], d[1]])
    dt = -h / RK4_SUBSTEPS
    tj = t
    for j in range(4):
        f = _field(tj, z, A, m, law)
        hist[j, 2], hist[j, 3] = f[0], f[1]
        thist[j] = f[2], f[3]
        for _ in range(RK4_SUBSTEPS):
            z = _rk4(tj, z, dt, A, m, law)
            tj += dt
        tj = t - (j + 1) * h  # no drift of the time from the substeps
    return hist, thist


class Strobe(NamedTuple):
    """The image of a point after `periods` periods and its Jacobian d(y, y')/d(y0, y0')."""

    y: float
    vy: float
    jacobian: np.ndarray


def _params(amplitude, mass, fidelity, t_end, law=None):
    h = time_step(amplitude, mass, fidelity, scales=None if law is None else law_scales(law))
    return D.kernel_params(amplitude, mass, 0.3, 1.2, 0.0, 0.0, h, t_end, 1e9), h


def strobe(
    amplitude: float,
    mass: float,
    y: Any,
    vy: Any,
    periods: float = 1,
    fidelity: str = "standard",
    t0: float = 0.0,
    law: Any = None,
) -> Strobe:
    """P^periods(y, vy) from the integer time t0 with its Jacobian (a kernel run
    per column); law: drivers.scene_law(scene) (None: the sphere)."""
    p, h = _params(amplitude, mass, fidelity, t0 + periods, law)
    gap = y - amplitude * math.cos(TWO_PI * t0)
    columns = []
    end: Any = None
    fixed = dict(tangential=False, samples_capacity=16, record_rest=False, chunk_steps=None, law=law)
    for e in ((1.0, 0.0), (0.0, 1.0)):
        state, hist = D.rest_state()
        state[[D.S_T, D.S_Y, D.S_VY]] = (t0, y, vy)
        tangent = np.zeros(D.NTANGENT)
        tangent[[D.L_FROM, D.L_START, D.L_END_T]] = (t0, -1.0, -1.0)
        tangent[[D.L_DY, D.L_DVY]] = e
        in_flight = gap <= 0.0
        if in_flight:
            state[[D.S_T0, D.S_Y0, D.S_VY0]] = (t0, y, vy)
            tangent[[D.L_DY0, D.L_DVY0]] = e
        else:
            hist, thist = _contact_history(t0, y, vy, e, h, amplitude, mass, law)
            tangent[D.L_HIST : D.L_HIST + 8] = thist.ravel()
            state[D.S_GAP] = gap
        run = drivers.run_hertz(
            p, "ab4", state=state, hist=hist, tangent=tangent, in_flight=in_flight, **fixed
        )
        t_end, dy, dvy = D.tangent_at_end(run.tangent, run.state)
        columns.append((dy, dvy))
        end = _end_state(run, t_end)
    return Strobe(end[0], end[1], np.array(columns).T)


def _end_state(run, t_end):
    """(y, y') at t_end: the record interpolated there in contact, or the flight's state."""
    from vibtrans.core.kernels import records as R

    if run.samples.shape[0] and run.samples[-1, R.T_] == t_end:
        return run.samples[-1, R.Y], run.samples[-1, R.VY]
    return run.state[D.S_Y], run.state[D.S_VY]


class Orbit(NamedTuple):
    """A period-k orbit (found or not) and its Floquet multipliers."""

    found: bool
    y: float  # the section point (t = 0 mod 1), a0
    vy: float  #   and its velocity, a0 per period
    period: int
    multipliers: tuple  # complex pair (elliptic) or real pair (hyperbolic)
    trace: float  # |trace| < 2: elliptic (linearly stable), > 2 hyperbolic
    determinant: float  # 1 for an area-preserving map (a check)
    stable: bool  # elliptic
    iterations: int
    residual: float  # |P^k(z) - z| at the end


def periodic_orbit(
    amplitude: float,
    mass: float,
    guess: tuple[float, float] | np.ndarray,
    period: int = 1,
    fidelity: str = "standard",
    tol: float = SHOOTING_TOL,
    max_iterations: int = SHOOTING_ITERATIONS,
    phase: float = 0.0,
    law: Any = None,
) -> Orbit:
    """A periodic orbit of the stroboscopic map: damped Newton shooting on
    P^period (a step never more than doubles the residual).

    Parameters
    ----------
    amplitude, mass : float
        A* and m*.
    guess : tuple of float
        (y, y') to start from, e.g. `run_guess`'s.
    period : int
        The orbit's period, in wave periods.
    fidelity : str
        Time-step preset.
    tol, max_iterations : float, int
        The residual that stops the shooting; Newton steps at most.
    phase : float
        The section's time mod 1.
    law : optional
        The contact law's compiled parameters (None: the sphere's).

    Returns
    -------
    Orbit
        The orbit's point, trace, multipliers, stability and convergence.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    """
    _check_orbit_args(amplitude, mass, period)
    z = np.array(guess, dtype=float)
    s = strobe(amplitude, mass, z[0], z[1], period, fidelity, phase, law)
    r = np.array([s.y, s.vy]) - z
    it = 0
    while np.linalg.norm(r) > tol and it < max_iterations:
        it += 1
        try:
            dz = np.linalg.solve(s.jacobian - np.eye(2), -r)
        except np.linalg.LinAlgError:
            break
        lam = 1.0
        while True:
            zn = z + lam * dz
            sn = strobe(amplitude, mass, zn[0], zn[1], period, fidelity, phase, law)
            rn = np.array([sn.y, sn.vy]) - zn
            if np.linalg.norm(rn) <= 2.0 * np.linalg.norm(r) or lam < 1e-3:
                break
            lam *= 0.5
        z, s, r = zn, sn, rn
    return _orbit(z, s, r, period, it, tol)


def _orbit(z, s, r, period, iterations, tol):
    mult = tuple(complex(v) for v in np.linalg.eigvals(s.jacobian))
    trace, det = float(np.trace(s.jacobian)), float(np.linalg.det(s.jacobian))
    residual = float(np.linalg.norm(r))
    found, stable = bool(residual <= tol * 100), bool(abs(trace) < 2.0)
    return Orbit(found, float(z[0]), float(z[1]), int(period), mult, trace, det, stable, iterations, residual)


def _check_orbit_args(amplitude, mass, period):
    Scene(amplitude=amplitude, mass=mass)  # the scene's own validation
    if isinstance(period, bool) or not isinstance(period, (int, np.integer)) or not 1 <= period <= 64:
        raise InputError(f"period must be an integer in [1, 64], got {period!r}")


def rest_guess(amplitude: float, mass: float, law: Any = None) -> tuple[float, float]:
    """The small-amplitude contact orbit's section point, to first order in A*:
    y* = 1 + A* / (1 - (2 pi)^2 m* / N*'(1)), y*' = 0 (off near resonance)."""
    k1 = 1.5 if law is None else float(law[LAW_K1])
    return 1.0 + amplitude / (1.0 - TWO_PI**2 * mass / k1), 0.0


def section(
    amplitude: float,
    mass: float,
    y: Any,
    vy: Any,
    periods: Any,
    fidelity: str = "standard",
    phase: float = 0.0,
    cancel: Any = None,
    law: Any = None,
) -> np.ndarray:
    """The orbit of (y, y') under the map at `phase` mod 1: float64[periods + 1, 2],
    a kernel call per period; Cancelled between periods once `cancel` is set."""
    from vibtrans.core.errors import Cancelled

    out = np.empty((periods + 1, 2))
    out[0] = y, vy
    for k in range(periods):
        if cancel is not None and cancel.is_set():
            raise Cancelled("section cancelled")
        s = strobe(amplitude, mass, out[k, 0], out[k, 1], 1, fidelity, phase, law)
        out[k + 1] = s.y, s.vy
    return out


def run_guess(scene: Scene, periods: float | None = None) -> tuple[float, float]:
    """A starting point for `periodic_orbit`: where the scene's vertical run
    (from rest, through its ramp) ends, at an integer time.

    Parameters
    ----------
    scene : Scene
        The scene (its vertical motion is run).
    periods : float, optional
        Length of the run; None: the scene's T_obs.

    Returns
    -------
    tuple of float
        (y, y') at the run's end.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    """
    from vibtrans.core.simulate import simulate

    periods = float(math.ceil(periods or scene.periods))
    # (the vertical motion is the same whether the particle rolls or not:
    # docs/MODEL.md section 11; the vertical model takes no rolling)
    ds = simulate(scene.replace(model="vertical", rolling="none", periods=periods), samples_per_period=1)
    return float(ds["y"].values[-1]), float(ds["vy"].values[-1])


class BranchPoint(NamedTuple):
    """One point of a continued branch: log10 parameters and its orbit."""

    log_amplitude: float
    log_mass: float
    orbit: Orbit


class Branch(NamedTuple):
    """A period-k orbit continued in one parameter, with its folds (trace = 2:
    the continuation ends) and period doublings (trace = -2), interpolated."""

    parameter: str  # "amplitude" | "mass"
    points: list  # BranchPoint, in continuation order
    folds: list  # log10 parameter values
    period_doublings: list
    ended: str  # why the continuation stopped


def continue_orbit(
    log_amplitude: Any,
    log_mass: Any,
    parameter: Any,
    to: Any,
    step: Any = 0.02,
    period: Any = 1,
    guess: Any = None,
    fidelity: Any = "standard",
    profile: Any = "sphere",
    load_over_modulus: float | None = None,
) -> Branch:
    """Natural-parameter continuation of a period-k orbit along log10 A* or
    log10 m* towards `to` in `step` decades, each solve started from the
    secant prediction (the first: `guess`, else the run's end)."""
    if parameter not in ("amplitude", "mass"):
        raise InputError(f"parameter must be amplitude or mass, got {parameter!r}")
    if not (isinstance(step, float) and 1e-4 <= step <= 0.5):
        raise InputError(f"step must be a number of decades in [1e-4, 0.5], got {step!r}")
    start = log_amplitude if parameter == "amplitude" else log_mass
    n = int(math.floor(abs(to - start) / step + 1e-9))
    direction = 1.0 if to >= start else -1.0
    base = Scene(
        amplitude=10.0**log_amplitude,
        mass=10.0**log_mass,
        profile=profile,
        load_over_modulus=load_over_modulus,
    )
    law = drivers.scene_law(base)
    if guess is None:
        guess = run_guess(base)
    points: list = []
    folds: list = []
    doublings: list = []
    ended = "reached the end"
    z_prev = None
    z = np.array(guess, dtype=float)
    for i in range(n + 1):
        value = start + direction * i * step
        la, lm = (value, log_mass) if parameter == "amplitude" else (log_amplitude, value)
        orbit = periodic_orbit(10.0**la, 10.0**lm, z, period, fidelity, law=law)
        if not orbit.found:
            if points and abs(points[-1].orbit.trace - 2.0) < 0.5:
                folds.append(_crossing(points[-2:], parameter, 2.0) if len(points) > 1 else value)
                ended = "fold: the orbit vanished (trace near 2)"
            else:
                ended = "lost: Newton did not converge"
            break
        if points:
            for level, out in ((2.0, folds), (-2.0, doublings)):
                if (points[-1].orbit.trace - level) * (orbit.trace - level) < 0.0:
                    out.append(_crossing([points[-1], BranchPoint(la, lm, orbit)], parameter, level))
        points.append(BranchPoint(la, lm, orbit))
        zn = np.array([orbit.y, orbit.vy])
        z = zn if z_prev is None else 2.0 * zn - z_prev  # secant predictor
        z_prev = zn
    return Branch(parameter, points, folds, doublings, ended)


def _crossing(pair, parameter, level):
    """The parameter (log10) where the trace crosses `level` between two points."""
    key = 0 if parameter == "amplitude" else 1
    p0, p1 = (pt[key] for pt in pair)
    t0, t1 = (pt.orbit.trace for pt in pair)
    return p0 + (level - t0) * (p1 - p0) / (t1 - t0) if t1 != t0 else p0


def period_one_chart(
    log_amplitudes: npt.ArrayLike, log_masses: npt.ArrayLike, fidelity: str = "standard"
) -> xr.Dataset:
    """Where the period-1 orbit born from the contact orbit exists and is stable:
    continued upwards in A* on each m* column until Newton loses it.  A
    Dataset of `trace` (NaN: not followed), `exists`, `stable` (|trace| < 2)
    and `in_flight` (a* < 0 at the section: hopping)."""
    import xarray as xr

    la = np.asarray(log_amplitudes, dtype=float)
    lm = np.asarray(log_masses, dtype=float)
    trace = np.full((la.size, lm.size), np.nan)
    flight = np.zeros((la.size, lm.size), dtype=bool)
    for j, m in enumerate(10.0**lm):
        z = np.array(rest_guess(10.0 ** la[0], m))
        z_prev = None
        for i, A in enumerate(10.0**la):
            orbit = periodic_orbit(A, m, z, 1, fidelity)
            if not orbit.found:
                break
            trace[i, j] = orbit.trace
            flight[i, j] = orbit.y - A < 0.0
            zn = np.array([orbit.y, orbit.vy])
            z = zn if z_prev is None else 2.0 * zn - z_prev
            z_prev = zn
    exists = np.isfinite(trace)
    data = dict(trace=trace, exists=exists, stable=exists & (np.abs(trace) < 2.0), in_flight=flight)
    what = (
        "period-1 orbit continued upwards in A* from the small-amplitude contact orbit "
        "(vibtrans.analysis.dynamics.period_one_chart)"
    )
    data = {k: (("log_amplitude", "log_mass"), v) for k, v in data.items()}
    coords = {"log_amplitude": la, "log_mass": lm}
    return xr.Dataset(data, coords=coords, attrs={"fidelity": fidelity, "description": what})


class OrbitDiagram(NamedTuple):
    """Take-off phases and section points y* of runs' final periods, against
    log10 A* or log10 m* along a line."""

    parameter: str  # "amplitude" | "mass"
    values: np.ndarray  # the log10 parameter of each run
    phase_value: np.ndarray  # (flattened) the run's log10 parameter of each take-off
    phase: np.ndarray  #   and its phase, periods mod 1
    section_value: np.ndarray
    section_y: np.ndarray  # y* at the final periods' integer times (or the next step)
    final_periods: float


MAX_DIAGRAM_RUNS = 2000


def orbit_diagram(
    scene: Scene,
    parameter: Any,
    values: Any,
    final_periods: float = 100.0,
    progress: Any = None,
    cancel: Any = None,
) -> OrbitDiagram:
    """Vertical runs of `scene` at each log10 A* or m* of `values`: the
    take-off phases and section points y*(k) of their final periods."""
    from vibtrans.core.kernels import records as R
    from vibtrans.core.simulate import simulate

    if parameter not in ("amplitude", "mass"):
        raise InputError(f"parameter must be amplitude or mass, got {parameter!r}")
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or not 1 <= values.size <= MAX_DIAGRAM_RUNS or not np.isfinite(values).all():
        raise InputError(f"values must be 1 to {MAX_DIAGRAM_RUNS} finite log10 values, got {values.size}")
    if not (isinstance(final_periods, (int, float)) and 1 <= final_periods <= scene.periods):
        raise InputError(f"final_periods must be in [1, {scene.periods:g}], got {final_periods!r}")
    base = scene.replace(model="vertical", rolling="none", periods=float(math.ceil(scene.periods)))
    t0 = base.periods - final_periods
    pv, ph, sv, sy = [], [], [], []
    for n, v in enumerate(values):
        sc = base.replace(**{parameter: 10.0**v})
        if cancel is not None and cancel.is_set():
            from vibtrans.core.errors import Cancelled

            raise Cancelled("orbit diagram cancelled")
        ds = simulate(sc, samples_per_period=1, cancel=cancel)
        kind, t = ds["event_kind"].values, ds["event_time"].values
        sel = (kind == R.TAKEOFF) & (t >= t0)
        ph.append(ds["event_value"].values[sel])
        pv.append(np.full(sel.sum(), v))
        # one sample per period: the integer time, in contact the step at or after it
        time = ds["time"].values
        at = time >= t0
        sy.append(ds["y"].values[at])
        sv.append(np.full(at.sum(), v))
        if progress is not None:
            progress((n + 1) / values.size)
    return OrbitDiagram(
        parameter,
        values,
        np.concatenate(pv),
        np.concatenate(ph),
        np.concatenate(sv),
        np.concatenate(sy),
        float(final_periods),
    )
