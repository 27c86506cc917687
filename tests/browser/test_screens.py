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
from browserpages import answered, frames, steady
from budget import budget_ms

from devtools.explorershots import MAP_JS as _MAP_JS

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
SCREENS = [(1024, 768), (1280, 800), (1920, 1080)]
PROJECTOR = (1920, 1080)
SLACK_PX = 1  # sub-pixel layout rounding
MAP_SHARE = 0.55  # presentation mode at 1024: the map's frame, of the main area's width
STRIP_PX = 30  # the contact-state strip's frame, at least (its bars drawn in it)

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
        steady(page)  # drawn, fonts loaded, laid out for good
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
        return (
            f"{what} spans {_span(box)}, beyond the viewport's width {width} px "
            f"(cut off or reached only by scrolling sideways)"
        )
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
        problems.append(
            f"a horizontal scrollbar: the document is {g['scroll_width']} px "
            f"wide in a {g['width']} px viewport"
        )
    problems += [f"a horizontal scrollbar inside the page: {s}" for s in g["scrollers"]]
    problems += filter(
        None,
        [
            _across("the map figure", g["map"], g["width"]),
            _across("the map's colour bar", g["colorbar"], g["width"]),
            _across("the Run button", run, g["width"]),
        ],
    )
    assert not problems, f"at {width} x {height}: " + "; ".join(problems)


def test_the_map_and_a_trajectory_fit_one_projector_screen(screen):
    width, height = PROJECTOR
    page = screen(width, height)
    toggle = page.locator(".vt-presentation")
    presentation = toggle.count() > 0
    if presentation:
        inner = toggle.first.locator("button, input, [role=switch]")
        (inner.first if inner.count() else toggle.first).click()
        _presented(page)
    page.get_by_role("button", name="Run selected scene").first.click()
    page.locator("strong", has_text="mu = ").first.wait_for(timeout=budget_ms(60))
    # the run's figures shown (they come with its summary), laid out
    page.wait_for_function(f"() => ({_GEOMETRY_JS})(false).panel !== null", timeout=budget_ms(60))
    steady(page)
    page.evaluate(_GEOMETRY_JS, True)  # the map at the top of the screen
    frames(page)
    _shot(page, f"{width}x{height}-presentation")
    g = page.evaluate(_GEOMETRY_JS, False)
    problems = list(
        filter(
            None,
            [
                _across("the map figure", g["map"], g["width"]),
                _across("the trajectory's first panel", g["panel"], g["width"]),
            ],
        )
    )
    if g["map"] and g["panel"]:
        top = min(g["map"]["top"], g["panel"]["top"])
        bottom = max(g["map"]["bottom"], g["panel"]["bottom"])
        if bottom - top > g["height"] + SLACK_PX:
            problems.append(
                f"the map and the trajectory's first panel span {bottom - top:.0f} "
                f"px of height, more than the screen's {g['height']} px"
            )
    where = f"map {g['map']}, first panel {g['panel']}"
    assert presentation, (
        "no presentation mode: no element of class vt-presentation to "
        f"toggle it (without it: {'; '.join(problems) or 'fits'}; {where})"
    )
    assert not problems, "in presentation mode: " + "; ".join(problems) + f" ({where})"


