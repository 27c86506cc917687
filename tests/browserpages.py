"""What the browser tests share: a page of a screen's size whose JavaScript
errors are collected, and the explorer opened in it."""


def new_page(browser, width, height):
    """(page of width x height, the list its page errors are appended to)."""
    page = browser.new_page(viewport={"width": width, "height": height})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    return page, errors


def open_explorer(page, url):
    """Load the explorer at `url` and wait for its map and its controls."""
    page.goto(url)
    page.wait_for_selector("canvas", timeout=60000)
    page.get_by_text("Paper points").first.wait_for(timeout=60000)
