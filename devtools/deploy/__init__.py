"""Several `vibtrans serve` processes behind one nginx, each visitor kept on
one process (docs/SECURITY.md, "Several processes").

    python -m devtools.deploy --workers 2 --port 8080 [--address 127.0.0.1]
                              [--origin vib.example.org] [--keep]

Starts the workers on free loopback ports, writes nginx's configuration from
nginx.conf.template into a temporary prefix and runs nginx in the foreground
until Ctrl-C, SIGTERM or any process's exit (--keep: leave the prefix and its
logs).  A visitor's first request goes to the least connected worker, and a
cookie (`vtworker`) routes the rest there.
"""

import argparse
import contextlib
import os
import re
import shutil
import signal
import socket
import string
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from ..results import bounded

ROOT = Path(__file__).resolve().parents[2]
TEMPLATE = Path(__file__).with_name("nginx.conf.template")
ROUTE_COOKIE = "vtworker"
# one access-log line per request (the template's log_format)
_ACCESS = re.compile(
    r'"(?P<method>\S+) (?P<path>\S+) [^"]*" (?P<status>\d+) \d+ '
    r"worker=(?P<worker>\S*) upstream=(?P<upstream>\S*)"
)


def nginx_binary():
    """nginx's path (RuntimeError if it is not installed)."""
    found = shutil.which("nginx") or next(
        (p for p in ("/usr/sbin/nginx", "/usr/local/sbin/nginx") if os.access(p, os.X_OK)), None
    )
    if found is None:
        raise RuntimeError(
            "nginx is required: install Debian's (`make proxy`, as root: apt-get install nginx-light)"
        )
    return found


def free_port(address="127.0.0.1"):
    """A TCP port free on `address` now."""
    with socket.socket() as s:
        s.bind((address, 0))
        return s.getsockname()[1]


class _Template(string.Template):
    delimiter = "@"  # nginx uses $ for its own variables


def worker_name(k):
    """The cookie value that routes to worker k (0-based)."""
    return f"w{k}"


def render_config(prefix, listen, worker_ports):
    """nginx.conf: listen on "ADDRESS:PORT", proxy to 127.0.0.1:`worker_ports`,
    pid, logs and temporary files under `prefix`."""
    addrs = [f"127.0.0.1:{p}" for p in worker_ports]
    names = [worker_name(k) for k in range(len(addrs))]
    servers = "\n".join(f"        server {a} max_fails=0;" for a in addrs)
    upstreams = []
    for k, a in enumerate(addrs):
        lines = [f"    upstream vt_{names[k]} {{", f"        server {a} max_fails=0;"]
        lines += [f"        server {b} max_fails=0 backup;" for b in addrs if b != a]
        upstreams.append("\n".join([*lines, "    }"]))
    routes = "\n".join(f"        {n:<8}    vt_{n};" for n in names)
    # $upstream_addr: "ADDR", or "ADDR1, ADDR2" when the first refused
    answered = "\n".join(f'        "~(^|, ){re.escape(a)}$" {n};' for a, n in zip(addrs, names))
    set_cookie = "\n".join(
        f'        "{n}|{n}" "";\n'
        f'        "~\\|{n}$" "{ROUTE_COOKIE}={n}; Path=/; HttpOnly; SameSite=Lax$vtworker_secure";'
        for n in names
    )
    parts = dict(servers=servers, worker_upstreams="\n".join(upstreams), routes=routes, answered=answered)
    return _Template(TEMPLATE.read_text()).substitute(
        prefix=prefix, listen=listen, set_cookie=set_cookie, **parts
    )


def answers(url):
    """Whether `url` answers (its /liveness: the server is up)."""
    try:
        with urllib.request.urlopen(url, timeout=10):
            return True
    except OSError:
        return False


def wait_until(ready, dead, timeout):
    """Poll ready() until true; RuntimeError with dead()'s text (a process
    that exited) or after `timeout` s.  The seconds waited."""
    t0 = time.perf_counter()
    while not ready():
        if gone := dead():
            raise RuntimeError(gone)
        if time.perf_counter() - t0 > timeout:
            raise RuntimeError(f"not ready in {timeout} s")
        time.sleep(0.2)
    return time.perf_counter() - t0


def _stop(proc, sig=signal.SIGTERM, wait=15):
    """Stop one process started here and wait for it (SIGKILL if it lingers)."""
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(wait)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


