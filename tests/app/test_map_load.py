"""A shipped map not rendered yet in the server's process loads off the event
loop (app/views/map.py MapView._load): a line over the map says what loads
(its stage: the file read and checked, then drawn) and the old map is
dimmed until the new one is shown; the event loop stays free meanwhile; the
latest choice wins (an older load's map is never shown).  The load is held
by a stand-in of the map's render that waits on a gate the test opens."""

import asyncio
import threading

import holoviews as hv
import pytest
from asyncutil import until
from budget import budget

from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import data
from vibtrans_explorer.session.state import ExplorerState
from vibtrans_explorer.views import map as map_view
from vibtrans_explorer.views.map import DRAWING, READING, MapView

hv.extension("bokeh")  # as the explorer does

pytestmark = pytest.mark.skipif(
    not {("deformable", 0.1), ("deformable", 0.3), ("deformable", 1.0)} <= set(data.available_maps()),
    reason="needs the shipped deformable maps at mu = 0.1, 0.3 and 1",
)


class Gates:
    """A stand-in for a slow step: `wrap(fn)` waits, for each (model, mu),
    until the test opens its gate; `entered` and `left` tell where the
    worker is."""

    def __init__(self):
        self.gates, self.entered, self.left = {}, {}, {}
        self._lock = threading.Lock()

    def _events(self, key):
        with self._lock:
            for d in (self.gates, self.entered, self.left):
                d.setdefault(key, threading.Event())
        return self.gates[key], self.entered[key], self.left[key]

    def open(self, model, mu):
        self._events((model, mu))[0].set()

    def wrap(self, fn):
        def slow(model, mu, *rest):
            gate, entered, left = self._events((model, mu))
            entered.set()
            try:
                if not gate.wait(budget(60)):
                    raise AssertionError(f"the test never opened the gate of {model}, mu = {mu:g}")
                return fn(model, mu, *rest)
            finally:
                left.set()

        return slow

    def inside(self, model, mu):
        return self._events((model, mu))[1].is_set()

    def done(self, model, mu):
        return self._events((model, mu))[2].is_set()


@pytest.fixture
def gates(monkeypatch):
    """The map's render (reading the file within) held at each map's gate,
    the default map's open; no map of this test in the rendering cache."""
    map_view._map_json.cache_clear()
    g = Gates()
    g.open("deformable", 0.3)
    monkeypatch.setattr(map_view._map_json, "make", g.wrap(map_view._map_json.make))
    yield g
    for gate in list(g.gates.values()):
        gate.set()  # (a failed test's worker ends)
    map_view._map_json.cache_clear()  # (no stand-in's result is kept)


def _title(view):
    return view.figures[0].title.text


def _line(view):
    """The loading line's text while shown, else None."""
    return view.loading_line.object if view.loading_line.styles.get("display") != "none" else None


def _dimmed(view):
    return view.pane.styles.get("opacity") not in (None, "1")


async def _settled():
    """Every task left by the loads has ended."""
    await asyncio.gather(*(asyncio.all_tasks() - {asyncio.current_task()}))


def test_a_map_not_rendered_yet_loads_off_the_event_loop_and_says_so(gates):
    answered = []

    async def go():
        state = ExplorerState()
        view = MapView(
            state, on_click=lambda *a: None, answered=lambda: answered.append(state.mu), background=True
        )
        shown = view.figures[0]
        assert _title(view).endswith("mu = 0.3") and _line(view) is None and not _dimmed(view)
        state.mu = 0.1
        # at once, before any of the load: the line, the old map dimmed
        assert view.loading
        assert "Loading the map for deformable, mu = 0.1" in _line(view)
        assert _dimmed(view) and _title(view).endswith("mu = 0.3")
        # the load waits in a worker while this loop runs on
        await until(lambda: gates.inside("deformable", 0.1))
        assert view.loading and answered == []
        gates.open("deformable", 0.1)
        await until(lambda: not view.loading)
        assert view.figures[0] is shown  # updated in place, as a change of mu always was
        assert _title(view).endswith("mu = 0.1")
        assert _line(view) is None and not _dimmed(view)
        assert answered == [0.1]
        # shown again: from the cache, at once, nothing to load
        state.mu = 0.3
        assert not view.loading and _title(view).endswith("mu = 0.3")
        state.mu = 0.1
        assert not view.loading and _title(view).endswith("mu = 0.1")
        await _settled()

    asyncio.run(go())


