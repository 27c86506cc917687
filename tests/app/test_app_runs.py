"""The explorer's runs, server side (no browser): one run per session (a new
request cancels and replaces the running one, freeing its worker), the step
cap, a failing run (only its session sees an error), Cancel, and figures
that are built once and then fed new data."""

import asyncio
import gc
import logging
import threading
import weakref

import numpy as np
import pytest
from asyncutil import until
from budget import budget

from vibtrans import Cancelled
from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import memory
from vibtrans_explorer.session import controller as C
from vibtrans_explorer.views import map as M
from vibtrans_explorer.views import runtabs
from vibtrans_explorer.views.live import TIMELINE_BINS, LiveTrajectory

# explorer sessions with real runs, ~40 s (make test-fast leaves them out)
pytestmark = pytest.mark.slow

REAL_SIMULATE = C.simulate


def _explorer(**state):
    ex = E.Explorer()
    ex.state.param.update(fidelity="preview", compare="none", **state)
    return ex


def _runs_until_cancelled(started):
    """A stand-in for simulate that sets `started` and runs until cancelled."""

    def slow(scene, *, cancel=None, **kwargs):
        started.set()
        cancel.wait()
        raise Cancelled("run cancelled")

    return slow


async def _start_run_that_waits_for_cancel(ex, monkeypatch):
    """Start a run whose simulate blocks until cancelled; its job, once running."""
    started = threading.Event()
    monkeypatch.setattr(ex.controller, "simulate", _runs_until_cancelled(started))
    job = ex.start_run()
    await until(started.is_set)
    return job


def _idle(ex):
    return ex.controller.job is None


def test_a_run_shows_its_summary_and_figures():
    async def go():
        ex = _explorer()
        ex.start_run()
        await until(lambda: _idle(ex) and "drift <v*>" in ex.summary_view.pane.object)
        assert not ex.message.visible
        assert list(ex.trajectories.views) == ["alone"]
        view = ex.trajectories.views["alone"]
        assert view.panel.visible and ex.exports.panel.visible and view.runs == 1
        source = view.over.source
        first = source.data["x"]
        # the whole run in per-bin envelopes (live.TIMELINE_BINS), the
        # fragment at full resolution (preview: 16 steps/period)
        assert len(first) == TIMELINE_BINS and len(view.last.source.data["time"]) > 2 * 16
        # a second run of the same structure feeds the same figures
        ex.state.log_mass = 0.5
        ex.start_run()
        await until(lambda: _idle(ex) and "m\\* = 3.162" in ex.summary_view.pane.object)
        assert ex.trajectories.views["alone"] is view and view.runs == 2
        assert view.over.source is source and source.data["x"] is not first
        assert len(ex.runs.tabs) == 5  # tabs: figures, animation, memory, downloads, dynamics
        assert len(ex.trajectories.panel) == 1  # one structure's figures

    asyncio.run(go())


def test_a_new_run_cancels_and_replaces_the_running_one(monkeypatch):
    started = threading.Event()
    seen_cancel = []

    def slow(scene, *, cancel=None, **kwargs):
        started.set()
        cancel.wait()
        seen_cancel.append(scene)
        raise Cancelled("run cancelled")

    async def go():
        ex = _explorer()
        monkeypatch.setattr(ex.controller, "simulate", slow)
        first = ex.start_run()
        await until(started.is_set)
        monkeypatch.setattr(ex.controller, "simulate", REAL_SIMULATE)
        ex.state.log_amplitude = 0.5
        second = ex.start_run()
        assert first.event.is_set() and ex.controller.job is second  # one run per session
        # the replaced run's worker is free at once (its kernel saw the flag)
        await until(lambda: all(f.done() for f in first.futures), timeout=budget(5))
        assert len(seen_cancel) == 1
        await until(lambda: _idle(ex) and "A\\* = 3.162" in ex.summary_view.pane.object)
        assert "cancelled" not in ex.summary_view.pane.object and not ex.message.visible

    asyncio.run(go())


