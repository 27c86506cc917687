"""Maps on demand for every session of a server, with no widgets: one
queue, one cache, one core budget for the process.

* `MapJobs.submit(session, request, on_update)` asks for a map
  (maprequest.MapRequest); `on_update(Update)` hears, from a worker thread,
  that it waits in the queue, each level's map so far (the finest grid
  filled from the cells computed: a progressive picture), and its end
  (the verified map, a failure, or its cancellation).  The caller moves the
  updates to its own event loop: nothing here touches a Bokeh model.
* The cache (vibtrans.maps.cache.MapCache, a folder shared by every session
  and every server process using it) holds finished maps keyed by their
  request and the code version; a finished map is read from it, a damaged
  entry is recomputed, never shown.
* One session, one map: a new request from a session replaces its
  previous one.  Sessions asking for the same map share one computation
  (each hears its levels); it is cancelled when the last of them cancels
  (or closes), its finished points kept for a request that comes back.
  (The session's side, which drops a replaced map's updates, is a
  LatestJob: app/session/latest.py.)
* Up to `max_running` maps compute at once and share `cores` workers
  fairly (app/server/fairshare.py: their points take turns, so a big map asked
  for first never starves a small one asked for later; a map alone gets
  every worker), niced (MAP_NICE) below the sessions' runs and the event
  loop.  The workers are processes (started for the maps, stopped when
  none computes), so that the points' Python never holds this process's
  GIL against its event loop.  `cores` is by default all cores but one,
  which stays for the sessions' clicks (their runs use
  app/session/controller.py's pool, never these workers).  Further maps wait
  first come, first served; at most `max_queued` wait, beyond that a
  request is refused.
"""

import logging
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np

from vibtrans.core.errors import Cancelled, InputError, StoreMismatch
from vibtrans.core.simulate import warmup as compile_kernels
from vibtrans.maps.cache import DEFAULT_MAX_BYTES, TEMPORARY, MapCache, request_key
from vibtrans_explorer.server import warmup
from vibtrans_explorer.server.fairshare import FairPool
from vibtrans_explorer.session import maprequest

log = logging.getLogger("vibtrans.explorer")

MAX_QUEUED = 16
# maps computing at once (sharing the cores): more would only slice the
# cores thinner, fewer would let one big map hold the others back
MAX_RUNNING = 4
# the map workers' niceness: on a core they share with the sessions' runs
# and the event loop, those come first (a weight of about 1/10 of the event
# loop's, 1/3 of the runs', controller.RUN_NICE)
MAP_NICE = 10
# a picture of a map within a refinement level at most this often: a level
# of a large map takes minutes.  Each picture costs a render (under the
# render lock) and a redraw in the browser: the five-map load test on one
# server core (`python -m devtools.loadtest --maps 5`, noisy) gave click p95 12.6 s with a picture
# every 3 s, 10.0 and 3.5 s with one every 10 s, 7.6 s with none (and 4.5,
# 9.5 s for the code before pictures): within the noise at 10 s
CHUNK_SECONDS = 10.0
# the timed run that measures a kernel's seconds per step (step_seconds):
# long enough that the run's fixed costs are a small part of it
STEP_PERIODS = 2000.0
# seconds the map workers' processes outlive the last map: a map asked for
# meanwhile starts at once (a worker's start is ~1.3 s of CPU: imports,
# compiled kernels loaded); `stop_workers` ends them sooner (the server's
# memory release, once no session is open)
WORKERS_LINGER = 60.0


def default_folder():
    """$VIBTRANS_MAP_CACHE, else the user's cache folder."""
    env = os.environ.get("VIBTRANS_MAP_CACHE")
    if env:
        return env
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "vibtrans", "maps")


def default_cores():
    """All cores but one (which stays for the sessions' clicks), at least one."""
    return max(1, (os.cpu_count() or 1) - 1)


def same_values(snapshot, ds):
    """Whether the map `ds` holds what `snapshot` (a map so far) does, value
    for value, in every variable of the snapshot."""
    return all(
        name in ds and np.array_equal(snapshot[name].values, ds[name].values, equal_nan=True)
        for name in snapshot.data_vars
    )


class MapRefused(Exception):
    """A request this server will not queue (the message says why)."""


class Update(NamedTuple):
    """What a map's subscriber hears.  kind: "queued" (text says how many
    wait before it), "level" (ds: the map so far after `level` of
    `levels`), "chunk" (ds: the map so far while `level` is computed:
    every CHUNK_SECONDS within a level; both with `seconds_left`, the time
    left as a progress bar says it: maprequest.seconds_left), "done" (ds:
    the finished, verified map; cached: read from the cache; shown: its
    values are those of the finest level's map, sent before it to every
    subscriber, so a picture of that one stands), "failed" (text),
    "cancelled"."""

    kind: str
    level: int = 0
    levels: int = 0
    ds: object = None
    text: str = ""
    cached: bool = False
    shown: bool = False
    seconds_left: object = None

    def left_text(self):
        """ ", about 3 min left" while the time left is known, else ""."""
        if not self.seconds_left:
            return ""
        return f", about {maprequest.duration(self.seconds_left)} left"

    @property
    def final(self):
        return self.kind in ("done", "failed", "cancelled")


