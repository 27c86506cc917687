"""Maps on demand (app/session/maprequest.py, app/server/mapjobs.py): the request's checks
and URL form, the server-wide queue (one map per session, sessions sharing
a computation, cancel, the cache's reuse and a damaged entry recomputed)."""

import os
import threading

import numpy as np
import pytest
from asyncutil import wait_until
from budget import budget

from vibtrans_explorer.server import mapjobs
from vibtrans_explorer.session import maprequest
from vibtrans_explorer.session.maprequest import MapRequest

# a tiny map: 5 x 5 points (2 coarse cells, K = 1), 30 periods at preview
TINY = dict(
    model="deformable",
    fidelity="preview",
    periods=30.0,
    tau=5.0,
    la_from=-0.5,
    la_to=0.5,
    lm_from=0.0,
    lm_to=1.0,
    cells=2,
    levels=1,
)


class Listener:
    """A session's updates, and an event set at the final one."""

    def __init__(self):
        self.updates = []
        self.ended = threading.Event()

    def __call__(self, update):
        self.updates.append(update)
        if update.final:
            self.ended.set()

    def wait(self, timeout=300):
        assert self.ended.wait(timeout), [u.kind for u in self.updates]
        return self.updates[-1]

    def kinds(self):
        return [u.kind for u in self.updates]


@pytest.fixture
def gate():
    return threading.Event()


@pytest.fixture
def jobs(tmp_path, gate):
    """MapJobs on a fresh cache folder whose maps start once `gate` is set."""

    def build(comp, path, on_level):
        assert gate.wait(60)
        made.run_adaptive(comp, path, on_level)

    made = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, build=build)
    return made


def test_a_map_arrives_level_by_level_then_comes_from_the_cache(jobs, gate):
    gate.set()
    first = Listener()
    jobs.submit("a", MapRequest(**TINY), first)
    done = first.wait()
    assert done.kind == "done" and not done.cached, first.kinds()
    levels = [u.level for u in first.updates if u.kind == "level"]
    assert levels == [0, 1]  # the coarse grid, then the finest
    coarse = next(u.ds for u in first.updates if u.kind == "level")
    assert coarse["computed"].values.sum() == 9  # 3 x 3 coarse points
    assert np.isfinite(coarse["drift_velocity"].values).all()  # filled from its cells
    assert done.ds["drift_velocity"].shape == (5, 5)
    # the finest level's picture is the verified map's: a subscriber keeps it
    assert done.shown
    # another session asking for the same map reads it: nothing computed
    second = Listener()
    jobs.submit("b", MapRequest(**TINY), second)
    again = second.wait()
    assert again.kind == "done" and again.cached and jobs.computed == 1
    assert not again.shown  # nothing drawn before: draw it
    # each level says the time left from the points done: some after the
    # coarse grid (9 of the 0.9 x 25 expected), none once they are all done
    left = [u.seconds_left for u in first.updates if u.kind == "level"]
    assert left[0] > 0 and left[-1] == 0 and "left" in first.updates[0].left_text()
    # made with the request's stopping rule (a new request's: decided), its
    # points' periods run kept; 30 periods end before the rule's first check
    assert done.ds.attrs["stop"] == "decided"
    assert (done.ds["periods_run"].values[done.ds["computed"].values] == 30.0).all()
    np.testing.assert_array_equal(again.ds["drift_velocity"].values, done.ds["drift_velocity"].values)


def test_sessions_asking_for_one_map_share_its_computation(jobs, gate):
    a, b = Listener(), Listener()
    jobs.submit("a", MapRequest(**TINY), a)
    jobs.submit("b", MapRequest(**TINY), b)
    gate.set()
    assert a.wait().kind == "done" and b.wait().kind == "done"
    assert jobs.computed == 1
    assert not a.wait().cached and not b.wait().cached


def test_a_new_request_of_a_session_cancels_its_previous_one(jobs, gate):
    old, new = Listener(), Listener()
    jobs.submit("a", MapRequest(**TINY), old)
    jobs.submit("a", MapRequest(**{**TINY, "mu": 0.5}), new)
    assert old.wait(5).kind == "cancelled"
    gate.set()
    assert new.wait().kind == "done"
    assert jobs.computed == 1  # the first one never ran
    assert jobs.busy() == (0, 0)


