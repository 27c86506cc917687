"""The memory view (app/views/memory.py) in a real headless browser: a page
of only the view (pn.serve in a thread), fed a preview run; a slider step
and a typed time change the figures in the browser, and the time from the
key press (or the click) to the new title in the page's Bokeh document is
printed (the goal: click/scrub to drawn <= 0.5 s; tests assert behaviour,
not wall-clock times).  A screenshot goes to test-artifacts/."""

import socket
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import panel as pn
import pytest
from asyncutil import wait_until
from budget import budget, budget_ms
from netutil import free_port

from devtools.chromium import launched
from vibtrans import paper_scene
from vibtrans.core.simulate import memory_snapshot
from vibtrans_explorer.views.memory import MemoryView

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
SCENE = paper_scene(9).replace(model="deformable", fidelity="preview", periods=200.0)

# the memory diagram's title in the page's Bokeh document, and the first
# value of the w(h) line's source
_TITLE_JS = """() => {
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.text !== undefined && typeof m.text === "string"
        && m.text.startsWith("memory diagram w(h)\\nt* =")) return m.text;
  return null;
}"""
_CHANGED_JS = f"(before) => {{ const t = ({_TITLE_JS})(); return t !== null && t !== before; }}"


@pytest.fixture(scope="module")
def served():
    pool = ThreadPoolExecutor(2)
    memory_snapshot(SCENE, 1.0)  # kernels loaded before the page asks

    def app():
        view = MemoryView(pool)
        pn.state.onload(lambda: view.set_run(SCENE, SCENE.periods))
        return view

    port = free_port()
    server = pn.serve(
        {"memory": app},
        port=port,
        address="127.0.0.1",
        show=False,
        threaded=True,
        websocket_origin=[f"127.0.0.1:{port}"],
    )
    # ready once its port accepts a connection (the thread Panel returns
    # has no public "started" signal)
    wait_until(lambda: _accepts(port), budget(30), f"panel serve on port {port}")
    try:
        yield f"http://127.0.0.1:{port}/memory"
    finally:
        server.stop()
        pool.shutdown(cancel_futures=True)


def _accepts(port):
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
        return True
    except OSError:
        return False


def _elapsed_until_changed(page, act):
    before = page.evaluate(_TITLE_JS)
    t0 = time.perf_counter()
    act()
    page.wait_for_function(_CHANGED_JS, arg=before, polling="raf", timeout=budget_ms(30))
    return time.perf_counter() - t0, page.evaluate(_TITLE_JS)


def test_the_slider_and_a_typed_time_update_the_figures(served):
    with launched() as browser:
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(served)
        page.wait_for_function(f"() => ({_TITLE_JS})() !== null", timeout=budget_ms(60))
        assert "t* = 200," in page.evaluate(_TITLE_JS)  # the run's end first
        handle = page.locator(".noUi-handle").first
        handle.focus()
        scrubs = []
        for _ in range(5):
            dt, title = _elapsed_until_changed(page, lambda: page.keyboard.press("ArrowLeft"))
            scrubs.append(dt)
        assert "t* = 199.8" in title  # five steps of 1/47 period back
        field = page.locator("input[type=text]").first
        field.fill("123.45")
        field.press("Enter")
        # no wait: the typed time goes to the server before the click, on the
        # same websocket, and the server handles the two in that order
        dt_click, title = _elapsed_until_changed(
            page, lambda: page.get_by_role("button", name="Show the memory diagram at t*").click()
        )
        assert "t* = 123.45" in title
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "memory_view.png"), full_page=True)
    print(
        f"\nkey press to new title: {', '.join(f'{s * 1e3:.0f}' for s in scrubs)} ms; "
        f"click to new title: {dt_click * 1e3:.0f} ms"
    )
    assert not errors, errors
