"""The jumping threshold A_J*(m*): the smallest amplitude at which the
particle ever loses contact during the observation time (vertical motion
alone, MODEL.md section 4), found by bisection in log10 A*.

Jumping is monotonic in A* (the paper's argument: if it jumps at A*, it jumps
at any larger amplitude), which is what makes bisection valid.
"""
import math

import numpy as np

from . import records as R
from .contact import STICK
from .fidelity import time_step
from .integrators import INTEGRATORS
from .models import deformable as D
from .models.vertical import vertical_kernel
from .params import Physical, Scene

_NO_MEMORY = np.empty(0)


def first_takeoff(amplitude, mass, tau=50.0, periods=2000.0, fidelity="standard",
                  integrator="ab4"):
    """Time of the first contact loss of the vertical Hertz particle, or inf.

    Inputs are validated as a Scene would validate them.
    """
    scene = Scene(amplitude=amplitude, mass=mass, tau=tau, periods=periods,
                  fidelity=fidelity, integrator=integrator, model="vertical")
    return _first_takeoff(scene)


def _first_takeoff(scene):
    h = time_step(scene.amplitude, scene.mass, scene.fidelity)
    p = np.zeros(D.NPARAM)
    p[[D.P_A, D.P_M, D.P_MU, D.P_THETA, D.P_R, D.P_TAU, D.P_H, D.P_TEND,
       D.P_SDT, D.P_W0, D.P_W1]] = (scene.amplitude, scene.mass, 1.0, 1.0, 0.0,
                                    scene.tau, h, scene.periods, math.inf,
                                    math.inf, -math.inf)
    state = np.zeros(D.NSTATE)
    state[D.S_Y] = 1.0
    state[D.S_GAP] = 1.0
    hist = np.zeros((4, 4))
    samples = np.empty((4, R.NCOL))
    events = np.empty((8, 3))
    ctr = R.new_counters()
    ctr[R.C_STATE] = STICK
    ctr[R.C_NEXT] = 1
    vertical_kernel(p, INTEGRATORS[scene.integrator], True, state, hist, _NO_MEMORY,
                    samples, events, ctr, scene.periods)
    kinds = events[:ctr[R.C_NEVT], 1]
    hit = np.flatnonzero(kinds == R.TAKEOFF)
    return float(events[hit[0], 0]) if hit.size else math.inf


_TOL = Physical(1e-3, bounds=(1e-12, 0.5))


def threshold_amplitude(mass, tau=50.0, periods=2000.0, fidelity="standard",
                        integrator="ab4", rel_tol=1e-3):
    """A_J*(m*): smallest A* with a contact loss within `periods`.

    Bisection in log10 A* to a relative width rel_tol.  The point-mass line
    1 / (4 pi^2 m*) bounds the search from above (a rigid contact jumps
    first at low m*; above the resonance, at A* ~ 1).
    """
    _TOL._validate(rel_tol)
    base = Scene(mass=mass, tau=tau, periods=periods, fidelity=fidelity,
                 integrator=integrator, model="vertical")

    def jumps(a):
        return _first_takeoff(base.replace(amplitude=a)) < math.inf

    hi = max(4.0, 4.0 / (4.0 * math.pi ** 2 * mass))
    while not jumps(hi):
        hi *= 4.0
        if hi > 1e8:
            raise RuntimeError(f"no contact loss up to A* = 1e8 at m* = {mass:g}")
    lo = 1e-5
    if jumps(lo):
        return lo
    while math.log(hi / lo) > rel_tol:
        mid = math.sqrt(lo * hi)
        if jumps(mid):
            hi = mid
        else:
            lo = mid
    return math.sqrt(lo * hi)


def point_mass_threshold(mass):
    """Rigid contact: jumping at m* = 1/(4 pi^2 A*) (MODEL.md section 3)."""
    return 1.0 / (4.0 * math.pi ** 2 * mass)


def point_mass_sliding_threshold(mass, mu=0.3, r=None, nu=0.3):
    """Rigid contact: sliding starts at m* = mu/sqrt(mu^2+r^2)/(4 pi^2 A*)."""
    if r is None:
        r = Scene(nu=nu).r
    return mu / math.sqrt(mu * mu + r * r) / (4.0 * math.pi ** 2 * mass)
