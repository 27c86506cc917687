"""What a first look at the page finds, each replayed in chromium: the page
as a newcomer sees it (legends, titles, sizes at 1024x768)."""
import pytest
from browserpages import new_page, open_explorer, settle
from budget import budget_ms

pytestmark = pytest.mark.browser

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
    open_explorer(page, served_explorer.url
                  + "?la=0.5&lm=1.5&maps=both%20models&compare=point%20mass&fidelity=preview")
    page.get_by_text("drift <v*> (mean over the run)").first.wait_for(timeout=budget_ms(90))
    page.wait_for_function("""() => (%s)().some(l => l[1].startsWith("x*, point mass"))"""
                           % _LEGEND_LABELS_JS, timeout=budget_ms(30), polling=250)
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
    assert window.input_value() == "the last periods at full resolution"   # (not blank)
    # every line of the figures' titles and notes within its figure's frame:
    # the contact's title ("from above: c = ..., s = ...") and the side
    # view's "Not to scale: ..." note were cut at 1024
    page.wait_for_function("""() => (%s)().some(f => f.name === "anim-circle"
                               && f.lines.some(l => l[0].startsWith("from above")))"""
                           % _ANIMATION_TEXTS_JS, timeout=budget_ms(30), polling=250)
    settle(page)
    figures = page.evaluate(_ANIMATION_TEXTS_JS)
    page.close()
    assert sorted(f["name"] for f in figures) == ["anim-circle", "anim-side"], figures
    for fig in figures:
        assert any(l.startswith("Not to scale") for l, _ in fig["lines"]) or \
            fig["name"] == "anim-circle", fig
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
    page.wait_for_function("""() => (%s)().some(f => f.title.startsWith(
                               "memory diagram w(h)\\nt* ="))""" % _MEMORY_FIGURES_JS,
                           timeout=budget_ms(60), polling=250)
    settle(page)
    figures = page.evaluate(_MEMORY_FIGURES_JS)
    page_width = page.evaluate("() => document.documentElement.clientWidth")
    page.close()
    assert len(figures) == 3, figures
    for fig in figures:
        assert fig["left"] >= 0 and fig["right"] <= page_width, (page_width, fig)
        for line, line_width in fig["lines"]:
            assert line_width <= fig["frame_width"], (line, line_width, fig)
    circle, = [f for f in figures if f["title"].startswith("contact")]
    assert abs(circle["frame_width"] - circle["frame_height"]) <= 1, circle
    assert not errors, errors
