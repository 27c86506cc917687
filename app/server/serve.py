"""`vibtrans serve`: the explorer's web server (Panel on Tornado).

The library's command line reaches it through one lazy import
(vibtrans.cli.cmd_serve), so `import vibtrans` and the other commands never
load Panel.  Start-up, each step said on stderr:

1. the options and websocket origins are checked (InputError: one line,
   exit status 2);
2. the process re-executes itself on the C allocator (PYTHONMALLOC=malloc);
3. the shipped maps are loaded and verified: a damaged, foreign or missing
   map refuses the start;
4. the server listens and serves pages while the simulation kernels compile
   in a background thread (warmup.py; "kernels 1/2 ready (...)"), started
   once the first page is answered (or KERNELS_AFTER s after listening if
   none is asked for); a run asked for before they are ready waits, with a
   message in the page.
"""

import gc
import logging
import os
import re
import sys
import threading
import time

from vibtrans.core.errors import InputError
from vibtrans_explorer.server import memory


def _age():
    """Seconds since this process started (the command, before the
    re-execution: same pid), from /proc; None elsewhere."""
    try:
        with open("/proc/self/stat") as f:
            start = int(f.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as f:
            up = float(f.read().split()[0])
        return up - start / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


_SAY = threading.Lock()
# the command's start on the monotonic clock (kept by the processes that
# --num-procs forks, whose own start /proc would give)
_AGE = _age()
_STARTED = None if _AGE is None else time.monotonic() - _AGE


def _process():
    """ "process K/N: " in a process forked by --num-procs (Tornado's task
    id), else ""."""
    from tornado.process import task_id

    k = task_id()
    return "" if k is None else f"process {k + 1}/{_PROCESSES[0]}: "


_PROCESSES = [1]


def say(line):
    """One line of start-up progress on stderr, with the seconds since the
    command started (and which process, with --num-procs > 1).  Whole lines
    under a lock: the kernels' thread speaks too, and print() writes the
    text and its newline separately."""
    when = "" if _STARTED is None else f"[{time.monotonic() - _STARTED:.1f} s] "
    with _SAY:
        sys.stderr.write(f"vibtrans serve: {when}{_process()}{line}\n")
        sys.stderr.flush()


def origins(args):
    """Hosts whose pages may open the explorer's websocket: --allow-websocket-origin,
    else $VIBTRANS_ALLOWED_ORIGINS (comma-separated), else this port on localhost."""
    given = args.allow_websocket_origin
    if not given:
        env = os.environ.get("VIBTRANS_ALLOWED_ORIGINS", "")
        given = [o for o in env.split(",")]
    found = [o.strip() for o in given if o.strip()]
    if not found:
        return [f"localhost:{args.port}", f"127.0.0.1:{args.port}"]
    for o in found:
        if "://" in o or "/" in o or any(c.isspace() for c in o):
            raise InputError(f"allow_websocket_origin must be HOST[:PORT] (no scheme, no path), got {o!r}")
    return found


def component_routes():
    """Panel's /components/ route imports the module named in the URL before
    it checks anything (/components/<module>/...): any installed module, run
    at a stranger's request.  Served here for panel's own modules only (the
    explorer requests none)."""
    from panel.io.server import COMPONENT_PATH, ComponentResourceHandler
    from tornado.web import HTTPError

    class PanelComponents(ComponentResourceHandler):
        def parse_url_path(self, path):
            module = path.split("/", 1)[0]
            if module != "panel" and not module.startswith("panel."):
                raise HTTPError(404)
            return super().parse_url_path(path)

    return [(f"/{COMPONENT_PATH}(.*)", PanelComponents, {})]


def _log_to_stderr(logger):
    """The server's own INFO lines (e.g. memory released after sessions
    close) beside Bokeh's, in Bokeh's format."""
    if not logger.handlers:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("%(asctime)s - %(name)s - %(levelname)s - %(message)s"))
        logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    logger.propagate = False


