"""Load test of the explorer server: many concurrent sessions.

    python -m devtools.loadtest --sessions 30 --clicks 5 [--browsers 2] [--think 10] [--json]

Starts `vibtrans serve` on a free loopback port (`--num-procs` processes),
then starts `--sessions` sessions over `--ramp` seconds.  Each session
loads the page, then clicks `--clicks` different points on the map, each
time waiting until that click's run is shown, with a think time of
`--think` seconds (+-50%, random) between clicks, as a person reading the
result would.

Two kinds of session, mixed in one run:
* `--browsers` of them are real pages in one headless chromium (Debian's
  /usr/bin/chromium driven by Playwright; its processes niced,
  --browser-nice, so that the server they measure comes first): click to
  plot drawn, as a person sees it (including drawing on this machine);
* the others are protocol sessions (devtools/protoclient.py): the same messages
  over the same websocket as the page (recorded from chromium), without
  drawing: click to the server's reply carrying the run's data and
  summary.  Thirty people bring thirty computers to draw on; thirty
  chromium renderers on the server's own 2 cores would measure the
  browsers, not the server.

Measured: click latency p50/p95/max over all clicks and per kind; errors
(pages that fail to load, clicks with no result within --click-timeout,
runs that fail, JavaScript errors in a page, tracebacks in the server's
log); the server's RSS (its process tree, from /proc) at ready, after a
warm-up session is closed and dropped (the baseline), the peak while the
sessions run (sampled every 0.2 s), and after every session is closed and
Bokeh has dropped them (counted from its debug log: "Discarding session";
the server runs with --unused-session-lifetime 3000
--check-unused-sessions 1000 so that this takes seconds, not the default
~30 s) and the explorer has released their memory (its log line, which
comes ~2 s after the last discard).  Goals: p95 <= 3 s, 0 errors, and the
RSS after within 10% of the baseline.  Runs the server refuses as over its step cap
(VIBTRANS_MAX_STEPS) are counted apart ("refused"), not as errors.  Also
the CPU seconds the server used during the load (`server_cpu_s`, from
/proc): two runs of the same code doing the same work should use about the
same; a run that used several times as much ran on a slower machine (a
virtual machine's host taking time from its core).

Pinning (`--pin`, or `--pin-server CPUS --pin-clients CPUS`, CPUS as
taskset's lists: 0 / 0,2 / 0-3): the server's processes run on some cores
(started through `taskset -c`), the clients (this process, its threads and
the chromium it starts) on others (os.sched_setaffinity), so that the
clients' work does not count as the server's; `--pin` is server on the
first core this process may use, clients on the second.  The report gives
the affinity read back from the processes.

`--maps N`: N of the protocol sessions are researchers asking for a map
on demand instead of clicking: each opens a link with its own map request
(`map=`: a 33 x 33 preview, 500-period window at its own mu, computed
adaptively on the server's map workers) and waits for the finished map;
the others click meanwhile.  Every map must finish (errors otherwise); the
report gives their durations.  The server's map cache is a fresh folder,
so that the maps are computed, not read from an earlier run's cache.

`--proxy-workers N`: the same load through nginx in front of N `vibtrans
serve` processes (devtools/deploy; `make loadtest-proxy`); memory is then
the workers' together, and the report says how the sessions spread.

Bounded: at most --sessions sessions, --timeout seconds in all (clicks not
done by then count as errors), and the server is always stopped.
"""

import argparse
import asyncio
import collections
import json
import os
import random
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

from vibtrans_explorer.server.memory import CLOSED, EXPLORERS_HELD, HELD, RELEASE_NAME, RELEASED

from . import results
from .chromium import ARGS, CHROMIUM
from .deploy import free_port as _port

ROOT = Path(__file__).resolve().parent.parent
LIFETIME_MS, CHECK_MS = 3000, 1000
BENIGN = ("WebSocketClosedError", "StreamClosedError")
KERNELS_READY = "kernels ready"  # app/server/warmup.py logs it
# a message from a page that is closing, handled after its connection was
# detached from the session (Bokeh's assertion): a disconnect race too
DETACHED = "assert self._session is not None"

# In the page: the summary's first line (bold, "... mu = ...") and the alert,
# found through Bokeh's shadow roots; polled inside the page (no round trips).
_STATE_JS = """
window.__vtState = () => {
  const out = {summary: "", alert: "", whole: false, canvases: 0};
  const visit = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) visit(el.shadowRoot);
      const tag = el.tagName;
      if (tag === "STRONG" && el.textContent.includes("mu = ")) out.summary = el.textContent;
      else if (tag === "CANVAS") out.canvases += 1;
      else if (el.classList && el.classList.contains("alert") && el.offsetParent !== null)
        out.alert = el.textContent;
      else if ((tag === "P" || tag === "STRONG") && el.textContent.startsWith("Whole run"))
        out.whole = true;
    }
  };
  visit(document);
  return out;
};
"""
_IDLE_JS = (
    "() => window.Bokeh !== undefined && Bokeh.documents.length > 0 "
    "&& Bokeh.documents.every((d) => d.is_idle)"
)
_DONE_JS = """
(before) => {
  const s = window.__vtState();
  if (/run failed|server's limit/.test(s.alert)) return {error: s.alert};
  if (s.summary && s.summary !== before && !s.summary.startsWith("Running") && s.whole)
    return {summary: s.summary};
  return null;
}
"""


