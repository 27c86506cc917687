"""The drivers of the compiled kernels: one per model family.

A kernel runs until a time t_stop and returns a status, with every piece of
its state in arrays its caller owns (records.py).  A driver owns those
arrays and what a kernel cannot do:

* buffers: allocates samples, events (and the memory diagram), grows the one
  a kernel reports full and calls it again;
* chunks: runs the kernel to successive t_stop, so that between chunks it can
  report progress (progress(fraction)) and honour a cancel request
  (cancel.is_set() -> Cancelled);
* the start and the end of a run: the rest state or a caller's own initial
  state, an optional stop at the first take-off, and the final state (and
  memory diagram) returned with the records.

The stopping rule of a run (vibtrans.core.stopping): `full` (to T_obs) or
`decided` (stopping.DecidedRule, checked between chunks).

`run_hertz` drives the deformable and vertical (Hertz) kernels, `run_point_mass`
the material point, `run_memory_stops` the deformable kernel for memory
diagrams at several times of one run; all three through one chunk loop
(`_drive`), each with the kernel that kernels.dispatch.KERNELS names for its
scene.  simulate(), the jumping threshold, memory snapshots and the tests
all run through these.

Chunks are whole kernel calls, so they are part of the numerics: the Hertz
kernels restart their sin/cos rotation at every call (exact to rounding, not
bit-identical), the material point re-bases its closed form at the last
commit (bit-identical on its scan grid).  Each caller keeps its own chunking
(`chunk_steps`; None = one call) and buffer sizes, which is what makes its
results reproducible bit for bit.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from vibtrans.core.errors import Cancelled, InputError, StepBudgetExceeded
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import point_mass as PM
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import (
    FLIGHT,
    LAW_ARG,
    LAW_K1,
    LAW_KIND,
    LAW_ROOT,
    LAW_TABLE,
    STICK,
    kernel_law,
    kind_of_law,
    law_scales,
    new_memory,
)
from vibtrans.core.kernels.dispatch import kernel_for
from vibtrans.core.kernels.integrators import INTEGRATORS
from vibtrans.core.kernels.substrate import surface_acceleration, surface_motion

if TYPE_CHECKING:
    from vibtrans.core.params import Scene

DEFAULT_MAX_STEPS = 200_000_000  # ~5-10 s of one core; the server lowers it
CHUNK_STEPS = 2_000_000  # kernel steps between progress/cancel checks

# what a Hertz kernel gets for the tangent without lyapunov and the law of
# the sphere, arrays it never reads (deformable.hertz_kernel)
_NO_TANGENT = np.empty(0)
_NO_LAW = np.empty(0)


class Run(NamedTuple):
    """What a driver returns: the records and the final state."""

    samples: np.ndarray  # float64[n, records.NCOL]
    events: np.ndarray  # float64[k, 3]
    ctr: np.ndarray  # int64[records.NCTR]
    state: np.ndarray  # the kernel's state at the end
    hist: object = None  # Hertz: derivative history float64[4, 4]
    memory: object = None  # deformable: (H, W, P, nvert, memf)
    tangent: object = None  # Hertz with lyapunov_from: float64[NTANGENT]


def checked_steps(n: Any, max_steps: Any, what: str, h: Any = None) -> int:
    """n (a step estimate) if it is within max_steps, else StepBudgetExceeded
    with the estimate in the message (n = math.inf: a count no float holds)."""
    if n == math.inf:
        step = "" if h is None else f" at a step of {h:.3g} periods"
        raise StepBudgetExceeded(
            f"{what} needs about inf steps{step} (more than a float holds), over any "
            f"budget: reduce periods, amplitude or fidelity"
        )
    if n > max_steps:
        raise StepBudgetExceeded(
            f"{what} needs about {n:.3g} steps, over the budget of {max_steps:.3g} "
            f"(reduce periods or fidelity, or raise max_steps)"
        )
    return n


def grow(a: Any, factor: Any = 2) -> np.ndarray:
    """A copy of `a` with `factor` times the rows (the used rows copied)."""
    out = np.empty((a.shape[0] * factor,) + a.shape[1:], dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


def _integrator(integrator):
    if isinstance(integrator, str):
        if integrator not in INTEGRATORS:
            raise InputError(f"integrator must be one of {', '.join(INTEGRATORS)}, got {integrator!r}")
        return INTEGRATORS[integrator]
    return int(integrator)


def _drive(
    call,
    t_end,
    chunk,
    growers,
    progress=None,
    cancel=None,
    *,
    stopped=None,
    next_check=None,
    stops=None,
    at_stop=None,
):
    """The chunk loop: call a kernel chunk by chunk to t_end, growing
    whichever buffer it reports full; between chunks report
    progress(fraction) and honour cancel (Cancelled).

    Chunks end every `chunk` periods and, where given, also at:
    `next_check(t)`: the next time the stopping rule looks, after a chunk end
        t (DecidedRule.next_check); `stopped()`, called after each chunk,
        ends the run when true;
    `stops`: times (non-decreasing, the last one t_end) at which
        at_stop(stop) is called, the kernel having run to the last step at
        or before it.  A stop does not move the chunk grid (a run's chunk
        ends are the same with or without stops), a check does.
    """
    base = 0.0  # where the current chunk started
    for target in [t_end] if stops is None else stops:
        while True:
            t_next = base + chunk
            if next_check is not None:
                t_next = min(t_next, next_check(base))
            t_stop = min(t_next, target)
            _until_done(call, t_stop, growers)
            if t_stop < target:
                base = t_stop
            if stopped is not None and stopped():
                t_stop = t_end
            if progress is not None:
                progress(t_stop / t_end)
            if t_stop >= t_end:
                if at_stop is not None:
                    at_stop(target)
                return
            if cancel is not None and cancel.is_set():
                raise Cancelled("run cancelled")
            if t_stop >= target:
                break
        if at_stop is not None:
            at_stop(target)


def _until_done(call, t_stop, growers):
    """One kernel call to t_stop, repeated after growing whatever it reports full."""
    while True:
        code = call(t_stop)
        if code == R.DONE:
            return
        growers[code]()


def _growers(buf, mem):
    """What a Hertz kernel's status codes ask to grow: the sample and event
    buffers (in `buf`) and the memory diagram's arrays (`mem`, a list;
    the vertical kernel never asks)."""

    def grow_memory():
        mem[0], mem[1], mem[2] = grow(mem[0]), grow(mem[1]), grow(mem[2])

    return {
        R.SAMPLES_FULL: lambda: buf.__setitem__("samples", grow(buf["samples"])),
        R.EVENTS_FULL: lambda: buf.__setitem__("events", grow(buf["events"])),
        R.MEMORY_FULL: grow_memory,
    }


def _record_rest(buf, ctr):
    """The rest state at t = 0 (a* = 1, N* = 1, stuck) as the first sample,
    and the coarse samples' cursor after it."""
    buf["samples"][0] = (0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, STICK, 1.0, 1.0)
    ctr[R.C_NSAMP] = 1
    ctr[R.C_NEXT] = 1


