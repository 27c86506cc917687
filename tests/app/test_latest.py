"""The latest request wins (app/session/latest.py), without a server: a
newer request cancels the older one, whose result is never shown; results
and failures come at the document's next tick; a coroutine's step raises
Cancelled once its job is replaced."""

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor
from types import SimpleNamespace

import pytest
from asyncutil import until

from vibtrans import Cancelled
from vibtrans_explorer.session.latest import LatestJob, at_next_tick

POOL = ThreadPoolExecutor(max_workers=2)


def _until_cancelled(value, cancel=None):
    if cancel is not None and cancel.wait(10):
        raise Cancelled("cancelled")
    return value


def test_a_newer_request_cancels_the_older_and_only_its_result_is_shown():
    shown, failed = [], []

    async def go():
        work = LatestJob(POOL)
        first = work.start()
        first.submit(_until_cancelled, "first", cancel=first.event)
        work.deliver(first, shown.append, failed.append)
        assert work.running and work.is_latest(first)
        second = work.start()
        second.submit(_until_cancelled, "second")
        work.deliver(second, shown.append, failed.append)
        assert first.event.is_set() and not work.is_latest(first)
        await until(lambda: not work.running)
        # the first's end (its thread done, then every task it left) changes nothing
        await until(lambda: all(f.done() for f in first.futures))
        await asyncio.gather(*(asyncio.all_tasks() - {asyncio.current_task()}))
        assert shown == ["second"] and failed == [] and work.job is second

    asyncio.run(go())


def test_a_cancelled_job_is_forgotten_and_says_nothing():
    shown, failed = [], []

    async def go():
        work = LatestJob(POOL)
        job = work.start()
        job.submit(_until_cancelled, "late", cancel=job.event)
        work.deliver(job, shown.append, failed.append)
        assert work.cancel() is job and job.event.is_set()
        assert work.job is None and not work.running
        await until(lambda: job.finished)
        assert shown == [] and failed == []

    asyncio.run(go())


def test_a_failure_is_delivered_and_ends_the_job():
    shown, failed = [], []

    def broken():
        raise ZeroDivisionError("no")

    async def go():
        work = LatestJob(POOL)
        job = work.start()
        job.submit(broken)
        work.deliver(job, shown.append, failed.append)
        await until(lambda: not work.running)
        assert shown == [] and [type(e) for e in failed] == [ZeroDivisionError]

    asyncio.run(go())


def test_a_coroutines_step_raises_cancelled_once_replaced():
    gate = threading.Event()

    async def go():
        work = LatestJob()  # the event loop's default executor
        job = work.start()
        step = asyncio.ensure_future(job.run(gate.wait, 10))
        await asyncio.sleep(0)
        work.start()
        with pytest.raises(Cancelled):
            await step
        gate.set()
        assert await work.job.run(lambda: 42) == 42

    asyncio.run(go())


def test_the_answer_waits_for_a_served_documents_next_tick():
    ticks, said = [], []
    served = SimpleNamespace(session_context=object(), add_next_tick_callback=ticks.append)
    at_next_tick(served, lambda: said.append("served"))
    assert said == [] and len(ticks) == 1
    ticks.pop()()
    at_next_tick(None, lambda: said.append("no server"))
    assert said == ["served", "no server"]
