"""What a first look at the page finds, each replayed in chromium: the page
as a newcomer sees it (legends, titles, sizes at 1024x768)."""

import re
from pathlib import Path

import pytest
from browserpages import new_page, open_explorer, settle
from budget import budget_ms

pytestmark = pytest.mark.browser

ARTIFACTS = Path(__file__).resolve().parent.parent / "test-artifacts"

# every legend item's label in the page's Bokeh documents: [kind, text]
# (kind "value" for a text, "column" for a column of the renderers' source,
# "field" for a column name the source lacks: Bokeh shows "Invalid field")
_LEGEND_LABELS_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.type !== "LegendItem" && !(m.constructor && m.constructor.__name__ === "LegendItem"))
      continue;
    const l = m.label;
    if (l == null) continue;
    if (l.field !== undefined) {
      // a column name: valid where every renderer's source has that column
      const ok = m.renderers.every(r => {
        const d = r.data_source.data;
        return d instanceof Map ? d.has(l.field) : l.field in d;
      });
      out.push([ok ? "column" : "field", String(l.field)]);
    }
    else if (l.value !== undefined) out.push(["value", String(l.value)]);
  }
  return out;
}"""


def test_both_models_click_names_both_lines_of_the_x_legend(browser, served_explorer):
    """'both models', a scene at (0.5, 1.5): the x*(t) legend named its two
    lines 'Invalid field' (a label set as a column name)."""
    page, errors = new_page(browser, 1280, 800)
    open_explorer(
        page, served_explorer.url + "?la=0.5&lm=1.5&maps=both%20models&compare=point%20mass&fidelity=preview"
    )
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(90))
    page.wait_for_function(
        """() => (%s)().some(l => l[1].startsWith("x*, point mass"))""" % _LEGEND_LABELS_JS,
        timeout=budget_ms(30),
        polling=250,
    )
    labels = page.evaluate(_LEGEND_LABELS_JS)
    page.close()
    assert not [l for l in labels if l[0] == "field"], labels
    texts = [t for _, t in labels]
    assert any(t.startswith("x*, tau = ") for t in texts), texts
    assert not errors, errors


def test_the_animation_player_fits_at_1024(browser, served_explorer):
    """At 1024x768 the animation's speed selector was off the page's right
    edge (the player below the figures, a 560-pixel slider): the player and
    its window selector are inside the viewport, and the window selector
    shows its choice."""
    page, errors = new_page(browser, 1024, 768)
    open_explorer(page, served_explorer.url + "?la=-0.3&lm=1&fidelity=preview")
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(90))
    page.get_by_text("Animation", exact=True).first.click()
    speed = page.locator("select").filter(has_text="1 period/s").first
    speed.wait_for(timeout=budget_ms(30))
    window = page.locator("select").filter(has_text="the whole run (decimated)").first
    for el in (speed, window, page.get_by_role("button", name="Play")):
        el.scroll_into_view_if_needed()
        box = el.bounding_box()
        assert box is not None and box["x"] >= 0 and box["x"] + box["width"] <= 1024, box
    assert window.input_value() == "the last periods at full resolution"  # (not blank)
    # every line of the figures' titles and notes within its figure's frame:
    # the contact's title ("from above: c = ..., s = ...") and the side
    # view's "Not to scale: ..." note were cut at 1024
    page.wait_for_function(
        """() => (%s)().some(f => f.name === "anim-circle"
                               && f.lines.some(l => l[0].startsWith("from above")))"""
        % _ANIMATION_TEXTS_JS,
        timeout=budget_ms(30),
        polling=250,
    )
    settle(page)
    figures = page.evaluate(_ANIMATION_TEXTS_JS)
    page.close()
    assert sorted(f["name"] for f in figures) == ["anim-circle", "anim-side"], figures
    for fig in figures:
        assert any(l.startswith("Not to scale") for l, _ in fig["lines"]) or fig["name"] == "anim-circle", fig
        for line, line_width in fig["lines"]:
            assert line_width <= fig["frame_width"], (line, line_width, fig)
    assert not errors, errors


# the animation's two figures: each line of their titles (above and below
# the frame) with its width as the canvas draws it, and the frame's width
_ANIMATION_TEXTS_JS = """() => {
  const ctx = document.createElement("canvas").getContext("2d");
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.name !== "anim-side" && m.name !== "anim-circle") continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v || v.el.getClientRects().length === 0) continue;
    const titles = [m.title, ...m.below].filter(
      (t) => t && typeof t.text === "string" && t.text_font_size !== undefined);
    const lines = [];
    for (const t of titles) {
      ctx.font = `${t.text_font_style} ${t.text_font_size} ${t.text_font}`;
      for (const l of String(t.text).split("\\n")) if (l) lines.push([l, ctx.measureText(l).width]);
    }
    out.push({name: m.name, frame_width: v.frame.bbox.width, lines: lines});
  }
  return out;
}"""


# the memory tab's three figures, each where the page shows it: its box in
# the viewport, its frame (data area) and the width of each line of its
# title as the figure's canvas draws it (its font, measured by a canvas)
_MEMORY_FIGURES_JS = """() => {
  const ctx = document.createElement("canvas").getContext("2d");
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.title === undefined || m.title === null || m.renderers === undefined) continue;
    const text = String(m.title.text);
    if (!/^(memory diagram|spring displacements|contact)/.test(text)) continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v || v.el.getClientRects().length === 0) continue;
    const box = v.el.getBoundingClientRect();
    const t = m.title;
    ctx.font = `${t.text_font_style} ${t.text_font_size} ${t.text_font}`;
    out.push({title: text, left: box.left, right: box.right,
              frame_width: v.frame.bbox.width, frame_height: v.frame.bbox.height,
              lines: text.split("\\n").map((l) => [l, ctx.measureText(l).width])});
  }
  return out;
}"""


@pytest.mark.parametrize("width,height", [(1024, 768), (1920, 1080)])
def test_the_memory_figures_and_their_titles_fit(browser, served_explorer, width, height):
    """The memory tab at 1024 and 1920: its titles ("spring displacements
    u(h), |u| <= a* - h", "contact: c = ..., s = ... (total sliding)") were
    cut at their figures' edges, and one Bokeh row of the three figures
    (~900 pixels) cut the contact circle at the page's right edge and
    squeezed it into an ellipse.  Each figure lies inside the page, each
    line of its title fits over its frame, and the circle's frame is
    square."""
    page, errors = new_page(browser, width, height)
    open_explorer(page, served_explorer.url + "?la=-0.3&lm=1&fidelity=preview")
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(90))
    page.get_by_text("Memory diagram", exact=True).first.click()
    page.wait_for_function(
        """() => (%s)().some(f => f.title.startsWith(
                               "memory diagram w(h)\\nt* ="))"""
        % _MEMORY_FIGURES_JS,
        timeout=budget_ms(60),
        polling=250,
    )
    settle(page)
    figures = page.evaluate(_MEMORY_FIGURES_JS)
    page_width = page.evaluate("() => document.documentElement.clientWidth")
    page.close()
    assert len(figures) == 3, figures
    for fig in figures:
        assert fig["left"] >= 0 and fig["right"] <= page_width, (page_width, fig)
        for line, line_width in fig["lines"]:
            assert line_width <= fig["frame_width"], (line, line_width, fig)
    (circle,) = [f for f in figures if f["title"].startswith("contact")]
    assert abs(circle["frame_width"] - circle["frame_height"]) <= 1, circle
    assert not errors, errors


# ------------------------------------------------------------------ every text fits
# What is cut or overlaps, in every figure and dropdown shown: each plot's
# titles (their lines against its frame's width), axis labels (against the
# frame's side they run along), text glyphs inside the frame (a centred one
# against the frame's width, a left-aligned one from where it starts), a
# colour bar's title against its labels (the two must not overlap), and
# every option of every dropdown (a native select shows its choice on one
# line, cut at the box's edge).  Widths as the browser's canvas draws the
# text (its font, measured); a list of problems, each naming the figure.
_TEXTS_JS = """() => {
  const ctx = document.createElement("canvas").getContext("2d");
  const value = (p) => (p !== null && typeof p === "object" && "value" in p) ? p.value : p;
  const width = (font, text) => { ctx.font = font; return ctx.measureText(text).width; };
  const font = (m, key) => `${value(m[key + "_font_style"])} ${value(m[key + "_font_size"])} `
                           + `${value(m[key + "_font"])}`;
  const px = (size) => parseFloat(size) * (String(size).endsWith("pt") ? 4 / 3 : 1);
  const problems = [], figures = [];
  // shown: laid out and visible (a hidden tab's content, display: none
  // somewhere above it through shadow roots, is not)
  const shown = (el) => el && el.isConnected && el.checkVisibility({visibilityProperty: true})
    && el.getBoundingClientRect().width > 0;
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.x_range === undefined || m.renderers === undefined) continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v || !shown(v.el)) continue;
    const frame = v.frame.bbox;
    const name = String((m.title && m.title.text) || m.name || m.id).split("\\n")[0];
    figures.push(name);
    const cut = (what, text, w, room) => {
      if (w > room + 1)
        problems.push(`${name}: ${what} '${text}' is ${Math.round(w)} px wide, `
                      + `${Math.round(room)} px of room`);
    };
    for (const t of [m.title, ...m.above, ...m.below, ...m.left, ...m.right])
      if (t && t.type === "Title" && t.visible !== false)
        for (const line of String(t.text).split("\\n"))
          if (line) cut("title", line, width(font(t, "text"), line), frame.width);
    for (const [axes, room] of [[[...m.above, ...m.below], frame.width],
                                [[...m.left, ...m.right], frame.height]])
      for (const a of axes)
        if (a.axis_label !== undefined && a.visible !== false && a.axis_label)
          for (const line of String(value(a.axis_label)).split("\\n"))
            cut("axis label", line, width(font(a, "axis_label_text"), line), room);
    const canvas = v.canvas_view.bbox;
    for (const rv of v.renderer_views.values()) {
      const r = rv.model;
      if (r.type === "Legend" && r.visible !== false && rv.bbox && rv.bbox.width > 0
          && (rv.bbox.left < -1 || rv.bbox.right > canvas.width + 1))
        problems.push(`${name}: its legend spans x ${Math.round(rv.bbox.left)} to `
                      + `${Math.round(rv.bbox.right)} px of a ${Math.round(canvas.width)} px canvas`);
      if (r.type === "ColorBar" && r.title && rv._frame_view) {
        // its title runs along the bar (beside a vertical one)
        const bar = rv._frame_view.bbox;
        const room = rv.orientation === "horizontal" ? bar.width : bar.height;
        for (const line of String(value(r.title)).split("\\n"))
          cut("colour bar title", line, width(font(r, "title_text"), line), room);
      }
      if (r.type !== "GlyphRenderer" || !r.glyph || r.glyph.type !== "Text" || !r.visible) continue;
      const g = r.glyph, data = r.data_source.data;
      const get = (k) => data instanceof Map ? data.get(k) : data[k];
      const field = g.text && g.text.field;
      const texts = field ? get(field) : null;
      if (!texts) continue;
      const size = value(g.text_font_size) || "16px";
      const f = `${value(g.text_font_style) || "normal"} ${size} ${value(g.text_font) || "helvetica"}`;
      const align = value(g.text_align);
      const sx = rv.glyph.sx;
      for (let i = 0; i < texts.length; i++)
        for (const text of String(texts[i]).split("\\n")) {
          if (!text) continue;
          const w = width(f, text);
          if (align === "center") cut("text", text, w, frame.width);
          else if (align === "left" && sx && isFinite(sx[i]))
            cut("text", text, w, frame.right - sx[i]);
        }
    }
  }
  const all = (root, out = []) => {
    for (const e of root.querySelectorAll("*")) {
      out.push(e);
      if (e.shadowRoot) all(e.shadowRoot, out);
    }
    return out;
  };
  // every figure, field, dropdown and button inside the page's width (not
  // cut at its right edge)
  for (const e of all(document)) {
    if (!["SELECT", "INPUT", "BUTTON", "CANVAS"].includes(e.tagName) || !shown(e)) continue;
    const r = e.getBoundingClientRect();
    if (r.right > innerWidth + 1 || r.left < -1)
      problems.push(`a ${e.tagName.toLowerCase()} spans x ${Math.round(r.left)} to `
                    + `${Math.round(r.right)} px of a ${innerWidth} px page `
                    + `('${(e.value || e.textContent || "").slice(0, 40)}')`);
  }
  // every widget's label whole, inside its widget (one on a line of its own
  // runs past the widget's edge, cut there)
  for (const e of all(document).filter((e) => e.tagName === "LABEL" && shown(e))) {
    const box = e.parentElement && e.parentElement.getBoundingClientRect();
    const r = e.getBoundingClientRect();
    if (box && (r.right > box.right + 1 || r.right > innerWidth + 1))
      problems.push(`the label '${e.textContent.trim()}' is cut: it ends at x `
                    + `${Math.round(r.right)} px, its widget at ${Math.round(box.right)}`);
  }
  for (const s of all(document).filter((e) => e.tagName === "SELECT" && shown(e))) {
    const style = getComputedStyle(s);
    // the text's room: the box less its paddings (the arrow sits in the right one)
    const room = s.clientWidth - parseFloat(style.paddingLeft) - parseFloat(style.paddingRight);
    for (const o of s.options) {
      const w = width(`${style.fontStyle} ${style.fontWeight} ${style.fontSize} ${style.fontFamily}`,
                      o.text);
      if (w > room + 1)
        problems.push(`dropdown option '${o.text}' is ${Math.round(w)} px wide, `
                      + `${Math.round(room)} px of room`);
    }
  }
  return {problems, figures};
}"""

MAP_TABS = ("Map", "Vertical", "Units", "Map on demand", "Difference", "Design")
RUN_TABS = ("Trajectory", "Animation", "Memory diagram", "Downloads", "Dynamics")


# a plot shown (laid out and visible) whose title starts with the text given
_PLOT_SHOWN_JS = """(start) => {
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.x_range === undefined || m.renderers === undefined || !m.title) continue;
    if (!String(m.title.text).startsWith(start)) continue;
    const v = window.Bokeh.index.find_one(m);
    if (v && v.el.checkVisibility({visibilityProperty: true}) && v.frame.bbox.width > 0)
      return true;
  }
  return false;
}"""
# what each tab shows once its content has come from the server: the
# start of a plot's title, or a text
TAB_READY = {
    "Map": ("plot", "<v*> over"),
    "Vertical": ("plot", "Jumping threshold"),
    "Units": ("text", "Device in SI units"),
    "Map on demand": ("text", "Compute map"),
    "Difference": ("text", "Show the difference"),
    "Design": ("text", "Draw chart"),
    "Trajectory": ("plot", "normal:"),
    "Animation": ("plot", "t* = "),
    "Memory diagram": ("plot", "memory diagram w(h)\nt* = "),
    "Downloads": ("text", "trajectory .png"),
    "Dynamics": ("plot", "stroboscopic section"),
}


def open_tab(page, name, ready=None):
    """Open the tab `name` (a map tab or a run tab), its header at the top
    of the screen, and wait until its content is drawn (TAB_READY, or
    `ready`: the start of a plot's title)."""
    exact = re.compile(f"^{re.escape(name)}$")
    page.locator(".bk-tab", has_text=exact).first.click()
    active = page.locator(".bk-tab.bk-active", has_text=exact).first
    active.wait_for(timeout=budget_ms(30))
    kind, what = ("plot", ready) if ready else TAB_READY[name]
    if kind == "plot":
        page.wait_for_function(_PLOT_SHOWN_JS, arg=what, timeout=budget_ms(120), polling=250)
    else:
        page.get_by_text(what).first.wait_for(timeout=budget_ms(60))
    active.evaluate("(e) => e.scrollIntoView({block: 'start'})")
    settle(page)


def _fill_tab(page, name):
    """What a tab shows once used: the difference of two maps, the design
    chart."""
    if name == "Difference":
        page.get_by_role("button", name="Show the difference").first.click()
        page.locator(".vt-diff-summary").get_by_text(re.compile(".")).first.wait_for(timeout=budget_ms(120))
    elif name == "Design":
        page.get_by_role("button", name="Draw chart").first.click()
        page.get_by_text("Click the chart to move the device").first.wait_for(timeout=budget_ms(180))
    settle(page)


def presentation_on(page):
    """Switch presentation mode on and wait until the page's text grew (the
    browser's root size, then the server's styles) and its figures are
    drawn again."""
    tab = page.locator(".bk-tab").first
    before = tab.evaluate("(e) => parseFloat(getComputedStyle(e).fontSize)")
    page.locator(".vt-presentation").first.locator("button").first.click()
    page.wait_for_function(
        "([e, px]) => parseFloat(getComputedStyle(e).fontSize) > 1.4 * px",
        arg=[tab.element_handle(), before],
        timeout=budget_ms(30),
    )
    settle(page)


SCREENS = [(1024, 768), (1280, 800), (1920, 1080)]


@pytest.mark.parametrize("presentation", [False, True], ids=["normal", "presentation"])
@pytest.mark.parametrize("width,height", SCREENS, ids=[f"{w}x{h}" for w, h in SCREENS])
def test_every_title_label_and_dropdown_fits(browser, served_explorer, width, height, presentation):
    """Every tab of the map and of the run, after a run, in normal and
    presentation mode: no title, axis label, text in a figure or dropdown
    option is cut at its figure's frame or its box (`_TEXTS_JS`).  The
    screen of each tab goes to test-artifacts/texts-<size>-<mode>-<tab>.png
    (look at them)."""
    page, errors = new_page(browser, width, height)
    # a particle with a tip (its drawing in the sidebar), in permanent contact
    open_explorer(page, served_explorer.url + "?la=-0.3&lm=1&fidelity=preview&profile=power:3")
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(90))
    if presentation:
        presentation_on(page)
    mode = "presentation" if presentation else "normal"
    ARTIFACTS.mkdir(exist_ok=True)
    problems, figures = [], []

    def check(name, shot):
        if shot:
            page.screenshot(path=str(ARTIFACTS / f"texts-{width}x{height}-{mode}-{shot}.png"))
        got = page.evaluate(_TEXTS_JS)
        problems.extend(f"{name} tab: {p}" for p in got["problems"])
        figures.extend(got["figures"])

    for name in MAP_TABS + RUN_TABS:
        open_tab(page, name)
        _fill_tab(page, name)
        open_tab(page, name)
        check(name, name.lower().replace(" ", "-"))
    # a hopping scene (paper point 4), in flight at its end: the memory
    # diagram's and the animation's words for a flight
    page.locator(".vt-paper-points select").select_option(index=4)
    page.locator("strong", has_text="A* = 316.2, m* = 1,").first.wait_for(timeout=budget_ms(120))
    for name, ready in (
        ("Memory diagram", "memory diagram w(h)\nt* = 2000, flight"),
        ("Animation", "t* = "),
        ("Trajectory", "normal:"),
    ):
        open_tab(page, name, ready)
        check(name, None)
    page.close()
    assert len(figures) >= 15, figures
    assert not problems, "\n".join(sorted(set(problems)))
    assert not errors, errors
