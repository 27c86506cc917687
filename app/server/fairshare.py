"""Worker threads shared fairly between maps: each map on demand gets a
lane (an Executor of its own) and the workers take the next task from the
lanes in turn, so a big map that was asked for first cannot starve a small
one asked for later; each map runs as fast as the cores allow while alone.

The tasks are map points (vibtrans.maps.adaptive).  Their kernels release the
GIL, but a point's Python around its kernel (the scene's checks, the
summary of its run) does not, and at preview fidelity it is most of the
point (1.3 of a 33 x 33 preview map's 1.45 s of CPU when each point
built its run's Dataset; still most since trajectory.RunArrays).  In
threads of the server that Python held the GIL against the event loop,
however nice the threads.  So a pool made with `processes=True` runs the
tasks in worker processes (its threads only hand them over and wait),
started when a task comes and stopped `linger` seconds after the last lane
closed (a map asked for meanwhile starts at once: a worker's start, its
imports and compiled kernels loaded, is ~1.3 s of CPU) or when the owner
calls `stop_processes`.  Nothing here knows about maps.
"""

import multiprocessing
import os
import threading
from collections import OrderedDict, deque
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool


def lower_priority(nice):
    """Make the calling thread `nice` steps nicer than it is (Linux, where a
    thread's id is a process id for setpriority; elsewhere it keeps the
    process's priority): a thread pool's initializer, so that the
    process's other threads come first on a busy core."""
    if not nice:
        return
    try:
        tid = threading.get_native_id()
        os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + nice))
    except (OSError, AttributeError):
        pass


def _start_worker_process(niceness, initializer):
    """A worker process's start: at `niceness` (the whole process; it
    inherits that of the pool's thread that started it), then
    `initializer()` (say, loading compiled kernels)."""
    if niceness is not None:
        try:
            os.setpriority(os.PRIO_PROCESS, 0, niceness)
        except (OSError, AttributeError):
            pass
    if initializer is not None:
        initializer()


