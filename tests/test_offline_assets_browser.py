"""Every asset the explorer's page loads comes from our own server (issue
32): a classroom or lab network without internet must get the page whole.
The Downloads and map-on-demand views fetched Panel's widget CSS from a CDN
(12 ERR_NAME_NOT_RESOLVED offline).  The test records every request the
page makes while every tab is opened and fails on any to another host."""
from urllib.parse import urlsplit

import pytest

from browserpages import new_page, open_explorer
from budget import budget_ms
from devtools.chromium import launched

pytestmark = pytest.mark.browser

MAP_TABS = ("Vertical", "Units", "Map on demand", "Difference", "Design", "Map")
RUN_TABS = ("Animation", "Memory diagram", "Downloads", "Dynamics", "Trajectory")


def test_every_request_goes_to_the_server(served_explorer):
    own = urlsplit(served_explorer.url).netloc
    with launched() as browser:
        page, errors = new_page(browser, 1280, 800)
        elsewhere = []

        def seen(request):
            parts = urlsplit(request.url)
            if parts.scheme in ("http", "https", "ws", "wss") and parts.netloc != own:
                elsewhere.append(request.url)
        page.on("request", seen)
        try:
            open_explorer(page, served_explorer.url)
            for name in MAP_TABS + RUN_TABS:
                page.get_by_text(name, exact=True).first.click()
                page.wait_for_load_state("networkidle", timeout=budget_ms(30))
            # a view's widgets, once shown, are there: the Downloads buttons
            page.get_by_text("Downloads", exact=True).first.click()
            page.locator(".vt-export-map-png").first.wait_for(timeout=budget_ms(30))
            page.wait_for_load_state("networkidle", timeout=budget_ms(30))
        finally:
            page.close()
            # offline, a page whose assets are elsewhere never loads: say why
            assert not elsewhere, (f"requests to hosts other than {own}: "
                                   f"{sorted(set(elsewhere))}")
    assert not elsewhere, f"requests to hosts other than {own}: {sorted(set(elsewhere))}"
    assert not errors, errors
