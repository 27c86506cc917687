"""The simulation kernels, compiled (or loaded from numba's on-disk cache)
while the server already serves pages: `vibtrans serve` starts `start()`
in a background thread once its first page is answered (app/server/serve.py),
and says on stderr what it
compiles; a run asked for before the kernels are ready waits for them
(`wait`), and the page shows `status()` meanwhile.

A cold start (empty numba cache) compiles for a minute or more on two
cores; a warm one loads the cached kernels in about a second."""
import logging
import threading
import time

import vibtrans

log = logging.getLogger("vibtrans.explorer")

# what the explorer runs: the map's two models (deformable first: the page's
# default scene), both integrators each; the vertical model and the
# threshold search are not run by the explorer
MODELS = ("deformable", "point-mass")

READY = threading.Event()
_state = {"done": 0, "total": 0, "label": "", "seconds": None, "error": None}
_lock = threading.Lock()
_thread = None


def compile_all(report=None):
    """Compile (or load) the explorer's kernels now, in this thread; report
    (a callable taking one line) hears each step.  Sets READY, also when the
    warm-up fails (runs then compile what they need themselves)."""
    t0 = time.perf_counter()

    def progress(done, total, label):
        with _lock:
            _state.update(done=done, total=total, label=str(label))
        if report is not None:
            report(f"kernels {done}/{total} ready ({label}), {time.perf_counter() - t0:.1f} s")

    if report is not None:
        report("compiling the kernels in the background (numba; only the first start "
               "after an install compiles, later ones load them from the cache) ...")
    try:
        vibtrans.warmup(models=MODELS, progress=progress)
    except Exception as exc:          # a bug in the warm-up must not stop the server
        log.exception("compiling the kernels failed")
        with _lock:
            _state["error"] = f"{type(exc).__name__}: {exc}"
    finally:
        with _lock:
            _state["seconds"] = time.perf_counter() - t0
        READY.set()
    if report is not None:
        report(f"kernels ready in {_state['seconds']:.1f} s"
               + (f" (warm-up failed: {_state['error']})" if _state["error"] else ""))


def start(report=None, on_ready=None):
    """compile_all in a daemon thread (once per process); on_ready() is
    called from that thread when it is done."""
    global _thread
    if _thread is not None:
        return _thread

    def run():
        compile_all(report)
        if on_ready is not None:
            on_ready()
    _thread = threading.Thread(target=run, name="vibtrans-kernels", daemon=True)
    _thread.start()
    return _thread


def ready():
    """Whether runs may start: the warm-up is done, or was never started
    (an explorer outside `vibtrans serve`: runs compile what they need)."""
    return _thread is None or READY.is_set()


def status():
    """None once the kernels are ready; else a line for the page."""
    if ready():
        return None
    with _lock:
        done, total = _state["done"], _state["total"]
    count = f" ({done} of {total} ready)" if total else ""
    return (f"Compiling the simulation kernels{count}: this server has just started with an "
            f"empty compilation cache; the run starts as soon as they are ready ...")


def wait(cancel=None):
    """Block until the kernels are ready; returns False if `cancel` (a
    threading.Event) was set first."""
    while not ready():
        if READY.wait(0.2):
            break
        if cancel is not None and cancel.is_set():
            return False
    return True
