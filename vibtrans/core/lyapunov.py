"""The material point's vertical Lyapunov exponent from its impact map.

Its flights are parabolas and its impacts elastic (alpha_n = 1), so the
impact map (t_n, v_n) -> (t_{n+1}, v_{n+1}) is known in closed form and so is
its Jacobian; `simulate(..., lyapunov=True)` multiplies them along a run's
events.  (The deformable particle's exponent comes from its tangent
equations inside the kernel instead.)  Normalized units: time in periods,
lengths in a0.
"""

from __future__ import annotations

import math

import numpy as np

from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.substrate import TWO_PI, ramp


def _surface(t, amplitude, tau):
    """(u_y*, u_y*', u_y*'') at t (the substrate's vertical motion, ramp included)."""
    g, g1, g2 = ramp(t, tau)
    c, s = math.cos(TWO_PI * t), math.sin(TWO_PI * t)
    u = g * amplitude * c
    du = amplitude * (g1 * c - TWO_PI * g * s)
    ddu = amplitude * (g2 * c - 2.0 * TWO_PI * g1 * s - TWO_PI**2 * g * c)
    return u, du, ddu


def impact_jacobian(
    t0: float, t1: float, amplitude: float, mass: float, tau: float
) -> tuple[np.ndarray, float, float]:
    """The Jacobian of the material point's impact map (t_n, v_n) ->
    (t_{n+1}, v_{n+1}): a flight launched from the surface at t_n with
    vertical velocity v_n lands at t_{n+1}, where the elastic impact
    (alpha_n = 1) reflects its velocity relative to the surface.  From the
    landing condition F = u(t0) + v0 s + s^2 / (2 m*) - u(t1) = 0 (s = t1 -
    t0; implicit function theorem) and v1 = 2 u'(t1) - (v0 + s / m*).
    v0 follows from the two times (the flight joins two surface points).
    Returns (J, v0, approach speed at t1)."""
    m = mass
    s = t1 - t0
    u0, du0, _ = _surface(t0, amplitude, tau)
    u1, du1, ddu1 = _surface(t1, amplitude, tau)
    v0 = (u1 - u0 - 0.5 * s * s / m) / s
    w1 = v0 + s / m - du1  # > 0: moving into the surface
    dt1_dt0 = (v0 + s / m - du0) / w1
    dt1_dv0 = -s / w1
    dv1_dt0 = 2.0 * ddu1 * dt1_dt0 - (dt1_dt0 - 1.0) / m
    dv1_dv0 = 2.0 * ddu1 * dt1_dv0 - (1.0 + dt1_dv0 / m)
    return np.array([[dt1_dt0, dt1_dv0], [dv1_dt0, dv1_dv0]]), v0, w1


class ImpactGrowth:
    """The impact map's tangent grown along a run's events as they come
    (the `decided` rule asks for it at each check; `impact_lyapunov` at the
    end of a run): the product of the Jacobians from the first impact at or
    after t_from, renormalized at each.

    `update(events)` takes the run's event rows so far (the rows it has seen
    again, and more) and returns (t0, log growth since t0): t0 the first
    impact's time, the growth -inf once the point rode the surface after
    t_from (a capture), NaN if the tangent broke down; None before three
    impacts (nothing measured yet).  A landing is an impact when a take-off
    at the same instant follows it (the kernel commits the two together);
    a landing that is the last row so far waits for the next rows, unless
    `final`."""

    def __init__(self, amplitude: float, mass: float, tau: float, t_from: float) -> None:
        self.amplitude, self.mass, self.tau = float(amplitude), float(mass), float(tau)
        self.t_from = float(t_from)
        self.row = 0  # the next event row to look at
        self.landings = 0  # impacts counted
        self.first = self.last = math.nan
        self.total = 0.0  # log growth over the impacts so far
        self.captured = self.broken = False
        self._d = np.array([1.0, 0.0])

    def update(self, events: np.ndarray, final: bool = False) -> tuple[float, float] | None:
        if self.captured:  # -inf for good
            return self.value()
        t, kind = events[:, 0], events[:, 1]
        n, start = t.size, self.row
        self.row = n
        for j in start + np.flatnonzero(kind[start:] == R.LANDING):
            if t[j] < self.t_from:
                continue
            if j + 1 >= n and not final:
                self.row = int(j)  # its take-off, if any, comes with the next rows
                break
            if not (j + 1 < n and kind[j + 1] == R.TAKEOFF and t[j + 1] == t[j]):
                self.captured = True
                if self.landings == 0:
                    self.first = float(t[j])
                break
            self._impact(float(t[j]))
        return self.value()

    def _impact(self, t1):
        if self.broken:
            return  # (a capture later still decides: -inf)
        if self.landings:
            J, _, _ = impact_jacobian(self.last, t1, self.amplitude, self.mass, self.tau)
            d = J @ self._d
            norm = math.hypot(d[0], d[1])
            if not (norm > 0.0 and math.isfinite(norm)):
                self.broken = True
                return
            self.total += math.log(norm)
            self._d = d / norm
        else:
            self.first = t1
        self.last = t1
        self.landings += 1

    def value(self) -> tuple[float, float] | None:
        """(t0, log growth since t0), or None (see the class)."""
        if self.captured:
            return self.first, -math.inf
        if self.broken:
            return self.first, math.nan
        if self.landings < 3:
            return None
        return self.first, self.total

    def exponent(self) -> tuple[float, float]:
        """(lambda per period, t_start) as `impact_lyapunov` returns them."""
        if self.captured:
            return -math.inf, self.first
        if self.broken or self.landings < 3:
            return math.nan, math.nan
        return self.total / (self.last - self.first), self.first


def impact_lyapunov(
    events: np.ndarray, amplitude: float, mass: float, tau: float, t_from: float
) -> tuple[float, float]:
    """The material point's vertical Lyapunov exponent, per period, from its
    run's events (records: LANDING and TAKEOFF at one instant = an elastic
    impact): the product of the impact map's Jacobians over the impacts
    from t_from on (renormalized at each), over the time between the first
    and the last of them (`ImpactGrowth`).  Returns (lambda, t_start):

    * -inf if the point rode the surface after t_from (a landing without a
      take-off, a capture): its detachment comes at a phase set by the
      surface alone, which forgets every perturbation (superstable);
    * NaN if fewer than three impacts fall after t_from (permanent contact,
      or a flight that never ends: nothing to measure)."""
    growth = ImpactGrowth(amplitude, mass, tau, t_from)
    growth.update(events, final=True)
    return growth.exponent()