class Ticket:
    """One session's interest in one map."""

    def __init__(self, session, key, on_update):
        self.session = session
        self.key = key
        self.on_update = on_update
        self.cancelled = False

    def tell(self, update):
        if self.cancelled and update.kind != "cancelled":
            return
        try:
            self.on_update(update)
        except Exception:  # a closed session's loop: nobody listens any more
            log.exception("a map update could not be delivered")


class _Computation:
    def __init__(self, key, request):
        self.key = key
        self.request = request
        self.cancel = threading.Event()
        self.tickets = []
        self.last = None  # the latest level's Update (for a late subscriber)
        self.started = None  # when its points began (time.monotonic)


class MapJobs:
    """The process's maps on demand (module docstring)."""

    def __init__(
        self,
        folder=None,
        max_bytes=DEFAULT_MAX_BYTES,
        cores=None,
        max_queued=MAX_QUEUED,
        max_points=maprequest.MAX_POINTS,
        max_seconds=maprequest.MAX_SECONDS,
        build=None,
        scheduler=None,
        max_running=MAX_RUNNING,
        processes=True,
    ):
        self.folder = folder or default_folder()
        # a dask.distributed scheduler's address: the points run on its
        # cluster instead of this process's threads (`vibtrans serve --scheduler`)
        self.scheduler = scheduler
        self.max_bytes = max_bytes
        self.cores = cores or default_cores()
        self.max_queued = max_queued
        self.max_running = max_running
        # the points in worker processes (fairshare.FairPool), else in threads
        self.processes = bool(processes)
        self.max_points = max_points
        self.max_seconds = max_seconds
        # build(computation, path, on_level): computes the map's store at
        # path (run_adaptive; a test passes a stand-in)
        self._build = build or self.run_adaptive
        self._cache = None
        self._lock = threading.Lock()
        self._computations = {}  # key -> _Computation (queued or running)
        self._queue = []  # computations waiting, in order
        self._running = set()  # the computations running
        self._workers = None  # the FairPool of `cores` workers (made at first use)
        self._sessions = {}  # session -> Ticket
        self._step_seconds = {}  # (model, profile, fidelity) -> step_seconds
        # a thread per running map (its refinement; its points go to the
        # shared workers); a second, light pool opens the cache, so that a
        # cached map never waits for a big one
        self._runner = ThreadPoolExecutor(max_workers=max_running, thread_name_prefix="vibtrans-map")
        self._front = ThreadPoolExecutor(max_workers=2, thread_name_prefix="vibtrans-map-front")
        self.computed = 0  # maps computed (not read from the cache): for tests

    @property
    def cache(self):
        if self._cache is None:
            self._cache = MapCache(self.folder, self.max_bytes)
        return self._cache

    # ---------- the a-priori time ----------
    def step_seconds(self, request):
        """(seconds per integration step, seconds a point costs besides its
        steps) of the request's kernel (its model, profile and fidelity) on
        this host, measured once: a map point of STEP_PERIODS run to the end
        (its chaos verdict's exponent included), timed after an untimed one
        that compiles or loads the kernel; the run's seconds over the steps
        the estimate counts for it, and the point's Python around the run
        (the scene's checks, the run's summary).  Blocking."""
        from vibtrans import Scene, estimate_steps
        from vibtrans.maps.sweep import compute_point

        key = (request.model, request.profile if request.profiled() else None, request.fidelity)
        with self._lock:
            known = self._step_seconds.get(key)
        if known is not None:
            return known
        warmup.wait()
        values = {**request.scene_values(), "periods": STEP_PERIODS}
        compute_point(values, 0.0, 0.0, maprequest.CHAOS, "full")
        timed = []
        for _ in range(3):
            start = time.perf_counter()
            run = compute_point(values, 0.0, 0.0, maprequest.CHAOS, "full")["seconds"]
            timed.append((time.perf_counter() - start, run))
        whole, run = min(timed)
        measured = (run / estimate_steps(Scene(amplitude=1.0, mass=1.0, **values)), max(whole - run, 0.0))
        with self._lock:
            self._step_seconds[key] = measured
        return measured

    def estimate(self, request):
        """(Estimate or None, problems): the request's a-priori time, or why
        it is refused (the server's limits included, the time by that
        figure); blocking (off the loop)."""
        problems = request.problems(self.max_points)
        if problems:
            return None, problems
        try:
            request.sweep()  # every scene value, the library's checks
        except ValueError as exc:
            return None, [str(exc)]
        est = maprequest.estimate(request, *self.step_seconds(request), self.cores)
        if est.seconds > self.max_seconds:
            return est, [
                f"estimated {maprequest.duration(est.seconds)}, over this server's "
                f"limit of {maprequest.duration(self.max_seconds)} per map: fewer "
                f"points, periods or a lower fidelity"
            ]
        return est, []

    # ---------- requests ----------
    def submit(self, session, request, on_update):
        """Ask for `request`'s map for `session` (replacing the session's
        previous request); returns its Ticket.  MapRefused if the queue is
        full.  The request must have passed `estimate`."""
        key = request_key(request.cache_request())
        request = request.copy()
        ticket = Ticket(session, key, on_update)
        with self._lock:
            self._cancel_locked(session)
            comp = self._computations.get(key)
            if comp is None or comp.cancel.is_set():
                if len(self._queue) >= self.max_queued:
                    raise MapRefused(
                        f"this server's map queue is full ({self.max_queued} maps "
                        f"waiting): try again in a while"
                    )
                comp = _Computation(key, request)
                self._computations[key] = comp
                start = True
            else:
                start = False
            comp.tickets.append(ticket)
            self._sessions[session] = ticket
            last = comp.last
        if start:
            self._front.submit(self._open_or_queue, comp)
        elif last is not None:
            ticket.tell(last)
        return ticket

    def cancel(self, session):
        """Cancel the session's request (its computation stops if no other
        session waits for it).  Also when the session closes."""
        with self._lock:
            self._cancel_locked(session)

    def _cancel_locked(self, session):
        ticket = self._sessions.pop(session, None)
        if ticket is None:
            return
        ticket.cancelled = True
        comp = self._computations.get(ticket.key)
        if comp is not None and ticket in comp.tickets:
            comp.tickets.remove(ticket)
            if not comp.tickets:
                comp.cancel.set()
                self._forget_locked(comp)
        ticket.tell(Update("cancelled"))

    def _forget_locked(self, comp):
        if self._computations.get(comp.key) is comp:
            del self._computations[comp.key]
        if comp in self._queue:
            self._queue.remove(comp)

    def busy(self):
        """(maps computing or waiting, sessions with a request)."""
        with self._lock:
            return len(self._computations), len(self._sessions)

    def _tell(self, comp, update, final=False):
        with self._lock:
            tickets = list(comp.tickets)
            if update.kind in ("level", "chunk"):
                comp.last = update
            if final:
                for t in tickets:
                    if self._sessions.get(t.session) is t:
                        del self._sessions[t.session]
                self._forget_locked(comp)
        for t in tickets:
            t.tell(update)

    def _open_or_queue(self, comp):
        try:
            ds = self.cache.get(comp.key)  # verified; a damaged entry is removed
        except Exception as exc:
            log.exception("the map cache could not be read")
            self._tell(comp, Update("failed", text=f"the map cache could not be read: {exc}"), final=True)
            return
        if ds is not None:
            self._tell(
                comp, Update("done", comp.request.levels, comp.request.levels, ds, cached=True), final=True
            )
            return
        with self._lock:
            self._queue.append(comp)
            # the runner takes the queue in order as maps finish; the maps
            # queued before this one and not yet started take the free
            # places first (their threads may not have begun: count them)
            before = len(self._running) + len(self._queue) - 1
            computing = min(before, self.max_running)
            ahead = before - computing
        if before >= self.max_running:
            self._tell(
                comp,
                Update(
                    "queued",
                    text=f"waiting: {computing} map(s) computing "
                    f"and {ahead} waiting before it in this "
                    f"server's queue",
                ),
            )
        self._runner.submit(self._compute, comp)

    def _compute(self, comp):
        with self._lock:
            if comp in self._queue:
                self._queue.remove(comp)
            if comp.cancel.is_set():
                return
            self._running.add(comp)
        try:
            self._compute_now(comp)
        finally:
            with self._lock:
                self._running.discard(comp)

    def _compute_now(self, comp):
        levels = comp.request.levels
        # one working folder per key and process: a cancelled map's finished
        # points stay there (`.partial`) for a request that comes back; the
        # cache removes it after a day (mapcache.STALE_SECONDS)
        work = os.path.join(self.cache.folder, f"{comp.key}{TEMPORARY}{os.getpid()}")

        def on_level(level, ds):
            self._tell(comp, self._progress(comp, "level", level, ds))

        try:
            if not warmup.wait(comp.cancel):
                raise Cancelled("map cancelled")
            comp.started = time.monotonic()
            self._build(comp, work, on_level)
            self.computed += 1
            self.cache.publish(comp.key, work)
            ds = self.cache.get(comp.key)
            if ds is None:
                raise StoreMismatch("the computed map could not be read back")
            with self._lock:
                last = comp.last
            shown = (
                last is not None
                and last.kind == "level"
                and last.level == levels
                and same_values(last.ds, ds)
            )
            self._tell(comp, Update("done", levels, levels, ds, shown=shown), final=True)
        except Cancelled:
            self._tell(comp, Update("cancelled"), final=True)
        except Exception as exc:
            log.exception("a map on demand failed: %s", comp.request.title())
            self._tell(comp, Update("failed", text=f"{type(exc).__name__}: {exc}"), final=True)

    def _progress(self, comp, kind, level, ds):
        """A level's or chunk's Update, with the time left from the points
        done so far and the points the refinement is expected to compute."""
        request = comp.request
        left = maprequest.seconds_left(
            time.monotonic() - comp.started,
            int(ds["computed"].values.sum()),
            maprequest.expected_points(request),
        )
        return Update(kind, level, request.levels, ds, seconds_left=left)

    def start_helpers(self):
        """At the server's warm-up: measure the sphere's and the material
        point's cost per step at the default fidelity (step_seconds), and
        start the helper process that worker processes need for the
        server's whole life (multiprocessing's resource tracker, ~13 MB), so
        that it is not first started, and counted as memory kept, by a map."""
        for model in warmup.MODELS:
            self.step_seconds(maprequest.MapRequest(model=model))
        if self.processes and not self.scheduler:
            from multiprocessing import resource_tracker

            resource_tracker.ensure_running()

    def share(self):
        """A new lane of the server's workers (app/server/fairshare.py) for one map."""
        with self._lock:
            if self._workers is None:
                self._workers = FairPool(
                    self.cores,
                    name="vibtrans-map-point",
                    nice=MAP_NICE,
                    processes=self.processes,
                    initializer=compile_kernels,
                    linger=WORKERS_LINGER,
                )
            return self._workers.lane()

    def stop_workers(self):
        """Stop the map workers' processes now unless a map is computing
        (their memory back to the system)."""
        with self._lock:
            workers = self._workers
        if workers is not None:
            workers.stop_processes()

    def run_adaptive(self, comp, path, on_level):
        from vibtrans.maps.adaptive import run_adaptive

        lane = None if self.scheduler else self.share()

        def on_chunk(level, ds):
            self._tell(comp, self._progress(comp, "chunk", level, ds))

        try:
            run_adaptive(
                comp.request.sweep(),
                path,
                comp.request.levels,
                workers=self.cores,
                scheduler=self.scheduler,
                progress=False,
                on_level=on_level,
                cancel=comp.cancel,
                executor=lane,
                on_chunk=on_chunk,
                chunk_seconds=CHUNK_SECONDS,
            )
        finally:
            if lane is not None:
                lane.shutdown()


