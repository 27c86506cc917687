"""`vibtrans serve`'s start (app/server/serve.py, app/server/warmup.py): it says what it
does on stderr, serves pages while the kernels compile in a background
thread, and a run asked for before they are ready waits with a message in
the page (then runs, or is cancelled)."""

import asyncio
import re
import threading

import pytest
from asyncutil import until, wait_until
from budget import budget

import vibtrans
from vibtrans import Cancelled
from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import warmup


@pytest.fixture
def compiling(monkeypatch):
    """The kernels as at a cold start: a warm-up under way, 1 of 4 kernels ready."""
    monkeypatch.setattr(warmup, "READY", threading.Event())
    monkeypatch.setattr(warmup, "_thread", object())
    monkeypatch.setattr(warmup, "_state", dict(warmup._state, done=1, total=4, label="deformable, ab4"))
    return warmup.READY


def _explorer():
    ex = E.Explorer()
    ex.state.param.update(fidelity="preview", compare="none")
    return ex


def test_a_run_before_the_kernels_are_ready_waits_with_a_message(compiling, monkeypatch):
    calls, waiting = [], threading.Event()

    def recorded(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)

    real = E.simulate

    def wait(cancel=None, scene=None):  # the run's thread waiting for the kernels
        waiting.set()
        return real_wait(cancel, scene)

    real_wait = warmup.wait
    monkeypatch.setattr(warmup, "wait", wait)

    async def go():
        ex = _explorer()
        monkeypatch.setattr(ex.controller, "simulate", recorded)
        ex.start_run()
        await until(lambda: "Compiling the simulation kernels" in ex.summary_view.pane.object)
        assert "(1 of 4 ready)" in ex.summary_view.pane.object, ex.summary_view.pane.object
        assert ex.run_buttons.progress.visible and not ex.run_buttons.cancel_button.disabled
        await until(waiting.is_set)  # its thread waits (simulate comes after)
        assert not calls  # the run waits for the kernels
        compiling.set()
        await until(lambda: ex.controller.job is None and "drift <v*>" in ex.summary_view.pane.object)
        assert len(calls) == 1

    asyncio.run(go())


def test_a_waiting_run_can_be_cancelled(compiling):
    async def go():
        ex = _explorer()
        job = ex.start_run()
        await until(lambda: "Compiling the simulation kernels" in ex.summary_view.pane.object)
        ex.run_buttons.cancel_button.clicks += 1
        await until(lambda: ex.controller.job is None)
        assert ex.summary_view.pane.object == "Run cancelled."
        with pytest.raises(Cancelled):
            job.futures[0].result(timeout=budget(5))

    asyncio.run(go())


def test_outside_vibtrans_serve_runs_do_not_wait():
    # no warm-up started in this process (panel serve app/explorer.py, tests)
    assert warmup._thread is None and warmup.ready() and warmup.status() is None


def test_compile_all_reports_each_step(monkeypatch):
    seen = {}

    def fake_warmup(models=None, progress=None):
        seen["models"] = models
        for k, label in enumerate(("deformable kernel", "point-mass kernel"), 1):
            progress(k, 2, label)

    monkeypatch.setattr(vibtrans, "warmup", fake_warmup)
    monkeypatch.setattr(warmup, "READY", threading.Event())
    lines = []
    warmup.compile_all(lines.append)
    assert warmup.READY.is_set()
    assert lines[0].startswith("compiling the kernels in the background")
    steps = [re.sub(r", [0-9.]+ s$", "", ln) for ln in lines[1:-1]]
    assert seen["models"] == warmup.MODELS
    assert steps == ["kernels 1/2 ready (deformable kernel)", "kernels 2/2 ready (point-mass kernel)"]
    assert lines[-1].startswith("kernels ready in ")


def test_a_failed_warm_up_still_lets_runs_start(monkeypatch):
    def fake_warmup(models=None, progress=None):
        raise RuntimeError("boom")

    monkeypatch.setattr(vibtrans, "warmup", fake_warmup)
    monkeypatch.setattr(warmup, "READY", threading.Event())
    lines = []
    warmup.compile_all(lines.append)
    assert warmup.READY.is_set()
    assert "warm-up failed: RuntimeError: boom" in lines[-1]


