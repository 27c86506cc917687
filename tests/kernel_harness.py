"""Direct kernel drivers for tests that need initial conditions the public
API does not expose (the free Hertz oscillator)."""

import numpy as np

from vibtrans import records as R
from vibtrans.contact import STICK
from vibtrans.fidelity import time_step
from vibtrans.integrators import INTEGRATORS
from vibtrans.models import deformable as D
from vibtrans.models.vertical import vertical_kernel


def free_oscillator(y0, mass, periods, integrator="ab4", fidelity="standard",
                    samples_per_period=4, refine=1.0):
    """Vertical Hertz particle with A* = 0 released at rest from y* = y0
    (`refine` divides the fidelity's step).

    Returns (samples, events, counters, h).
    """
    h = time_step(0.0, mass, fidelity, refine)
    p = D.kernel_params(0.0, mass, 1.0, 1.0, 0.0, 0.0, h, periods, 1.0 / samples_per_period)
    state, hist = D.rest_state(y0)
    ay = (1.0 - max(y0, 0.0) ** 1.5) / mass   # at rest before t = 0: constant force
    hist[:, 3] = ay
    hist[:, 2] = -np.arange(4) * h * ay       # v(t - j h) of the same motion (to O(h^2))
    samples = np.empty((int(periods * samples_per_period) + 16, R.NCOL))
    events = np.empty((int(periods) * 8 + 64, 3))
    ctr = R.new_counters()
    ctr[R.C_STATE] = STICK
    code = vertical_kernel(p, INTEGRATORS[integrator], False, state, hist, np.empty(0),
                           samples, events, ctr, periods)
    assert code == R.DONE, code
    return samples[:ctr[R.C_NSAMP]], events[:ctr[R.C_NEVT]], ctr, h


def hertz_energy(samples, mass):
    """m* y'^2 / 2 - y + (2/5) max(a, 0)^(5/2)  (A* = 0, so a* = y*)."""
    y = samples[:, R.Y]
    vy = samples[:, R.VY]
    a = np.maximum(samples[:, R.A], 0.0)
    return 0.5 * mass * vy ** 2 - y + 0.4 * a ** 2.5
