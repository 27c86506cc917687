"""The Design tab in a real browser (Debian's chromium, Playwright) at
1280 x 800: opened, the paper preset's chart drawn and shown, a click on
it moving the device.  Screenshots go to test-artifacts/."""
from pathlib import Path

import pytest

from devtools.chromium import launched

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parent.parent
ARTIFACTS = ROOT / "test-artifacts"
WIDTH, HEIGHT = 1280, 800

# the titles of the page's Bokeh models (the chart's figure has one)
_TITLES_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.title != null && m.title.text !== undefined) out.push(m.title.text);
  return out;
}"""


@pytest.fixture(scope="module")
def browser():
    with launched() as b:
        yield b


def _shot(page, name):
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"design-{name}.png"))


def _device_text(page):
    """The device's Markdown (its text is in the pane's shadow root)."""
    return " ".join(page.locator(".vt-design-device p, .vt-design-device td, "
                                 ".vt-design-device li").all_inner_texts())


def test_the_design_tab_draws_the_paper_chart(browser, served_explorer):
    page = browser.new_page(viewport={"width": WIDTH, "height": HEIGHT})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(served_explorer.url)
        page.wait_for_selector("canvas", timeout=60000)
        page.get_by_text("Paper points").first.wait_for(timeout=60000)
        page.get_by_text("Design", exact=True).first.click()
        draw = page.get_by_role("button", name="Draw chart").first
        draw.wait_for(timeout=30000)
        assert page.locator(".vt-design-preset select").first.input_value() == "paper"
        draw.click()
        page.get_by_text("Click the chart to move the device").first.wait_for(timeout=60000)
        chart = page.locator(".vt-design-chart canvas").first
        chart.wait_for(timeout=30000)
        chart.scroll_into_view_if_needed()
        box = chart.bounding_box()
        assert box["width"] > 300 and box["height"] > 300, box
        titles = page.evaluate(_TITLES_JS)
        assert any("steel on glass" in t for t in titles), titles
        before = _device_text(page)
        assert "drift velocity" in before and "synchronous hopping" in before
        _shot(page, "paper")
        # a click inside the plot moves the device
        page.mouse.click(box["x"] + box["width"] * 0.4, box["y"] + box["height"] * 0.35)
        for _ in range(100):
            if _device_text(page) != before:
                break
            page.wait_for_timeout(200)
        assert _device_text(page) != before
        _shot(page, "clicked")
    except Exception:
        _shot(page, "failed")
        print("page errors:", errors)
        raise
    finally:
        page.close()
    assert not errors, errors