def test_the_server_says_what_it_does(served_explorer):
    # "vibtrans serve: [12.3 s] what": seconds since the command started
    lines = [
        re.sub(r"^\[[0-9.]+ s\] ", "", ln[len("vibtrans serve: ") :])
        for ln in served_explorer.text().splitlines()
        if ln.startswith("vibtrans serve:")
    ]
    assert "drift maps and the vertical curve checked in" in lines[0], lines
    assert any(ln.startswith("explorer on http://127.0.0.1:") for ln in lines), lines
    assert any(ln.startswith("compiling the kernels") for ln in lines), lines
    assert any(ln.startswith("kernels 1/") for ln in lines), lines
    # then "kernels ready" (a session's rolling particle may add its own line later)
    ready = [k for k, ln in enumerate(lines) if ln.startswith("kernels ready in ")]
    first = min(k for k, ln in enumerate(lines) if ln.startswith("kernels 1/"))
    assert len(ready) == 1 and ready[0] > first, lines


@pytest.mark.server
@pytest.mark.slow
def test_num_procs_2_forks_two_servers_that_each_warm_up_and_serve():
    """`vibtrans serve --num-procs 2`: Bokeh's own multi-process serving
    (Tornado forks after the maps are checked): each process says it is
    listening and warms its kernels up, and visitors' pages load and their
    websocket sessions answer a click (devtools/protoclient.py, as the load
    test's sessions); stopping the server's process tree ends them all."""
    import os
    import signal
    from pathlib import Path

    from conftest import SERVER_ENV, SERVER_ENV_UNSET
    from netutil import Served

    from devtools.protoclient import ProtocolSession
    from devtools.server import pid_alive, tree

    root = Path(__file__).resolve().parents[2]
    env = {k: v for k, v in os.environ.items() if k not in SERVER_ENV_UNSET}
    served = Served(env={**env, **SERVER_ENV}, cwd=root, args=("--num-procs", "2"))
    try:
        served.wait_page()

        def both_ready():
            assert served.proc.poll() is None, served.text()[-4000:]
            return served.text().count("kernels ready in") >= 2

        wait_until(both_ready, 600, "both processes' kernels")
        text = served.text()
        for k in (1, 2):
            assert f"process {k}/2: explorer on http://" in text, text[-4000:]
            assert f"process {k}/2: kernels ready in" in text, text[-4000:]
        servers = [
            p
            for p in tree(served.proc.pid)
            if b"vibtrans.cli\x00serve" in Path(f"/proc/{p}/cmdline").read_bytes()
        ]
        assert len(servers) == 3  # the parent and the two it forked

        async def visit():
            s = ProtocolSession(served.url, timeout=180.0)
            try:
                await s.open()
                return (await s.click(0.55, 0.5))[0]
            finally:
                s.close()

        assert [asyncio.run(visit()) for _ in range(4)] == ["done"] * 4
    finally:
        pids = tree(served.proc.pid)
        served.stop()  # the parent first: Tornado's would restart a stopped child
        for pid in pids[1:]:
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        wait_until(lambda: not any(pid_alive(p) for p in pids), 30, "every process ended")
        assert not any(pid_alive(p) for p in pids)


def test_a_port_in_use_is_a_message_naming_it_not_a_traceback():
    """`vibtrans serve --port P` with P held by another process: one line
    naming the port and what to do, exit status 2, no traceback (it was
    tornado's OSError)."""
    import os
    import socket
    import subprocess
    import sys
    from pathlib import Path

    held = socket.socket()
    held.bind(("localhost", 0))
    held.listen()
    port = held.getsockname()[1]
    try:
        r = subprocess.run(
            [sys.executable, "-m", "vibtrans.cli", "serve", "--port", str(port)],
            cwd=Path(__file__).resolve().parents[2],
            capture_output=True,
            text=True,
            timeout=budget(120),
            env={k: v for k, v in os.environ.items() if k != "PYTHONMALLOC"},
        )
    finally:
        held.close()
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    assert f"--port {port}: cannot listen on 127.0.0.1:{port}" in r.stderr, r.stderr
    assert "choose another port" in r.stderr
