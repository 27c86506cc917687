"""HoloViews elements rendered into Bokeh models of a Document of our own.

`hv.render` attaches the plot it makes to `curdoc()`, which in a server
callback can be a session's document that has already been destroyed (a
closed page's: its attributes are deleted, and setting the theme then
raises AttributeError, breaking the redraw that asked).  The figures the
explorer renders once and shares between sessions belong to no session, so
they are rendered into a fresh Document instead.

HoloViews' rendering is not thread-safe (its plots share class-level state:
two renders at once leave a figure's title a plain string, and the second
raises AttributeError in `_update_title`).  Maps on demand are rendered off
the event loop, several at once since four maps compute together, so every
render here holds one lock.

Bokeh's property validation is switched per thread here (`_validation_per_thread`).
HoloViews turns it off around some updates of a render's sources
(`with validate(False)`), and Bokeh keeps that switch in one flag for the
whole process: a figure built on the event loop while a map rendered in a
worker thread got its title left a plain string, which validation would
have made a Title (a five-map load test: 46 failed drawings)."""
import threading

import holoviews as hv
from bokeh.core.property import bases, validation
from bokeh.document import Document

_LOCK = threading.Lock()
_VALIDATION = threading.local()      # .on: this thread's switch (None: Bokeh's default)


def _validation_on():
    on = getattr(_VALIDATION, "on", None)
    return bases.Property._should_validate if on is None else on


def _switch(self, value):
    self.old = getattr(_VALIDATION, "on", None)
    _VALIDATION.on = value


def _restore(self, typ, value, traceback):
    _VALIDATION.on = self.old


def _validation_per_thread():
    """Make `bokeh.core.property.validation.validate` (a context manager,
    used by HoloViews) switch validation for its own thread only: Bokeh's
    `validation_on`, which property values are checked by, reads the
    thread's switch."""
    if getattr(validation.validate, "per_thread", False):
        return
    bases.validation_on = _validation_on
    validation.validate.__init__ = _switch
    validation.validate.__exit__ = _restore
    validation.validate.per_thread = True


_validation_per_thread()


def rendered(make, *args, **kwargs):
    """(document, figure): the element `make(*args, **kwargs)` rendered by
    HoloViews' Bokeh renderer into a new Document (the figure its only
    root), built and rendered holding the lock: building an element sets
    HoloViews' shared options too, and reads the shipped data's lazily
    opened netCDF files, which two threads must not open at once (that
    crashed the process)."""
    with _LOCK, validation.validate(True):    # HoloViews relies on validation's conversions
        return _render(make(*args, **kwargs))


def unvalidated():
    """A context in which this thread sets Bokeh properties without
    validating them (explorer.create_app builds its pages so: a tenth of
    a page's cost).  Only for code whose values are known to be valid as given:
    validation also converts (a str given for a figure's title becomes a
    Title), and without it they stay as given.  Renders here switch it
    back on."""
    return validation.validate(False)


def exclusively(work, *args, **kwargs):
    """work(*args, **kwargs) holding the same lock: a figure exported to a
    file (HoloViews' matplotlib plots share that class-level state too)."""
    with _LOCK:
        return work(*args, **kwargs)


def _render(element):
    renderer = hv.renderer("bokeh").instance(mode="server")   # mode server: takes `doc`
    # (the renderer sets its theme on the scratch document; the figure goes
    # to a plain one, as hv.render's did: the page's theme applies)
    plot = renderer.get_plot(element, doc=Document())
    doc = Document()
    doc.add_root(plot.state)
    return doc, plot.state
