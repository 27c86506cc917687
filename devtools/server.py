"""`vibtrans serve` as the benches start and measure it: a server on a free
loopback port with its log in a file, the memory and CPU of its processes,
and what its log says (sessions dropped and released, errors)."""

import contextlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil  # a dependency of distributed

from vibtrans_explorer.server.memory import CLOSED, RELEASED

from .chromium import launched
from .deploy import _stop, answers, free_port, wait_until

ROOT = Path(__file__).resolve().parent.parent
KERNELS_READY = "kernels ready"  # app/server/warmup.py logs it
# a page closing while the server writes to it: Tornado's errors, and
# Bokeh's assertion on a message handled after the connection was detached
BENIGN = ("WebSocketClosedError", "StreamClosedError")
DETACHED = "assert self._session is not None"


def each(pids, read):
    """read(psutil.Process) of each of `pids` still there."""
    out = []
    for pid in pids:
        try:
            out.append(read(psutil.Process(pid)))
        except psutil.Error:
            pass
    return out


def tree(pid):
    """pid and every process under it."""
    kids = each([pid], lambda p: [c.pid for c in p.children(recursive=True)])
    return [pid, *(kids[0] if kids else [])]


def rss_mb(pids):
    """The RSS of these processes together, MB."""
    return sum(each(pids, lambda p: p.memory_info().rss)) / 2**20


def cpu_seconds(pids):
    """CPU seconds (user + system) these processes have used so far."""
    return sum(each(pids, lambda p: sum(p.cpu_times()[:2])))


def affinity(pids):
    """The cores these processes may run on (union)."""
    return sorted(set().union(*each(pids, lambda p: p.cpu_affinity())))


def pid_alive(pid):
    """Whether process `pid` exists and is not a zombie."""
    return any(each([pid], lambda p: p.status() != psutil.STATUS_ZOMBIE))


def discarded(text):
    """Sessions Bokeh has dropped, from its debug log."""
    return len(set(re.findall(r"Discarding session '([^']+)'", text)))


def released_after_discards(text):
    """Whether every server process in the log released the memory of the
    sessions it closed (its last release after its last close; the lines
    name their process) and nothing was discarded after the last close."""
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


def log_errors(text):
    """(errors in a server log, client-disconnect races): each traceback by
    its last line, and ERROR lines; a page closing under the server's
    writes (BENIGN, DETACHED) is counted apart."""
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


@contextlib.contextmanager
def explorer(url=None):
    """(chromium, the explorer's URL, its Server or None): `url`, or a server
    of its own (kernels compiled; its log's end on stderr after a failure)."""
    server = None if url else Server()
    try:
        if server:
            server.wait_ready()
        with launched() as browser:
            yield browser, url or server.url, server
    except BaseException:
        if server:
            print(f"the server's log:\n{server.text()[-3000:]}", file=sys.stderr)
        raise
    finally:
        if server:
            server.stop()
            server.remove_logs()


class Measured:
    """The server side as the benches read it: pids() its processes (each
    with its children), texts() their logs in `log_dir`."""

    peak = 0.0
    _sampling = False

    def server_pids(self):
        return [q for p in self.pids() for q in tree(p)]

    def rss(self):
        return rss_mb(self.server_pids())

    def text(self):
        return "\n".join(self.texts())

    def remove_logs(self):
        shutil.rmtree(self.log_dir, ignore_errors=True)

    def discarded(self):
        return sum(discarded(t) for t in self.texts())

    def released_after_discards(self):
        texts = [t for t in self.texts() if "Discarding session" in t]
        return bool(texts) and all(released_after_discards(t) for t in texts)

    def errors(self):
        """(error lines of every log, client-disconnect races)."""
        found = [log_errors(t) for t in self.texts()]
        return [e for errors, _ in found for e in errors], sum(b for _, b in found)

    def wait_ready(self, timeout=300):
        """Wait until ready(): every process has its kernels (pages are
        served while they compile); the seconds waited."""
        exited = lambda: not self.alive() and f"the server exited:\n{self.text()[-3000:]}"
        return wait_until(self.ready, exited, timeout)

    def sample(self):
        """Sample the peak RSS every 0.2 s from now until stop_sampling()."""
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
        """Wait until Bokeh has discarded `sessions` sessions in all, the
        explorer has released their memory (reading the RSS before would
        measure their garbage) and the RSS is steady for 2 s; returns
        (seconds waited, whether the release was seen)."""
        t0 = time.perf_counter()

        def waited():
            return time.perf_counter() - t0

        while waited() < timeout:
            if self.discarded() < sessions or not self.released_after_discards():
                time.sleep(0.25)
                continue
            last, steady = self.rss(), 0
            while steady < 8 and waited() < timeout:
                time.sleep(0.25)
                now = self.rss()
                steady = steady + 1 if abs(now - last) < 0.5 else 0
                last = now
            # a session discarded meanwhile (one that never connected goes
            # when its lifetime ends) is released later: wait for that too
            if self.released_after_discards():
                break
        return waited(), self.released_after_discards()


class Server(Measured):
    """`vibtrans serve ARGS` on a free port, its log in a file; env: more
    environment; wrap: a command prefix (taskset, py-spy)."""

    def __init__(self, args=(), env=None, wrap=(), num_procs=1):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}/"
        self.log_dir = tempfile.mkdtemp(prefix="vibtrans-serve-")
        self.log = open(Path(self.log_dir, "server.log"), "wb")
        cmd = [*wrap, sys.executable, "-m", "vibtrans.cli", "serve", "--port", str(self.port)]
        cmd += ["--num-procs", str(num_procs), *args]
        self.proc = subprocess.Popen(
            cmd, cwd=ROOT, env={**os.environ, **(env or {})}, stdout=self.log, stderr=subprocess.STDOUT
        )
        self.processes = num_procs or os.cpu_count() or 1

    def ready(self):
        return answers(self.url + "liveness") and self.text().count(KERNELS_READY) >= self.processes

    def pids(self):
        return [self.proc.pid]

    def alive(self):
        return self.proc.poll() is None

    def texts(self):
        return [Path(self.log.name).read_text(errors="replace")]

    def stop(self):
        """Stop the server and every process it forked (Tornado's children
        outlive their parent)."""
        self._sampling = False
        children = tree(self.proc.pid)[1:]
        _stop(self.proc)
        each(children, lambda p: p.kill())
        self.log.close()
