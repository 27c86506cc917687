"""The Hertz particle kernels: the deformable particle (Hertz + Cattaneo-
Mindlin memory diagram) and its vertical-only model.

Normalized equations (docs/MODEL.md section 1):

    m* x'' = -mu T*(b*, a*, history),   m* y'' = 1 - N*(a*),
    a* = y* - u_y*(t),   theta mu b* = x* - u_x*(t).

A rolling particle (docs/MODEL.md section 11; HertzVariant.rolling) turns
under T*: j m* (omega R)' = -mu T*, so omega R - x*'/j is constant, zero
from rest, and the contact point, which the memory diagram sees, is at
(1 + 1/j) x*: theta mu b* = (1 + 1/j) x* - u_x*(t).  The state stays the
centre's; HertzParams.roll_ratio is 1/j.

One loop serves every variant (`HertzVariant`: the full model or the
vertical one, with or without the Lyapunov tangent, and the contact law's
kind), each compiled as a kernel of its own (`hertz_kernel`: a copy of the
loop whose flags are global constants, jit.specialize): the vertical kernel
(`tangential` False) has no memory diagram, no sin and no x (about half the
deformable step, `vibtrans bench`).  kernels.dispatch.KERNELS says which
variant runs a scene.  A
kernel runs until t_stop and returns, with every piece of its state in the
arrays it was given, so a caller can show progress, cancel between chunks,
and grow buffers (records.py).

Arguments:
    params  HertzParams (a NamedTuple, from `kernel_params`): the scene, the
            step and the sampling.
    state   float64[NSTATE]: current (t, x, vx, y, vy), the flight origin, and
            a rolling kernel's contact-episode extremes.
    hist    float64[4, 4]:   derivative history F = (vx, ax, vy, ay), hist[j] = F_{n-j}.

The kernel is a loop over named phases (each a helper or an inlined
function, vibtrans/core/kernels/jit.py): in flight `_sample_flight`, `_land`; in contact
`_predict`, `_advance_wave`, `_contact_force`, `_commit_step`, `_take_off`,
`_note_state`, `_record_step` (or `_record_end` for the step holding t_end).
"""

import functools
import math
from typing import NamedTuple

import numpy as np

from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import (
    FLIGHT,
    LAW_K1,
    LAW_KINDS,
    NO_WARM,
    PARTIAL_SLIP,
    SPHERE,
    law_eval,
    law_eval_warm,
    memory_steps,
)
from vibtrans.core.kernels.integrators import AB4, ab4_increment, find_landing, push_history
from vibtrans.core.kernels.jit import helper, inline, kernel, specialize, template
from vibtrans.core.kernels.substrate import RAMP_OFF, TWO_PI, ramp_exact, surface_motion, wave_motion


class HertzParams(NamedTuple):
    """The Hertz kernels' parameters (normalized units, docs/MODEL.md section 1)."""

    amplitude: float  # A*: vertical wave amplitude / a0
    mass: float  # m*
    mu: float  # friction coefficient
    theta: float  # theta = (2 - nu) / (2 (1 - nu))
    r: float  # Rayleigh ratio u_x / u_y amplitude
    tau: float  # ramp time of the wave, periods
    step: float  # h: the time step, periods
    t_end: float  # T_obs: end of the run, periods
    sample_dt: float  # coarse sampling interval, periods
    win_t0: float  # full-resolution window [win_t0, win_t1], periods
    win_t1: float  #   (empty when win_t0 > win_t1)
    shortcuts: int  # bits SHORT_* switched on
    roll_ratio: float = 0.0  # 1/j = m R^2 / I of a rolling particle (rolling kernels only)


# Shortcuts (bits of HertzParams.shortcuts); `vibtrans bench` measures
# each one's speed-up and result difference by switching it off.
SHORT_RAMP = 1  # G(t) = 1 once exp(-t^2/tau^2) < 2^-60 (t > 6.5 tau): skip exp
SHORT_ROTATION = 2  # cos, sin of 2 pi t advanced by a rotation on fixed steps
SHORTCUTS_ALL = SHORT_RAMP | SHORT_ROTATION
ROTATION_STEPS = 64  # exact cos, sin every 64 steps: rounding stays ~1e-14
# state
S_T, S_X, S_VX, S_Y, S_VY, S_T0, S_X0, S_VX0, S_Y0, S_VY0, S_GAP = range(11)
# a rolling kernel's contact episodes: the lowest and highest x* of the one
# in progress, and the largest span (highest - lowest x*) of the finished ones
S_EPISODE_LO, S_EPISODE_HI, S_EPISODE_SPAN = range(11, 14)
NSTATE = 14  # S_GAP: a* at the last committed step (locates take-offs)
MODE_CONTACT = 0
MODE_FLIGHT = 1

# tangent: the vertical motion's tangent vector (dy*, dy*') for the largest
# Lyapunov exponent (Benettin: integrated with the run's own step and
# renormalized when its norm leaves [1e-50, 1e50]; docs/MODEL.md section 4,
# "Chaos verdict").
# The normal force N*(a*) = a*^(3/2) is C1 at a* = 0, so the tangent needs no
# jump at landings or take-offs: in flight it is the free flight's
# (dy' constant), in contact m* dy'' = -N*'(a*) dy, N*' = 1.5 sqrt(a*).
(
    L_DY,
    L_DVY,
    L_DY0,
    L_DVY0,  # now; at the flight's origin
    L_FROM,  # the time the exponent is measured from (input)
    L_START,  # the first step at or after it (-1: not yet)
    L_LOG,  # sum of the renormalizations' logs
    L_LOG_START,  # L_LOG + log|d| at L_START
    L_END_T,
    L_END_DY,
    L_END_DVY,
) = range(11)  # the tangent at t_end (L_END_T < 0: not yet)
L_HIST = 11  # tangent derivative history, (dy', dy'') of F_{n-j}
NTANGENT = L_HIST + 8  #   at tangent[L_HIST + 2 j + k]
TANGENT_BIG = 1e100  # renormalize when |d|^2 leaves [1/BIG, BIG]


