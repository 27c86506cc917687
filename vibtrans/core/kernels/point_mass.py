"""Material point on a rigid substrate carrying a Rayleigh wave (docs/MODEL.md section 3).

Normalized units (docs/MODEL.md section 1): time in wave periods, lengths in a0, y
points DOWN (gravity +y).  The substrate surface moves as

    u_x = G(t) A r sin(2 pi t),   u_y = G(t) A cos(2 pi t)

and the point obeys  m x'' = -mu T*,  m y'' = 1 - N*.  Three states:

stick   x = u_x + const, y = u_y;  T* = -m u_x''/mu,  N* = 1 - m u_y''.
slide   y = u_y;  m x'' = -mu s N*, s = sgn(x' - u_x') = +-1,  T* = s N*.
        N*(t) = 1 - m u_y''(t) is known, so the slide has a closed form:
            v(t) = v0 - (mu s/m)(t - t0) + mu s (u_y'(t) - u_y'(t0))
            x(t) = x0 + v0 (t-t0) - (mu s/2m)(t-t0)^2
                       + mu s (u_y(t) - u_y(t0) - u_y'(t0)(t-t0))
flight  x = x0 + vx (t-t0),  y = y0 + vy (t-t0) + (t-t0)^2/(2m);  N* = T* = 0.

Nothing is time-stepped: every state is a closed form.  The kernel walks a
scan grid t = k * scan_dt, looks at the event functions at each grid point
(sign change = event), refines an event by bisection to ~1e-13 in t, applies
the transition and goes on from the event time.  The closed form is re-based
at every grid point and every event (so a call can stop there and resume with
bit-identical results).  docs/MODEL.md section 8.6.

Parameters: a `PointMassParams` (make_params), named fields in normalized
units: amplitude (A*), mass (m*), mu, theta, r, tau, alpha_t, t_end,
sample_dt, win_t0, win_t1 (the full-resolution window), scan_dt and
capture_t; times in periods.

The kernel, phase by phase (one loop turn = one scan step or one event):
`_fresh_start` (initial condition and first sample, on a fresh call only),
then until t_final: `_segment_base` (re-base the closed form at the
committed state), `_step_end` (the next scan-grid point b), `_eval` at b,
the event search on (t, b] (`_search_landing` in flight, `_search_contact`
in contact), then either `_transition` + `_commit_event` at the first event
or `_commit_step_end` at b.

Events (docs/MODEL.md section 3):
1. landing: gap a* = y - u_y reaches 0 from below.  Elastic normal impact
   (alpha_n = 1: the relative normal velocity reverses, the point flies again
   at once, LANDING + TAKEOFF at the same time) and tangential restitution
   v_rel -> alpha_t v_rel.  A sign change of the gap at the grid points alone
   would miss a landing-and-exit inside one scan step (grazing impacts); the
   landing search therefore also proves, with a second-derivative bound on the
   gap, that no crossing hides between two grid points, subdividing when it
   cannot (see `_first_bracket`).  Flights are not scanned while the point is
   above the highest reachable surface position (y < -A at both ends of a
   step: the parabola is convex), which keeps long flights cheap.
2. detachment: N* = 1 - m u_y'' < 0 in contact -> flight (TAKEOFF), with the
   point's own horizontal velocity and the substrate's vertical velocity.
3. stick -> slide: |m u_x''| > mu N*, direction s = -sgn(u_x'').
4. slide -> stick, by `stick_rule`:
   RULE_PAPER (0, default): stick as soon as |m u_x''| <= mu N*; the velocity
       jumps to the substrate's (the paper's rule, section "Dynamics of a
       material point").
   RULE_CLASSICAL (1): stick only when v_rel reaches 0 and |m u_x''| <= mu N*
       there.
   Under both rules, v_rel reaching 0 while |m u_x''| > mu N* restarts the
   slide in the direction s = -sgn(u_x'') (a reversal).

Chatter capture.  With alpha_n = 1 a point that lands almost tangentially
while N* > 0 bounces with a tiny relative speed v_n, each flight lasting about
2 m v_n / N*, and (by the adiabatic invariant of a bouncing ball) keeps doing
so: an unbounded number of events that is, in the limit, contact.  A landing
whose next flight would last less than CAPTURE_T periods is therefore taken as
the start of contact (LANDING + STATE_CHANGE), after the tangential
restitution; stick or slide then follows the stick rule.  This changes the
trajectory by less than N* CAPTURE_T^2 / (8 m) in the gap (about
5 CAPTURE_T^2 A* near the jumping line).  The price of a small CAPTURE_T is
paid just above the jumping line, where the point chatters steadily with
flights of a few CAPTURE_T: with 1e-3, up to ~400 events per period there
(e.g. 4 pi^2 m* A* - 1 ~ 3e-3).  The parameter `capture_t` (default
CAPTURE_T) sets it.

Initial condition (a fresh call: t = 0 and zero counters): x = vx = 0,
y = u_y(0), vy = u_y'(0), and the contact state that Coulomb's law (with the
stick rule) gives there: stick when tau > 0 (G(0) = 0).  The first event is
STATE_CHANGE at t = 0 with that initial state.

Counters (records.C_*): C_MODE holds the mode (MODE_* below), C_STATE the last
recorded state code (contact.FLIGHT / STICK / SLIDING), C_STEPS the scanned
steps (grid steps on which the event functions were evaluated; steps skipped
in high flights are not counted), C_FEVALS the extra event-function
evaluations (bisection and subdivision).

Chunks.  The kernel runs until t = min(t_stop, t_end) exactly.  It returns
SAMPLES_FULL / EVENTS_FULL before writing anything it has no room for, with the
state at its last commit (a grid point or an event), so a call with a larger
buffer continues exactly as if the buffer had been large enough.  A t_stop on
the scan grid (e.g. whole periods with scan_dt = 1/64) gives results
bit-identical to a single run; an off-grid t_stop re-bases the closed form
there, which differs by rounding only.
"""