def test_the_line_names_the_stage_a_map_not_read_yet_is_at(gates, monkeypatch):
    """A map whose file was not read in this process: first its file,
    then its drawing."""
    monkeypatch.setattr(map_view.data, "loaded", lambda model, mu: False)
    read = Gates()
    monkeypatch.setattr(map_view, "_read", read.wrap(lambda model, mu: None))

    async def go():
        state = ExplorerState()
        view = MapView(state, on_click=lambda *a: None, background=True)
        state.mu = 1.0
        assert READING in _line(view)
        await until(lambda: read.inside("deformable", 1.0))
        read.open("deformable", 1.0)
        await until(lambda: gates.inside("deformable", 1.0))
        await until(lambda: DRAWING in _line(view))
        gates.open("deformable", 1.0)
        await until(lambda: not view.loading)
        assert _title(view).endswith("mu = 1") and _line(view) is None
        await _settled()

    asyncio.run(go())


def test_a_newer_choice_wins_over_an_older_load(gates):
    answered = []

    async def go():
        state = ExplorerState()
        view = MapView(
            state, on_click=lambda *a: None, answered=lambda: answered.append(state.mu), background=True
        )
        state.mu = 0.1
        await until(lambda: gates.inside("deformable", 0.1))
        state.mu = 1.0  # another map not rendered yet: its load replaces the first
        assert "mu = 1" in _line(view) and "mu = 0.1" not in _line(view)
        await until(lambda: gates.inside("deformable", 1.0))
        gates.open("deformable", 1.0)
        await until(lambda: not view.loading)
        assert _title(view).endswith("mu = 1")
        # the older load ends later: its map is not shown
        gates.open("deformable", 0.1)
        await until(lambda: gates.done("deformable", 0.1))
        await _settled()
        assert _title(view).endswith("mu = 1") and _line(view) is None and not _dimmed(view)
        assert answered == [1.0]

    asyncio.run(go())


def test_a_choice_shown_at_once_ends_the_load_before_it(gates):
    """Back to the map shown before while another loads: shown at once,
    the line gone, and the load's map never shown."""

    async def go():
        state = ExplorerState()
        view = MapView(state, on_click=lambda *a: None, background=True)
        state.mu = 0.1
        await until(lambda: gates.inside("deformable", 0.1))
        state.mu = 0.3
        assert not view.loading and _line(view) is None and not _dimmed(view)
        assert _title(view).endswith("mu = 0.3")
        gates.open("deformable", 0.1)
        await until(lambda: gates.done("deformable", 0.1))
        await _settled()
        assert _title(view).endswith("mu = 0.3") and _line(view) is None

    asyncio.run(go())


def test_a_failed_load_says_so_over_the_old_map(gates, monkeypatch):
    make = map_view._map_json.make

    def broken(model, mu, *rest):
        if mu == 0.1:
            raise RuntimeError("the stand-in failed")
        return make(model, mu, *rest)

    monkeypatch.setattr(map_view._map_json, "make", broken)

    async def go():
        state = ExplorerState()
        view = MapView(state, on_click=lambda *a: None, background=True)
        state.mu = 0.1
        await until(lambda: not view.loading)
        assert "could not be drawn" in _line(view) and "reference" in _line(view)
        assert "stand-in" not in _line(view)  # (the server's words stay in its log)
        assert _dimmed(view) and _title(view).endswith("mu = 0.3")
        await _settled()

    asyncio.run(go())


def test_the_explorer_answers_a_mu_change_once_its_map_is_shown(gates):
    """The page's acknowledgement ("Drawing the map ...") is cleared when
    the map is shown, not when its load starts; the loading line is in the
    map's tab, over the map."""

    async def go():
        ex = E.Explorer()
        ex.map_view.background = True
        assert ex.map_view.loading_line in ex.map_pane.objects
        ack = ex.ack.object
        ex.state.mu = 0.1
        await until(lambda: gates.inside("deformable", 0.1))
        assert ex.ack.object == ack  # not answered yet
        gates.open("deformable", 0.1)
        await until(lambda: not ex.map_view.loading)
        assert ex.ack.object != ack  # answered
        assert _title(ex.map_view).endswith("mu = 0.1")
        ack = ex.ack.object
        ex.state.mu = 0.3  # shown at once: answered at once
        assert ex.ack.object != ack
        await _settled()

    asyncio.run(go())