def kernel_params(
    amplitude,
    mass,
    mu,
    theta,
    r,
    tau,
    h,
    t_end,
    sample_dt,
    window=(math.inf, -math.inf),
    shortcuts=SHORTCUTS_ALL,
    roll_ratio=0.0,
):
    """The kernels' HertzParams (values already validated).  Every field is
    converted to float (shortcuts to int), so that one compiled variant
    serves every caller.  roll_ratio: 1/j of a rolling particle, 0 for one
    that does not turn (the kernel is chosen by it: drivers.run_hertz)."""
    return HertzParams(
        float(amplitude),
        float(mass),
        float(mu),
        float(theta),
        float(r),
        float(tau),
        float(h),
        float(t_end),
        float(sample_dt),
        float(window[0]),
        float(window[1]),
        int(shortcuts),
        float(roll_ratio),
    )


def episode_roll(state, in_contact, roll_ratio):
    """The largest rolling travel within one contact episode of a rolling
    run, in a0: the span of the rolled arc x*/j over each episode (the one
    in progress too, if `in_contact`), from the kernel's S_EPISODE_* (to
    within a step at the run's end)."""
    span = state[S_EPISODE_SPAN]
    if in_contact:
        span = max(span, state[S_EPISODE_HI] - state[S_EPISODE_LO])
    return float(span * roll_ratio)


def rest_state(y0=1.0):
    """(state, hist) of a particle at rest at y* = y0 before t = 0 (y0 = 1:
    under the static load, a* = 1, N* = 1, no force, so a zero history)."""
    state = np.zeros(NSTATE)
    state[S_Y] = y0
    state[S_GAP] = y0
    return state, np.zeros((4, 4))


def unused_memory():
    """(H, W, P, nvert, memf) for a kernel without a memory diagram (the
    vertical model, `hertz_kernel`): arrays of the right types, never read
    or written."""
    return [np.empty((0, 2)), np.empty(0), np.empty(0), np.zeros(2, dtype=np.int64), np.empty(0)]


def rest_tangent(mass, step, t_from, stiffness=1.5):
    """The tangent of a particle at rest (`rest_state`) for a run that
    measures the Lyapunov exponent from t_from (periods): d = (dy*, dy*') =
    (1, 0), with the derivative history of the small oscillation about rest
    that it starts, dy = cos(w t), w = sqrt(N*'(1) / m*) (stiffness N*'(1):
    1.5 for the sphere)."""
    tangent = np.zeros(NTANGENT)
    tangent[L_DY] = 1.0
    tangent[L_FROM] = t_from
    tangent[L_START] = -1.0
    tangent[L_END_T] = -1.0
    w = math.sqrt(stiffness / mass)
    for j in range(4):
        tangent[L_HIST + 2 * j] = w * math.sin(w * j * step)
        tangent[L_HIST + 2 * j + 1] = -w * w * math.cos(w * j * step)
    return tangent


def tangent_at_end(tangent, state):
    """(t, dy*, dy*') of a run's tangent at its end: at t_end, interpolated
    inside the last step as the state is (`_record_end`), or where the
    kernel stopped (a flight, or a run that has not reached t_end)."""
    if tangent[L_END_T] >= 0.0:
        return tangent[L_END_T], tangent[L_END_DY], tangent[L_END_DVY]
    return state[S_T], tangent[L_DY], tangent[L_DVY]


def lyapunov_exponent(tangent, state):
    """The largest Lyapunov exponent of the vertical motion, per period,
    measured from tangent[L_START] to the run's end (`tangent_at_end`): the
    growth of log|d| over that time, renormalizations included.  NaN when
    the measurement never started, lasted under one period, or overflowed."""
    t0 = tangent[L_START]
    t_end, dy, dvy = tangent_at_end(tangent, state)
    if t0 < 0.0 or not t_end - t0 >= 1.0:
        return math.nan
    n = math.hypot(dy, dvy)
    if not (math.isfinite(n) and n > 0.0):
        return math.nan
    value = (tangent[L_LOG] + math.log(n) - tangent[L_LOG_START]) / (t_end - t0)
    return value if math.isfinite(value) else math.nan


@helper
def contact_point(x, kc, rolling):
    """A rolling particle's contact point kc x* (kc = 1 + 1/j; the same
    for velocities), else the centre's x*."""
    return kc * x if rolling else x


@helper
def _episode_end(state):
    """A contact episode ends at the take-off state[S_X0]: its span (highest
    minus lowest x*, the take-off's included) joins S_EPISODE_SPAN."""
    x_off = state[S_X0]
    span = max(state[S_EPISODE_HI], x_off) - min(state[S_EPISODE_LO], x_off)
    state[S_EPISODE_SPAN] = max(state[S_EPISODE_SPAN], span)


@helper
def _set_motion(state, x, vx, y, vy):
    """The particle's current position and velocity (state[S_X:S_VY])."""
    state[S_X] = x
    state[S_VX] = vx
    state[S_Y] = y
    state[S_VY] = vy