import math
from typing import NamedTuple

import numpy as np

from vibtrans.core.errors import InputError
from vibtrans.core.kernels.contact import FLIGHT, SLIDING, STICK
from vibtrans.core.kernels.jit import helper, inline, kernel
from vibtrans.core.kernels.records import (
    C_FEVALS,
    C_MODE,
    C_NEVT,
    C_NEXT,
    C_NSAMP,
    C_STATE,
    C_STEPS,
    DONE,
    EVENTS_FULL,
    EVENTS_RUNAWAY,
    LANDING,
    SAMPLES_FULL,
    STATE_CHANGE,
    TAKEOFF,
    add_event,
    record,
    want_sample,
)
from vibtrans.core.kernels.substrate import surface_acceleration, surface_motion

# modes (ctr[C_MODE])
MODE_STICK = 0
MODE_SLIDE_POS = 1  # sliding with v_rel > 0, s = +1
MODE_SLIDE_NEG = 2  # sliding with v_rel < 0, s = -1
MODE_FLIGHT = 3
MODE_NAMES = ("stick", "slide +", "slide -", "flight")

# slide -> stick rules
RULE_PAPER = 0
RULE_CLASSICAL = 1
STICK_RULES = ("paper", "classical")

# event functions (internal); an event is phi > 0 (strict) or phi >= 0
EV_DETACH = 0  # phi = -N*                       (strict)
EV_SLIP = 1  # phi = m |u_x''| - mu N*          (strict)
EV_STICK = 2  # phi = mu N* - m |u_x''|  (paper rule, in a slide)
EV_VZERO = 3  # phi = -s v_rel          (in a slide)
EV_LAND = 4  # phi = gap a* = y - u_y  (in flight)

TOL_T = 1e-13  # event time resolution (periods)
SHORT_SEG = 1e-7  # steps shorter than this (just after an event) are not
# scanned: below it the event functions are rounding noise
H_MIN = 1e-7  # smallest subdivision of the no-hidden-crossing proof
CAPTURE_T = 1e-3  # chatter capture: a rebound flight shorter than this
# (periods) is taken as contact
STACK = 64
MAX_EVENTS_PER_STEP = 10000  # events between two scan-grid points (chatter is
# captured at ~10): more is a Zeno-like sequence at rounding
# level (an extreme scene): EVENTS_RUNAWAY, not an endless run


class PointMassParams(NamedTuple):
    """The kernel's parameters (normalized units, docs/MODEL.md section 1;
    times in wave periods), built by `make_params`."""

    amplitude: float  # A*: wave amplitude (a0)
    mass: float  # m* = a0 m f^2 / (M g)
    mu: float  # friction coefficient
    theta: float  # compliance ratio; here only the unit theta mu of b*
    r: float  # Rayleigh ratio |u_x| / |u_y| of the wave
    tau: float  # ramp time of G(t) (periods; 0: the wave is on from t = 0)
    alpha_t: float  # tangential restitution of a landing
    t_end: float  # end of the run (periods)
    sample_dt: float  # coarse sample interval (periods)
    win_t0: float  # full-resolution window [win_t0, win_t1] (periods):
    win_t1: float  #   every scan-grid point and event recorded there
    scan_dt: float  # scan grid step (periods)
    capture_t: float = CAPTURE_T  # chatter capture (periods; module doc)


