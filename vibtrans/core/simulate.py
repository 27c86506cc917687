"""Run a scene: validate, estimate its cost, choose the step, run its driver.

The public entry point is `simulate(scene)`; `warmup` compiles the kernels
ahead of the first run.  The kernels run through
`vibtrans.core.drivers` in chunks of about two million steps; between chunks the
driver reports progress, honours a cancel request, and grows any buffer a
kernel reports full, so a long run stays responsive and memory follows the
need.
"""

from __future__ import annotations

import math
import numbers
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from vibtrans.core import drivers
from vibtrans.core.drivers import DEFAULT_MAX_STEPS
from vibtrans.core.errors import Cancelled, InputError, InputTypeError, StepBudgetExceeded  # noqa: F401
from vibtrans.core.fidelity import scan_step, step_count, time_step
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import point_mass as PM
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.substrate import RAMP_OFF
from vibtrans.core.lyapunov import ImpactGrowth
from vibtrans.core.params import Scene
from vibtrans.core.stopping import STOP_FLIGHT, DecidedRule, check_stop
from vibtrans.core.trajectory import build_trajectory
from vibtrans.version import __version__

if TYPE_CHECKING:
    import threading
    from collections.abc import Callable, Sequence

    import xarray as xr

    from vibtrans.core.kernels.deformable import HertzParams

SAMPLES_PER_PERIOD = 10


def _scene(scene, values):
    if scene is None:
        return Scene(**values)
    if not isinstance(scene, Scene):
        raise InputTypeError(f"scene must be a vibtrans Scene, got {type(scene).__name__}")
    return scene.replace(**values) if values else scene


def estimate_steps(scene: Scene, refine: float = 1.0, steps: tuple[float, float] | None = None) -> int:
    """Upper estimate of a scene's integration steps, before running it.

    Parameters
    ----------
    scene : Scene
        The scene.
    refine : float
        Factor dividing the fidelity's time step.
    steps : tuple of float, optional
        (steps per period, steps per contact time scale) in place of the
        fidelity's pair.

    Returns
    -------
    int
        The estimated number of steps.

    Raises
    ------
    StepBudgetExceeded
        If the count is too large for a float to hold (a huge T_obs, or a step
        that underflows at an extreme A*).
    """
    if scene.model == "point-mass":
        h = scan_step(scene.fidelity, refine)
    else:
        h = time_step(
            scene.amplitude,
            scene.mass,
            scene.fidelity,
            refine,
            steps=steps,
            scales=drivers.scene_scales(scene),
        )
    return drivers.checked_steps(step_count(scene.periods, h), math.inf, "scene", h)


def _check_steps(steps, model):
    if steps is None:
        return None
    try:
        per_period, per_contact = (float(v) for v in steps)
    except (TypeError, ValueError):
        raise InputError(
            f"steps must be a pair (steps per period, steps per contact time "
            f"scale) of numbers in [1, 1e6], got {steps!r}"
        ) from None
    if not (1 <= per_period <= 1e6 and 1 <= per_contact <= 1e6):
        raise InputError(f"steps must be a pair of numbers in [1, 1e6], got {steps!r}")
    if model == "point-mass":
        raise InputError(
            "steps applies to the deformable and vertical models only (the material point is event-driven)"
        )
    return per_period, per_contact


def _window(window, periods):
    if window is None:
        return math.inf, -math.inf
    try:
        w0, w1 = (float(v) for v in window)
    except (TypeError, ValueError):
        raise InputError(
            f"window must be a pair (t0, t1) of times in [0, {periods:g}], got {window!r}"
        ) from None
    if not (math.isfinite(w0) and math.isfinite(w1) and 0 <= w0 <= w1 <= periods):
        raise InputError(f"window must satisfy 0 <= t0 <= t1 <= {periods:g}, got {window!r}")
    return w0, w1


