"""The explorer on common screens (headless chromium, Playwright): at 1024 x
768, 1280 x 800 and 1920 x 1080 the page must need no horizontal
scrolling and show the map whole; on a projector (1920 x 1080, the
presentation mode: an element of class vt-presentation toggles it), the map
and the first panel of a run's trajectory must fit on one screen.

What "fits" means, measured in the page (CSS px, the viewport's client
coordinates):
  no horizontal scrollbar   document.scrollingElement.scrollWidth <=
                            innerWidth, and no element scrolls sideways
                            (overflow-x auto/scroll with content wider than
                            the element): one inside the page is a
                            scrollbar too
  map not cut off           the map figure's box (BokehJS's view of the plot
                            in the model named "map") within [0, innerWidth]
  colour bar, Run button    their boxes within [0, innerWidth] (the colour
                            bar: its view's box in the map's canvas; the
                            button: "Run selected scene"); vertically they
                            may need scrolling
  one screen                the map's box and the first trajectory panel's
                            (the topmost plot shown in the model named
                            "trajectory") span at most innerHeight, and both
                            lie within [0, innerWidth]

Screenshots (the viewport, what the screen shows) go to
test-artifacts/screens-WxH.png (look at them)."""
from pathlib import Path

import pytest


from budget import budget_ms

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parent.parent
ARTIFACTS = ROOT / "test-artifacts"
SCREENS = [(1024, 768), (1280, 800), (1920, 1080)]
PROJECTOR = (1920, 1080)
SLACK_PX = 1          # sub-pixel layout rounding

# The page's geometry: the viewport, horizontal scrolling, and the boxes of
# the map figure, its colour bar and the first trajectory panel (through
# BokehJS's views; null when not shown).  With `scroll`, the map is first
# scrolled to the top of its scrolling container.
_GEOMETRY_JS = """(scroll) => {
  const plots = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.x_range !== undefined && m.renderers !== undefined) plots.push(m);
  const under = (m, out) => {      // the plots in a model (a plot, a layout, a tab)
    if (m == null) return out;
    if (m.x_range !== undefined && m.renderers !== undefined) { out.push(m); return out; }
    for (const c of [m.child, ...(m.children || []), ...(m.tabs || [])])
      under(Array.isArray(c) ? c[0] : c, out);
    return out;
  };
  const named = (name) => {
    const out = [];
    for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
      if (m.name === name) under(m, out);
    return out;
  };
  const box = (r) => r && {left: r.left, right: r.right, top: r.top, bottom: r.bottom,
                           width: r.width, height: r.height};
  const shown = (m) => {
    const v = window.Bokeh.index.find_one(m);
    return v && v.el.getClientRects().length > 0 ? v : null;
  };
  // a replaced figure stays among the document's models for a while: the shown one
  const mapView = [...named("map"), ...plots.filter(
    (m) => m.title && String(m.title.text).startsWith("<v*> over"))].map(shown).find((v) => v);
  if (scroll && mapView) mapView.el.scrollIntoView({block: "start"});
  let colorbar = null;
  if (mapView) {
    const cb = [...mapView.renderer_views.values()].find((r) => r.model.type === "ColorBar");
    if (cb) {
      const c = mapView.canvas_view.el.getBoundingClientRect();
      colorbar = {left: c.left + cb.bbox.left, right: c.left + cb.bbox.right,
                  top: c.top + cb.bbox.top, bottom: c.top + cb.bbox.bottom,
                  width: cb.bbox.width, height: cb.bbox.height};
    }
  }
  // the trajectory's panels: the model named so, or its figures (titled "normal: ...")
  const trajectory = [...named("trajectory"), ...plots.filter(
    (m) => m.title && String(m.title.text).startsWith("normal:"))];
  const panels = trajectory.map(shown).filter((v) => v)
    .map((v) => v.el.getBoundingClientRect()).filter((r) => r.width > 0 && r.height > 0)
    .sort((a, b) => a.top - b.top);
  const scrollers = [];
  const walk = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) walk(el.shadowRoot);
      const ox = getComputedStyle(el).overflowX;
      if ((ox === "auto" || ox === "scroll") && el.scrollWidth > el.clientWidth + 1
          && el.getClientRects().length > 0)
        scrollers.push(`${el.tagName.toLowerCase()}.${[...el.classList].join(".")} `
                       + `(${el.clientWidth} px showing ${el.scrollWidth} px)`);
    }
  };
  walk(document);
  return {width: innerWidth, height: innerHeight,
          scroll_width: document.scrollingElement.scrollWidth, scrollers,
          map: mapView ? box(mapView.el.getBoundingClientRect()) : null, colorbar,
          panel: panels.length ? box(panels[0]) : null};
}"""


