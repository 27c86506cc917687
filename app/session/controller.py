"""A session's runs, with no widgets: the run controller.

`RunController` turns the selected scene (`state.ExplorerState`) into runs
in a worker pool and publishes what the page shows as parameters: `status`
(what a run is doing, or that it was cancelled), `busy` and `progress`
(shown by the page while a run takes a while), `message` (a refusal or an
error, for the page's alert) and `result` (the last run shown, a
`RunResult`).  The views watch these; nothing here knows a widget, so the
controller runs in a test with `asyncio.run` and a stand-in `simulate`.

One run per session: a new request cancels the running one (its kernels
stop at their next chunk, runs not started are dropped) and replaces it
(app/session/latest.py's LatestJob).
"""

import asyncio
import functools
import logging
import os
import time
from concurrent.futures import CancelledError, ThreadPoolExecutor
from typing import NamedTuple

import param

from vibtrans import Cancelled, estimate_steps, simulate
from vibtrans.analysis.summary import TWIN_TAU_OFFSET, Summary, jumped, summarize, twin_scene
from vibtrans.core.kernels.jit import compile_notice
from vibtrans.core.simulate import StepBudgetExceeded
from vibtrans.products.plots import FRAGMENT, OVERVIEW_SAMPLES
from vibtrans_explorer.server import warmup
from vibtrans_explorer.server.fairshare import lower_priority
from vibtrans_explorer.session.latest import Job, LatestJob
from vibtrans_explorer.session.urlstate import literal

CANCELLED = "Run cancelled."  # the status after the user's Cancel

log = logging.getLogger("vibtrans.explorer")

# the run threads' niceness: on a core they share with the event loop
# (every session's pages, figures and messages: one thread), the event loop
# comes first (weight 335 against 1024); the maps' workers are nicer still
# (mapjobs.MAP_NICE), so runs come before them
RUN_NICE = 5
# One pool for the process: numba kernels release the GIL, so runs proceed
# while the server keeps serving other sessions.
RUNNER = ThreadPoolExecutor(
    max_workers=max(2, os.cpu_count() or 2),
    thread_name_prefix="vibtrans-run",
    initializer=lower_priority,
    initargs=(RUN_NICE,),
)
MAX_STEPS = int(float(os.environ.get("VIBTRANS_MAX_STEPS", 5e7)))
# while a run's kernels compile (a tip or a rolling particle run for the
# first time since an install): its progress stays at 0 meanwhile
COMPILING = (
    "Compiling the kernels of this scene (numba: once after an install; later runs "
    "load them from the cache) ..."
)
BUSY_AFTER = 0.25  # s: a run still going then shows progress and Cancel
TWIN_LABEL = f"tau + {TWIN_TAU_OFFSET:g}"


def over_budget(steps, max_steps):
    return (
        f"This scene needs about {steps:.2g} steps, over this server's limit of "
        f"{max_steps:.2g} (VIBTRANS_MAX_STEPS): lower the fidelity or choose another point."
    )


class RunResult(NamedTuple):
    """A run as shown: its scene and samples, the comparison run and its
    label in the figures (None without one), the tau twin used for the
    chaos verdict (None if none was needed: no take-off, or no twin run),
    the summary of both (analysis.Summary), and whether a twin ran but had
    nothing to decide (the run never took off)."""

    scene: object
    ds: object
    other: object
    label: object
    twin: object
    summary: Summary
    twin_unneeded: bool
    ran: dict = None  # the state's values when the run was made (all of them)


def comparison(scene, compare):
    """(comparison scene or None, its label in the figures or None) for the
    explorer's "compare with" setting."""
    if compare == "tau twin":
        return twin_scene(scene), TWIN_LABEL
    if compare == "point mass" and scene.model == "deformable":
        # (the material point has no size: it does not turn, whatever the run does)
        return scene.replace(model="point-mass", rolling="none"), "point mass"
    return None, None


def interpret(scene, ds, other, label):
    """A finished run and its comparison run as a RunResult."""
    twin = other if (other is not None and other.attrs["model"] == scene.model) else None
    unneeded = twin is not None and not jumped(ds)
    if unneeded:
        twin = None  # no take-off: the tau twin has nothing to decide
    return RunResult(scene, ds, other, label, twin, summarize(ds, twin), unneeded)


def _retrieved(future):
    if not future.cancelled():
        future.exception()


class RunJob(Job):
    """One run of a session (a scene and its comparison run): a Job
    (app/session/latest.py: its cancel event and worker futures) with its
    scene, its label and its progress."""

    def __init__(self, scene, label, executor):
        super().__init__(executor)
        self.scene, self.label = scene, label
        self.progress = 0.0
        self.compiling = False  # a kernel of its runs is compiling
        self.ran = None  # the state's values when the run was made

    def set_progress(self, fraction):
        self.progress = fraction
        self.compiling = False

    def submit(self, fn, *args, **kwargs):
        if warmup.ready(self.scene):
            return super().submit(self._noticed, fn, *args, **kwargs)
        # the server has just started, or a particle that rolls is run for
        # the first time: its kernels are compiling
        return super().submit(self._when_compiled, fn, *args, **kwargs)

    def _noticed(self, fn, *args, **kwargs):
        with compile_notice(lambda name: setattr(self, "compiling", True)):
            return fn(*args, **kwargs)

    def _when_compiled(self, fn, *args, **kwargs):
        if not warmup.wait(self.event, self.scene):
            raise Cancelled("cancelled while the kernels compiled")
        return self._noticed(fn, *args, **kwargs)


def _create_task(start):
    """Run the coroutine `start()` returns as a task of the running loop."""
    return asyncio.get_running_loop().create_task(start())


