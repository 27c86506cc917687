"""Load test of the explorer server: many concurrent sessions.

    python -m devtools.loadtest --sessions 30 --clicks 5 [--browsers 2] [--think 10] [--json]

Starts `vibtrans serve` (`--num-procs` processes; `--proxy-workers N`: N
behind nginx, devtools/deploy), then `--sessions` sessions over `--ramp`
seconds, each loading the page and clicking `--clicks` points of the map,
`--think` s (+-50%) apart.  `--browsers` of them are chromium pages (click to
plot drawn), the others protocol sessions (devtools/protoclient.py: click to
the server's reply), so that the clients' drawing does not load the
server's cores; `--maps N` of those open a link asking for a map on demand
and wait for it.  `--pin`, `--pin-server`, `--pin-clients`: the server and
the clients on disjoint cores.

Measured: click latency p50/p95/max (all, per kind, while sessions arrive
and after), page loads, errors (failed pages, clicks with no result within
--click-timeout, failed runs, JavaScript errors, tracebacks in the server's
log), the server's RSS at ready, after a warm-up session (the baseline), at
peak and once every session is dropped and released, and its CPU seconds.
Goals: p95 <= 3 s, page load p95 <= 3 s, 0 errors, RSS after within 10% of
the baseline.  Runs refused over VIBTRANS_MAX_STEPS count apart.
"""

import argparse
import asyncio
import collections
import json
import math
import os
import random
import re
import shutil
import statistics
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from urllib.parse import quote

from vibtrans_explorer.server.memory import CLOSED, EXPLORERS_HELD, HELD, RELEASE_NAME, RELEASED

from . import results
from .chromium import ARGS, CHROMIUM
from .deploy import Deployment, free_port
from .protoclient import ProtocolSession
from .server import KERNELS_READY, Measured, Server, affinity, cpu_seconds, each, rss_mb, tree

# closed sessions dropped in seconds (Bokeh's default: ~30 s); the debug log
# says which were discarded
SERVE_ARGS = ["--unused-session-lifetime", "3000", "--check-unused-sessions", "1000"]
SERVE_ENV = {"BOKEH_PY_LOG_LEVEL": "debug"}
BROWSER_NICE = 10  # the clients' chromium yields to the server it measures