def run_hertz(
    params: Any,
    integrator: str,
    *,
    tangential: Any,
    samples_capacity: int,
    events_capacity: int = 1024,
    memory_capacity: int = 1024,
    state: Any = None,
    hist: Any = None,
    record_rest: bool = True,
    stop_at_takeoff: bool = False,
    chunk_steps: Any = CHUNK_STEPS,
    progress: Any = None,
    cancel: Any = None,
    lyapunov_from: Any = None,
    tangent: Any = None,
    in_flight: bool = False,
    decide: Any = None,
    law: Any = None,
) -> Run:
    """Run the deformable (tangential=True) or vertical Hertz kernel.

    params: models.deformable.kernel_params(...), a HertzParams (t_end, step,
        sampling there).
    integrator: "ab4", "verlet" or its code.
    state, hist: the initial state (models.deformable.rest_state() if None);
        modified in place.
    record_rest: record the rest state at t = 0 and start the coarse samples
        at sample_dt (as simulate() does); else the first coarse sample is the
        first step (a caller's own initial state).
    stop_at_takeoff: end the run at the first contact loss (vertical only).
    lyapunov_from: a time (periods) to measure the vertical motion's largest
        Lyapunov exponent from (the tangent advanced alongside, Run.tangent;
        models.deformable.lyapunov_exponent); runs from rest only.  The
        records are the same bit for bit.
    tangent: instead, a caller's own tangent (float64[NTANGENT], with its own
        `state`), advanced in place (tangent-map tests, dynamics).
    in_flight: `state` is a flight from its origin state[S_T0:S_VY0+1] (a
        complete initial condition: the history is the flight's at landing).
    chunk_steps: kernel steps per call (progress and cancel between calls);
        None: one call.
    decide: a stopping rule (DecidedRule) checked between calls at
        the times it names; the run ends where it says (runs from rest).
    law: an axisymmetric profile's kernel law (vibtrans.core.profiles.
        kernel_law; docs/MODEL.md section 10); None: the sphere (Hertz).
    Returns a Run (memory: the memory diagram's arrays, deformable only).
    """
    if stop_at_takeoff and (tangential or lyapunov_from is not None):
        raise ValueError("stop_at_takeoff applies to the vertical kernel only, without lyapunov_from")
    integ = _integrator(integrator)
    t_end = params.t_end
    h = params.step
    if lyapunov_from is not None:
        if state is not None or tangent is not None:
            raise ValueError("lyapunov_from applies to runs from rest only")
        tangent = D.rest_tangent(
            params.mass, h, float(lyapunov_from), 1.5 if law is None else float(law[LAW_K1])
        )
    if state is None:
        state, hist = D.rest_state()
    buf = {"samples": np.empty((samples_capacity, R.NCOL)), "events": np.empty((events_capacity, 3))}
    ctr = R.new_counters()
    ctr[R.C_STATE] = STICK
    if in_flight:
        ctr[R.C_MODE] = D.MODE_FLIGHT
        ctr[R.C_STATE] = FLIGHT
    mem = _new_memory(memory_capacity, law) if tangential else D.unused_memory()
    if record_rest:
        _record_rest(buf, ctr)

    call = _hertz_call(
        params,
        integ,
        state,
        hist,
        tangent,
        mem,
        buf,
        ctr,
        law,
        tangential=tangential,
        stop_at_takeoff=stop_at_takeoff,
    )
    growers = _growers(buf, mem)
    chunk = t_end if chunk_steps is None else max(1.0, chunk_steps * h)
    stopped = (lambda: ctr[R.C_MODE] == D.MODE_FLIGHT) if stop_at_takeoff else None
    next_check = None
    if decide is not None:
        stopped, next_check = _hertz_decider(decide, buf, ctr, state, tangent), decide.next_check
    _drive(call, t_end, chunk, growers, progress, cancel, stopped=stopped, next_check=next_check)
    n, k = ctr[R.C_NSAMP], ctr[R.C_NEVT]
    return Run(
        buf["samples"][:n], buf["events"][:k], ctr, state, hist, tuple(mem) if tangential else None, tangent
    )


