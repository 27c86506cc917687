"""Bokeh's property validation is switched per thread in the explorer
(app/views/render.py): HoloViews turns it off around updates of a render's
sources, in the worker threads that render maps on demand, while the event
loop builds other figures whose values only validation converts (a title
given as a string becomes a Title).  With Bokeh's one flag for the whole
process, a five-map load test lost 46 drawings to that."""
import threading

from bokeh.core.property.validation import validate
from bokeh.models import Title
from bokeh.plotting import figure

from vibtrans_explorer.views import render  # noqa: F401  (switches validation per thread)


def test_validation_off_in_another_thread_leaves_this_one_validating():
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
    assert isinstance(fig.title, Title) and fig.title.text == "built meanwhile"


def test_validation_off_still_applies_to_its_own_thread_and_is_restored():
    with validate(False):
        with validate(False):
            pass
        unchecked = figure(title="unconverted")
    assert unchecked.title == "unconverted"          # not validated, not converted
    assert isinstance(figure(title="after").title, Title)
