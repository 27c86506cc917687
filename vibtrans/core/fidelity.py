"""Fidelity presets: the time step of a scene, from its physics.

The step is the smaller of (one period / steps_per_period) and (the shortest
contact time scale / steps_per_contact).  Contact time scales (normalized):
* the linear Hertz oscillation about the static load, 2 pi sqrt(2 m* / 3);
* the Hertz impact duration at the fastest plausible impact speed
  v = 4 pi A* (particle and surface meeting at their peak speeds):
  t_c = 2.94 a_max / v with a_max = (5 m* v^2 / 4)^(2/5)  (Hertz impact).
This bound keeps stiff light-particle scenes (m* = 1e-5) stable.
"""

from __future__ import annotations

import math
from typing import Any

FIDELITY = {
    # name: (steps per period, steps per shortest contact time scale)
    # AB4 is stable on an oscillation only while omega h < ~0.43: 24 steps
    # per contact time scale (omega h = 0.26) keeps preview stable.
    "preview": (16, 24),
    "standard": (256, 40),
    "reference": (2048, 320),
}
# preview: AB4 needs >= ~16 steps per contact time scale (omega h < 0.43), so
# scenes whose step the contact sets gain only 40/24 = 1.7x over standard;
# scenes set by the period gain 16x (work-precision study, README).

# Stated accuracy: the largest relative drift error (floor v0* = 0.1) against a
# 4096-steps/period reference on the non-chaotic scenes that drift, measured by
# `vibtrans bench --work-precision` (preview 1.6e-2, standard 1.0e-4,
# reference 3.5e-6, both integrators); tests/products/test_presets.py holds each preset
# to its bound on the quick study.
V0 = 0.1  # |v*| <= V0: "no drift" (the paper's white band; the floor above)
# Chaotic: the vertical motion's largest Lyapunov exponent above this, per
# period (simulate(..., lyapunov=True)).  Chosen from the exponent's
# histogram over the shipped grid (docs/DYNAMICS.md): regular orbits measure
# |lambda| < ~3e-3 after 1675 periods (log T / T), chaotic ones 0.02-0.2.
CHAOS_LYAPUNOV = 0.01
STATED_DRIFT_ERROR = {"preview": 0.05, "standard": 0.005, "reference": 1e-4}
PRESET_NOTES = {
    "preview": "drift within 5% (measured <= 1.6% where it drifts), 2.3x faster than "
    "standard in total (1.5x on the worst scene)",
    "standard": "drift within 0.5% (measured <= 0.01% where it drifts)",
    "reference": "drift within 0.01% (measured <= 0.0004%), 9x slower than standard",
}


def _profile_time_scale(amplitude, mass, impacts, scales):
    """contact_time_scale for a profile's law (docs/MODEL.md section 10), scales =
    (N*'(1), p) (kernels.contact.law_scales):
    the linear oscillation 2 pi sqrt(m* / N*'(1)); the impact of the law
    N* ~ (N*'(1)/p) a*^p at v = 4 pi A*: a_max^(p+1) = (p+1) p m* v^2 / (2 N*'(1)),
    t_c = c_p a_max / v, c_p = 2 int_0^1 (1 - x^(p+1))^(-1/2) dx
    = 2 sqrt(pi) Gamma(1 + 1/(p+1)) / Gamma(1/2 + 1/(p+1)) (2.94 for p = 3/2).
    Tables take p = 2: a convex profile's contact radius grows at most
    linearly with the approach (the cone), so N* at most as a*^2."""
    k1, p = scales
    log_m = math.log(mass)
    t_lin = 2.0 * math.pi * math.exp(0.5 * (log_m - math.log(k1)))
    v = 4.0 * math.pi * amplitude
    if v <= 0.0 or not impacts or v < 1e-100:
        return t_lin
    q = 1.0 / (p + 1.0)
    c_p = 2.0 * math.sqrt(math.pi) * math.gamma(1.0 + q) / math.gamma(0.5 + q)
    log_t = (
        math.log(c_p) + q * (math.log((p + 1.0) * p / (2.0 * k1)) + log_m + 2.0 * math.log(v)) - math.log(v)
    )
    t_imp = math.exp(log_t) if log_t < 709.0 else math.inf
    return min(t_lin, t_imp)


def contact_time_scale(amplitude: float, mass: float, impacts: bool = True, scales: Any = None) -> float:
    """Shortest contact time scale of a scene, in wave periods (> 0, not NaN,
    for any amplitude >= 0 and mass > 0 a float can hold: where the direct
    formulas overflow or underflow, the same quantities in logarithms).

    impacts=False: only the linear oscillation (runs that stop at the first
    take-off, such as the jumping threshold, never land).  scales: a profile's
    (N*'(1), p) (kernels.contact.law_scales; None: the sphere)."""
    if scales is not None:
        return _profile_time_scale(amplitude, mass, impacts, scales)
    t_lin = 2.0 * math.pi * math.sqrt(2.0 * mass / 3.0)
    if t_lin == math.inf:  # 2 m* overflows (m* > 9e307)
        t_lin = 2.0 * math.pi * math.sqrt(mass) * math.sqrt(2.0 / 3.0)
    v = 4.0 * math.pi * amplitude
    if v <= 0.0 or not impacts:
        return t_lin
    if v < 1e-100:
        # 2.94 a_max / v = 2.94 (5 m*/4)^(2/5) v^(-1/5) > 1e17 here, far above
        # t_lin; and v^2 below would underflow to 0 (a zero step) for tiny A*
        return t_lin
    load = 1.25 * mass * v * v
    if 0.0 < load < math.inf:
        t_imp = 2.94 * load**0.4 / v
    else:
        # 5 m* v^2 / 4 overflows (huge A* or m*) or underflows (tiny m*):
        # 2.94 (5 m*/4)^(2/5) v^(-1/5), in logarithms (v may be inf: t_imp 0)
        log_t = math.log(2.94) + 0.4 * (math.log(1.25) + math.log(mass)) - 0.2 * math.log(v)
        t_imp = math.exp(log_t) if log_t < 709.0 else math.inf
    return min(t_lin, t_imp)


def time_step(
    amplitude: float,
    mass: float,
    fidelity: Any = "standard",
    refine: float = 1.0,
    impacts: bool = True,
    steps: Any = None,
    scales: Any = None,
) -> Any:
    """Integration step (periods) for the deformable and vertical models
    (>= 0; 0 only where the impact time scale underflows: an unbounded cost).

    `refine` divides the step (convergence studies); `steps` = (steps per
    period, steps per contact time scale) replaces the preset's pair
    (work-precision studies).
    """
    per_period, per_contact = FIDELITY[fidelity] if steps is None else steps
    h = min(1.0 / per_period, contact_time_scale(amplitude, mass, impacts, scales) / per_contact)
    return h / refine


def step_count(duration: float, h: Any) -> int | float:
    """ceil(duration / h) as an int, or math.inf where it does not fit a float
    (h = 0, or duration / h overflows): an upper estimate of the steps."""
    n = duration / h if h > 0.0 else math.inf
    return int(math.ceil(n)) if n < math.inf else math.inf


# Material point: the event functions are scanned on this grid (periods) and
# every event found on it is refined to ~1e-13 by bisection.
POINT_MASS_SCAN = {"preview": 1.0 / 32, "standard": 1.0 / 64, "reference": 1.0 / 256}


def scan_step(fidelity: str = "standard", refine: float = 1.0) -> float:
    """Scan step (periods) of the event-driven material point."""
    return POINT_MASS_SCAN[fidelity] / refine
