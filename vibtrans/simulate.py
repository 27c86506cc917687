"""Run a scene: validate, choose the step, drive a kernel in chunks.

The public entry point is `simulate(scene)`.  The numba kernels run in chunks
of about a million steps; between chunks we report progress, honour a cancel
request, and grow any buffer a kernel reports full, so a long run stays
responsive and memory follows the need.
"""
import math
import time

import numpy as np

from . import __version__
from . import records as R
from .contact import STICK, new_memory
from .fidelity import scan_step, time_step
from .integrators import INTEGRATORS
from .models import deformable as D
from .models import point_mass as PM
from .models.vertical import vertical_kernel
from .params import Scene
from .substrate import surface_acceleration, surface_motion
from .trajectory import build_trajectory
from .errors import Cancelled, InputError, InputTypeError, StepBudgetExceeded

DEFAULT_MAX_STEPS = 200_000_000   # ~5-10 s of one core; the server lowers it
CHUNK_STEPS = 2_000_000
SAMPLES_PER_PERIOD = 10


def _scene(scene, values):
    if scene is None:
        return Scene(**values)
    if not isinstance(scene, Scene):
        raise InputTypeError(f"scene must be a vibtrans Scene, got {type(scene).__name__}")
    return scene.replace(**values) if values else scene


def estimate_steps(scene, refine=1.0, steps=None):
    """Upper estimate of the integration steps of a scene (before running)."""
    if scene.model == "point-mass":
        return int(math.ceil(scene.periods / scan_step(scene.fidelity, refine)))
    h = time_step(scene.amplitude, scene.mass, scene.fidelity, refine, steps=steps)
    return int(math.ceil(scene.periods / h))


def _check_steps(steps, model):
    if steps is None:
        return None
    try:
        per_period, per_contact = (float(v) for v in steps)
    except (TypeError, ValueError):
        raise InputError(f"steps must be a pair (steps per period, steps per contact time "
                         f"scale) of numbers in [1, 1e6], got {steps!r}") from None
    if not (1 <= per_period <= 1e6 and 1 <= per_contact <= 1e6):
        raise InputError(f"steps must be a pair of numbers in [1, 1e6], got {steps!r}")
    if model == "point-mass":
        raise InputError("steps applies to the deformable and vertical models only "
                         "(the material point is event-driven)")
    return per_period, per_contact


def _window(window, periods):
    if window is None:
        return math.inf, -math.inf
    try:
        w0, w1 = (float(v) for v in window)
    except (TypeError, ValueError):
        raise InputError(f"window must be a pair (t0, t1) of times in [0, {periods:g}], "
                         f"got {window!r}") from None
    if not (math.isfinite(w0) and math.isfinite(w1) and 0 <= w0 <= w1 <= periods):
        raise InputError(f"window must satisfy 0 <= t0 <= t1 <= {periods:g}, got {window!r}")
    return w0, w1


def _grow(a, factor=2):
    out = np.empty((a.shape[0] * factor,) + a.shape[1:], dtype=a.dtype)
    out[:a.shape[0]] = a
    return out


