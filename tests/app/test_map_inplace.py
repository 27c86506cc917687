"""A new mu, v0*, model or way of drawing chaotic points updates the shown
map figure in place (app/views/map.py update_in_place): the browser
repaints one plot instead of building a new figure.  What it then draws
must equal a freshly built figure of the new settings: every source's data,
which renderers are shown and where the resonance lines lie, the colour
bar's ticks, labels and title, the key's entries shown, the hover and the
title.  Another layer builds a new figure."""

import holoviews as hv
import numpy as np
import pytest
from bokeh.models import ColorBar, HoverTool, Legend

from vibtrans.products.plots import RESONANCE_LABEL, colour_ticks
from vibtrans_explorer.server import data
from vibtrans_explorer.session.state import ExplorerState
from vibtrans_explorer.views.map import LYAPUNOV_LAYER, MapView, bar_labels, map_figure

hv.extension("bokeh")  # as the explorer does


def _drawn(fig):
    """What a map figure draws, comparable between two figures."""
    sources, shown = [], []
    for r in fig.renderers:
        src = getattr(r, "data_source", None)
        if src is not None and set(src.data) == {"x", "y"}:
            continue  # the session's markers (shared)
        shown.append((type(r).__name__, r.visible, getattr(r, "location", None)))
        if src is None or not src.data:
            continue  # the key's swatches
        sources.append({k: np.asarray(v) for k, v in src.data.items()})
    (bar,) = fig.select(type=ColorBar)
    labels = bar_labels(bar)
    return {
        "sources": sources,
        "ticks": sorted(labels),
        "labels": labels,
        "bar": bar.title,
        "key": [
            (str(getattr(i.label, "value", i.label)), i.visible)
            for legend in fig.select(type=Legend)
            for i in legend.items
        ],
        "shown": shown,
        "hover": [h.tooltips for h in fig.select(type=HoverTool)],
        "title": fig.title.text,
    }


def _assert_same(a, b):
    assert len(a["sources"]) == len(b["sources"]) > 0
    for x, y in zip(a["sources"], b["sources"]):
        assert x.keys() == y.keys()
        for k in x:
            assert np.array_equal(x[k], y[k], equal_nan=x[k].dtype.kind == "f"), k
    for k in ("shown", "ticks", "labels", "bar", "key", "hover", "title"):
        assert a[k] == b[k], k


@pytest.mark.parametrize("change", [{"mu": 0.1}, {"v0": 0.05}, {"mu": 1.0, "v0": 0.3}])
def test_a_new_mu_or_v0_updates_the_figure_to_what_a_new_one_draws(change):
    if not {("deformable", 0.1), ("deformable", 1.0)} <= set(data.available_maps()):
        pytest.fail("the shipped maps are missing (assets/maps)")
    state = ExplorerState()
    view = MapView(state, on_click=lambda *a: None)
    shown = view.figures[0]
    before = _drawn(shown)
    state.param.update(**change)
    assert view.figures[0] is shown  # updated, not replaced
    fresh = map_figure(state.model, state.mu, state.v0, state.chaotic, state.layer, state.orbits)
    after = _drawn(shown)
    _assert_same(after, _drawn(fresh))
    # and it changed (not two pictures of the old settings)
    assert any(after[k] != before[k] for k in ("title", "ticks", "labels", "bar", "key"))


@pytest.mark.parametrize(
    "change", [{"model": "point-mass"}, {"chaotic": "colour"}, {"model": "point-mass", "chaotic": "colour"}]
)
def test_another_model_or_colouring_updates_the_figure_too(change):
    state = ExplorerState()
    view = MapView(state, on_click=lambda *a: None)
    shown = view.figures[0]
    before = _drawn(shown)
    state.param.update(**change)
    assert view.figures[0] is shown
    fresh = map_figure(state.model, state.mu, state.v0, state.chaotic, state.layer, state.orbits)
    after = _drawn(shown)
    _assert_same(after, _drawn(fresh))
    # what differs is drawn: the grey layer's key entry hidden in colour,
    # the resonances (lines and key entry) hidden for the point mass
    key = dict(after["key"])
    grey = next(k for k in key if k.startswith("grey: chaotic"))
    assert key[grey] == (state.chaotic == "grey") and dict(before["key"])[grey]
    assert key[RESONANCE_LABEL] == (state.model == "deformable")
    spans = [v for t, v, _ in after["shown"] if t == "Span"]
    assert spans and all(v == (state.model == "deformable") for v in spans)
    state.param.update(model="deformable", chaotic="grey")  # and back
    _assert_same(_drawn(shown), before)


