"""The locked door (docs/SECURITY.md): no input evaluated as code, the
websocket origin restricted to localhost unless configured, no admin or
debug endpoints, the container runs as non-root.  The server tests start a
real `vibtrans serve` and talk HTTP/websocket to it."""

import ast
import re
import socket
import urllib.error
import urllib.request
from argparse import Namespace
from pathlib import Path

import pytest
from budget import budget

from vibtrans.cli import build_parser
from vibtrans.core.errors import InputError
from vibtrans_explorer.server.serve import origins as _origins

ROOT = Path(__file__).resolve().parents[2]
SOURCES = sorted([*ROOT.glob("vibtrans/**/*.py"), *ROOT.glob("app/**/*.py"), *ROOT.glob("devtools/**/*.py")])
# modules that start processes on purpose (the benches' server and the
# deployment start `vibtrans serve`, the deployment nginx, the session-cost
# measurement stops its profiled server; the sweep's process pool; a bench
# record's git commit): argument lists, no shell
SUBPROCESS_OK = {
    "devtools/server.py",
    "devtools/sessioncpu.py",
    "devtools/deploy/__init__.py",
    "vibtrans/tools/bench.py",
    "vibtrans/maps/sweep.py",
    "vibtrans/tools/results.py",
}


# ------------------------------------------------------------------ no code from input
def _calls_and_imports(path):
    tree = ast.parse(path.read_text(), filename=str(path))
    calls, imports = [], []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Name):
                calls.append((f.id, node))
            elif isinstance(f, ast.Attribute):
                owner = f.value.id if isinstance(f.value, ast.Name) else "?"
                calls.append((f"{owner}.{f.attr}", node))
        elif isinstance(node, ast.Import):
            imports += [a.name.split(".")[0] for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            imports.append(node.module.split(".")[0])
    return calls, imports


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_code_is_evaluated_from_data(path):
    calls, imports = _calls_and_imports(path)
    rel = str(path.relative_to(ROOT))
    evaluated = [
        n
        for n, _ in calls
        if n in ("eval", "exec", "compile", "__import__", "os.system", "os.popen", "builtins.eval")
    ]
    assert not evaluated, (rel, evaluated)
    loaders = {"pickle", "cPickle", "marshal", "shelve", "dill", "cloudpickle", "yaml", "jsonpickle"}
    assert not (set(imports) & loaders), (rel, set(imports) & loaders)
    for name, node in calls:
        if any(k.arg == "shell" and getattr(k.value, "value", False) is not False for k in node.keywords):
            pytest.fail(f"{rel}: {name}(..., shell=...)")
    if "subprocess" in imports:
        assert rel in SUBPROCESS_OK, rel


# ------------------------------------------------------------------ websocket origin
def _args(**kw):
    return Namespace(**{"allow_websocket_origin": None, "port": 5006, **kw})


def test_origin_defaults_to_localhost(monkeypatch):
    monkeypatch.delenv("VIBTRANS_ALLOWED_ORIGINS", raising=False)
    assert _origins(_args(port=7000)) == ["localhost:7000", "127.0.0.1:7000"]


def test_origin_from_environment_and_option(monkeypatch):
    monkeypatch.setenv("VIBTRANS_ALLOWED_ORIGINS", "vib.example.org, vib.example.org:8443")
    assert _origins(_args()) == ["vib.example.org", "vib.example.org:8443"]
    # the option wins over the environment
    assert _origins(_args(allow_websocket_origin=["a.example:443"])) == ["a.example:443"]
    monkeypatch.setenv("VIBTRANS_ALLOWED_ORIGINS", " , ")
    assert _origins(_args(port=7001)) == ["localhost:7001", "127.0.0.1:7001"]


@pytest.mark.parametrize("bad", ["https://vib.example.org", "vib.example.org/app", "a b"])
def test_origin_must_be_a_host(monkeypatch, bad):
    monkeypatch.delenv("VIBTRANS_ALLOWED_ORIGINS", raising=False)
    with pytest.raises(InputError, match="allow_websocket_origin must be HOST"):
        _origins(_args(allow_websocket_origin=[bad]))


def test_serve_options_parse():
    a = build_parser().parse_args(
        [
            "serve",
            "--allow-websocket-origin",
            "x.org",
            "--allow-websocket-origin",
            "y.org:8443",
            "--num-procs",
            "2",
        ]
    )
    assert a.allow_websocket_origin == ["x.org", "y.org:8443"] and a.num_procs == 2


@pytest.fixture(scope="module")
def server(served_explorer):
    """The session's `vibtrans serve` as shipped (conftest.py): its port."""
    return served_explorer.port


def _status(url):
    try:
        with urllib.request.urlopen(url, timeout=budget(30)) as r:
            return r.status, r.read().decode(errors="replace")
    except urllib.error.HTTPError as e:
        return e.code, e.read().decode(errors="replace")


def _ws_status(port, origin):
    """HTTP status of a websocket upgrade to /ws sent with `origin`."""
    with socket.create_connection(("127.0.0.1", port), timeout=budget(30)) as s:
        s.sendall(
            (
                f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                f"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                f"Sec-WebSocket-Version: 13\r\nOrigin: {origin}\r\n\r\n"
            ).encode()
        )
        head = s.recv(4096).decode(errors="replace")
    return int(head.split()[1])


def test_websocket_refuses_other_origins(server):
    for origin in (
        "http://evil.example",
        f"http://evil.example:{server}",
        f"http://localhost.evil.example:{server}",
        "null",
    ):
        assert _ws_status(server, origin) == 403, origin
    # the page's own origin passes the origin check (Bokeh then wants a
    # session token; anything but 403 means the origin was accepted)
    assert _ws_status(server, f"http://localhost:{server}") != 403
    assert _ws_status(server, f"http://127.0.0.1:{server}") != 403


@pytest.mark.parametrize(
    "path",
    [
        "/admin",
        "/admin/",
        "/admin/?",
        "/rest/session_info",
        "/debug",
        "/metadata/../admin",
        "/static/",
        "/components/..%2F..%2F..%2F..%2Fetc%2Fpasswd",
        "/static/..%2F..%2F..%2Fetc%2Fpasswd",
        "/?bokeh-admin=1",
    ],
)
def test_no_admin_or_debug_endpoints(server, path):
    code, body = _status(f"http://127.0.0.1:{server}{path}")
    if path == "/?bokeh-admin=1":
        assert code == 200 and "admin" not in body.lower()  # just the explorer
        return
    assert code in (403, 404, 405), (path, code)
    assert "Traceback" not in body and "root:" not in body, body[:500]


def test_components_route_imports_no_module_from_the_url(server):
    # Panel's handler imports /components/<module>/... before any check:
    # json would be imported and the bad resource type answered 403.  The
    # server's own route refuses every module but panel's with 404, first.
    for path in (
        "/components/json/JSONDecoder/notvalid/x",
        "/components/antigravity/__name__/notvalid/x",
        "/components/vibtrans.cli/main/__css__/x",
    ):
        code, _ = _status(f"http://127.0.0.1:{server}{path}")
        assert code == 404, (path, code)


def test_liveness_is_the_only_extra_endpoint(server):
    code, body = _status(f"http://127.0.0.1:{server}/liveness")
    assert code == 200
    assert "Traceback" not in body


# ------------------------------------------------------------------ the container
def test_dockerfile_runs_as_non_root():
    lines = [
        ln.strip()
        for ln in (ROOT / "Dockerfile").read_text().splitlines()
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    users = [i for i, ln in enumerate(lines) if ln.upper().startswith("USER ")]
    cmd = max(i for i, ln in enumerate(lines) if ln.upper().startswith(("CMD", "ENTRYPOINT")))
    assert users and users[-1] < cmd
    user = lines[users[-1]].split(None, 1)[1].split(":")[0]
    assert user not in ("root", "0")
    assert re.search(rf"useradd\b.*\b{re.escape(user)}\b", "\n".join(lines))
    # the container serves on every interface, so its origin must be set
    assert "VIBTRANS_ALLOWED_ORIGINS" in "\n".join(lines)