@pytest.fixture
def screen(browser, served_explorer):
    """open(width, height): a new page of that viewport on the explorer,
    loaded (its map drawn); JavaScript errors fail the test."""
    pages, errors = [], []

    def open_(width, height):
        page = browser.new_page(viewport={"width": width, "height": height})
        page.on("pageerror", lambda e: errors.append(str(e)))
        pages.append(page)
        page.goto(served_explorer.url)
        page.wait_for_selector("canvas", timeout=budget_ms(60))
        page.get_by_text("Paper points").first.wait_for(timeout=budget_ms(60))
        page.wait_for_function("() => window.Bokeh.documents.every((d) => d.is_idle)",
                               timeout=budget_ms(60))
        page.wait_for_timeout(1000)        # the prebuilt trajectory figures, fonts
        return page
    yield open_
    for page in pages:
        page.close()
    assert not errors, errors


def _shot(page, name):
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"screens-{name}.png"))


def _span(box):
    return f"x {box['left']:.0f}-{box['right']:.0f} px"


def _across(what, box, width):
    """A problem if `box` is missing or not within [0, width]; else None."""
    if box is None:
        return f"{what} is not shown"
    if box["left"] < -SLACK_PX or box["right"] > width + SLACK_PX:
        return (f"{what} spans {_span(box)}, beyond the viewport's width {width} px "
                f"(cut off or reached only by scrolling sideways)")
    return None


@pytest.mark.parametrize("width, height", SCREENS, ids=[f"{w}x{h}" for w, h in SCREENS])
def test_the_page_fits_the_screen(screen, width, height):
    page = screen(width, height)
    _shot(page, f"{width}x{height}")
    g = page.evaluate(_GEOMETRY_JS, False)
    run = page.get_by_role("button", name="Run selected scene").first.bounding_box()
    run = run and {"left": run["x"], "right": run["x"] + run["width"]}
    problems = []
    if g["scroll_width"] > g["width"]:
        problems.append(f"a horizontal scrollbar: the document is {g['scroll_width']} px "
                        f"wide in a {g['width']} px viewport")
    problems += [f"a horizontal scrollbar inside the page: {s}" for s in g["scrollers"]]
    problems += filter(None, [_across("the map figure", g["map"], g["width"]),
                              _across("the map's colour bar", g["colorbar"], g["width"]),
                              _across("the Run button", run, g["width"])])
    assert not problems, f"at {width} x {height}: " + "; ".join(problems)


def test_the_map_and_a_trajectory_fit_one_projector_screen(screen):
    width, height = PROJECTOR
    page = screen(width, height)
    toggle = page.locator(".vt-presentation")
    presentation = toggle.count() > 0
    if presentation:
        inner = toggle.first.locator("button, input, [role=switch]")
        (inner.first if inner.count() else toggle.first).click()
        page.wait_for_timeout(1000)
    page.get_by_role("button", name="Run selected scene").first.click()
    page.locator("strong", has_text="mu = ").first.wait_for(timeout=budget_ms(60))
    page.wait_for_timeout(1500)           # the run's data drawn
    page.evaluate(_GEOMETRY_JS, True)     # the map at the top of the screen
    page.wait_for_timeout(300)
    _shot(page, f"{width}x{height}-presentation")
    g = page.evaluate(_GEOMETRY_JS, False)
    problems = list(filter(None, [_across("the map figure", g["map"], g["width"]),
                                  _across("the trajectory's first panel", g["panel"],
                                          g["width"])]))
    if g["map"] and g["panel"]:
        top = min(g["map"]["top"], g["panel"]["top"])
        bottom = max(g["map"]["bottom"], g["panel"]["bottom"])
        if bottom - top > g["height"] + SLACK_PX:
            problems.append(f"the map and the trajectory's first panel span {bottom - top:.0f} "
                            f"px of height, more than the screen's {g['height']} px")
    where = (f"map {g['map']}, first panel {g['panel']}")
    assert presentation, ("no presentation mode: no element of class vt-presentation to "
                          f"toggle it (without it: {'; '.join(problems) or 'fits'}; {where})")
    assert not problems, "in presentation mode: " + "; ".join(problems) + f" ({where})"
