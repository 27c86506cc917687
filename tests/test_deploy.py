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
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import pytest
from tornado.httpclient import HTTPClientError, HTTPRequest
from tornado.websocket import websocket_connect

from devtools import deploy
from devtools.loadtest import _tree, pid_alive
from devtools.protoclient import ProtocolSession
from budget import budget

ROOT = Path(__file__).resolve().parent.parent
# the server settings as shipped, not the caller's (conftest.SERVER_ENV_UNSET)
ENV = {k: v for k, v in os.environ.items()
       if k not in ("VIBTRANS_ALLOWED_ORIGINS", "PYTHONMALLOC", "BOKEH_ALLOW_WS_ORIGIN")}
TIMEOUT = budget(180)        # page loads and clicks on a loaded 2-core machine

pytestmark = pytest.mark.server      # starts `vibtrans serve`; needs nginx (make test)


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
        t0 = time.perf_counter()
        while not all("kernels ready" in Path(p).read_text(errors="replace") for p in d.logs):
            assert d.exited() is None, d.exited()
            assert time.perf_counter() - t0 < 300, "workers' kernels not ready in 300 s"
            time.sleep(0.2)
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


def _workers_of(d, route, timeout=60):
    """{path: set of worker addresses} for one visitor's requests, once its
    websocket's line is in the access log (nginx writes it when the
    connection closes)."""
    t0 = time.perf_counter()
    while True:
        mine = [r for r in d.requests() if r["route"] == route]
        if any(r["path"] == "/ws" for r in mine) or time.perf_counter() - t0 > timeout:
            out = {}
            for r in mine:
                out.setdefault(r["path"], set()).add(r["upstream"])
            return out
        time.sleep(0.2)


def test_the_configuration_is_valid_nginx(tmp_path):
    """The rendered template passes `nginx -t`, hashes on the route cookie
    (not the address) and names every worker."""
    nginx = _nginx()
    (tmp_path / "tmp").mkdir()
    conf = tmp_path / "nginx.conf"
    conf.write_text(deploy.render_config(str(tmp_path), "127.0.0.1:8999", [7001, 7002, 7003]))
    upstream = re.search(r"upstream vibtrans \{(.*?)\n    \}", conf.read_text(), re.S).group(1)
    directives = [ln.split("#")[0].strip() for ln in upstream.splitlines()]
    directives = [d for d in directives if d]
    assert directives == ["hash $vtroute consistent;",
                          *(f"server 127.0.0.1:{p} max_fails=0;" for p in (7001, 7002, 7003))]
    checked = subprocess.run([nginx, "-t", "-p", str(tmp_path), "-c", str(conf),
                              "-e", str(tmp_path / "error.log")],
                             capture_output=True, text=True, timeout=budget(30))
    assert checked.returncode == 0, checked.stderr


@pytest.mark.slow
def test_a_session_works_through_the_proxy_and_stays_on_its_worker(proxied):
    with urllib.request.urlopen(proxied.url, timeout=TIMEOUT) as r:
        assert r.status == 200
        cookie = r.headers["Set-Cookie"]
    assert cookie.startswith(f"{deploy.ROUTE_COOKIE}=")
    assert "HttpOnly" in cookie and "SameSite=Lax" in cookie and "Path=/" in cookie
    assert "Secure" not in cookie           # plain http here; set under https only

    cookies, outcome = _visit(proxied.url)
    assert outcome == "done"                # the click's run came back over the websocket
    routes = _workers_of(proxied, cookies[deploy.ROUTE_COOKIE])
    assert set(routes) == {"/", "/ws"}, routes
    assert len(routes["/"] | routes["/ws"]) == 1, routes        # page and websocket together
    ws = [r for r in proxied.requests() if r["route"] == cookies[deploy.ROUTE_COOKIE]
          and r["path"] == "/ws"]
    assert ws[0]["status"] == "101"


