"""What one session costs the server's CPU, phase by phase.

    python -m devtools.sessioncpu [--sessions 10] [--clicks 1] [--idle 10]
                                  [--log-level debug|info] [--py-spy PATH] [--json]

Starts `vibtrans serve` (the load test's settings) and drives protocol
sessions (devtools/protoclient.py) one at a time through each phase: the
server's CPU (event loop apart from its other threads, less its idle rate)
from a mark until its CPU clock stands still is that phase's: `get`,
`pull_doc`, `ready`, idle per open session, `first click`, `click`, `close`.
`--py-spy PATH`: the server under py-spy, its samples counted by
PROFILE_PARTS.
"""

import argparse
import asyncio
import json
import os
import re
import signal
import statistics
import subprocess
import sys
import time

import psutil

from vibtrans_explorer.server.memory import CLOSED, RELEASED

from . import results
from .loadtest import SERVE_ARGS, _range_points
from .protoclient import ProtocolSession
from .server import Server, tree

QUIET_S = 0.3  # the server's CPU clock unchanged this long: quiet


def thread_cpu(pid):
    """CPU seconds so far of the process's main thread (the event loop) and
    of its other threads (those that ended too)."""
    p = psutil.Process(pid)
    main = sum(next((t[1:] for t in p.threads() if t.id == pid), (0, 0)))
    return main, sum(p.cpu_times()[:2]) - main


class _Session(ProtocolSession):
    """A protocol session whose opening is marked in phases (`marks(phase)`)."""

    def __init__(self, url, marks, **kw):
        super().__init__(url, **kw)
        self.marks = marks

    async def open(self):
        page = await self._get()
        await self.marks("get")
        await self._connect(page)
        await self.marks("pull_doc")
        self._listen()


async def _quiet(pid, timeout=10.0):
    """Wait until the server's CPU clock stands still for QUIET_S; the seconds waited."""
    t0 = time.perf_counter()
    last, still = sum(thread_cpu(pid)), time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        await asyncio.sleep(0.05)
        now = sum(thread_cpu(pid))
        if now != last:
            last, still = now, time.perf_counter()
        elif time.perf_counter() - still >= QUIET_S:
            break
    return time.perf_counter() - t0


class Meter:
    """The server's CPU between marks, by phase, less its idle rate."""

    def __init__(self, pid, idle_rate):
        self.pid, self.idle_rate = pid, idle_rate
        self.phases = {}
        self.at = (time.perf_counter(), *thread_cpu(pid))

    def reset(self):
        self.at = (time.perf_counter(), *thread_cpu(self.pid))

    async def mark(self, phase):
        await _quiet(self.pid)
        t, main, other = time.perf_counter(), *thread_cpu(self.pid)
        t0, main0, other0 = self.at
        idle = self.idle_rate * (t - t0)
        self.phases.setdefault(phase, []).append((main - main0 - idle, other - other0))
        self.reset()


def _release_seen(text, closes):
    """Whether the log shows `closes` sessions closed and a release after the last."""
    found = [m.start() for m in re.finditer(CLOSED, text)]
    return len(found) >= closes and text.rfind(RELEASED) > found[closes - 1]