class FairPool:
    """`workers` daemon threads serving lanes round-robin (one task from a
    lane, then the next lane with work), at niceness `nice` (Linux: per
    thread), so that the process's other threads (a server's event loop and
    its sessions' runs) come first on a busy core.

    processes: run each task in one of `workers` worker processes (spawned,
    at niceness `nice`, each calling `initializer()` first) instead of in
    the thread: the task, its arguments and its result must pickle.  The
    processes start with the first task after an idle spell and stop
    `linger` seconds after every lane is shut down and no task runs (they
    hold memory: ~220 MB each for the map points), or at `stop_processes`."""

    def __init__(self, workers, name="vibtrans-fair", nice=0, processes=False, initializer=None, linger=0.0):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = int(workers)
        self.nice = int(nice)
        try:  # the worker processes' niceness: `nice` below this process's
            self._process_niceness = min(19, os.getpriority(os.PRIO_PROCESS, 0) + self.nice)
        except (OSError, AttributeError):
            self._process_niceness = None
        self.processes = bool(processes)
        self.initializer = initializer
        self.linger = float(linger)
        self._processes = None  # the ProcessPoolExecutor while one is up
        self._idle_timer = None  # stops the processes after `linger` s idle
        self._busy = 0  # tasks running
        self._ready = threading.Condition()
        self._lanes = OrderedDict()  # Lane -> deque of (future, fn, args, kwargs)
        self._threads = [
            threading.Thread(target=self._serve, name=f"{name}-{k}", daemon=True) for k in range(self.workers)
        ]
        for t in self._threads:
            t.start()

    def lane(self):
        """A new lane: an Executor whose tasks take their turn with the
        other lanes'.  Shut it down when its map ends."""
        lane = Lane(self)
        with self._ready:
            self._lanes[lane] = deque()
        return lane

    def _submit(self, lane, fn, args, kwargs):
        future = Future()
        with self._ready:
            if lane not in self._lanes:
                raise RuntimeError("cannot submit to a lane that was shut down")
            self._lanes[lane].append((future, fn, args, kwargs))
            if self._idle_timer is not None:  # work again: the idle spell ended
                self._idle_timer.cancel()
                self._idle_timer = None
            self._ready.notify()
        return future

    def _close(self, lane):
        """Drop the lane and cancel its tasks that have not started."""
        with self._ready:
            tasks = self._lanes.pop(lane, ())
            self._stop_idle_processes()
        for future, *_ in tasks:
            future.cancel()

    def _next(self):
        with self._ready:
            while True:
                for lane, tasks in self._lanes.items():
                    if tasks:
                        # this lane goes to the back of the turn
                        self._lanes.move_to_end(lane)
                        self._busy += 1
                        return tasks.popleft()
                self._ready.wait()

    def _serve(self):
        lower_priority(self.nice)
        while True:
            future, fn, args, kwargs = self._next()
            try:
                if future.set_running_or_notify_cancel():
                    try:
                        result = self._run(fn, args, kwargs)
                    except BaseException as exc:  # handed to the map that asked
                        future.set_exception(exc)
                    else:
                        future.set_result(result)
            finally:
                with self._ready:
                    self._busy -= 1
                    self._stop_idle_processes()

    def _run(self, fn, args, kwargs):
        if not self.processes:
            return fn(*args, **kwargs)
        with self._ready:
            if self._processes is None:
                self._processes = ProcessPoolExecutor(
                    self.workers,
                    mp_context=multiprocessing.get_context("spawn"),
                    initializer=_start_worker_process,
                    initargs=(self._process_niceness, self.initializer),
                )
            processes = self._processes
        try:
            return processes.submit(fn, *args, **kwargs).result()
        except BrokenProcessPool:
            # a worker died (killed, out of memory): the next task starts a new pool
            with self._ready:
                if self._processes is processes:
                    self._processes = None
            processes.shutdown(wait=False)
            raise

    def _idle(self):
        return self._processes is not None and not self._lanes and not self._busy

    def _stop_idle_processes(self):
        """(Holding the lock) once no lane is left and no task runs, stop
        the worker processes `linger` seconds later if still idle then (at
        once without linger): memory back to the system between maps."""
        if not self._idle():
            return
        if self.linger <= 0.0:
            self._stop()
        elif self._idle_timer is None:
            self._idle_timer = threading.Timer(self.linger, self._stop_if_idle)
            self._idle_timer.daemon = True
            self._idle_timer.start()

    def _stop_if_idle(self):
        with self._ready:
            self._idle_timer = None
            if self._idle():
                self._stop()

    def _stop(self):
        """(Holding the lock) shut the worker processes down now."""
        if self._idle_timer is not None:
            self._idle_timer.cancel()
            self._idle_timer = None
        if self._processes is not None:
            self._processes.shutdown(wait=False)
            self._processes = None

    def stop_processes(self):
        """Stop the worker processes now if no lane is open and no task runs
        (say, once no session that could ask for a map is left); True if
        none are up afterwards."""
        with self._ready:
            if self._idle():
                self._stop()
            return self._processes is None

    def processes_up(self):
        """Whether worker processes are running (for tests and diagnostics)."""
        with self._ready:
            return self._processes is not None

    def queued(self):
        """{lane: tasks waiting} (for tests and diagnostics)."""
        with self._ready:
            return {lane: len(tasks) for lane, tasks in self._lanes.items()}


class Lane(Executor):
    """One map's share of a FairPool."""

    def __init__(self, pool):
        self.pool = pool

    def submit(self, fn, /, *args, **kwargs):
        return self.pool._submit(self, fn, args, kwargs)

    def shutdown(self, wait=True, *, cancel_futures=False):
        # the pool's threads belong to every lane: only this lane's queue goes
        self.pool._close(self)
