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

HoloViews turns Bokeh's property validation off around some updates of a
render's sources (`with validate(False)`), and Bokeh keeps that switch in
one flag for the whole process (docs/how-to/deployment.md 1.1): the lock
keeps two renders from switching it at once (one could leave it off), and
what is built outside a render, on the event loop while a worker renders,
gives Bokeh only values of its properties' types (a figure's title a
`Title`, not a string that only validation converts), so that it needs no
validation (tests/app/test_render_threads.py)."""

import threading

import holoviews as hv
from bokeh.document import Document

_LOCK = threading.Lock()


def rendered(make, *args, **kwargs):
    """(document, figure): the element `make(*args, **kwargs)` rendered by
    HoloViews' Bokeh renderer into a new Document (the figure its only
    root), built and rendered holding the lock: building an element sets
    HoloViews' shared options too, and reads the shipped data's lazily
    opened netCDF files, which two threads must not open at once (that
    crashed the process)."""
    with _LOCK:
        return _render(make(*args, **kwargs))


def exclusively(work, *args, **kwargs):
    """work(*args, **kwargs) holding the same lock: a figure exported to a
    file (HoloViews' matplotlib plots share that class-level state too)."""
    with _LOCK:
        return work(*args, **kwargs)


def _render(element):
    renderer = hv.renderer("bokeh").instance(mode="server")  # mode server: takes `doc`
    # (the renderer sets its theme on the scratch document; the figure goes
    # to a plain one, as hv.render's did: the page's theme applies)
    plot = renderer.get_plot(element, doc=Document())
    doc = Document()
    doc.add_root(plot.state)
    return doc, plot.state
