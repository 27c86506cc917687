"""The deployment of devtools/deploy: `vibtrans serve` workers behind
Debian's nginx, each visitor kept on one worker by a cookie nginx sets.

Through the proxy: a page loads and its websocket session answers a click
(devtools/protoclient.py, as the load test's sessions); the page and its
websocket reach the same worker; visitors from one address (all of these
come from 127.0.0.1, as visitors behind one NAT) spread over the workers;
a returning visitor gets its worker again; a foreign Origin is refused;
the launcher stops every process it started.  Needs nginx (`make proxy`
installs it, as `make test` does)."""

import asyncio
import http.server
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import urllib.request
from pathlib import Path

import pytest
from asyncutil import wait_until
from budget import budget
from tornado.httpclient import HTTPClientError, HTTPRequest
from tornado.websocket import websocket_connect

from devtools import deploy
from devtools.protoclient import ProtocolSession
from devtools.server import pid_alive, tree

ROOT = Path(__file__).resolve().parents[2]
# the server settings as shipped, not the caller's (conftest.SERVER_ENV_UNSET)
ENV = {
    k: v
    for k, v in os.environ.items()
    if k not in ("VIBTRANS_ALLOWED_ORIGINS", "PYTHONMALLOC", "BOKEH_ALLOW_WS_ORIGIN")
}
TIMEOUT = budget(180)  # page loads and clicks on a loaded 2-core machine

pytestmark = pytest.mark.server  # starts `vibtrans serve`; needs nginx (make test)


def _nginx():
    try:
        return deploy.nginx_binary()
    except RuntimeError as exc:
        pytest.fail(str(exc))


@pytest.fixture(scope="module")
def proxied():
    """Two workers behind nginx, kernels ready (runs start at once)."""
    _nginx()
    logs = tempfile.mkdtemp(prefix="vibtrans-test-deploy-")
    d = deploy.Deployment(workers=2, port=deploy.free_port(), env=ENV, log_dir=logs)
    d.start()
    try:
        d.wait_ready(timeout=budget(300))

        def kernels_ready():
            assert d.exited() is None, d.exited()
            return all("kernels ready" in Path(p).read_text(errors="replace") for p in d.logs)

        wait_until(kernels_ready, 300, "the workers' kernels")
        yield d
    finally:
        d.stop()
        for p in d.logs:
            os.unlink(p)
        os.rmdir(logs)


def _visit(url, cookies=None, click=True):
    """One visitor through the proxy: load the page, open its websocket
    session, click the map once (when click); returns (the session's
    cookies, the click's outcome or None)."""

    async def go():
        s = ProtocolSession(url, timeout=TIMEOUT, cookies=cookies)
        try:
            await s.open()
            outcome = (await s.click(0.55, 0.5))[0] if click else None
            return dict(s.cookies), outcome
        finally:
            s.close()

    return asyncio.run(go())


def _visit_logged(d, cookies=None, click=True, timeout=60):
    """One visitor (_visit) alone on the proxy: (its cookies, the click's
    outcome, {path: set of worker addresses} of its requests), once its
    websocket's line is in the access log (nginx writes it when the
    connection closes)."""
    before = len(d.requests())
    cookies, outcome = _visit(d.url, cookies=cookies, click=click)
    try:
        wait_until(lambda: any(r["path"] == "/ws" for r in d.requests()[before:]), timeout)
    except AssertionError:
        pass  # the caller's checks say what is missing
    out = {}
    for r in d.requests()[before:]:
        out.setdefault(r["path"], set()).add(r["upstream"])
    return cookies, outcome, out


def _address(d, name):
    """The address of the worker a `vtworker` cookie names."""
    return f"127.0.0.1:{d.ports[int(name.removeprefix('w'))]}"