def test_cancel_stops_the_map_and_caches_nothing_but_spares_other_sessions(jobs, gate):
    from vibtrans.maps.cache import request_key

    alone, shared_a, shared_b = Listener(), Listener(), Listener()
    request = MapRequest(**TINY)
    jobs.submit("a", request, alone)
    jobs.cancel("a")
    assert alone.wait(5).kind == "cancelled"
    other = MapRequest(**{**TINY, "mu": 0.5})
    jobs.submit("b", other, shared_a)
    jobs.submit("c", other, shared_b)
    jobs.cancel("b")  # c still waits for it
    gate.set()
    assert shared_b.wait().kind == "done"
    assert shared_a.kinds()[-1] == "cancelled" and "done" not in shared_a.kinds()
    assert jobs.cache.get(request_key(request.cache_request())) is None
    assert jobs.computed == 1


def test_a_damaged_cache_entry_is_recomputed_not_shown(jobs, gate):
    gate.set()
    first = Listener()
    jobs.submit("a", MapRequest(**TINY), first)
    first.wait()
    entry = jobs.cache.path(jobs.cache.entries()[0])
    chunk = next(
        os.path.join(root, f)
        for root, _, files in os.walk(entry)
        for f in files
        if "drift_velocity" in root and not f.startswith(".")
    )
    with open(chunk, "r+b") as f:  # flip a byte of the data
        f.seek(max(0, os.path.getsize(chunk) // 2))
        byte = f.read(1)
        f.seek(-1, 1)
        f.write(bytes([byte[0] ^ 0xFF]))
    again = Listener()
    jobs.submit("b", MapRequest(**TINY), again)
    done = again.wait()
    assert done.kind == "done" and not done.cached and jobs.computed == 2


def test_the_estimate_bounds_the_work_and_refuses_beyond_the_limits(tmp_path, monkeypatch):
    """The a-priori time: the points the refinement is expected to compute
    x (their mean expected steps x the measured seconds per step + a
    point's own seconds) over the workers; beyond the server's limits the
    request is refused by it."""
    from vibtrans import Scene, estimate_steps
    from vibtrans.maps.cost import expected_time_share

    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=2, max_points=1000, max_seconds=10.0)
    monkeypatch.setattr(jobs, "step_seconds", lambda request: (1e-7, 1e-3))
    request = MapRequest(**{**TINY, "stop": "full"})
    est, problems = jobs.estimate(request)
    assert problems == [] and est.points == 25
    # every point's steps at its own step (the contact time scale's): the bound
    la, lm = request.axes()
    steps = np.array(
        [
            [estimate_steps(Scene(amplitude=10**a, mass=10**m, **request.scene_values())) for m in lm]
            for a in la
        ]
    )
    np.testing.assert_array_equal(maprequest.bound_steps(request), steps)
    assert est.computed == pytest.approx(0.9 * 25)  # 5 points per axis: the 9's share
    assert est.steps == pytest.approx(est.computed * steps.mean())
    assert est.seconds == pytest.approx(
        maprequest.MAP_START_SECONDS + est.computed * (steps.mean() * 1e-7 + 1e-3) / 2
    )
    assert "about 0.41 s on this server (2 cores, from its measured time" in est.text(2)
    # a decided map: each point's steps times the share of them it is expected to run
    decided = MapRequest(**TINY)
    share = expected_time_share("deformable", "decided", 30.0, 5.0, "preview")
    assert share < 1.0
    assert jobs.estimate(decided)[0].steps == pytest.approx(est.steps * share)
    big = MapRequest(**{**TINY, "cells": 8, "levels": 3})  # 65 x 65
    est, problems = jobs.estimate(big)
    assert est is None and "4,225 points is over this server's limit of 1,000" in problems[0]
    slow = MapRequest(**{**TINY, "periods": 10000.0, "fidelity": "reference", "stop": "full"})
    est, problems = jobs.estimate(slow)
    assert est.seconds > 10.0 and "over this server's limit of 10 s per map" in problems[0]
    empty = MapRequest(**{**TINY, "la_from": 0.5, "la_to": -0.5})
    assert "log10 A* 'from' (0.5) must be below its 'to' (-0.5)" in jobs.estimate(empty)[1][0]


def test_the_cost_per_step_is_measured_once_per_kernel_and_fidelity(tmp_path):
    """step_seconds: a map point's run timed on this host, once for each
    model, profile and fidelity; the material point has no profile."""
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, processes=False)
    step, point = jobs.step_seconds(MapRequest(**TINY))
    assert 0 < step < 1e-5 and 0 <= point < 1.0
    assert jobs.step_seconds(MapRequest(**{**TINY, "la_from": -0.4})) == (step, point)
    cone = jobs.step_seconds(MapRequest(**{**TINY, "profile": "cone"}))
    standard = jobs.step_seconds(MapRequest(**{**TINY, "fidelity": "standard"}))
    assert cone != (step, point) and standard != (step, point)
    material = jobs.step_seconds(MapRequest(**{**TINY, "model": "point-mass"}))
    assert jobs.step_seconds(MapRequest(**{**TINY, "model": "point-mass", "profile": "cone"})) == material