@functools.lru_cache(maxsize=32)
def _law_of(profile, load_over_modulus):
    from vibtrans.core.params import Scene

    return kernel_law(Scene(profile=profile, load_over_modulus=load_over_modulus).profile_shape())


def scene_law(scene: Scene) -> np.ndarray | None:
    """The kernels' law of a scene's profile (kernels.contact.kernel_law;
    None: the sphere's own path), built once per profile."""
    return _law_of(scene.profile, scene.load_over_modulus)


def scene_scales(scene: Scene) -> tuple[float, float] | None:
    """(N*'(1), p) of a scene's profile for the time step (None: the sphere)."""
    law = scene_law(scene)
    return None if law is None else law_scales(law)


def law_path(scene: Scene) -> str:
    """Which of the kernels' contact-law paths a scene runs (their costs per
    step differ: tools.bench's profile_cost): "sphere" (Hertz's own),
    "cone" (a power law whose N*' is linear), "power" (an integer n up to
    WARM_ROOT_MAX: the warm-started root), "power-pow" (any other n: pow()
    at every evaluation) or "table" (the interpolated table)."""
    law = scene_law(scene)
    if law is None:
        return "sphere"
    if law[LAW_KIND] == LAW_TABLE:
        return "table"
    if law[LAW_ARG] == 2.0:
        return "cone"
    return "power" if law[LAW_ROOT] != 0.0 else "power-pow"


