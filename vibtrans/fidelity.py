"""Fidelity presets: the time step of a scene, from its physics.

The step is the smaller of (one period / steps_per_period) and (the shortest
contact time scale / steps_per_contact).  Contact time scales (normalized):
* the linear Hertz oscillation about the static load, 2 pi sqrt(2 m* / 3);
* the Hertz impact duration at the fastest plausible impact speed
  v = 4 pi A* (particle and surface meeting at their peak speeds):
  t_c = 2.94 a_max / v with a_max = (5 m* v^2 / 4)^(2/5)  (Hertz impact).
This bound keeps stiff light-particle scenes (m* = 1e-5) stable.
"""
import math

FIDELITY = {
    # name: (steps per period, steps per shortest contact time scale)
    # AB4 is stable on an oscillation only while omega h < ~0.43: 24 steps
    # per contact time scale (omega h = 0.26) keeps preview stable.
    "preview": (64, 24),
    "standard": (256, 40),
    "reference": (2048, 320),
}


def contact_time_scale(amplitude, mass, impacts=True):
    """Shortest contact time scale of a scene, in wave periods.

    impacts=False: only the linear oscillation (runs that stop at the first
    take-off, such as the jumping threshold, never land)."""
    t_lin = 2.0 * math.pi * math.sqrt(2.0 * mass / 3.0)
    v = 4.0 * math.pi * amplitude
    if v <= 0.0 or not impacts:
        return t_lin
    a_max = (1.25 * mass * v * v) ** 0.4
    return min(t_lin, 2.94 * a_max / v)


def time_step(amplitude, mass, fidelity="standard", refine=1.0, impacts=True):
    """Integration step (periods) for the deformable and vertical models.

    `refine` divides the step (convergence studies).
    """
    per_period, per_contact = FIDELITY[fidelity]
    h = min(1.0 / per_period, contact_time_scale(amplitude, mass, impacts) / per_contact)
    return h / refine


# Material point: the event functions are scanned on this grid (periods) and
# every event found on it is refined to ~1e-13 by bisection.
POINT_MASS_SCAN = {"preview": 1.0 / 32, "standard": 1.0 / 64, "reference": 1.0 / 256}


def scan_step(fidelity="standard", refine=1.0):
    """Scan step (periods) of the event-driven material point."""
    return POINT_MASS_SCAN[fidelity] / refine