def test_the_points_expected_follow_the_finest_grid_s_side():
    """expected_points: COMPUTED_SHARE at the finest grid's points per axis,
    in between interpolated in log points per axis."""
    assert maprequest.expected_points(MapRequest(**{**TINY, "cells": 4, "levels": 3})) == pytest.approx(
        0.45 * 33**2
    )
    # 8 cells, 3 levels: 65 per axis, the share of 4 cells and 4 levels
    assert maprequest.expected_points(MapRequest(**{**TINY, "cells": 8, "levels": 3})) == pytest.approx(
        0.3 * 65**2
    )
    between = maprequest.expected_points(MapRequest(**{**TINY, "cells": 6, "levels": 3}))
    assert 0.3 * 49**2 < between < 0.45 * 49**2


def test_the_time_left_is_the_progress_bars():
    """seconds_left: elapsed / done x the points still expected (tqdm's and
    dask's remaining time), none before a point is done, none past the end."""
    assert maprequest.seconds_left(10.0, 0, 100) is None
    assert maprequest.seconds_left(10.0, 20, 100) == pytest.approx(40.0)
    assert maprequest.seconds_left(10.0, 120, 100) == 0.0
    assert mapjobs.Update("chunk", seconds_left=150.0).left_text() == ", about 2.5 min left"
    assert mapjobs.Update("chunk").left_text() == ""


def test_the_url_form_round_trips_and_names_a_bad_value():
    request = MapRequest(
        model="point-mass",
        mu=0.45,
        theta=1.1,
        nu=0.25,
        tau=20.0,
        periods=150.0,
        fidelity="preview",
        stick_rule="classical",
        alpha_t=0.2,
        la_from=-3.5,
        la_to=4.25,
        lm_from=-6.0,
        lm_to=7.0,
        cells=3,
        levels=2,
    )
    text = maprequest.encode(request)
    back, errors = maprequest.decode(text)
    assert errors == [] and back.values() == request.values()
    assert maprequest.encode(back) == text
    parts = text.split(",")
    bad = ",".join([*parts[:1], "2", *parts[2:]])  # mu = 2
    none, errors = maprequest.decode(bad)
    assert none is None and errors == ["URL parameter 'map': mu must be a number in [0.01, 1.0]; got '2'"]
    bad = ",".join([*parts[:-3], "2.5", *parts[-2:]])  # levels not an integer
    assert "levels must be an integer in [1, 6]; got '2\\.5'" in maprequest.decode(bad)[1][0]
    assert "must hold 19 comma-separated values" in maprequest.decode("deformable,0.3")[1][0]
    assert "must hold 19" in maprequest.decode(text + ",none,full")[1][0]
    bad = ",".join([*parts[:-2], "fast", parts[-1]])
    assert (
        "URL parameter 'map': stop must be one of decided, full; got 'fast'" in maprequest.decode(bad)[1][0]
    )
    swapped = ",".join([*parts[:10], parts[11], parts[10], *parts[12:]])
    assert "'from' (4.25) must be below its 'to' (-3.5)" in maprequest.decode(swapped)[1][0]


def test_a_new_request_stops_each_point_once_decided_and_an_old_link_meant_full_runs():
    """A link written before the stopping rule was part of the request (its
    16 values) meant full runs and still does; a new request is decided."""
    assert MapRequest().stop == "decided"
    for stop in ("decided", "full"):
        request = MapRequest(**{**TINY, "stop": stop})
        text = maprequest.encode(request)
        assert text.endswith(f",{stop},sphere")
        back, errors = maprequest.decode(text)
        assert errors == [] and back.values() == request.values()
    old = maprequest.encode(MapRequest(**TINY)).rsplit(",", 2)[0]  # the 16 older values
    back, errors = maprequest.decode(old)
    assert errors == [] and back.stop == "full"
    assert back.values() == MapRequest(**{**TINY, "stop": "full"}).values()
    assert maprequest.encode(back) == old + ",full,sphere"  # written again with its rule
    # the sweep it runs, and the title over its map, carry the rule
    assert MapRequest(**TINY).sweep().stop == "decided" and back.sweep().stop == "full"
    assert "stop: decided" in MapRequest(**TINY).title() and "stop: full" in back.title()


