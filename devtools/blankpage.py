"""A bug's reproduction, kept as its check: the first pages after `vibtrans
serve` started were sometimes blank.

    python -m devtools.blankpage [--trials 40] [--lifetime MS]

Each trial starts a server, asks for its page once without a browser (as
the tests' fixture and the load test do to wait for it: a session is made
and never connected), waits for "kernels ready" (the maps' pre-rendering
starts then), opens the page in chromium and waits for a canvas.  Seen on
2026-11-25 with the maps pre-rendered in the kernels' thread: about one
trial in ten showed a blank page whose BokehJS logged "Error rendering
Bokeh items: TypeError: n is not iterable" (in a glyph's set_visuals),
the server idle and responsive; also with the code of 2026-11-24
(66cf63c) and with --lifetime 120000 (the first session kept); not in 34
trials without the browserless request, nor in 24 with no pre-rendering;
still with every HoloViews build and render and the map figures' decoding
holding one lock.  The pre-rendering now runs on the event loop, one map
per turn (app/server.py): no blank page since (the note of that change
gives the trials).  Why a thread's timing broke the page is not known.
Prints each trial's seconds to the canvas, and for a blank page the
browser's console errors; exits 1 if any page was blank."""
import argparse
import os
import subprocess
import sys
import tempfile
import time
import urllib.request

from devtools.chromium import launched
from devtools.firstpage import _port, _vibtrans


def _wait(condition, seconds, step=0.1):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(step)
    return False


def _answers(url):
    try:
        with urllib.request.urlopen(url, timeout=2):
            return True
    except OSError:
        return False


def trial(browser, lifetime=None, timeout=30.0):
    """(seconds to the canvas or None, console errors)."""
    port = _port()
    url = f"http://127.0.0.1:{port}/"
    extra = ["--unused-session-lifetime", str(lifetime)] if lifetime else []
    with tempfile.NamedTemporaryFile("w+", suffix=".log") as log:
        server = subprocess.Popen([*_vibtrans(), "serve", "--port", str(port), *extra],
                                  stdout=log, stderr=subprocess.STDOUT)
        try:
            if not _wait(lambda: _answers(url + "liveness"), 120):
                raise RuntimeError("the server did not start")
            urllib.request.urlopen(url, timeout=60).read()     # a session never connected
            _wait(lambda: "kernels ready" in open(log.name).read(), 60, 0.05)
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            console = []
            page.on("console", lambda m: console.append(m.text))
            try:
                t0 = time.perf_counter()
                page.goto(url)
                try:
                    page.wait_for_selector("canvas", timeout=timeout * 1000)
                    return time.perf_counter() - t0, []
                except Exception:      # noqa: BLE001 - the blank page being looked for
                    return None, [c.splitlines()[0] for c in console if "Error" in c]
            finally:
                page.close()
        finally:
            server.terminate()
            server.wait(30)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m devtools.blankpage", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trials", type=int, default=40)
    p.add_argument("--lifetime", type=int, default=None,
                   help="the server's --unused-session-lifetime (ms)")
    a = p.parse_args(argv)
    blank = 0
    with launched() as browser:
        for k in range(a.trials):
            seconds, errors = trial(browser, a.lifetime)
            if seconds is None:
                blank += 1
                print(f"{k}: BLANK PAGE; console: {errors}", flush=True)
            else:
                print(f"{k}: canvas after {seconds:.2f} s", flush=True)
    print(f"{blank} blank of {a.trials} first pages")
    return 1 if blank else 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    sys.exit(main())
