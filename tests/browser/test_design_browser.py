"""The Design tab in a real browser (Debian's chromium, Playwright) at
1280 x 800: opened, the paper preset's chart drawn and shown with its
chart-wide notes and downloads, a click on it moving the device, a custom
substrate's field shown.  Screenshots go to test-artifacts/."""

from pathlib import Path

import pytest
from browserpages import new_page, open_explorer, read_back, small_chart_offer
from budget import budget_ms
from playwright.sync_api import expect

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
WIDTH, HEIGHT = 1280, 800

# the titles of the page's Bokeh models (the chart's figure has one)
_TITLES_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.title != null && m.title.text !== undefined) out.push(m.title.text);
  return out;
}"""


def _shot(page, name):
    ARTIFACTS.mkdir(exist_ok=True)
    size = page.viewport_size
    page.screenshot(path=str(ARTIFACTS / f"design-{name}-{size['width']}.png"))


def _device(page):
    """The device's Markdown's paragraphs, cells and items (its text is in
    the pane's shadow root)."""
    return page.locator(".vt-design-device p, .vt-design-device td, .vt-design-device li")


def _device_text(page):
    return " ".join(_device(page).all_inner_texts())


def _open_design(page, url):
    """The explorer at `url`, its Design tab open: the Draw chart button."""
    open_explorer(page, url)
    page.get_by_text("Design", exact=True).first.click()
    draw = page.get_by_role("button", name="Draw chart").first
    draw.wait_for(timeout=budget_ms(30))
    return draw


@pytest.mark.parametrize("width, height", [(WIDTH, HEIGHT), (1920, 1080)], ids=["1280x800", "1920x1080"])
def test_the_design_tab_draws_the_paper_chart(browser, served_explorer, width, height):
    page, errors = new_page(browser, width, height)
    try:
        draw = _open_design(page, served_explorer.url)
        assert page.locator(".vt-design-preset select").first.input_value() == "paper"
        draw.click()
        page.get_by_text("Click the chart to move the device").first.wait_for(timeout=budget_ms(60))
        chart = page.locator(".vt-design-chart canvas").first
        chart.wait_for(timeout=budget_ms(30))
        chart.scroll_into_view_if_needed()
        box = chart.bounding_box()
        assert box["width"] > 300 and box["height"] > 300, box
        titles = page.evaluate(_TITLES_JS)
        assert any("steel on glass" in t for t in titles), titles
        before = _device_text(page)
        assert "drift velocity" in before and "synchronous hopping" in before
        # the chart-wide notes between the status and the chart; the downloads below it
        notes = page.locator(".vt-design-chart-notes").first
        notes.get_by_text("Over the chart").first.wait_for(timeout=budget_ms(30))
        png = page.locator(".vt-design-download-png button").first
        assert png.is_enabled()
        n, d = notes.bounding_box(), page.locator(".vt-design-downloads").first.bounding_box()
        assert n["y"] + n["height"] <= box["y"] + 1 and d["y"] >= box["y"] + box["height"] - 1
        _shot(page, "paper")
        page.locator(".vt-design-status").first.scroll_into_view_if_needed()
        _shot(page, "notes")
        page.locator(".vt-design-downloads").first.scroll_into_view_if_needed()
        _shot(page, "downloads")
        with page.expect_download(timeout=budget_ms(60)) as got:  # the figure, as a browser gets it
            png.click()
        assert Path(got.value.path()).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert got.value.suggested_filename == "vibtrans-design.png"
        chart.scroll_into_view_if_needed()
        box = chart.bounding_box()
        # a click inside the plot moves the device
        shown = _device(page).all_inner_texts()
        page.mouse.click(box["x"] + box["width"] * 0.4, box["y"] + box["height"] * 0.35)
        expect(_device(page)).not_to_have_text(shown, use_inner_text=True, timeout=budget_ms(20))
        assert _device_text(page) != before
        _shot(page, "clicked")
        # a custom substrate: its text field appears beside the materials
        page.locator(".vt-design-preset select").first.scroll_into_view_if_needed()
        page.get_by_label("substrate", exact=True).first.select_option("custom (E, nu, rho)")
        field = page.locator(".vt-design-fields .vt-substrate-custom input").first
        field.wait_for(timeout=budget_ms(30))
        assert field.input_value() == "E=70e9,nu=0.3,rho=2500"
        assert page.locator(".vt-design-preset select").first.input_value() == "custom"
        _shot(page, "custom")
    except Exception:
        _shot(page, "failed")
        print("page errors:", errors)
        raise
    finally:
        page.close()
    assert not errors, errors


def test_a_chart_no_shipped_map_serves_is_computed_and_its_device_runs(browser, served_explorer):
    """At 1024 x 768: mu 0.5 has no shipped map; the map the chart needs
    is offered with its cost, computed on a click, the chart drawn on it;
    a click on the chart runs the device's scene, given in SI units."""
    page, errors = new_page(browser, 1024, 768)
    try:
        draw = _open_design(page, served_explorer.url)
        offer = small_chart_offer(page, draw, mu="0.5")
        offer.get_by_text("No shipped map serves this chart").first.wait_for(timeout=budget_ms(60))
        offer.get_by_text("integration steps").first.wait_for(timeout=budget_ms(60))
        offer.scroll_into_view_if_needed()
        _shot(page, "offer")
        page.get_by_role("button", name="Compute this map").first.click()
        page.locator(".vt-design-progress").first.get_by_text("The chart's map is finished").first.wait_for(
            timeout=budget_ms(180)
        )
        chart = page.locator(".vt-design-chart canvas").first
        chart.wait_for(timeout=budget_ms(30))
        chart.scroll_into_view_if_needed()
        titles = page.evaluate(_TITLES_JS)
        assert any("steel on glass" in t for t in titles), titles
        assert "computed on this server" in " ".join(page.locator(".vt-design-status p").all_inner_texts())
        _shot(page, "computed")
        box = chart.bounding_box()
        page.mouse.click(box["x"] + box["width"] * 0.5, box["y"] + box["height"] * 0.5)
        page.get_by_text("(the device of the Units and Design tabs)").first.wait_for(timeout=budget_ms(120))
        _shot(page, "device-run")
    except Exception:
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "design-computed-failed.png"))
        print("page errors:", errors)
        print("server log:", served_explorer.text()[-3000:])
        raise
    finally:
        page.close()
    assert not errors, errors