# --------------------------------------------------------------- flight phases
@helper
def _flight_point(state, t, m):
    """(x, vx, y, vy) at time t on the current flight parabola."""
    s = t - state[S_T0]
    return (
        state[S_X0] + state[S_VX0] * s,
        state[S_VX0],
        state[S_Y0] + state[S_VY0] * s + 0.5 * s * s / m,
        state[S_VY0] + s / m,
    )


@helper
def _record_flight(samples, ctr, state, t, p, tangential, rolling):
    """One sample row at time t of the flight (N* = T* = 0)."""
    x, vx, y, vy = _flight_point(state, t, p.mass)
    ux, uy, uxd, uyd = surface_motion(t, p.amplitude, p.r, p.tau)
    if tangential:
        scale = p.theta * p.mu
        kc = 1.0 + p.roll_ratio if rolling else 1.0
        R.record(
            samples,
            ctr,
            t,
            x,
            vx,
            y,
            vy,
            y - uy,
            (contact_point(x, kc, rolling) - ux) / scale,
            (contact_point(vx, kc, rolling) - uxd) / scale,
            0.0,
            0.0,
            FLIGHT,
            0.0,
            0.0,
        )
    else:
        R.record(samples, ctr, t, 0.0, 0.0, y, vy, y - uy, 0.0, 0.0, 0.0, 0.0, FLIGHT, 0.0, 0.0)


@helper
def _sample_flight(p, state, samples, ctr, t, t_fin, tangential, rolling):
    """Record the flight's coarse samples and full-resolution window points
    in (t, t_fin] (a flight has no steps: window points lie on the step grid
    k h).  False when `samples` is full (nothing lost: the cursors say where
    to resume)."""
    h = p.step
    w0 = p.win_t0
    w1 = p.win_t1
    cap_s = samples.shape[0]
    while True:
        tc = ctr[R.C_NEXT] * p.sample_dt
        tw = math.inf
        if w0 <= w1:
            kw = max(ctr[R.C_WNEXT], math.ceil(max(t, w0) / h))
            ctr[R.C_WNEXT] = kw
            if kw * h <= w1:
                tw = kw * h
        ts = min(tc, tw)
        if ts > t_fin:
            return True
        if ctr[R.C_NSAMP] >= cap_s:
            return False
        _record_flight(samples, ctr, state, ts, p, tangential, rolling)
        if tc <= ts:
            ctr[R.C_NEXT] += 1
        if tw <= ts:
            ctr[R.C_WNEXT] += 1


@helper
def _land(p, state, hist, nvert, memf, events, ctr, x, vx, vy, tangential, rolling):
    """Landing at t = state[S_T]: contact restarts.  The springs attach
    where the particle touches (a virgin memory diagram at b* of the
    landing point), and the multistep history is filled from the parabola
    (the force is C1 at a* = 0 since N* = a*^(3/2)), so AB4 restarts at full
    order."""
    t = state[S_T]
    h = p.step
    m = p.mass
    ux, uy, uxd, uyd = surface_motion(t, p.amplitude, p.r, p.tau)
    ctr[R.C_MODE] = MODE_CONTACT
    R.add_event(events, ctr, t, R.LANDING, t - math.floor(t))
    state[S_GAP] = 0.0
    if tangential:
        nvert[0] = 0
        nvert[1] = 0
        memf[0] = 0.0
        memf[1] = (contact_point(x, 1.0 + p.roll_ratio, rolling) - ux) / (p.theta * p.mu)
    for j in range(4):
        hist[j, 0] = vx
        hist[j, 1] = 0.0
        hist[j, 2] = vy - j * h / m
        hist[j, 3] = 1.0 / m


# -------------------------------------------------------------- contact phases
@inline
def _predict(integrator, state, hist, h):
    """Positions (and AB4 velocities) at t + h from the state at t and the
    derivative history; Verlet's velocities wait for the new force.

    `inline`: as a helper LLVM left it a call in every step, and every value
    live across a call is spilled to the stack and reloaded around it (all
    xmm registers are caller-saved): inlined, a step costs ~4 ns less in
    every Hertz kernel, and the tangent's (Lyapunov) share shrinks too."""
    if integrator == AB4:
        x1 = state[S_X] + ab4_increment(hist, 0, h)
        vx1 = state[S_VX] + ab4_increment(hist, 1, h)
        y1 = state[S_Y] + ab4_increment(hist, 2, h)
        vy1 = state[S_VY] + ab4_increment(hist, 3, h)
    else:
        x1 = state[S_X] + h * state[S_VX] + 0.5 * h * h * hist[0, 1]
        y1 = state[S_Y] + h * state[S_VY] + 0.5 * h * h * hist[0, 3]
        vx1 = 0.0
        vy1 = 0.0
    return x1, vx1, y1, vy1


@helper
def _advance_wave(t1, cw, sw, rot_left, cos_h, sin_h, rotation):
    """(cos, sin)(2 pi t1) and the steps left before they are evaluated
    afresh: a rotation by 2 pi h from their values at t1 - h while
    rot_left > 0 (SHORT_ROTATION), else math.cos, math.sin."""
    if rot_left > 0:
        c_new = cw * cos_h - sw * sin_h
        sw = sw * cos_h + cw * sin_h
        return c_new, sw, rot_left - 1
    return math.cos(TWO_PI * t1), math.sin(TWO_PI * t1), rotation


@helper
def _substrate_at(t1, cw, sw, t_flat, p):
    """Surface displacement and velocity (ux, uy, uxd, uyd) at t1 from the
    wave's phase; beyond t_flat the ramp G is 1 to machine precision."""
    if t1 >= t_flat:
        g = 1.0
        g1 = 0.0
    else:
        g, g1 = ramp_exact(t1, p.tau)
    return wave_motion(cw, sw, g, g1, p.amplitude, p.r)