def test_runs_not_started_are_dropped_when_replaced(monkeypatch):
    """A run still queued behind busy workers is cancelled, never run."""
    gate = threading.Event()
    blockers = [C.RUNNER.submit(gate.wait, 30) for _ in range(C.RUNNER._max_workers)]
    calls = []

    async def go():
        ex = _explorer()
        monkeypatch.setattr(ex.controller, "simulate", lambda scene, **kw: calls.append(scene))
        first = ex.start_run()
        second = ex.start_run()
        assert all(f.cancelled() for f in first.futures)
        gate.set()
        await until(lambda: all(f.done() for f in second.futures))
        assert len(calls) == 1

    try:
        asyncio.run(go())
    finally:
        gate.set()
        for b in blockers:
            b.result(timeout=budget(30))


def test_cancel_frees_the_worker_and_says_so(monkeypatch):
    async def go():
        ex = _explorer()
        job = await _start_run_that_waits_for_cancel(ex, monkeypatch)
        await until(lambda: ex.run_buttons.progress.visible and not ex.run_buttons.cancel_button.disabled)
        ex.run_buttons.cancel_button.clicks += 1
        await until(lambda: ex.summary_view.pane.object == "Run cancelled.")
        assert all(f.done() for f in job.futures)
        assert not ex.run_buttons.progress.visible and ex.run_buttons.cancel_button.disabled and _idle(ex)

    asyncio.run(go())


def test_a_failing_run_shows_an_error_in_its_session_only(monkeypatch):
    def broken(scene, **kwargs):
        raise RuntimeError("kernel exploded")

    async def go():
        ex, other = _explorer(), _explorer()
        monkeypatch.setattr(ex.controller, "simulate", broken)
        ex.start_run()
        await until(lambda: _idle(ex) and ex.message.visible)
        assert "The run failed: RuntimeError: kernel exploded" in ex.message.object
        assert ex.summary_view.pane.object == "" and not ex.run_buttons.progress.visible
        assert not other.message.visible
        # the server and the other session carry on; so does this one
        monkeypatch.setattr(ex.controller, "simulate", REAL_SIMULATE)
        other.start_run()
        await until(lambda: _idle(other) and "drift <v*>" in other.summary_view.pane.object)
        ex.start_run()
        await until(lambda: _idle(ex) and "drift <v*>" in ex.summary_view.pane.object)
        assert not ex.message.visible

    asyncio.run(go())


def test_a_failure_drawing_a_run_is_reported(monkeypatch):
    def broken(*args, **kwargs):
        raise ValueError("no figure")

    async def go():
        ex = _explorer()
        monkeypatch.setattr(LiveTrajectory, "show", broken)
        ex.start_run()
        await until(lambda: _idle(ex) and ex.message.visible)
        assert "Drawing the run failed: ValueError: no figure" in ex.message.object

    asyncio.run(go())


def test_the_step_cap_refuses_with_a_message(monkeypatch):
    calls = []
    ex = _explorer()
    monkeypatch.setattr(ex.controller, "max_steps", 1000)
    monkeypatch.setattr(ex.controller, "simulate", lambda *a, **k: calls.append(a))
    assert ex.start_run() is None
    assert not calls and ex.controller.job is None
    assert "over this server's limit of 1e+03 (VIBTRANS_MAX_STEPS)" in ex.message.object


def test_closing_the_session_cancels_its_run(monkeypatch):
    async def go():
        ex = _explorer()
        job = await _start_run_that_waits_for_cancel(ex, monkeypatch)
        ex._on_session_destroyed(None)
        await until(lambda: all(f.done() for f in job.futures), timeout=budget(5))
        assert ex.controller.job is None and not ex.trajectories.views

    asyncio.run(go())


@pytest.fixture
def thawed():
    """`memory.release` and `page_built` freeze the objects alive (the
    server's own); the tests after these need their collector back."""
    yield
    gc.unfreeze()