# sup |d^n/dq^n exp(-q^2)| for n = 1, 2, 3: bounds of the ramp derivatives
_G1 = 0.8578
_G2 = 2.0
_G3 = 3.9036
_W = 2.0 * math.pi


def mode_state(mode):
    """Contact state code (contact.FLIGHT/STICK/SLIDING) of a mode."""
    if mode == MODE_FLIGHT:
        return FLIGHT
    if mode == MODE_STICK:
        return STICK
    return SLIDING


_mode_state = helper(mode_state)


@helper
def _sign_of(mode):
    return 1.0 if mode == MODE_SLIDE_POS else -1.0


@inline
def _eval(t, mode, seg, A, m, mu, r, tau):
    """State and substrate at t from the segment base `seg`.

    seg = (t0, x0, v0, y0, vy0, ux0, uy0, dux0, duy0).
    Returns (x, vx, y, vy, ux, uy, dux, duy, ax, ay).
    """
    ux, uy, dux, duy = surface_motion(t, A, r, tau)
    ax, ay = surface_acceleration(t, A, r, tau)
    dt = t - seg[0]
    if mode == MODE_FLIGHT:
        x = seg[1] + seg[2] * dt
        vx = seg[2]
        y = seg[3] + seg[4] * dt + dt * dt / (2.0 * m)
        vy = seg[4] + dt / m
    elif mode == MODE_STICK:
        x = seg[1] + (ux - seg[5])
        vx = dux
        y = uy
        vy = duy
    else:
        ms = mu * _sign_of(mode)
        vx = seg[2] - (ms / m) * dt + ms * (duy - seg[8])
        x = seg[1] + seg[2] * dt - (ms / (2.0 * m)) * dt * dt + ms * (uy - seg[6] - seg[8] * dt)
        y = uy
        vy = duy
    return x, vx, y, vy, ux, uy, dux, duy, ax, ay


@inline
def _phi(kind, t, mode, seg, x, vx, y, vy, ux, uy, dux, duy, ax, ay, m, mu):
    """(phi, dphi/dt, N*) of event function `kind` from the values at t.

    dphi is only computed for EV_VZERO and EV_LAND (the subdivided ones).
    v_rel and the gap are computed relative to the segment base, which keeps
    them accurate near the segment start.
    """
    nf = 1.0 - m * ay
    dt = t - seg[0]
    if kind == EV_DETACH:
        return -nf, 0.0, nf
    if kind == EV_SLIP:
        return m * abs(ax) - mu * nf, 0.0, nf
    if kind == EV_STICK:
        return mu * nf - m * abs(ax), 0.0, nf
    if kind == EV_VZERO:
        s = _sign_of(mode)
        ms = mu * s
        vrel = (seg[2] - seg[7]) - (ms / m) * dt + ms * (duy - seg[8]) - (dux - seg[7])
        return -s * vrel, (mu / m) * nf + s * ax, nf
    # EV_LAND
    gap = (seg[3] - seg[6]) + (seg[4] - seg[8]) * dt + dt * dt / (2.0 * m) - (uy - seg[6] - seg[8] * dt)
    return gap, vy - duy, nf


@helper
def _phi_at(kind, t, mode, seg, A, m, mu, r, tau):
    x, vx, y, vy, ux, uy, dux, duy, ax, ay = _eval(t, mode, seg, A, m, mu, r, tau)
    return _phi(kind, t, mode, seg, x, vx, y, vy, ux, uy, dux, duy, ax, ay, m, mu)


@helper
def _triggered(kind, phi):
    if kind == EV_DETACH or kind == EV_SLIP:
        return phi > 0.0
    return phi >= 0.0


@kernel
def _bisect(kind, lo, hi, mode, seg, A, m, mu, r, tau):
    """First time in (lo, hi] where `kind` triggers; lo untriggered, hi triggered."""
    n = 0
    while hi - lo > TOL_T:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        phi, _, _ = _phi_at(kind, mid, mode, seg, A, m, mu, r, tau)
        n += 1
        if _triggered(kind, phi):
            hi = mid
        else:
            lo = mid
    return hi, n


