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
* Up to `max_running` maps compute at once and share `cores` workers
  fairly (app/fairshare.py: their points take turns, so a big map asked
  for first never starves a small one asked for later; a map alone gets
  every worker), niced (MAP_NICE) below the sessions' runs and the event
  loop.  The workers are processes (started for the maps, stopped when
  none computes), so that the points' Python never holds this process's
  GIL against its event loop.  `cores` is by default all cores but one,
  which stays for the sessions' clicks (their runs use
  app/controller.py's pool, never these workers).  Further maps wait
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
from vibtrans.maps.cache import DEFAULT_MAX_BYTES, TEMPORARY, MapCache, request_key
from vibtrans.core.simulate import warmup

from . import kernels, maprequest
from .fairshare import FairPool

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
# server core (2026-11-25, a noisy day) gave click p95 12.6 s with a picture
# every 3 s, 10.0 and 3.5 s with one every 10 s, 7.6 s with none (and 4.5,
# 9.5 s for the code before pictures): within the noise at 10 s
CHUNK_SECONDS = 10.0
# the share of the finest grid the refinement computes, by levels, before
# this server has computed a map of that model and depth (then its own):
# measured with `python -m devtools.mapestimate` (2026-11-27)
FRACTION_PRIOR = {1: 0.9, 2: 0.66, 3: 0.45, 4: 0.3, 5: 0.2, 6: 0.15}
# a map's own work besides its points' runs: its start (store, levels) and
# each computed point's passage (to a worker and back, into the store), on
# a host where a point's Python in its worker (the scene's checks, the run's
# summary: cost.timed_point's whole time less the run's) takes
# WORKER_PYTHON_SECONDS.  `python -m devtools.mapestimate --own-work`:
# maps of 10-period points, whose runs cost next to nothing, less their runs
# over the cores, 66 to 4827 points computed, fitted as 0.29 s + 0.76 ms a
# point (0.28 s + 0.87 ms in a second run), the worker's Python 0.46 ms
# (0.48) (2026-11-27 23:59 UTC, this 2-core machine, calm; the constants before,
# 0.4 s + 2.2 ms, were a slower host's and older code's: on this host every
# estimate came out 1.25-2x the time).  A server scales them by its probe's
# worker Python over WORKER_PYTHON_SECONDS, then learns them from its own
# maps (MapJobs.own_factor).
MAP_START_SECONDS = 0.29
WORKER_PYTHON_SECONDS = 4.6e-4
PROBE_PERIODS = 2000.0
# points the first estimate of a model and fidelity runs to measure this
# server's speed (cost.probe_points: drawn by their expected work among the
# points the refinement is expected to compute)
PROBE_POINTS = 12
# the weight of what a rate was measured on before, at each new measurement
# (MapJobs._pool_rate): a map's rate counts by its runs' seconds, the
# earlier ones by half of theirs, a quarter, ...
RATE_MEMORY = 0.5
POINT_PASSAGE_SECONDS = 7.6e-4
# seconds the map workers' processes outlive the last map: a map asked for
# meanwhile starts at once (a worker's start is ~1.3 s of CPU: imports,
# compiled kernels loaded); `stop_workers` ends them sooner (the server's
# memory release, once no session is open)
WORKERS_LINGER = 60.0


class _Done:
    """A finished future's stand-in (the probe without workers)."""

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


def _now(fn, *args):
    return _Done(fn(*args))


def _class_key(request):
    """The settings a decided map's periods per class hold for."""
    return (request.model, float(request.periods), float(request.tau), request.fidelity)


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
    return all(name in ds and np.array_equal(snapshot[name].values, ds[name].values,
                                             equal_nan=True)
               for name in snapshot.data_vars)


class MapRefused(Exception):
    """A request this server will not queue (the message says why)."""


class Update(NamedTuple):
    """What a map's subscriber hears.  kind: "queued" (text says how many
    wait before it), "level" (ds: the map so far after `level` of
    `levels`), "chunk" (ds: the map so far while `level` is computed:
    every CHUNK_SECONDS within a level), "done" (ds: the finished,
    verified map; cached: read from the cache; shown: its values are those
    of the finest level's map, sent before it to every subscriber, so a
    picture of that one stands), "failed" (text), "cancelled"."""
    kind: str
    level: int = 0
    levels: int = 0
    ds: object = None
    text: str = ""
    cached: bool = False
    shown: bool = False

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
        except Exception:       # a closed session's loop: nobody listens any more
            log.exception("a map update could not be delivered")