def simulate(
    scene: Scene | None = None,
    *,
    window: tuple[float, float] | None = None,
    samples_per_period: int = SAMPLES_PER_PERIOD,
    max_steps: float = DEFAULT_MAX_STEPS,
    progress: Callable[[float], object] | None = None,
    cancel: threading.Event | None = None,
    refine: float = 1.0,
    shortcuts: int = D.SHORTCUTS_ALL,
    steps: tuple[float, float] | None = None,
    lyapunov: bool = False,
    stop: str = "full",
    **values: Any,
) -> xr.Dataset:
    """Simulate one scene and return its trajectory.

    The run's decimated samples, its events and its attributes, as built by
    `run_records` and `trajectory.build_trajectory`.

    Parameters
    ----------
    scene : Scene, optional
        The scene to run; None: a default Scene.
    window : tuple of float, optional
        (t0, t1) in wave periods where every step is recorded (full
        resolution); None: no window.
    samples_per_period : int
        Decimated samples per wave period over the whole run.
    max_steps : float
        Step budget; a scene estimated to need more is refused.
    progress : callable, optional
        Called as `progress(fraction)` between chunks of the run.
    cancel : threading.Event, optional
        Checked between chunks; once set, the run stops (Cancelled).
    refine : float
        Factor dividing the fidelity's time step.
    shortcuts : int
        Bit mask of the Hertz kernels' exact-to-rounding shortcuts (the
        default enables all of them; 0 switches them off).
    steps : tuple of float, optional
        (steps per period, steps per contact time scale) in place of the
        fidelity's pair (Hertz models only).
    lyapunov : bool
        Also measure the vertical motion's Lyapunov exponent
        (attributes `lyapunov`, `lyapunov_from`, `lyapunov_start`).
    stop : str
        "full" runs to T_obs; "decided" stops once the drift is decided.
    **values
        Scene parameters overriding the scene's (or a default Scene's).

    Returns
    -------
    xarray.Dataset
        The trajectory: samples along `time`, events along `event`, the
        scene and the run's measures in `attrs`.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    StepBudgetExceeded
        If the run would need more than `max_steps` steps.
    Cancelled
        If `cancel` asked the run to stop.
    """
    return build_trajectory(
        *run_records(
            scene,
            window=window,
            samples_per_period=samples_per_period,
            max_steps=max_steps,
            progress=progress,
            cancel=cancel,
            refine=refine,
            shortcuts=shortcuts,
            steps=steps,
            lyapunov=lyapunov,
            stop=stop,
            **values,
        )
    )