@helper
def _no_crossing(fa, da, fb, db, h, M):
    """True if f < 0 on (a, b] is proven, given f(a) <= 0, f(b) < 0, f'' <= M.

    f <= q1 = fa + da (t-a) + M (t-a)^2/2 and f <= q2 = fb + db (t-b) + M (t-b)^2/2;
    q1 - q2 is linear, so min(q1, q2) peaks at a, b or where q1 = q2.
    """
    hm = 0.5 * M * h * h
    d_a = fa - (fb - db * h + hm)  # (q1 - q2)(a) <= 0
    d_b = (fa + da * h + hm) - fb  # (q1 - q2)(b) >= 0
    den = d_b - d_a
    if den <= 0.0:
        return True
    lam = -d_a / den
    if lam <= 0.0 or lam >= 1.0:
        return True
    xx = lam * h
    return fa + da * xx + 0.5 * M * xx * xx < 0.0


@kernel
def _first_bracket(kind, a, fa, da, na, b, fb, db, nb, mode, seg, work, m_vz, uy3, A, m, mu, r, tau):
    """Prove that `kind` (EV_VZERO or EV_LAND) does not trigger in (a, b], or
    return the first bracket (lo, hi) with hi triggered.

    f(b) < 0 on entry.  Left-to-right subdivision with the bound on f'':
    EV_VZERO: |f''| <= A J3 (mu + r) (m_vz); EV_LAND: f'' = N*/m <= max(N*)/m
    + uy3 h / 2 (N* is Lipschitz with constant m uy3).  Intervals shorter
    than H_MIN are accepted (a crossing there would rise less than M H_MIN^2/8),
    and so are intervals where a value or the bound is not finite (scenes
    whose forces overflow: the proof would subdivide to H_MIN everywhere).
    Returns (found, lo, hi, evaluations).
    """
    n = 0
    top = 1
    work[0, 0] = b
    work[0, 1] = fb
    work[0, 2] = db
    work[0, 3] = nb
    lt = a
    lf = fa
    ld = da
    ln = na
    while top > 0:
        rt = work[top - 1, 0]
        rf = work[top - 1, 1]
        rd = work[top - 1, 2]
        rn = work[top - 1, 3]
        if _triggered(kind, rf):
            return True, lt, rt, n
        h = rt - lt
        if kind == EV_LAND:
            M = max(ln, rn) / m + 0.5 * uy3 * h
            if M < 0.0:
                M = 0.0
        else:
            M = m_vz
        # a bound or value that overflowed (an extreme scene) proves nothing
        # at any subdivision: accept the interval rather than subdivide to H_MIN
        if (
            h < H_MIN
            or top >= STACK
            or not math.isfinite(lf + ld + rf + rd + M)
            or _no_crossing(lf, ld, rf, rd, h, M)
        ):
            lt = rt
            lf = rf
            ld = rd
            ln = rn
            top -= 1
            continue
        mid = 0.5 * (lt + rt)
        phi, dphi, nf = _phi_at(kind, mid, mode, seg, A, m, mu, r, tau)
        n += 1
        work[top, 0] = mid
        work[top, 1] = phi
        work[top, 2] = dphi
        work[top, 3] = nf
        top += 1
    return False, a, b, n


@helper
def _resolve(nf, f, vrel, ax, rule):
    """Mode of a point in contact with normal force nf, stick margin
    f = mu N* - |m u_x''| and relative velocity vrel (contact start)."""
    if nf < 0.0:
        return MODE_FLIGHT
    if f >= 0.0 and (rule == RULE_PAPER or vrel == 0.0):
        return MODE_STICK
    if vrel > 0.0:
        return MODE_SLIDE_POS
    if vrel < 0.0:
        return MODE_SLIDE_NEG
    return MODE_SLIDE_NEG if ax > 0.0 else MODE_SLIDE_POS


@helper
def record_row(samples, ctr, t, x, vx, y, vy, mode, ux, uy, dux, duy, ax, ay, m, mu, tmu):
    if mode == MODE_FLIGHT:
        nf = 0.0
        tf = 0.0
        code = FLIGHT
    elif mode == MODE_STICK:
        nf = 1.0 - m * ay
        tf = -m * ax / mu
        code = STICK
    else:
        nf = 1.0 - m * ay
        tf = _sign_of(mode) * nf
        code = SLIDING
    record(samples, ctr, t, x, vx, y, vy, y - uy, (x - ux) / tmu, (vx - dux) / tmu, nf, tf, code, 0.0, 0.0)


# --------------------------------------------------------------------------- the kernel
# The kernel's phases, in the JIT policy of vibtrans.core.kernels.jit: `@helper` where
# LLVM inlines them or where they run once per call or event; the two event
# searches, run on every scan step and left as calls by LLVM (~20% slower
# runs measured), are `@inline` (one call site each).  Each phase keeps the
# floating-point operations of the former one-piece kernel in their order.
GO = -1  # a phase's status: carry on (else a records.* return code)


