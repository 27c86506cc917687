"""The jumping threshold A_J*(m*): the smallest amplitude at which the
particle ever loses contact during the observation time (vertical motion
alone, docs/MODEL.md section 4), found by bisection in log10 A*.

Jumping is monotonic in A* (the paper's argument: if it jumps at A*, it jumps
at any larger amplitude), which is what makes bisection valid.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from vibtrans.core import drivers
from vibtrans.core.drivers import DEFAULT_MAX_STEPS
from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import step_count, time_step
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R
from vibtrans.core.params import Scene

if TYPE_CHECKING:
    import numpy.typing as npt
    import xarray as xr


def first_takeoff(
    amplitude: float,
    mass: float,
    tau: float = 50.0,
    periods: float = 2000.0,
    fidelity: str = "standard",
    integrator: str = "ab4",
    profile: str = "sphere",
    load_over_modulus: float | None = None,
) -> float:
    """Time of the first contact loss of the vertical Hertz particle.

    Inputs are validated as a Scene would validate them.

    Parameters
    ----------
    amplitude : float
        A*, the normalized wave amplitude.
    mass : float
        m*, the normalized mass.
    tau : float
        Ramp time of the wave, periods.
    periods : float
        Observation time T_obs, periods.
    fidelity : str
        Time-step preset.
    integrator : str
        "ab4" or "verlet".
    profile : str
        The particle's tip profile.
    load_over_modulus : float, optional
        N0/E* [m^2], needed by measured profiles.

    Returns
    -------
    float
        The time of the first take-off, periods; inf if none within `periods`.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    """
    scene = Scene(
        amplitude=amplitude,
        mass=mass,
        tau=tau,
        periods=periods,
        fidelity=fidelity,
        integrator=integrator,
        model="vertical",
        profile=profile,
        load_over_modulus=load_over_modulus,
    )
    return _first_takeoff(scene)


def _first_takeoff(scene, max_steps=DEFAULT_MAX_STEPS):
    # it stops at the first take-off: no impact to resolve, only the linear
    # contact oscillation
    law = drivers.scene_law(scene)
    h = time_step(
        scene.amplitude, scene.mass, scene.fidelity, impacts=False, scales=drivers.scene_scales(scene)
    )
    drivers.checked_steps(
        step_count(scene.periods, h),
        max_steps,
        f"threshold run at A* = {scene.amplitude:.3g}, m* = {scene.mass:.3g}",
        h,
    )
    p = D.kernel_params(scene.amplitude, scene.mass, 1.0, 1.0, 0.0, scene.tau, h, scene.periods, math.inf)
    # one kernel call (chunk_steps=None): a take-off time is bit-reproducible
    run = drivers.run_hertz(
        p,
        scene.integrator,
        tangential=False,
        samples_capacity=4,
        events_capacity=8,
        stop_at_takeoff=True,
        chunk_steps=None,
        law=law,
    )
    hit = np.flatnonzero(run.events[:, 1] == R.TAKEOFF)
    return float(run.events[hit[0], 0]) if hit.size else math.inf


def threshold_amplitude(
    mass: float,
    tau: float = 50.0,
    periods: float = 2000.0,
    fidelity: str = "standard",
    integrator: str = "ab4",
    rel_tol: float = 1e-3,
    guess: float | None = None,
    profile: str = "sphere",
    load_over_modulus: float | None = None,
) -> float:
    """The jumping threshold A_J*(m*): the smallest A* with a contact loss.

    Bisection in log10 A* to a relative width `rel_tol`.  Without a guess the
    bracket starts from the rigid line 1 / (4 pi^2 m*) (a rigid contact jumps
    first at low m*; above the resonance, at A* ~ 1); with a guess (the
    threshold of a neighbouring mass) it starts at guess / 1.25 .. guess * 1.25
    and widens as needed, which saves most of the full-length runs.

    Parameters
    ----------
    mass : float
        m*, the normalized mass.
    tau : float
        Ramp time of the wave, periods.
    periods : float
        Observation time T_obs, periods: a contact loss must come within it.
    fidelity : str
        Time-step preset ("preview", "standard", ...).
    integrator : str
        "ab4" or "verlet".
    rel_tol : float
        Relative width of the final bracket, in [1e-12, 0.5].
    guess : float, optional
        A nearby threshold to start the bracket from.
    profile : str
        The particle's tip profile, one of PROFILE_KINDS.
    load_over_modulus : float, optional
        N0/E* [m^2], needed by measured profiles.

    Returns
    -------
    float
        A_J*, the geometric mean of the final bracket.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    RuntimeError
        If no contact loss occurs up to A* = 1e8.
    """
    if isinstance(rel_tol, bool) or not isinstance(rel_tol, (int, float)) or not 1e-12 <= rel_tol <= 0.5:
        raise InputError(f"rel_tol must be in [1e-12, 0.5], got {rel_tol!r}")
    base = Scene(
        mass=mass,
        tau=tau,
        periods=periods,
        fidelity=fidelity,
        integrator=integrator,
        model="vertical",
        profile=profile,
        load_over_modulus=load_over_modulus,
    )

    def jumps(a):
        return _first_takeoff(base.replace(amplitude=a)) < math.inf

    def first_jump_above(lo, hi, factor):
        # widen upwards until the particle jumps; lo tracks the last quiet amplitude
        while not jumps(hi):
            lo, hi = hi, hi * factor
            if hi > 1e8:
                raise RuntimeError(f"no contact loss up to A* = 1e8 at m* = {mass:g}")
        return lo, hi

    if guess is not None and guess > 0 and math.isfinite(guess):
        lo, hi = guess / 1.25, guess * 1.25
        while jumps(lo):
            hi, lo = lo, lo / 1.25
            if lo < 1e-6:
                return lo
        lo, hi = first_jump_above(lo, hi, 1.25)
    else:
        _, hi = first_jump_above(None, max(4.0, 4.0 / (4.0 * math.pi**2 * mass)), 4.0)
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


def point_mass_threshold(mass: float) -> float:
    """Rigid contact: jumping at m* = 1/(4 pi^2 A*) (docs/MODEL.md section 3)."""
    return 1.0 / (4.0 * math.pi**2 * mass)


def point_mass_sliding_threshold(mass: float, mu: float = 0.3, r: Any = None, nu: float = 0.3) -> float:
    """Rigid contact: sliding starts at m* = mu/sqrt(mu^2+r^2)/(4 pi^2 A*)."""
    if r is None:
        r = Scene(nu=nu).r
    return mu / math.sqrt(mu * mu + r * r) / (4.0 * math.pi**2 * mass)


def _threshold_task(args):
    """A run of consecutive masses, each bracketed from its neighbour."""
    masses, values = args
    out = []
    guess = None
    for m in masses:
        guess = threshold_amplitude(m, guess=guess, **values)
        out.append(guess)
    return out


def local_minima(log_mass: npt.ArrayLike, aj: npt.ArrayLike) -> np.ndarray:
    """Indices of the strict local minima of A_J*(m*) (resonance candidates)."""
    aj = np.asarray(aj)
    i = np.arange(1, aj.size - 1)
    return i[(aj[i] < aj[i - 1]) & (aj[i] <= aj[i + 1])]


def resonances(log_mass: npt.ArrayLike, aj: npt.ArrayLike) -> dict[Any, Any] | dict[str, int]:
    """Name the resonances of the curve (paper, section III.A).

    fundamental: the deepest minimum (m_c* ~ 3/(8 pi^2)); subharmonic: the
    deepest minimum within a factor 2 of 4 m_c*; superharmonics: minima below
    m_c* (at roughly m_c*/n^2, n = 2, 3, ...), deepest first.
    """
    log_mass = np.asarray(log_mass)
    aj = np.asarray(aj)
    mins = local_minima(log_mass, aj)
    if mins.size == 0:
        return {}
    fund = int(mins[np.argmin(aj[mins])])
    mc = 10 ** log_mass[fund]
    out = {"fundamental": fund}
    near4 = [i for i in mins if 2 * mc < 10 ** log_mass[i] < 8 * mc]
    if near4:
        out["subharmonic"] = int(min(near4, key=lambda i: aj[i]))
    supers = sorted((i for i in mins if 10 ** log_mass[i] < mc / 2), key=lambda i: aj[i])
    for n, i in enumerate(supers[:4], start=2):
        out[f"superharmonic_{n}"] = int(i)
    return out


def threshold_curve(
    log_mass: npt.ArrayLike,
    tau: float = 50.0,
    periods: float = 2000.0,
    fidelity: str = "standard",
    workers: int | None = None,
    progress: bool = True,
    profile: str = "sphere",
    load_over_modulus: float | None = None,
) -> xr.Dataset:
    """The jumping threshold A_J*(m*) over a grid of log10 m*.

    With the rigid line and the resonances; runs on a local process pool.

    Parameters
    ----------
    log_mass : array_like
        The grid of log10 m*.
    tau : float
        Ramp time of the wave, periods.
    periods : float
        Observation time T_obs, periods.
    fidelity : str
        Time-step preset.
    workers : int, optional
        Processes of the pool; None: one per core.
    progress : bool
        Show a progress bar on stderr.
    profile : str
        The particle's tip profile.
    load_over_modulus : float, optional
        N0/E* [m^2], needed by measured profiles.

    Returns
    -------
    xarray.Dataset
        `threshold_amplitude` (and the material point's) along
        `log_mass`, as read by `open_vertical`.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    """
    import multiprocessing as mp
    import os
    import sys
    from concurrent.futures import ProcessPoolExecutor

    import xarray as xr
    from tqdm import tqdm

    from vibtrans.version import __version__

    values = dict(
        tau=tau, periods=periods, fidelity=fidelity, profile=profile, load_over_modulus=load_over_modulus
    )
    Scene(**values)  # validate
    log_mass = np.asarray(log_mass, dtype=float)
    masses = 10.0**log_mass
    tasks = [(masses[i : i + 25], values) for i in range(0, masses.size, 25)]
    workers = workers or os.cpu_count() or 1
    with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn")) as pool:
        parts = list(
            tqdm(
                pool.map(_threshold_task, tasks),
                total=len(tasks),
                file=sys.stderr,
                disable=not progress,
                desc="threshold runs",
            )
        )
    aj = np.concatenate(parts)
    res = resonances(log_mass, aj)
    ds = xr.Dataset(
        {
            "threshold_amplitude": ("log_mass", aj, {"description": "A_J*: deformable (Hertz) particle"}),
            "point_mass_threshold_amplitude": (
                "log_mass",
                1.0 / (4 * np.pi**2 * masses),
                {"description": "rigid contact: 1/(4 pi^2 m*)"},
            ),
        },
        coords={"log_mass": log_mass},
        attrs={
            "tau": tau,
            "periods": periods,
            "fidelity": fidelity,
            "code_version": __version__,
            **({} if profile == "sphere" else {"profile": profile}),
            **{f"resonance_{k}_log_mass": float(log_mass[i]) for k, i in res.items()},
            **{f"resonance_{k}_amplitude": float(aj[i]) for k, i in res.items()},
        },
    )
    return ds