def test_the_cache_key_holds_the_stopping_rule_and_a_full_map_keeps_its_old_key():
    from vibtrans.maps.cache import request_key

    full = MapRequest(**{**TINY, "stop": "full"})
    decided = MapRequest(**{**TINY, "stop": "decided"})
    assert request_key(full.cache_request()) != request_key(decided.cache_request())
    assert decided.cache_request()["stop"] == "decided"
    # a full map's key is the one it had before the rule existed (its store's
    # attributes name no rule either: vibtrans.maps.sweep.Sweep.attrs)
    assert "stop" not in full.cache_request()
    assert "stop" not in full.sweep().attrs() and decided.sweep().attrs()["stop"] == "decided"


def test_the_cache_key_ignores_what_changes_no_number():
    base = MapRequest(**TINY)
    # the material point's rules do not enter a deformable map
    same = MapRequest(**{**TINY, "stick_rule": "classical", "alpha_t": 0.1})
    assert base.cache_request() == same.cache_request()
    for change in (
        {"mu": 0.31},
        {"periods": 31.0},
        {"la_to": 0.6},
        {"levels": 2},
        {"fidelity": "standard"},
        {"stop": "full"},
    ):
        assert MapRequest(**{**TINY, **change}).cache_request() != base.cache_request()


# ------------------------------------------------------------------ the explorer's side
def _explorer(monkeypatch, query):
    from urllib.parse import parse_qs

    import panel as pn

    from vibtrans_explorer import explorer as E
    from vibtrans_explorer.views.browserside import BrowserAddress

    monkeypatch.setattr(E, "_page_location", BrowserAddress)
    args = {k: [v.encode() for v in vs] for k, vs in parse_qs(query).items()}
    monkeypatch.setattr(type(pn.state), "session_args", property(lambda self: args))
    return E.Explorer()


def test_a_link_with_a_map_request_shows_it_and_a_bad_one_says_why(monkeypatch):
    request = MapRequest(**{**TINY, "mu": 0.45})
    text = maprequest.encode(request)
    e = _explorer(monkeypatch, f"map={text}&mu=0.45&la=0.1&lm=0.5")
    assert e.state.map_request == text and e._url_map.values() == request.values()
    assert e.state.mu == 0.45 and not e.message.visible  # the map's own mu: no reset
    assert f"map={text.replace(',', '%2C')}" in e.location.search
    e.ondemand.back_to_shipped()  # the request leaves the link
    assert e.state.map_request is None and "map=" not in e.location.search
    assert e.state.mu == 0.3  # a shipped map's, and said so
    bad = _explorer(monkeypatch, "map=" + text.replace("deformable", "rigid"))
    assert bad.state.map_request is None
    assert (
        "URL parameter 'map': model must be one of deformable, point-mass; got 'rigid'" in bad.message.object
    )


def test_back_to_an_address_without_the_map_shows_the_shipped_map(monkeypatch):
    """The browser's Back from a link with a map on demand to one without:
    the shipped map again, and the page's state is the address's."""
    text = maprequest.encode(MapRequest(**{**TINY, "mu": 0.45}))
    e = _explorer(monkeypatch, f"map={text}&mu=0.45&la=0.1&lm=0.5")
    with_map = e.location.search
    e.location.search = "?la=0.2&lm=0.5&mu=0.3"  # as the browser reports it
    assert e.state.map_request is None and e.ondemand.computed_map() is None
    assert (e.state.log_amplitude, e.state.mu) == (0.2, 0.3)
    assert e.location.search == "?la=0.2&lm=0.5&mu=0.3"  # the address stays as it is
    e.state.log_mass = 0.7  # a change: a new address
    assert "map=" not in e.location.search and "lm=0.7" in e.location.search
    assert with_map != e.location.search