@template(inline)
def _contact_force(H, W, Pm, nvert, memf, x1, y1, ux, uy, inv_scale, law, warm, roll_ratio):
    """Hertz's N* = a*^(3/2) (or the profile's law, `law_kind`) and the
    memory diagram's committed T* at the step end (docs/MODEL.md sections 2,
    10).  Returns (a*, c1, N*, b*, T*, s_h, contact state, warm): c1 = sqrt(a*)
    for the sphere, N*'(a*) with a profile (0 off contact); warm: the
    profile's warm-start histories (law_eval_warm) at a* and at the stick
    edge, a pair the kernel carries from step to step.  roll_ratio: a
    rolling particle's 1/j (its contact point is at (1 + 1/j) x*)."""
    a1 = y1 - uy
    c1 = 0.0  # contact radius sqrt(a*) (profile: N*'(a*))
    nf = 0.0  # Hertz: N* = a*^(3/2)
    wa, ws = warm
    if a1 > 0.0:
        if law_kind != SPHERE:
            nf, c1, wa = law_eval_warm(law, a1, wa, 0.0, law_kind)
        else:
            c1 = math.sqrt(a1)
            nf = a1 * c1
    if tangential:
        b1 = ((x1 * (1.0 + roll_ratio) if rolling else x1) - ux) * inv_scale
        tf, sh, st, ws = memory_commit(H, W, Pm, nvert, memf, a1, c1, b1, law, nf, ws)
    else:
        b1 = 0.0
        tf = 0.0
        sh = 0.0
        st = 1 if a1 > 0.0 else FLIGHT
    return a1, c1, nf, b1, tf, sh, st, (wa, ws)


@helper
def _commit_step(integrator, state, hist, ctr, t1, h, x1, vx1, y1, vy1, tf, nf, a1, mu_m, inv_m):
    """Accelerations from the new forces, Verlet's velocities, the history
    shift and the new state at t1.  Returns (vx1, vy1, a* before the step)."""
    ax1 = -mu_m * tf
    ay1 = (1.0 - nf) * inv_m
    if integrator != AB4:
        vx1 = state[S_VX] + 0.5 * h * (hist[0, 1] + ax1)
        vy1 = state[S_VY] + 0.5 * h * (hist[0, 3] + ay1)
    push_history(hist, vx1, ax1, vy1, ay1)
    ctr[R.C_STEPS] += 1
    ctr[R.C_FEVALS] += 1
    a0 = state[S_GAP]
    state[S_GAP] = a1
    state[S_T] = t1
    _set_motion(state, x1, vx1, y1, vy1)
    return vx1, vy1, a0


@helper
def _take_off(state, hist, ctr, t, t1, h, a0, a1, xo, vxo, yo, vyo, m):
    """Take-off between t and t1.  The step extrapolated contact forces past
    a* = 0; instead leave on the flight parabola from the gap's zero, reached
    from the state at t under the force at t (small: N* = a*^(3/2) near
    a* = 0).  Returns the state (x, vx, y, vy) at t1 on that parabola."""
    d = h * a0 / (a0 - a1) if a0 > 0.0 else 0.0
    axo = hist[1, 1]
    ayo = hist[1, 3]
    ctr[R.C_MODE] = MODE_FLIGHT
    state[S_T0] = t + d
    state[S_X0] = xo + vxo * d + 0.5 * axo * d * d
    state[S_VX0] = vxo + axo * d
    state[S_Y0] = yo + vyo * d + 0.5 * ayo * d * d
    state[S_VY0] = vyo + ayo * d
    x1, vx1, y1, vy1 = _flight_point(state, t1, m)
    _set_motion(state, x1, vx1, y1, vy1)
    return x1, vx1, y1, vy1


@helper
def _note_state(events, ctr, state, t1, st):
    """Events of a change of contact state at t1 (with the take-off time
    itself when the particle left)."""
    if st != ctr[R.C_STATE]:
        if st == FLIGHT:
            tto = state[S_T0]
            R.add_event(events, ctr, tto, R.TAKEOFF, tto - math.floor(tto))
        R.add_event(events, ctr, t1, R.STATE_CHANGE, st)
        ctr[R.C_STATE] = st


@helper
def _hermite(p0, v0, p1, v1, h, s):
    """Cubic Hermite interpolant of a step at t0 + s h (0 <= s <= 1): value
    and slope from the values and slopes at both ends (error O(h^4))."""
    s2 = s * s
    s3 = s2 * s
    p = (
        (2.0 * s3 - 3.0 * s2 + 1.0) * p0
        + (s3 - 2.0 * s2 + s) * h * v0
        + (3.0 * s2 - 2.0 * s3) * p1
        + (s3 - s2) * h * v1
    )
    v = (6.0 * s2 - 6.0 * s) * (p0 - p1) / h + (3.0 * s2 - 4.0 * s + 1.0) * v0 + (3.0 * s2 - 2.0 * s) * v1
    return p, v


