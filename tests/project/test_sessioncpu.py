"""devtools.sessioncpu's readings: the CPU time of a process's event-loop
thread apart from its other threads (/proc), and the release after the
sessions' closes read from the explorer's log lines."""

import os
import threading
import time

from devtools.sessioncpu import _release_seen, thread_cpu
from vibtrans_explorer.server.memory import CLOSED, RELEASED


def _burn(seconds):
    """Use `seconds` of this thread's CPU."""
    start = time.thread_time()
    while time.thread_time() - start < seconds:
        pass


def test_thread_cpu_tells_the_main_thread_from_the_others():
    main0, other0 = thread_cpu(os.getpid())
    t = threading.Thread(target=_burn, args=(0.3,))
    t.start()
    t.join()
    main1, other1 = thread_cpu(os.getpid())
    # the thread's 0.3 s counted as another thread's (clock ticks: 10 ms)
    assert other1 - other0 >= 0.25
    assert main1 - main0 <= 0.1
    _burn(0.3)
    main2, other2 = thread_cpu(os.getpid())
    assert main2 - main1 >= 0.25
    assert other2 - other1 <= 0.1


def test_release_seen_only_after_the_last_close():
    close = f"vibtrans.explorer - INFO - {CLOSED} (process 7): 0 open\n"
    release = f"vibtrans.explorer - INFO - {RELEASED} (process 7): 10 objects\n"
    assert not _release_seen(close, 2)
    assert not _release_seen(release + close + close, 2)  # an earlier release
    assert _release_seen(close + close + release, 2)
    assert not _release_seen(close + release + close, 2)  # before the second close


def test_profile_parts_by_the_innermost_phase(tmp_path):
    from devtools.sessioncpu import profile_parts

    raw = tmp_path / "raw.txt"
    raw.write_text(
        "main;DocHandler.get (panel/io/server.py:671);_first_page.<locals>.page (app/server/serve.py:184) 7\n"
        "main;DocHandler.get (panel/io/server.py:671);Document.validate (bokeh/document/document.py:842) 2\n"
        "main;DocHandler.get (panel/io/server.py:671);render (jinja2) 1\n"
        "Thread._bootstrap (threading.py:995);simulate (vibtrans/core/simulate.py:1) 4\n"
        "main;BaseEventLoop._run_once (asyncio/base_events.py:1) 3\n"
    )
    parts = profile_parts(raw)
    assert parts == {
        ("event loop", "GET: the page function (serve_page)"): 7,
        ("event loop", "GET: Bokeh's document checks"): 2,
        ("event loop", "GET: the rest (session, HTML)"): 1,
        ("other", "rest"): 4,
        ("event loop", "rest"): 3,
    }