class _Computation:
    def __init__(self, key, request):
        self.key = key
        self.request = request
        self.cancel = threading.Event()
        self.tickets = []
        self.last = None          # the latest level's Update (for a late subscriber)
        self.shared = False       # another map ran beside it (its wall time is not its own)


class MapJobs:
    """The process's maps on demand (module docstring)."""

    def __init__(self, folder=None, max_bytes=DEFAULT_MAX_BYTES, cores=None,
                 max_queued=MAX_QUEUED, max_points=maprequest.MAX_POINTS,
                 max_seconds=maprequest.MAX_SECONDS, build=None, scheduler=None,
                 max_running=MAX_RUNNING, processes=True):
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
        self._build = build or self._run_adaptive
        self._cache = None
        self._lock = threading.Lock()
        self._computations = {}      # key -> _Computation (queued or running)
        self._queue = []             # computations waiting, in order
        self._running = set()        # the computations running
        self._workers = None         # the FairPool of `cores` workers (made at first use)
        self._sessions = {}          # session -> Ticket
        self._rates = {}             # (model, fidelity, unit, stop) -> s per unit run, measured
        self._rate_sums = {}         # the same -> (seconds, work) behind it (_pool_rate)
        self._whole = {}             # the same -> a point's whole time over its run's
        # a map's own work (MAP_START_SECONDS, POINT_PASSAGE_SECONDS) on this
        # server over the constants': (measured, the constants') seconds
        # pooled over the maps computed alone (own_factor), else the probe's
        self._own_sums = None
        self._own_probe = None
        self._fractions = {}         # (model, levels) -> share of the finest grid computed
        # (model, fidelity) -> the not-steady share of the refinement its last
        # map showed (cost.learn_not_steady_share)
        self._not_steady = {}
        self._profiles = {}          # model -> (f_end, extra) of its last decided map
        # (model, periods, tau, fidelity) -> periods per class its decided maps ran
        self._class_periods = {}
        # a thread per running map (its refinement; its points go to the
        # shared workers); a second, light pool opens the cache and
        # measures the speed, so that a cached map never waits for a big one
        self._runner = ThreadPoolExecutor(max_workers=max_running,
                                          thread_name_prefix="vibtrans-map")
        self._front = ThreadPoolExecutor(max_workers=2, thread_name_prefix="vibtrans-map-front")
        self.computed = 0            # maps computed (not read from the cache): for tests

    @property
    def cache(self):
        if self._cache is None:
            self._cache = MapCache(self.folder, self.max_bytes)
        return self._cache

    # ---------- speed and estimates ----------
    # A map's expected time: its own work (MAP_START_SECONDS, and
    # POINT_PASSAGE_SECONDS a point) and its points' runs.  Which points the
    # refinement computes is read from the shipped map of the model (nearest
    # mu) where it covers the window: the refinement replayed on its values
    # with the chaos verdict maps on demand judge by
    # (maprequest.replay_reference; adaptive.predict_refinement), plus a
    # share of the refinement its not-steady points' scattered drifts add
    # (cost.NOT_STEADY_REFINED, then this server's own).  What each point
    # costs: under the `decided` rule its bounded steps times the share of
    # T_obs its class there runs (cost.class_periods, then this server's
    # own); under `full` the shipped point's measured seconds scaled to the
    # request's run length and fidelity.  This server's speed against them
    # is probed on PROBE_POINTS points drawn by their expected work at the
    # first estimate of a model and fidelity, then learned from each map
    # computed (per unit of the work its points actually ran, their
    # periods_run; pooled with the earlier measurements, _pool_rate).
    # Beyond the shipped maps: the points' bounded steps, and the share of
    # the grid this server's last map of the model and depth computed, each
    # point's share of T_obs the profile of this server's last decided map
    # of the model, else the measured one of the whole domain.
    def seconds_per_work(self, model, fidelity, unit, stop="full"):
        """This server's measured wall seconds of a map point's runs on one
        worker per unit of the work they ran ("reference": seconds of the
        shipped map's point, a full map's unit inside a shipped map;
        "steps": bounded steps, a decided map's and any beyond the shipped
        maps; both for a run to T_obs, scaled by the periods run under
        `stop`), or None."""
        return self._rates.get((model, fidelity, unit, stop))

    def profile(self, model):
        """The (f_end, extra periods) of this server's last map of `model`
        made with the `decided` rule (vibtrans.maps.cost.decided_profile),
        or None (the model's measured profile then)."""
        return self._profiles.get(model)

    def fraction(self, model, levels):
        """The share of the finest grid the refinement computes: this
        server's last maps' of `model` and `levels`, else FRACTION_PRIOR's."""
        return self._fractions.get((model, levels), FRACTION_PRIOR.get(levels, 1.0))

    def _reference(self, request):
        """The shipped drift map of the request's model nearest its mu, or None."""
        from . import data
        mus = [mu for model, mu in data.available_maps() if model == request.model]
        if not mus:
            return None
        try:
            return data.drift_map(request.model, min(mus, key=lambda mu: abs(mu - request.mu)))
        except data.MapUnavailable:
            return None

    def _predicted(self, request):
        """(each finest-grid point's work, its unit, the points the replay
        of the refinement on the shipped map computes: (a boolean array,
        the same with the not-steady points' drifts unknown:
        maprequest.unknown_drift_reference), or the share of the grid this
        server's last map of the model and depth computed).  The work of a
        decided map is its points' bounded steps (vibtrans.maps.cost: a
        decided run's time follows its steps), of a full map the shipped
        map's seconds where it covers the window."""
        from vibtrans.maps.adaptive import predict_refinement
        reference = self._reference(request)
        work = (None if reference is None or request.stop != "full"
                else maprequest.reference_work(request, reference))
        # a profile's kernel costs more per step (maprequest.PROFILE_STEP_COST);
        # the refinement is predicted on the sphere's shipped map
        cost = maprequest.step_cost(request)
        if work is None:
            work, unit = maprequest.bound_steps(request) * cost, "steps"
        else:
            work, unit = work * cost, "reference"
        if reference is None or maprequest.nearest_points(request, reference) is None:
            return work, unit, self.fraction(request.model, request.levels)
        replay = maprequest.replay_reference(reference)
        return work, unit, tuple(
            predict_refinement(request.sweep(), request.levels, ref)
            for ref in (replay, maprequest.unknown_drift_reference(replay)))

    def expected_work(self, request):
        """(each finest-grid point's work, its unit, the points expected to
        be computed: an array of the finest grid, each point's expected
        count (vibtrans.maps.cost.expected_refinement with
        `not_steady_share`), or the share of the grid)."""
        from vibtrans.maps.cost import expected_refinement
        work, unit, computed = self._predicted(request)
        if isinstance(computed, tuple):
            computed = expected_refinement(*computed, self.not_steady_share(request))
        return work, unit, computed

    def not_steady_share(self, request):
        """The share of the not-steady points' refinement a map of the
        request's model and fidelity adds to the replay: this server's last
        map's where it showed one (cost.learn_not_steady_share), else
        cost.NOT_STEADY_REFINED's (0 where it has none)."""
        from vibtrans.maps.cost import NOT_STEADY_REFINED
        key = (request.model, request.fidelity)
        return self._not_steady.get(key, NOT_STEADY_REFINED.get(key, 0.0))

    def _share(self, request):
        """Each finest-grid point's expected periods over T_obs (an array,
        from the shipped map's classes, maprequest.reference_share), or
        None (the same for all then)."""
        reference = self._reference(request)
        return (None if reference is None else maprequest.reference_share(
            request, reference, self._class_periods.get(_class_key(request))))

    def measure_speed(self, request, work, unit, computed=1.0):
        """Probe this server's speed for the request's model and fidelity
        (seconds per unit of `work` run) on PROBE_POINTS points of its
        window, in the map workers: blocking (call it off the event loop); it
        also starts the workers, so that a map asked for soon after its
        estimate starts at once.  Each map computed then replaces it by its
        own rate.

        The points are drawn in proportion to their expected work (their
        `work` times the share of T_obs they are expected to run, among the
        points `computed`: cost.probe_points), each timed whole in its
        worker (cost.timed_point: the run and the Python around it), and the
        rate is their mean of seconds over expected work: an unbiased
        estimate of the map's own, its expected periods per point included
        (a first map's share of T_obs is checked on the probe's points)."""
        key = (request.model, request.fidelity, unit, request.stop)
        if key in self._rates:
            return self._rates[key]
        from vibtrans.maps.cost import probe_points, timed_point
        kernels.wait()
        # at the request's length (a much shorter run has the ramp's and a
        # run's fixed costs out of proportion) up to PROBE_PERIODS
        probe = request.copy()
        probe.periods = min(request.periods, PROBE_PERIODS)
        share = self._share(probe)
        share = probe.expected_share(self.profile(probe.model)) if share is None else share
        expected = work * (probe.periods / request.periods) * share
        weights = expected * (computed if isinstance(computed, np.ndarray) else 1.0)
        if not (np.all(np.isfinite(weights)) and weights.sum() > 0):
            return None
        picks = probe_points(weights, PROBE_POINTS)
        unique = sorted(set(picks.tolist()))
        la, lm = probe.axes()
        at = [np.unravel_index(k, weights.shape) for k in unique]
        lane = None if self.scheduler else self.share()
        try:
            run = lane.submit if lane is not None else _now
            futures = [run(timed_point, probe.scene_values(), la[i], lm[j],
                           maprequest.CHAOS, probe.stop) for i, j in at]
            timed = dict(zip(unique, (f.result() for f in futures)))
        finally:
            if lane is not None:
                lane.shutdown()
        seconds = {k: t for k, (_, t) in timed.items()}
        if self._own_probe is None:
            python = float(np.median([t - point["seconds"] for point, t in timed.values()]))
            if python > 0:
                self._own_probe = python / WORKER_PYTHON_SECONDS
        flat = expected.ravel()
        rate = float(np.mean([seconds[k] / flat[k] for k in picks.tolist()]))
        if rate > 0 and key not in self._rates:
            spent = float(sum(seconds[k] for k in picks.tolist()))
            self._pool_rate(key, spent, spent / rate)
            runs = sum(point["seconds"] for point, _ in timed.values())
            if runs > 0:
                self._whole[key] = sum(seconds.values()) / runs
        return self._rates.get(key)

    def own_factor(self):
        """This server's time for a map's own work over the constants'
        (MAP_START_SECONDS + POINT_PASSAGE_SECONDS a point): pooled over its
        maps computed alone (each older map at RATE_MEMORY's weight), else
        its first probe's worker Python over WORKER_PYTHON_SECONDS, else 1."""
        if self._own_sums is not None:
            return self._own_sums[0] / self._own_sums[1]
        return self._own_probe or 1.0

    def _learn_own(self, key, ds, wall):
        """A map computed alone took `wall` seconds: less its points' runs
        over the cores, the rest is its own work (its start, its points'
        passage, the levels' waits), pooled against the constants'.  key:
        its rate's (`_learn_speed`'s), whose probe measured a point's whole
        time over its run's."""
        computed = ds["computed"].values
        runs = self.whole_over_run(key) * float(np.nansum(ds["seconds"].values[computed]))
        own = wall - runs / max(1, self.cores)
        constants = MAP_START_SECONDS + int(computed.sum()) * POINT_PASSAGE_SECONDS
        if own > 0:
            measured, weight = self._own_sums or (0.0, 0.0)
            self._own_sums = (own + RATE_MEMORY * measured, constants + RATE_MEMORY * weight)

    def whole_over_run(self, key):
        """A point's whole time in its worker over its run's own `seconds`
        (the scene's checks and the run's summary besides the run), as this
        server's probe of `key` measured it, else 1."""
        return self._whole.get(key, 1.0)

    def _pool_rate(self, key, seconds, work):
        """Add `seconds` of runs over `work` to the rate of `key`: the
        seconds and work measured so far (the probe's, each map's), the
        older discounted by RATE_MEMORY at each new one, so that a small
        map's noise (its runs a few tenths of a second beside its fixed
        costs) does not set the next map's rate alone."""
        old_seconds, old_work = self._rate_sums.get(key, (0.0, 0.0))
        seconds += RATE_MEMORY * old_seconds
        work += RATE_MEMORY * old_work
        self._rate_sums[key] = (seconds, work)
        self._rates[key] = seconds / work

    def _learn_speed(self, request, ds):
        """The map's own rate (its points' seconds, per unit of the work
        they ran), the share of the grid computed, the not-steady points'
        share of its refinement and, for a decided map, its profile (the
        periods its points ran), for the next estimates.  Returns its rate's
        key, (model, fidelity, unit, stop)."""
        from vibtrans.maps.cost import (decided_profile, learn_class_periods,
                                        learn_not_steady_share)
        computed = ds["computed"].values
        work, unit, predicted = self._predicted(request)
        if isinstance(predicted, tuple):
            share = learn_not_steady_share(computed, *predicted)
            if share is not None:
                self._not_steady[(request.model, request.fidelity)] = share
        if request.stop == "full":
            ran = work[computed]
        else:
            ran = work[computed] * ds["periods_run"].values[computed] / request.periods
            own = ds[["periods_run", "stop_reason"]].where(ds["computed"])
            own.attrs = dict(ds.attrs)
            self._profiles[request.model] = decided_profile(own)
            reference = self._reference(request)
            classes = (None if reference is None
                       else maprequest.reference_classes(request, reference))
            if classes is not None:
                key = _class_key(request)
                self._class_periods[key] = learn_class_periods(
                    classes[computed], ds["periods_run"].values[computed],
                    self._class_periods.get(key))
        total = float(np.nansum(ran))
        key = (request.model, request.fidelity, unit, request.stop)
        # its points' own seconds (each run's, in its worker, times the
        # probe's whole time over the run's): the map's wall time less its
        # fixed costs would count those costs' growth with the host's load
        # as the points' (a small map's runs are a few tenths of a second
        # beside half a second of them)
        runs = self.whole_over_run(key) * float(np.nansum(ds["seconds"].values[computed]))
        if total > 0 and runs > 0:
            self._pool_rate(key, runs, total)
        self._fractions[(request.model, request.levels)] = float(computed.mean())
        return key

    def estimate(self, request):
        """(Estimate or None, problems): the request's expected cost, or why
        it is refused (the server's limits included); blocking (off the loop)."""
        problems = request.problems(self.max_points)
        if problems:
            return None, problems
        try:
            request.sweep()            # every scene value, the library's checks
        except ValueError as exc:
            return None, [str(exc)]
        work, unit, computed = self.expected_work(request)
        rate = self.measure_speed(request, work, unit, computed)
        own = self.own_factor()
        est = maprequest.estimate(request, rate, work, computed, self.cores,
                                  own * MAP_START_SECONDS, own * POINT_PASSAGE_SECONDS,
                                  self.profile(request.model), self._share(request))
        if est.seconds is not None and est.seconds > self.max_seconds:
            return est, [f"estimated {maprequest.duration(est.seconds)}, over this server's "
                         f"limit of {maprequest.duration(self.max_seconds)} per map: fewer "
                         f"points, periods or a lower fidelity"]
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
                    raise MapRefused(f"this server's map queue is full ({self.max_queued} maps "
                                     f"waiting): try again in a while")
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
            ds = self.cache.get(comp.key)       # verified; a damaged entry is removed
        except Exception as exc:
            log.exception("the map cache could not be read")
            self._tell(comp, Update("failed", text=f"the map cache could not be read: {exc}"),
                       final=True)
            return
        if ds is not None:
            self._tell(comp, Update("done", comp.request.levels, comp.request.levels, ds,
                                    cached=True), final=True)
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
            self._tell(comp, Update("queued", text=f"waiting: {computing} map(s) computing "
                                                   f"and {ahead} waiting before it in this "
                                                   f"server's queue"))
        self._runner.submit(self._compute, comp)

    def _compute(self, comp):
        with self._lock:
            if comp in self._queue:
                self._queue.remove(comp)
            if comp.cancel.is_set():
                return
            self._running.add(comp)
            # its wall time tells its own work only if no other map shared
            # the workers meanwhile
            if len(self._running) > 1:
                for other in self._running:
                    other.shared = True
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
            self._tell(comp, Update("level", level, levels, ds))
        try:
            if not kernels.wait(comp.cancel):
                raise Cancelled("map cancelled")
            started = time.perf_counter()
            self._build(comp, work, on_level)
            self.computed += 1
            self.cache.publish(comp.key, work)
            ds = self.cache.get(comp.key)
            if ds is None:
                raise StoreMismatch("the computed map could not be read back")
            key = self._learn_speed(comp.request, ds)
            wall = time.perf_counter() - started
            with self._lock:
                alone = not comp.shared
            if alone:
                self._learn_own(key, ds, wall)
            with self._lock:
                last = comp.last
            shown = (last is not None and last.kind == "level" and last.level == levels
                     and same_values(last.ds, ds))
            self._tell(comp, Update("done", levels, levels, ds, shown=shown), final=True)
        except Cancelled:
            self._tell(comp, Update("cancelled"), final=True)
        except Exception as exc:
            log.exception("a map on demand failed: %s", comp.request.title())
            self._tell(comp, Update("failed", text=f"{type(exc).__name__}: {exc}"), final=True)

    def start_helpers(self):
        """Start, at the server's warm-up, the helper process that worker
        processes need for the server's whole life (multiprocessing's
        resource tracker, ~13 MB), so that it is not first started, and
        counted as memory kept, by a map."""
        if self.processes and not self.scheduler:
            from multiprocessing import resource_tracker
            resource_tracker.ensure_running()

    def share(self):
        """A new lane of the server's workers (app/fairshare.py) for one map."""
        with self._lock:
            if self._workers is None:
                self._workers = FairPool(self.cores, name="vibtrans-map-point",
                                         nice=MAP_NICE, processes=self.processes,
                                         initializer=warmup, linger=WORKERS_LINGER)
            return self._workers.lane()

    def stop_workers(self):
        """Stop the map workers' processes now unless a map is computing
        (their memory back to the system)."""
        with self._lock:
            workers = self._workers
        if workers is not None:
            workers.stop_processes()

    def _run_adaptive(self, comp, path, on_level):
        from vibtrans.maps.adaptive import run_adaptive
        lane = None if self.scheduler else self.share()
        levels = comp.request.levels

        def on_chunk(level, ds):
            self._tell(comp, Update("chunk", level, levels, ds))
        try:
            run_adaptive(comp.request.sweep(), path, levels, workers=self.cores,
                         scheduler=self.scheduler, progress=False, on_level=on_level,
                         cancel=comp.cancel, executor=lane, on_chunk=on_chunk,
                         chunk_seconds=CHUNK_SECONDS)
        finally:
            if lane is not None:
                lane.shutdown()