def test_the_configuration_is_valid_nginx(tmp_path):
    """The rendered template passes `nginx -t`; new visitors go to the
    pool of every worker by least connections, and a cookie routes only by
    the names listed (never an address)."""
    nginx = _nginx()
    (tmp_path / "tmp").mkdir()
    conf = tmp_path / "nginx.conf"
    conf.write_text(deploy.render_config(str(tmp_path), "127.0.0.1:8999", [7001, 7002, 7003]))
    text = conf.read_text()
    upstream = re.search(r"upstream vibtrans \{(.*?)\n    \}", text, re.S).group(1)
    directives = [ln.split("#")[0].strip() for ln in upstream.splitlines()]
    directives = [d for d in directives if d]
    assert directives == ["least_conn;", *(f"server 127.0.0.1:{p} max_fails=0;" for p in (7001, 7002, 7003))]
    routes = re.search(r"map \$cookie_vtworker \$vtbackend \{(.*?)\n    \}", text, re.S).group(1)
    entries = [ln.split("#")[0].split() for ln in routes.splitlines()]
    assert [e for e in entries if e] == [
        ["default", "vibtrans;"],
        ["w0", "vt_w0;"],
        ["w1", "vt_w1;"],
        ["w2", "vt_w2;"],
    ]
    checked = subprocess.run(
        [nginx, "-t", "-p", str(tmp_path), "-c", str(conf), "-e", str(tmp_path / "error.log")],
        capture_output=True,
        text=True,
        timeout=budget(30),
    )
    assert checked.returncode == 0, checked.stderr


class _Backend(http.server.BaseHTTPRequestHandler):
    """A stand-in worker: answers every GET with its own port."""

    def do_GET(self):
        body = str(self.server.server_address[1]).encode()
        self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture
