"""Bokeh's property validation switched per thread where the installed
Bokeh keeps it in one flag for the whole process (app/server/compat.py, as the
server applies it): HoloViews turns it off around updates of a render's
sources, in the worker threads that render maps on demand, while the event
loop builds other figures whose values only validation converts (a title
given as a string becomes a Title).  With Bokeh's one flag, a five-map load
test lost 46 drawings to that."""

import threading

import pytest
from bokeh.core.property.validation import validate
from bokeh.models import Title
from bokeh.plotting import figure

from vibtrans_explorer.server import compat


@pytest.fixture
def as_served():
    """compat applied as app/server/serve.py applies it, undone after."""
    was = compat.applied()
    compat.apply()
    yield
    if not was:
        compat.undo()


def test_validation_off_in_another_thread_leaves_this_one_validating(as_served):
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


def test_validation_off_still_applies_to_its_own_thread_and_is_restored(as_served):
    with validate(False):
        with validate(False):
            pass
        unchecked = figure(title="unconverted")
    assert unchecked.title == "unconverted"  # not validated, not converted
    assert isinstance(figure(title="after").title, Title)