_JOBS = {"jobs": None, "settings": {}}


def configure(folder=None, max_bytes=None, cores=None, scheduler=None):
    """The server's settings (`vibtrans serve --map-cache --map-cache-mb
    --map-cores --scheduler`), before the first session."""
    _JOBS["settings"] = {
        k: v
        for k, v in (("folder", folder), ("max_bytes", max_bytes), ("cores", cores), ("scheduler", scheduler))
        if v is not None
    }
    _JOBS["jobs"] = None


def jobs():
    """The process's MapJobs (made at first use, from `configure` and the
    environment: VIBTRANS_MAP_CACHE, VIBTRANS_MAP_CORES, VIBTRANS_MAP_MAX_POINTS,
    VIBTRANS_MAP_MAX_SECONDS, VIBTRANS_MAP_PROCESSES: 0 runs the points in
    threads of the server, not in worker processes)."""
    if _JOBS["jobs"] is None:
        settings = dict(_JOBS["settings"])
        for name, key, kind, lo, hi in (
            ("cores", "VIBTRANS_MAP_CORES", int, 1, 256),
            ("max_points", "VIBTRANS_MAP_MAX_POINTS", int, 1, 1e7),
            ("max_seconds", "VIBTRANS_MAP_MAX_SECONDS", float, 1, 1e6),
            ("processes", "VIBTRANS_MAP_PROCESSES", int, 0, 1),
        ):
            text = os.environ.get(key)
            if name in settings or not text:
                continue
            try:
                value = kind(float(text))
            except ValueError:
                value = None
            if value is None or not lo <= value <= hi:
                raise InputError(f"{key} must be a number in [{lo:g}, {hi:g}], got {text!r}")
            settings[name] = value
        _JOBS["jobs"] = MapJobs(**settings)
    return _JOBS["jobs"]
