"""Every asset the explorer's page loads comes from our own server: a
classroom or lab network without internet must get the page whole.
The test records every request the page makes while every tab is opened
and every button that builds something is pressed (a map on demand, the
design charts and their map, each download, presentation mode), and
fails on any to another host."""

import re
from urllib.parse import urlsplit

import pytest
from browserpages import new_page, open_explorer, small_chart_offer
from budget import budget_ms
from playwright.sync_api import TimeoutError as PlaywrightTimeout

from devtools.chromium import launched

pytestmark = pytest.mark.browser

MAP_TABS = ("Vertical", "Units", "Map on demand", "Difference", "Design", "Map")
RUN_TABS = ("Animation", "Memory diagram", "Downloads", "Dynamics", "Trajectory")


# a tiny map on demand (tests/browser/test_map_request_browser.py's)
MAP_FIELDS = {
    "tau": "20",
    "periods": "100",
    "la_from": "-0.5",
    "la_to": "0.5",
    "lm_from": "0",
    "lm_to": "1",
    "cells": "2",
    "levels": "2",
}


def _tab(page, name):
    """Open the tab `name` (of the map's or the run's tabs) and wait until it
    is the active one and the page has fetched what it shows."""
    exact = re.compile(f"^{re.escape(name)}$")
    active = page.locator(".bk-tab.bk-active", has_text=exact).first
    # a click that lands while the page lays out a large change can be lost:
    # clicked again until the tab is the active one (an event, not a delay)
    for _ in range(3):
        page.locator(".bk-tab", has_text=exact).first.click()
        try:
            active.wait_for(timeout=budget_ms(10))
            break
        except PlaywrightTimeout:
            continue
    active.wait_for(timeout=budget_ms(30))
    page.wait_for_load_state("networkidle", timeout=budget_ms(30))


def _type(page, selector, text):
    box = page.locator(selector).first
    box.fill(text)
    box.press("Enter")


def _every_action(page, url):
    """Every tab opened, and every button that builds something pressed:
    Draw chart, Compute this map, Compute map, each download, Play, Show the difference,
    presentation mode, with tab changes between them (a pane changed while its tab is
    hidden is shown again)."""
    open_explorer(page, url)
    for name in MAP_TABS + RUN_TABS:
        _tab(page, name)
    # the paper's device chart, its tab hidden and shown again
    _tab(page, "Design")
    draw = page.get_by_role("button", name="Draw chart").first
    draw.click()
    page.get_by_text("Click the chart to move the device").first.wait_for(timeout=budget_ms(60))
    # a chart no shipped map serves (another mu): its map computed while
    # the tab is hidden, then shown
    offer = small_chart_offer(page, draw, mu="0.45")
    offer.get_by_text("integration steps").first.wait_for(timeout=budget_ms(60))
    page.get_by_role("button", name="Compute this map").first.click()
    page.locator(".vt-design-progress").get_by_text(re.compile(".")).first.wait_for(timeout=budget_ms(60))
    _tab(page, "Map")
    _tab(page, "Design")
    page.locator(".vt-design-progress").first.get_by_text("The chart's map is finished").first.wait_for(
        timeout=budget_ms(240)
    )
    # a map on demand, computed while the Map tab is hidden, then shown
    _tab(page, "Map on demand")
    page.locator(".vt-field-periods input").first.wait_for(timeout=budget_ms(30))
    page.locator(".vt-map-fidelity select").first.select_option("preview")
    for name, text in MAP_FIELDS.items():
        _type(page, f".vt-field-{name} input", text)
    # the estimate of the typed request shown: the form has settled
    page.get_by_text("At most 81 points (9 per axis)").first.wait_for(timeout=budget_ms(60))
    page.get_by_role("button", name="Compute map").first.click()
    page.locator(".vt-map-banner").get_by_text(
        re.compile("Map finished|from this server's cache")
    ).first.wait_for(timeout=budget_ms(240))
    _tab(page, "Map")
    _tab(page, "Map on demand")
    # a run, then each of its downloads and the map's
    _tab(page, "Map")
    page.get_by_role("button", name="Run selected scene").first.click()
    page.locator("strong", has_text="mu = ").first.wait_for(timeout=budget_ms(120))
    _tab(page, "Downloads")
    buttons = page.locator("[class*='vt-export-'] button, [class*='vt-data-'] button")
    buttons.first.wait_for(timeout=budget_ms(30))
    for i in range(buttons.count()):
        with page.expect_download(timeout=budget_ms(120)):
            buttons.nth(i).click()
    # the run's other buttons that build something: the animation played,
    # the difference of the two shipped maps shown
    _tab(page, "Animation")
    page.get_by_role("button", name="Play").first.click()
    page.get_by_role("button", name="Pause").first.click()
    _tab(page, "Difference")
    page.get_by_role("button", name="Show the difference").first.click()
    page.locator(".vt-diff-summary").get_by_text(re.compile(".")).first.wait_for(timeout=budget_ms(120))
    # presentation mode, and every tab again in it
    toggle = page.locator(".vt-presentation")
    inner = toggle.first.locator("button, input, [role=switch]")
    (inner.first if inner.count() else toggle.first).click()
    for name in MAP_TABS + RUN_TABS:
        _tab(page, name)


@pytest.mark.slow
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
            try:
                _every_action(page, served_explorer.url)
            except Exception:
                page.screenshot(path="test-artifacts/offline-fail.png", full_page=True)
                raise
            page.wait_for_load_state("networkidle", timeout=budget_ms(30))
        finally:
            page.close()
            # offline, a page whose assets are elsewhere never loads: say why
            assert not elsewhere, f"requests to hosts other than {own}: {sorted(set(elsewhere))}"
    assert not elsewhere, f"requests to hosts other than {own}: {sorted(set(elsewhere))}"
    assert not errors, errors