def test_zooming_the_shipped_map_beyond_its_resolution_offers_a_refinement(monkeypatch):
    e = _explorer(monkeypatch, "")
    e.main()
    fig = e.map_view.figures[0]
    fig.x_range.start, fig.x_range.end = -1.0, 1.0  # 40 cells of 0.05: no offer
    fig.y_range.start, fig.y_range.end = 0.0, 2.0
    assert e.ondemand.refine_button is None and not e.ondemand.refine_box.visible
    fig.x_range.start, fig.x_range.end = 0.1, 0.3  # 4 x 4 cells
    fig.y_range.start, fig.y_range.end = 0.5, 0.7
    assert e.ondemand.refine_box.visible and e.ondemand.refine_button.visible
    e.ondemand.refine_window()
    r = e.ondemand.map_request_panel.request
    shipped = e.ondemand.shipped_request()  # the shipped map's stored scene
    assert (r.la_from, r.la_to, r.lm_from, r.lm_to) == (0.1, 0.3, 0.5, 0.7)
    assert (r.tau, r.periods, r.fidelity, r.model, r.mu) == (
        shipped.tau,
        shipped.periods,
        shipped.fidelity,
        "deformable",
        0.3,
    )
    assert e.map_tabs.active == 3


@pytest.mark.slow
def test_a_cluster_computes_the_same_map_and_can_cancel_it(tmp_path):
    """`vibtrans serve --scheduler`: the points run on a dask.distributed
    cluster (here a LocalCluster) and the map equals the local one; a cancel
    drops the cluster's queued points."""
    from dask.distributed import LocalCluster

    local = mapjobs.MapJobs(folder=str(tmp_path / "local"), cores=1)
    mine = Listener()
    local.submit("a", MapRequest(**TINY), mine)
    expected = mine.wait()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        remote = mapjobs.MapJobs(
            folder=str(tmp_path / "remote"), cores=1, scheduler=cluster.scheduler_address
        )
        theirs = Listener()
        remote.submit("a", MapRequest(**TINY), theirs)
        got = theirs.wait()
        assert got.kind == "done" and not got.cached, theirs.kinds()
        for v in ("drift_velocity", "drift", "chaotic", "computed"):
            np.testing.assert_array_equal(got.ds[v].values, expected.ds[v].values)
        bigger = MapRequest(**{**TINY, "cells": 4, "levels": 2})  # 17 x 17
        cancelled = Listener()

        def cancel_at_first_level(update):
            cancelled(update)
            if update.kind == "level":
                remote.cancel("b")

        remote.submit("b", bigger, cancel_at_first_level)
        assert cancelled.wait().kind == "cancelled", cancelled.kinds()
        # the computation ends (its queued points dropped), leaving no map
        wait_until(lambda: not remote._running, budget(120), "the computation's end")
        from vibtrans.maps.cache import request_key

        assert not remote._running
        assert remote.cache.get(request_key(bigger.cache_request())) is None


def test_worker_processes_compute_the_threads_map_and_stop_after_it(tmp_path, monkeypatch):
    """The points run in worker processes by default (their Python off the
    server's GIL), with the same results as in threads of the server; the
    processes are gone WORKERS_LINGER after no map computes (their memory
    with them), or at `stop_workers`."""
    monkeypatch.setattr(mapjobs, "WORKERS_LINGER", 0.5)
    threads = mapjobs.MapJobs(folder=str(tmp_path / "threads"), cores=1, processes=False)
    mine = Listener()
    threads.submit("a", MapRequest(**TINY), mine)
    expected = mine.wait()
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "processes"), cores=1)
    assert jobs.processes
    theirs = Listener()
    jobs.submit("a", MapRequest(**TINY), theirs)
    got = theirs.wait()
    assert got.kind == "done" and not got.cached, theirs.kinds()
    for v in ("drift_velocity", "drift", "chaotic", "computed", "lyapunov", "steps"):
        np.testing.assert_array_equal(got.ds[v].values, expected.ds[v].values)
    assert jobs._workers.processes and threads._workers is not None
    assert not threads._workers.processes
    wait_until(lambda: not jobs._workers.processes_up(), budget(60), "the processes' end")
    assert not jobs._workers.processes_up()
    monkeypatch.setattr(mapjobs, "WORKERS_LINGER", 600.0)
    again = mapjobs.MapJobs(folder=str(tmp_path / "again"), cores=1)
    mine = Listener()
    again.submit("a", MapRequest(**TINY), mine)
    assert mine.wait().kind == "done"
    # the map's bookkeeping done, its lane shut (without a linger its
    # processes would have stopped then)
    wait_until(lambda: not again._running, budget(60), "the map's end")
    assert again._workers.processes_up()  # lingering for the next map
    again.stop_workers()
    assert not again._workers.processes_up()


