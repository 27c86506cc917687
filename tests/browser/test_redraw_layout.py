"""A change of mu or of the model redraws the map in the browser
within 0.5 s (`python -m devtools.browserbench --check`).

A Chrome trace of those redraws showed the time
going to BokehJS laying out every figure of the page's main column again,
each forcing a style recalculation: after a run, 1.0-1.7 s of "Recalculate
Style" per change.  Two changes of the page set that off, not the map's own
update: the stale note's `visible` (any LayoutDOM's `visible`, size, margin,
CSS classes or children: BokehJS's `invalidate_layout` of the layout root)
and the acknowledgement's text in a Bokeh `Div` (BokehJS's MarkupView
re-renders at every change, then computes the root's layout).

A third: the map's colour bar, whose labels differ for every map (each
side of the paper's scale runs to that map's largest drift): a change of
a ColorBar's labels, ticks, ticker or formatter makes BokehJS lay out the
whole root again (the bar marks its layout dirty whatever its size).  The
labels are now read from a source (app/views/map.py BAR_LABELS).

The test checks that mechanism, not a time: the document changes a mu or
model change makes in a served page after a run (what Bokeh sends to the
browser) touch no such property of a model in the page's main column (the
map's root: the map, the run's figures).  The sidebar's widgets may change
(its own root: the selector's options, the point mass's controls)."""

import asyncio

import panel as pn
import pytest
from bokeh.document import Document
from bokeh.models import ColorBar, LayoutDOM, Plot, Ticker, TickFormatter
from bokeh.models.widgets.markups import Markup
from panel.io.state import set_curdoc
from relayout import LAYOUT_PROPERTIES, PLOT_LAYOUT_PROPERTIES
from standin import StandIn

from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import data

pytestmark = pytest.mark.slow  # an explorer session with a run, ~10 s


def relayouts(events, models):
    """The changes among `events` that make BokehJS lay out a whole root
    again, of a model in `models`: (model type, property)."""
    out = []
    for e in events:
        model, attr = getattr(e, "model", None), getattr(e, "attr", None)
        if model is None or model not in models:
            continue
        if isinstance(model, LayoutDOM) and attr in LAYOUT_PROPERTIES:
            out.append((type(model).__name__, attr))
        elif isinstance(model, Plot) and attr in PLOT_LAYOUT_PROPERTIES:
            out.append((type(model).__name__, attr))
        elif (
            isinstance(model, Markup) and type(model).__module__.startswith("bokeh.") and attr == "text"
        ):  # a Bokeh Div's view re-renders at any change
            out.append((type(model).__name__, attr))
        elif isinstance(model, (ColorBar, Ticker, TickFormatter)):
            # BokehJS's ColorBarView passes any change of the bar to its axis,
            # and the axis asks for a layout at a change of its labels,
            # ticker or formatter: the bar then marks its layout dirty
            # whatever its size (its `request_layout`), so the plot lays out
            # its layout root again
            out.append((type(model).__name__, attr))
    return out


def _served_page():
    """A page as `vibtrans serve` builds it (Panel's server_doc), a run of
    its scene drawn; (document, explorer)."""
    doc = Document()
    with set_curdoc(doc):
        ex = E.Explorer(simulate=StandIn())
        pending = []
        ex.controller.schedule = pending.append
        E.explorer_template(ex).server_doc(doc)
        ex.state.fidelity = "preview"
        ex.start_run()
        asyncio.run(pending.pop()())
    assert "drift" in ex.summary_view.pane.object and not ex.stale_shown()
    return doc, ex


def _main_root(doc, ex):
    """The document root holding the map (the page's main column)."""
    fig = ex.map_view.figures[0]
    (root,) = [r for r in doc.roots if fig in r.references()]
    return root


