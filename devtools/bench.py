"""Explorer latency benchmark, in a real headless browser:

    python -m devtools.bench [--points 8] [--sessions 3] [--settle 120] [--json]

Starts `vibtrans serve` (closed sessions dropped after 3 s, checked every
second), measures server start to ready, then runs one warm-up session (as
the measured ones) and waits until it is dropped: the server's RSS then is
the baseline (one-time growth: imports, caches, allocator arenas).
Then `--sessions` sessions one after the other, each clicking `--points`
points of the map; click-to-plot latency is from the click until the run's
summary is shown and the browser has painted the frame after it (two
animation frames; the explorer sends the figures' new data in the same held
batch of changes as the summary), p50 and p95 over all clicks.  Memory: the server's RSS (from
/proc) at ready, the baseline, the peak during the sessions and after they
are closed, dropped and their memory released (the explorer's log line;
waited for at most `--settle` seconds), with after/baseline.  The server
is devtools/loadtest.py's.  Needs Debian's chromium (make test installs it).
"""

import argparse
import json
import os
import statistics
import sys
import time

from . import results
from .loadtest import ARGS, CHROMIUM, Server, _quantile

# In the page: the summary's first line (bold, "... mu = ..."), the alert,
# found through Bokeh's shadow roots; polled inside the page.
_SUMMARY_JS = """
() => {
  let summary = "", alert = "";
  const visit = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) visit(el.shadowRoot);
      if (el.tagName === "STRONG" && el.textContent.includes("mu = ")) summary = el.textContent;
      else if (el.classList && el.classList.contains("alert") && el.offsetParent !== null)
        alert = el.textContent;
    }
  };
  visit(document);
  return {summary, alert};
}
"""
_DONE_JS = (
    "(before) => { const s = ("
    + _SUMMARY_JS
    + """)();
  if (s.alert) return {error: s.alert};
  return s.summary && s.summary !== before ? s : null; }"""
)
_PAINTED_JS = "() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"


def _points(n):
    return [(0.30 + 0.5 * ((i * 0.618) % 1.0), 0.15 + 0.6 * ((i * 0.382) % 1.0)) for i in range(n)]


def _session(browser, url, points, on_click=None):
    """Open the explorer, click each point of the map (fractions of the
    map's canvas) and wait for its run: [seconds per click]."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    try:
        page.goto(url)
        page.wait_for_selector("canvas", timeout=60000)
        page.wait_for_timeout(1000)
        box = page.locator("canvas").first.bounding_box()
        out = []
        for fx, fy in points:
            before = page.evaluate(_SUMMARY_JS)["summary"]
            start = time.perf_counter()
            page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
            done = page.wait_for_function(_DONE_JS, arg=before, polling=20, timeout=120000).json_value()
            if "error" in done:
                raise RuntimeError(f"the run failed: {done['error']}")
            page.evaluate(_PAINTED_JS)
            out.append(time.perf_counter() - start)
            if on_click is not None:
                on_click()
        return out
    finally:
        page.close()


def main(argv=None):
    from playwright.sync_api import sync_playwright

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=8)
    ap.add_argument("--sessions", type=int, default=3)
    ap.add_argument(
        "--settle",
        type=float,
        default=120.0,
        help="at most this many seconds to wait for closed sessions to be dropped and their memory released",
    )
    ap.add_argument("--json", action="store_true")
    results.add_option(ap)
    argv = sys.argv[1:] if argv is None else list(argv)
    a = ap.parse_args(argv)
    begun = results.begin()
    server = Server()
    try:
        ready = server.wait_ready()
        rss_ready = server.rss()
        latencies = []
        peak = [rss_ready]

        def sample():
            peak[0] = max(peak[0], server.rss())

        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
            _session(browser, server.url, _points(a.points))  # warm-up, not counted
            _, warm_released = server.wait_dropped(1, a.settle)
            rss_base = server.rss()
            peak[0] = rss_base
            for _ in range(a.sessions):
                latencies += _session(browser, server.url, _points(a.points), on_click=sample)
                sample()
            browser.close()
        _, released = server.wait_dropped(1 + a.sessions, a.settle)
        rss_after = server.rss()
    except BaseException:
        print(f"the server's log is kept in {server.log.name}", file=sys.stderr)
        raise
    finally:
        server.stop()
    os.remove(server.log.name)
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
        "rss_peak_mb": peak[0],
        "rss_after_mb": rss_after,
        "rss_after_vs_baseline": rss_after / rss_base - 1,
        "memory_released": warm_released and released,
        "machine": f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}",
    }
    results.save("latency", out, begun, a.results_dir, " ".join(["python -m devtools.bench", *argv]))
    if a.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:>26}: {v:.3f}" if isinstance(v, float) else f"{k:>26}: {v}")


if __name__ == "__main__":
    main()