async def _drive(server, pid, a, idle_rate, out):
    meter = Meter(pid, idle_rate)
    sessions = []
    for _ in range(a.sessions):
        s = _Session(server.url, meter.mark, timeout=120.0)
        meter.reset()
        await s.open()
        s.announce()
        await meter.mark("ready")
        sessions.append(s)
    out["bytes"] = {
        kind: statistics.median(s.bytes.get(kind, 0) for s in sessions)
        for kind in ("html", "PULL-DOC-REPLY", "PATCH-DOC")
    }
    meter.reset()
    t0 = time.perf_counter()
    await asyncio.sleep(a.idle)
    main, other = thread_cpu(pid)
    dt = time.perf_counter() - t0
    main0, other0 = meter.at[1:]
    out["idle_open"] = {
        "seconds": dt,
        "sessions": a.sessions,
        "main_per_session_s": (main - main0 - idle_rate * dt) / dt / a.sessions,
        "other_per_session_s": (other - other0) / dt / a.sessions,
    }
    meter.reset()
    for c in range(a.clicks):
        for k, s in enumerate(sessions):
            fx, fy = _range_points(k + 100, a.clicks)[c]
            meter.reset()
            status, text = await s.click(fx, fy)
            if status != "done":
                out.setdefault("errors", []).append(f"session {k}, click {c + 1}: {text[:200]}")
            await meter.mark("click" if c else "first click")
    closes_before = server.text().count(CLOSED)
    meter.reset()
    for s in sessions:
        s.close()
    t0 = time.perf_counter()
    while not _release_seen(server.text(), closes_before + a.sessions):
        if time.perf_counter() - t0 > 60:
            out.setdefault("errors", []).append("the sessions' release was not logged in 60 s")
            break
        await asyncio.sleep(0.2)
    await meter.mark("close")
    out["close_wait_s"] = time.perf_counter() - t0
    return meter.phases


# py-spy's samples by what the server did: the first rule whose keys a frame
# names (inner parts of a phase first: the page function is inside the GET)
PROFILE_PARTS = [
    ("warm-up (kernels, maps' pre-render)", ("prerender", "app/server/warmup.py", "_find_and_load")),
    ("GET: the page function (serve_page)", ("_first_page.<locals>.page",)),
    ("GET: Bokeh's document checks", ("Document.validate", "check_integrity")),
    ("GET: the rest (session, HTML)", ("DocHandler.get",)),
    ("pull-doc", ("ServerSession._handle_pull",)),
    ("click: the run's figures built (first run)", ("TrajectoryView.view",)),
    ("click: the rest of the tap", ("MapView._on_tap",)),
    ("the browser's patches (sizes, document_ready, onload)", ("ServerSession._handle_patch",)),
    ("after a run: its results shown", ("RunController.finish",)),
    ("close: the explorer's release (full collection)", ("app/server/memory.py",)),
    ("close: Bokeh's discard, Panel's cleanup", ("_discard_session", "on_session_destroyed")),
]


def profile_parts(path):
    """{(thread, part): samples} of a py-spy raw profile (thread "event loop" or "other")."""
    out = {}
    with open(path) as f:
        for line in f:
            if not line.strip():
                continue
            stack, count = line.rsplit(" ", 1)
            frames = stack.split(";")
            thread = "other" if frames[0].startswith("Thread._bootstrap") else "event loop"
            part = next(
                (name for name, keys in PROFILE_PARTS if any(k in fr for fr in frames for k in keys)), "rest"
            )
            out[thread, part] = out.get((thread, part), 0) + int(count)
    return out


def _server_python(server):
    """The server's Python process (under py-spy: its child)."""
    for q in tree(server.proc.pid):
        try:
            args = psutil.Process(q).cmdline()
        except psutil.Error:
            continue
        if "vibtrans.cli" in args and not args[0].endswith("py-spy"):
            return q
    return server.proc.pid