@helper
def _record_end(
    samples,
    ctr,
    p,
    state,
    st,
    sh,
    tf,
    t0,
    x0,
    vx0,
    y0,
    vy0,
    t1,
    x1,
    vx1,
    y1,
    vy1,
    tangential,
    law,
    law_kind,
    rolling,
):
    """Record the state at t_end, inside the last step (t0, t1]: positions
    and velocities exact on a flight parabola, else Hermite-interpolated;
    a*, b*, b*', N* from them and the exact substrate motion at t_end; the
    contact state, the stick radius and T* are the step end's (held to
    s <= c and Coulomb's |T*| <= N* at t_end).

    x*(T_obs) / T_obs is the drift: the record ends at T_obs exactly, not up
    to a step later (in contact x* follows u_x*, so a later end moves x* by
    up to 2 pi A* r h)."""
    t_end = p.t_end
    if st == FLIGHT and state[S_T0] <= t_end:
        x, vx, y, vy = _flight_point(state, t_end, p.mass)
    else:
        s = (t_end - t0) / (t1 - t0)
        x, vx = _hermite(x0, vx0, x1, vx1, t1 - t0, s)
        y, vy = _hermite(y0, vy0, y1, vy1, t1 - t0, s)
    ux, uy, uxd, uyd = surface_motion(t_end, p.amplitude, p.r, p.tau)
    a = y - uy
    if law_kind != SPHERE:
        nf, c = law_eval(law, a) if a > 0.0 else (0.0, 0.0)
        c = c / law[LAW_K1]  # contact radius / the static one
        stick = min(law_eval(law, sh)[1] / law[LAW_K1], c) if sh > 0.0 and st != FLIGHT else 0.0
    else:
        c = math.sqrt(a) if a > 0.0 else 0.0
        stick = min(math.sqrt(sh), c) if sh > 0.0 and st != FLIGHT else 0.0
        nf = a * c
    if tangential:
        scale = p.theta * p.mu
        kc = 1.0 + p.roll_ratio if rolling else 1.0
        R.record(
            samples,
            ctr,
            t_end,
            x,
            vx,
            y,
            vy,
            a,
            (contact_point(x, kc, rolling) - ux) / scale,
            (contact_point(vx, kc, rolling) - uxd) / scale,
            nf,
            max(-nf, min(tf, nf)),
            st,
            stick,
            c,
        )
    else:
        R.record(samples, ctr, t_end, 0.0, 0.0, y, vy, a, 0.0, 0.0, nf, 0.0, st, 0.0, c)


@inline
def _stick_stiffness(H, nvert, st, sh, a1, c1):
    """A profile's N*'(s_h) at the step end, for its record: in partial slip
    the stick edge's vertex, just below the top one (contact._clamp: (s_h,
    N*'(s_h), N*(s_h))), in full stick (s_h = a*) N*'(a*) = c1, else 0."""
    if st == PARTIAL_SLIP:
        return H[nvert[0] - 2, 1]
    if sh > 0.0 and sh == a1 and st != FLIGHT:
        return c1
    return 0.0


@helper
def _record_step(
    samples,
    ctr,
    t1,
    x1,
    vx1,
    y1,
    vy1,
    a1,
    b1,
    uxd,
    nf,
    tf,
    st,
    sh,
    c1,
    scale,
    tangential,
    law,
    law_kind,
    kc,
    rolling,
):
    """One sample row at the step end t1 (contact and stick radii in units
    of the static contact radius).  c1: N*'(a1) of the step's contact force
    (a profile's; in contact, st != FLIGHT, it is law_eval's at a1).  sh:
    the stick core's depth s_h (the sphere) or, with a profile, its N*'(s_h)
    (`_stick_stiffness`, from the memory): no law evaluated twice."""
    if law_kind != SPHERE:
        k = 0.0
        if a1 > 0.0:
            k = c1 if st != FLIGHT else law_eval(law, a1)[1]
        c = k / law[LAW_K1]
        s = sh / law[LAW_K1]
    else:
        c = math.sqrt(a1) if a1 > 0.0 else 0.0
        s = math.sqrt(sh) if sh > 0.0 else 0.0
    bd = (contact_point(vx1, kc, rolling) - uxd) / scale if tangential else 0.0
    R.record(samples, ctr, t1, x1, vx1, y1, vy1, a1, b1, bd, nf, tf, st, s, c)


@helper
def _room_for_step(samples, events, H, nvert, ctr, tangential):
    """DONE if the buffers hold one more step's records (a sample, three
    events, three memory vertices), else the status that grows the full one."""
    if ctr[R.C_NSAMP] >= samples.shape[0]:
        return R.SAMPLES_FULL
    if ctr[R.C_NEVT] + 3 > events.shape[0]:
        return R.EVENTS_FULL
    if tangential and nvert[0] + 3 > H.shape[0]:
        return R.MEMORY_FULL
    return R.DONE


# -------------------------------------------------------------- tangent phases
@helper
def _tangent_norm(tangent):
    """Renormalize the tangent (vector, flight origin, history) to |d| = 1
    when |d|^2 leaves [1/TANGENT_BIG, TANGENT_BIG], adding log|d| to L_LOG."""
    n2 = tangent[L_DY] * tangent[L_DY] + tangent[L_DVY] * tangent[L_DVY]
    if TANGENT_BIG >= n2 >= 1.0 / TANGENT_BIG:
        return
    if not n2 > 0.0:  # zero or NaN (an overflowed scene): leave it
        return
    tangent[L_LOG] += 0.5 * math.log(n2)
    inv = 1.0 / math.sqrt(n2)
    for i in range(L_DVY0 + 1):
        tangent[i] *= inv
    if tangent[L_END_T] >= 0.0:
        tangent[L_END_DY] *= inv
        tangent[L_END_DVY] *= inv
    for i in range(L_HIST, NTANGENT):
        tangent[i] *= inv


