"""Slow, obviously-right twin of the memory diagram: a literal spring bed.

MODEL.md section 2, rule by rule, with no cleverness: a bed of M independent
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

    def __init__(self, M, hmax, a_start=1.0, b_start=0.0, tol=1e-12):
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
        excess = np.abs(u) - lim                        # > 0: pushed past limit
        clipped = on & (excess > 0.0)
        u = np.where(on, np.clip(u, -lim, lim), 0.0)

        self.u, self.on, self.a, self.b = u, on, float(a1), float(b1)
        return self.describe(excess, clipped)

    # ----------------------------------------------------------- observables
    def tangential_force(self):
        if self.a <= 0.0:
            return 0.0
        hi = np.minimum(self.h_hi, self.a)
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
            state = None                        # contact thinner than one cell
        elif n_slide == 0:
            state = STICK
        elif n_slide == n_on:
            state = SLIDING
        else:
            state = PARTIAL_SLIP
        out.update(state=state, s_lo=s_lo, s_hi=s_hi, contiguous=contiguous,
                   ambiguous=ambiguous)
        return out


def spring_bed_history(a, b, M, hmax=None, a_start=1.0, b_start=0.0):
    """Run a whole (a*, b*) history through a SpringBed; list of step dicts."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if hmax is None:
        hmax = max(a_start, float(a.max()), 1e-3)
    bed = SpringBed(M, hmax, a_start, b_start)
    return [bed.step(ai, bi) for ai, bi in zip(a, b)]
