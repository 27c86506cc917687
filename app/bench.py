"""Explorer latency benchmark, in a real headless browser:

    python -m app.bench [--points 8] [--sessions 3]

Measures server start to ready, then click-to-plot latency (tap on the map
until the run's summary is shown) for 2000-period standard scenes at several
map points, p50 and p95, and the server's memory before, during and after the
sessions (RSS, from /proc).  Needs Debian's chromium (make test installs it).
"""
import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]


def _rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def _text(page):
    """The run summary's first line (pierces Bokeh's shadow DOM)."""
    loc = page.get_by_text("mu = 0.3")
    try:
        return " | ".join(loc.all_inner_texts())
    except Exception:
        return ""


def _port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main(argv=None):
    from playwright.sync_api import sync_playwright
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=8)
    ap.add_argument("--sessions", type=int, default=3)
    ap.add_argument("--settle", type=float, default=45.0,
                    help="seconds to wait after the sessions close before the last RSS "
                         "(Bokeh discards unused sessions after ~15-30 s)")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    port = _port()
    url = f"http://127.0.0.1:{port}/"
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "vibtrans.cli", "serve", "--port", str(port)],
                            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while True:
            try:
                urllib.request.urlopen(url, timeout=5)
                break
            except OSError:
                if time.perf_counter() - t0 > 300:
                    raise RuntimeError("server not ready in 300 s")
                time.sleep(0.2)
        ready = time.perf_counter() - t0
        rss0 = _rss_mb(proc.pid)
        latencies, rss_peak = [], rss0
        rng = [(0.30 + 0.5 * ((i * 0.618) % 1.0), 0.15 + 0.6 * ((i * 0.382) % 1.0))
               for i in range(a.points)]
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium", headless=True,
                                        args=ARGS)
            for s in range(a.sessions):
                page = browser.new_page(viewport={"width": 1400, "height": 1000})
                page.goto(url)
                page.wait_for_selector("canvas", timeout=60000)
                page.wait_for_timeout(1000)
                box = page.locator("canvas").first.bounding_box()
                for fx, fy in rng:
                    before = _text(page)
                    start = time.perf_counter()
                    page.mouse.click(box["x"] + box["width"] * fx, box["y"] + box["height"] * fy)
                    while _text(page) == before or "Running" in _text(page):
                        if time.perf_counter() - start > 120:
                            raise RuntimeError("no plot within 120 s")
                        time.sleep(0.02)
                    page.get_by_text("Whole run").first.wait_for(timeout=120000)
                    latencies.append(time.perf_counter() - start)
                    rss_peak = max(rss_peak, _rss_mb(proc.pid))
                page.close()
            browser.close()
        time.sleep(a.settle)
        rss_after = _rss_mb(proc.pid)
    finally:
        proc.terminate()
        proc.wait(10)
    lat = sorted(latencies)
    out = {"server_start_to_ready_s": ready, "clicks": len(lat),
           "click_to_plot_p50_s": statistics.median(lat),
           "click_to_plot_p95_s": lat[min(len(lat) - 1, int(round(0.95 * (len(lat) - 1))))],
           "rss_before_mb": rss0, "rss_peak_mb": rss_peak, "rss_after_mb": rss_after,
           "machine": f"{os.cpu_count()} cores"}
    if a.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:>26}: {v:.3f}" if isinstance(v, float) else f"{k:>26}: {v}")


if __name__ == "__main__":
    main()
