"""Debian's chromium as the tests and benches drive it (Playwright's download
does not work here), with flags against throttling and network chatter."""

import shutil
from contextlib import contextmanager
from pathlib import Path

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-renderer-backgrounding",
    "--disable-background-timer-throttling",
    "--disable-backgrounding-occluded-windows",
    "--disable-dev-shm-usage",
]


@contextmanager
def launched():
    """A headless chromium (Playwright's Browser), closed on exit."""
    from playwright import sync_api as playwright

    assert Path(CHROMIUM).exists(), "Debian's chromium is required (`make browser` installs it)"
    with playwright.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        try:
            yield browser
        finally:
            browser.close()
