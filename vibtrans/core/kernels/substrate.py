"""The substrate surface: a ramped Rayleigh wave, in normalized units.

Time t* in wave periods, displacements in units of a0 (static Hertz
compression).  y points DOWN into the substrate.  docs/MODEL.md section 1:

    u_y* = G(t) A* cos(2 pi t),   u_x* = G(t) A* r sin(2 pi t),
    G(t) = 1 - exp(-t^2 / tau^2)  (tau = 0: the wave is on from t = 0).

The `+ sin` sign makes the wave travel towards +x (retrograde surface motion).
All functions are scalar numba helpers, inlined into the kernels.
"""

import math

from vibtrans.core.kernels.jit import helper

TWO_PI = 2.0 * math.pi

# exp(-x) < 2**-60 once x > 41.6: beyond t = 6.5 tau the ramp is exactly 1 in
# double precision, so we skip its exp() there.
RAMP_OFF = 6.5


@helper
def ramp(t: float, tau: float) -> tuple[float, float, float]:
    """G(t) and its first two time derivatives (G, G', G'')."""
    if tau <= 0.0 or t >= RAMP_OFF * tau:
        return 1.0, 0.0, 0.0
    q = t / tau
    e = math.exp(-q * q)
    g1 = 2.0 * t / (tau * tau) * e
    g2 = (2.0 / (tau * tau) - 4.0 * t * t / (tau**4)) * e
    return 1.0 - e, g1, g2


@helper
def vertical_displacement(t: float, amplitude: float, tau: float) -> float:
    """u_y*(t) = G A* cos(2 pi t)."""
    g, _, _ = ramp(t, tau)
    return g * amplitude * math.cos(TWO_PI * t)


@helper
def ramp_exact(t: float, tau: float) -> tuple[float, float]:
    """(G, G') evaluated in full, even where G = 1 to machine precision
    (the reference for the ramp shortcut of `ramp`)."""
    if tau <= 0.0:
        return 1.0, 0.0
    q = t / tau
    e = math.exp(-q * q)
    return 1.0 - e, 2.0 * t / (tau * tau) * e


@helper
def wave_motion(
    c: float, s: float, g: float, g1: float, amplitude: float, r: float
) -> tuple[float, float, float, float]:
    """(u_x*, u_y*, du_x*/dt, du_y*/dt) from c = cos(2 pi t), s = sin(2 pi t)
    and the ramp (G, G') at t."""
    ux = g * amplitude * r * s
    uy = g * amplitude * c
    vx = amplitude * r * (g1 * s + TWO_PI * g * c)
    vy = amplitude * (g1 * c - TWO_PI * g * s)
    return ux, uy, vx, vy


@helper
def surface_motion(t: float, amplitude: float, r: float, tau: float) -> tuple[float, float, float, float]:
    """(u_x*, u_y*, du_x*/dt, du_y*/dt) of the substrate surface."""
    g, g1, _ = ramp(t, tau)
    return wave_motion(math.cos(TWO_PI * t), math.sin(TWO_PI * t), g, g1, amplitude, r)


@helper
def surface_acceleration(t: float, amplitude: float, r: float, tau: float) -> tuple[float, float]:
    """(d2u_x*/dt2, d2u_y*/dt2) of the substrate surface."""
    g, g1, g2 = ramp(t, tau)
    c = math.cos(TWO_PI * t)
    s = math.sin(TWO_PI * t)
    w2 = TWO_PI * TWO_PI
    ax = amplitude * r * (g2 * s + 2.0 * TWO_PI * g1 * c - w2 * g * s)
    ay = amplitude * (g2 * c - 2.0 * TWO_PI * g1 * s - w2 * g * c)
    return ax, ay
