"""Workarounds for bugs of the explorer's frameworks: the only place where
the app changes Panel's, Param's, Bokeh's or HoloViews' code.  Each is
applied only where its probe shows the bug in the installed version, so a
version that fixes it runs stock; tests/app/test_compat.py fails on the day a
version fixes one (then delete it here).  Each is written up, with its
measurement and its upstream report, in docs/how-to/deployment.md.

1. Bokeh's property validation is one flag for the whole process
   (`bokeh.core.property.validation.validate` sets
   `Property._should_validate`).  HoloViews turns it off around updates of
   a render's sources (`with validate(False)`, holoviews/plotting/bokeh/
   plot.py), and the explorer renders maps on demand in worker threads
   (views/render.py), so a figure the event loop builds meanwhile is left
   unvalidated and unconverted: a title given as a string stays a string
   instead of becoming a Title, and the figure fails to draw (a five-map
   load test, `python -m devtools.loadtest --maps 5`: 46 failed drawings).
   Workaround: the switch kept per thread.

2. Panel's text panes (Markdown, HTML, Alert) update a model with the
   properties of the model's own document (`HTMLBasePane._update`).  A
   hidden tab of a `Tabs(dynamic=True)` keeps its rendered models detached
   (no document), so a pane updated while its tab is hidden gets its
   stylesheets resolved for no document: Panel's CDN.  The stylesheet
   objects are shared, so once the tab is shown again the page fetches its
   theme, markdown.css and loading.css from cdn.holoviz.org (a page offline
   loses its table borders and padding).  Workaround: a detached model is
   updated with the properties of the session's document, as an attached
   one is.

3. Panel's Location parses the browser's query in its `search` watcher
   (`parse_query`: '²'.isdigit() is true, int('²') raises) even when it
   syncs nothing, as the template's Location of the explorer does (it
   reads its link itself): a link '?la=²' logged Panel's traceback when the
   page connected.  Workaround: a Location that syncs nothing parses nothing.

`apply()` is called once by the server (app/server/serve.py); nothing else here
runs at import.  Nothing here imports the rest of the app.
"""

import threading
import traceback

from bokeh.core.property import bases, validation

_VALIDATION = threading.local()  # .on: this thread's switch (None: Bokeh's default)
_STOCK = {
    "validation_on": bases.validation_on,
    "validate_init": validation.validate.__init__,
    "validate_exit": validation.validate.__exit__,
}


def validation_switch_is_process_wide(timeout=10.0):
    """The probe of bug 1: True when `validate(False)` held in another
    thread turns validation off in this one."""
    inside, leave = threading.Event(), threading.Event()

    def other():
        with validation.validate(False):
            inside.set()
            leave.wait(timeout)

    thread = threading.Thread(target=other, name="vibtrans-compat-probe", daemon=True)
    thread.start()
    try:
        if not inside.wait(timeout):
            raise RuntimeError("the validation probe's thread did not start")
        return not bases.validation_on()
    finally:
        leave.set()
        thread.join(timeout)


def _validation_on():
    on = getattr(_VALIDATION, "on", None)
    return bases.Property._should_validate if on is None else on


def _switch(self, value):
    self.old = getattr(_VALIDATION, "on", None)
    _VALIDATION.on = value


def _restore(self, typ, value, traceback):
    _VALIDATION.on = self.old


def _validation_per_thread():
    bases.validation_on = _validation_on
    validation.validate.__init__ = _switch
    validation.validate.__exit__ = _restore


def _stock_validation():
    """Bokeh's own switch back (for tests)."""
    bases.validation_on = _STOCK["validation_on"]
    validation.validate.__init__ = _STOCK["validate_init"]
    validation.validate.__exit__ = _STOCK["validate_exit"]