def test_the_rendering_cache_makes_a_setting_once_for_threads_asking_at_once():
    made, release = [], threading.Event()

    def make(*setting):
        made.append(setting)
        release.wait(budget(30))
        return object()

    cache = map_view._Renders(make, 2)
    out = []
    threads = [threading.Thread(target=lambda: out.append(cache("a", 1))) for _ in range(3)]
    for t in threads:
        t.start()
    release.set()
    for t in threads:
        t.join(budget(30))
    assert made == [("a", 1)] and len(out) == 3 and out[0] is out[1] is out[2]
    assert ("a", 1) in cache and ("b", 1) not in cache
    cache("b", 1), cache("c", 1)  # (two kept: the oldest goes)
    assert ("a", 1) not in cache and ("c", 1) in cache
    cache.cache_clear()
    assert ("c", 1) not in cache


def test_the_loading_line_and_the_dimmed_map_lay_out_nothing(gates):
    """Shown and hidden by style: a change of a layout's `visible`, size
    or classes would make BokehJS lay out every figure of the page's main
    column again (tests/relayout.py).  Checked at a session's second load:
    the first change of any text pane of the page (this line, the stale
    note, the message) also sends the page design's stylesheets (Panel's)."""
    from bokeh.document import Document
    from bokeh.models import LayoutDOM, Plot
    from panel.io.state import set_curdoc
    from relayout import LAYOUT_PROPERTIES, PLOT_LAYOUT_PROPERTIES

    doc = Document()
    gates.open("deformable", 1.0)

    async def go():
        with set_curdoc(doc):
            ex = E.Explorer()
            E.explorer_template(ex).server_doc(doc)
            ex.map_view.background = True
            fig = ex.map_view.figures[0]
            (root,) = [r for r in doc.roots if fig in r.references()]
            main = set(root.references())
            ex.state.mu = 1.0  # (the first load)
            await until(lambda: not ex.map_view.loading)
            events = []
            doc.on_change(events.append)
            ex.state.mu = 0.1
            assert ex.map_view.loading
            await until(lambda: gates.inside("deformable", 0.1))
            gates.open("deformable", 0.1)
            await until(lambda: not ex.map_view.loading)
            await _settled()
        assert ex.map_view.figures[0] is fig and _title(ex.map_view).endswith("mu = 0.1")
        mine = [e for e in events if getattr(e, "model", None) in main]
        line, box = ex.map_view.loading_line, ex.map_view.pane
        assert {e.attr for e in mine if "vt-map-loading" in e.model.css_classes} == {"text", "styles"}
        assert {e.attr for e in mine if "vt-map" in e.model.css_classes} == {"styles"}
        assert line.styles == {"display": "none"} and box.styles.get("opacity") is None
        found = [
            (type(e.model).__name__, e.attr)
            for e in mine
            if (isinstance(e.model, LayoutDOM) and e.attr in LAYOUT_PROPERTIES)
            or (isinstance(e.model, Plot) and e.attr in PLOT_LAYOUT_PROPERTIES)
        ]
        assert found == []

    asyncio.run(go())


def test_a_map_asked_for_by_threads_at_once_is_read_once(monkeypatch):
    """Sessions load maps off the event loop: two asking for the same map
    at once get one read (app/server/data.py `_reading`)."""
    data.forget()
    reads, release = [], threading.Event()
    real = data.open_map

    def counted(path, expect=None):
        reads.append(path.rsplit("/", 1)[-1])
        release.wait(budget(30))
        return real(path, expect=expect)

    monkeypatch.setattr(data, "open_map", counted)
    out = []

    def ask():
        out.append(data.drift_map("deformable", 0.1))

    threads = [threading.Thread(target=ask) for _ in range(3)]
    for t in threads:
        t.start()
    release.set()
    for t in threads:
        t.join(budget(60))
    assert len(out) == 3 and out[0] is out[1] is out[2]
    assert reads.count("deformable-mu0.1.zarr") == 1
    assert data.loaded("deformable", 0.1) and not data.loaded("deformable", 1.0)