def routing():
    """nginx with the shipped configuration in front of two stand-in
    workers (_Backend); yields (get, backends): get(cookie) -> (the port
    that answered, the Set-Cookie header or None)."""
    nginx = _nginx()
    backends = [http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Backend) for _ in range(2)]
    threads = [threading.Thread(target=b.serve_forever, daemon=True) for b in backends]
    for th in threads:
        th.start()
    prefix = tempfile.mkdtemp(prefix="vibtrans-test-routing-")
    os.chmod(prefix, 0o755)  # nginx's workers run as nobody
    Path(prefix, "tmp").mkdir()
    port = deploy.free_port()
    conf = Path(prefix, "nginx.conf")
    conf.write_text(
        deploy.render_config(prefix, f"127.0.0.1:{port}", [b.server_address[1] for b in backends])
    )
    proc = subprocess.Popen(
        [nginx, "-p", prefix, "-c", str(conf), "-e", f"{prefix}/error.log"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )

    def get(cookie=None):
        req = urllib.request.Request(
            f"http://127.0.0.1:{port}/", headers={"Cookie": cookie} if cookie else {}
        )
        with urllib.request.urlopen(req, timeout=TIMEOUT) as r:
            return int(r.read()), r.headers.get("Set-Cookie")

    def listening():
        try:
            get()
            return True
        except OSError:
            assert proc.poll() is None, proc.stderr.read().decode()
            return False

    try:
        wait_until(listening, budget(30), "nginx listening")
        yield get, backends
    finally:
        deploy._stop(proc)
        proc.stderr.close()
        for b in backends:
            b.shutdown()
            b.server_close()
        shutil.rmtree(prefix, ignore_errors=True)


def test_routing_new_visitors_alternate_and_returning_ones_stay(routing):
    """With no connection open, least_conn ties and takes the workers in
    turn: new visitors alternate, each told its worker's name; a cookie
    naming a worker goes there, with no new cookie."""
    get, backends = routing
    ports = [b.server_address[1] for b in backends]
    answered = []
    for _ in range(4):
        port, cookie = get()
        name = deploy.worker_name(ports.index(port))
        assert cookie.startswith(f"{deploy.ROUTE_COOKIE}={name};"), cookie
        answered.append(port)
    assert sorted(answered) == sorted(ports * 2), answered
    for k, p in enumerate(ports):
        for _ in range(3):
            assert get(f"{deploy.ROUTE_COOKIE}={deploy.worker_name(k)}") == (p, None)


@pytest.mark.parametrize("value", ["w7", "w01", "127.0.0.1:22", "vt_w0", "vibtrans", ""])
def test_routing_a_cookie_that_names_no_worker_is_a_new_visitor(routing, value):
    """A forged or stale cookie never picks an address or an upstream by
    itself: the request goes to the pool and gets a valid cookie."""
    get, backends = routing
    ports = [b.server_address[1] for b in backends]
    port, cookie = get(f"{deploy.ROUTE_COOKIE}={value}")
    name = deploy.worker_name(ports.index(port))
    assert cookie is not None and cookie.startswith(f"{deploy.ROUTE_COOKIE}={name};"), cookie


def test_routing_a_visitor_whose_worker_is_down_moves_and_is_told(routing):
    """A refused connection goes on to another worker (the backups of the
    visitor's upstream), and the answer re-points the visitor's cookie."""
    get, backends = routing
    ports = [b.server_address[1] for b in backends]
    backends[0].shutdown()
    backends[0].server_close()
    port, cookie = get(f"{deploy.ROUTE_COOKIE}={deploy.worker_name(0)}")
    assert port == ports[1]
    assert cookie.startswith(f"{deploy.ROUTE_COOKIE}={deploy.worker_name(1)};"), cookie
    assert get(f"{deploy.ROUTE_COOKIE}={deploy.worker_name(1)}") == (ports[1], None)


@pytest.mark.slow
def test_a_session_works_through_the_proxy_and_stays_on_its_worker(proxied):
    logged = len(proxied.requests())
    with urllib.request.urlopen(proxied.url, timeout=TIMEOUT) as r:
        assert r.status == 200
        cookie = r.headers["Set-Cookie"]
        r.read()
    # this request's line in the access log before the visit below counts
    # its own: unread, the page was logged once the connection closed, and
    # was counted as the visit's (a page on the other worker; make test, once)
    wait_until(lambda: len(proxied.requests()) != logged, budget(30), "the page's request logged")
    assert cookie.startswith(f"{deploy.ROUTE_COOKIE}=w")
    assert "HttpOnly" in cookie and "SameSite=Lax" in cookie and "Path=/" in cookie
    assert "Secure" not in cookie  # plain http here; set under https only

    cookies, outcome, routes = _visit_logged(proxied)
    assert outcome == "done"  # the click's run came back over the websocket
    assert set(routes) == {"/", "/ws"}, routes
    # page and websocket together, on the worker the cookie names
    assert routes["/"] | routes["/ws"] == {_address(proxied, cookies[deploy.ROUTE_COOKIE])}, routes
    ws = [r for r in proxied.requests() if r["path"] == "/ws"]
    assert ws[-1]["status"] == "101"


@pytest.mark.slow
def test_visitors_from_one_address_split_evenly_and_return_to_their_worker(proxied):
    """All visitors here come from 127.0.0.1 with the same client: an
    address hash would send them all to one worker, a hash of a random
    cookie splits them by chance.  Four visitors arrive one after another
    and stay (their websockets open): least connections gives each worker
    two.  Each page's websocket reaches its page's worker; a returning
    visitor (its cookie) gets its worker again."""

    async def arrive(n):
        sessions = []
        try:
            for _ in range(n):
                s = ProtocolSession(proxied.url, timeout=TIMEOUT)
                await s.open()
                sessions.append(s)
            return [dict(s.cookies)[deploy.ROUTE_COOKIE] for s in sessions]
        finally:
            for s in sessions:
                s.close()

    before = len(proxied.requests())
    names = asyncio.run(arrive(4))
    assert sorted(names) == ["w0", "w0", "w1", "w1"], names
    wait_until(
        lambda: sum(r["path"] == "/ws" for r in proxied.requests()[before:]) >= 4,
        60,
        "the visitors' websockets logged",
    )
    for r in proxied.requests()[before:]:
        if r["path"] == "/ws":  # each websocket carries its page's cookie
            assert r["upstream"] == _address(proxied, r["worker"]), r
    cookies = {deploy.ROUTE_COOKIE: "w1"}
    again, _, routes = _visit_logged(proxied, cookies=cookies, click=False)
    assert routes["/"] | routes["/ws"] == {_address(proxied, "w1")}, routes
    assert again[deploy.ROUTE_COOKIE] == "w1"


@pytest.mark.slow
def test_a_foreign_origin_is_refused_through_the_proxy(proxied):
    """The workers accept the proxy's address as websocket origin, and
    nothing else (docs/SECURITY.md)."""
    with urllib.request.urlopen(proxied.url, timeout=TIMEOUT) as r:
        cookie = r.headers["Set-Cookie"].split(";")[0]
        token = r.read().decode().split('"token":"')[1].split('"')[0]

    async def connect(origin):
        req = HTTPRequest(
            proxied.url.replace("http", "ws") + "ws",
            headers={"Origin": origin, "Cookie": cookie},
            request_timeout=TIMEOUT,
        )
        conn = await websocket_connect(req, subprotocols=["bokeh", token])
        conn.close()

    with pytest.raises(HTTPClientError) as refused:
        asyncio.run(connect("http://evil.example.org"))
    assert refused.value.code == 403
    asyncio.run(connect(proxied.url.rstrip("/")))  # the proxy's own: accepted


@pytest.mark.slow
def test_the_launcher_serves_and_stops_everything(tmp_path):
    """`python -m devtools.deploy --workers 1 --port P`: the page through the
    proxy, then SIGTERM ends the launcher (status 0), its worker and nginx,
    and removes nginx's prefix."""
    _nginx()
    port = deploy.free_port()
    log = open(tmp_path / "deploy.log", "wb")
    proc = subprocess.Popen(
        [sys.executable, "-m", "devtools.deploy", "--workers", "1", "--port", str(port)],
        cwd=ROOT,
        env=ENV,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    try:

        def launched():
            assert proc.poll() is None, (tmp_path / "deploy.log").read_text()
            return b"Ctrl-C stops" in (tmp_path / "deploy.log").read_bytes()

        wait_until(launched, 300, "the launcher ready")
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=TIMEOUT) as r:
            assert r.status == 200 and b"token" in r.read()
        text = (tmp_path / "deploy.log").read_text()
        prefix = text.split("prefix ")[1].split(";")[0]
        started = tree(proc.pid)[1:]
        names = {Path(f"/proc/{p}/cmdline").read_bytes().split(b"\0")[0] for p in started}
        assert any(b"nginx" in n for n in names) and len(started) >= 3, names
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(60) == 0
        assert not [p for p in started if pid_alive(p)]
        assert not Path(prefix).exists()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        log.close()


class _Served(Exception):
    pass


def test_serve_hands_use_xheaders_to_bokeh(monkeypatch):
    """`vibtrans serve --use-xheaders` (the deployment's workers) reaches
    Bokeh's server as use_xheaders; without it, off (a server facing
    clients directly must not believe their X-Forwarded-For)."""
    import panel

    from vibtrans.cli import build_parser
    from vibtrans_explorer.server import serve as server

    given = []

    def fake_serve(*args, **kwargs):
        given.append(kwargs.get("use_xheaders"))
        raise _Served

    monkeypatch.setattr(panel, "serve", fake_serve)
    monkeypatch.setattr(server, "_freeze", lambda: None)  # not in the test process
    for argv, expected in ((["serve", "--use-xheaders"], True), (["serve"], False)):
        with pytest.raises(_Served):
            server.serve(build_parser().parse_args(argv))
        assert given[-1] is expected