def test_closed_sessions_give_their_memory_back_once(monkeypatch, caplog, thawed):
    """A burst of closed sessions schedules one collection + malloc_trim,
    logged at INFO in the words the load test waits for."""
    caplog.set_level(logging.INFO, logger="vibtrans.explorer")
    monkeypatch.setattr(memory, "RELEASE_DELAY", 0.05)
    calls = []
    real = memory.release
    monkeypatch.setattr(memory, "release", lambda: (calls.append(1), real()))

    async def go():
        for _ in range(3):
            memory.session_closed()
        # released, and nothing scheduled after (each close replaced the last's)
        await until(lambda: calls and memory._RELEASE["handle"] is None)

    asyncio.run(go())
    assert calls == [1] and memory._RELEASE["handle"] is None
    released = [r.getMessage() for r in caplog.records if memory.RELEASED in r.getMessage()]
    assert len(released) == 1 and " MB in " in released[0], caplog.text


def test_memory_is_released_when_the_last_session_closes_or_after_many_closes(monkeypatch, thawed):
    """While sessions stay open a close collects nothing (a full collection
    would hold every open session's clicks); the last close does, and so
    does the CLOSES_PER_RELEASE-th on a server that is never idle.  The
    closed session's page, frozen when it was built (`page_built`), is
    collected then, and what lives on is frozen again."""
    from types import SimpleNamespace

    monkeypatch.setattr(memory, "RELEASE_DELAY", 0.01)
    monkeypatch.setattr(memory, "CLOSES_PER_RELEASE", 4)
    monkeypatch.setitem(memory._RELEASE, "closes", 0)
    open_sessions = [object(), object()]
    ctx = SimpleNamespace(server_context=SimpleNamespace(sessions=open_sessions))
    calls = []
    real = memory.release
    monkeypatch.setattr(memory, "release", lambda: (calls.append(len(open_sessions)), real()))

    class Page:  # a closed session's document: a reference cycle
        def __init__(self):
            self.me = self

    page = Page()
    frozen = gc.get_freeze_count()
    memory.page_built()
    assert gc.get_freeze_count() > frozen
    gone = weakref.ref(page)
    del page

    async def go():
        for _ in range(3):  # two sessions stay open: nothing due
            memory.session_closed(ctx)
            assert memory._RELEASE["handle"] is None  # nothing scheduled
        gc.collect()
        assert calls == [] and gone() is not None  # frozen: not even a full pass
        memory.session_closed(ctx)  # the 4th close: due, sessions open or not
        await until(lambda: calls)
        assert calls == [2] and gone() is None
        open_sessions.clear()
        memory.session_closed(ctx)  # the last session: due at once
        await until(lambda: len(calls) == 2)
        assert calls == [2, 0]

    asyncio.run(go())
    assert gc.get_freeze_count() > 0  # the server's own objects, frozen again


def test_the_server_freezes_every_page_once_built(monkeypatch):
    """`vibtrans serve`'s page function freezes each page it builds (not
    only the first, which also starts the kernels)."""
    from vibtrans_explorer.server import serve as server

    built, kernels = [], []
    monkeypatch.setattr(memory, "page_built", lambda: built.append(1))
    page = server._first_page(lambda: "a page", lambda: kernels.append(1))

    async def go():
        pages = page(), page(), page()
        await until(lambda: len(kernels) == 3)  # each page's start_kernels called
        return pages

    assert asyncio.run(go()) == ("a page",) * 3 and built == [1, 1, 1]


def test_a_release_leaves_a_process_that_never_froze_unfrozen(monkeypatch, thawed):
    gc.unfreeze()
    monkeypatch.setitem(memory._RELEASE, "server", None)
    memory.release()
    assert gc.get_freeze_count() == 0


def test_a_release_runs_the_servers_hooks_first(monkeypatch, thawed):
    """`at_release` hooks (the server's: stop the map workers kept for the
    open sessions) run at each release, a failing one not stopping it."""
    calls = []
    monkeypatch.setattr(memory, "_AT_RELEASE", [])
    memory.at_release(lambda: 1 / 0)
    memory.at_release(lambda: calls.append("stopped"))
    monkeypatch.setitem(memory._RELEASE, "server", None)
    memory.release()
    assert calls == ["stopped"]


