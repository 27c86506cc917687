"""Several `vibtrans serve` processes behind one nginx, each visitor kept on
one process (docs/SECURITY.md, "Several processes").

    python -m devtools.deploy --workers 2 --port 8080 [--address 127.0.0.1]
                              [--origin vib.example.org] [--keep]

Starts the workers on free loopback ports (--use-xheaders, the proxy as
websocket origin), writes nginx's configuration from nginx.conf.template into
a temporary prefix and runs nginx in the foreground until Ctrl-C, SIGTERM or
any process's exit (--keep: leave the prefix and its logs).  A worker is one
event loop, about one core.  Stickiness: Bokeh expects a page's websocket in
the process that served the page, so the first request goes to the least
connected worker and a cookie (`vtworker`) routes the rest there (the
template says why not ip_hash).  `python -m devtools.loadtest
--proxy-workers N` measures it; `make proxy` installs nginx.
"""

import argparse
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


def access_log(path):
    """The proxy's access log: a dict (method, path, status, worker, upstream) per request."""
    try:
        text = Path(path).read_text(errors="replace")
    except OSError:
        return []
    return [m.groupdict() for m in map(_ACCESS.search, text.splitlines()) if m]


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
    """`workers` `vibtrans serve` processes behind nginx on address:port (the
    workers on 127.0.0.1).  origins: more public HOST[:PORT] accepted as
    websocket origin; serve_args: more serve options; env: the workers';
    log_dir: worker-K.log files (else stderr); wrap: a command prefix (e.g.
    taskset).  A context manager, or start() and stop()."""

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

    # ---------- life cycle ----------
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
            cmd = [self.nginx_bin, "-p", self.prefix, "-c", str(conf), "-e", self.error_log_path]
            out = dict(stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            self.nginx = subprocess.Popen([*self.wrap, *cmd], **out)
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
        out = None
        if self.log_dir is not None:
            path = Path(self.log_dir, f"worker-{k + 1}.log")
            self.logs.append(str(path))
            out = open(path, "wb")
        try:
            self.procs.append(
                subprocess.Popen(
                    args, cwd=ROOT, env=self.env, stdout=out, stderr=subprocess.STDOUT if out else None
                )
            )
        finally:
            if out is not None:
                out.close()
        self.ports.append(port)

    def wait_ready(self, timeout=300):
        """Wait until every worker and the proxy answer /liveness; the seconds waited."""
        t0 = time.perf_counter()
        pending = [f"http://127.0.0.1:{p}/liveness" for p in self.ports]
        pending.append(self.url + "liveness")
        while pending:
            try:
                with urllib.request.urlopen(pending[0], timeout=10):
                    pending.pop(0)
                    continue
            except OSError:
                pass
            dead = self.exited()
            if dead:
                raise RuntimeError(f"{dead} exited before the deployment was ready{self._nginx_error()}")
            if time.perf_counter() - t0 > timeout:
                raise RuntimeError(f"not ready in {timeout} s: {pending[0]}")
            time.sleep(0.2)
        return time.perf_counter() - t0

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
        try:
            text += Path(self.prefix, "error.log").read_text(errors="replace")
        except OSError:
            pass
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

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()

    # ---------- what happened ----------
    @property
    def access_log_path(self):
        return str(Path(self.prefix, "access.log"))

    @property
    def error_log_path(self):
        return str(Path(self.prefix, "error.log"))

    def requests(self):
        return access_log(self.access_log_path)

    def sessions_per_worker(self):
        """Websockets opened through the proxy (status 101) per worker address."""
        counts = {f"127.0.0.1:{p}": 0 for p in self.ports}
        for r in self.requests():
            if r["path"].split("?")[0] == "/ws" and r["status"] == "101":
                counts[r["upstream"]] = counts.get(r["upstream"], 0) + 1
        return counts

    def proxy_errors(self):
        """nginx's error-log lines at level error or worse."""
        try:
            lines = Path(self.error_log_path).read_text(errors="replace").splitlines()
        except OSError:
            return []
        return [line for line in lines if re.search(r"\[(error|crit|alert|emerg)\]", line)]


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.deploy", description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2, help="`vibtrans serve` processes (1-64)")
    ap.add_argument("--port", type=int, default=8080, help="nginx's port (1-65535)")
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
    if not 1 <= a.workers <= 64:
        ap.error(f"--workers must be in [1, 64], got {a.workers}")
    if not 1 <= a.port <= 65535:
        ap.error(f"--port must be in [1, 65535], got {a.port}")
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