def run_records(
    scene: Scene | None = None,
    *,
    window: tuple[float, float] | None = None,
    samples_per_period: int = SAMPLES_PER_PERIOD,
    max_steps: float = DEFAULT_MAX_STEPS,
    progress: Callable[[float], object] | None = None,
    cancel: threading.Event | None = None,
    refine: float = 1.0,
    shortcuts: int = D.SHORTCUTS_ALL,
    steps: tuple[float, float] | None = None,
    lyapunov: bool = False,
    stop: str = "full",
    **values: Any,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Simulate one scene: its (samples, events, attrs), the kernel's
    trimmed buffers (records.COLUMNS, records event rows) and the run's
    attributes, before they become a Dataset (`simulate`; a map point
    summarizes them as trajectory.RunArrays, without one).

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
    lyapunov: also measure the largest Lyapunov exponent of the vertical
        motion (per period; attrs `lyapunov`, measured from `lyapunov_from`,
        `lyapunov_start`): the chaos indicator (analysis.CHAOS_LYAPUNOV).
        The records are the same bit for bit.  The material point's comes
        from its impact map (lyapunov.impact_lyapunov: -inf where it rides
        the surface after the ramp, None with fewer than three impacts).
    stop: "full" (run to T_obs) or "decided" (stop once the outcome is
        known to the fidelity's stated drift error: stopping.DecidedRule;
        attrs `stop`, `stop_reason`, `periods_run`,
        `asymptotic_drift_velocity`, `decided_drift_velocity`, the x*(T)/T
        that analysis.summary.drift_velocity reports).  "full" adds no attribute.
    """
    scene = _scene(scene, values)
    if not (
        isinstance(samples_per_period, (int, np.integer))
        and not isinstance(samples_per_period, bool)
        and 1 <= samples_per_period <= 10000
    ):
        raise InputError(f"samples_per_period must be an integer in [1, 10000], got {samples_per_period!r}")
    if isinstance(refine, bool) or not (
        isinstance(refine, (int, float)) and math.isfinite(refine) and 1 <= refine <= 1024
    ):
        raise InputError(f"refine must be a number in [1, 1024], got {refine!r}")
    if isinstance(shortcuts, bool) or not (
        isinstance(shortcuts, (int, np.integer)) and 0 <= shortcuts <= D.SHORTCUTS_ALL
    ):
        raise InputError(f"shortcuts must be an integer in [0, {D.SHORTCUTS_ALL}], got {shortcuts!r}")
    if isinstance(max_steps, bool) or not (
        isinstance(max_steps, (int, float)) and max_steps > 0 and not math.isnan(max_steps)
    ):
        raise InputError(f"max_steps must be a number in (0, inf], got {max_steps!r}")
    steps = _check_steps(steps, scene.model)
    if not isinstance(lyapunov, (bool, np.bool_)):
        raise InputError(f"lyapunov must be True or False, got {lyapunov!r}")
    check_stop(stop)
    drivers.checked_steps(estimate_steps(scene, refine, steps), max_steps, "scene")
    w0, w1 = _window(window, scene.periods)
    decide = (
        DecidedRule(scene.periods, scene.tau, scene.amplitude, scene.mass, scene.fidelity)
        if stop == "decided"
        else None
    )
    runner = _run_point_mass if scene.model == "point-mass" else _run_hertz
    start = time.perf_counter()
    samples, events, ctr, info = runner(
        scene,
        w0,
        w1,
        samples_per_period,
        refine,
        progress,
        cancel,
        shortcuts=int(shortcuts),
        steps=steps,
        lyapunov=bool(lyapunov),
        decide=decide,
    )
    if decide is not None:
        info.update(decide.attrs())
    seconds = time.perf_counter() - start
    attrs = dict(
        scene.values(),
        r=scene.r,
        steps=int(ctr[R.C_STEPS]),
        force_evaluations=int(ctr[R.C_FEVALS]),
        seconds=seconds,
        samples_per_period=samples_per_period,
        window_start=w0 if window is not None else None,
        window_end=w1 if window is not None else None,
        refine=refine,
        code_version=__version__,
        **info,
    )
    return samples, events, attrs


def hertz_params(
    scene: Scene, w0: Any, w1: Any, samples_per_period: int, refine: float, shortcuts: Any, steps: Any
) -> tuple[HertzParams, float, int]:
    """(HertzParams, h, samples capacity) of a Hertz scene's run: its time
    step, the full-resolution window [w0, w1], the sampling and shortcuts."""
    h = time_step(
        scene.amplitude, scene.mass, scene.fidelity, refine, steps=steps, scales=drivers.scene_scales(scene)
    )
    p = D.kernel_params(
        scene.amplitude,
        scene.mass,
        scene.mu,
        scene.theta,
        scene.r,
        scene.tau,
        h,
        scene.periods,
        1.0 / samples_per_period,
        (w0, w1),
        shortcuts,
        roll_ratio(scene),
    )
    n_win = 0 if w1 < w0 else int((w1 - w0) / h) + 2
    capacity = int(scene.periods * samples_per_period) + n_win + 16
    return p, h, capacity


def roll_ratio(scene: Scene) -> float:
    """1/j = m R^2 / I of a rolling scene's particle (the kernels'
    HertzParams.roll_ratio), 0.0 for one that does not turn."""
    j = scene.inertia_ratio
    return 0.0 if j is None else 1.0 / j


def lyapunov_start(scene: Scene, decide: Any = None) -> Any:
    """Where a scene's Lyapunov exponent is measured from (periods): the end
    of the ramp, where the wave is periodic (G = 1 to machine precision, t =
    RAMP_OFF tau), or half the run if that comes later.  Under the `decided`
    rule (decide: its DecidedRule) from where its windows start
    (stopping.settle_time: the ramp's residual below 1e-3 of its tolerance),
    so that its gate on the exponent holds from its first check."""
    start = RAMP_OFF * scene.tau if decide is None else float(decide.t_settle)
    return min(start, 0.5 * scene.periods)


def _run_hertz(
    scene,
    w0,
    w1,
    samples_per_period,
    refine,
    progress,
    cancel,
    shortcuts=D.SHORTCUTS_ALL,
    steps=None,
    lyapunov=False,
    decide=None,
):
    """Run the deformable or vertical kernel from rest."""
    p, h, capacity = hertz_params(scene, w0, w1, samples_per_period, refine, shortcuts, steps)
    t_from = lyapunov_start(scene, decide) if lyapunov else None
    run = drivers.run_hertz(
        p,
        scene.integrator,
        tangential=scene.model == "deformable",
        samples_capacity=capacity,
        progress=progress,
        cancel=cancel,
        lyapunov_from=t_from,
        decide=decide,
        law=drivers.scene_law(scene),
    )
    info = {"h": h}
    if p.roll_ratio != 0.0:
        # the rolled arc within a contact episode: the plane model's check
        # (docs/MODEL.md section 11)
        info.update(
            inertia_ratio=scene.inertia_ratio,
            max_episode_roll=D.episode_roll(run.state, run.ctr[R.C_MODE] == D.MODE_CONTACT, p.roll_ratio),
        )
    if lyapunov:
        if decide is not None and decide.reason == STOP_FLIGHT:
            _flight_tangent_to_end(run.tangent, run.state, scene.periods)
        info.update(_lyapunov_attrs(run.tangent, run.state, t_from))
    return run.samples, run.events, run.ctr, info


def _flight_tangent_to_end(tangent, state, t_end):
    """A run stopped in a flight that lasts past t_end (stopping.STOP_FLIGHT):
    its tangent at t_end, on the flight's closed form (dy' constant), as the
    run to t_end would have it (its measurement started on the flight if
    the flight spans its start: kernels.deformable._tangent_mark_in_flight)."""
    t0 = state[D.S_T0]
    if tangent[D.L_START] < 0.0 and t_end >= tangent[D.L_FROM]:
        t = max(tangent[D.L_FROM], t0)
        dy = tangent[D.L_DY0] + tangent[D.L_DVY0] * (t - t0)
        tangent[D.L_START] = t
        tangent[D.L_LOG_START] = tangent[D.L_LOG] + 0.5 * math.log(
            dy * dy + tangent[D.L_DVY0] * tangent[D.L_DVY0]
        )
    tangent[D.L_END_T] = t_end
    tangent[D.L_END_DY] = tangent[D.L_DY0] + tangent[D.L_DVY0] * (t_end - t0)
    tangent[D.L_END_DVY] = tangent[D.L_DVY0]


def _lyapunov_attrs(tangent, state, t_from):
    value = D.lyapunov_exponent(tangent, state)
    return {
        "lyapunov": None if math.isnan(value) else value,
        "lyapunov_from": t_from,
        "lyapunov_start": float(tangent[D.L_START]) if tangent[D.L_START] >= 0 else None,
    }


def _run_point_mass(
    scene,
    w0,
    w1,
    samples_per_period,
    refine,
    progress,
    cancel,
    shortcuts=None,
    steps=None,
    lyapunov=False,
    decide=None,
):
    # event-driven: its flights and segments are closed forms already
    dt = scan_step(scene.fidelity, refine)
    p = PM.make_params(
        scene.amplitude,
        scene.mass,
        scene.mu,
        scene.theta,
        scene.r,
        scene.tau,
        float(scene.periods),
        scene.alpha_t,
        1.0 / samples_per_period,
        (w0, w1),
        dt,
    )
    n_win = 0 if w1 < w0 else int((w1 - w0) / dt) + 64
    growth = None
    if lyapunov:
        # measured along the run (the `decided` rule reads it at each check)
        t_from = lyapunov_start(scene, decide)
        growth = ImpactGrowth(scene.amplitude, scene.mass, scene.tau, t_from)
    run = drivers.run_point_mass(
        p,
        scene.stick_rule,
        progress=progress,
        cancel=cancel,
        decide=decide,
        growth=growth,
        samples_capacity=int(scene.periods * samples_per_period) + n_win + 16,
    )
    info: dict[str, Any] = {"h": dt}
    if growth is not None:
        growth.update(run.events, final=True)
        value, start = growth.exponent()
        info.update(
            lyapunov=None if math.isnan(value) else value,
            lyapunov_from=t_from,
            lyapunov_start=None if math.isnan(start) else start,
        )
    return run.samples, run.events, run.ctr, info


def _deformable(scene):
    if scene.model != "deformable":
        raise InputError(f"model must be deformable for a memory diagram, got {scene.model!r}")


def _is_time(t, periods):
    return isinstance(t, numbers.Real) and not isinstance(t, (bool, np.bool_)) and 0 <= float(t) <= periods


def _snapshot(state, ctr, memory):
    """The dict of a memory diagram from a run's final state and memory."""
    from vibtrans.core.kernels.contact import anchor_profile

    H, W, P, nvert, memf = memory
    hs, ws = anchor_profile(H, W, nvert, memf)
    a, b = float(memf[0]), float(memf[1])
    return {
        "t": float(state[D.S_T]),
        "a": a,
        "b": b,
        "h": hs,
        "w": ws,
        "u": b - ws,
        "stick_depth": _stick_depth(hs, ws, a, b),
        "state": int(ctr[R.C_STATE]),
    }


