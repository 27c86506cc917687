"""A map on demand in a real browser (Debian's chromium, Playwright): a tiny
map requested in its tab (its estimate shown first), drawn level by level
in the map tab, clicked to run its scene, its link reopening it from the
server's cache.  Screenshots at 1280 x 800 go to test-artifacts/."""

from pathlib import Path

import pytest
from browserpages import new_page, open_explorer, steady
from budget import budget_ms

from vibtrans_explorer.session import maprequest

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
WIDTH, HEIGHT = 1280, 800
# 9 x 9 points (2 coarse cells, K = 2), 100 periods at preview
FIELDS = {
    "tau": "20",
    "periods": "100",
    "la_from": "-0.5",
    "la_to": "0.5",
    "lm_from": "0",
    "lm_to": "1",
    "cells": "2",
    "levels": "2",
}

# every text the page's models were given, recorded as the browser applies
# the server's changes (the levels of a tiny map pass quickly)
_RECORD_JS = """() => {
  window.__mapTexts = [];
  for (const doc of window.Bokeh.documents)
    doc.on_change((e) => {
      if (e.kind === "ModelChanged" && e.attr === "text" && typeof e.value === "string")
        window.__mapTexts.push(e.value);
    });
}"""


def _field(page, name, text):
    box = page.locator(f".vt-field-{name} input").first
    box.fill(text)
    box.press("Enter")


def _shot(page, name):
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"map-request-{name}.png"))


def test_a_map_on_demand_is_drawn_by_levels_clicked_and_linked(browser, served_explorer):
    page, errors = new_page(browser, WIDTH, HEIGHT)
    try:
        open_explorer(page, served_explorer.url)
        page.get_by_text("Map on demand", exact=True).first.click()
        page.locator(".vt-field-periods input").first.wait_for(timeout=budget_ms(30))
        page.locator(".vt-map-fidelity select").first.select_option("preview")
        for name, text in FIELDS.items():
            _field(page, name, text)
        # the cost before anything runs: the finest grid's points, steps, seconds
        page.get_by_text("At most 81 points (9 per axis)").first.wait_for(timeout=budget_ms(60))
        page.get_by_text("on this server (").first.wait_for(timeout=budget_ms(60))
        _shot(page, "request")
        page.evaluate(_RECORD_JS)
        page.get_by_role("button", name="Compute map").first.click()
        page.get_by_text("Map finished:").first.wait_for(timeout=budget_ms(120))
        steady(page)  # the finished map drawn and laid out
        _shot(page, "finished")
        texts = page.evaluate("() => window.__mapTexts")
        # the coarse grid's 3 x 3 points drawn first, then each level's
        said = [t for t in texts if "Level " in t or "Map finished" in t]
        assert any("Level 0 of 2 drawn: 9 of 81 points" in t for t in said), said
        assert any("Level 1 of 2 drawn" in t for t in said), said
        finished = next(t for t in said if "Map finished" in t)
        computed = int(finished.split("Map finished:")[1].split(" of ")[0].strip().replace(",", ""))
        assert 9 < computed <= 81
        # the link carries the request
        url = page.evaluate("() => window.location.href")
        request, problems = maprequest.decode(_query(url)["map"])
        assert problems == [] and request.points_per_axis() == 9
        assert (request.fidelity, request.periods, request.tau) == ("preview", 100.0, 20.0)
        assert (request.la_from, request.la_to, request.lm_from, request.lm_to) == (-0.5, 0.5, 0.0, 1.0)
        # a click on the map runs its scene, with the map's values
        canvas = page.locator("canvas").first
        box = canvas.bounding_box()
        canvas.scroll_into_view_if_needed()
        page.mouse.click(box["x"] + box["width"] * 0.45, box["y"] + box["height"] * 0.5)
        page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(120))
        page.wait_for_function("() => window.location.href.includes('la=')", timeout=budget_ms(30))
        query = _query(page.evaluate("() => window.location.href"))
        assert query["fidelity"] == "preview" and float(query["periods"]) == 100.0
        assert float(query["tau"]) == 20.0 and -0.5 <= float(query["la"]) <= 0.5
        assert 0.0 <= float(query["lm"]) <= 1.0 and "map" in query
        steady(page)
        _shot(page, "clicked")
        link = page.evaluate("() => window.location.href")
    except Exception:
        _shot(page, "failed")
        print("page errors:", errors)
        raise
    finally:
        page.close()
    assert not errors, errors
    # the link reopens the map: from the server's cache, nothing computed again
    again = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
    try:
        again.goto(link)
        again.get_by_text("Map from this server's cache").first.wait_for(timeout=budget_ms(120))
        titles = again.evaluate("""() => {
          const out = [];
          for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
            if (m.title != null && m.title.text !== undefined) out.push(m.title.text);
          return out;
        }""")
        assert any("map on demand: deformable, mu = 0.3" in t for t in titles), titles
        steady(again)
        _shot(again, "reopened")
        # the Difference tab compares the map on demand (on its grid) with the
        # shipped map of its model and mu
        again.get_by_text("Difference", exact=True).first.click()
        first = again.locator(".vt-diff-first select").first
        first.wait_for(timeout=budget_ms(30))
        assert first.input_value().startswith("map on demand:")
        assert again.locator(".vt-diff-second select").first.input_value() == "deformable, mu = 0.3 (shipped)"
        again.get_by_role("button", name="Show the difference").first.click()
        again.get_by_text("points compared").first.wait_for(timeout=budget_ms(60))
        summary = again.get_by_text("points compared").first.inner_text()
        assert "deformable mu 0.3 tau 20 preview 100 periods" in summary, summary
        steady(again)
        _shot(again, "difference")
        again.get_by_text("Map", exact=True).first.click()
        # back to the shipped map: the request leaves the link
        again.get_by_role("button", name="Back to the shipped map").first.click()
        again.wait_for_function("() => !window.location.href.includes('map=')", timeout=budget_ms(30))
    finally:
        again.close()


def _query(url):
    from urllib.parse import parse_qs, urlsplit

    return {k: v[0] for k, v in parse_qs(urlsplit(url).query).items()}


@pytest.mark.parametrize("width, height", [(1024, 768), (1920, 1080)])
def test_the_difference_tab_compares_the_two_models(browser, served_explorer, width, height):
    """The Difference tab's default pair (the deformable particle against the
    material point at mu 0.3) drawn with its summary and colour bar."""
    page = browser.new_page(viewport={"width": width, "height": height})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(served_explorer.url)
        page.wait_for_selector("canvas", timeout=budget_ms(60))
        page.get_by_text("Difference", exact=True).first.click()
        page.get_by_role("button", name="Show the difference").first.click()
        page.get_by_text("points compared").first.wait_for(timeout=budget_ms(60))
        summary = page.get_by_text("points compared").first.inner_text()
        assert "point-mass mu 0.3" in summary and "deformable mu 0.3" in summary, summary
        assert "drift class agrees at" in summary, summary
        steady(page)
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / f"difference-{width}x{height}.png"), full_page=True)
    finally:
        page.close()
    assert not errors, errors
