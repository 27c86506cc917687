"""The load test (devtools/loadtest.py) at a small scale, as CI runs it: a
real server, one real browser session and two protocol sessions
(devtools/protoclient.py), 3 sessions x 2 clicks.  No errors, every click
answered in both kinds of session, every closed session dropped, and the
server's memory growth bounded.  The full-scale figures (30 x 5) are in
docs/SECURITY.md."""

import os
from pathlib import Path

import pytest

from devtools import loadtest
from devtools.server import released_after_discards

CORES = sorted(os.sched_getaffinity(0))  # the cores this process may use


@pytest.mark.browser  # a real chromium session
def test_small_load_has_no_errors_and_bounded_memory(tmp_path):
    """Where there are two cores, pinned (--pin): the server's processes on
    the first core, the clients (this process and the chromium it drives)
    on the second, as read back from the kernel; this process's own
    affinity is given back afterwards (one load for both checks: each load
    starts its own server)."""
    assert Path(loadtest.CHROMIUM).exists(), "Debian's chromium is required (make test installs it)"
    pin = ["--pin"] if len(CORES) >= 2 else []
    out = loadtest.main(
        [
            "--sessions",
            "3",
            "--clicks",
            "2",
            "--browsers",
            "1",
            "--think",
            "0.5",
            "--ramp",
            "1",
            "--click-timeout",
            "90",
            "--timeout",
            "120",
            "--settle",
            "30",
            "--json",
            "--results-dir",
            str(tmp_path),
            *pin,
        ]
    )
    assert out["errors"] == 0, out["error_samples"]
    assert len(list(tmp_path.glob("loadtest-*.json"))) == 1  # the run, as a record
    assert out["refused"] == 0
    assert out["browser_clicks"] == 2 and out["protocol_clicks"] == 4, out
    assert out["sessions_dropped"] == 3  # Bokeh dropped every closed session
    assert out["memory_released"], out  # ... and the explorer released them
    # The memory goal, at this scale: the RSS back within 10% of the
    # post-warm-up baseline once the sessions are dropped and released
    # (30 x 5: docs/SECURITY.md).
    assert out["rss_after_over_baseline"] <= 0.10, out
    assert out["rss_peak_mb"] < 4 * out["rss_baseline_mb"], out
    # no closed session's page is held (each held one grew the server by a
    # few MB a visitor, unseen at this scale): a process keeps at most two
    # documents, whatever the sessions, both held by Panel: the first
    # page's (its shared style sheets refer to it) and the one in whose
    # context Panel's busy-state cleanup task was started
    held = out["documents_held_by_process"]
    assert held and max(held.values()) <= 2, out["release_lines"]
    # ... nor a closed session's explorer (its views, state and runs: a few
    # MB a visitor, the whole last burst of them otherwise, kept past the
    # release that collected their documents)
    explorers = out["explorers_held_by_process"]
    assert explorers and max(explorers.values()) == 0, out["release_lines"]
    # the server worked (pages, runs) and was counted: CPU seconds, at most
    # its cores' share of the load's wall time
    assert 0 < out["server_cpu_s"] <= (os.cpu_count() or 1) * out["load_wall_s"] + 1, out
    if pin:
        assert out["pin_server"] == str(CORES[0]) and out["pin_clients"] == str(CORES[1])
        assert out["server_cores"] == str(CORES[0]), out
        assert out["client_cores"] == str(CORES[1]), out
    assert sorted(os.sched_getaffinity(0)) == CORES
    # times depend on the machine's load: reported, not asserted
    print(
        f"load test 3 x 2: {out['total_wall_s']:.0f} s in all, server ready after "
        f"{out['server_start_to_ready_s']:.1f} s, click p95 {out['click_to_plot_p95_s']:.1f} s"
    )


@pytest.mark.server
@pytest.mark.slow
def test_a_session_asking_for_a_map_gets_it_while_the_others_click(tmp_path):
    """--maps: one protocol session opens a link with a map request and
    waits for the finished map (computed: the server's map cache is a fresh
    folder) while two sessions click; every click answered, the map
    finished, no errors."""
    out = loadtest.main(
        [
            "--sessions",
            "3",
            "--clicks",
            "2",
            "--browsers",
            "0",
            "--maps",
            "1",
            "--think",
            "0.5",
            "--ramp",
            "1",
            "--click-timeout",
            "90",
            "--timeout",
            "240",
            "--settle",
            "30",
            "--json",
            "--results-dir",
            str(tmp_path),
        ]
    )
    assert out["errors"] == 0, out["error_samples"]
    assert out["map_sessions"] == 1 and out["maps_finished"] == 1, out
    assert out["goal_maps_finished"]
    assert out["protocol_clicks"] == 4, out
    assert out["sessions_dropped"] == 3
    print(
        f"load test 3 x 2 with a map: map {out['map_seconds']} s, click p95 "
        f"{out['click_to_plot_p95_s']:.1f} s"
    )