def _check(args):
    if not 1 <= args.port <= 65535:
        raise InputError(f"port must be in [1, 65535], got {args.port}")
    if not 0 <= args.num_procs <= 64:
        raise InputError(f"num_procs must be in [0, 64] (0: one per core), got {args.num_procs}")
    cores = getattr(args, "map_cores", None)
    if cores is not None and not 1 <= cores <= 256:
        raise InputError(f"map-cores must be in [1, 256], got {cores}")
    scheduler = getattr(args, "scheduler", None)
    if scheduler is not None and not re.fullmatch(r"(tcp|tls|inproc)://[^\s/]+(:\d+)?", scheduler):
        raise InputError(f"scheduler must be an address such as tcp://HOST:PORT, got {scheduler!r}")
    mb = getattr(args, "map_cache_mb", None)
    if mb is not None and not 1 <= mb <= 10**7:
        raise InputError(f"map-cache-mb must be in [1, 10000000] (MB), got {mb}")
    for name in ("unused_session_lifetime", "check_unused_sessions"):
        if not 100 <= getattr(args, name) <= 86_400_000:
            raise InputError(f"{name} must be in [100, 86400000] ms, got {getattr(args, name)}")
    return origins(args)


def _reexec_on_c_allocator(args):
    """Python's small-object allocator keeps a 256 KiB arena while any
    object in it lives, so the memory of closed sessions, interleaved with
    the survivors of thirty concurrent ones, stayed with the process
    (+31-35% of the baseline after all closed); with the C allocator, the
    release after sessions close (malloc_trim) hands it back (+2.5-5.8%;
    `python -m devtools.loadtest`).  Set PYTHONMALLOC to opt out.  Only a
    real command line is re-executed (args.argv set by vibtrans.cli.main):
    callers of main(argv) (tests, scripts) keep their process."""
    if os.environ.get("PYTHONMALLOC") is None and getattr(args, "argv", None) is not None:
        os.execve(
            sys.executable,
            [sys.executable, "-m", "vibtrans.cli", *args.argv],
            dict(os.environ, PYTHONMALLOC="malloc"),
        )


def _freeze():
    """What the imports (and the warm-up) built (~10^6 objects: modules, JIT
    dispatchers, maps) lives as long as the server: leave it out of the
    cyclic collector, whose full passes would otherwise walk it all while
    every session waits (memory.py: pages are frozen too, until released)."""
    gc.collect()
    gc.freeze()


# Seconds after listening to start the kernels' warm-up if no page was asked
# for.  Otherwise it starts once the first page is answered: loading the
# cached kernels (~1.5 s, holding the GIL) beside the first page's build
# delayed that page by as much on two cores, while the kernels are needed
# only at the first run; a cold start's compilation (a minute) starts a
# second or two later and ends about as late (the same CPU).
KERNELS_AFTER = 2.0
# Seconds between two of the maps' pre-renders on the event loop (a page's
# messages go between them)
PRERENDER_PAUSE = 0.05


FAILED_PAGE = """### The explorer could not open this page

Something failed in the server while it built the page (reference `{reference}`).
[Open the explorer with its default scene](./), or try the link again later;
the server's log names the cause under that reference."""


def failed_page():
    """The page served when building the explorer's raised: its own short
    message (never Panel's traceback, which shows the server's paths), the
    failure logged with its traceback under a reference the page gives."""
    import panel as pn

    from vibtrans_explorer.explorer import PAGE_TITLE, failure_reference

    reference = failure_reference()
    logging.getLogger("vibtrans.explorer").exception("building a page failed (reference %s)", reference)
    doc = pn.state.curdoc
    if doc is not None:
        doc.clear()  # whatever the failed build had attached
        doc.title = PAGE_TITLE
    return pn.Column(
        pn.pane.Markdown(FAILED_PAGE.format(reference=reference), css_classes=["vt-failed-page"]),
        margin=20,
        sizing_mode="stretch_width",
    )


def _closed_page_writes(loop, context):
    """asyncio's exception handler on the server's loop: a message to a
    page that closed meanwhile (its websocket's write failed, and Panel's
    writer was not waiting for it: asyncio's "Task exception was never
    retrieved" with the traceback) is logged as Bokeh and Panel log the
    same failure when they await it, a warning in one line; anything else
    goes to asyncio's own handler."""
    from tornado.iostream import StreamClosedError
    from tornado.websocket import WebSocketClosedError

    if isinstance(context.get("exception"), (WebSocketClosedError, StreamClosedError)):
        logging.getLogger("vibtrans.explorer").warning("Failed sending message as connection was closed")
        return
    loop.default_exception_handler(context)