class Deployment:
    """`workers` `vibtrans serve` behind nginx on address:port; start() and
    stop().  origins: more public HOST[:PORT] accepted as websocket origin;
    log_dir: the workers' logs (else stderr); wrap: a command prefix."""

    def __init__(
        self,
        workers=2,
        port=8080,
        address="127.0.0.1",
        origins=(),
        serve_args=(),
        env=None,
        log_dir=None,
        wrap=(),
        keep=False,
    ):
        if not 1 <= workers <= 64:
            raise ValueError(f"workers must be in [1, 64], got {workers}")
        if not 1 <= port <= 65535:
            raise ValueError(f"port must be in [1, 65535], got {port}")
        self.nginx_bin = nginx_binary()
        self.workers, self.port, self.address = workers, port, address
        host = "127.0.0.1" if address in ("0.0.0.0", "") else address
        self.url = f"http://{host}:{port}/"
        self.origins = [f"{address}:{port}"] if address not in ("0.0.0.0", "") else []
        if address in ("127.0.0.1", "localhost", "0.0.0.0", ""):
            self.origins += [f"127.0.0.1:{port}", f"localhost:{port}"]
        self.origins = list(dict.fromkeys([*self.origins, *origins]))
        self.serve_args, self.env, self.wrap, self.keep = list(serve_args), env, list(wrap), keep
        self.log_dir = log_dir
        self.prefix = None
        self.procs = []  # the workers' Popen objects
        self.ports = []
        self.logs = []  # the workers' log paths (with log_dir)
        self.nginx = None

    def start(self):
        self.prefix = tempfile.mkdtemp(prefix="vibtrans-nginx-")
        # nginx's workers drop root for `nobody`: they must reach the prefix
        os.chmod(self.prefix, 0o755)
        try:
            for k in range(self.workers):
                self._start_worker(k)
            conf = Path(self.prefix, "nginx.conf")
            conf.write_text(render_config(self.prefix, f"{self.address}:{self.port}", self.ports))
            Path(self.prefix, "tmp").mkdir()
            log = str(Path(self.prefix, "error.log"))
            cmd = [*self.wrap, self.nginx_bin, "-p", self.prefix, "-c", str(conf), "-e", log]
            self.nginx = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        except BaseException:
            self.stop()
            raise
        return self

    def _start_worker(self, k):
        port = free_port()
        serve = ["serve", "--port", str(port), "--address", "127.0.0.1", "--use-xheaders"]
        args = [*self.wrap, sys.executable, "-m", "vibtrans.cli", *serve, *self.serve_args]
        for o in self.origins:
            args += ["--allow-websocket-origin", o]
        log = None
        if self.log_dir is not None:
            self.logs.append(str(Path(self.log_dir, f"worker-{k + 1}.log")))
            log = open(self.logs[-1], "wb")
        with log or contextlib.nullcontext():
            err = subprocess.STDOUT if log else None
            self.procs.append(subprocess.Popen(args, cwd=ROOT, env=self.env, stdout=log, stderr=err))
        self.ports.append(port)

    def wait_ready(self, timeout=300):
        """Wait until every worker and the proxy answer /liveness; the seconds waited."""
        pending = [f"http://127.0.0.1:{p}/liveness" for p in self.ports] + [self.url + "liveness"]

        def ready():
            while pending and answers(pending[0]):
                pending.pop(0)
            return not pending

        def dead():
            gone = self.exited()
            return gone and f"{gone} exited before the deployment was ready{self._nginx_error()}"

        return wait_until(ready, dead, timeout)

    def exited(self):
        """The first process that has exited, in words, else None."""
        for k, p in enumerate(self.procs):
            if p.poll() is not None:
                return f"worker {k + 1} (port {self.ports[k]}, status {p.returncode})"
        if self.nginx is not None and self.nginx.poll() is not None:
            return f"nginx (status {self.nginx.returncode})"
        return None

    def _nginx_error(self):
        text = ""
        if self.nginx is not None and self.nginx.poll() is not None:
            text = self.nginx.stderr.read().decode(errors="replace")
        text += "\n".join(self._log("error.log"))
        return f":\n{text[-2000:]}" if text.strip() else ""

    def pids(self):
        return [p.pid for p in self.procs]

    def stop(self):
        """Stop nginx and the workers; remove the prefix unless keep."""
        if self.nginx is not None:
            _stop(self.nginx)
            self.nginx.stderr.close()
        for p in self.procs:
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            _stop(p)
        if self.prefix and not self.keep:
            shutil.rmtree(self.prefix, ignore_errors=True)

    def requests(self):
        """The proxy's access log: a dict (method, path, status, worker, upstream) per request."""
        return [m.groupdict() for m in map(_ACCESS.search, self._log("access.log")) if m]

    def sessions_per_worker(self):
        """Websockets opened through the proxy (status 101) per worker address."""
        counts = {f"127.0.0.1:{p}": 0 for p in self.ports}
        for r in self.requests():
            if r["path"].split("?")[0] == "/ws" and r["status"] == "101":
                counts[r["upstream"]] = counts.get(r["upstream"], 0) + 1
        return counts

    def proxy_errors(self):
        """nginx's error-log lines at level error or worse."""
        return [line for line in self._log("error.log") if re.search(r"\[(error|crit|alert|emerg)\]", line)]

    def _log(self, name):
        try:
            return Path(self.prefix, name).read_text(errors="replace").splitlines()
        except OSError:
            return []


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.deploy", description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=bounded(int, 1, 64), default=2, help="`vibtrans serve` processes")
    ap.add_argument("--port", type=bounded(int, 1, 65535), default=8080, help="nginx's port")
    ap.add_argument(
        "--address", default="127.0.0.1", help="nginx's interface (the workers stay on 127.0.0.1)"
    )
    ap.add_argument(
        "--origin",
        action="append",
        default=[],
        metavar="HOST[:PORT]",
        help="public host the browsers' address bar shows (repeatable; docs/SECURITY.md)",
    )
    ap.add_argument(
        "--keep", action="store_true", help="keep nginx's prefix (configuration, logs) after exit"
    )
    a = ap.parse_args(argv)
    try:
        deployment = Deployment(
            workers=a.workers, port=a.port, address=a.address, origins=a.origin, keep=a.keep
        )
    except RuntimeError as exc:
        ap.error(str(exc))

    def terminate(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, terminate)
    deployment.start()
    try:
        deployment.wait_ready()
        print(
            f"devtools.deploy: {a.workers} workers (ports "
            f"{', '.join(map(str, deployment.ports))}) behind nginx on {deployment.url} "
            f"(websocket origins: {', '.join(deployment.origins)}); prefix "
            f"{deployment.prefix}; Ctrl-C stops",
            file=sys.stderr,
            flush=True,
        )
        while (dead := deployment.exited()) is None:
            time.sleep(0.5)
        print(f"devtools.deploy: {dead} exited; stopping", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0
    finally:
        deployment.stop()