@pytest.mark.slow
def test_visitors_from_one_address_spread_and_return_to_their_worker(proxied):
    """All visitors here come from 127.0.0.1 with the same client: an
    address hash would send them all to one worker.  New visitors come
    until two workers are seen (at most 16: with two balanced workers all
    on one has probability ~3e-5); each visitor's page and websocket share
    a worker."""
    seen, first = set(), None
    for _ in range(16):
        cookies, _ = _visit(proxied.url, click=False)
        routes = _workers_of(proxied, cookies[deploy.ROUTE_COOKIE])
        workers = routes.get("/", set()) | routes.get("/ws", set())
        assert len(workers) == 1 and set(routes) == {"/", "/ws"}, routes
        first = first or (cookies, workers)
        seen |= workers
        if len(seen) == 2:
            break
    assert len(seen) == 2, f"16 visitors, all on {seen}"
    # a returning visitor (its cookie) gets its worker again, page and websocket
    cookies, workers = first
    before = len(proxied.requests())
    _visit(proxied.url, cookies=cookies, click=False)
    time.sleep(0.5)
    t0 = time.perf_counter()
    while not any(r["path"] == "/ws" for r in proxied.requests()[before:]):
        assert time.perf_counter() - t0 < 60, "the returning visitor's websocket is not logged"
        time.sleep(0.2)
    again = {r["upstream"] for r in proxied.requests()[before:]
             if r["route"] == cookies[deploy.ROUTE_COOKIE]}
    assert again == workers, (again, workers)


@pytest.mark.slow
def test_a_foreign_origin_is_refused_through_the_proxy(proxied):
    """The workers accept the proxy's address as websocket origin, and
    nothing else (docs/SECURITY.md)."""
    with urllib.request.urlopen(proxied.url, timeout=TIMEOUT) as r:
        cookie = r.headers["Set-Cookie"].split(";")[0]
        token = r.read().decode().split('"token":"')[1].split('"')[0]

    async def connect(origin):
        req = HTTPRequest(proxied.url.replace("http", "ws") + "ws",
                          headers={"Origin": origin, "Cookie": cookie}, request_timeout=TIMEOUT)
        conn = await websocket_connect(req, subprotocols=["bokeh", token])
        conn.close()

    with pytest.raises(HTTPClientError) as refused:
        asyncio.run(connect("http://evil.example.org"))
    assert refused.value.code == 403
    asyncio.run(connect(proxied.url.rstrip("/")))             # the proxy's own: accepted


@pytest.mark.slow
def test_the_launcher_serves_and_stops_everything(tmp_path):
    """`python -m devtools.deploy --workers 1 --port P`: the page through the
    proxy, then SIGTERM ends the launcher (status 0), its worker and nginx,
    and removes nginx's prefix."""
    _nginx()
    port = deploy.free_port()
    log = open(tmp_path / "deploy.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "devtools.deploy", "--workers", "1",
                             "--port", str(port)], cwd=ROOT, env=ENV, stdout=log,
                            stderr=subprocess.STDOUT)
    try:
        t0 = time.perf_counter()
        while b"Ctrl-C stops" not in (tmp_path / "deploy.log").read_bytes():
            assert proc.poll() is None, (tmp_path / "deploy.log").read_text()
            assert time.perf_counter() - t0 < 300, "the launcher was not ready in 300 s"
            time.sleep(0.2)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=TIMEOUT) as r:
            assert r.status == 200 and b"token" in r.read()
        text = (tmp_path / "deploy.log").read_text()
        prefix = text.split("prefix ")[1].split(";")[0]
        started = _tree(proc.pid)[1:]
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
    from vibtrans_explorer import server

    given = []

    def fake_serve(*args, **kwargs):
        given.append(kwargs.get("use_xheaders"))
        raise _Served
    monkeypatch.setattr(panel, "serve", fake_serve)
    monkeypatch.setattr(server, "_freeze", lambda: None)     # not in the test process
    for argv, expected in ((["serve", "--use-xheaders"], True), (["serve"], False)):
        with pytest.raises(_Served):
            server.serve(build_parser().parse_args(argv))
        assert given[-1] is expected