def _first_page(serve_page, start_kernels):
    """The page function for the server (`serve_page`: builds the session's
    page into its document): every page is frozen once built
    (memory.page_built); the first page also starts the kernels, once it is
    answered (add_callback: after the handler, which builds and writes the
    page without yielding once the session exists)."""

    def page():
        try:
            app = serve_page()
        except Exception:
            app = failed_page()
        memory.page_built()
        from tornado.ioloop import IOLoop

        IOLoop.current().add_callback(start_kernels)
        return app

    return page


def serve(args):
    """Serve the explorer (args: the `vibtrans serve` options); returns the
    exit status once the server stops."""
    allowed = _check(args)
    _PROCESSES[0] = args.num_procs or os.cpu_count() or 1
    # before the heavy imports, which would be paid twice: `import vibtrans`
    # loads no numerics (lazy names), so the command line got here in ~0.1 s
    _reexec_on_c_allocator(args)
    from vibtrans_explorer.server import data, mapjobs, warmup

    mapjobs.configure(
        folder=getattr(args, "map_cache", None),
        max_bytes=getattr(args, "map_cache_mb", None) and args.map_cache_mb * 2**20,
        cores=getattr(args, "map_cores", None),
        scheduler=getattr(args, "scheduler", None),
    )
    mapjobs.jobs().cache  # its folder made now: an unusable one refuses to start  # noqa: B018
    memory.at_release(mapjobs.jobs().stop_workers)  # no session left: no map to come
    problems = data.preload()  # damaged, foreign or missing maps: refuse to start
    if problems:  # (in one line: nothing printed before it)
        raise InputError("; ".join(problems))
    curve = " and the vertical curve" if data.vertical_curve() is not None else ""
    say(
        f"{len(data.available_maps())} drift maps{curve} checked in {data.ASSETS / 'maps'}; "
        f"loading the explorer ..."
    )
    import panel as pn

    from vibtrans_explorer.explorer import PAGE_TITLE, serve_page

    _log_to_stderr(logging.getLogger("vibtrans"))
    from vibtrans_explorer.explorer import report_failure

    pn.config.param.update(exception_handler=report_failure)  # a callback failed: said, logged
    _freeze()
    started = []

    def start_kernels():  # once per process (warmup.start is too)
        if not started:
            started.append(True)
            warmup.start(report=say, on_ready=ready)

    def ready():  # in the kernels' thread, after the warm-up
        from vibtrans_explorer.views import map as map_view

        mapjobs.jobs().start_helpers()
        # the maps pre-rendered (a change of model, mu or grey: a copy, not a
        # render) on the event loop, one render per turn: rendered in this
        # thread while a page was being built, about one first page in ten
        # came to the browser blank
        loop.add_callback(prerender, map_view.prerender_steps())

    def prerender(steps):
        step = next(steps, None)
        if step is None:
            # what the warm-up built lives on too (a session open meanwhile is
            # frozen with it, as every page is: collected at the next release)
            _freeze()
            return
        try:
            step()
        except Exception:  # only an optimisation: the rest is left
            logging.getLogger("vibtrans.explorer").exception("prerendering the maps failed")
            _freeze()
            return
        loop.call_later(PRERENDER_PAUSE, prerender, steps)

    try:
        server = pn.serve(
            {"/": _first_page(serve_page, start_kernels)},
            port=args.port,
            address=args.address,
            show=False,
            start=False,
            verbose=False,
            websocket_origin=allowed,
            title=PAGE_TITLE,
            num_procs=args.num_procs,
            liveness=True,
            admin=False,
            extra_patterns=component_routes(),
            # behind a proxy: the visitor's address and scheme, not the proxy's
            use_xheaders=bool(getattr(args, "use_xheaders", False)),
            unused_session_lifetime_milliseconds=args.unused_session_lifetime,
            check_unused_sessions_milliseconds=args.check_unused_sessions,
        )
    except OSError as exc:  # the port taken, or not ours to open
        raise InputError(
            f"--port {args.port}: cannot listen on {args.address}:{args.port} "
            f"({exc.strerror or exc}); choose another port (1-65535), or stop "
            f"the server that holds it"
        ) from None
    # after the server is made: with --num-procs > 1 it has forked, and each
    # process compiles (or loads) its own kernels
    loop = server.io_loop
    loop.asyncio_loop.set_exception_handler(_closed_page_writes)
    loop.call_later(KERNELS_AFTER, start_kernels)
    say(f"explorer on http://{args.address}:{args.port}/ (websocket origins: {', '.join(allowed)})")
    server.start()
    try:
        loop.start()
    except KeyboardInterrupt:
        pass
    return 0