@helper
def _tangent_mark(tangent, t, dy, dvy):
    """Note where the exponent is measured from: the first tangent update at
    or after tangent[L_FROM] (the caller checks that, `_tangent_marking`);
    (dy, dvy): the tangent at t."""
    tangent[L_START] = t
    n2 = dy * dy + dvy * dvy
    tangent[L_LOG_START] = tangent[L_LOG] + 0.5 * math.log(n2)


@helper
def _tangent_marking(tangent):
    """(still to mark, the time to mark from): `_tangent_mark` is due at the
    first contact step ending at or after that time, if still to mark."""
    return tangent[L_START] < 0.0, tangent[L_FROM]


@helper
def _tangent_mark_in_flight(tangent, t_origin, t_fin):
    """`_tangent_mark` for a flight from t_origin to t_fin: the measurement
    starts at tangent[L_FROM] itself if the flight spans it (on the flight,
    the tangent at any time is known in closed form)."""
    if tangent[L_START] < 0.0 and t_fin >= tangent[L_FROM]:
        t = max(tangent[L_FROM], t_origin)
        dy = tangent[L_DY0] + tangent[L_DVY0] * (t - t_origin)
        dvy = tangent[L_DVY0]
        tangent[L_START] = t
        tangent[L_LOG_START] = tangent[L_LOG] + 0.5 * math.log(dy * dy + dvy * dvy)


@helper
def _tangent_load(tangent):
    """The tangent's hot values, which the contact steps keep in locals:
    (dy, dy', the derivative history dh, dh[2 j + k] = tangent[L_HIST + 2 j + k]).
    Why: as array elements they were loaded and stored at every step (the
    history shifted in memory), which LLVM cannot drop since `tangent` might
    alias the other arrays; in locals the shift is a renaming (~1 ns a step
    of the deformable kernel, `vibtrans bench`)."""
    k = L_HIST
    return (
        tangent[L_DY],
        tangent[L_DVY],
        (
            tangent[k],
            tangent[k + 1],
            tangent[k + 2],
            tangent[k + 3],
            tangent[k + 4],
            tangent[k + 5],
            tangent[k + 6],
            tangent[k + 7],
        ),
    )


@helper
def _tangent_store(tangent, dy, dvy, dh):
    """Write the hot values (`_tangent_load`) back, for the phases that work
    in the array: flights, renormalizations, the caller."""
    tangent[L_DY] = dy
    tangent[L_DVY] = dvy
    for i in range(8):
        tangent[L_HIST + i] = dh[i]


@helper
def _tangent_step(integrator, dy, dvy, dh, h, c1, inv_m, law_kind):
    """One committed contact step of the tangent, with the run's integrator:
    m* dy'' = -1.5 sqrt(a*) dy at the step end (c1 = sqrt(a*), 0 off contact;
    with a profile m* dy'' = -N*'(a*) dy, c1 = N*'(a*)).
    Returns the new (dy, dy', dh)."""
    if integrator == AB4:
        dy1 = dy + h / 24.0 * (55.0 * dh[0] - 59.0 * dh[2] + 37.0 * dh[4] - 9.0 * dh[6])
        dvy1 = dvy + h / 24.0 * (55.0 * dh[1] - 59.0 * dh[3] + 37.0 * dh[5] - 9.0 * dh[7])
        dacc1 = -c1 * dy1 * inv_m if law_kind != SPHERE else -1.5 * c1 * dy1 * inv_m
    else:
        dy1 = dy + h * dvy + 0.5 * h * h * dh[1]
        dacc1 = -c1 * dy1 * inv_m if law_kind != SPHERE else -1.5 * c1 * dy1 * inv_m
        dvy1 = dvy + 0.5 * h * (dh[1] + dacc1)
    return dy1, dvy1, (dvy1, dacc1, dh[0], dh[1], dh[2], dh[3], dh[4], dh[5])


@helper
def _tangent_norm_hot(tangent, dy, dvy, dh):
    """`_tangent_norm` for the hot values in locals: the test in registers;
    a renormalization (rare) goes through the array.  Returns (dy, dy', dh)."""
    n2 = dy * dy + dvy * dvy
    if TANGENT_BIG >= n2 >= 1.0 / TANGENT_BIG:
        return dy, dvy, dh
    _tangent_store(tangent, dy, dvy, dh)
    _tangent_norm(tangent)
    return _tangent_load(tangent)


@helper
def _tangent_take_off(tangent, d, dyo, dvyo, dacco, t0, t1):
    """The tangent at the take-off d after the step's start (as the state:
    from the values at the step's start under the derivative there, dacco,
    which the history's second row now holds): the flight's origin, in the
    array; returns the tangent (dy, dy') on the flight at t1."""
    dy0 = dyo + dvyo * d + 0.5 * dacco * d * d
    dvy0 = dvyo + dacco * d
    tangent[L_DY0] = dy0
    tangent[L_DVY0] = dvy0
    return dy0 + dvy0 * (t1 - t0), dvy0


@helper
def _tangent_end(tangent, state, st, t_end, t0, dyo, dvyo, t1, dy1, dvy1, dh):
    """The tangent at t_end inside the last step (t0, t1], as `_record_end`
    takes the state: on the flight parabola, else cubic Hermite from the
    values and slopes at both ends ((dy1, dvy1) at t1, slopes in dh)."""
    if st == FLIGHT and state[S_T0] <= t_end:
        dy = tangent[L_DY0] + tangent[L_DVY0] * (t_end - state[S_T0])
        dvy = tangent[L_DVY0]
    else:
        dacc1 = 0.0 if st == FLIGHT else dh[1]
        s = (t_end - t0) / (t1 - t0)
        dy, _ = _hermite(dyo, dvyo, dy1, dvy1, t1 - t0, s)
        dvy, _ = _hermite(dvyo, dh[3], dvy1, dacc1, t1 - t0, s)
    tangent[L_END_T] = t_end
    tangent[L_END_DY] = dy
    tangent[L_END_DVY] = dvy


