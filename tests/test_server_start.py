"""`vibtrans serve`'s start (app/server.py, app/kernels.py): it says what it
does on stderr, serves pages while the kernels compile in a background
thread, and a run asked for before they are ready waits with a message in
the page (then runs, or is cancelled)."""
import asyncio
import re
import threading

import pytest

import vibtrans
from vibtrans import Cancelled
from asyncutil import until
from vibtrans_explorer import explorer as E
from vibtrans_explorer import kernels
from budget import budget


@pytest.fixture
def compiling(monkeypatch):
    """The kernels as at a cold start: a warm-up under way, 1 of 4 kernels ready."""
    monkeypatch.setattr(kernels, "READY", threading.Event())
    monkeypatch.setattr(kernels, "_thread", object())
    monkeypatch.setattr(kernels, "_state", dict(kernels._state, done=1, total=4,
                                                label="deformable, ab4"))
    return kernels.READY


def _explorer():
    ex = E.Explorer()
    ex.state.param.update(fidelity="preview", compare="none")
    return ex


def test_a_run_before_the_kernels_are_ready_waits_with_a_message(compiling, monkeypatch):
    calls = []

    def recorded(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)
    real = E.simulate

    async def go():
        ex = _explorer()
        monkeypatch.setattr(ex.controller, "simulate", recorded)
        ex.start_run()
        await until(lambda: "Compiling the simulation kernels" in ex.summary.object)
        assert "(1 of 4 ready)" in ex.summary.object, ex.summary.object
        assert ex.progress.visible and not ex.cancel_button.disabled
        await asyncio.sleep(0.5)
        assert not calls                       # the run waits for the kernels
        compiling.set()
        await until(lambda: ex.controller.job is None and "drift <v*>" in ex.summary.object)
        assert len(calls) == 1
    asyncio.run(go())


def test_a_waiting_run_can_be_cancelled(compiling):
    async def go():
        ex = _explorer()
        job = ex.start_run()
        await until(lambda: "Compiling the simulation kernels" in ex.summary.object)
        ex._on_cancel(None)
        await until(lambda: ex.controller.job is None)
        assert ex.summary.object == "Run cancelled."
        with pytest.raises(Cancelled):
            job.futures[0].result(timeout=budget(5))
    asyncio.run(go())


def test_outside_vibtrans_serve_runs_do_not_wait():
    # no warm-up started in this process (panel serve app/explorer.py, tests)
    assert kernels._thread is None and kernels.ready() and kernels.status() is None


def test_compile_all_reports_each_step(monkeypatch):
    seen = {}

    def warmup(models=None, progress=None):
        seen["models"] = models
        for k, label in enumerate(("deformable kernel", "point-mass kernel"), 1):
            progress(k, 2, label)
    monkeypatch.setattr(vibtrans, "warmup", warmup)
    monkeypatch.setattr(kernels, "READY", threading.Event())
    lines = []
    kernels.compile_all(lines.append)
    assert kernels.READY.is_set()
    assert lines[0].startswith("compiling the kernels in the background")
    steps = [re.sub(r", [0-9.]+ s$", "", ln) for ln in lines[1:-1]]
    assert seen["models"] == kernels.MODELS
    assert steps == ["kernels 1/2 ready (deformable kernel)",
                     "kernels 2/2 ready (point-mass kernel)"]
    assert lines[-1].startswith("kernels ready in ")


def test_a_failed_warm_up_still_lets_runs_start(monkeypatch):
    def warmup(models=None, progress=None):
        raise RuntimeError("boom")
    monkeypatch.setattr(vibtrans, "warmup", warmup)
    monkeypatch.setattr(kernels, "READY", threading.Event())
    lines = []
    kernels.compile_all(lines.append)
    assert kernels.READY.is_set()
    assert "warm-up failed: RuntimeError: boom" in lines[-1]


def test_the_server_says_what_it_does(served_explorer):
    # "vibtrans serve: [12.3 s] what": seconds since the command started
    lines = [re.sub(r"^\[[0-9.]+ s\] ", "", ln[len("vibtrans serve: "):])
             for ln in served_explorer.text().splitlines() if ln.startswith("vibtrans serve:")]
    assert "drift maps and the vertical curve checked in" in lines[0], lines
    assert any(ln.startswith("explorer on http://127.0.0.1:") for ln in lines), lines
    assert any(ln.startswith("compiling the kernels") for ln in lines), lines
    assert any(ln.startswith("kernels 1/") for ln in lines), lines
    assert lines[-1].startswith("kernels ready in "), lines