def _new_memory(capacity, law):
    """A memory diagram at rest (a* = 1, b* = 0), in the law's format."""
    return list(new_memory(capacity, law))


def _hertz_call(
    params, integ, state, hist, tangent, mem, buf, ctr, law, *, tangential, stop_at_takeoff=False
):
    """A Hertz run's kernel call to t_stop, call(t_stop) -> status: the
    kernel that kernels.dispatch.KERNELS names for the run (its model,
    whether `tangent` advances, its law's kind, whether the particle turns:
    params.roll_ratio non-zero), on the run's arrays (`mem` and `buf` read
    at each call: the growers replace them)."""
    rolling = params.roll_ratio != 0.0
    if rolling and not tangential:
        raise ValueError("a rolling particle runs the deformable kernel (tangential=True)")
    kernel = kernel_for(
        "deformable" if tangential else "vertical", tangent is not None, kind_of_law(law), rolling
    )
    tangent = _NO_TANGENT if tangent is None else tangent
    law = _NO_LAW if law is None else law

    def call(t_stop):
        return kernel(
            params,
            integ,
            stop_at_takeoff,
            state,
            hist,
            tangent,
            *mem,
            buf["samples"],
            buf["events"],
            ctr,
            t_stop,
            law,
        )

    return call


def _hertz_decider(decide, buf, ctr, state, tangent):
    """The `stopped()` of a Hertz run under a stopping rule: its records so
    far, the flight in progress and the tangent's growth, to the rule."""

    def stopped():
        n, k = ctr[R.C_NSAMP], ctr[R.C_NEVT]
        flying = ctr[R.C_MODE] == D.MODE_FLIGHT
        lyapunov = None
        if tangent is not None and tangent[D.L_START] >= 0.0:
            norm = math.hypot(tangent[D.L_DY], tangent[D.L_DVY])
            growth = tangent[D.L_LOG] + math.log(norm) - tangent[D.L_LOG_START] if norm > 0.0 else math.nan
            lyapunov = (float(tangent[D.L_START]), float(growth))
        t_now = max(float(buf["samples"][n - 1, R.T_]) if n else 0.0, float(state[D.S_T]))
        flight = None
        if flying:  # the flight from its origin, at t_now
            s = t_now - state[D.S_T0]
            flight = (
                t_now,
                state[D.S_X0] + state[D.S_VX0] * s,
                state[D.S_VX0],
                state[D.S_Y0] + state[D.S_VY0] * s + s * s / (2.0 * decide.mass),
                state[D.S_VY0] + s / decide.mass,
            )
        return decide(
            t_now,
            buf["samples"][:n],
            buf["events"][:k],
            float(state[D.S_T0]) if flying else None,
            lyapunov,
            flight,
        )

    return stopped