def _stat(pid):
    """The fields of /proc/PID/stat after the command's name (which may
    hold spaces and parentheses): [0] the state, [1] the parent's pid,
    [11] and [12] user and system time in clock ticks."""
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rsplit(")", 1)[1].split()


def _tree(pid):
    """pid and its descendants (server processes with --num-procs > 1)."""
    children = {}
    for p in os.listdir("/proc"):
        if p.isdigit():
            try:
                ppid = int(_stat(p)[1])
                children.setdefault(ppid, []).append(int(p))
            except (OSError, IndexError, ValueError):
                pass
    out, todo = [], [pid]
    while todo:
        q = todo.pop()
        out.append(q)
        todo += children.get(q, [])
    return out


def rss_mb(pid, tree=True):
    """RSS (MB) of process `pid` and (tree) every process under it."""
    total = 0.0
    for q in _tree(pid) if tree else [pid]:
        try:
            with open(f"/proc/{q}/status") as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        total += int(line.split()[1]) / 1024
        except OSError:
            pass
    return total


def cpu_seconds(pids):
    """CPU seconds (user + system) the processes `pids` have used so far.
    On a virtual machine, time the host takes from a guest's core and does
    not report as steal is counted here too: the same work costing a run
    several times the CPU seconds of another says the machine was slower,
    not the code."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for q in pids:
        try:
            fields = _stat(q)
            total += int(fields[11]) + int(fields[12])  # utime, stime
        except (OSError, IndexError, ValueError):
            pass
    return total / tick


# the server's session settings under load: closed sessions dropped in seconds
SERVE_ARGS = ["--unused-session-lifetime", str(LIFETIME_MS), "--check-unused-sessions", str(CHECK_MS)]


def parse_cpus(text, option):
    """A taskset-style core list ("0", "0,2", "1-3") as a sorted list of
    core numbers, each one this process may run on; ValueError naming
    `option` and the cores there are otherwise."""
    allowed = sorted(os.sched_getaffinity(0))
    cpus = set()
    for part in str(text).split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            first, last = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise ValueError(
                f"{option} must be a list of cores such as 0, 0,2 or 0-1 "
                f"(cores here: {_cpu_list(allowed)}), got {text!r}"
            ) from None
        if first < 0 or last < first:
            raise ValueError(
                f"{option}: {part.strip()!r} is not a core range (cores here: {_cpu_list(allowed)})"
            )
        cpus.update(range(first, last + 1))
    missing = sorted(cpus - set(allowed))
    if missing:
        raise ValueError(
            f"{option}: core{'s' if len(missing) > 1 else ''} "
            f"{_cpu_list(missing)} do{'es' if len(missing) == 1 else ''} not "
            f"exist here (cores here: {_cpu_list(allowed)}), got {text!r}"
        )
    return sorted(cpus)


def _cpu_list(cpus):
    """Cores as taskset writes them: 0,2,4-7."""
    runs = []
    for c in sorted(cpus):
        if runs and c == runs[-1][1] + 1:
            runs[-1][1] = c
        else:
            runs.append([c, c])
    return ",".join(f"{a}" if a == b else f"{a}-{b}" for a, b in runs) or "none"


def _taskset(cpus):
    """The command prefix that starts a process on `cpus` (None: as this
    process; util-linux's taskset execs the command, so its pid is the
    process's, and re-executions and forks keep the affinity)."""
    if not cpus:
        return []
    taskset = shutil.which("taskset")
    if taskset is None:
        raise RuntimeError("--pin-server needs taskset (util-linux)")
    return [taskset, "-c", _cpu_list(cpus)]


def affinity(pids):
    """The cores these processes may run on (union; from the kernel)."""
    cores = set()
    for pid in pids:
        try:
            cores |= os.sched_getaffinity(pid)
        except OSError:
            pass
    return sorted(cores)


class _Measured:
    """What the load test reads from the server side: RSS (sampled), the
    sessions dropped and released, errors in the logs."""

    peak = 0.0
    _sampling = False

    def alive(self):
        return all(pid_alive(p) for p in self.pids())

    def server_pids(self):
        """Every process of the server side (for the affinity report)."""
        return [q for p in self.pids() for q in _tree(p)]

    def rss(self):
        """The server's processes' RSS together, MB."""
        return sum(rss_mb(p) for p in self.pids())

    def sample(self):
        """Start sampling the peak RSS (every 0.2 s) from now."""
        self.peak = self.rss()
        self._sampling = True

        def loop():
            while self._sampling and self.alive():
                self.peak = max(self.peak, self.rss())
                time.sleep(0.2)

        threading.Thread(target=loop, daemon=True).start()

    def stop_sampling(self):
        self._sampling = False
        return self.peak

    def wait_dropped(self, sessions, timeout):
        """Wait until Bokeh has discarded `sessions` sessions in all and the
        explorer has released their memory (it does so RELEASE_DELAY after a
        discard: reading the RSS before would measure the sessions' garbage),
        then for the RSS to settle; returns (seconds waited, whether the
        release was seen)."""
        t0 = time.perf_counter()

        def waited():
            return time.perf_counter() - t0

        while waited() < timeout:
            if self.discarded() < sessions or not self.released_after_discards():
                time.sleep(0.25)
                continue
            # let the discard finish and memory settle: RSS steady for 2 s
            last, steady = self.rss(), 0
            while steady < 8 and waited() < timeout:
                time.sleep(0.25)
                now = self.rss()
                steady = steady + 1 if abs(now - last) < 0.5 else 0
                last = now
            # a session discarded meanwhile (one never connected, such as
            # the request that saw the server start, goes when its lifetime
            # ends) has its memory released later: wait for that too (one
            # run read the RSS before it: +11.6%, released False)
            if self.released_after_discards():
                break
        return waited(), self.released_after_discards()


def pid_alive(pid):
    """Whether process `pid` exists and is not a zombie."""
    try:
        return _stat(pid)[0] != "Z"
    except (OSError, IndexError):
        return False


def discarded(text):
    """Sessions Bokeh has dropped, from its debug log (one line or more per
    session)."""
    return len(set(re.findall(r"Discarding session '([^']+)'", text)))


def release_lines(text):
    """The explorer's lines on releasing closed sessions' memory (each names
    its process), in the log's order."""
    return [line.strip()[:240] for line in text.splitlines() if RELEASED in line or RELEASE_NAME in line]


def _held(lines, what):
    """Each process's count of `what` at its last release (a figure of its
    release line)."""
    held = {}
    for line in lines:
        m = re.search(rf"\(process (\d+)\).* (\d+) {what}", line)
        if m:
            held[m.group(1)] = int(m.group(2))
    return held


def documents_held(lines):
    """Each process's Bokeh documents still held at its last release
    (memory.documents_held)."""
    return _held(lines, HELD)


def explorers_held(lines):
    """Each process's pages' explorers still held at its last release
    (memory.explorers_held)."""
    return _held(lines, EXPLORERS_HELD)


def released_after_discards(text):
    """Whether every server process has released the memory of the
    sessions it closed (the explorer's INFO lines name their process: a
    process's last release after its last close), and Bokeh has discarded
    nothing since the last close.  (One check over all processes' lines
    passed while one process had not released yet: rss_after then read
    its sessions' garbage, +20%.)"""
    closed, released = {}, {}
    for i, line in enumerate(text.splitlines()):
        m = re.search(r"\(process (\d+)\)", line)
        if m and CLOSED in line:
            closed[m.group(1)] = i
        elif m and RELEASED in line:
            released[m.group(1)] = i
    if text.rfind(CLOSED) < text.rfind("Discarding session"):
        return False  # a discard whose close is not logged yet
    return bool(closed) and all(released.get(pid, -1) > i for pid, i in closed.items())


class Server(_Measured):
    """`vibtrans serve` on a free port, its log in a file, RSS sampled.
    wrap: a command prefix (the pinning's taskset)."""

    def __init__(self, num_procs=1, env=None, wrap=()):
        self.port = _port()
        self.url = f"http://127.0.0.1:{self.port}/"
        self.log = tempfile.NamedTemporaryFile(prefix="vibtrans-loadtest-", suffix=".log", delete=False)
        env = {**os.environ, "BOKEH_PY_LOG_LEVEL": "debug", **(env or {})}
        self.proc = subprocess.Popen(
            [
                *wrap,
                sys.executable,
                "-m",
                "vibtrans.cli",
                "serve",
                "--port",
                str(self.port),
                "--num-procs",
                str(num_procs),
                *SERVE_ARGS,
            ],
            cwd=ROOT,
            env=env,
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )
        self.processes = num_procs or os.cpu_count() or 1

    def wait_ready(self, timeout=300):
        """Wait until the server answers and every process of it has its
        kernels compiled (the server serves pages while they compile: the
        load would otherwise measure the compilation)."""
        t0 = time.perf_counter()
        while True:
            try:
                urllib.request.urlopen(self.url + "liveness", timeout=5)
                if self.text().count(KERNELS_READY) >= self.processes:
                    return time.perf_counter() - t0
            except OSError:
                pass
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited:\n{self.text()[-3000:]}")
            if time.perf_counter() - t0 > timeout:
                raise RuntimeError(f"server not ready in {timeout} s")
            time.sleep(0.2)

    def pids(self):
        return [self.proc.pid]

    def alive(self):
        return self.proc.poll() is None

    def rss(self):
        return rss_mb(self.proc.pid)  # the tree: --num-procs > 1 forks

    def text(self):
        with open(self.log.name, errors="replace") as f:
            return f.read()

    def discarded(self):
        return discarded(self.text())

    def released_after_discards(self):
        return released_after_discards(self.text())

    def errors(self):
        return log_errors(self.text())

    def logs(self):
        """Where the server's log is (kept when the run had errors)."""
        return self.log.name

    def remove_logs(self):
        os.remove(self.log.name)

    def stop(self):
        """Stop the server and every process it forked (--num-procs > 1:
        Tornado's children outlive their parent)."""
        self._sampling = False
        children = _tree(self.proc.pid)[1:]
        self.proc.terminate()
        try:
            self.proc.wait(15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)
        for pid in children:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        self.log.close()


class ProxiedServers(_Measured):
    """--proxy-workers: `workers` `vibtrans serve` behind nginx
    (devtools.deploy), measured as one server: RSS the workers' together
    (nginx's few MB left out), sessions dropped and errors over all their
    logs, and nginx's own errors."""

    def __init__(self, workers, env=None, wrap=()):
        from .deploy import Deployment

        self.log_dir = tempfile.mkdtemp(prefix="vibtrans-loadtest-")
        env = {**os.environ, "BOKEH_PY_LOG_LEVEL": "debug", **(env or {})}
        self.deployment = Deployment(
            workers=workers,
            port=_port(),
            serve_args=SERVE_ARGS,
            env=env,
            log_dir=self.log_dir,
            wrap=wrap,
            keep=True,
        )
        self.deployment.start()
        self.url = self.deployment.url

    def wait_ready(self, timeout=300):
        """Every worker and the proxy answer, and every worker has its
        kernels."""
        t0 = time.perf_counter()
        self.deployment.wait_ready(timeout)
        while not all(KERNELS_READY in t for t in self.texts()):
            dead = self.deployment.exited()
            if dead:
                raise RuntimeError(f"{dead} exited:\n{self.text()[-3000:]}")
            if time.perf_counter() - t0 > timeout:
                raise RuntimeError(f"workers not ready in {timeout} s")
            time.sleep(0.2)
        return time.perf_counter() - t0

    def pids(self):
        return self.deployment.pids()

    def server_pids(self):
        return [*super().server_pids(), *_tree(self.deployment.nginx.pid)]

    def alive(self):
        return self.deployment.exited() is None

    def texts(self):
        out = []
        for path in self.deployment.logs:
            with open(path, errors="replace") as f:
                out.append(f.read())
        return out

    def text(self):
        return "\n".join(self.texts())

    def discarded(self):
        return sum(discarded(t) for t in self.texts())

    def released_after_discards(self):
        return all(released_after_discards(t) for t in self.texts() if "Discarding session" in t)

    def errors(self):
        errors, benign = [], 0
        for t in self.texts():
            e, b = log_errors(t)
            errors += e
            benign += b
        return errors + [f"nginx: {line[:300]}" for line in self.deployment.proxy_errors()], benign

    def logs(self):
        return self.log_dir

    def remove_logs(self):
        shutil.rmtree(self.log_dir, ignore_errors=True)
        shutil.rmtree(self.deployment.prefix, ignore_errors=True)

    def stop(self):
        self._sampling = False
        self.deployment.stop()


def log_errors(text):
    """(server-side errors in a log, client-disconnect races): each
    traceback by its final exception line, and ERROR log lines.  A page
    that closes while the server still writes to it gives Tornado's
    WebSocketClosedError/StreamClosedError: counted apart, not errors."""
    errors, benign = [], 0
    lines = text.splitlines()
    i, pending = 0, None  # pending: an ERROR line waiting for its traceback
    while i < len(lines):
        line = lines[i]
        if line.startswith("Traceback"):
            j = i + 1
            while j < len(lines) and (
                not lines[j]
                or lines[j][0].isspace()
                or lines[j].startswith(("Traceback", "During handling"))
                or "exception occurred" in lines[j]
            ):
                j += 1
            final = lines[j] if j < len(lines) else "(truncated traceback)"
            block = "\n".join(lines[i : j + 1])
            if any(k in final for k in BENIGN) or (final.startswith("AssertionError") and DETACHED in block):
                benign += 1
            else:
                errors.append(f"{pending + ': ' if pending else ''}{final}"[:300])
            pending = None
            i = j + 1
            continue
        if pending is not None and " - " in line[:30]:  # the next log line: no traceback
            errors.append(pending)
            pending = None
        if " - ERROR - " in line or line.startswith("ERROR:"):
            pending = line[:300]
        i += 1
    if pending is not None:
        errors.append(pending)
    return errors, benign


def map_request(k):
    """Map session k's request (the URL's `map=` value): a window across
    the jumping boundary, 33 x 33 points at the finest level, preview
    fidelity and 500 periods, at a mu of its own (so that no two sessions
    share a computation)."""
    from vibtrans_explorer.session.maprequest import MapRequest, encode

    return encode(
        MapRequest(
            model="deformable",
            mu=round(0.31 + 0.02 * k, 2),
            fidelity="preview",
            periods=500.0,
            la_from=0.0,
            la_to=1.5,
            lm_from=-1.5,
            lm_to=1.5,
            cells=8,
            levels=2,
        )
    )


def map_sessions(sessions, browsers, maps):
    """Which sessions ask for a map: `maps` of the protocol sessions,
    spread over the arrival order."""
    protocol = [k for k in range(sessions) if k not in browser_sessions(sessions, browsers)]
    maps = min(maps, len(protocol))
    return {protocol[int((i + 0.5) * len(protocol) / maps)] for i in range(maps)} if maps else set()


def _sequence(session, clicks):
    """Distinct well-spread numbers (u, v) in [0, 1)^2 for each click."""
    for c in range(clicks):
        i = session * clicks + c + 1
        yield (i * 0.6180339887) % 1.0, (i * 0.7548776662) % 1.0


def _points(session, clicks):
    """Distinct map points (fractions of the map canvas) for each click:
    log10 A* from about -1 to 2.3, log10 m* from about -3.3 to 3.3 (the
    shipped map's body, runs of a fraction of a second to a few seconds),
    clear of the legend in the top right corner (a click there is no tap)."""
    return [(0.33 + 0.42 * u, 0.22 + 0.55 * v) for u, v in _sequence(session, clicks)]


def _range_points(session, clicks):
    """The same for protocol sessions, as fractions of the map's data
    ranges (log10 A* in [-3, 3], log10 m* in [-5, 5]): log10 A* from about
    -1 to 2.3, log10 m* from about -3 to 3."""
    return [(0.33 + 0.55 * u, 0.2 + 0.6 * v) for u, v in _sequence(session, clicks)]


async def _arrive(a, k):
    """Session k's start: the sessions arrive evenly over --ramp seconds."""
    await asyncio.sleep(a.ramp * k / max(1, a.sessions - 1) if a.sessions > 1 else 0)


async def _clicked(result, a, rng, k, kind, start, error=None, note=""):
    """A click's outcome: a refusal or an error (its message), else its
    latency; then the think time before the next click."""
    if error is not None:
        result["refused" if "server's limit" in error else "errors"].append(f"session {k}: {error[:200]}")
        return
    latency = time.perf_counter() - start
    result["latencies"].append(latency)
    result[f"{kind}_latencies"].append(latency)
    result["timeline"].append((start, latency, kind))
    if a.verbose:
        print(f"session {k} ({kind}): {latency:.2f} s  {note}", file=sys.stderr, flush=True)
    await asyncio.sleep(a.think * rng.uniform(0.5, 1.5))


async def _protocol_session(url, k, a, result, rng):
    """One person, at the protocol level (devtools/protoclient.py)."""
    from .protoclient import ProtocolSession

    await _arrive(a, k)
    client = ProtocolSession(url, timeout=a.click_timeout)
    try:
        t0 = time.perf_counter()
        await client.open()
        result["load_s"].append(time.perf_counter() - t0)
        result["load_kinds"].append("protocol")
        for c, (fx, fy) in enumerate(_range_points(k + getattr(a, "first_point", 0), a.clicks)):
            start = time.perf_counter()
            try:
                kind, text = await client.click(fx, fy)
            except TimeoutError:
                result["errors"].append(
                    f"session {k}, click {c + 1}: no result within "
                    f"{a.click_timeout:g} s (at map range fraction "
                    f"{fx:.3f}, {fy:.3f})"
                )
                continue
            await _clicked(result, a, rng, k, "protocol", start, error=text if kind == "error" else None)
    except Exception as exc:  # noqa: BLE001 - counted, reported
        result["errors"].append(f"session {k}: {type(exc).__name__}: {str(exc)[:200]}")
    finally:
        client.close()


async def _map_session(url, k, a, result, index):
    """A researcher: open a link asking for a map, wait until it is
    finished (no clicks)."""
    from urllib.parse import quote

    from .protoclient import ProtocolSession

    await _arrive(a, k)
    client = ProtocolSession(url, timeout=a.click_timeout, query=f"?map={quote(map_request(index))}")
    try:
        t0 = time.perf_counter()
        await client.open()
        ended = client.map_ended()  # before any await: its end cannot be missed
        result["load_s"].append(time.perf_counter() - t0)
        result["load_kinds"].append("map")
        try:
            kind, text = await asyncio.wait_for(ended, a.timeout)
        except TimeoutError:
            result["errors"].append(f"session {k}: its map did not finish")
            return
        if kind == "error":
            result["errors"].append(f"session {k}: its map: {text[:300]}")
        else:
            result["map_s"].append(time.perf_counter() - t0)
    except Exception as exc:  # noqa: BLE001 - counted, reported
        result["errors"].append(f"session {k}: {type(exc).__name__}: {str(exc)[:200]}")
    finally:
        client.close()


async def _session(browser, url, k, a, result, rng):
    """One person: open the page, click the map a.clicks times."""
    await _arrive(a, k)
    context = await browser.new_context(viewport={"width": 1400, "height": 1000})
    await context.add_init_script(_STATE_JS)
    page = await context.new_page()
    js_errors = []
    page.on("pageerror", lambda e: js_errors.append(str(e)))
    try:
        t0 = time.perf_counter()
        await page.goto(url, timeout=a.click_timeout * 1000)
        await page.wait_for_selector("canvas", timeout=a.click_timeout * 1000)
        await page.get_by_text("Paper points").first.wait_for(timeout=a.click_timeout * 1000)
        # every root rendered (BokehJS's idle): before that a click on the
        # map can be lost (its tap callback is not attached yet)
        await page.wait_for_function(_IDLE_JS, polling=100, timeout=a.click_timeout * 1000)
        result["load_s"].append(time.perf_counter() - t0)
        result["load_kinds"].append("browser")
        await page.wait_for_timeout(500)
        box = await page.locator("canvas").first.bounding_box()
        for c, (fx, fy) in enumerate(_points(k + getattr(a, "first_point", 0), a.clicks)):
            before = (await page.evaluate("window.__vtState()"))["summary"]
            start = time.perf_counter()
            await page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
            try:
                handle = await page.wait_for_function(
                    _DONE_JS, arg=before, polling=100, timeout=a.click_timeout * 1000
                )
                done = await handle.json_value()
            except Exception as exc:  # noqa: BLE001 - counted, reported
                result["errors"].append(
                    f"session {k}, click {c + 1}: no result within "
                    f"{a.click_timeout:g} s (at map canvas fraction "
                    f"{fx:.3f}, {fy:.3f}; {type(exc).__name__})"
                )
                continue
            await _clicked(
                result, a, rng, k, "browser", start, error=done.get("error"), note=done.get("summary", "")
            )
    except Exception as exc:  # noqa: BLE001 - counted, reported
        result["errors"].append(f"session {k}: {type(exc).__name__}: {str(exc)[:200]}")
    finally:
        result["errors"] += [f"session {k}: JavaScript error: {e[:200]}" for e in js_errors]
        await context.close()


def _renice_browser(nice):
    """Lower the priority of this process's chromium processes (the browser,
    its zygote and GPU process; renderers started later inherit it): the
    browser and the server share this machine's cores, and the server is
    what is measured (its clients would be elsewhere)."""
    if not nice:
        return
    for pid in _tree(os.getpid())[1:]:
        try:
            with open(f"/proc/{pid}/comm") as f:
                if "chrom" not in f.read():
                    continue
            os.setpriority(os.PRIO_PROCESS, pid, nice)
        except OSError:
            pass


def browser_sessions(sessions, browsers):
    """Which sessions are real browser pages: `browsers` of them, spread
    over the arrival order (the others are protocol sessions)."""
    browsers = min(browsers, sessions)
    return {int((i + 0.5) * sessions / browsers) for i in range(browsers)} if browsers else set()


async def _drive(url, a, sessions, result, seed):
    rng = random.Random(seed)
    in_browser = browser_sessions(sessions, a.browsers)
    asking = sorted(map_sessions(sessions, a.browsers, getattr(a, "maps", 0)))

    def protocol(k):
        if k in asking:
            return _map_session(url, k, a, result, asking.index(k))
        return _protocol_session(url, k, a, result, rng)

    if not in_browser:
        await _gather([protocol(k) for k in range(sessions)], a, result)
        return
    from playwright.async_api import async_playwright

    # processes this one had started before (the server; a test session's
    # own servers): not clients
    before = set(_tree(os.getpid())) - {os.getpid()}
    async with async_playwright() as p:
        browser = await p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        _renice_browser(a.browser_nice)
        # the clients' cores, read back: this process and what it started
        # for them (Playwright's driver, chromium)
        result["client_cores"] = affinity(
            p for p in _tree(os.getpid()) if p not in before and p not in result.get("server_pids", ())
        )
        try:
            await _gather(
                [
                    _session(browser, url, k, a, result, rng) if k in in_browser else protocol(k)
                    for k in range(sessions)
                ],
                a,
                result,
            )
        finally:
            await browser.close()


async def _gather(coroutines, a, result):
    tasks = [asyncio.create_task(c) for c in coroutines]
    done, pending = await asyncio.wait(tasks, timeout=a.timeout)
    for t in pending:
        t.cancel()
    if pending:
        result["errors"].append(f"{len(pending)} sessions not finished within --timeout {a.timeout:g} s")
        await asyncio.gather(*pending, return_exceptions=True)


def _median(values):
    return statistics.median(values) if values else float("nan")


def _new_result():
    lists = "latencies browser_latencies protocol_latencies timeline errors refused load_s load_kinds map_s"
    return {k: [] for k in lists.split()}


def _quantile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))] if v else float("nan")


