"""Kernel runs from initial conditions the public API does not expose (the
free Hertz oscillator), through the production driver (vibtrans.core.drivers)."""

import numpy as np

from vibtrans.core import drivers
from vibtrans.core.fidelity import time_step
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R


def free_oscillator(
    y0, mass, periods, integrator="ab4", fidelity="standard", samples_per_period=4, refine=1.0
):
    """Vertical Hertz particle with A* = 0 released at rest from y* = y0
    (`refine` divides the fidelity's step), in one kernel call; buffers grow
    as needed.

    Returns (samples, events, counters, h).
    """
    h = time_step(0.0, mass, fidelity, refine)
    p = D.kernel_params(0.0, mass, 1.0, 1.0, 0.0, 0.0, h, periods, 1.0 / samples_per_period)
    state, hist = D.rest_state(y0)
    ay = (1.0 - max(y0, 0.0) ** 1.5) / mass  # at rest before t = 0: constant force
    hist[:, 3] = ay
    hist[:, 2] = -np.arange(4) * h * ay  # v(t - j h) of the same motion (to O(h^2))
    run = drivers.run_hertz(
        p,
        integrator,
        tangential=False,
        state=state,
        hist=hist,
        record_rest=False,
        chunk_steps=None,
        samples_capacity=int(periods * samples_per_period) + 16,
        events_capacity=int(periods) * 8 + 64,
    )
    return run.samples, run.events, run.ctr, h


def hertz_energy(samples, mass):
    """m* y'^2 / 2 - y + (2/5) max(a, 0)^(5/2)  (A* = 0, so a* = y*)."""
    y = samples[:, R.Y]
    vy = samples[:, R.VY]
    a = np.maximum(samples[:, R.A], 0.0)
    return 0.5 * mass * vy**2 - y + 0.4 * a**2.5
