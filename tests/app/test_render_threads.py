"""Bokeh's property validation is one flag for the whole process
(`validate(False)` sets `Property._should_validate`), and HoloViews holds it
off around updates of a render's sources, in the worker threads that render
maps on demand.  The explorer answers with public APIs only
(docs/how-to/deployment.md 1.1): every HoloViews render holds one lock
(views/render.py), so no two renders switch the flag at once, and what is
built outside a render needs nothing of validation: every value given to
Bokeh there is of its property's type already (a figure's title a Title,
not a string that only validation converts).  A five-map load test lost
46 drawings to a title left a string."""

import asyncio
import threading

from asyncutil import until
from bokeh.core.property.validation import validate
from bokeh.document import Document
from bokeh.models import Plot, Title
from bokeh.plotting import figure
from panel.io.state import set_curdoc

from vibtrans_explorer import explorer as E
from vibtrans_explorer.views.render import exclusively


def test_bokehs_validation_switch_is_one_flag_for_the_process():
    """The hazard, in stock Bokeh: a figure built while another thread holds
    `validate(False)` keeps its title a string.  Fails on the day Bokeh
    keeps the switch per thread: the rule above is then no longer needed
    (docs/how-to/deployment.md 1.1)."""
    inside, leave = threading.Event(), threading.Event()

    def holoviews_like():
        with validate(False):
            inside.set()
            leave.wait(10)

    other = threading.Thread(target=holoviews_like)
    other.start()
    try:
        assert inside.wait(10)
        fig = figure(title="built meanwhile")
    finally:
        leave.set()
        other.join()
    assert fig.title == "built meanwhile", "Bokeh's validation switch is per thread now"
    assert isinstance(figure(title="after").title, Title)


class RendersInAnotherThread:
    """A stand-in for the map renders of other sessions: a thread that
    holds validation off nearly all the time, each hold inside the render
    lock as HoloViews' is (a render of this thread waits for a gap)."""

    def __init__(self, hold_s=0.02):
        self.hold_s, self.stop, self.held = hold_s, threading.Event(), threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _hold(self):
        with validate(False):
            self.held.set()
            self.stop.wait(self.hold_s)

    def _run(self):
        while not self.stop.is_set():
            exclusively(self._hold)
            self.stop.wait(0.001)  # the lock's gap: a waiting render gets it

    def __enter__(self):
        self.thread.start()
        assert self.held.wait(10)
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(10)


def _invalid(models):
    """'Model.property: value' for each property value that is not of its
    property's type (checked by the property itself, whatever the switch)."""
    bad = []
    for m in models:
        for name in m.properties():
            try:
                value = getattr(m, name)
            except Exception:
                continue  # (unset and without a default)
            try:
                m.lookup(name).property.validate(value, False)
            except ValueError:
                bad.append(f"{type(m).__name__}.{name}: {value!r:.80}")
    return bad


def test_what_is_built_outside_a_render_needs_no_validation():
    """The page (its every tab opened) and a run's figures, built while
    another thread holds validation off as a render does: every value of
    every model of the page is of its property's type."""
    E.Explorer()  # (the map of the first page rendered here, outside the test's hold)

    async def go():
        doc, seen = Document(), {}

        def look():  # the models of the page as the browser has them now
            seen.update((m.id, m) for m in doc.models)

        with RendersInAnotherThread(), set_curdoc(doc):
            ex = E.Explorer()
            ex.state.param.update(fidelity="preview", compare="none")
            E.explorer_template(ex).server_doc(doc)
            for tabs in (ex.map_tabs, ex.runs.tabs):
                for i in [*range(1, len(tabs)), 0]:
                    tabs.active = i
                    look()
            ex.start_run()
            await until(lambda: ex.controller.job is None and ex.controller.result is not None)
            for i in [*range(1, len(ex.runs.tabs)), 0]:  # each run tab showing the run
                ex.runs.tabs.active = i
                look()
        return list(seen.values())

    models = asyncio.run(go())
    figures = [m for m in models if isinstance(m, Plot)]
    assert len(figures) > 10
    assert all(f.title is None or isinstance(f.title, Title) for f in figures)
    assert _invalid(models) == []