def memory_snapshot(scene: Scene | None = None, t: float | None = None, **values: Any) -> dict[str, Any]:
    """The memory diagram of a deformable scene at time t (periods).

    Runs the scene from rest to t and returns a dict: t, a, b (a*, b* at t),
    h and w (the anchor polyline w(h), absolute b* units; empty in flight),
    u = b - w (spring displacements), stick_depth s_h, and state code.
    In contact, t is the first step at or after the time asked for.
    """
    scene = _scene(scene, values)
    _deformable(scene)
    if t is None or isinstance(t, bool) or not isinstance(t, (int, float)) or not (0 <= t <= scene.periods):
        raise InputError(f"t must be a time in [0, {scene.periods:g}] periods, got {t!r}")
    short = scene.replace(periods=max(float(t), MIN_SNAPSHOT_TIME))
    p, _, capacity = hertz_params(short, math.inf, -math.inf, 1, 1.0, D.SHORTCUTS_ALL, None)
    run = drivers.run_hertz(
        p, short.integrator, tangential=True, samples_capacity=capacity, law=drivers.scene_law(short)
    )
    return _snapshot(run.state, run.ctr, run.memory)


MIN_SNAPSHOT_TIME = 1e-9  # t = 0 shows the first step (a run needs a length)
MAX_SNAPSHOTS = 10_000