def test_the_environment_switches_the_map_workers_to_threads(monkeypatch):
    monkeypatch.setattr(mapjobs, "_JOBS", {"jobs": None, "settings": {}})
    monkeypatch.setenv("VIBTRANS_MAP_PROCESSES", "0")
    assert mapjobs.jobs().processes is False
    monkeypatch.setattr(mapjobs, "_JOBS", {"jobs": None, "settings": {}})
    monkeypatch.setenv("VIBTRANS_MAP_PROCESSES", "2")
    with pytest.raises(
        mapjobs.InputError,
        match=r"VIBTRANS_MAP_PROCESSES must be a number "
        r"in \[0, 1\], got '2'",
    ):
        mapjobs.jobs()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--scheduler", "localhost:8786"], "scheduler must be an address such as tcp://HOST:PORT"),
        (["--map-cores", "0"], "map-cores must be in [1, 256]"),
        (["--map-cache-mb", "0"], "map-cache-mb must be in [1, 10000000]"),
    ],
)
def test_serve_refuses_bad_map_settings_before_starting(capsys, argv, message):
    from vibtrans.cli import main

    try:
        code = main(["serve", "--port", "5999", *argv])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err, err


def test_a_closing_page_cancels_its_map(monkeypatch, tmp_path, gate):
    """A session that closes while its map waits cancels it (unless another
    session waits for it too): the explorer's session-destroyed callback."""
    made = mapjobs.MapJobs(
        folder=str(tmp_path / "maps"), cores=1, build=lambda comp, path, on_level: gate.wait(60)
    )
    monkeypatch.setattr(mapjobs, "jobs", lambda: made)
    e = _explorer(monkeypatch, "")
    mine = Listener()
    made.submit(e.ondemand.session, MapRequest(**TINY), mine)
    assert made.busy() == (1, 1)
    e._on_session_destroyed(None)
    assert mine.wait(5).kind == "cancelled" and made.busy() == (0, 0)
    gate.set()


def test_a_small_map_asked_for_later_is_not_starved_by_a_big_one(tmp_path):
    """Maps share the server's workers in turn (app/server/fairshare.py): on one
    core, a 5 x 5 map asked for while a 33 x 33 map computes finishes
    first, and both maps equal the ones computed alone."""
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    big_request = MapRequest(**{**TINY, "cells": 8, "levels": 2})  # 33 x 33
    small_request = MapRequest(**{**TINY, "mu": 0.5})
    ended = []
    big, small = Listener(), Listener()

    def on_big(update):
        big(update)
        if update.final:
            ended.append("big")
        elif update.kind == "level" and update.level == 0:
            # the big map's coarse level is drawn: now a small map is asked for
            jobs.submit("small", small_request, on_small)

    def on_small(update):
        small(update)
        if update.final:
            ended.append("small")

    jobs.submit("big", big_request, on_big)
    assert small.wait().kind == "done" and big.wait().kind == "done", (big.kinds(), small.kinds())
    assert ended == ["small", "big"]
    assert "queued" not in small.kinds()
    alone = mapjobs.MapJobs(folder=str(tmp_path / "alone"), cores=1)
    for request, shared in ((small_request, small), (big_request, big)):
        solo = Listener()
        alone.submit("a", request, solo)
        got = solo.wait()
        for v in ("drift_velocity", "drift", "chaotic", "computed"):
            np.testing.assert_array_equal(got.ds[v].values, shared.updates[-1].ds[v].values)


@pytest.mark.parametrize("slow_cache_read", ["first", "second"])
def test_beyond_the_running_maps_a_request_waits_its_turn(tmp_path, gate, slow_cache_read):
    """With max_running maps computing, the next one says it waits, whichever
    of two requests reaches the queue first (a slow cache read lets the
    second overtake the first, as a busy machine can)."""
    building = threading.Event()

    def build(comp, path, on_level):
        building.set()
        assert gate.wait(60)
        made.run_adaptive(comp, path, on_level)

    made = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, build=build, max_running=1)
    read = made.cache.get
    slow_key = mapjobs.request_key(
        MapRequest(**(TINY if slow_cache_read == "first" else {**TINY, "mu": 0.5})).cache_request()
    )

    def get(key):
        if key == slow_key:  # read once the other map computes
            assert building.wait(60)
        return read(key)

    made.cache.get = get
    first, second = Listener(), Listener()
    made.submit("a", MapRequest(**TINY), first)
    made.submit("b", MapRequest(**{**TINY, "mu": 0.5}), second)
    # the two requests open the cache on two threads: either may reach the
    # queue first, and the other is the one that waits
    wait_until(lambda: "queued" in first.kinds() + second.kinds(), budget(60), "a queued map")
    gate.set()
    assert first.wait().kind == "done" and second.wait().kind == "done"
    queued = [u for listener in (first, second) for u in listener.updates if u.kind == "queued"]
    assert len(queued) == 1 and "1 map(s) computing and 0 waiting" in queued[0].text