@helper
def _crossing_bounds(p):
    """(uy3, m_vz) for the no-hidden-crossing proof (`_first_bracket`):
    uy3 = A J3 >= |u_y'''|, m_vz = A J3 (mu + r) >= |v_rel''| in a slide,
    J3 bounding the third derivative of G(t) cos(2 pi t) (or sin) from
    sup|G^(n)| (the ramp) and (2 pi)^n (the wave)."""
    tau = p.tau
    if tau > 0.0:
        g1 = _G1 / tau
        g2 = _G2 / (tau * tau)
        g3 = _G3 / (tau * tau * tau)
    else:
        g1 = 0.0
        g2 = 0.0
        g3 = 0.0
    j3 = g3 + 3.0 * _W * g2 + 3.0 * _W * _W * g1 + _W * _W * _W
    return p.amplitude * j3, p.amplitude * j3 * (p.mu + p.r)


@helper
def _fresh_start(p, stick_rule, state, samples, events, ctr):
    """On a fresh call (t = 0, zero counters): the initial condition, its
    STATE_CHANGE event and the sample at t = 0 (module doc).  A call that
    resumes a run passes through.  Returns GO, EVENTS_FULL or SAMPLES_FULL."""
    A = p.amplitude
    m = p.mass
    mu = p.mu
    if state[0] == 0.0 and ctr[C_NEVT] == 0 and ctr[C_NSAMP] == 0 and ctr[C_STEPS] == 0:
        ux, uy, dux, duy = surface_motion(0.0, A, p.r, p.tau)
        ax, ay = surface_acceleration(0.0, A, p.r, p.tau)
        nf = 1.0 - m * ay
        # at rest horizontally: v_rel = -u_x'(0)
        mode = _resolve(nf, mu * nf - m * abs(ax), -dux, ax, stick_rule)
        state[1] = 0.0
        state[2] = dux if mode == MODE_STICK else 0.0
        state[3] = uy
        state[4] = duy
        if events.shape[0] < 1:
            return EVENTS_FULL
        ctr[C_MODE] = mode
        code = _mode_state(mode)
        add_event(events, ctr, 0.0, STATE_CHANGE, code)
        ctr[C_STATE] = code
    if state[0] == 0.0 and ctr[C_NSAMP] == 0 and ctr[C_STEPS] == 0 and ctr[C_NEXT] == 0:
        save = ctr[C_NEXT]
        if want_sample(0.0, ctr, p.sample_dt, p.win_t0, p.win_t1):
            if samples.shape[0] < 1:
                ctr[C_NEXT] = save  # no room: undo, to sample again on resume
                return SAMPLES_FULL
            ux, uy, dux, duy = surface_motion(0.0, A, p.r, p.tau)
            ax, ay = surface_acceleration(0.0, A, p.r, p.tau)
            record_row(
                samples,
                ctr,
                0.0,
                state[1],
                state[2],
                state[3],
                state[4],
                ctr[C_MODE],
                ux,
                uy,
                dux,
                duy,
                ax,
                ay,
                m,
                mu,
                p.theta * mu,
            )
    return GO


@helper
def _segment_base(state, A, r, tau):
    """The closed form's base at the committed state: (t0, x0, v0, y0, vy0,
    ux0, uy0, dux0, duy0), the point's and the surface's position and
    velocity at t0 = state[0] (see `_eval`)."""
    t = state[0]
    ux0, uy0, dux0, duy0 = surface_motion(t, A, r, tau)
    return (t, state[1], state[2], state[3], state[4], ux0, uy0, dux0, duy0)


@helper
def _step_end(t, scan_dt, t_final, t_end):
    """(b, sample_here): the end of the scan step from t, the next point
    k * scan_dt of the absolute grid, or t_final.  sample_here: b may be
    sampled (not at a t_stop off the grid before t_end: the resumed call
    samples there)."""
    kk = math.floor(t / scan_dt) + 1.0
    b = kk * scan_dt
    if b <= t:  # t / scan_dt rounded down below a grid index
        b = (kk + 1.0) * scan_dt
    sample_here = True
    if b >= t_final:
        sample_here = b == t_final or t_final == t_end
        b = t_final
    return b, sample_here


