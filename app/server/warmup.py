"""The simulation kernels, compiled (or loaded from numba's on-disk cache)
while the server already serves pages: `vibtrans serve` starts `start()`
in a background thread once its first page is answered (app/server/serve.py),
and says on stderr what it
compiles; a run asked for before the kernels are ready waits for them
(`wait`), and the page shows `status()` meanwhile.

A cold start (empty numba cache) compiles for a minute or more on two
cores; a warm one loads the cached kernels in about a second.

The kernels of a particle that rolls (docs/MODEL.md section 11) are not in
the warm-up: most sessions never run one, and compiling them cold costs
~10-20 s of a core.  They compile in the background on their first need
(`prepare_rolling`: a session chose a rolling particle, or asked for a
run of one), after the warm-up; a rolling run asked for meanwhile waits
for them, and the page says "Compiling" (`status(scene)`)."""

import logging
import threading
import time

import vibtrans
from vibtrans.core.params import ROLLING_NONE

log = logging.getLogger("vibtrans.explorer")

# what the explorer runs: the map's two models (deformable first: the page's
# default scene), both integrators each; the vertical model and the
# threshold search are not run by the explorer
MODELS = ("deformable", "point-mass")

READY = threading.Event()
ROLLING_READY = threading.Event()  # the rolling particle's kernels
_state = {"done": 0, "total": 0, "label": "", "seconds": None, "error": None, "report": None}
_lock = threading.Lock()
_thread = None
_rolling_thread = None


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
        report(
            "compiling the kernels in the background (numba; only the first start "
            "after an install compiles, later ones load them from the cache) ..."
        )
    try:
        vibtrans.warmup(models=MODELS, progress=progress)
    except Exception as exc:  # a bug in the warm-up must not stop the server
        log.exception("compiling the kernels failed")
        with _lock:
            _state["error"] = f"{type(exc).__name__}: {exc}"
    finally:
        with _lock:
            _state["seconds"] = time.perf_counter() - t0
        READY.set()
    if report is not None:
        report(
            f"kernels ready in {_state['seconds']:.1f} s"
            + (f" (warm-up failed: {_state['error']})" if _state["error"] else "")
        )


def start(report=None, on_ready=None):
    """compile_all in a daemon thread (once per process); on_ready() is
    called from that thread when it is done."""
    global _thread
    if _thread is not None:
        return _thread
    _state["report"] = report

    def run():
        compile_all(report)
        if on_ready is not None:
            on_ready()

    _thread = threading.Thread(target=run, name="vibtrans-kernels", daemon=True)
    _thread.start()
    return _thread


def _rolls(scene):
    return scene is not None and getattr(scene, "rolling", ROLLING_NONE) != ROLLING_NONE


def compile_rolling():
    """Compile (or load) the kernels of a particle that rolls, in this
    thread: the explorer's run (with its Lyapunov tangent) and its tau
    twin's.  Sets ROLLING_READY, also when it fails (runs then compile
    what they need themselves)."""
    t0 = time.perf_counter()
    try:
        scene = vibtrans.Scene(amplitude=100.0, mass=1.0, periods=2.0, tau=0.5, rolling="solid")
        for lyapunov in (True, False):
            vibtrans.simulate(scene, window=(1.0, 1.5), lyapunov=lyapunov)
        error = None
    except Exception as exc:  # a bug here must not stop the server
        log.exception("compiling the rolling particle's kernels failed")
        error = f"{type(exc).__name__}: {exc}"
    finally:
        ROLLING_READY.set()
    report = _state["report"]
    if report is not None:
        report(
            f"rolling particle's kernels ready in {time.perf_counter() - t0:.1f} s"
            + (f" (failed: {error})" if error else "")
        )


def _after_warmup(fn):
    READY.wait()
    fn()


def prepare_rolling():
    """Compile the rolling particle's kernels in a daemon thread, once per
    process, after the warm-up: off the page's critical path (a session
    calls it when its particle first rolls).  Only where the warm-up runs
    (`vibtrans serve`): elsewhere runs compile what they need."""
    global _rolling_thread
    with _lock:
        if _thread is None or _rolling_thread is not None:
            return
        _rolling_thread = threading.Thread(
            target=_after_warmup, args=(compile_rolling,), name="vibtrans-rolling-kernels", daemon=True
        )
    _rolling_thread.start()


def ready(scene=None):
    """Whether runs (of `scene`, if given) may start: the warm-up is done,
    or was never started (an explorer outside `vibtrans serve`: runs
    compile what they need); a scene whose particle rolls also waits for
    its kernels (started here if they were not: `prepare_rolling`)."""
    if _thread is None:
        return True
    if not READY.is_set():
        return False
    if _rolls(scene):
        prepare_rolling()
        return ROLLING_READY.is_set()
    return True


def status(scene=None):
    """None once the kernels (of `scene`, if given) are ready; else a line
    for the page."""
    if ready(scene):
        return None
    if READY.is_set():  # (the rolling particle's, `ready`)
        return (
            "Compiling the kernels of a particle that rolls (once per server start: "
            "numba loads them from its cache, or compiles them after an install) "
            "..."
        )
    with _lock:
        done, total = _state["done"], _state["total"]
    count = f" ({done} of {total} ready)" if total else ""
    return (
        f"Compiling the simulation kernels{count}: this server has just started with an "
        f"empty compilation cache; the run starts as soon as they are ready ..."
    )


def wait(cancel=None, scene=None):
    """Block until the kernels (of `scene`, if given) are ready; returns
    False if `cancel` (a threading.Event) was set first."""
    while not ready(scene):
        event = ROLLING_READY if READY.is_set() else READY
        if event.wait(0.2) and ready(scene):
            break
        if cancel is not None and cancel.is_set():
            return False
    return True
