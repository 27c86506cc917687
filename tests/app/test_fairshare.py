"""app/server/fairshare.py: the server's workers shared between maps in turn."""

import threading

import pytest

from vibtrans_explorer.server.fairshare import FairPool


def _blocked_pool():
    """A one-worker pool whose worker is held by a task of lane `first`
    until `gate` is set."""
    pool = FairPool(1)
    first, second = pool.lane(), pool.lane()
    gate, holding = threading.Event(), threading.Event()

    def hold():
        holding.set()
        assert gate.wait(30)

    held = first.submit(hold)
    assert holding.wait(30)
    return pool, first, second, gate, held


def test_lanes_take_turns_so_a_later_lane_is_not_starved():
    pool, big, small, gate, held = _blocked_pool()
    order = []
    big_tasks = [big.submit(order.append, f"big{k}") for k in range(9)]
    small_tasks = [small.submit(order.append, f"small{k}") for k in range(3)]
    gate.set()
    for f in [held, *big_tasks, *small_tasks]:
        f.result(timeout=30)
    # first come, first served would run the 9 big tasks first
    assert order.index("small2") < order.index("big3"), order
    assert [t for t in order if t.startswith("big")] == [f"big{k}" for k in range(9)]


def test_a_failing_task_reaches_its_future_and_the_worker_goes_on():
    pool = FairPool(1)
    lane = pool.lane()

    def fail():
        raise ValueError("a point failed")

    bad = lane.submit(fail)
    good = lane.submit(lambda: 42)
    with pytest.raises(ValueError, match="a point failed"):
        bad.result(timeout=30)
    assert good.result(timeout=30) == 42


def test_shutting_a_lane_down_cancels_its_waiting_tasks_only():
    pool, first, second, gate, held = _blocked_pool()
    dropped = [first.submit(lambda: "dropped") for _ in range(3)]
    kept = second.submit(lambda: "kept")
    first.shutdown()
    gate.set()
    assert kept.result(timeout=30) == "kept"
    assert held.result(timeout=30) is None
    assert all(f.cancelled() for f in dropped)
    with pytest.raises(RuntimeError, match="shut down"):
        first.submit(lambda: None)
    assert first not in pool.queued()


def test_a_pool_needs_a_worker():
    with pytest.raises(ValueError, match="workers must be >= 1"):
        FairPool(0)


def test_the_workers_run_at_the_niceness_asked_for():
    """Map workers yield a shared core to the server's other threads."""
    import os

    pool = FairPool(1, nice=7)
    lane = pool.lane()
    here = os.getpriority(os.PRIO_PROCESS, 0)
    got = lane.submit(lambda: os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
    assert got.result(timeout=30) == min(19, here + 7)
    assert os.getpriority(os.PRIO_PROCESS, 0) == here  # this thread unchanged


def test_the_sessions_runs_yield_to_the_event_loop_and_maps_to_them():
    """controller.RUNNER's threads run at RUN_NICE (the event loop, one
    thread for every session's pages and figures, comes first on a shared
    core), the maps' workers nicer still."""
    import os

    from vibtrans_explorer.server.mapjobs import MAP_NICE
    from vibtrans_explorer.session.controller import RUN_NICE, RUNNER

    here = os.getpriority(os.PRIO_PROCESS, 0)
    got = RUNNER.submit(lambda: os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
    assert got.result(timeout=30) == min(19, here + RUN_NICE)
    assert 0 < RUN_NICE < MAP_NICE


def _process_facts(value):
    """A task for a worker process: its pid, niceness and an echo."""
    import os

    return os.getpid(), os.getpriority(os.PRIO_PROCESS, 0), value


def _fail_in_process():
    raise ValueError("a point failed in its process")


def test_process_workers_run_the_tasks_elsewhere_and_stop_when_idle():
    """With processes=True the tasks run in worker processes (niced, the
    calling process's Python free for its event loop), which stop once no
    lane is left and start again for the next task."""
    import os

    here = os.getpriority(os.PRIO_PROCESS, 0)
    pool = FairPool(1, nice=3, processes=True)
    lane = pool.lane()
    pid, nice, echo = lane.submit(_process_facts, "point").result(timeout=120)
    assert pid != os.getpid() and echo == "point"
    assert nice == min(19, here + 3)
    with pytest.raises(ValueError, match="failed in its process"):
        lane.submit(_fail_in_process).result(timeout=120)
    assert lane.submit(_process_facts, 2).result(timeout=120)[2] == 2  # the worker goes on
    assert pool.processes_up()
    lane.shutdown()
    assert _soon(lambda: not pool.processes_up())  # no lane, no task: the memory goes back
    again = pool.lane()
    pid2, _, _ = again.submit(_process_facts, None).result(timeout=120)
    assert pid2 not in (pid, os.getpid())
    again.shutdown()
    assert _soon(lambda: not pool.processes_up())


def test_process_workers_stay_while_a_task_of_a_shut_lane_runs():
    """A lane shut down while its task runs in a process: the task ends
    with its result, then the processes stop."""
    import multiprocessing

    pool = FairPool(1, processes=True)
    lane, other = pool.lane(), pool.lane()
    assert lane.submit(_process_facts, 0).result(timeout=120)  # processes up
    with multiprocessing.Manager() as manager:
        gate = manager.Event()  # the task runs until it is set
        running = lane.submit(_wait_then, gate, "done")
        assert _soon(running.running)
        lane.shutdown()
        other.shutdown()
        assert pool.processes_up()  # its task still runs there
        gate.set()
        assert running.result(timeout=120) == "done"
    assert _soon(lambda: not pool.processes_up())


def test_process_workers_linger_for_the_next_map_then_stop():
    """With `linger`, the processes outlive the last lane that long: a map
    asked for meanwhile runs in the same processes (no new start), and the
    spell is counted from the last lane's end; `stop_processes` ends it
    at once, not while a lane is open."""
    import time

    linger = 3.0
    pool = FairPool(1, processes=True, linger=linger)
    # a second pool whose linger starts with the first lane's end: its stop
    # says when a spell counted from that end is over
    clock = FairPool(1, processes=True, linger=linger)
    lane, clock_lane = pool.lane(), clock.lane()
    pid = lane.submit(_process_facts, 0).result(timeout=120)[0]
    clock_lane.submit(_process_facts, 0).result(timeout=120)
    lane.shutdown()
    clock_lane.shutdown()
    lane = pool.lane()
    assert lane.submit(_process_facts, 1).result(timeout=120)[0] == pid  # the same worker
    assert _soon(lambda: not clock.processes_up())  # a spell from the first lane's end is over
    assert pool.processes_up()  # ... the lane open since keeps them
    lane.shutdown()
    last = time.monotonic()
    assert pool.processes_up()
    assert _soon(lambda: not pool.processes_up())  # 3 s after the last lane
    assert time.monotonic() - last >= 0.9 * linger, time.monotonic() - last
    lane = pool.lane()
    assert lane.submit(_process_facts, 2).result(timeout=120)[0] != pid
    assert not pool.stop_processes() and pool.processes_up()  # a lane is open
    lane.shutdown()
    assert pool.stop_processes() and not pool.processes_up()


def _wait_then(gate, value):
    assert gate.wait(120)
    return value


def _soon(condition, seconds=30.0):
    """Whether `condition()` holds within `seconds` (a worker thread's
    bookkeeping follows the result it hands over)."""
    from asyncutil import wait_until

    try:
        wait_until(condition, seconds, every=0.01)
    except AssertionError:
        return False
    return True