def test_map_sessions_are_protocol_sessions_and_bounded(capsys):
    assert loadtest.map_sessions(30, 2, 5).isdisjoint(loadtest.browser_sessions(30, 2))
    assert len(loadtest.map_sessions(30, 2, 5)) == 5
    assert loadtest.map_sessions(30, 2, 0) == set()
    # five distinct requests: no two sessions share one computation
    assert len({loadtest.map_request(k) for k in range(5)}) == 5
    with pytest.raises(SystemExit):
        loadtest.parse(["--sessions", "3", "--browsers", "1", "--maps", "3"])
    assert "--maps must be in [0, --sessions - --browsers = 2], got 3" in capsys.readouterr().err


def test_the_server_runs_on_the_c_allocator(served_explorer):
    """`vibtrans serve` re-executes itself with PYTHONMALLOC=malloc (memory
    of closed sessions goes back to the OS: docs/SECURITY.md), in the same
    process (a supervisor's pid stays valid).  The session's server was
    started without PYTHONMALLOC (conftest.py)."""
    with open(f"/proc/{served_explorer.proc.pid}/environ", "rb") as f:
        assert b"PYTHONMALLOC=malloc" in f.read().split(b"\0")


def test_pinning_options_parse():
    a = loadtest.parse(["--pin-server", str(CORES[0]), "--pin-clients", str(CORES[-1])])
    assert a.pin_server == [CORES[0]] and a.pin_clients == [CORES[-1]]
    assert loadtest.parse([]).pin_server is None  # no pinning by default
    assert loadtest.parse_cpus(f"{CORES[0]}-{CORES[-1]}", "--pin-server") == [
        c for c in range(CORES[0], CORES[-1] + 1)
    ]
    if len(CORES) >= 2:
        a = loadtest.parse(["--pin"])
        assert (a.pin_server, a.pin_clients) == (CORES[:1], CORES[1:2])


HERE = f"cores here: {loadtest._cpu_list(CORES)}"


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["--pin-server", str(CORES[-1] + 1)],
            f"--pin-server: core {CORES[-1] + 1} does not exist here ({HERE})",
        ),
        (
            ["--pin-clients", f"{CORES[-1] + 1}-999"],
            f"--pin-clients: cores {CORES[-1] + 1}-999 do not exist here ({HERE})",
        ),
        (["--pin-server", "first"], f"--pin-server must be a list of cores such as 0, 0,2 or 0-1 ({HERE})"),
        (["--pin-server", "3-1"], f"--pin-server: '3-1' is not a core range ({HERE})"),
        (
            ["--pin-server", str(CORES[0]), "--pin-clients", str(CORES[0])],
            f"--pin-server {CORES[0]} and --pin-clients {CORES[0]} share cores",
        ),
        (
            ["--pin", "--pin-clients", str(CORES[0])],
            "--pin is --pin-server FIRST --pin-clients SECOND: give either",
        ),
    ],
)
def test_pinning_refuses_cores_that_are_not_there(argv, message, capsys):
    with pytest.raises(SystemExit) as exited:
        loadtest.parse(argv)
    assert exited.value.code == 2
    assert message in capsys.readouterr().err


def _line(what, pid):
    return f"1970-01-01 00:00:00,000 - vibtrans.explorer - INFO - {what} (process {pid}): x"


def test_memory_counts_as_released_only_when_every_process_released_its_closes():
    """With several server processes in one log, one process's release
    after the last discard does not stand for the others' (read so, one
    process's garbage was measured as the load's memory growth, +20%)."""
    from vibtrans_explorer.server.memory import CLOSED, RELEASED

    discard = "DEBUG - Discarding session 'abc' last in use 5 milliseconds ago"
    # process 2 closed a session after its last release; process 1 released after it
    late = [discard, _line(CLOSED, 1), _line(RELEASED, 2), discard, _line(CLOSED, 2), _line(RELEASED, 1)]
    assert not released_after_discards("\n".join(late))
    assert released_after_discards("\n".join(late + [_line(RELEASED, 2)]))
    # a discard whose close is not logged yet
    assert not released_after_discards("\n".join(late + [_line(RELEASED, 2), discard]))
    assert not released_after_discards("")
