"""The latest request wins: a session's work of one kind, off the event loop.

A page often asks for the same work again before the last answer came: a
new run, the memory diagram of a newer run, a chart drawn again, a map
estimated or computed again.  The newer request cancels the older one (its
cancel event is set, its work not started is dropped) and the older one's
result, should it still come, is never shown.  `LatestJob` is that rule,
for one kind of work of one session:

    job = work.start()                      # cancels the job before it
    job.submit(fn, *args, cancel=job.event) # in the executor, off the event loop
    work.deliver(job, show, failed)         # show(result) at the page's next tick,
                                            # if `job` is still the latest

A coroutine with several steps awaits `job.run(fn, ...)` and asks
`work.is_latest(job)` after each.  The work runs in a thread pool, so the
event loop (every session's clicks) stays free; what it changes in the
page is changed at the document's next tick (`at_next_tick`).

The server's map queue (app/server/mapjobs.py) keeps its own rule, one
request per session, under its lock: a map is shared by every session
asking for it and stops only when the last of them cancels, which no
session's object can decide alone.  A session's side of it is a LatestJob
whose cancellation withdraws the session's request (`Job.when_cancelled`).
"""

import asyncio
import functools
import threading
from collections.abc import Callable
from concurrent.futures import CancelledError, Executor
from typing import Any

import panel as pn

from vibtrans import Cancelled


def at_next_tick(doc: Any, answer: Callable[[], Any]) -> None:
    """answer() at the next tick of `doc`, a served page's document, or now
    (no server).  Code that runs without the document's lock (after an
    await in a coroutine, or in a watcher where Panel applies a browser's
    change `unlocked`) and changes plain Bokeh models raised "_pending_writes
    should be non-None" in the server's log (typed values did not move the
    map's marker); the document's next tick holds the lock, and runs after
    the callback in progress has sent its own changes.  (A typed time's
    memory diagram that now and then never came, before this was used
    there, was not traced to this: none lost in 202 views since,
    docs/how-to/deployment.md 2.2.)"""
    if doc is not None and doc.session_context is not None:
        doc.add_next_tick_callback(answer)
    else:
        answer()


class Job:
    """One request: the cancel event its work watches (`event`), the
    futures of its work in the executor (`futures`), and whether it has
    ended (`finished`: shown, failed, or cancelled and said so).

    executor: a concurrent.futures executor, or None for the event loop's
    default one."""

    def __init__(self, executor: Executor | None = None):
        self.executor = executor
        self.event = threading.Event()
        self.futures = []
        self.finished = False
        self._on_cancel = []

    def submit(self, fn: Callable, *args, **kwargs) -> Any:
        """fn(*args, **kwargs) in the executor; returns its future (kept in
        `futures`, cancelled with the job)."""
        if self.executor is None:
            future = asyncio.get_running_loop().run_in_executor(None, functools.partial(fn, *args, **kwargs))
        else:
            future = self.executor.submit(fn, *args, **kwargs)
        self.futures.append(future)
        return future

    async def run(self, fn: Callable, *args, **kwargs) -> Any:
        """fn(*args, **kwargs), computed in the executor and awaited.
        Raises Cancelled once the job is cancelled."""
        try:
            return await asyncio.wrap_future(self.submit(fn, *args, **kwargs))
        except (CancelledError, asyncio.CancelledError):
            if self.event.is_set():
                raise Cancelled("replaced by a newer request") from None
            raise

    def when_cancelled(self, callback: Callable[[], Any]) -> None:
        """callback() also when the job is cancelled (work elsewhere: a
        map in the server's queue)."""
        self._on_cancel.append(callback)

    def cancel(self) -> None:
        """Set the cancel event (the kernels stop at their next chunk) and
        drop the work not started."""
        self.event.set()
        for future in self.futures:
            future.cancel()
        callbacks, self._on_cancel = self._on_cancel, []
        for callback in callbacks:
            callback()


class LatestJob:
    """The latest request of one kind of a session's work (module docstring).

    executor: where its work runs (a concurrent.futures executor; None: the
    event loop's default one).  schedule(start): runs the coroutine that
    start() returns (Panel's pn.state.execute by default, which keeps the
    session's document current in it)."""

    def __init__(self, executor: Executor | None = None, schedule: Callable[[Callable], Any] | None = None):
        self.executor = executor
        self.schedule = schedule or pn.state.execute
        self.job = None  # the latest Job (kept once finished), None once cancelled

    @property
    def running(self) -> bool:
        """Whether the latest job has not ended yet."""
        return self.job is not None and not self.job.finished

    def start(self, job: Job | None = None) -> Job:
        """`job` (a new Job in the executor if None) becomes the latest; the
        one before is cancelled if it had not ended.  Returns it."""
        self.cancel()
        self.job = Job(self.executor) if job is None else job
        return self.job

    def is_latest(self, job: Job | None) -> bool:
        """Whether `job` is still the latest (neither replaced nor cancelled)."""
        return job is self.job

    def finish(self, job: Job) -> None:
        """`job` has ended (its result shown, its failure or cancellation said)."""
        job.finished = True

    def cancel(self) -> Job | None:
        """Cancel the latest job if it has not ended, and forget it (its
        result is never shown); returns it (None if there was none)."""
        job, self.job = self.job, None
        if job is not None and not job.finished:
            job.cancel()
        return job

    def deliver(self, job: Job, show: Callable[[Any], Any], failed: Callable[[Exception], Any]) -> None:
        """Wait for the job's first future (off the event loop), then, at the
        page's next tick and if `job` is still the latest: finish it and
        show(result), or failed(exception) if its work raised.  A cancelled
        or replaced job ends silently."""
        self.schedule(functools.partial(self._deliver, job, show, failed))

    async def _deliver(self, job, show, failed):
        doc = pn.state.curdoc  # (the session's: its next tick answers)
        try:
            out = await asyncio.wrap_future(job.futures[0])
        except (Cancelled, CancelledError, asyncio.CancelledError):
            self.finish(job)  # replaced by a newer request, or cancelled
            return
        except Exception as exc:
            at_next_tick(doc, functools.partial(self._answer, job, failed, exc))
            return
        at_next_tick(doc, functools.partial(self._answer, job, show, out))

    def _answer(self, job, answer, value):
        if self.is_latest(job) and not job.finished:
            self.finish(job)
            answer(value)