class RunController(param.Parameterized):
    """Runs the selected scene and publishes its course and result.

    state: the session's ExplorerState.  simulate: the library's simulate
    (a test passes a stand-in).  executor: where runs go (the process's
    RUNNER).  schedule(start): runs the coroutine that start() returns (the
    explorer passes Panel's pn.state.execute, which holds the session's
    document; by default an asyncio task).  refusals: a callable returning the messages of invalid
    fields (a run is refused while there are any)."""

    status = param.String(default="", doc="what the running run does, or 'Run cancelled.'")
    busy = param.Boolean(default=False, doc="a run has taken longer than BUSY_AFTER")
    progress = param.Number(default=0.0, bounds=(0.0, 1.0), doc="the main run's progress")
    message = param.String(default="", doc="why a run was refused or failed; empty if none")
    result = param.Parameter(default=None, doc="the last RunResult shown")

    def __init__(
        self,
        state,
        simulate=simulate,
        executor=RUNNER,
        schedule=_create_task,
        refusals=list,
        max_steps=MAX_STEPS,
        **params,
    ):
        super().__init__(**params)
        self.state = state
        self.simulate = simulate
        self.executor = executor
        self.schedule = schedule
        self.refusals = refusals
        self.max_steps = max_steps
        self.runs = LatestJob(executor)  # the latest run wins (its RunJob)

    @property
    def job(self):
        """The running RunJob, if any."""
        return self.runs.job if self.runs.running else None

    def start(self, schedule=True):
        """Run the selected scene; the kernels start here, at once, and
        `finish` (scheduled unless `schedule` is False) waits for them.
        Returns the RunJob, or None if the run was refused (`message` says
        why)."""
        self.discard()
        errors = self.refusals()
        if errors:
            self.message = "Not run: " + " · ".join(errors)
            return None
        try:
            scene = self.state.scene()
            steps = estimate_steps(scene)
        except ValueError as exc:
            self.message = literal(exc)
            return None
        if steps > self.max_steps:
            self.message = over_budget(steps, self.max_steps)
            return None
        self.message = ""
        other_scene, label = comparison(scene, self.state.compare)
        job = self.runs.start(RunJob(scene, label, self.executor))
        job.ran = dict(self.state.param.values())
        # The comparison run goes in parallel with the main one (the kernels
        # release the GIL).
        T = scene.periods
        # the chaos verdict: the run's own Lyapunov exponent (Hertz models)
        job.submit(
            self.simulate,
            scene,
            window=(T - FRAGMENT, T),
            samples_per_period=OVERVIEW_SAMPLES,
            progress=job.set_progress,
            cancel=job.event,
            max_steps=self.max_steps,
            lyapunov=True,
        )
        if other_scene is not None:
            job.submit(
                self.simulate,
                other_scene,
                samples_per_period=OVERVIEW_SAMPLES,
                cancel=job.event,
                max_steps=self.max_steps,
            )
        if schedule:
            self.schedule(functools.partial(self.finish, job))
        return job

    async def run(self):
        """Run the selected scene and wait until it is shown (or refused,
        failed, cancelled or replaced)."""
        job = self.start(schedule=False)
        if job is not None:
            await self.finish(job)

    def cancel(self):
        """The user's Cancel: stop the running job; `finish` then says
        'Run cancelled.'."""
        if self.job is not None:
            self.job.cancel()

    def discard(self):
        """Stop the running job (if any) silently (it is replaced, or its
        session closed); returns it."""
        return self.runs.cancel()

    async def finish(self, job):
        """Wait for a job's runs, then publish them as `result`, if it is
        still the session's job (a replaced job ends silently)."""
        scene = job.scene
        waiting = [asyncio.wrap_future(f) for f in job.futures]
        for w in waiting:  # a replaced job's errors are not for anyone
            w.add_done_callback(_retrieved)
        try:
            t0 = time.perf_counter()
            while True:
                _, pending = await asyncio.wait(waiting, timeout=0.1)
                if not self.runs.is_latest(job):  # replaced by a newer run
                    return
                if not pending:
                    break
                # progress only for runs that take a while (a fast run's UI
                # goes straight from the click to its plots)
                if self.busy or time.perf_counter() - t0 > BUSY_AFTER:
                    self.param.update(
                        busy=True,
                        progress=job.progress,
                        status=warmup.status(scene)
                        or (
                            COMPILING
                            if job.compiling
                            else (
                                f"Running {scene.model} at A* = {scene.amplitude:.4g}, "
                                f"m* = {scene.mass:.4g} ..."
                            )
                        ),
                    )
            ds = job.futures[0].result()
            other = None if len(job.futures) < 2 else job.futures[1].result()
        except (Cancelled, CancelledError):
            if self.runs.is_latest(job):
                self.status = CANCELLED
            return
        except StepBudgetExceeded as exc:
            if self.runs.is_latest(job):
                self.param.update(
                    status="",
                    message=f"This scene is over this server's limit (VIBTRANS_MAX_STEPS): {literal(exc)}",
                )
            return
        except Exception as exc:  # a failed run harms only this session
            if self.runs.is_latest(job):
                log.exception("run failed: %s", scene.values())
                self.param.update(status="", message=f"The run failed: {type(exc).__name__}: {literal(exc)}")
            return
        finally:
            self.runs.finish(job)
            if self.job is None and self.busy:
                self.param.update(busy=False, progress=0.0)
        try:
            result = interpret(scene, ds, other, job.label)._replace(ran=job.ran)
            self.param.update(status="", result=result)
        except Exception as exc:
            log.exception("showing a run failed: %s", scene.values())
            self.message = f"Showing the run failed: {type(exc).__name__}: {literal(exc)}"
