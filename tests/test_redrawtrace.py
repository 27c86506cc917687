"""devtools/redrawtrace.py's sums over a Chrome trace (issue 32), on a
made-up trace: self times of nested events clipped to the measured
interval, the phases, the idle rest, the main thread's CPU time and the
bench probe's share."""
import pytest

from devtools.redrawtrace import _intervals, _main_thread, cpu_ms, phases, probe_ms, self_times

T = (1, 10)          # (pid, tid) of the page's main thread


def _x(name, ts, dur, tdur=None, **data):
    e = {"ph": "X", "pid": T[0], "tid": T[1], "name": name, "ts": ts, "dur": dur,
         "args": {"data": data} if data else {}}
    if tdur is not None:
        e["tdur"] = tdur
    return e


EVENTS = [
    {"ph": "M", "pid": 1, "tid": 10, "name": "thread_name", "args": {"name": "CrRendererMain"}},
    {"ph": "M", "pid": 2, "tid": 20, "name": "thread_name", "args": {"name": "CrRendererMain"}},
    # a task: a script (the probe's frame) that forces a style recalculation
    _x("RunTask", 1000, 400, tdur=300),
    _x("FunctionCall", 1000, 300, functionName="frame", url=""),
    _x("UpdateLayoutTree", 1100, 100),
    _x("Paint", 1300, 50),
    # a second task half outside the interval [1000, 2000)
    _x("RunTask", 1800, 400, tdur=350),
    _x("FunctionCall", 1800, 400, functionName="paint", url="https://x/bokeh.min.js"),
    # another thread's task (another page)
    {"ph": "X", "pid": 2, "tid": 20, "name": "RunTask", "ts": 1000, "dur": 900, "tdur": 900},
    {"ph": "B", "pid": 2, "tid": 20, "name": "Layout", "ts": 1000},
    {"ph": "E", "pid": 2, "tid": 20, "name": "Layout", "ts": 1500},
]


def test_the_page_thread_is_the_busiest_renderer_main_thread():
    assert _main_thread(EVENTS + [_x("RunTask", 3000, 1)] * 5) == T


def test_self_times_are_clipped_and_nested():
    iv = _intervals(EVENTS, T)
    selfs, busy = self_times(iv, 1000, 2000)
    assert selfs["UpdateLayoutTree"] == pytest.approx(0.1)
    assert selfs["FunctionCall"] == pytest.approx(0.2 + 0.2)     # 300 - 100 forced; 200 inside
    assert selfs["RunTask"] == pytest.approx(0.05)               # 400 - 300 - 50 (paint)
    assert busy == pytest.approx(0.4 + 0.2)                      # top-level time inside
    ph = phases(selfs)
    assert ph["style"] == pytest.approx(0.1) and ph["paint"] == pytest.approx(0.05)
    assert ph["script"] == pytest.approx(0.4)


def test_cpu_time_and_the_probes_share():
    iv = _intervals(EVENTS, T)
    assert cpu_ms(EVENTS, T, 1000, 2000) == pytest.approx(0.65)  # thread time of both tasks
    assert cpu_ms(EVENTS, T, 1500, 2000) == pytest.approx(0.35)  # tasks starting inside
    assert probe_ms(iv, 1000, 2000) == pytest.approx(0.3)        # `frame`, no URL: the probe
    # another thread's B/E pair is joined there (outer event first), not here
    assert [(s, e, n) for s, e, n, _ in _intervals(EVENTS, (2, 20))] == [
        (1000, 1900, "RunTask"), (1000, 1500, "Layout")]