def memory_snapshots(
    scene: Scene | None = None, times: Any = None, *, progress: Any = None, cancel: Any = None, **values: Any
) -> list[dict[str, Any]]:
    """The memory diagram of a deformable scene at each of several times
    (periods, increasing), from ONE run from rest: a list of the dicts
    `memory_snapshot` returns, one per time.

    Each takes the same steps as memory_snapshot(scene, t) and agrees with
    it to rounding, not bit for bit: the run's kernel calls end at each time,
    which restarts the kernel's sin/cos rotation (drivers.run_memory_stops);
    memory_snapshots(scene, [t]) is memory_snapshot(scene, t) bit for bit.
    progress(fraction) and cancel (an object with is_set(); raises
    Cancelled) as in simulate().  Costs one run to times[-1].
    """
    scene = _scene(scene, values)
    _deformable(scene)
    stops = _snapshot_times(times, scene.periods)
    short = scene.replace(periods=stops[-1])
    p, _, capacity = hertz_params(short, math.inf, -math.inf, 1, 1.0, D.SHORTCUTS_ALL, None)
    runs = drivers.run_memory_stops(
        p,
        short.integrator,
        stops,
        samples_capacity=capacity,
        progress=progress,
        cancel=cancel,
        law=drivers.scene_law(short),
    )
    return [_snapshot(*run) for run in runs]