# Each shown map: its box in the page (CSS px), its frame's width, and its
# key (its legend below the plot) against its canvas: the key's left and
# right edges and the canvas's width (key null where it has none)
_MAPS_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.x_range === undefined || m.renderers === undefined) continue;
    const t = m.title && String(m.title.text);
    if (!(t && t.startsWith("<v*> over"))) continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v || v.el.getClientRects().length === 0) continue;
    const r = v.el.getBoundingClientRect();
    const key = [...v.renderer_views.values()].find((r) => r.model.type === "Legend");
    out.push({title: t, left: r.left, right: r.right, top: r.top, bottom: r.bottom,
              frame_width: v.frame.bbox.width,
              key: key ? {left: key.bbox.left, right: key.bbox.right,
                          canvas: v.canvas_view.el.getBoundingClientRect().width} : null});
  }
  return out;
}"""


def _idle(page):
    """The server's answer to the last action arrived (the page's
    acknowledgement, shown by the browser at the action, cleared by the
    server after its answer), and the page laid out again for good."""
    answered(page)
    steady(page)


def _presented(page):
    """After presentation mode is switched on: the server's answer (its note
    on hiding the controls, sent with its styles and fonts) shown and the
    page laid out again for good."""
    page.get_by_text("hides the controls").first.wait_for(timeout=budget_ms(30))
    steady(page)


def _px(locator):
    return float(locator.evaluate("(e) => getComputedStyle(e).fontSize").rstrip("px"))


def _font_px(size):
    """A Bokeh font size ('11px', '8pt') in CSS px."""
    size = str(size)
    return float(size[:-2]) * (4 / 3 if size.endswith("pt") else 1.0)


def test_the_map_keeps_its_frame_when_its_key_grows(screen):
    """At 1024 x 768 the map's data area keeps its height when the key
    below it gains the orbit curves' entries, or the Lyapunov layer's."""
    page = screen(1024, 768)
    before = page.evaluate(_MAP_JS)
    for name, back in (("period-1 orbit curves", "no orbit curves"), ("Lyapunov exponent", "drift velocity")):
        page.get_by_role("button", name=name, exact=True).first.click()
        _idle(page)
        after = page.evaluate(_MAP_JS)
        assert abs(after["frame_height"] - before["frame_height"]) <= SLACK_PX, (
            f"with {name!r} the map's frame is {after['frame_height']:.0f} px high "
            f"against {before['frame_height']:.0f} px"
        )
        page.get_by_role("button", name=back, exact=True).first.click()
        _idle(page)
    # two maps side by side: each key within its own map's canvas (two
    # columns of it were wider than a map and cut off at the left)
    page.get_by_role("button", name="both models", exact=True).first.click()
    page.wait_for_function(f"() => ({_MAPS_JS})().length === 2", timeout=budget_ms(60))
    _idle(page)
    keys = [m["key"] for m in page.evaluate(_MAPS_JS)]
    assert len(keys) == 2 and all(keys), keys
    for key in keys:
        assert key["left"] >= -SLACK_PX and key["right"] <= key["canvas"] + SLACK_PX, keys


@pytest.mark.parametrize("width,height,side_by_side", [(1024, 768, False), (1280, 800, True)])
def test_both_models_maps_fit_the_page(screen, width, height, side_by_side):
    """'both models' at 1024 x 768 put the point-mass map beside the
    deformable one, cut off at the page's right edge: each map lies inside
    the page, side by side where both fit (1280 x 800), else one under the
    other, each at least as wide as one map alone at 1024."""
    page = screen(width, height)
    page.get_by_role("button", name="both models", exact=True).first.click()
    page.wait_for_function(f"() => ({_MAPS_JS})().length === 2", timeout=budget_ms(60))
    _idle(page)
    maps = sorted(page.evaluate(_MAPS_JS), key=lambda m: (m["top"], m["left"]))
    page_width = page.evaluate("() => document.documentElement.clientWidth")
    for m in maps:
        assert m["left"] >= 0 and m["right"] <= page_width + SLACK_PX, (page_width, maps)
    first, second = maps
    if side_by_side:
        assert (
            abs(first["top"] - second["top"]) <= SLACK_PX and second["left"] >= first["right"] - SLACK_PX
        ), maps
    else:
        assert second["top"] >= first["bottom"] - SLACK_PX, maps


def test_presentation_mode_scales_everything_and_the_sidebar_can_hide(screen):
    """Presentation mode: the sidebar's widgets, the tabs and the colour
    bar's ticks and title grow with the page's text; the map's data area
    keeps its height; the template's menu button hides the sidebar, and
    the page then takes its room."""
    page = screen(1280, 800)
    widget = page.get_by_role("button", name="deformable", exact=True).first
    tab = page.get_by_text("Vertical", exact=True).first
    # the typed log10 A* and the chosen fidelity (they stayed at the
    # browser's 13.33 px for a form's controls)
    typed = page.locator("input.bk-input").first
    chosen = page.locator("select.bk-input").first
    before = page.evaluate(_MAP_JS), _px(widget), _px(tab), _px(typed), _px(chosen)
    page.locator(".vt-presentation").first.locator("button").first.click()
    _presented(page)
    after = page.evaluate(_MAP_JS), _px(widget), _px(tab), _px(typed), _px(chosen)
    _shot(page, "1280x800-presentation-sidebar")
    assert after[1] >= 1.4 * before[1], f"the sidebar's buttons: {before[1]} -> {after[1]} px"
    assert after[2] >= 1.4 * before[2], f"the tabs: {before[2]} -> {after[2]} px"
    assert after[3] >= 1.4 * before[3], f"a text input's text: {before[3]} -> {after[3]} px"
    assert after[4] >= 1.4 * before[4], f"a select's text: {before[4]} -> {after[4]} px"
    for key in ("bar_ticks", "bar_title"):
        assert _font_px(after[0][key]) >= 1.4 * _font_px(before[0][key]), (key, before[0], after[0])
    assert abs(after[0]["frame_height"] - before[0]["frame_height"]) <= SLACK_PX, (before[0], after[0])
    page.get_by_text("hides the controls").first.wait_for(timeout=budget_ms(10))
    page.locator("#sidebar-toggle").first.click()
    steady(page)  # the sidebar's transition ended, the map resized
    hidden = page.evaluate(_MAP_JS)
    _shot(page, "1280x800-presentation-no-sidebar")
    assert not widget.is_visible() or widget.bounding_box()["x"] + 5 < 0, "the sidebar is still shown"
    assert hidden["left"] < after[0]["left"] - 250, (
        "the map did not move into the sidebar's room",
        after[0],
        hidden,
    )
    assert abs(hidden["frame_height"] - before[0]["frame_height"]) <= SLACK_PX, (before[0], hidden)


# In presentation mode: the map's frame and the main area's width, the
# state strips' frames and whether their bars have data, the Vertical
# tab's tick labels (model) and the animation's speed selector's text (CSS
# px, as the browser draws it); null where not shown
_PRESENTED_JS = """() => {
  const plots = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.x_range !== undefined && m.renderers !== undefined && m.title) {
      const v = window.Bokeh.index.find_one(m);
      if (v && v.el.checkVisibility({visibilityProperty: true}) && v.frame.bbox.width > 0)
        plots.push([String(m.title.text), m, v]);
    }
  const titled = (start) => plots.filter(([t]) => t.startsWith(start));
  const map = titled("<v*> over")[0];
  const main = document.querySelector("#main");
  const strips = titled("contact state").map(([t, m, v]) => {
    const bands = m.renderers.find((r) => r.glyph && r.glyph.type === "Quad");
    const data = bands.data_source.data;
    return {title: t, frame_height: v.frame.bbox.height,
            bars: (data instanceof Map ? data.get("left") : data.left).length};
  });
  const vertical = titled("Jumping threshold")[0];
  let speed = null;
  for (const doc of window.Bokeh.documents) {
    const m = doc.get_model_by_name("anim-speed");
    const v = m && window.Bokeh.index.find_one(m);
    const root = v && (v.shadow_el || v.el.shadowRoot);
    const el = root && root.querySelector("select");
    if (el && el.checkVisibility()) speed = parseFloat(getComputedStyle(el).fontSize);
  }
  return {main: main ? main.getBoundingClientRect().width : null,
          map: map ? map[2].frame.bbox.width : null, strips,
          vertical_ticks: vertical ? vertical[1].below.find(
            (a) => a.major_label_text_font_size !== undefined).major_label_text_font_size : null,
          speed};
}"""


def _tab_shows(page, name, start):
    """Open the tab `name` and wait until a plot titled `start`... is shown."""
    from test_first_look_browser import open_tab

    open_tab(page, name, start)
    return page.evaluate(_PRESENTED_JS)


def test_presentation_at_1024_keeps_the_map_the_strips_and_enlarges_every_text(browser, served_explorer):
    """Presentation mode at 1024 x 768, the sidebar shown: the map's frame
    keeps at least MAP_SHARE of the main area's width (a sidebar of 1.5 x
    330 pixels left it ~260 of ~530 pixels); the contact-state strips keep
    a frame of at least STRIP_PX with their bars (with the fonts scaled,
    their text took the figures' whole fixed height); the Vertical tab's
    ticks and the animation's speed selector grow with the page's text
    (they stayed at their normal sizes)."""
    from browserpages import new_page, open_explorer
    from test_first_look_browser import presentation_on

    page, errors = new_page(browser, 1024, 768)
    open_explorer(page, served_explorer.url + "?la=-0.3&lm=1&fidelity=preview")
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(90))
    normal = _tab_shows(page, "Animation", "t* = ")["speed"]
    presentation_on(page)
    got = _tab_shows(page, "Map", "<v*> over")
    assert got["map"] >= MAP_SHARE * got["main"], got
    got = _tab_shows(page, "Trajectory", "contact state")
    assert len(got["strips"]) == 2, got
    for strip in got["strips"]:
        assert strip["frame_height"] >= STRIP_PX and strip["bars"] > 0, strip
    assert _font_px(_tab_shows(page, "Vertical", "Jumping threshold")["vertical_ticks"]) >= 1.4 * _font_px(
        "8pt"
    )
    speed = _tab_shows(page, "Animation", "t* = ")["speed"]
    assert normal and speed >= 1.4 * normal, (normal, speed)
    _shot(page, "1024x768-presentation-animation")
    page.close()
    assert not errors, errors
