"""Explorer latency in a real headless browser, sessions one after another:

    python -m devtools.bench [--points 8] [--sessions 3] [--settle 120] [--json]

Starts `vibtrans serve` (the load test's settings), then a warm-up session,
then `--sessions` sessions each clicking `--points` points of the map.
Measured: server start to ready; click to plot (the run's summary shown and
the frame after it painted), p50 and p95; the server's RSS at ready, after
the warm-up session is dropped (the baseline), at peak and once the sessions
are dropped and released (waited for at most `--settle` s).
"""

import argparse
import json
import os
import statistics
import sys
import time

from . import results
from .chromium import launched
from .loadtest import _DONE_JS, _STATE_JS, SERVE_ARGS, SERVE_ENV, _quantile
from .server import Server

_PAINTED_JS = "() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"


def _points(n):
    return [(0.30 + 0.5 * ((i * 0.618) % 1.0), 0.15 + 0.6 * ((i * 0.382) % 1.0)) for i in range(n)]


def _session(browser, url, points):
    """Open the explorer, click each point (fractions of the map's canvas)
    and wait for its run: [seconds per click]."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    try:
        page.add_init_script(_STATE_JS)
        page.goto(url)
        page.wait_for_selector("canvas", timeout=60000)
        page.wait_for_timeout(1000)
        box = page.locator("canvas").first.bounding_box()
        out = []
        for fx, fy in points:
            before = page.evaluate("window.__vtState()")["summary"]
            start = time.perf_counter()
            page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
            done = page.wait_for_function(_DONE_JS, arg=before, polling=20, timeout=120000).json_value()
            if "error" in done:
                raise RuntimeError(f"the run failed: {done['error']}")
            page.evaluate(_PAINTED_JS)
            out.append(time.perf_counter() - start)
        return out
    finally:
        page.close()


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.bench", description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=8)
    ap.add_argument("--sessions", type=int, default=3)
    ap.add_argument("--settle", type=float, default=120.0, help="seconds at most for the sessions' release")
    ap.add_argument("--json", action="store_true")
    results.add_option(ap)
    argv = sys.argv[1:] if argv is None else list(argv)
    a = ap.parse_args(argv)
    begun = results.begin()
    server = Server(SERVE_ARGS, env=SERVE_ENV)
    try:
        ready = server.wait_ready()
        rss_ready = server.rss()
        latencies = []
        with launched() as browser:
            _session(browser, server.url, _points(a.points))  # warm-up, not counted
            _, warm_released = server.wait_dropped(1, a.settle)
            rss_base = server.rss()
            server.sample()
            for _ in range(a.sessions):
                latencies += _session(browser, server.url, _points(a.points))
        peak = server.stop_sampling()
        _, released = server.wait_dropped(1 + a.sessions, a.settle)
        rss_after = server.rss()
    except BaseException:
        print(f"the server's log is kept in {server.log_dir}", file=sys.stderr)
        raise
    finally:
        server.stop()
    server.remove_logs()
    lat = sorted(latencies)
    out = {
        "server_start_to_ready_s": ready,
        "clicks": len(lat),
        "click_to_plot_p50_s": statistics.median(lat),
        "click_to_plot_p95_s": _quantile(lat, 0.95),
        "click_to_plot_max_s": lat[-1],
        "click_to_plot_s": [round(x, 3) for x in latencies],
        "rss_ready_mb": rss_ready,
        "rss_baseline_mb": rss_base,
        "rss_peak_mb": peak,
        "rss_after_mb": rss_after,
        "rss_after_vs_baseline": rss_after / rss_base - 1,
        "memory_released": warm_released and released,
        "machine": f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}",
    }
    results.save("latency", out, begun, a.results_dir, " ".join(["python -m devtools.bench", *argv]))
    if a.json:
        print(json.dumps(out))
    else:
        results.show(out)


if __name__ == "__main__":
    main()