@inline
def _search_landing(b, end, mode, seg, work, uy3, m_vz, p):
    """Landing search on the flight step (seg[0], b] (event 1).

    end = `_eval` at b.  Returns (scanned, found, t_land, evaluations):
    scanned is False for a high flight (above the highest reachable surface,
    y < -A, at both ends: the parabola is convex, no landing in between).
    """
    A = p.amplitude
    m = p.mass
    mu = p.mu
    xb, vxb, yb, vyb, uxb, uyb, duxb, duyb, axb, ayb = end
    if seg[3] < -A and yb < -A:
        return False, False, b, 0
    gb, dgb, nb = _phi(EV_LAND, b, mode, seg, xb, vxb, yb, vyb, uxb, uyb, duxb, duyb, axb, ayb, m, mu)
    t = seg[0]
    _, ay0 = surface_acceleration(t, A, p.r, p.tau)
    na = 1.0 - m * ay0
    ga = seg[3] - seg[6]
    dga = seg[4] - seg[8]
    if na <= 0.0 and nb <= 0.0 and dga <= 0.0:
        # moving away with N* <= 0 (the gap is concave): no landing,
        # whatever rounding says about gb
        return True, False, b, 0
    if gb >= 0.0:
        t_land, n = _bisect(EV_LAND, t, b, mode, seg, A, m, mu, p.r, p.tau)
        return True, True, t_land, n
    # the gap is negative at both ends: prove no crossing hides in between
    found, lo, hi, n = _first_bracket(
        EV_LAND, t, ga, dga, na, b, gb, dgb, nb, mode, seg, work, m_vz, uy3, A, m, mu, p.r, p.tau
    )
    if not found:
        return True, False, b, n
    t_land, n2 = _bisect(EV_LAND, lo, hi, mode, seg, A, m, mu, p.r, p.tau)
    return True, True, t_land, n + n2


@inline
def _search_contact(b, end, mode, stick_rule, seg, work, uy3, m_vz, p):
    """Event search on the contact step (seg[0], b]: detachment and slip in
    stick; detachment, stick (paper rule) and v_rel = 0 in a slide (events
    2-4).  end = `_eval` at b.  Returns (kind, t_event, evaluations) of the
    first event, kind -1 if none."""
    A = p.amplitude
    m = p.mass
    mu = p.mu
    xb, vxb, yb, vyb, uxb, uyb, duxb, duyb, axb, ayb = end
    t = seg[0]
    nev = 0
    ev_kind = -1
    t_ev = b
    for kind in range(4):
        if mode == MODE_STICK:
            if kind != EV_DETACH and kind != EV_SLIP:
                continue
        else:
            if kind == EV_SLIP:
                continue
            if kind == EV_STICK and stick_rule != RULE_PAPER:
                continue
        phib, dphib, nb = _phi(kind, b, mode, seg, xb, vxb, yb, vyb, uxb, uyb, duxb, duyb, axb, ayb, m, mu)
        tk = b
        hit = False
        if _triggered(kind, phib):
            hit = True
            tk, n = _bisect(kind, t, b, mode, seg, A, m, mu, p.r, p.tau)
            nev += n
        elif kind == EV_VZERO:
            # v_rel may touch 0 and turn back inside the step: the proof
            ax0, ay0 = surface_acceleration(t, A, p.r, p.tau)
            na = 1.0 - m * ay0
            s = _sign_of(mode)
            phia = -s * (seg[2] - seg[7])
            dphia = (mu / m) * na + s * ax0
            found, lo, hi, n = _first_bracket(
                kind, t, phia, dphia, na, b, phib, dphib, nb, mode, seg, work, m_vz, uy3, A, m, mu, p.r, p.tau
            )
            nev += n
            if found:
                hit = True
                tk, n = _bisect(kind, lo, hi, mode, seg, A, m, mu, p.r, p.tau)
                nev += n
        if hit and (ev_kind < 0 or tk < t_ev):
            ev_kind = kind
            t_ev = tk
    return ev_kind, t_ev, nev