@helper
def _tangent_flight(tangent, s, landed):
    """The tangent s after the flight's origin (dy' constant in flight);
    at a landing its history is the flight's (dy'' = 0), as the state's."""
    tangent[L_DY] = tangent[L_DY0] + tangent[L_DVY0] * s
    tangent[L_DVY] = tangent[L_DVY0]
    if landed:
        for j in range(4):
            tangent[L_HIST + 2 * j] = tangent[L_DVY0]
            tangent[L_HIST + 2 * j + 1] = 0.0


# ------------------------------------------------------------------ the kernel
@template(kernel)
def _hertz_particle(
    p,
    integrator,
    stop_at_takeoff,
    state,
    hist,
    tangent,
    H,
    W,
    Pm,
    nvert,
    memf,
    samples,
    events,
    ctr,
    t_stop,
    law,
):
    """The Hertz particle from state[S_T] to t_stop: flights in closed form,
    contact one committed step at a time.  A template (`hertz_kernel`): its
    HertzVariant's flags are global constants of each copy, `tangential`
    (the memory diagram and x, or the vertical motion alone), `lyapunov`
    (the vertical motion's tangent advanced alongside, in `tangent`),
    `law_kind` (contact.SPHERE: Hertz's law; else the profile's `law`,
    contact.law_eval), with the law kind's `memory_commit`, and `rolling`
    (the memory diagram sees the contact point at (1 + 1/j) x*, and the
    contact episodes' extremes of x* are kept, S_EPISODE_*).  Returns a
    records.* status.

    The tangent's hot values (dy, dvy, dh: `_tangent_load`) live in locals;
    the array is current whenever the particle is in flight at the loop's
    top and when the kernel returns: the contact steps write them back at a
    take-off and at every exit, and read them back after a flight."""
    m = p.mass
    h = p.step
    t_end = p.t_end
    scale = p.theta * p.mu  # theta mu: b* = (x* - u_x*) / (theta mu)
    # multiplies, not divides, on the step's critical path (x -> b* -> T* -> x'')
    inv_scale = 1.0 / scale
    inv_m = 1.0 / m
    mu_m = p.mu / m
    final = t_stop >= t_end
    # beyond t_flat the ramp G is 1 to machine precision
    t_flat = RAMP_OFF * p.tau if p.shortcuts & SHORT_RAMP else math.inf
    rotation = ROTATION_STEPS if p.shortcuts & SHORT_ROTATION else 0
    cos_h = math.cos(TWO_PI * h)
    sin_h = math.sin(TWO_PI * h)
    cw = 1.0  # cos(2 pi t), sin(2 pi t) at the last step
    sw = 0.0
    rot_left = 0  # steps before cos, sin are evaluated afresh
    dy = 0.0  # the tangent's hot values (lyapunov)
    dvy = 0.0
    dh = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    warm = (NO_WARM, NO_WARM)  # a profile's warm starts (at a*, at the stick edge)
    marking = False  # _tangent_mark still due, at t >= t_from
    t_from = 0.0
    if lyapunov:
        dy, dvy, dh = _tangent_load(tangent)
        marking, t_from = _tangent_marking(tangent)
    while state[S_T] < t_end:
        t = state[S_T]
        if ctr[R.C_MODE] == MODE_FLIGHT:
            # ---- closed-form flight: sample it, then find the landing
            limit = t_stop if t_stop < t_end else t_end
            t_land = find_landing(state[S_T0], state[S_Y0], state[S_VY0], m, p.amplitude, p.tau, t, limit, h)
            t_fin = limit if t_land < 0.0 else t_land
            if not _sample_flight(p, state, samples, ctr, t, t_fin, tangential, rolling):
                return R.SAMPLES_FULL
            if ctr[R.C_NEVT] + 2 > events.shape[0]:
                return R.EVENTS_FULL
            x, vx, y, vy = _flight_point(state, t_fin, m)
            state[S_T] = t_fin
            _set_motion(state, x, vx, y, vy)
            if lyapunov:
                _tangent_mark_in_flight(tangent, state[S_T0], t_fin)
                _tangent_flight(tangent, t_fin - state[S_T0], t_land >= 0.0)
                _tangent_norm(tangent)
                dy, dvy, dh = _tangent_load(tangent)
                marking, t_from = _tangent_marking(tangent)
            if t_land < 0.0:
                break
            _land(p, state, hist, nvert, memf, events, ctr, x, vx, vy, tangential, rolling)
            if rolling:  # a contact episode starts
                state[S_EPISODE_LO] = x
                state[S_EPISODE_HI] = x
            rot_left = 0  # off the step grid: restart the rotation
            continue
        # ---- one committed contact step, t -> t1
        if (not final) and t + h > t_stop:
            break
        room = _room_for_step(samples, events, H, nvert, ctr, tangential)
        if room != R.DONE:
            if lyapunov:
                _tangent_store(tangent, dy, dvy, dh)
            return room
        t1 = t + h
        xo = state[S_X]
        vxo = state[S_VX]
        yo = state[S_Y]
        vyo = state[S_VY]
        x1, vx1, y1, vy1 = _predict(integrator, state, hist, h)
        cw, sw, rot_left = _advance_wave(t1, cw, sw, rot_left, cos_h, sin_h, rotation)
        ux, uy, uxd, uyd = _substrate_at(t1, cw, sw, t_flat, p)
        a1, c1, nf, b1, tf, sh, st, warm = _contact_force(
            H, W, Pm, nvert, memf, x1, y1, ux, uy, inv_scale, law, warm, p.roll_ratio
        )
        vx1, vy1, a0 = _commit_step(
            integrator, state, hist, ctr, t1, h, x1, vx1, y1, vy1, tf, nf, a1, mu_m, inv_m
        )
        dyo = 0.0
        dvyo = 0.0
        if lyapunov:
            dyo = dy
            dvyo = dvy
            dy, dvy, dh = _tangent_step(integrator, dy, dvy, dh, h, c1, inv_m, law_kind)
        if st == FLIGHT:
            x1, vx1, y1, vy1 = _take_off(state, hist, ctr, t, t1, h, a0, a1, xo, vxo, yo, vyo, m)
            a1 = y1 - uy
            b1 = (contact_point(x1, 1.0 + p.roll_ratio, rolling) - ux) / scale if tangential else 0.0
            if rolling:
                _episode_end(state)
            if lyapunov:
                dy, dvy = _tangent_take_off(tangent, state[S_T0] - t, dyo, dvyo, dh[3], state[S_T0], t1)
                _tangent_store(tangent, dy, dvy, dh)  # the flight's phases use the array
        elif rolling:
            # the contact episode's extremes, in the state array: as locals
            # they were live across the step's calls, spilled and reloaded
            # around each (a rolling step ~3% dearer, `vibtrans bench`)
            if x1 < state[S_EPISODE_LO]:
                state[S_EPISODE_LO] = x1
            elif x1 > state[S_EPISODE_HI]:
                state[S_EPISODE_HI] = x1
        if lyapunov:
            if marking and t1 >= t_from:
                _tangent_mark(tangent, t1, dy, dvy)
                marking = False
            dy, dvy, dh = _tangent_norm_hot(tangent, dy, dvy, dh)
        _note_state(events, ctr, state, t1, st)
        if final and t1 > t_end:
            _record_end(
                samples,
                ctr,
                p,
                state,
                st,
                sh,
                tf,
                t,
                xo,
                vxo,
                yo,
                vyo,
                t1,
                x1,
                vx1,
                y1,
                vy1,
                tangential,
                law,
                law_kind,
                rolling,
            )
            if lyapunov:
                _tangent_end(tangent, state, st, t_end, t, dyo, dvyo, t1, dy, dvy, dh)
        elif R.want_sample(t1, ctr, p.sample_dt, p.win_t0, p.win_t1) or (final and t1 >= t_end):
            stick = sh
            if law_kind != SPHERE and tangential:
                stick = _stick_stiffness(H, nvert, st, sh, a1, c1)
            _record_step(
                samples,
                ctr,
                t1,
                x1,
                vx1,
                y1,
                vy1,
                a1,
                b1,
                uxd,
                nf,
                tf,
                st,
                stick,
                c1,
                scale,
                tangential,
                law,
                law_kind,
                1.0 + p.roll_ratio,
                rolling,
            )
        if st == FLIGHT and stop_at_takeoff:
            break
    if lyapunov:
        _tangent_store(tangent, dy, dvy, dh)
    return R.DONE