_JOBS = {"jobs": None, "settings": {}}


def configure(folder=None, max_bytes=None, cores=None, scheduler=None):
    """The server's settings (`vibtrans serve --map-cache --map-cache-mb
    --map-cores --scheduler`), before the first session."""
    _JOBS["settings"] = {k: v for k, v in
                         (("folder", folder), ("max_bytes", max_bytes), ("cores", cores),
                          ("scheduler", scheduler))
                         if v is not None}
    _JOBS["jobs"] = None


def jobs():
    """The process's MapJobs (made at first use, from `configure` and the
    environment: VIBTRANS_MAP_CACHE, VIBTRANS_MAP_CORES, VIBTRANS_MAP_MAX_POINTS,
    VIBTRANS_MAP_MAX_SECONDS, VIBTRANS_MAP_PROCESSES: 0 runs the points in
    threads of the server, not in worker processes)."""
    if _JOBS["jobs"] is None:
        settings = dict(_JOBS["settings"])
        for name, key, kind, lo, hi in (("cores", "VIBTRANS_MAP_CORES", int, 1, 256),
                                        ("max_points", "VIBTRANS_MAP_MAX_POINTS", int, 1, 1e7),
                                        ("max_seconds", "VIBTRANS_MAP_MAX_SECONDS", float, 1,
                                         1e6),
                                        ("processes", "VIBTRANS_MAP_PROCESSES", int, 0, 1)):
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