def simulate(scene=None, *, window=None, samples_per_period=SAMPLES_PER_PERIOD,
             max_steps=DEFAULT_MAX_STEPS, progress=None, cancel=None,
             refine=1.0, shortcuts=D.SHORTCUTS_ALL, steps=None, **values):
    """Simulate one scene and return its trajectory (xarray.Dataset).

    scene: a `Scene`, or scene values as keywords (amplitude=..., mass=...).
    window: (t0, t1) in periods, recorded at every step (full resolution);
        elsewhere `samples_per_period` samples per period.
    max_steps: refuse (StepBudgetExceeded) a scene estimated to need more.
    progress: callable(fraction) called between chunks.
    cancel: object with is_set() (threading.Event); raises Cancelled.
    refine: divide the fidelity's step (convergence studies).
    steps: (steps per period, steps per contact time scale) in place of the
        fidelity preset's pair (work-precision studies; Hertz models only).
    shortcuts: bit mask of the Hertz kernels' exact-to-rounding shortcuts
        (models.deformable.SHORT_*; 0 switches them all off, for the bench).
    """
    scene = _scene(scene, values)
    if not (isinstance(samples_per_period, (int, np.integer))
            and not isinstance(samples_per_period, bool) and 1 <= samples_per_period <= 10000):
        raise InputError(f"samples_per_period must be an integer in [1, 10000], "
                         f"got {samples_per_period!r}")
    if isinstance(refine, bool) or not (isinstance(refine, (int, float))
                                        and math.isfinite(refine) and 1 <= refine <= 1024):
        raise InputError(f"refine must be a number in [1, 1024], got {refine!r}")
    if isinstance(shortcuts, bool) or not (isinstance(shortcuts, (int, np.integer))
                                           and 0 <= shortcuts <= D.SHORTCUTS_ALL):
        raise InputError(f"shortcuts must be an integer in [0, {D.SHORTCUTS_ALL}], "
                         f"got {shortcuts!r}")
    if isinstance(max_steps, bool) or not (isinstance(max_steps, (int, float))
                                           and max_steps > 0 and not math.isnan(max_steps)):
        raise InputError(f"max_steps must be a number in (0, inf], got {max_steps!r}")
    steps = _check_steps(steps, scene.model)
    n_steps = estimate_steps(scene, refine, steps)
    if n_steps > max_steps:
        raise StepBudgetExceeded(
            f"scene needs about {n_steps:.3g} steps, over the budget of {max_steps:.3g} "
            f"(reduce periods or fidelity, or raise max_steps)")
    w0, w1 = _window(window, scene.periods)
    runner = _run_point_mass if scene.model == "point-mass" else _run_hertz
    start = time.perf_counter()
    samples, events, ctr, info = runner(scene, w0, w1, samples_per_period, refine,
                                        progress, cancel, shortcuts=int(shortcuts), steps=steps)
    seconds = time.perf_counter() - start
    attrs = dict(scene.values(), r=scene.r, steps=int(ctr[R.C_STEPS]),
                 force_evaluations=int(ctr[R.C_FEVALS]), seconds=seconds,
                 samples_per_period=samples_per_period,
                 window_start=w0 if window is not None else None,
                 window_end=w1 if window is not None else None, refine=refine,
                 code_version=__version__, **info)
    return build_trajectory(samples, events, attrs)


def _drive(call, t_end, chunk, buffers, progress, cancel):
    """Call a kernel chunk by chunk, growing whichever buffer it reports full."""
    t_stop = 0.0
    while True:
        t_stop = min(t_stop + chunk, t_end)
        while True:
            code = call(t_stop)
            if code == R.DONE:
                break
            buffers[code]()
        if progress is not None:
            progress(t_stop / t_end)
        if t_stop >= t_end:
            return
        if cancel is not None and cancel.is_set():
            raise Cancelled("run cancelled")


def _run_hertz(scene, w0, w1, samples_per_period, refine, progress, cancel, final=None,
               shortcuts=D.SHORTCUTS_ALL, steps=None):
    """Run the deformable or vertical kernel; `final` (a dict), if given,
    receives the end state and memory diagram (memory snapshots)."""
    h = time_step(scene.amplitude, scene.mass, scene.fidelity, refine, steps=steps)
    tangential = scene.model == "deformable"
    sdt = 1.0 / samples_per_period
    p = D.kernel_params(scene.amplitude, scene.mass, scene.mu, scene.theta, scene.r,
                        scene.tau, h, scene.periods, sdt, (w0, w1), shortcuts)
    state, hist = D.rest_state()
    n_win = 0 if w1 < w0 else int((w1 - w0) / h) + 2
    buf = {
        "samples": np.empty((int(scene.periods * samples_per_period) + n_win + 16, R.NCOL)),
        "events": np.empty((1024, 3)),
    }
    ctr = R.new_counters()
    ctr[R.C_STATE] = STICK
    mem = list(new_memory(1024)) if tangential else None
    # the initial state at t = 0
    R.record(buf["samples"], ctr, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0,
             STICK, 1.0, 1.0)
    ctr[R.C_NEXT] = 1
    integ = INTEGRATORS[scene.integrator]

    def call(t_stop):
        if tangential:
            return D.deformable_kernel(p, integ, state, hist, *mem, buf["samples"],
                                       buf["events"], ctr, t_stop)
        return vertical_kernel(p, integ, False, state, hist, np.empty(0), buf["samples"],
                               buf["events"], ctr, t_stop)

    def grow_memory():
        mem[0], mem[1], mem[2] = _grow(mem[0]), _grow(mem[1]), _grow(mem[2])

    growers = {
        R.SAMPLES_FULL: lambda: buf.__setitem__("samples", _grow(buf["samples"])),
        R.EVENTS_FULL: lambda: buf.__setitem__("events", _grow(buf["events"])),
        R.MEMORY_FULL: grow_memory,
    }
    _drive(call, scene.periods, max(1.0, CHUNK_STEPS * h), growers, progress, cancel)
    if final is not None:
        final.update(state=state, memory=mem)
    n, k = ctr[R.C_NSAMP], ctr[R.C_NEVT]
    return buf["samples"][:n], buf["events"][:k], ctr, {"h": h}