def test_a_map_click_selects_and_runs_that_scene(monkeypatch):
    """A tap on the map (a Bokeh Tap event: data coordinates) moves the
    selected point's marker and runs that scene; a tap in the map's padding,
    outside the domain, is no scene: nothing is clamped into it."""
    from types import SimpleNamespace

    ex = _explorer()
    runs = []
    monkeypatch.setattr(ex, "start_run", lambda: runs.append(ex.state.scene()))
    ex.map_view._on_tap(True, SimpleNamespace(x=0.51234, y=-1.25))
    assert (ex.state.log_amplitude, ex.state.log_mass) == (0.512, -1.25)
    assert ex.map_view.selected.data == {"x": [0.512], "y": [-1.25]}
    assert len(runs) == 1 and abs(runs[0].amplitude - 10**0.512) < 1e-12
    for x, y in ((3.2, 0.0), (0.0, -5.3), (float("nan"), 0.0), (None, 1.0)):
        ex.map_view._on_tap(True, SimpleNamespace(x=x, y=y))
    assert len(runs) == 1 and ex.state.log_amplitude == 0.512


def test_each_session_gets_its_own_map_figure():
    """The map's Bokeh models are rebuilt for every session from one
    rendering (explorer.map_figure): equal content, separate models, each
    with its session's marker sources."""
    a, b = _explorer(), _explorer()
    fa, fb = a.map_view.figures[0], b.map_view.figures[0]
    assert fa is not fb and fa.title.text == fb.title.text
    glyphs = [[r for r in f.renderers if hasattr(r, "data_source")] for f in (fa, fb)]
    images = [[r.data_source.data["image"][0] for r in g if "image" in r.data_source.data] for g in glyphs]
    assert len(images[0]) >= 1 and all(np.array_equal(x, y, equal_nan=True) for x, y in zip(*images))
    sources = [{r.data_source for r in g} for g in glyphs]
    assert a.map_view.selected in sources[0] and a.map_view.selected not in sources[1]
    assert b.map_view.selected in sources[1]
    # another shipped map: that session's figure shows it (updated in place,
    # views/map.py update_in_place), the other session's is untouched
    a.state.mu = 0.1
    assert "mu = 0.1" in a.map_view.figures[0].title.text
    assert b.map_view.figures[0] is fb and "mu = 0.3" in fb.title.text
    image_a = [
        r.data_source.data["image"][0]
        for r in a.map_view.figures[0].renderers
        if hasattr(r, "data_source") and "image" in r.data_source.data
    ]
    assert not np.array_equal(image_a[0], images[1][0], equal_nan=True)  # the mu 0.1 map


def _serialized(doc):
    """A document's JSON with its model ids (p1234) and Panel's names
    (Column01234, main-1407...) numbered in order of appearance."""
    import re

    from bokeh.core.json_encoder import serialize_json

    ids = {}
    return re.sub(
        r"p\d{3,}|[A-Za-z]*-?\d{4,}",
        lambda m: ids.setdefault(m.group(0), f"ID{len(ids)}"),
        serialize_json(doc.to_json()),
    )


def test_served_page_is_the_template_attached_by_panel():
    """The page as the server builds it (explorer.serve_page: the template
    attached by Panel's `server_doc` into the session's document, with the
    explorer's Location) serializes to the same document as the template's
    plain attach (ids aside), every model registered with the document."""
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    from vibtrans_explorer.views import map as map_view

    texts = []
    for served in (False, True):
        map_view._map_json.cache_clear()  # the map rendered inside each build too
        doc = Document()
        with set_curdoc(doc):
            if served:
                assert E.serve_page() is None
            else:
                assert E.create_app().server_doc(doc) is doc
        reachable = {m.id for root in doc.roots for m in root.references()}
        assert reachable and reachable <= {m.id for m in doc.models}
        assert all(doc.get_model_by_id(i) is not None for i in reachable)
        texts.append(_serialized(doc))
    assert len(texts[0]) > 10000
    assert texts[0] == texts[1]


