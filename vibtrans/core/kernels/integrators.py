"""Time stepping shared by the contact models.

Two one-force-evaluation-per-step methods (the memory diagram must be updated
once per committed step, never inside trial stages; docs/MODEL.md section 2):

* AB4 - explicit 4th-order Adams-Bashforth, the paper's method:
  z_{n+1} = z_n + h/24 (55 F_n - 59 F_{n-1} + 37 F_{n-2} - 9 F_{n-3}).
* Verlet - velocity Verlet, symplectic, 2nd order, the DEM standard.

Free flight is a parabola, integrated in closed form; the landing is the
first root of the gap a*(t) = y*(t) - u_y*(t), bracketed by steps that are
provably too short to jump over a crossing and refined by the Illinois
method.  After a landing the multistep history is filled from the parabola
(the force is C1 at a* = 0 since N* = a*^(3/2)), so AB4 restarts at full
order without a Runge-Kutta starter.
"""

import math

import numpy as np

from vibtrans.core.kernels.jit import helper, kernel
from vibtrans.core.kernels.substrate import TWO_PI, vertical_displacement

AB4 = 0
VERLET = 1
INTEGRATORS = {"ab4": AB4, "verlet": VERLET}


@helper
def ab4_increment(hist: np.ndarray, k: int, h: float) -> float:
    """h/24 (55 F_n - 59 F_{n-1} + 37 F_{n-2} - 9 F_{n-3}) for component k.

    hist[j, k] holds F_{n-j}.
    """
    return h / 24.0 * (55.0 * hist[0, k] - 59.0 * hist[1, k] + 37.0 * hist[2, k] - 9.0 * hist[3, k])


@helper
def push_history(hist: np.ndarray, f0: float, f1: float, f2: float, f3: float) -> None:
    """Shift the derivative history and store F_{n+1} = (f0, f1, f2, f3)."""
    for j in range(3, 0, -1):
        for k in range(4):
            hist[j, k] = hist[j - 1, k]
    hist[0, 0] = f0
    hist[0, 1] = f1
    hist[0, 2] = f2
    hist[0, 3] = f3


@helper
def flight_gap(t: float, t0: float, y0: float, vy0: float, m: float, amplitude: float, tau: float) -> float:
    """a*(t) = y*(t) - u_y*(t) on the free-flight parabola from (t0, y0, vy0)."""
    s = t - t0
    return y0 + vy0 * s + 0.5 * s * s / m - vertical_displacement(t, amplitude, tau)


@kernel
def find_landing(
    t0: float,
    y0: float,
    vy0: float,
    m: float,
    amplitude: float,
    tau: float,
    t_from: float,
    t_limit: float,
    dt_min: float,
) -> float:
    """First time in (t_from, t_limit] where the flight gap turns positive.

    Returns -1.0 if the particle is still in flight at t_limit.  Each bracket
    step is bounded from a Taylor bound on the gap, so no crossing deeper than
    dt_min is skipped; long flights high above the substrate cost a handful
    of steps.
    """
    # Bounds on the substrate's vertical speed and acceleration (ramp included).
    ramp_v = 0.0
    ramp_a = 0.0
    if tau > 0.0:
        ramp_v = 1.0 / tau
        ramp_a = 11.0 / tau + 2.0 / (tau * tau)
    vsub = amplitude * (TWO_PI + ramp_v)
    asub = amplitude * (TWO_PI * TWO_PI + ramp_a) + 1.0 / m
    t = t_from
    # Skip the part of the parabola provably above the substrate's top (y < -A).
    c0 = y0 + amplitude + vy0 * (t - t0) + 0.5 * (t - t0) ** 2 / m
    if c0 < 0.0:
        vy = vy0 + (t - t0) / m
        disc = vy * vy - 2.0 * c0 / m
        t_skip = t + m * (-vy + math.sqrt(disc))
        if t_skip > t:
            t = t_skip
    if t >= t_limit:
        return -1.0
    g = flight_gap(t, t0, y0, vy0, m, amplitude, tau)
    while True:
        if g > 0.0:
            return t  # already touching (grazing start)
        vy = abs(vy0 + (t - t0) / m)
        rate = vy + vsub
        dt = 2.0 * (-g) / (rate + math.sqrt(rate * rate + 2.0 * asub * (-g)))
        if not dt >= dt_min:  # also a NaN (overflowed scene): bounded steps
            dt = dt_min
        t1 = t + dt
        if t1 > t_limit:
            t1 = t_limit
        g1 = flight_gap(t1, t0, y0, vy0, m, amplitude, tau)
        if g1 > 0.0:
            return _illinois(t, g, t1, g1, t0, y0, vy0, m, amplitude, tau)
        if t1 >= t_limit:
            return -1.0
        t = t1
        g = g1


@kernel
def _illinois(ta, ga, tb, gb, t0, y0, vy0, m, amplitude, tau):
    """Root of the flight gap in [ta, tb] with ga <= 0 < gb (returns a t with
    gap >= 0, within a few ulps of the root)."""
    side = 0
    for _ in range(100):
        if tb - ta <= 4e-16 * (1.0 + abs(tb)):
            break
        tc = (ta * gb - tb * ga) / (gb - ga)
        if not (ta < tc < tb):
            tc = 0.5 * (ta + tb)
        gc = flight_gap(tc, t0, y0, vy0, m, amplitude, tau)
        if gc > 0.0:
            tb = tc
            gb = gc
            if side == 1:
                ga *= 0.5
            side = 1
        else:
            ta = tc
            ga = gc
            if side == -1:
                gb *= 0.5
            side = -1
    return tb