def run(a):
    """The load test; returns the figures (a dict)."""
    if not Path(CHROMIUM).exists():
        raise RuntimeError(f"{CHROMIUM} is required (Debian's chromium; make test installs it)")
    t_all = time.perf_counter()
    load_before = os.getloadavg()
    own_affinity = os.sched_getaffinity(0)
    wrap = _taskset(a.pin_server)
    # maps on demand computed, not read from an earlier run's cache
    map_cache = tempfile.mkdtemp(prefix="vibtrans-loadtest-maps-")
    env = {"VIBTRANS_MAP_CACHE": map_cache}
    if a.proxy_workers:
        server = ProxiedServers(a.proxy_workers, env=env, wrap=wrap)
    else:
        server = Server(num_procs=a.num_procs, env=env, wrap=wrap)
    try:
        if a.pin_clients:
            # this thread, and every thread and process started from it from
            # now on (asyncio's, Playwright's driver, chromium)
            os.sched_setaffinity(0, a.pin_clients)
        ready = server.wait_ready()
        server_affinity = affinity(server.server_pids())
        rss_ready = server.rss()
        # warm-up: one session, one click, closed and dropped -> the baseline
        warm = _new_result()
        one = dict(sessions=1, clicks=1, think=0.0, ramp=0.0, first_point=997, maps=0)
        warm_args = argparse.Namespace(**{**vars(a), **one})
        asyncio.run(_drive(server.url, warm_args, 1, warm, a.seed))
        _, warm_released = server.wait_dropped(1, a.settle)
        rss_base = server.rss()
        # the load
        result = _new_result()
        result["server_pids"] = set(server.server_pids())
        server.sample()
        cpu0 = cpu_seconds(server.server_pids())
        t0 = time.perf_counter()
        asyncio.run(_drive(server.url, a, a.sessions, result, a.seed + 1))
        load_wall = time.perf_counter() - t0
        server_cpu = cpu_seconds(server.server_pids()) - cpu0
        client_cores = sorted(set(result.get("client_cores", [])) | set(affinity([0])))
        rss_closed = server.rss()
        settle, released = server.wait_dropped(1 + a.sessions, a.settle)
        peak = server.stop_sampling()
        rss_after = server.rss()
        rss_by_process = {str(q): round(rss_mb(q, tree=False), 1) for q in server.server_pids()}
        releases = release_lines(server.text())
        closes = collections.Counter(re.findall(rf"{CLOSED} \(process (\d+)\)", server.text()))
        dropped = server.discarded() - 1
        try:
            urllib.request.urlopen(server.url + "liveness", timeout=10)
            alive = server.alive()
        except OSError:
            alive = False
        server_errors, disconnects = server.errors()
        spread = server.deployment.sessions_per_worker() if a.proxy_workers else None
    finally:
        server.stop()
        shutil.rmtree(map_cache, ignore_errors=True)
        os.sched_setaffinity(0, own_affinity)
    lat = result["latencies"]
    arriving = [x for start, x, _ in result["timeline"] if start - t0 <= a.ramp]
    settled = [x for start, x, _ in result["timeline"] if start - t0 > a.ramp]
    errors = warm["errors"] + result["errors"] + [f"server log: {e}" for e in server_errors]
    if not alive:
        errors.append("server not alive after the load")
    count = len(errors)  # the note below is not an error
    if errors:
        errors.append(f"the server's log is kept in {server.logs()}")
    else:
        server.remove_logs()
    out = {
        "command": "python -m devtools.loadtest " + " ".join(a.argv),
        "sessions": a.sessions,
        "clicks_per_session": a.clicks,
        "think_s": a.think,
        "ramp_s": a.ramp,
        "clicks_planned": a.sessions * a.clicks,
        "clicks_measured": len(lat),
        "refused": len(result["refused"]),
        "map_sessions": len(map_sessions(a.sessions, a.browsers, a.maps)),
        "maps_finished": len(result["map_s"]),
        "map_seconds": [round(x, 1) for x in sorted(result["map_s"])],
        "errors": count,
        "error_samples": errors[:10],
        "click_to_plot_p50_s": statistics.median(lat) if lat else float("nan"),
        "click_to_plot_p95_s": _quantile(lat, 0.95),
        "click_to_plot_max_s": max(lat) if lat else float("nan"),
        "click_to_plot_mean_s": statistics.fmean(lat) if lat else float("nan"),
        "browser_sessions": len(browser_sessions(a.sessions, a.browsers)),
        "browser_clicks": len(result["browser_latencies"]),
        "browser_click_to_plot_p50_s": _median(result["browser_latencies"]),
        "browser_click_to_plot_p95_s": _quantile(result["browser_latencies"], 0.95),
        "protocol_clicks": len(result["protocol_latencies"]),
        "protocol_click_to_data_p50_s": _median(result["protocol_latencies"]),
        "protocol_click_to_data_p95_s": _quantile(result["protocol_latencies"], 0.95),
        # the slow clicks are those made while pages still load
        "click_to_plot_p95_while_arriving_s": _quantile(arriving, 0.95),
        "click_to_plot_p95_after_arrivals_s": _quantile(settled, 0.95),
        "page_load_p50_s": statistics.median(result["load_s"]) if result["load_s"] else None,
        "page_load_p95_s": _quantile(result["load_s"], 0.95) if result["load_s"] else None,
        "page_load_max_s": max(result["load_s"]) if result["load_s"] else None,
        # which pages are slow: [[kind (protocol, map or browser), seconds], ...], slowest first
        "page_loads": sorted(
            ([k, round(t, 3)] for k, t in zip(result["load_kinds"], result["load_s"])), key=lambda kt: -kt[1]
        ),
        "warmup_click_s": warm["latencies"][0] if warm["latencies"] else None,
        "server_start_to_ready_s": ready,
        "rss_ready_mb": rss_ready,
        "rss_baseline_mb": rss_base,
        "rss_peak_mb": peak,
        "rss_all_closed_mb": rss_closed,
        "rss_after_mb": rss_after,
        "rss_after_over_baseline": rss_after / rss_base - 1.0,
        "sessions_dropped": dropped,
        "memory_released": warm_released and released,
        "settle_s": settle,
        # each server process's own RSS at the end, and the explorer's
        # release lines (which process released what, or deferred it)
        "rss_after_by_process_mb": rss_by_process,
        "release_lines": releases,
        "documents_held_by_process": documents_held(releases),
        "explorers_held_by_process": explorers_held(releases),
        # pages built and closed, by process (a session whose page was
        # served by one process and whose websocket reached another is
        # built in both)
        "pages_closed_by_process": dict(closes),
        "client_disconnect_races": disconnects,
        "load_wall_s": load_wall,
        "total_wall_s": time.perf_counter() - t_all,
        "server_cpu_s": server_cpu,
        "machine": f"{os.cpu_count()} cores",
        "load_average_before": [round(x, 2) for x in load_before],
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
        "proxy_workers": a.proxy_workers,
        "sessions_per_worker": spread,
        # the cores asked for, and those the processes had (from the kernel)
        "pin_server": _cpu_list(a.pin_server) if a.pin_server else None,
        "pin_clients": _cpu_list(a.pin_clients) if a.pin_clients else None,
        "server_cores": _cpu_list(server_affinity),
        "client_cores": _cpu_list(client_cores),
    }
    # (no click or no page load measured, e.g. every page failed: the goal is
    # missed, not a TypeError)
    out["goal_p95_3s"] = _within(out["click_to_plot_p95_s"], 3.0)
    # (the goal holds for both: clicks and page loads)
    out["goal_page_load_p95_3s"] = _within(out["page_load_p95_s"], 3.0)
    out["goal_errors_0"] = out["errors"] == 0
    out["goal_rss_within_10pct"] = abs(out["rss_after_over_baseline"]) <= 0.10
    out["goal_maps_finished"] = out["maps_finished"] == out["map_sessions"]
    return out