def _final_step(params, integ, state, hist, mem, ctr, law=None):
    """The deformable kernel's final call of a run ending at params.t_end, on
    copies of a run's state (left as it was), which a non-final call has
    brought to the last step at or before t_end: it commits the step that
    reaches t_end (or stops a flight at t_end), as a run from rest to t_end
    ends.  Returns (state, ctr, memory) of the copy."""
    state, hist, ctr = state.copy(), hist.copy(), ctr.copy()
    mem = [a.copy() for a in mem]
    ctr[R.C_NSAMP] = 0  # its records go to small buffers of its own
    ctr[R.C_NEVT] = 0
    buf = {"samples": np.empty((16, R.NCOL)), "events": np.empty((16, 3))}
    call = _hertz_call(params, integ, state, hist, None, mem, buf, ctr, law, tangential=True)
    _until_done(call, params.t_end, _growers(buf, mem))
    return state, ctr, tuple(mem)


def run_memory_stops(
    params: Any,
    integrator: str,
    stops: Any,
    *,
    samples_capacity: int,
    events_capacity: int = 1024,
    memory_capacity: int = 1024,
    chunk_steps: Any = CHUNK_STEPS,
    progress: Any = None,
    cancel: Any = None,
    law: Any = None,
) -> list[Any]:
    """One run of the deformable kernel from rest, with the memory diagram
    taken at each of `stops` (non-decreasing times, periods, the last one
    params.t_end): a list of (state, ctr, memory), one per stop, each what
    `run_hertz` returns at the end of a run to that stop.

    The kernel calls end at run_hertz's chunk ends and at each stop; a call
    to a stop before t_end is non-final (the last step at or before it), and
    a copy of the state takes the final step (`_final_step`).  The step
    sequence is therefore that of a run to each stop, but each extra call
    restarts the kernel's sin/cos rotation and a flight's landing search, so
    the diagram at a stop before t_end agrees with a separate run's to
    rounding, not bit for bit (as chunks do, module docstring); at t_end
    alone (one stop) it is run_hertz's, bit for bit.  progress(fraction) and
    cancel as in run_hertz.
    """
    integ = _integrator(integrator)
    t_end = params.t_end
    state, hist = D.rest_state()
    buf = {"samples": np.empty((samples_capacity, R.NCOL)), "events": np.empty((events_capacity, 3))}
    ctr = R.new_counters()
    ctr[R.C_STATE] = STICK
    mem = _new_memory(memory_capacity, law)
    _record_rest(buf, ctr)
    call = _hertz_call(params, integ, state, hist, None, mem, buf, ctr, law, tangential=True)
    out = []

    def at_stop(stop):
        if stop < t_end:
            # a stop inside the run: a copy takes the step that reaches it
            out.append(_final_step(params._replace(t_end=stop), integ, state, hist, mem, ctr, law))
        else:
            out.append((state, ctr, tuple(mem)))

    chunk = t_end if chunk_steps is None else max(1.0, chunk_steps * params.step)
    _drive(call, t_end, chunk, _growers(buf, mem), progress, cancel, stops=list(stops), at_stop=at_stop)
    return out


def point_mass_capacity(params: Any) -> int:
    """Initial sample rows of a point-mass run (coarse samples, window, margin)."""
    t_end = params.t_end
    sample_dt = params.sample_dt
    n = 16
    if math.isfinite(sample_dt) and sample_dt > 0.0:
        n += int(t_end / sample_dt)
    w0 = max(params.win_t0, 0.0)
    w1 = min(params.win_t1, t_end)
    if w1 >= w0:
        n += int((w1 - w0) / params.scan_dt) + 64
    return n


def _pm_flight_start(events):
    """The last take-off's time (the flight in progress), or 0 (none yet);
    searched from the end (in a flight the take-off is the last event or
    near it: a check costs O(1), not O(events))."""
    kinds = events[:, 1]
    for i in range(kinds.size - 1, -1, -1):
        if kinds[i] == R.TAKEOFF:
            return float(events[i, 0])
    return 0.0