def _snapshot_times(times, periods):
    """Validated snapshot times as run stops (floats >= MIN_SNAPSHOT_TIME)."""
    what = f"times must be a sequence of 1 to {MAX_SNAPSHOTS} increasing times in [0, {periods:g}] periods"
    if isinstance(times, (str, bytes)) or times is None:
        raise InputError(f"{what}, got {times!r}")
    try:
        values = list(times)
    except TypeError:
        raise InputError(f"{what}, got {times!r}") from None
    if not 1 <= len(values) <= MAX_SNAPSHOTS:
        raise InputError(f"{what}, got {len(values)} times")
    for i, t in enumerate(values):
        if not _is_time(t, periods):
            raise InputError(f"{what}; times[{i}] = {t!r} is not")
        if i and not t > values[i - 1]:
            raise InputError(f"{what}; times[{i}] = {t!r} does not follow times[{i - 1}] = {values[i - 1]!r}")
    return [max(float(t), MIN_SNAPSHOT_TIME) for t in values]


def _stick_depth(h, w, a, b):
    """Depth where the springs stop being at their Coulomb limit |u| = a - h."""
    if h.size == 0:
        return 0.0
    at_limit = np.abs(np.abs(b - w) - (a - h)) <= 1e-12 * (1 + abs(b) + a)
    i = h.size - 1
    while i > 0 and at_limit[i - 1]:
        i -= 1
    return float(h[i]) if i < h.size - 1 else float(a)


# Compiled variants by model, in the order warmup compiles them.
MODELS = ("deformable", "vertical", "point-mass")


def _warm(model):
    for integrator in ("ab4", "verlet"):
        # one compiled kernel per model: the integrator is a run-time argument
        simulate(
            Scene(model=model, integrator=integrator, amplitude=100.0, mass=1.0, periods=2.0, tau=0.5),
            window=(1.0, 1.5),
        )
    # the chaos indicator's variant (the explorer's and the CLI's runs
    # measure it): the Hertz models advance the tangent map in a kernel of
    # their own, the material point's exponent comes from its impact map.
    # (The jumping threshold's runs, which stop at the first take-off, use
    # the vertical model's kernel: stopping there is a run-time argument.)
    simulate(
        Scene(model=model, amplitude=100.0, mass=1.0, periods=2.0, tau=0.5), window=(1.0, 1.5), lyapunov=True
    )


def warmup(models: Sequence[str] = MODELS, progress: Callable[[int, int, str], object] | None = None) -> None:
    """Compile (or load from the on-disk cache) the kernels of `models`.

    Then no user-facing run pays for compilation.  Cheap once the cache
    holds them (about 0.1 s per variant).

    Parameters
    ----------
    models : sequence of str
        Any of "deformable", "vertical" (also the jumping threshold) and
        "point-mass"; each is one compiled variant.
    progress : callable, optional
        Called as `progress(done, total, label)` after each variant is
        ready (done = 1 .. total, label such as "deformable kernel").

    Returns
    -------
    None

    Raises
    ------
    InputError
        If a model is not one of the three.
    """
    models = (models,) if isinstance(models, str) else tuple(models)
    for model in models:
        if model not in MODELS:
            raise InputError(f"models must be among {', '.join(MODELS)}, got {model!r}")
    models = tuple(dict.fromkeys(models))
    for done, model in enumerate(models, start=1):
        _warm(model)
        if progress is not None:
            progress(done, len(models), f"{model} kernel")