@pytest.mark.parametrize("width, height", [(1024, 768), (1920, 1080)], ids=["1024x768", "1920x1080"])
def test_a_cone_tip_chart_is_offered_its_own_map_and_drawn(browser, served_explorer, width, height):
    """The particle's tip chosen on the Design tab (a 60-degree
    cone): only its half-angle field shown; no shipped map serves it (the
    sphere's), the reason said; the cone's map computed (the second size
    reads it from the server's cache) and the chart drawn; the device's
    table names the tip, its normalized profile and the cone's warnings."""
    page, errors = new_page(browser, width, height)
    try:
        draw = _open_design(page, served_explorer.url)
        page.get_by_label("particle tip", exact=True).first.select_option("cone")
        angle = page.locator(".vt-design-tip-half-angle input").first
        angle.wait_for(timeout=budget_ms(30))
        assert angle.input_value() == "60"
        assert not page.locator(".vt-design-tip-exponent input").first.is_visible()
        # a half-angle out of range: the library's message under the field
        angle.fill("95")
        angle.press("Enter")
        page.locator(".vt-error-tip_half_angle").get_by_text(
            "half_angle must be a real number in (0, 90) degrees"
        ).first.wait_for(timeout=budget_ms(30))
        angle.fill("60")
        angle.press("Enter")
        read_back(page, "vt-field-tip_half_angle")
        offer = small_chart_offer(page, draw)
        offer.get_by_text("the shipped maps are the sphere's").first.wait_for(timeout=budget_ms(60))
        offer.get_by_text("integration steps").first.wait_for(timeout=budget_ms(60))
        offer.get_by_text("cone (half-angle 60 deg), runs the normalized profile").first.wait_for(
            timeout=budget_ms(30)
        )
        page.get_by_role("button", name="Compute this map").first.click()
        page.locator(".vt-design-progress").first.get_by_text("The chart's map").first.wait_for(
            timeout=budget_ms(240)
        )
        chart = page.locator(".vt-design-chart canvas").first
        chart.wait_for(timeout=budget_ms(30))
        text = _device_text(page)
        assert "cone (half-angle 60 deg)" in text and "a cone's contact pressure" in text
        titles = page.evaluate(_TITLES_JS)
        assert any("the particle's tip: cone (half-angle 60 deg)" in t for t in titles), titles
        page.locator(".vt-design-fields").first.scroll_into_view_if_needed()
        _shot(page, "cone-form")
        chart.scroll_into_view_if_needed()
        _shot(page, "cone")
    except Exception:
        _shot(page, "cone-failed")
        print("page errors:", errors)
        print("server log:", served_explorer.text()[-3000:])
        raise
    finally:
        page.close()
    assert not errors, errors
