"""Slow, obviously-right twin of the memory diagram: a literal spring bed.

docs/MODEL.md section 2, rule by rule, with no cleverness: a bed of M independent
springs at the midpoints h_j of a uniform grid on [0, hmax]; spring j is in
contact while h_j < a*, and carries a tangential displacement u_j (units of b*).
Only plain numpy (arrays over the springs, one Python call per committed step).

One committed step moves (a*, b*) along the straight line (a0, b0) -> (a1, b1):
  1. springs already in contact get u += b1 - b0; a spring out of contact with
     h_j < a1 enters at the b* where the line crosses a* = h_j, so it starts
     with u = b1 - b_cross;
  2. springs with h_j >= a1 (all of them if a1 <= 0) leave contact and forget:
     u = 0;
  3. Coulomb, spring by spring: u_j is clipped to [-(a1 - h_j), a1 - h_j].
     A spring that had to be clipped slides during the step.

Clamping once at the end of a straight step is the same as clamping all along
it: u_j and its limit are both linear in the step's parameter, so once a spring
is pushed past its limit it stays there until the end of the step.

    T* = (3/4) * sum_j u_j * integral over cell j (cut at a1) of h^(-1/2) dh
       = (3/4) * sum_j u_j * 2 (sqrt(min(h_hi, a1)) - sqrt(h_lo))

(u frozen at the midpoint value over its cell, the h^(-1/2) weight integrated
exactly, so the singularity at h = 0 costs nothing).  The springs themselves
are exact: spring j follows exactly the anchor w(h_j) = b* - u_j of the
continuum; only T* carries a quadrature error, O(dh^1.5) or better.
"""

import numpy as np

FLIGHT, STICK, PARTIAL_SLIP, SLIDING = 0, 1, 2, 3


class SpringBed:
    """M springs at midpoints of a uniform grid on [0, hmax]."""

    def __init__(self, M, hmax, a_start=1.0, b_start=0.0, tol=1e-12, profile=None):
        # profile: None = the sphere (weights 0.75 h^-1/2 dh, as below); else a
        # vibtrans.profiles object whose springs weigh dN*'(h) (docs/MODEL.md section 10)
        self.profile = profile
        edges = np.linspace(0.0, hmax, M + 1)
        self.h_lo = edges[:-1]
        self.h_hi = edges[1:]
        self.h = 0.5 * (self.h_lo + self.h_hi)
        self.dh = hmax / M
        self.tol = tol
        # Virgin contact: every spring with h < a_start is stuck with u = 0.
        self.on = self.h < a_start if a_start > 0.0 else np.zeros(M, dtype=bool)
        self.u = np.zeros(M)
        self.a = float(a_start)
        self.b = float(b_start)

    # ------------------------------------------------------------------ step
    def step(self, a1, b1):
        """Commit (a1, b1); return a dict describing the state after the step."""
        return self.describe(*self._advance(a1, b1))

    def force_step(self, a1, b1):
        """Commit (a1, b1); return T* after the step (the dynamics' use)."""
        self._advance(a1, b1)
        return self.tangential_force()

    def _advance(self, a1, b1):
        """Rules 1-3 for one straight step; (excess, clipped) per spring."""
        a0, b0 = self.a, self.b
        h = self.h
        u = self.u.copy()
        on = self.on.copy()

        # 1. springs in contact follow b*; new springs enter on the step's line.
        u[on] += b1 - b0
        enter = (~on) & (h < a1)
        if enter.any():
            # a1 > h_j >= a0 for these springs, so a1 > a0: the line crosses
            # a* = h_j at parameter t = (h_j - a0) / (a1 - a0) in [0, 1).
            t = (h[enter] - a0) / (a1 - a0)
            b_cross = b0 + t * (b1 - b0)
            u[enter] = b1 - b_cross
            on = on | enter

        # 2. springs out of reach leave contact and forget.
        leave = on & ((h >= a1) if a1 > 0.0 else np.ones_like(on))
        u[leave] = 0.0
        on = on & ~leave

        # 3. Coulomb, spring by spring.
        lim = np.where(on, a1 - h, 0.0)
        excess = np.abs(u) - lim  # > 0: pushed past limit
        clipped = on & (excess > 0.0)
        u = np.where(on, np.clip(u, -lim, lim), 0.0)

        self.u, self.on, self.a, self.b = u, on, float(a1), float(b1)
        return excess, clipped

    # ----------------------------------------------------------- observables
    def tangential_force(self):
        if self.a <= 0.0:
            return 0.0
        hi = np.minimum(self.h_hi, self.a)
        if self.profile is not None:
            k = self.profile.stiffness
            weight = k(np.maximum(hi, self.h_lo)) - k(self.h_lo)
            weight[0] += float(k(0.0))  # a flat part: springs all entering at h = 0
            return float(np.sum(np.where(self.on, self.u, 0.0) * weight))
        weight = 2.0 * (np.sqrt(np.maximum(hi, self.h_lo)) - np.sqrt(self.h_lo))
        return 0.75 * float(np.sum(np.where(self.on, self.u, 0.0) * weight))

    def anchors(self):
        """(h_j, w_j = b* - u_j) of the springs in contact."""
        return self.h[self.on], self.b - self.u[self.on]

    def describe(self, excess, clipped):
        """State after the step, read off the springs.

        slide: springs clipped in this step (the slip annulus).  Springs whose
        excess is within tol of zero are ambiguous (rounding decides) and are
        left out of the stick-depth bracket [s_lo, s_hi]: the continuum stick
        depth must lie between the deepest surely-stuck spring (s_lo) and the
        shallowest surely-sliding one (s_hi).
        """
        a1, on, h, tol = self.a, self.on, self.h, self.tol
        T = self.tangential_force()
        out = dict(T=T, a=a1, b=self.b, n_on=int(on.sum()), n_slide=int(clipped.sum()))
        if a1 <= 0.0:
            out.update(state=FLIGHT, s_lo=0.0, s_hi=0.0, contiguous=True, ambiguous=False)
            return out
        sure_slide = on & (excess > tol)
        sure_stick = on & (excess < -tol)
        s_lo = float(h[sure_stick].max()) if sure_stick.any() else 0.0
        s_hi = float(h[sure_slide].min()) if sure_slide.any() else a1
        # The slip annulus must be one band at the edge (Cattaneo-Mindlin).
        contiguous = s_lo < s_hi
        n_on, n_slide = out["n_on"], out["n_slide"]
        ambiguous = bool((on & ~sure_slide & ~sure_stick).any()) or n_on == 0
        if n_on == 0:
            state = None  # contact thinner than one cell
        elif n_slide == 0:
            state = STICK
        elif n_slide == n_on:
            state = SLIDING
        else:
            state = PARTIAL_SLIP
        out.update(state=state, s_lo=s_lo, s_hi=s_hi, contiguous=contiguous, ambiguous=ambiguous)
        return out