class HertzVariant(NamedTuple):
    """What a Hertz kernel is compiled for: compile-time constants, each
    variant a kernel of its own (kernels.dispatch.KERNELS picks one)."""

    tangential: bool  # the memory diagram and x* (deformable), or y* alone (vertical)
    lyapunov: bool  # the vertical motion's tangent advanced alongside
    law_kind: int  # contact.SPHERE, PROFILE or WARM_POWER
    rolling: bool = False  # the particle turns (deformable only; HertzParams.roll_ratio)


@functools.cache
def hertz_kernel(variant):
    """The Hertz kernel of a HertzVariant, compiled on its first call (or
    loaded from the disk cache):

        kernel(params, integrator, stop_at_takeoff, state, hist, tangent,
               H, W, P, nvert, memf, samples, events, ctr, t_stop, law)

    runs the particle from state[S_T] to t_stop (or its first take-off, with
    `stop_at_takeoff`) and returns a records.* status, every array updated in
    place: `tangent` float64[NTANGENT] (`rest_tangent`), the memory diagram
    (H, W, P, nvert, memf: contact.new_memory), `law` a contact.kernel_law.
    An array the variant does not use is still passed, as any array of its
    type, never read or written: `tangent` without lyapunov, the memory in
    the vertical model (`unused_memory`), `law` for the sphere.  A lyapunov
    variant records what its plain twin records, bit for bit, and so do the
    WARM_POWER and PROFILE kernels for a warm-started power law."""
    tangential, lyapunov, law_kind, rolling = (
        bool(variant.tangential),
        bool(variant.lyapunov),
        int(variant.law_kind),
        bool(variant.rolling),
    )
    if rolling and not tangential:
        raise ValueError("a rolling kernel is a deformable one (tangential=True)")
    name = (
        f"{'deformable' if tangential else 'vertical'}{'_lyapunov' if lyapunov else ''}"
        f"_{LAW_KINDS[law_kind].replace('-', '_')}{'_rolling' if rolling else ''}"
    )
    copies = specialize(
        (_contact_force, _hertz_particle),
        name,
        tangential=tangential,
        lyapunov=lyapunov,
        law_kind=law_kind,
        rolling=rolling,
        memory_commit=memory_steps(law_kind).commit,
    )
    return copies["_hertz_particle"]