@pytest.mark.parametrize(
    "changes",
    [
        [("mu", 0.1), ("mu", 0.3)],
        [("model", "point-mass"), ("model", "deformable")],
    ],
    ids=["mu", "model"],
)
def test_a_mu_or_model_change_lays_out_nothing_in_the_main_column(changes):
    if not {("deformable", 0.1), ("deformable", 0.3), ("point-mass", 0.3)} <= set(data.available_maps()):
        pytest.fail("the shipped maps are missing (assets/maps)")
    doc, ex = _served_page()
    assert ex.state.mu == 0.3 and ex.state.model == "deformable"
    main = set(_main_root(doc, ex).references())
    figure = ex.map_view.figures[0]
    events = []
    doc.on_change(events.append)
    stale_seen = []
    with set_curdoc(doc):
        for name, value in changes:
            events.clear()
            setattr(ex.state, name, value)
            stale_seen.append(ex.stale_shown())
            # the map updated in place (no new figure) and the run marked
            # stale or not: the change did reach the page
            assert ex.map_view.figures[0] is figure
            assert any(getattr(e, "model", None) in main for e in events)
            found = relayouts(events, main)
            assert found == [], (name, value, found)
    # the first change made the run stale, the second made it current again
    assert stale_seen == [True, False]


def test_the_check_sees_a_relayout():
    """The check itself: a layout's `visible`, a Bokeh Div's text and a
    colour bar's labels in the main column are found (what the page did
    before)."""
    from bokeh.models import Div, LinearColorMapper
    from bokeh.plotting import figure

    doc = Document()
    div, column = Div(text=""), pn.Column(pn.pane.Markdown("x")).get_root(doc)
    fig = figure()
    bar = ColorBar(color_mapper=LinearColorMapper(palette="Viridis256"))
    fig.add_layout(bar, "right")
    doc.add_root(pn.Column().get_root(doc))
    events = []
    doc.add_root(column)
    column.children.extend([div, fig])
    doc.on_change(events.append)
    div.text = "<p>busy</p>"
    column.children[0].visible = False
    column.styles = {"color": "red"}  # a style: no layout
    bar.major_label_overrides = {0: "-2800"}
    assert relayouts(events, set(column.references())) == [
        ("Div", "text"),
        (type(column.children[0]).__name__, "visible"),
        ("ColorBar", "major_label_overrides"),
    ]


@pytest.fixture
def page(browser, served_explorer):
    pg = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    yield pg
    pg.close()
    assert not errors, errors


@pytest.mark.browser
def test_the_stale_note_shows_and_hides_in_the_browser(page, served_explorer):
    """The stale note, shown and hidden by its style: after a run, a new mu
    shows it over the run's figures, the run's mu hides it again (an empty
    style left it hidden: BokehJS only sets the properties it is given)."""
    from browserpages import settle
    from budget import budget_ms

    page.goto(served_explorer.url + "?la=1&lm=2&fidelity=preview")  # a link with a scene runs it
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(120))
    settle(page)
    # the note's own words (the summary says "Changed since this run" too);
    # Playwright's text locator looks into the pane's shadow root
    note = page.locator(".vt-stale").get_by_text("figures and downloads below").first
    assert page.locator(".vt-stale").count() == 1 and not note.is_visible()
    select = page.get_by_label("mu (shipped maps)", exact=True)
    select.select_option("0.1")
    note.wait_for(state="visible", timeout=budget_ms(30))
    select.select_option("0.3")
    note.wait_for(state="hidden", timeout=budget_ms(30))


@pytest.mark.browser
def test_the_point_mass_controls_wait_hidden_in_a_loaded_page(page, served_explorer):
    """The material point's controls are built, hidden, once the page has
    loaded (app/views/scene.py), so that the first switch to the point mass
    only shows them: built at that switch, their new views made the
    browser's redraw of the map 0.1-0.3 s slower)."""
    from browserpages import settle
    from budget import budget_ms

    page.goto(served_explorer.url)
    page.get_by_role("button", name="point-mass", exact=True).first.wait_for(timeout=budget_ms(120))
    settle(page)
    rule = page.get_by_text("stick rule (point mass: slide -> stick)").first
    rule.wait_for(state="attached", timeout=budget_ms(30))
    assert not rule.is_visible()
    page.get_by_role("button", name="point-mass", exact=True).first.click()
    rule.wait_for(state="visible", timeout=budget_ms(30))
    page.get_by_role("button", name="deformable", exact=True).first.click()
    rule.wait_for(state="hidden", timeout=budget_ms(30))