def test_a_map_is_pictured_within_its_levels(tmp_path, monkeypatch):
    """Every CHUNK_SECONDS within a refinement level, the map so far: chunk
    updates between the levels, each a complete picture (no NaN), their
    computed points growing, the last update the map."""
    from vibtrans.maps import adaptive

    monkeypatch.setattr(mapjobs, "CHUNK_SECONDS", 0.0)
    monkeypatch.setattr(adaptive, "POINTS_PER_TASK", 1)
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    got = Listener()
    jobs.submit("a", MapRequest(**{**TINY, "levels": 2}), got)  # 9 x 9
    assert got.wait().kind == "done", got.kinds()
    kinds = got.kinds()
    assert kinds[0] == "level" and kinds.count("level") == 3 and "chunk" in kinds
    assert kinds.index("chunk") > 0  # not within the coarse grid
    pictures = [u for u in got.updates if u.kind in ("level", "chunk", "done")]
    counts = [int(u.ds["computed"].values.sum()) for u in pictures]
    assert counts == sorted(counts)
    for u in pictures:
        assert np.isfinite(u.ds["drift_velocity"].values).all(), u.kind
        assert u.kind != "chunk" or 1 <= u.level <= 2


def test_the_finished_map_is_not_drawn_again_when_its_last_level_showed_it():
    """`same_values`: the verified map equals the finest level's map value
    for value (then the "done" update says `shown`, and the explorer and the
    Design tab keep their picture: no second render, no redraw in every
    browser); any difference draws it."""
    import xarray as xr

    grid = np.arange(6.0).reshape(2, 3)
    drawn = xr.Dataset(
        {
            "drift_velocity": (("a", "m"), grid),
            "chaotic": (("a", "m"), grid > 2),
            "lyapunov": (("a", "m"), np.where(grid > 4, np.nan, grid)),
        }
    )
    stored = drawn.assign(digest=("a", np.zeros(2)))  # the store holds more
    assert mapjobs.same_values(drawn, stored)
    changed = stored.copy(deep=True)
    changed["drift_velocity"].values[1, 2] += 1e-12
    assert not mapjobs.same_values(drawn, changed)
    assert not mapjobs.same_values(drawn, stored.drop_vars("chaotic"))


# ------------------------------------------------------------------ the particle's profile
def test_a_profile_is_the_requests_18th_value_and_an_older_link_meant_the_sphere():
    cone = MapRequest(**{**TINY, "profile": "cone"})
    text = maprequest.encode(cone)
    assert text.endswith(",decided,cone")
    back, errors = maprequest.decode(text)
    assert errors == [] and back.values() == cone.values()
    # a link of the 17 values (written before profiles): the sphere
    old = text.rsplit(",", 1)[0]
    back, errors = maprequest.decode(old)
    assert errors == [] and back.profile == "sphere" and back.stop == "decided"
    # a bad profile named with the explorer's kinds; a measured table refused
    for bad in ("power:0.5", "file:/etc/passwd", "ellipsoid"):
        none, errors = maprequest.decode(text.rsplit(",", 1)[0] + "," + bad)
        assert none is None and len(errors) == 1
        assert errors[0].startswith(
            "URL parameter 'map': profile must be one of sphere, cone, power:N (N ≥ 1), flat-sphere:C"
        ), errors
    with pytest.raises(ValueError, match=r"exponent n must be a real number in \[1, inf\)"):
        MapRequest(profile="power:0.9")