def _within(seconds, goal):
    """Whether a measured figure meets its goal (None: nothing measured)."""
    return seconds is not None and seconds <= goal


def parser():
    ap = argparse.ArgumentParser(prog="python -m devtools.loadtest", description=__doc__.splitlines()[0])
    ap.add_argument("--sessions", type=int, default=30, help="concurrent sessions (1-100)")
    ap.add_argument("--clicks", type=int, default=5, help="map clicks per session (1-50)")
    ap.add_argument(
        "--browsers",
        type=int,
        default=2,
        help="how many of the sessions are real chromium pages (the others "
        "are protocol sessions); 0 to --sessions",
    )
    ap.add_argument(
        "--maps",
        type=int,
        default=0,
        help="how many of the protocol sessions ask for a map on demand "
        "instead of clicking; 0 to --sessions - --browsers",
    )
    ap.add_argument(
        "--think", type=float, default=10.0, help="seconds between a result and the next click (+-50%%)"
    )
    ap.add_argument("--ramp", type=float, default=30.0, help="seconds over which the sessions start")
    ap.add_argument(
        "--click-timeout",
        type=float,
        default=180.0,
        help="seconds a click (or a page load) may take before it is an error",
    )
    ap.add_argument(
        "--timeout", type=float, default=1500.0, help="seconds for all the sessions; the rest count as errors"
    )
    ap.add_argument(
        "--settle",
        type=float,
        default=120.0,
        help="at most this many seconds for Bokeh to drop closed sessions",
    )
    ap.add_argument("--num-procs", type=int, default=1, help="server processes")
    ap.add_argument(
        "--proxy-workers",
        type=int,
        default=0,
        metavar="N",
        help="serve through nginx in front of N `vibtrans serve` processes "
        "(devtools/deploy), 0: no proxy; 0-16",
    )
    ap.add_argument(
        "--pin",
        action="store_true",
        help="the server on the first core this process may use, the clients on the second (needs 2 cores)",
    )
    ap.add_argument(
        "--pin-server", metavar="CPUS", help="cores for the server's processes (taskset list: 0, 0,2, 0-1)"
    )
    ap.add_argument("--pin-clients", metavar="CPUS", help="cores for the clients (this process, chromium)")
    ap.add_argument(
        "--browser-nice", type=int, default=10, help="niceness of the browser's processes (0: as the server)"
    )
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--verbose", action="store_true", help="each click's latency on stderr")
    results.add_option(ap)
    return ap


