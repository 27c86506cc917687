"""Whatever fails while the server answers a page, the page says so in its
own words: never Panel's traceback, never a server path.  The failure is
logged with its traceback under a reference the page gives."""

import logging

from bokeh.document import Document
from panel.io.state import set_curdoc

from vibtrans_explorer import explorer
from vibtrans_explorer.server import serve as server


class _Page:
    """Stands in for a served page's explorer: what it was told to say."""

    said = None

    def _error(self, text):
        self.said = text


def _served_page():
    """(document, its page) as the server registers them."""
    doc, page = Document(), _Page()
    explorer._PAGES[doc] = page
    return doc, page


def _raises():
    raise OverflowError("math range error in /srv/vibtrans/somewhere.py")


def test_a_page_whose_build_fails_is_the_explorers_message(caplog):
    doc = Document()
    started = []
    page = server._first_page(_raises, lambda: started.append(True))
    with set_curdoc(doc), caplog.at_level(logging.ERROR, logger="vibtrans.explorer"):
        shown = page()
    text = shown.objects[0].object
    assert "could not open this page" in text and "./" in text
    assert "Traceback" not in text and "/srv" not in text and "Overflow" not in text
    # the log has the traceback, under the reference the page shows
    record = next(r for r in caplog.records if "building a page failed" in r.getMessage())
    reference = record.args[0]
    assert f"`{reference}`" in text and record.exc_info[0] is OverflowError


def test_a_failed_callback_is_said_in_its_page_and_logged(caplog):
    doc, page = _served_page()
    with set_curdoc(doc), caplog.at_level(logging.ERROR, logger="vibtrans.explorer"):
        explorer.report_failure(OverflowError("in /srv/vibtrans/x.py"))
    record = next(r for r in caplog.records if "callback failed" in r.getMessage())
    assert record.args[0] in page.said and "/srv" not in page.said
    assert "Reload the page" in page.said and record.exc_info[0] is OverflowError
    # outside any page: logged, nothing raised
    caplog.clear()
    with caplog.at_level(logging.ERROR, logger="vibtrans.explorer"):
        explorer.report_failure(ValueError("x"))
    assert [r.exc_info[0] for r in caplog.records] == [ValueError]