def test_another_layer_builds_a_new_figure():
    state = ExplorerState()
    view = MapView(state, on_click=lambda *a: None)
    shown = view.figures[0]
    state.layer = LYAPUNOV_LAYER
    assert view.figures[0] is not shown


def test_the_shipped_map_after_a_computed_one_is_a_new_figure():
    state = ExplorerState()
    view = MapView(state, on_click=lambda *a: None)
    computed = map_figure("deformable", 0.3, state.v0, state.chaotic)  # a stand-in
    view.show_computed(computed, ((-1.0, 1.0), (-1.0, 1.0)), lambda la, lm: None)
    view.show_shipped()
    assert view.figures[0] is not computed


def test_a_model_without_a_map_at_that_mu_is_a_new_figure():
    """No shipped point-mass map at mu = 0.1: its message is a figure of
    its own (a click on it runs nothing), and the map after it a new one."""
    if ("point-mass", 0.1) in data.available_maps():
        pytest.fail("a point-mass map at mu = 0.1 ships: pick a mu without one")
    state = ExplorerState(mu=0.1)
    view = MapView(state, on_click=lambda *a: None)
    shown = view.figures[0]
    state.model = "point-mass"
    message = view.figures[0]
    assert message is not shown and not message.select(type=ColorBar)
    state.model = "deformable"
    assert view.figures[0] is not message and _drawn(view.figures[0])["sources"]


def test_prerendered_maps_serve_every_shipped_setting_without_a_render(monkeypatch):
    """The server's warm-up (map.prerender) renders each shipped map's
    settings once; afterwards a page, and a change of model, mu or the
    chaotic points' colour among the shipped maps, renders nothing (each
    render costs the event loop 0.3-1.8 s).  The warm-up's calls once
    missed the cache that the pages read (other arguments passed by name)."""
    from vibtrans_explorer.views import map as map_view

    map_view._map_json.cache_clear()
    map_view.prerender()
    renders = []
    real = map_view.rendered
    monkeypatch.setattr(map_view, "rendered", lambda *a, **k: renders.append(a[1:3]) or real(*a, **k))
    state = ExplorerState()
    view = MapView(state, on_click=lambda *a: None)
    for model, mu in sorted(data.available_maps()):
        state.param.update(model=model, mu=mu)
        for chaotic in ("colour", "grey"):
            state.chaotic = chaotic
    state.layer = LYAPUNOV_LAYER
    assert view.figures and renders == []


def test_renderers_share_parts_and_draw_what_they_drew_alone():
    """views/map.py `_shared_parts`: the map's sources share one selection,
    policy and filter, renderers drawing the same rows share one source and
    view; every renderer still finds, under each field its glyph reads,
    the column it read before sharing (a figure rendered unshared, the
    same setting)."""
    from bokeh.models import GlyphRenderer

    from vibtrans_explorer.views import map as map_view
    from vibtrans_explorer.views.render import rendered

    _, alone = rendered(map_view.map_element, "deformable", 0.3, 1.0, "grey")
    _, shared = rendered(map_view.map_element, "deformable", 0.3, 1.0, "grey")
    map_view._shared_parts(shared)
    pairs = [(a, s) for a, s in zip(alone.renderers, shared.renderers) if isinstance(a, GlyphRenderer)]
    assert len(pairs) >= 8
    fields = 0
    for a, s in pairs:
        assert type(a.glyph) is type(s.glyph)
        for name, spec in a.glyph.properties_with_values(include_defaults=False).items():
            field = spec.get("field") if isinstance(spec, dict) else getattr(spec, "field", None)
            if isinstance(field, str):
                fields += 1
                before = np.asarray(a.data_source.data[field])
                after = np.asarray(s.data_source.data[field])
                assert np.array_equal(before, after, equal_nan=before.dtype.kind == "f"), (a.glyph, name)
    assert fields >= 8
    renderers = [s for _, s in pairs]
    sources = {id(r.data_source): r.data_source for r in renderers}
    assert len(sources) < len(renderers)  # the key's swatches share one
    assert len({id(s.selected) for s in sources.values()}) == 1
    assert len({id(s.selection_policy) for s in sources.values()}) == 1
    assert len({id(r.view.filter) for r in renderers}) == 1
    for r in renderers:  # one view per source, never across sources
        assert all(o.view is not r.view or o.data_source is r.data_source for o in renderers)