def _pinning(ap, a):
    """--pin / --pin-server / --pin-clients -> a.pin_server, a.pin_clients
    (lists of cores, or None); refused with a message naming the option and
    the cores there are."""
    if a.pin and (a.pin_server or a.pin_clients):
        ap.error("--pin is --pin-server FIRST --pin-clients SECOND: give either")
    if a.pin:
        cores = sorted(os.sched_getaffinity(0))
        if len(cores) < 2:
            ap.error(f"--pin needs 2 cores, this process may use {len(cores)} ({_cpu_list(cores)})")
        a.pin_server, a.pin_clients = cores[:1], cores[1:2]
        return
    try:
        a.pin_server = parse_cpus(a.pin_server, "--pin-server") if a.pin_server else None
        a.pin_clients = parse_cpus(a.pin_clients, "--pin-clients") if a.pin_clients else None
    except ValueError as exc:
        ap.error(str(exc))
    if a.pin_server and a.pin_clients and set(a.pin_server) & set(a.pin_clients):
        ap.error(
            f"--pin-server {_cpu_list(a.pin_server)} and --pin-clients "
            f"{_cpu_list(a.pin_clients)} share cores: give disjoint ones"
        )


def parse(argv):
    """The command line as checked options (argparse's error, exit status 2
    and a message naming the option and its range, otherwise)."""
    ap = parser()
    a = ap.parse_args(argv)
    a.argv = argv
    if not 1 <= a.sessions <= 100:
        ap.error(f"--sessions must be in [1, 100], got {a.sessions}")
    if not 0 <= a.browsers <= a.sessions:
        ap.error(f"--browsers must be in [0, --sessions = {a.sessions}], got {a.browsers}")
    if not 0 <= a.maps <= a.sessions - a.browsers:
        ap.error(f"--maps must be in [0, --sessions - --browsers = {a.sessions - a.browsers}], got {a.maps}")
    if not 1 <= a.clicks <= 50:
        ap.error(f"--clicks must be in [1, 50], got {a.clicks}")
    for name in ("think", "ramp", "click_timeout", "timeout", "settle"):
        v = getattr(a, name)
        if not (v == v and 0 <= v <= 86400):
            ap.error(f"--{name.replace('_', '-')} must be in [0, 86400] s, got {v}")
    if not 0 <= a.proxy_workers <= 16:
        ap.error(f"--proxy-workers must be in [0, 16], got {a.proxy_workers}")
    if a.proxy_workers and a.num_procs != 1:
        ap.error(
            "--num-procs and --proxy-workers exclude each other (the proxy's workers are one process each)"
        )
    _pinning(ap, a)
    return a


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    a = parse(argv)
    begun = results.begin()
    out = run(a)
    results.save("loadtest", out, begun, a.results_dir, out["command"])
    if a.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            if k == "error_samples":
                for e in v:
                    print(f"{'error':>26}: {e}")
            else:
                print(f"{k:>26}: {v:.3f}" if isinstance(v, float) else f"{k:>26}: {v}")
    return out


if __name__ == "__main__":
    main()