def run(a):
    env = {"BOKEH_PY_LOG_LEVEL": a.log_level, "PYTHONMALLOC": "malloc"}
    wrap = ()
    if a.py_spy:
        wrap = (a.py_spy_bin, "record", "-r", "100", "-f", "raw", "-o", a.py_spy, "--")
    server = Server(SERVE_ARGS, env=env, wrap=wrap)
    out = {
        "command": "python -m devtools.sessioncpu " + " ".join(a.argv),
        "load_average_before": [round(x, 2) for x in os.getloadavg()],
        "log_level": a.log_level,
    }
    try:
        server.wait_ready()
        pid = _server_python(server)
        asyncio.run(_quiet(pid, timeout=60.0))  # the maps' pre-render
        c0, t0 = sum(thread_cpu(pid)), time.perf_counter()
        time.sleep(a.idle)
        idle_rate = (sum(thread_cpu(pid)) - c0) / (time.perf_counter() - t0)
        out["idle_no_session_cpu_per_s"] = idle_rate
        phases = asyncio.run(_drive(server, pid, a, idle_rate, out))
        out["phases"] = {
            name: {
                "n": len(v),
                "main_median_s": statistics.median(m for m, _ in v),
                "main_mean_s": statistics.fmean(m for m, _ in v),
                "other_mean_s": statistics.fmean(o for _, o in v),
            }
            for name, v in phases.items()
        }
        # the close phase is one mark for every session: per session
        close = out["phases"].get("close")
        if close:
            for key in ("main_median_s", "main_mean_s", "other_mean_s"):
                close[key] /= a.sessions
            close["n"] = a.sessions
        out["server_errors"] = server.errors()[0]
    finally:
        if a.py_spy:
            try:
                os.kill(_server_python(server), signal.SIGINT)
                server.proc.wait(60)
            except (OSError, subprocess.TimeoutExpired):
                pass
        server.stop()
        server.remove_logs()
    out["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
    return out


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(prog="python -m devtools.sessioncpu", description=__doc__.splitlines()[0])
    ap.add_argument("--sessions", type=results.bounded(int, 1, 60), default=10, help="sessions")
    ap.add_argument("--clicks", type=results.bounded(int, 0, 10), default=1, help="clicks per session")
    ap.add_argument(
        "--idle", type=results.bounded(float, 1, 120), default=10.0, help="seconds of the idle phases"
    )
    ap.add_argument(
        "--log-level",
        default="debug",
        choices=("debug", "info"),
        help="the server's Bokeh log level (the load test's: debug)",
    )
    ap.add_argument(
        "--py-spy", default=None, metavar="PATH", help="run the server under py-spy, its raw profile to PATH"
    )
    ap.add_argument("--py-spy-bin", default="py-spy", help="the py-spy executable")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    results.add_option(ap)
    a = ap.parse_args(argv)
    a.argv = argv
    begun = results.begin()
    out = run(a)
    if a.py_spy:
        parts = profile_parts(a.py_spy)
        out["profile_samples"] = {f"{t}: {p}": n for (t, p), n in parts.items()}
    results.save("sessioncpu", out, begun, a.results_dir, " ".join(["python -m devtools.sessioncpu", *argv]))
    if a.json:
        print(json.dumps(out))
    else:
        print(f"server idle, no session: {out['idle_no_session_cpu_per_s'] * 1000:.2f} ms CPU/s")
        print(f"{'phase':>10} {'n':>4} {'event loop ms (median/mean)':>30} {'other threads ms':>17}")
        for name, p in out["phases"].items():
            print(
                f"{name:>10} {p['n']:>4} {p['main_median_s'] * 1000:>14.1f} / "
                f"{p['main_mean_s'] * 1000:<13.1f} {p['other_mean_s'] * 1000:>17.1f}"
            )
        io = out["idle_open"]
        print(
            f"idle with {io['sessions']} open: {io['main_per_session_s'] * 1000:.3f} ms/s "
            f"(event loop) + {io['other_per_session_s'] * 1000:.3f} ms/s (others) per session"
        )
        print(f"bytes per page (median): {out['bytes']}")
        samples = out.get("profile_samples", {})
        if samples:
            total = sum(samples.values())
            print(
                f"py-spy samples of the server ({total} in all, warm-up included; the "
                f"other threads' include waits py-spy took for work: their CPU is the "
                f"table's, from /proc):"
            )
            for name, n in sorted(samples.items(), key=lambda kv: -kv[1]):
                print(f"  {n:6d} {100 * n / total:5.1f}%  {name}")
        for e in out.get("errors", []) + out.get("server_errors", []):
            print("ERROR:", e)
    return out


if __name__ == "__main__":
    main()