@pytest.mark.parametrize("change", [{"model": "point-mass"}, {"mu": 0.1}])
def test_a_change_builds_no_figure_and_sends_only_the_data_that_differs(change, monkeypatch):
    """The model redraw in 0.5 s: the shown figure is updated
    from the rendering cache's values (`map_content`), without decoding a
    figure of the new setting (0.1-0.25 s of the event loop a change), and
    only the sources whose data differ are set (each one set is sent to the
    browser and redrawn there; a model change set all twelve before)."""
    from bokeh.document import Document
    from bokeh.document.events import ColumnDataChangedEvent, ModelChangedEvent
    from bokeh.models import ColumnDataSource

    from vibtrans_explorer.views import map as map_view

    if ("deformable", 0.1) not in data.available_maps():
        pytest.fail("the shipped maps are missing (assets/maps)")
    state = ExplorerState()
    view = MapView(state, on_click=lambda *a: None)
    shown = view.figures[0]
    doc = Document()
    doc.add_root(shown)
    new = {**state.param.values(), **change}
    fresh = map_view.map_figure(
        new["model"], new["mu"], new["v0"], new["chaotic"], new["layer"], new["orbits"]
    )
    # the sources whose data the new setting changes (one source may serve
    # several renderers)
    differ = {
        id(r.data_source)
        for r, f in zip(shown.renderers, fresh.renderers)
        if hasattr(r, "data_source") and not _same_data(r.data_source.data, f.data_source.data)
    }
    assert differ and len(differ) < len(
        {id(r.data_source) for r in shown.renderers if hasattr(r, "data_source")}
    )
    # and the colour bar's labels (a source of their own: map.BAR_LABELS)
    (bar,) = shown.select(type=ColorBar)
    assert bar_labels(bar) != bar_labels(fresh.select_one({"type": ColorBar}))
    differ.add(id(bar.ticker.args["source"]))
    built = []
    real = map_view.map_figure
    monkeypatch.setattr(map_view, "map_figure", lambda *a, **k: built.append(a) or real(*a, **k))
    events = []
    doc.on_change(events.append)
    state.param.update(**change)
    assert view.figures[0] is shown and built == []
    sent = {
        id(e.model)
        for e in events
        if isinstance(e.model, ColumnDataSource)
        and (isinstance(e, ColumnDataChangedEvent) or (isinstance(e, ModelChangedEvent) and e.attr == "data"))
    }
    assert sent == differ
    _assert_same(_drawn(shown), _drawn(fresh))
    # the labels are the paper's scale of the map shown (products.plots)
    ds = data.drift_map(state.model, state.mu)
    want = colour_ticks(ds["drift_velocity"].values, state.v0)
    assert bar_labels(bar) == want


def _same_data(a, b):
    """Two sources' data equal (NaN equal to NaN)."""
    if a.keys() != b.keys():
        return False
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        nan = x.dtype.kind == "f" and y.dtype.kind == "f"
        if x.shape != y.shape or not np.array_equal(x, y, equal_nan=nan):
            return False
    return True
