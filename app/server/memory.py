"""The server's memory: when the cyclic collector runs, and when freed
memory goes back to the OS.

A full collection walks every object it tracks while the event loop, and
so every open session, waits: 0.4-1.0 s with 25 sessions open (measured in
the five-map load test, `python -m devtools.loadtest --maps 5`).  Before,
one ran at each session's close (Panel's, and the explorer's own), and
Python's collector ran others as the sessions' pages piled up (0.1-0.7 s
each, collecting almost nothing).  Now:

- What a page builds is taken out of the collector's passes once built
  (`page_built`: `gc.freeze`, O(1)), like what start-up built.  A session's
  objects are mostly its page; they live as long as it does.  Panel's own
  collection after a session closes (debounced, on the event loop) is left
  as Panel has it: with the pages frozen it walks only what is not.
- A closed session's objects (its document's reference cycles) wait in the
  frozen generation.  They are collected, and the freed heap handed back
  to the OS (glibc's `malloc_trim`: it keeps freed pages in its arenas),
  RELEASE_DELAY after the last open session closes; or, on a server that is
  never idle, after CLOSES_PER_RELEASE closes, whatever is open then.

Nothing here imports the app; `server.py` installs it, `explorer.py`
reports the closes.
"""

import asyncio
import ctypes
import gc
import logging
import os
import time
import weakref

from bokeh.io import curdoc

log = logging.getLogger("vibtrans.explorer")

RELEASE_DELAY = 2.0  # s after the last session closed (a burst of closes: once)
CLOSES_PER_RELEASE = 30  # closes kept uncollected at most (a server never idle)
# INFO: operators (and `python -m devtools.loadtest`, which waits for this
# line after the last session is discarded) see when memory went back
RELEASED = "released the memory of closed sessions"
HELD = "documents held"  # (their count, a figure of the release line)
EXPLORERS_HELD = "explorers held"  # (their count, the release line's last figure)
RELEASE_NAME = "the release of closed sessions' memory"
CLOSED = "session closed"

_RELEASE = {"handle": None, "server": None, "closes": 0}
_AT_RELEASE = []  # callables, run at each release (the server's)
_PAGES = weakref.WeakSet()  # the documents of the pages built, while alive
_EXPLORERS = weakref.WeakSet()  # the pages' explorers, while alive


def at_release(fn):
    """Call fn() at each release too (before the collection): say, stop
    helper processes kept for the open sessions."""
    _AT_RELEASE.append(fn)


def page_built():
    """A session's page is built (into Bokeh's current document): leave it
    (and everything older) out of the collector's passes until the next
    release, and count its document while it lives."""
    gc.freeze()
    _PAGES.add(curdoc())


def explorer_built(explorer):
    """A page's explorer is built: count it while it lives."""
    _EXPLORERS.add(explorer)


def sessions_open(server_context):
    """How many sessions the server still holds (0 outside a server)."""
    sessions = getattr(server_context, "sessions", None)
    return 0 if sessions is None else len(list(sessions))


def _due(server):
    return (not sessions_open(server)) or _RELEASE["closes"] >= CLOSES_PER_RELEASE


def session_closed(session_context=None):
    """A session was dropped (`session_context`: Bokeh's, for the sessions
    still open): schedule the release if it is due."""
    server = getattr(session_context, "server_context", None)
    _RELEASE["closes"] += 1
    log.info("%s (process %d): %d open", CLOSED, os.getpid(), sessions_open(server))
    if not _due(server):
        return
    try:
        loop = asyncio.get_running_loop()
    except RuntimeError:
        return
    if _RELEASE["handle"] is not None:
        _RELEASE["handle"].cancel()
    _RELEASE["server"] = server
    _RELEASE["handle"] = loop.call_later(RELEASE_DELAY, release)


def resident_mb():
    """This process's resident memory (MB) from /proc; None off Linux."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError):
        return None


def documents_held():
    """How many built pages' documents this process still holds.  Once
    every session has closed, Panel keeps one or two (the first page's,
    which its shared style sheets refer to; the one whose context its
    busy-state cleanup task started in); a closed session's page held
    besides would count here, a few MB a visitor."""
    return len(_PAGES)


def explorers_held():
    """How many pages' explorers this process still holds: the open
    sessions' only (a closed session's explorer, its views, state and
    runs, held past the release would count here)."""
    return len(_EXPLORERS)


def release():
    """Collect what the closed sessions left and give the freed heap back
    to the OS; what lives on is frozen again (as at start-up) if anything
    was frozen (a process that never froze, say a test's, stays so)."""
    _RELEASE["handle"] = None
    if not _due(_RELEASE["server"]):
        # a session opened meanwhile: at its close
        log.info(
            "%s deferred (process %d): %d sessions open",
            RELEASE_NAME,
            os.getpid(),
            sessions_open(_RELEASE["server"]),
        )
        return
    _RELEASE["closes"] = 0
    t0, before = time.perf_counter(), resident_mb()
    for fn in _AT_RELEASE:
        try:
            fn()
        except Exception:  # the release goes on
            log.exception("a release hook failed")
    frozen = gc.get_freeze_count() > 0  # the server froze start-up and pages
    gc.unfreeze()
    collected = gc.collect()
    held, explorers = documents_held(), explorers_held()
    if frozen:
        gc.freeze()
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):  # not glibc
        pass
    after = resident_mb()
    log.info(
        "%s (process %d): %d objects collected, RSS %s -> %s MB in %.2f s, %d %s, %d %s",
        RELEASED,
        os.getpid(),
        collected,
        f"{before:.0f}" if before else "?",
        f"{after:.0f}" if after else "?",
        time.perf_counter() - t0,
        held,
        HELD,
        explorers,
        EXPLORERS_HELD,
    )