# In the page: the summary's first line (bold, "... mu = ..."), the alert and
# whether the whole run is shown, through Bokeh's shadow roots.
_STATE_JS = """
window.__vtState = () => {
  const out = {summary: "", alert: "", whole: false};
  const visit = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) visit(el.shadowRoot);
      const tag = el.tagName;
      if (tag === "STRONG" && el.textContent.includes("mu = ")) out.summary = el.textContent;
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


def parse_cpus(text, option):
    """A taskset-style core list ("0", "0,2", "1-3") as a sorted list of
    cores this process may use; ValueError naming `option` otherwise."""
    allowed = sorted(os.sched_getaffinity(0))
    here = f"cores here: {_cpu_list(allowed)}"
    cpus = set()
    for part in str(text).split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            first, last = int(lo), int(hi) if sep else int(lo)
        except ValueError:
            raise ValueError(
                f"{option} must be a list of cores such as 0, 0,2 or 0-1 ({here}), got {text!r}"
            ) from None
        if first < 0 or last < first:
            raise ValueError(f"{option}: {part.strip()!r} is not a core range ({here})")
        cpus.update(range(first, last + 1))
    missing = sorted(cpus - set(allowed))
    if missing:
        one = len(missing) == 1
        raise ValueError(
            f"{option}: core{'' if one else 's'} {_cpu_list(missing)} do{'es' if one else ''} "
            f"not exist here ({here}), got {text!r}"
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
    """The command prefix that starts a process on `cpus` (taskset execs the
    command: its pid is the process's)."""
    if not cpus:
        return []
    if shutil.which("taskset") is None:
        raise RuntimeError("--pin-server needs taskset (util-linux)")
    return [shutil.which("taskset"), "-c", _cpu_list(cpus)]


def release_lines(text):
    """The explorer's lines on releasing closed sessions' memory."""
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
    """Each process's Bokeh documents still held at its last release."""
    return _held(lines, HELD)


def explorers_held(lines):
    """Each process's pages' explorers still held at its last release."""
    return _held(lines, EXPLORERS_HELD)


class ProxiedServers(Measured):
    """--proxy-workers: the workers behind nginx (devtools.deploy), measured
    as one server (nginx's own errors included, its RSS not)."""

    def __init__(self, workers, env=None, wrap=()):
        self.log_dir = tempfile.mkdtemp(prefix="vibtrans-loadtest-")
        self.deployment = Deployment(
            workers=workers,
            port=free_port(),
            serve_args=SERVE_ARGS,
            env={**os.environ, **(env or {})},
            log_dir=self.log_dir,
            wrap=wrap,
            keep=True,
        )
        self.deployment.start()
        self.url = self.deployment.url

    def wait_ready(self, timeout=300):
        return self.deployment.wait_ready(timeout) + super().wait_ready(timeout)

    def ready(self):
        return all(KERNELS_READY in t for t in self.texts())

    def pids(self):
        return self.deployment.pids()

    def server_pids(self):
        return [*super().server_pids(), *tree(self.deployment.nginx.pid)]

    def rss(self):
        return rss_mb(super().server_pids())

    def alive(self):
        return self.deployment.exited() is None

    def texts(self):
        return [Path(p).read_text(errors="replace") for p in self.deployment.logs]

    def errors(self):
        errors, benign = super().errors()
        return errors + [f"nginx: {line[:300]}" for line in self.deployment.proxy_errors()], benign

    def remove_logs(self):
        super().remove_logs()
        shutil.rmtree(self.deployment.prefix, ignore_errors=True)

    def stop(self):
        self._sampling = False
        self.deployment.stop()


def map_request(k):
    """Map session k's `map=` request: a 33 x 33 preview across the jumping
    boundary, 500 periods, at a mu of its own (no two share a computation)."""
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


def _spread(n, k):
    """k of range(n) (at most n), spread over it."""
    k = min(k, n)
    return [int((i + 0.5) * n / k) for i in range(k)] if k else []


def browser_sessions(sessions, browsers):
    """Which sessions are chromium pages."""
    return set(_spread(sessions, browsers))


def map_sessions(sessions, browsers, maps):
    """Which sessions ask for a map: `maps` of the protocol sessions."""
    protocol = [k for k in range(sessions) if k not in browser_sessions(sessions, browsers)]
    return {protocol[i] for i in _spread(len(protocol), maps)}


def _sequence(session, clicks):
    """Distinct well-spread numbers (u, v) in [0, 1)^2 for each click."""
    for c in range(clicks):
        i = session * clicks + c + 1
        yield (i * 0.6180339887) % 1.0, (i * 0.7548776662) % 1.0


def _points(session, clicks):
    """Map points as fractions of the map's canvas: the shipped map's body
    (runs of under a second to a few seconds), clear of its legend."""
    return [(0.33 + 0.42 * u, 0.22 + 0.55 * v) for u, v in _sequence(session, clicks)]


def _range_points(session, clicks):
    """The same points as fractions of the map's data ranges."""
    return [(0.33 + 0.55 * u, 0.2 + 0.6 * v) for u, v in _sequence(session, clicks)]


async def _arrive(a, k):
    """Session k's start: the sessions arrive evenly over --ramp seconds."""
    await asyncio.sleep(a.ramp * k / max(1, a.sessions - 1))


async def _clicked(result, a, rng, k, kind, start, error=None):
    """A click's outcome (a refusal, an error or its latency), then the think time."""
    if error is not None:
        result["refused" if "server's limit" in error else "errors"].append(f"session {k}: {error[:200]}")
        return
    latency = time.perf_counter() - start
    result["latencies"].append(latency)
    result[f"{kind}_latencies"].append(latency)
    result["timeline"].append((start, latency))
    await asyncio.sleep(a.think * rng.uniform(0.5, 1.5))


def _no_result(a, k, c, fx, fy, where, note=""):
    at = f"at map {where} fraction {fx:.3f}, {fy:.3f}{note}"
    return f"session {k}, click {c + 1}: no result within {a.click_timeout:g} s ({at})"


def _loaded(result, kind, t0):
    result["load_s"].append(time.perf_counter() - t0)
    result["load_kinds"].append(kind)


async def _protocol_session(url, k, a, result, rng):
    await _arrive(a, k)
    client = ProtocolSession(url, timeout=a.click_timeout)
    try:
        t0 = time.perf_counter()
        await client.open()
        _loaded(result, "protocol", t0)
        for c, (fx, fy) in enumerate(_range_points(k + a.first_point, a.clicks)):
            start = time.perf_counter()
            try:
                kind, text = await client.click(fx, fy)
            except TimeoutError:
                result["errors"].append(_no_result(a, k, c, fx, fy, "range"))
                continue
            await _clicked(result, a, rng, k, "protocol", start, error=text if kind == "error" else None)
    except Exception as exc:  # noqa: BLE001 - counted, reported
        result["errors"].append(f"session {k}: {type(exc).__name__}: {str(exc)[:200]}")
    finally:
        client.close()


async def _map_session(url, k, a, result, index):
    """A researcher: a link asking for a map, waited for until finished."""
    await _arrive(a, k)
    client = ProtocolSession(url, timeout=a.click_timeout, query=f"?map={quote(map_request(index))}")
    try:
        t0 = time.perf_counter()
        await client.open()
        ended = client.map_ended()  # before any await: its end cannot be missed
        _loaded(result, "map", t0)
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
    """One person in chromium: open the page, click the map a.clicks times."""
    await _arrive(a, k)
    context = await browser.new_context(viewport={"width": 1400, "height": 1000})
    await context.add_init_script(_STATE_JS)
    page = await context.new_page()
    js_errors = []
    page.on("pageerror", lambda e: js_errors.append(str(e)))
    timeout = a.click_timeout * 1000
    try:
        t0 = time.perf_counter()
        await page.goto(url, timeout=timeout)
        await page.wait_for_selector("canvas", timeout=timeout)
        await page.get_by_text("Paper points").first.wait_for(timeout=timeout)
        # every root rendered: before that a click on the map can be lost
        await page.wait_for_function(_IDLE_JS, polling=100, timeout=timeout)
        _loaded(result, "browser", t0)
        await page.wait_for_timeout(500)
        box = await page.locator("canvas").first.bounding_box()
        for c, (fx, fy) in enumerate(_points(k + a.first_point, a.clicks)):
            before = (await page.evaluate("window.__vtState()"))["summary"]
            start = time.perf_counter()
            await page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
            try:
                handle = await page.wait_for_function(_DONE_JS, arg=before, polling=100, timeout=timeout)
                done = await handle.json_value()
            except Exception as exc:  # noqa: BLE001 - counted, reported
                note = f"; {type(exc).__name__}"
                result["errors"].append(_no_result(a, k, c, fx, fy, "canvas", note))
                continue
            await _clicked(result, a, rng, k, "browser", start, error=done.get("error"))
    except Exception as exc:  # noqa: BLE001 - counted, reported
        result["errors"].append(f"session {k}: {type(exc).__name__}: {str(exc)[:200]}")
    finally:
        result["errors"] += [f"session {k}: JavaScript error: {e[:200]}" for e in js_errors]
        await context.close()


async def _drive(url, a, sessions, result, seed):
    rng = random.Random(seed)
    in_browser = browser_sessions(sessions, a.browsers)
    asking = sorted(map_sessions(sessions, a.browsers, a.maps))

    def session(k, browser=None):
        if k in in_browser:
            return _session(browser, url, k, a, result, rng)
        if k in asking:
            return _map_session(url, k, a, result, asking.index(k))
        return _protocol_session(url, k, a, result, rng)

    if not in_browser:
        await _gather([session(k) for k in range(sessions)], a, result)
        return
    from playwright.async_api import async_playwright

    before = set(tree(os.getpid()))  # the server and the like: not clients
    async with async_playwright() as p:
        browser = await p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        started = set(tree(os.getpid())) - before
        each(started, lambda q: "chrom" in q.name() and q.nice(BROWSER_NICE))  # renderers inherit it
        # the clients' cores, read back: this process and what it started for them
        result["client_cores"] = affinity([os.getpid(), *started])
        try:
            await _gather([session(k, browser) for k in range(sessions)], a, result)
        finally:
            await browser.close()


async def _gather(coroutines, a, result):
    tasks = [asyncio.create_task(c) for c in coroutines]
    _, pending = await asyncio.wait(tasks, timeout=a.timeout)
    for t in pending:
        t.cancel()
    if pending:
        result["errors"].append(f"{len(pending)} sessions not finished within --timeout {a.timeout:g} s")
        await asyncio.gather(*pending, return_exceptions=True)


def _new_result():
    lists = "latencies browser_latencies protocol_latencies timeline errors refused load_s load_kinds map_s"
    return {k: [] for k in lists.split()}


def _quantile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))] if v else math.nan


