"""Worker threads shared fairly between maps: each map on demand gets a
lane (an Executor of its own) and the workers take the next task from the
lanes in turn, so a big map that was asked for first cannot starve a small
one asked for later; each map runs as fast as the cores allow while alone.

The tasks are map points (vibtrans.adaptive), whose kernels release the
GIL, so threads use the cores.  Nothing here knows about maps.
"""
import os
import threading
from collections import OrderedDict, deque
from concurrent.futures import Executor, Future


def lower_priority(nice):
    """Make the calling thread `nice` steps nicer than it is (Linux, where a
    thread's id is a process id for setpriority; elsewhere it keeps the
    process's priority): a thread pool's initializer, so that the
    process's other threads come first on a busy core."""
    if not nice:
        return
    try:
        tid = threading.get_native_id()
        os.setpriority(os.PRIO_PROCESS, tid,
                       min(19, os.getpriority(os.PRIO_PROCESS, tid) + nice))
    except (OSError, AttributeError):
        pass


class FairPool:
    """`workers` daemon threads serving lanes round-robin (one task from a
    lane, then the next lane with work), at niceness `nice` (Linux: per
    thread), so that the process's other threads (a server's event loop and
    its sessions' runs) come first on a busy core."""

    def __init__(self, workers, name="vibtrans-fair", nice=0):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.workers = int(workers)
        self.nice = int(nice)
        self._ready = threading.Condition()
        self._lanes = OrderedDict()       # Lane -> deque of (future, fn, args, kwargs)
        self._threads = [threading.Thread(target=self._serve, name=f"{name}-{k}", daemon=True)
                         for k in range(self.workers)]
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
            self._ready.notify()
        return future

    def _close(self, lane):
        """Drop the lane and cancel its tasks that have not started."""
        with self._ready:
            tasks = self._lanes.pop(lane, ())
        for future, *_ in tasks:
            future.cancel()

    def _next(self):
        with self._ready:
            while True:
                for lane, tasks in self._lanes.items():
                    if tasks:
                        # this lane goes to the back of the turn
                        self._lanes.move_to_end(lane)
                        return tasks.popleft()
                self._ready.wait()

    def _serve(self):
        lower_priority(self.nice)
        while True:
            future, fn, args, kwargs = self._next()
            if not future.set_running_or_notify_cancel():
                continue
            try:
                result = fn(*args, **kwargs)
            except BaseException as exc:      # handed to the map that asked
                future.set_exception(exc)
            else:
                future.set_result(result)

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