def _run_point_mass(scene, w0, w1, samples_per_period, refine, progress, cancel,
                    shortcuts=None, steps=None):
    # event-driven: its flights and segments are closed forms already
    dt = scan_step(scene.fidelity, refine)
    p = PM.make_params(scene.amplitude, scene.mass, scene.mu, scene.theta, scene.r,
                       scene.tau, float(scene.periods), scene.alpha_t,
                       1.0 / samples_per_period, (w0, w1), dt)
    rule = PM.rule_code(scene.stick_rule)
    state = np.zeros(5)
    work = PM.new_work()
    ctr = R.new_counters()
    n_win = 0 if w1 < w0 else int((w1 - w0) / dt) + 64
    buf = {"samples": np.empty((int(scene.periods * samples_per_period) + n_win + 16, R.NCOL)),
           "events": np.empty((1024, 3))}

    def call(t_stop):
        return PM.point_mass_kernel(p, rule, state, work, buf["samples"], buf["events"],
                                    ctr, t_stop)

    growers = {
        R.SAMPLES_FULL: lambda: buf.__setitem__("samples", _grow(buf["samples"])),
        R.EVENTS_FULL: lambda: buf.__setitem__("events", _grow(buf["events"])),
    }
    # chunks end on whole periods (on the scan grid: bit-identical to one call)
    _drive(call, scene.periods, max(1.0, float(round(CHUNK_STEPS * dt))), growers,
           progress, cancel)
    n = ctr[R.C_NSAMP]
    if buf["samples"][n - 1, R.T_] < state[0]:
        # T_obs off the scan grid: record the final state too (x*(T_obs) is
        # what the drift velocity is made of).
        if n >= buf["samples"].shape[0]:
            buf["samples"] = _grow(buf["samples"])
        t = state[0]
        ux, uy, dux, duy = surface_motion(t, scene.amplitude, scene.r, scene.tau)
        ax, ay = surface_acceleration(t, scene.amplitude, scene.r, scene.tau)
        PM._record_row(buf["samples"], ctr, t, state[1], state[2], state[3], state[4],
                       ctr[R.C_MODE], ux, uy, dux, duy, ax, ay, scene.mass, scene.mu,
                       scene.theta * scene.mu)
    n, k = ctr[R.C_NSAMP], ctr[R.C_NEVT]
    return buf["samples"][:n], buf["events"][:k], ctr, {"h": dt}


def warmup():
    """Compile (or load from the on-disk cache) every kernel variant, so no
    user-facing run pays for compilation.  Cheap once the cache exists."""
    for model in ("deformable", "vertical", "point-mass"):
        for integrator in ("ab4", "verlet"):
            simulate(Scene(model=model, integrator=integrator, amplitude=100.0,
                           mass=1.0, periods=2.0, tau=0.5), window=(1.0, 1.5))
    from .threshold import first_takeoff
    first_takeoff(1.0, 1.0, periods=1.0)


def memory_snapshot(scene=None, t=None, **values):
    """The memory diagram of a deformable scene at time t (periods).

    Runs the scene from rest to t and returns a dict: t, a, b (a*, b* at t),
    h and w (the anchor polyline w(h), absolute b* units; empty in flight),
    u = b - w (spring displacements), stick_depth s_h, and state code.
    """
    from .contact import anchor_profile
    scene = _scene(scene, values)
    if scene.model != "deformable":
        raise InputError(f"model must be deformable for a memory diagram, got {scene.model!r}")
    if t is None or isinstance(t, bool) or not isinstance(t, (int, float)) \
            or not (0 <= t <= scene.periods):
        raise InputError(f"t must be a time in [0, {scene.periods:g}] periods, got {t!r}")
    short = scene.replace(periods=max(float(t), 1e-9))
    final = {}
    _, _, ctr, _ = _run_hertz(short, math.inf, -math.inf, 1, 1.0, None, None, final)
    state, mem = final["state"], final["memory"]
    H, W, P, nvert, memf = mem
    hs, ws = anchor_profile(H, W, nvert, memf)
    a, b = float(memf[0]), float(memf[1])
    return {"t": float(state[D.S_T]), "a": a, "b": b, "h": hs, "w": ws, "u": b - ws,
            "stick_depth": _stick_depth(hs, ws, a, b), "state": int(ctr[R.C_STATE])}


def _stick_depth(h, w, a, b):
    """Depth where the springs stop being at their Coulomb limit |u| = a - h."""
    if h.size == 0:
        return 0.0
    at_limit = np.abs(np.abs(b - w) - (a - h)) <= 1e-12 * (1 + abs(b) + a)
    i = h.size - 1
    while i > 0 and at_limit[i - 1]:
        i -= 1
    return float(h[i]) if i < h.size - 1 else float(a)
