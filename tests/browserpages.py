"""What the browser tests share: a page of a screen's size whose JavaScript
errors are collected, and the explorer opened in it.  Waits are on page events
(a selector, a text); their time limits are budgets scaled to the machine
(tests/budget.py), so a busy machine gets longer before a hang fails."""

from budget import budget_ms


def new_page(browser, width, height):
    """(page of width x height, the list its page errors are appended to)."""
    page = browser.new_page(viewport={"width": width, "height": height})
    page.set_default_timeout(budget_ms(30))   # Playwright's own default, scaled
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    return page, errors


# every Bokeh document of the page has rendered its roots (BokehJS's
# Document.is_idle: true once each root's views are first drawn)
_IDLE_JS = ("() => window.Bokeh !== undefined && window.Bokeh.documents.length > 0 "
            "&& window.Bokeh.documents.every((d) => d.is_idle)")
# two animation frames: the browser has laid out and painted what was drawn
_FRAMES_JS = "() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))"


def settle(page, timeout_s=60):
    """Wait until the page's Bokeh documents have rendered (is_idle), then
    for two animation frames (layout and paint, e.g. after a resize)."""
    page.wait_for_function(_IDLE_JS, timeout=budget_ms(timeout_s))
    page.evaluate(_FRAMES_JS)


def open_explorer(page, url):
    """Load the explorer at `url` and wait for its map and its controls."""
    page.goto(url)
    page.wait_for_selector("canvas", timeout=budget_ms(60))
    page.get_by_text("Paper points").first.wait_for(timeout=budget_ms(60))