@helper
def _transition(ev_kind, mode, at, stick_rule, p):
    """The state just after an event of kind ev_kind (docs/MODEL.md section 3).

    at = `_eval` at the event time.  Returns (new_mode, x, vx, y, vy, ev1,
    ev2): ev1, ev2 the TAKEOFF / LANDING events to record (-1: none) besides
    the STATE_CHANGE that a change of state records.
    """
    m = p.mass
    mu = p.mu
    x, vx, y, vy, ux, uy, dux, duy, ax, ay = at
    nf = 1.0 - m * ay
    f = mu * nf - m * abs(ax)
    nx = x
    nvx = vx
    ny = uy
    nvy = duy
    new_mode = mode
    ev1 = -1
    ev2 = -1
    if ev_kind == EV_DETACH:
        # take-off with the point's own vx and the surface's vy
        new_mode = MODE_FLIGHT
        ev1 = TAKEOFF
    elif ev_kind == EV_SLIP:
        nvx = dux
        new_mode = MODE_SLIDE_NEG if ax > 0.0 else MODE_SLIDE_POS
    elif ev_kind == EV_STICK:
        nvx = dux  # the paper's rule: the velocity jumps to the surface's
        new_mode = MODE_STICK
    elif ev_kind == EV_VZERO:
        nvx = dux
        if nf < 0.0:
            new_mode = MODE_FLIGHT
            ev1 = TAKEOFF
        elif f >= 0.0:
            new_mode = MODE_STICK
        else:  # a reversal: the slide restarts against u_x''
            new_mode = MODE_SLIDE_NEG if ax > 0.0 else MODE_SLIDE_POS
    else:  # EV_LAND
        vn = abs(vy - duy)  # approach speed
        vt = p.alpha_t * (vx - dux)  # tangential restitution
        nvx = dux + vt
        ev1 = LANDING
        if nf > 0.0 and 2.0 * m * vn < p.capture_t * nf:
            # chatter capture: the rebound would fly < capture_t: contact
            new_mode = _resolve(nf, f, vt, ax, stick_rule)
            if new_mode == MODE_STICK:
                nvx = dux
            elif new_mode == MODE_FLIGHT:
                nvy = duy - vn
        else:
            nvy = duy - vn  # elastic: reverse v_n
            ev2 = TAKEOFF
    return new_mode, nx, nvx, ny, nvy, ev1, ev2


@helper
def _commit_event(te, mode, at, new, ev1, ev2, nev, p, state, samples, events, ctr):
    """Commit an event at te: the rows before and after it (inside the
    window), the new state and mode, its events, the evaluation count.

    at = `_eval` at te (the state before), new = (new_mode, x, vx, y, vy)
    after.  Checks the room first, so that a full buffer leaves everything
    at the last commit.  Returns GO, EVENTS_FULL or SAMPLES_FULL.
    """
    m = p.mass
    mu = p.mu
    tmu = p.theta * mu
    x, vx, y, vy, ux, uy, dux, duy, ax, ay = at
    new_mode, nx, nvx, ny, nvy = new
    code = _mode_state(new_mode)
    n_events = (1 if ev1 >= 0 else 0) + (1 if ev2 >= 0 else 0) + (1 if code != ctr[C_STATE] else 0)
    in_win = p.win_t0 <= te <= p.win_t1
    if ctr[C_NEVT] + n_events > events.shape[0]:
        return EVENTS_FULL
    if in_win and ctr[C_NSAMP] + 2 > samples.shape[0]:
        return SAMPLES_FULL
    if in_win:
        record_row(samples, ctr, te, x, vx, y, vy, mode, ux, uy, dux, duy, ax, ay, m, mu, tmu)
    state[0] = te
    state[1] = nx
    state[2] = nvx
    state[3] = ny
    state[4] = nvy
    ctr[C_MODE] = new_mode
    phase = te - math.floor(te)
    if ev1 >= 0:
        add_event(events, ctr, te, ev1, phase)
    if ev2 >= 0:
        add_event(events, ctr, te, ev2, phase)
    if code != ctr[C_STATE]:
        add_event(events, ctr, te, STATE_CHANGE, code)
        ctr[C_STATE] = code
    ctr[C_FEVALS] += nev
    if in_win:
        record_row(samples, ctr, te, nx, nvx, ny, nvy, new_mode, ux, uy, dux, duy, ax, ay, m, mu, tmu)
    return GO


@helper
def _commit_step_end(b, sample_here, scanned, nev, mode, end, p, state, samples, ctr):
    """Commit the eventless step end b: the state (end = `_eval` at b), the
    counters and, when due, the sample.  Returns GO or SAMPLES_FULL (nothing
    committed)."""
    xb, vxb, yb, vyb, uxb, uyb, duxb, duyb, axb, ayb = end
    take = False
    if sample_here:
        save = ctr[C_NEXT]
        take = want_sample(b, ctr, p.sample_dt, p.win_t0, p.win_t1)
        if take and ctr[C_NSAMP] >= samples.shape[0]:
            ctr[C_NEXT] = save
            return SAMPLES_FULL
    state[0] = b
    state[1] = xb
    state[2] = vxb
    state[3] = yb
    state[4] = vyb
    if scanned:
        ctr[C_STEPS] += 1
    ctr[C_FEVALS] += nev
    if take:
        record_row(
            samples,
            ctr,
            b,
            xb,
            vxb,
            yb,
            vyb,
            mode,
            uxb,
            uyb,
            duxb,
            duyb,
            axb,
            ayb,
            p.mass,
            p.mu,
            p.theta * p.mu,
        )
    return GO


