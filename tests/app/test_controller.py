"""The run controller without a server or widgets (app/session/controller.py): a
stand-in simulate, asyncio.run, and the parameters the page shows.  The
controller makes the runs testable without Panel."""

import asyncio
import threading

import pytest
from asyncutil import until

from vibtrans import Cancelled, simulate
from vibtrans_explorer.session.controller import TWIN_LABEL, RunController, comparison
from vibtrans_explorer.session.state import ExplorerState


def _state(**values):
    s = ExplorerState()
    s.param.update(**{"fidelity": "preview", "compare": "none", **values})
    return s


def _recorder(controller):
    seen = []
    controller.param.watch(
        lambda *events: seen.extend((e.name, e.new) for e in events), ["status", "busy", "message", "result"]
    )
    return seen


def test_a_run_publishes_its_result_once():
    c = RunController(_state())
    seen = _recorder(c)
    asyncio.run(c.run())
    r = c.result
    assert r is not None and c.job is None and c.message == ""
    assert r.scene.values() == c.state.scene().values() and r.other is None and r.label is None
    assert r.summary.model == "deformable" and r.ds.attrs["model"] == "deformable"
    assert [n for n, _ in seen].count("result") == 1 and not c.busy


def test_a_slow_run_is_busy_with_progress_then_idle():
    gate = threading.Event()

    def slow(scene, progress=None, **kwargs):
        if progress is not None:
            progress(0.5)
        gate.wait(10)
        return simulate(scene, **kwargs)

    async def go():
        c = RunController(_state(), simulate=slow)
        c.start()
        await until(lambda: c.busy)
        assert c.progress == 0.5 and c.status.startswith("Running deformable at A* = ")
        gate.set()
        await until(lambda: c.result is not None)
        assert not c.busy and c.status == ""

    asyncio.run(go())


def test_a_run_whose_kernel_compiles_says_compiling_until_its_progress_moves():
    """A tip or a rolling particle run for the first time compiles its
    kernel, its progress at 0 meanwhile: the status says "Compiling", then
    "Running" once the kernel reports progress.  numba's own compile event
    stands in for a compile (a real one would depend on the cache)."""
    from numba.core import event

    from vibtrans.core.kernels import contact

    compiled, gate = threading.Event(), threading.Event()

    class Dispatcher:  # what numba's event carries: the function compiled
        py_func = contact.tangential_force_history

    def compiling(scene, progress=None, **kwargs):
        with event.trigger_event("numba:compile", data={"dispatcher": Dispatcher()}):
            compiled.wait(10)
        if progress is not None:
            progress(0.25)
        gate.wait(10)
        return simulate(scene, **kwargs)

    async def go():
        c = RunController(_state(), simulate=compiling)
        c.start()
        await until(lambda: c.busy)
        assert c.status.startswith("Compiling the kernels of this scene") and c.progress == 0
        compiled.set()
        await until(lambda: c.progress == 0.25)
        await until(lambda: c.status.startswith("Running deformable at A* = "))
        gate.set()
        await until(lambda: c.result is not None)

    asyncio.run(go())


def test_the_comparison_runs_beside_and_is_labelled():
    c = RunController(_state(compare="point mass"))
    asyncio.run(c.run())
    r = c.result
    assert r.label == "point mass" and r.other.attrs["model"] == "point-mass"
    assert r.twin is None  # a comparison model is no tau twin
    assert comparison(c.state.scene(), "tau twin")[1] == TWIN_LABEL


def test_refusals_and_the_step_budget_are_messages_and_run_nothing():
    calls = []
    c = RunController(
        _state(), simulate=lambda *a, **k: calls.append(a), refusals=lambda: ["log10 A* must be ..."]
    )
    assert c.start() is None and c.message == "Not run: log10 A* must be ..."
    c.refusals, c.max_steps = list, 10
    assert c.start() is None and "over this server's limit of 10" in c.message
    assert not calls and c.job is None


def test_cancel_says_so_and_a_replaced_run_is_silent():
    started = threading.Event()

    def until_cancelled(scene, cancel=None, **kwargs):
        started.set()
        cancel.wait()
        raise Cancelled("cancelled")

    async def go():
        c = RunController(_state(), simulate=until_cancelled)
        c.start()
        await until(started.is_set)
        c.cancel()
        await until(lambda: c.job is None)
        assert c.status == "Run cancelled." and c.result is None
        started.clear()
        first = c.start()
        await until(started.is_set)
        c.simulate = simulate
        second = c.start()  # replaces the first: no word of it
        assert first.event.is_set() and c.job is second
        await until(lambda: c.result is not None)
        assert c.status == "" and c.message == ""

    asyncio.run(go())


@pytest.mark.parametrize("error, words", [(RuntimeError("boom"), "The run failed: RuntimeError: boom")])
def test_a_failed_run_is_a_message(error, words):
    def broken(*a, **k):
        raise error

    c = RunController(_state(), simulate=broken)
    asyncio.run(c.run())
    assert c.message == words and c.result is None and c.job is None