def test_a_served_pages_location_is_the_explorers_address(monkeypatch):
    """A served page has no Panel Location (its own watcher parses the
    browser's query and fails on '?la=²', docs/how-to/deployment.md 1.3): the
    root the template embeds as the page's location is the explorer's
    address component (views.browserside.BrowserAddress), and the page's
    main column does not hold it again."""
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    from vibtrans_explorer.views.browserside import BrowserAddress

    monkeypatch.setattr(E, "_page_location", BrowserAddress)  # as in a served session
    doc = Document()
    with set_curdoc(doc):
        assert E.serve_page() is None
    explorer = E._PAGES[doc]
    assert isinstance(explorer.location, BrowserAddress)
    location = doc.get_model_by_name("location")
    assert location in doc.roots and hasattr(location.data, "search")
    assert not [m for m in doc.models if type(m).__name__ == "Location"]
    assert not explorer.page.select(BrowserAddress)


def test_page_cost_bench_runs_and_validates():
    """`python -m devtools.pagecost` measures pages as served; a bad
    --pages is refused naming the option."""
    from devtools import pagecost

    out = pagecost.main(["--pages", "1", "--json"])
    assert out["page_s_served"] > 0 and out["checks_s"] > 0
    assert out["models"] > 100 and out["page_cpu_s"] > 0
    with pytest.raises(SystemExit):
        pagecost.main(["--pages", "0"])


@pytest.mark.parametrize("chaotic", ["grey", "colour"])
def test_the_map_hover_shows_drift_and_verdict_never_nan(chaotic):
    """One hover on the map, on its drift image: the point, <v*> and the
    tau-twin verdict (finite everywhere), not the colour value, which is NaN
    under the grey of chaotic points (the grey layer's own hover used to
    cover it and show 'chaotic: NaN' off the grey)."""
    from bokeh.models import HoverTool

    fig = M.map_figure("deformable", 0.3, 0.1, chaotic)
    hovers = [t for t in fig.tools if isinstance(t, HoverTool)]
    assert len(hovers) == 1 and len(hovers[0].renderers) == 1
    fields = [field for _, field in hovers[0].tooltips]
    assert fields == ["$x", "$y", "@{v}", "@{chaotic}"]
    data = hovers[0].renderers[0].data_source.data
    assert np.isfinite(data["v"][0]).all()
    assert set(np.unique(data["chaotic"][0])) <= {0.0, 1.0}


def test_the_page_passes_bokehs_document_checks():
    """Bokeh checks every session's document (stock server); the page passes:
    no errors; the only warnings are the empty containers filled when first
    opened (the lazy tabs and boxes)."""
    from bokeh.core.validation.check import check_integrity
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    doc = Document()
    with set_curdoc(doc):
        E.create_app().server_doc(doc)
    issues = [check_integrity(root.references()) for root in doc.roots]
    assert not [e for i in issues for e in i.error]
    warnings = {w.name for i in issues for w in i.warning}
    assert warnings <= {"EMPTY_LAYOUT"}, warnings


def test_after_a_cancel_the_previous_run_is_shown_as_the_previous_runs(monkeypatch):
    """After Cancel the figures, the memory diagram and the downloads still
    show the previous run: a bare 'Run cancelled.' would pass it off as
    current.  The summary says whose they are, over
    the previous run's table, and the memory diagram says so too."""
    from vibtrans_explorer.views.summary import CANCELLED_LINE, PREVIOUS_RUN

    async def go():
        ex = _explorer(log_amplitude=2.5, log_mass=0.0)
        ex.start_run()
        await until(lambda: _idle(ex) and "drift <v*>" in ex.summary_view.pane.object)
        table = ex.summary_view.pane.object
        ex.runs.tabs.active = runtabs.MEMORY_TAB  # the memory diagram of that run
        await until(
            lambda: ex.runs.memory_view is not None and ex.runs.memory_view.snapshots, timeout=budget(120)
        )
        ex.state.log_mass = -0.5  # a new scene, run and cancelled
        await _start_run_that_waits_for_cancel(ex, monkeypatch)
        ex.run_buttons.cancel_button.clicks += 1
        await until(lambda: ex.summary_view.pane.object.startswith(CANCELLED_LINE))
        assert table.split("\n")[0] in ex.summary_view.pane.object  # the previous run's heading
        assert PREVIOUS_RUN in ex.runs.memory_view.status.object
        assert ex.stale_shown()  # and it is not the state's

    asyncio.run(go())