@kernel
def point_mass_kernel(p, stick_rule, state, work, samples, events, ctr, t_stop):
    """Advance the material point to min(t_stop, t_end); see the module doc.

    p       PointMassParams (make_params)
    stick_rule           RULE_PAPER (0) or RULE_CLASSICAL (1)
    state   float64[5]   t, x, vx, y, vy (updated in place)
    work    float64[STACK, 4]  scratch of the no-hidden-crossing proof (new_work())
    samples float64[:, records.NCOL], events float64[:, 3], ctr int64[NCTR]
    Returns records.DONE, SAMPLES_FULL, EVENTS_FULL, or EVENTS_RUNAWAY (more
    than MAX_EVENTS_PER_STEP events between two scan-grid points: state at
    the last commit, the run cannot go on).
    """
    A = p.amplitude
    m = p.mass
    mu = p.mu
    r = p.r
    tau = p.tau
    t_final = min(t_stop, p.t_end)
    uy3, m_vz = _crossing_bounds(p)
    status = _fresh_start(p, stick_rule, state, samples, events, ctr)
    if status != GO:
        return status
    run_events = 0  # events since the last scan-grid point
    while True:
        t = state[0]
        if t >= t_final:
            return DONE
        mode = ctr[C_MODE]
        seg = _segment_base(state, A, r, tau)
        b, sample_here = _step_end(t, p.scan_dt, t_final, p.t_end)
        end = _eval(b, mode, seg, A, m, mu, r, tau)
        # the first event in (t, b], if any (a step shorter than SHORT_SEG,
        # just after an event, is not scanned: rounding noise there)
        scanned = False
        ev_kind = -1
        t_ev = b
        nev = 0
        if b - t >= SHORT_SEG:
            if mode == MODE_FLIGHT:
                scanned, found, t_ev, nev = _search_landing(b, end, mode, seg, work, uy3, m_vz, p)
                if found:
                    ev_kind = EV_LAND
            else:
                scanned = True
                ev_kind, t_ev, nev = _search_contact(b, end, mode, stick_rule, seg, work, uy3, m_vz, p)
        if ev_kind < 0:
            # no event: on to b
            run_events = 0
            status = _commit_step_end(b, sample_here, scanned, nev, mode, end, p, state, samples, ctr)
        else:
            # the event: its transition, committed at t_ev (the loop
            # re-bases there)
            run_events += 1
            if run_events > MAX_EVENTS_PER_STEP:
                return EVENTS_RUNAWAY
            at = _eval(t_ev, mode, seg, A, m, mu, r, tau)
            new_mode, nx, nvx, ny, nvy, ev1, ev2 = _transition(ev_kind, mode, at, stick_rule, p)
            status = _commit_event(
                t_ev, mode, at, (new_mode, nx, nvx, ny, nvy), ev1, ev2, nev, p, state, samples, events, ctr
            )
        if status != GO:
            return status


# --------------------------------------------------------------------------- Python side
def new_work():
    """The kernel's scratch array (the subdivision stack of `_first_bracket`)."""
    return np.empty((STACK, 4))


def rule_code(stick_rule):
    """RULE_PAPER / RULE_CLASSICAL from an int or a name ("paper", "classical")."""
    if isinstance(stick_rule, str):
        key = stick_rule.strip().lower()
        if key not in STICK_RULES:
            raise InputError(f"stick_rule must be one of {STICK_RULES}, got {stick_rule!r}")
        return STICK_RULES.index(key)
    code = int(stick_rule)
    if code not in (RULE_PAPER, RULE_CLASSICAL) or code != stick_rule:
        raise InputError(f"stick_rule must be 0 (paper) or 1 (classical), got {stick_rule!r}")
    return code


def make_params(
    A,
    m,
    mu=0.3,
    theta=1.2,
    r=0.656,
    tau=50.0,
    t_end=2000.0,
    alpha_t=0.5,
    sample_dt=0.125,
    window=(math.inf, math.inf),
    scan_dt=1.0 / 64.0,
    capture_t=None,
):
    """The kernel's parameters (no validation here): a PointMassParams of
    floats (capture_t None: CAPTURE_T)."""
    return PointMassParams(
        float(A),
        float(m),
        float(mu),
        float(theta),
        float(r),
        float(tau),
        float(alpha_t),
        float(t_end),
        float(sample_dt),
        float(window[0]),
        float(window[1]),
        float(scan_dt),
        CAPTURE_T if capture_t is None else float(capture_t),
    )