def test_a_profiles_map_runs_keys_and_says_its_profile_and_the_material_point_has_none():
    from vibtrans.maps.cache import request_key

    sphere = MapRequest(**TINY)
    cone = MapRequest(**{**TINY, "profile": "cone"})
    flat = MapRequest(**{**TINY, "profile": "flat-sphere:0.5"})
    keys = {request_key(r.cache_request()) for r in (sphere, cone, flat)}
    assert len(keys) == 3
    # the sphere's key is the one it had before profiles (its scene's default)
    assert sphere.cache_request()["scene"]["profile"] == "sphere"
    assert "profile" not in sphere.scene_values() and "profile" not in sphere.sweep().attrs()
    assert cone.sweep().values["profile"] == "cone"
    assert cone.sweep().attrs()["scene_profile"] == "cone"
    assert "profile cone" in cone.title() and "profile" not in sphere.title()
    # the material point is rigid: one map whatever the profile says
    pm = MapRequest(**{**TINY, "model": "point-mass"})
    pm_cone = MapRequest(**{**TINY, "model": "point-mass", "profile": "cone"})
    assert pm.cache_request() == pm_cone.cache_request() and not pm_cone.profiled()
    assert "profile" not in pm_cone.title()


def test_a_cone_map_on_demand_is_the_cones(jobs, gate):
    """Computed end to end: its store names the cone, and its points are
    the cone's runs (the library's compute_point with the request's values)."""
    from vibtrans.maps.sweep import compute_point

    gate.set()
    got = Listener()
    request = MapRequest(**{**TINY, "profile": "cone"})
    jobs.submit("a", request, got)
    done = got.wait()
    assert done.kind == "done", got.kinds()
    assert done.ds.attrs["scene_profile"] == "cone"
    la, lm = request.axes()
    own = compute_point(request.scene_values(), la[0], lm[0], maprequest.CHAOS, request.stop)
    assert done.ds["drift_velocity"].values[0, 0] == own["drift_velocity"]


def test_the_page_says_when_the_map_shown_is_not_the_particles(monkeypatch):
    """The shipped maps are the sphere's: with a cone selected the page says
    so over the map and offers the cone's map on demand; a click on a map
    on demand runs its own particle."""
    e = _explorer(monkeypatch, "profile=cone&la=0.1&lm=0.5")
    o = e.ondemand
    assert o.profile_box.visible and o.profile_note.visible
    assert "This map is the sphere's" in o.profile_note.object
    assert "not the selected cone's" in o.profile_note.object
    assert o.profile_button.label == "Map on demand for cone"
    o.request_for_profile()
    panel = o.map_request_panel
    assert panel.request.profile == "cone" and panel.profile.kind.value == "cone"
    assert panel.request.la_from == pytest.approx(-0.4)  # the scene's neighbourhood
    # the material point is rigid: no warning
    e.state.model = "point-mass"
    assert not o.profile_box.visible
    e.state.model = "deformable"
    assert o.profile_box.visible
    e.state.profile = "power:2"  # the sphere's own law
    assert not o.profile_box.visible
    # a click on a sphere's map on demand runs the sphere, on a cone's the cone
    runs = []
    monkeypatch.setattr(o, "run", lambda: runs.append(e.state.scene().profile))
    e.state.profile = "cone"
    o._on_computed_click(MapRequest(**TINY), 0.0, 0.5)
    o._on_computed_click(MapRequest(**{**TINY, "profile": "flat-sphere:0.5"}), 0.0, 0.5)
    assert runs == ["sphere", "flat-sphere:0.5"]


def test_a_map_on_demand_of_another_scene_says_how_it_differs(monkeypatch):
    """A map on demand stays on screen while the form moves on: its note
    names every value that differs (mu, not only the profile) and says when
    the selected scene lies off the map."""
    e = _explorer(monkeypatch, "la=1.5&lm=1&mu=0.1&profile=flat-sphere:0.5")
    o = e.ondemand
    request = MapRequest(mu=0.1, profile="flat-sphere:0.5", la_from=1.0, la_to=2.0, lm_from=0.5, lm_to=1.5)
    monkeypatch.setattr(o, "_map_shown", (request, None))
    monkeypatch.setattr(e.map_view, "computed", object())  # a map on demand is shown
    o.on_profile()
    assert not o.profile_box.visible  # it is this scene's map
    e.state.param.update(mu=0.3, profile="sphere", log_amplitude=1.7, log_mass=-2.0)
    note = o.profile_note.object
    assert o.profile_box.visible
    assert "of another scene**: mu 0.1 (selected: 0.3)" in note
    assert "flat" in note and "not the selected sphere's" in note
    assert "lies off this map on demand" in note