def _figures(name, values, *which):
    """{name_p50_s, name_p95_s, ...}: the figures `which` of `values` (NaN if none)."""
    get = {
        "p50": statistics.median,
        "p95": lambda v: _quantile(v, 0.95),
        "max": max,
        "mean": statistics.fmean,
    }
    return {f"{name}_{w}_s": get[w](values) if values else math.nan for w in which}


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
    env = {**SERVE_ENV, "VIBTRANS_MAP_CACHE": map_cache}
    if a.proxy_workers:
        server = ProxiedServers(a.proxy_workers, env=env, wrap=wrap)
    else:
        server = Server(SERVE_ARGS, env=env, wrap=wrap, num_procs=a.num_procs)
    try:
        if a.pin_clients:  # this thread and all it starts from now on
            os.sched_setaffinity(0, a.pin_clients)
        ready = server.wait_ready()
        server_affinity = affinity(server.server_pids())
        rss_ready = server.rss()
        # warm-up: one session, one click, closed and dropped -> the baseline
        warm = _new_result()
        one = dict(sessions=1, clicks=1, think=0.0, ramp=0.0, first_point=997, maps=0)
        asyncio.run(_drive(server.url, argparse.Namespace(**{**vars(a), **one}), 1, warm, 1))
        _, warm_released = server.wait_dropped(1, a.settle)
        rss_base = server.rss()
        result = _new_result()
        server.sample()
        cpu0 = cpu_seconds(server.server_pids())
        t0 = time.perf_counter()
        asyncio.run(_drive(server.url, a, a.sessions, result, 2))
        load_wall = time.perf_counter() - t0
        server_cpu = cpu_seconds(server.server_pids()) - cpu0
        client_cores = sorted(set(result.get("client_cores", [])) | set(affinity([os.getpid()])))
        rss_closed = server.rss()
        settle, released = server.wait_dropped(1 + a.sessions, a.settle)
        peak = server.stop_sampling()
        rss_after = server.rss()
        rss_by_process = {str(q): round(rss_mb([q]), 1) for q in server.server_pids()}
        text = server.text()
        releases = release_lines(text)
        closes = collections.Counter(re.findall(rf"{CLOSED} \(process (\d+)\)", text))
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
    lat, loads = result["latencies"], result["load_s"]
    arriving = [x for start, x in result["timeline"] if start - t0 <= a.ramp]
    settled = [x for start, x in result["timeline"] if start - t0 > a.ramp]
    errors = warm["errors"] + result["errors"] + [f"server log: {e}" for e in server_errors]
    if not alive:
        errors.append("server not alive after the load")
    count = len(errors)  # the note below is not an error
    if errors:
        errors.append(f"the server's log is kept in {server.log_dir}")
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
        **_figures("click_to_plot", lat, "p50", "p95", "max", "mean"),
        "browser_sessions": len(browser_sessions(a.sessions, a.browsers)),
        "browser_clicks": len(result["browser_latencies"]),
        **_figures("browser_click_to_plot", result["browser_latencies"], "p50", "p95"),
        "protocol_clicks": len(result["protocol_latencies"]),
        **_figures("protocol_click_to_data", result["protocol_latencies"], "p50", "p95"),
        # the slow clicks are those made while pages still load
        "click_to_plot_p95_while_arriving_s": _quantile(arriving, 0.95),
        "click_to_plot_p95_after_arrivals_s": _quantile(settled, 0.95),
        **_figures("page_load", loads, "p50", "p95", "max"),
        # which pages are slow: [[kind (protocol, map or browser), seconds], ...], slowest first
        "page_loads": sorted(
            ([k, round(t, 3)] for k, t in zip(result["load_kinds"], loads)), key=lambda kt: -kt[1]
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
        "rss_after_by_process_mb": rss_by_process,
        "release_lines": releases,
        "documents_held_by_process": documents_held(releases),
        "explorers_held_by_process": explorers_held(releases),
        # a session whose page and websocket reached two processes is built in both
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
    out["goal_p95_3s"] = out["click_to_plot_p95_s"] <= 3.0  # NaN (nothing measured): missed
    out["goal_page_load_p95_3s"] = out["page_load_p95_s"] <= 3.0
    out["goal_errors_0"] = out["errors"] == 0
    out["goal_rss_within_10pct"] = abs(out["rss_after_over_baseline"]) <= 0.10
    out["goal_maps_finished"] = out["maps_finished"] == out["map_sessions"]
    return out


def parser():
    ap = argparse.ArgumentParser(prog="python -m devtools.loadtest", description=__doc__.splitlines()[0])
    count, seconds = results.bounded(int, 0, 100), results.bounded(float, 0, 86400)
    ap.add_argument("--sessions", type=results.bounded(int, 1, 100), default=30, help="concurrent sessions")
    ap.add_argument("--clicks", type=results.bounded(int, 1, 50), default=5, help="map clicks per session")
    ap.add_argument("--browsers", type=count, default=2, help="sessions that are chromium pages")
    ap.add_argument(
        "--maps", type=count, default=0, help="protocol sessions that ask for a map, not clicking"
    )
    ap.add_argument("--think", type=seconds, default=10.0, help="seconds between a result and the next click")
    ap.add_argument("--ramp", type=seconds, default=30.0, help="seconds over which the sessions start")
    ap.add_argument(
        "--click-timeout", type=seconds, default=180.0, help="seconds a click or page load may take"
    )
    ap.add_argument("--timeout", type=seconds, default=1500.0, help="seconds for all the sessions")
    ap.add_argument("--settle", type=seconds, default=120.0, help="seconds for closed sessions to be dropped")
    ap.add_argument("--num-procs", type=int, default=1, help="server processes")
    ap.add_argument(
        "--proxy-workers",
        type=results.bounded(int, 0, 16),
        default=0,
        metavar="N",
        help="N `vibtrans serve` behind nginx (devtools/deploy; 0: no proxy)",
    )
    ap.add_argument(
        "--pin", action="store_true", help="the server on this process's first core, clients on the second"
    )
    ap.add_argument("--pin-server", metavar="CPUS", help="cores for the server (taskset list: 0, 0,2, 0-1)")
    ap.add_argument("--pin-clients", metavar="CPUS", help="cores for the clients (this process, chromium)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    results.add_option(ap)
    return ap


def _pinning(ap, a):
    """--pin / --pin-server / --pin-clients -> a.pin_server, a.pin_clients
    (lists of cores, or None)."""
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
    """The command line as checked options (argparse's error otherwise)."""
    ap = parser()
    a = ap.parse_args(argv)
    a.argv, a.first_point = argv, 0
    if a.browsers > a.sessions:
        ap.error(f"--browsers must be in [0, --sessions = {a.sessions}], got {a.browsers}")
    if a.maps > a.sessions - a.browsers:
        ap.error(f"--maps must be in [0, --sessions - --browsers = {a.sessions - a.browsers}], got {a.maps}")
    if a.proxy_workers and a.num_procs != 1:
        ap.error("--num-procs and --proxy-workers exclude each other (a proxy's worker is one process)")
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
        results.show(out)
    return out


if __name__ == "__main__":
    main()
