"""Screenshots of the explorer as a newcomer sees it, from a server of its own
at 1024 x 768, 1280 x 800 and 1920 x 1080: main, orbits (period-1 curves),
lyapunov, both (models), run-<tab> (each run tab, its header at the top and
a screen on), presentation, no-sidebar.  Prints the map's frame per state,
so a frame that shrinks when the key grows shows in numbers.

    python -m devtools.explorershots [--out DIR] [--sizes 1024x768 ...]
"""

import argparse
import json
from pathlib import Path

from devtools.server import explorer

ROOT = Path(__file__).resolve().parent.parent
SIZES = ["1024x768", "1280x800", "1920x1080"]
RUN_TABS = ["Trajectory", "Animation", "Memory diagram", "Downloads", "Dynamics"]

# The shown map's frame (data area), left edge and colour bar's fonts, CSS px
MAP_JS = """() => {
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.x_range === undefined || m.renderers === undefined) continue;
    const t = m.title && String(m.title.text);
    if (!(m.name === "map" || (t && (t.startsWith("<v*> over") || t.startsWith("Lyapunov")))))
      continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v || v.el.getClientRects().length === 0) continue;
    const bars = [...m.right, ...m.left, ...m.below, ...m.above, ...m.center]
      .filter((a) => a.type === "ColorBar");
    return {frame_width: v.frame.bbox.width, frame_height: v.frame.bbox.height,
            left: v.el.getBoundingClientRect().left,
            bar_ticks: bars.length ? bars[0].major_label_text_font_size : null,
            bar_title: bars.length ? bars[0].title_text_font_size : null};
  }
  return null;
}"""


IDLE_JS = "() => window.Bokeh.documents.every((d) => d.is_idle)"


def _settle(page, ms=1500):
    page.wait_for_function(IDLE_JS, timeout=120000)
    page.wait_for_timeout(ms)


def _button(page, name):
    page.get_by_role("button", name=name, exact=True).first.click()
    _settle(page)


def shots(browser, url, size, out, log=print):
    width, height = (int(v) for v in size.split("x"))
    page = browser.new_page(viewport={"width": width, "height": height})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_selector("canvas", timeout=120000)
    page.get_by_text("Paper points").first.wait_for(timeout=120000)
    _settle(page)
    frames = {}

    def shot(name, frame=True):
        page.screenshot(path=str(out / f"{name}-{size}.png"), full_page=True)
        log(f"  {name}-{size}.png")
        if frame:
            frames[name] = page.evaluate(MAP_JS)

    # each state's buttons from the last one's
    for name, buttons in [
        ("main", []),
        ("orbits", ["period-1 orbit curves"]),
        ("lyapunov", ["no orbit curves", "Lyapunov exponent"]),
        ("both", ["drift velocity", "both models"]),
    ]:
        for b in buttons:
            _button(page, b)
        shot(name)
    _button(page, "selected model")
    page.get_by_role("button", name="Run selected scene").first.click()
    page.locator("strong:visible", has_text="mu = ").first.wait_for(timeout=120000)
    _settle(page)
    for tab in RUN_TABS:
        header = page.get_by_text(tab, exact=True).first
        header.click()
        _settle(page, 3000)
        # the main area scrolls by itself: the tab's header at the top, then a screen on
        header.evaluate("(e) => e.scrollIntoView({block: 'start'})")
        page.wait_for_timeout(300)
        name = "run-" + tab.lower().replace(" ", "-")
        shot(name, frame=False)
        page.mouse.move(width * 0.7, height * 0.6)
        page.mouse.wheel(0, height * 0.8)
        page.wait_for_timeout(500)
        shot(name + "-2", frame=False)
    page.get_by_text("Trajectory", exact=True).first.click()
    toggle = page.locator(".vt-presentation").first
    label = page.get_by_text("Paper points").first
    small = float(label.evaluate("(e) => getComputedStyle(e).fontSize").rstrip("px"))
    toggle.locator("button").first.click()
    # the server's styles follow the browser's change: until the labels grew
    page.wait_for_function(
        "([e, px]) => parseFloat(getComputedStyle(e).fontSize) > px",
        arg=[label.element_handle(), small],
        timeout=60000,
    )
    _settle(page)
    page.evaluate("() => window.scrollTo(0, 0)")
    shot("presentation")
    hide = page.locator("#sidebar-toggle")
    if hide.count():
        hide.first.click()
        _settle(page)
        shot("no-sidebar")
    page.close()
    return {"size": size, "frames": frames, "errors": errors}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(ROOT / "test-artifacts" / "explorer"))
    parser.add_argument("--sizes", nargs="+", default=SIZES)
    parser.add_argument("--url", help="a running explorer instead of a server of its own")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with explorer(args.url) as (browser, url, _):
        for size in args.sizes:
            print(size)
            print(json.dumps(shots(browser, url, size, out)))


if __name__ == "__main__":
    main()