def hidden_tab_update_fetches_the_cdn():
    """The probe of bug 2: True when a Markdown pane updated while its tab
    is hidden (a dynamic Tabs) comes back with stylesheets on Panel's CDN,
    in a document whose stylesheets are served locally."""
    import panel as pn
    from bokeh.document import Document
    from bokeh.models import ImportedStyleSheet
    from panel.io.resources import CDN_DIST, LOCAL_DIST
    from panel.io.state import set_curdoc

    doc = Document()
    doc.template_variables["dist_url"] = LOCAL_DIST  # as a served page's
    shown, hidden = pn.pane.Markdown("shown"), pn.pane.Markdown("hidden")
    tabs = pn.Tabs(("shown", shown), ("hidden", hidden), dynamic=True, active=1)
    with set_curdoc(doc):
        doc.add_root(tabs.get_root(doc))
        tabs.active = 0
        hidden.object = "changed while hidden"
        tabs.active = 1
    urls = {
        s.url for m in doc.models for s in getattr(m, "stylesheets", ()) if isinstance(s, ImportedStyleSheet)
    }
    return any(u.startswith(CDN_DIST) for u in urls)


def _text_update_in_the_sessions_document():
    from panel.io.state import state
    from panel.pane.markup import HTMLBasePane

    stock = _STOCK.setdefault("text_update", HTMLBasePane._update)

    def _update(self, ref, model):
        doc = state.curdoc
        if model.document is None and doc is not None and not self.enable_streaming:
            model.update(**self._get_properties(doc))
        else:
            stock(self, ref, model)

    HTMLBasePane._update = _update


def _stock_text_update():
    from panel.pane.markup import HTMLBasePane

    if "text_update" in _STOCK:
        HTMLBasePane._update = _STOCK["text_update"]


def unsynced_location_parses_the_query():
    """The probe of bug 2.1's other face: True when a Location that syncs
    nothing still parses each query it is given (its `search` watcher
    calls `parse_query`): the browser sends the page's address to the
    template's Location when the page connects, and '?la=²' failed there
    (Panel logged the failure with its traceback)."""
    from panel.io.location import Location

    try:
        Location(pathname="/").search = "?la=²"
    except ValueError:
        return True
    return False


def _parse_only_what_is_synced():
    from panel.io.location import Location

    stock = _STOCK.setdefault("update_synced", Location._update_synced)

    def _update_synced(self, event=None):
        if self._synced:  # (nothing synced: nothing to read in the query)
            stock(self, event)

    Location._update_synced = _update_synced


def _stock_update_synced():
    from panel.io.location import Location

    if "update_synced" in _STOCK:
        Location._update_synced = _STOCK["update_synced"]


def is_panels_query_parse_failure(exception):
    """True for bug 2.1's failure: Panel's Location parses the browser's raw
    query in its own watcher (`parse_query`: int('²') raises).  The explorer
    reads the link itself (app/session/urlstate.py) and says what is wrong with it,
    so this failure changes nothing on the page: logged, not said."""
    return isinstance(exception, ValueError) and any(
        frame.name == "parse_query" and "panel" in frame.filename
        for frame in traceback.extract_tb(exception.__traceback__)
    )


# (name, probe: True where the bug shows, workaround, undo)
WORKAROUNDS = [
    (
        "Bokeh's validation switch per thread (docs/how-to/deployment.md 1.1)",
        validation_switch_is_process_wide,
        _validation_per_thread,
        _stock_validation,
    ),
    (
        "Panel's text panes updated in a hidden tab keep the page's stylesheets "
        "(docs/how-to/deployment.md 1.2)",
        hidden_tab_update_fetches_the_cdn,
        _text_update_in_the_sessions_document,
        _stock_text_update,
    ),
    (
        "Panel's Location parses no query when it syncs nothing (docs/how-to/deployment.md 1.3)",
        unsynced_location_parses_the_query,
        _parse_only_what_is_synced,
        _stock_update_synced,
    ),
]


def applied():
    """The names of the workarounds applied in this process."""
    return [name for name, *_ in WORKAROUNDS if name in _APPLIED]


_APPLIED = set()


def apply():
    """Apply each workaround whose bug the installed versions show
    (idempotent); returns one line per workaround saying which."""
    lines = []
    for name, shows, workaround, _ in WORKAROUNDS:
        if name in _APPLIED:
            lines.append(f"{name}: applied")
        elif shows():
            workaround()
            _APPLIED.add(name)
            lines.append(f"{name}: applied (the bug shows in the installed version)")
        else:
            lines.append(f"{name}: not needed (the installed version does not show the bug)")
    return lines


def undo():
    """Every workaround undone (for tests)."""
    for name, _, _, stock in WORKAROUNDS:
        if name in _APPLIED:
            stock()
            _APPLIED.discard(name)