def spring_bed_history(a, b, M, hmax=None, a_start=1.0, b_start=0.0):
    """Run a whole (a*, b*) history through a SpringBed; list of step dicts."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if hmax is None:
        hmax = max(a_start, float(a.max()), 1e-3)
    bed = SpringBed(M, hmax, a_start, b_start)
    return [bed.step(ai, bi) for ai, bi in zip(a, b)]


# =========================================================================
# Slow twins of the dynamics (docs/MODEL.md sections 1 and 3), written from the
# equations with no shared code: plain Python floats, fixed small steps.
# =========================================================================
import math  # noqa: E402

TWO_PI = 2.0 * math.pi


def ramp(t, tau):
    """G(t) = 1 - exp(-t^2/tau^2) and its first two derivatives (tau = 0: 1)."""
    if tau == 0.0:
        return 1.0, 0.0, 0.0
    e = math.exp(-((t / tau) ** 2))
    return 1.0 - e, 2.0 * t / tau**2 * e, (2.0 / tau**2 - 4.0 * t * t / tau**4) * e


def surface(t, A, r, tau):
    """(u_x, u_y, u_x', u_y', u_x'', u_y'') of u_x = G A r sin(2 pi t),
    u_y = G A cos(2 pi t), differentiated by hand (product rule)."""
    g, g1, g2 = ramp(t, tau)
    w = TWO_PI
    c, s = math.cos(w * t), math.sin(w * t)
    ux, uy = g * A * r * s, g * A * c
    dux = A * r * (g1 * s + w * g * c)
    duy = A * (g1 * c - w * g * s)
    ddux = A * r * (g2 * s + 2.0 * w * g1 * c - w * w * g * s)
    dduy = A * (g2 * c - 2.0 * w * g1 * s - w * w * g * c)
    return ux, uy, dux, duy, ddux, dduy


def hertz_force(a):
    """N* = a*^(3/2) in contact, 0 out of it."""
    return a**1.5 if a > 0.0 else 0.0


# ------------------------------------------------------ one vertical Hertz step
def vertical_step(t, y, vy, history, h, m, A, tau, integrator):
    """One committed step of m* y'' = 1 - N*(y - u_y(t)) from t to t + h.

    history: [(y'_n, y''_n), (y'_{n-1}, y''_{n-1}), ...] newest first (AB4
    needs four, Verlet uses the first).  Returns (y1, vy1, a1, N1) with
    AB4:    z1 = z + h/24 (55 F_n - 59 F_{n-1} + 37 F_{n-2} - 9 F_{n-3}),
            z = (y, y'), F = (y', y'');
    Verlet: y1 = y + h y' + h^2/2 y''_n, y'1 = y' + h/2 (y''_n + y''_{n+1}).
    """
    t1 = t + h
    if integrator == "ab4":
        c = (55.0, -59.0, 37.0, -9.0)
        y1 = y + h / 24.0 * sum(ci * f[0] for ci, f in zip(c, history))
        vy1 = vy + h / 24.0 * sum(ci * f[1] for ci, f in zip(c, history))
        a1 = y1 - surface(t1, A, 0.0, tau)[1]
        return y1, vy1, a1, hertz_force(a1)
    y1 = y + h * vy + 0.5 * h * h * history[0][1]
    a1 = y1 - surface(t1, A, 0.0, tau)[1]
    n1 = hertz_force(a1)
    vy1 = vy + 0.5 * h * (history[0][1] + (1.0 - n1) / m)
    return y1, vy1, a1, n1


# ------------------------------------------------------ the deformable particle
def deformable_run(A, m, mu, theta, r, tau, periods, h, springs=2000, hmax=4.0):
    """The deformable particle from rest (docs/MODEL.md section 1), slowly:

        m* x'' = -mu T*,  m* y'' = 1 - N*(a*),  a* = y* - u_y,
        theta mu b* = x* - u_x,  T* from a SpringBed of `springs` springs
        on [0, hmax] (docs/MODEL.md section 2, rule by rule),

    velocity Verlet with the fixed step h (one force evaluation per step,
    so the bed is committed once per step, never on a trial state).  In
    flight the bed is empty (every spring left contact) and N* = T* = 0: no
    special case for take-off or landing, the step just crosses them.
    Start at rest: x = x' = 0, y = 1, y' = 0, every spring in [0, 1] stuck
    with u = 0.  Returns a dict of arrays t, x, vx, y, vy, a, b, N, T over
    every step (index k at t = k h).
    """
    n = int(round(periods / h))
    bed = SpringBed(springs, hmax, a_start=1.0, b_start=0.0)
    scale = theta * mu
    x, vx, y, vy, ax, ay = 0.0, 0.0, 1.0, 0.0, 0.0, 0.0
    out = {k: np.empty(n + 1) for k in ("t", "x", "vx", "y", "vy", "a", "b", "N", "T")}
    rows = [out[k] for k in ("t", "x", "vx", "y", "vy", "a", "b", "N", "T")]
    for arr, v in zip(rows, (0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0)):
        arr[0] = v
    for k in range(1, n + 1):
        t1 = k * h
        x1 = x + h * vx + 0.5 * h * h * ax
        y1 = y + h * vy + 0.5 * h * h * ay
        ux, uy = surface(t1, A, r, tau)[:2]
        a1 = y1 - uy
        b1 = (x1 - ux) / scale
        if a1 > hmax:
            raise ValueError(f"a* = {a1:g} is deeper than the spring bed (hmax = {hmax:g})")
        tf = bed.force_step(a1, b1)
        nf = hertz_force(a1)
        ax1, ay1 = -mu * tf / m, (1.0 - nf) / m
        vx += 0.5 * h * (ax + ax1)
        vy += 0.5 * h * (ay + ay1)
        x, y, ax, ay = x1, y1, ax1, ay1
        for arr, v in zip(rows, (t1, x, vx, y, vy, a1, b1, nf, tf)):
            arr[k] = v
    return out


# ------------------------------------------------------ the rolling particle
def rolling_run(A, m, mu, theta, r, tau, periods, h, j, springs=2000, hmax=4.0):
    """The rolling deformable particle from rest (docs/MODEL.md section 11),
    slowly, with its rotation as a degree of freedom of its own:

        m* x'' = -mu T*,  j m* w' = -mu T*  (w = omega R),  q' = w,
        m* y'' = 1 - N*(a*),  a* = y* - u_y,
        theta mu b* = x* + q* - u_x  (the contact point),

    T* from a SpringBed, velocity Verlet with the fixed step h for x, q and
    y alike (the bed committed once per step), as `deformable_run`.  Start
    at rest, q = w = 0.  Returns a dict of arrays t, x, vx, q, w, y, vy, a,
    b, N, T over every step (index k at t = k h)."""
    n = int(round(periods / h))
    bed = SpringBed(springs, hmax, a_start=1.0, b_start=0.0)
    scale = theta * mu
    x, vx, q, w, y, vy, ax, aw, ay = 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0
    names = ("t", "x", "vx", "q", "w", "y", "vy", "a", "b", "N", "T")
    out = {k: np.empty(n + 1) for k in names}
    rows = [out[k] for k in names]
    for arr, v in zip(rows, (0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0)):
        arr[0] = v
    for k in range(1, n + 1):
        t1 = k * h
        x1 = x + h * vx + 0.5 * h * h * ax
        q1 = q + h * w + 0.5 * h * h * aw
        y1 = y + h * vy + 0.5 * h * h * ay
        ux, uy = surface(t1, A, r, tau)[:2]
        a1 = y1 - uy
        b1 = (x1 + q1 - ux) / scale
        if a1 > hmax:
            raise ValueError(f"a* = {a1:g} is deeper than the spring bed (hmax = {hmax:g})")
        tf = bed.force_step(a1, b1)
        nf = hertz_force(a1)
        ax1, aw1, ay1 = -mu * tf / m, -mu * tf / (j * m), (1.0 - nf) / m
        vx += 0.5 * h * (ax + ax1)
        w += 0.5 * h * (aw + aw1)
        vy += 0.5 * h * (ay + ay1)
        x, q, y, ax, aw, ay = x1, q1, y1, ax1, aw1, ay1
        for arr, v in zip(rows, (t1, x, vx, q, w, y, vy, a1, b1, nf, tf)):
            arr[k] = v
    return out


# ------------------------------------------------------ the material point
STICK_MODE, SLIDE_POS, SLIDE_NEG, FLIGHT_MODE = "stick", "slide+", "slide-", "flight"


class MaterialPoint:
    """The rigid-contact point of docs/MODEL.md section 3, time-stepped.

    Modes stick / slide (s = +-1, the sign of the relative velocity) /
    flight.  Within a mode the motion from a base state (t0, x0, v0, y0, vy0):
      stick:  x = x0 + u_x(t) - u_x(t0), y = u_y;
      slide:  y = u_y, x'' = -(mu s / m) N*(t), N* = 1 - m u_y''(t), one RK4
              step from t0 (exact to O(dt^5));
      flight: the parabola x = x0 + v0 dt, y = y0 + vy0 dt + dt^2 / (2 m).
    Every dt the event functions of the mode are evaluated at the step end;
    a triggered one is located by bisection (to 1e-12), the earliest wins:
      detach (contact):  N* < 0                  -> flight, own x', y' = u_y'
      slip   (stick):    m |u_x''| > mu N*       -> slide, s = -sgn(u_x'')
      stick  (slide, paper rule): mu N* >= m |u_x''| -> stick, x' = u_x'
      v_rel = 0 (slide): N* < 0 -> flight; mu N* >= m |u_x''| -> stick;
                         else slide with s = -sgn(u_x'') (a reversal)
      landing (flight):  y >= u_y -> v_t -> alpha_t v_t (relative to the
                         surface), elastic normal reversal; a landing whose
                         next flight would last < capture_t (2 m v_n / N*)
                         starts contact instead (the kernel's chatter
                         capture, its docstring), mode by Coulomb and the rule.
    Start at t = 0: x = 0, y = u_y(0), x' = 0 (u_x'(0) if it sticks), y' = u_y'(0).
    """

    def __init__(self, A, m, mu, r, tau, alpha_t=0.5, rule="paper", capture_t=1e-3):
        self.A, self.m, self.mu, self.r, self.tau = A, m, mu, r, tau
        self.alpha_t, self.rule, self.capture_t = alpha_t, rule, capture_t
        self.events = []  # (t, "takeoff" | "landing" | "state", value)
        ux, uy, dux, duy, ddux, dduy = self.sub(0.0)
        nf = 1.0 - m * dduy
        self.mode = self.resolve(nf, mu * nf - m * abs(ddux), -dux, ddux)
        self.base = (0.0, 0.0, dux if self.mode == STICK_MODE else 0.0, uy, duy)
        self.state_code = self.code(self.mode)
        self.events.append((0.0, "state", self.state_code))

    def sub(self, t):
        return surface(t, self.A, self.r, self.tau)

    @staticmethod
    def code(mode):
        return {STICK_MODE: STICK, FLIGHT_MODE: FLIGHT}.get(mode, SLIDING)

    def resolve(self, nf, f, vrel, ddux):
        if nf < 0.0:
            return FLIGHT_MODE
        if f >= 0.0 and (self.rule == "paper" or vrel == 0.0):
            return STICK_MODE
        if vrel != 0.0:
            return SLIDE_POS if vrel > 0.0 else SLIDE_NEG
        return SLIDE_NEG if ddux > 0.0 else SLIDE_POS

    def at(self, t):
        """(x, vx, y, vy) at t >= base time, in the current mode."""
        t0, x0, v0, y0, vy0 = self.base
        dt = t - t0
        m = self.m
        if self.mode == FLIGHT_MODE:
            return x0 + v0 * dt, v0, y0 + vy0 * dt + dt * dt / (2.0 * m), vy0 + dt / m
        ux, uy, dux, duy = self.sub(t)[:4]
        if self.mode == STICK_MODE:
            return x0 + ux - self.sub(t0)[0], dux, uy, duy
        s = 1.0 if self.mode == SLIDE_POS else -1.0

        def acc(tt):
            return -(self.mu * s / m) * (1.0 - m * self.sub(tt)[5])

        k1, k2, k4 = acc(t0), acc(t0 + 0.5 * dt), acc(t)
        return (x0 + dt * v0 + dt * dt / 6.0 * (k1 + 2.0 * k2), v0 + dt / 6.0 * (k1 + 4.0 * k2 + k4), uy, duy)

    def phis(self, t):
        """{event: value} of the mode's event functions at t (event: > 0,
        or >= 0 for stick, vzero and land)."""
        x, vx, y, vy = self.at(t)
        ux, uy, dux, duy, ddux, dduy = self.sub(t)
        m, mu = self.m, self.mu
        nf = 1.0 - m * dduy
        if self.mode == FLIGHT_MODE:
            return {"land": y - uy}
        if self.mode == STICK_MODE:
            return {"detach": -nf, "slip": m * abs(ddux) - mu * nf}
        s = 1.0 if self.mode == SLIDE_POS else -1.0
        out = {"detach": -nf, "vzero": -s * (vx - dux)}
        if self.rule == "paper":
            out["stick"] = mu * nf - m * abs(ddux)
        return out

    @staticmethod
    def fired(kind, phi):
        return phi > 0.0 if kind in ("detach", "slip") else phi >= 0.0

    def run(self, periods, dt, sample_times=()):
        """Advance to t = periods; returns the states (t, x, vx, y, vy) at
        sample_times (sorted, in (0, periods]; at an event time, the state
        before the event)."""
        samples = []
        times = list(sample_times)
        i = 0
        t = 0.0
        while t < periods:
            t1 = min(t + dt, periods)
            hits = []
            for kind, phi in self.phis(t1).items():
                if self.fired(kind, phi):
                    lo, hi = t, t1
                    while hi - lo > 1e-12:
                        mid = 0.5 * (lo + hi)
                        if self.fired(kind, self.phis(mid)[kind]):
                            hi = mid
                        else:
                            lo = mid
                    hits.append((hi, kind))
            te, kind = min(hits) if hits else (t1, None)
            while i < len(times) and times[i] <= te:
                samples.append((times[i], *self.at(times[i])))
                i += 1
            if kind is None:
                self.base = (t1, *self.at(t1))
            else:
                self.transition(te, kind)
            t = te
        return np.array(samples)

    def transition(self, te, kind):
        x, vx, y, vy = self.at(te)
        ux, uy, dux, duy, ddux, dduy = self.sub(te)
        m, mu = self.m, self.mu
        nf = 1.0 - m * dduy
        f = mu * nf - m * abs(ddux)
        reverse = SLIDE_NEG if ddux > 0.0 else SLIDE_POS
        phase = te - math.floor(te)
        nvy = duy
        if kind == "detach":
            new = FLIGHT_MODE
            self.events.append((te, "takeoff", phase))
        elif kind in ("slip", "stick"):
            vx = dux
            new = reverse if kind == "slip" else STICK_MODE
        elif kind == "vzero":
            vx = dux
            new = FLIGHT_MODE if nf < 0.0 else (STICK_MODE if f >= 0.0 else reverse)
            if new == FLIGHT_MODE:
                self.events.append((te, "takeoff", phase))
        else:  # landing
            vn = abs(vy - duy)
            vt = self.alpha_t * (vx - dux)
            vx = dux + vt
            self.events.append((te, "landing", phase))
            if nf > 0.0 and 2.0 * m * vn < self.capture_t * nf:
                new = self.resolve(nf, f, vt, ddux)
                if new == STICK_MODE:
                    vx = dux
                elif new == FLIGHT_MODE:
                    nvy = duy - vn
            else:
                new = FLIGHT_MODE
                nvy = duy - vn
                self.events.append((te, "takeoff", phase))
        self.mode = new
        self.base = (te, x, vx, uy, nvy)
        code = self.code(new)
        if code != self.state_code:
            self.events.append((te, "state", code))
            self.state_code = code


# ------------------------------------- the vertical motion's Lyapunov exponent
def vertical_lyapunov(A, m, tau, periods, t_from, rtol=1e-11):
    """Largest Lyapunov exponent of m* y'' = 1 - N*(y - u_y(t)) from rest,
    per period, measured from t_from to `periods`: an independent twin of
    simulate(..., lyapunov=True) with nothing shared but the equations.

    scipy's DOP853 (adaptive, 8th order) integrates the state and the
    variational equation m* dy'' = -1.5 sqrt(a*) dy together (N* is C1 at
    a* = 0, so no events), one period at a time, the tangent renormalized
    after each (Benettin).  As in the kernel, the tangent starts as (1, 0)
    at t = 0, and the exponent is the growth of log|d| from t_from on."""
    from scipy.integrate import solve_ivp

    def rhs(t, z):
        y, vy, dy, dvy = z
        a = y - surface(t, A, 0.0, tau)[1]
        n = a**1.5 if a > 0.0 else 0.0
        dn = 1.5 * math.sqrt(a) if a > 0.0 else 0.0
        return [vy, (1.0 - n) / m, dvy, -dn * dy / m]

    z = np.array([1.0, 0.0, 1.0, 0.0])
    log_norm = 0.0  # log|d| with the renormalizations
    log_from = None
    stops = sorted({*np.arange(0.0, periods, 1.0)[1:], t_from, periods})
    t = 0.0
    for t1 in stops:
        if t1 > t:
            z = solve_ivp(rhs, (t, t1), z, method="DOP853", rtol=rtol, atol=1e-13).y[:, -1]
            norm = math.hypot(z[2], z[3])
            log_norm += math.log(norm)
            z[2:] /= norm
            t = t1
        if log_from is None and t >= t_from:
            log_from = log_norm
    return (log_norm - log_from) / (periods - t_from)


# --------------------------------------- the material point's vertical impacts
def bouncing_ball_flight(t0, v0, A, m, tau, dt=1e-3, t_max=1e4):
    """From a launch off the surface at t0 with vertical velocity v0 (y down,
    gravity 1/m*), the next landing on u_y = G A cos(2 pi t), found by a
    plain scan of the gap on a grid of dt and scipy's brentq, and the
    velocity after the elastic impact: (t1, v1).  Nothing shared with the
    kernel but the equations."""
    from scipy.optimize import brentq

    def gap(t):
        s = t - t0
        return surface(t0, A, 0.0, tau)[1] + v0 * s + 0.5 * s * s / m - surface(t, A, 0.0, tau)[1]

    t = t0 + 1e-9
    while t < t0 + t_max:
        t_next = t + dt
        if gap(t) < 0.0 <= gap(t_next):
            t1 = brentq(gap, t, t_next, xtol=1e-15, rtol=1e-15)
            v_in = v0 + (t1 - t0) / m
            return t1, 2.0 * surface(t1, A, 0.0, tau)[3] - v_in
        t = t_next
    raise RuntimeError("no landing")