def run_point_mass(
    params: Any,
    stick_rule: Any = PM.RULE_PAPER,
    *,
    samples_capacity: int | None = None,
    events_capacity: int = 1024,
    chunk_steps: Any = CHUNK_STEPS,
    progress: Any = None,
    cancel: Any = None,
    decide: Any = None,
    growth: Any = None,
) -> Run:
    """Run the material point from rest to t_end (params: a
    point_mass.PointMassParams, from point_mass.make_params).

    stick_rule: point_mass.RULE_* or its name.  The run ends with the state
    at t_end recorded (x*(T_obs) makes the drift velocity), also where t_end
    is off the scan grid.  chunk_steps: scan steps per call (whole periods:
    bit-identical to one call); None: one call.  decide: a stopping rule
    (DecidedRule) checked at the whole periods it names (chunk ends
    on the scan grid: bit-identical up to its stop).  growth: the impact
    map's tangent (lyapunov.ImpactGrowth) the rule reads its exponent from
    at each check (None: not measured).  Returns a Run (state: t, x, vx, y,
    vy).
    """
    rule = PM.rule_code(stick_rule)
    t_end = params.t_end
    dt = params.scan_dt
    if samples_capacity is None:
        samples_capacity = point_mass_capacity(params)
    state = np.zeros(5)
    work = PM.new_work()
    ctr = R.new_counters()
    buf = {"samples": np.empty((samples_capacity, R.NCOL)), "events": np.empty((events_capacity, 3))}

    kernel = kernel_for("point-mass")

    def call(t_stop):
        return kernel(params, rule, state, work, buf["samples"], buf["events"], ctr, t_stop)

    def runaway():
        raise StepBudgetExceeded(
            f"the material point met more than {PM.MAX_EVENTS_PER_STEP} events within one "
            f"scan step at t* = {state[0]:.6g} (a sequence of events at rounding level: "
            f"the scene's values are outside the model's numerical range)"
        )

    growers = {
        R.SAMPLES_FULL: lambda: buf.__setitem__("samples", grow(buf["samples"])),
        R.EVENTS_FULL: lambda: buf.__setitem__("events", grow(buf["events"])),
        R.EVENTS_RUNAWAY: runaway,
    }
    # chunks end on whole periods (on the scan grid: bit-identical to one call)
    chunk = t_end if chunk_steps is None else max(1.0, float(round(chunk_steps * dt)))
    stopped = next_check = None
    if decide is not None:

        def stopped():
            n, k = ctr[R.C_NSAMP], ctr[R.C_NEVT]
            flying = ctr[R.C_MODE] == PM.MODE_FLIGHT
            events = buf["events"][:k]
            return decide(
                float(state[0]),
                buf["samples"][:n],
                events,
                _pm_flight_start(events) if flying else None,
                None if growth is None else growth.update(events),
                tuple(float(v) for v in state) if flying else None,
            )

        next_check = decide.next_check
    _drive(call, t_end, chunk, growers, progress, cancel, stopped=stopped, next_check=next_check)
    n = ctr[R.C_NSAMP]
    if n == 0 or buf["samples"][n - 1, R.T_] < state[0]:
        # T_obs off the scan grid: record the final state too (x*(T_obs) is
        # what the drift velocity is made of).
        if n >= buf["samples"].shape[0]:
            buf["samples"] = grow(buf["samples"])
        A, r, tau, m, mu, theta = (
            params.amplitude,
            params.r,
            params.tau,
            params.mass,
            params.mu,
            params.theta,
        )
        t = state[0]
        ux, uy, dux, duy = surface_motion(t, A, r, tau)
        ax, ay = surface_acceleration(t, A, r, tau)
        PM.record_row(
            buf["samples"],
            ctr,
            t,
            state[1],
            state[2],
            state[3],
            state[4],
            ctr[R.C_MODE],
            ux,
            uy,
            dux,
            duy,
            ax,
            ay,
            m,
            mu,
            theta * mu,
        )
    n, k = ctr[R.C_NSAMP], ctr[R.C_NEVT]
    return Run(buf["samples"][:n], buf["events"][:k], ctr, state)
