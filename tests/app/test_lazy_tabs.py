"""The explorer's tabs hold only the open tab's content (views/tabs.py): a
hidden tab's views are not in the page, and a text changed while its tab
is hidden keeps the page's stylesheets on our own server (Panel's dynamic
Tabs resolved them to its CDN: docs/how-to/deployment.md 1.2)."""

import asyncio

import panel as pn
from asyncutil import until
from bokeh.document import Document
from bokeh.models import ImportedStyleSheet
from panel.io.resources import CDN_DIST, LOCAL_DIST
from panel.io.state import set_curdoc

from vibtrans_explorer import explorer as E
from vibtrans_explorer.views.tabs import lazy_tabs


def _served_document():
    """A document whose stylesheets are served locally, as a served page's."""
    doc = Document()
    doc.template_variables["dist_url"] = LOCAL_DIST
    return doc


def _cdn_stylesheets(doc):
    return sorted(
        s.url
        for m in doc.models
        for s in getattr(m, "stylesheets", ())
        if isinstance(s, ImportedStyleSheet) and s.url.startswith(CDN_DIST)
    )


def test_only_the_open_tab_is_in_the_page_and_a_hidden_text_keeps_local_stylesheets():
    doc = _served_document()
    shown, hidden = pn.pane.Markdown("shown"), pn.pane.Markdown("hidden")
    tabs = lazy_tabs(("shown", shown), ("hidden", hidden), active=1)
    with set_curdoc(doc):
        doc.add_root(tabs.get_root(doc))

        def has(word):
            return any(word in (getattr(m, "text", None) or "") for m in doc.models)

        assert has("hidden") and not has("shown")
        tabs.active = 0
        assert has("shown") and not has("hidden")
        hidden.object = "changed while out of sight"
        tabs.active = 1
        assert has("changed while out of sight") and not has("shown")
    assert _cdn_stylesheets(doc) == []


def test_the_explorers_tabs_keep_every_stylesheet_local():
    """Every tab of the map's and of the run's opened, then a run shown
    while most are hidden (their texts change: the downloads', the
    memory diagram's, the design's note) and every tab opened again: no
    stylesheet of the page is on Panel's CDN."""

    async def go():
        doc = _served_document()
        with set_curdoc(doc):
            ex = E.Explorer()
            ex.state.param.update(fidelity="preview", compare="none")
            E.explorer_template(ex).server_doc(doc)
            tab_sets = (ex.map_tabs, ex.runs.tabs)
            for tabs in tab_sets:
                for i in [*range(1, len(tabs)), 0]:
                    tabs.active = i
            ex.start_run()
            await until(lambda: ex.controller.job is None and ex.controller.result is not None)
            assert _cdn_stylesheets(doc) == []
            for tabs in tab_sets:
                for i in [*range(1, len(tabs)), 0]:
                    tabs.active = i
                    assert _cdn_stylesheets(doc) == [], (tabs.name, i)

    asyncio.run(go())
