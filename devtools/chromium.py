"""Debian's chromium as the tests and the benches drive it (Playwright's own
browser download does not work on these machines): where it is, and the
flags that keep a headless page from being throttled or talking to the
network."""
import shutil
from contextlib import contextmanager
from pathlib import Path

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run",
        "--disable-renderer-backgrounding", "--disable-background-timer-throttling",
        "--disable-backgrounding-occluded-windows", "--disable-dev-shm-usage"]


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
