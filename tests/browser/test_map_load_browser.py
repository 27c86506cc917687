"""A shipped map not rendered yet in the server loads off its event loop,
seen in a real browser (Debian's chromium, Playwright): at a new mu, the
page first gets the line "Loading the map for ..." over the dimmed map,
then the map of that mu, the line hidden again and the page's
acknowledgement cleared.  A v0* no other page uses makes the map one the
server has not rendered (its pre-render is of the default v0*)."""

import pytest
from browserpages import answered, new_page, open_explorer, settle
from budget import budget_ms

from vibtrans_explorer.server import data

pytestmark = pytest.mark.browser

V0 = "0.0173"  # (a v0* of this test alone)

# what the page's loading line and the map's container were set to, in the
# order the browser applied the server's changes
# (a model's styles: a Map in BokehJS)
_RECORD_JS = """() => {
  window.__vtLoad = [];
  const has = (m, c) => (m.css_classes || []).includes(c);
  const plain = (v) => JSON.stringify(v instanceof Map ? Object.fromEntries(v) : v);
  for (const doc of window.Bokeh.documents)
    doc.on_change((e) => {
      if (e.kind !== "ModelChanged") return;
      if (has(e.model, "vt-map-loading") && (e.attr === "text" || e.attr === "styles"))
        window.__vtLoad.push(["line", e.attr, plain(e.value)]);
      if (has(e.model, "vt-map") && e.attr === "styles")
        window.__vtLoad.push(["map", e.attr, plain(e.value)]);
    });
}"""

# the map's title, and whether the loading line is hidden
_STATE_JS = """() => {
  let title = null, hidden = null;
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.title && m.title.text !== undefined && String(m.title.text).startsWith("<v*> over"))
      title = String(m.title.text);
    if ((m.css_classes || []).includes("vt-map-loading")) {
      const styles = m.styles instanceof Map ? Object.fromEntries(m.styles) : m.styles || {};
      hidden = styles.display === "none";
    }
  }
  return {title, hidden};
}"""
# the map of mu = 0.1 shown, the loading line hidden
_SHOWN_JS = (
    "() => { const s = (" + _STATE_JS + ')(); return s.title !== null && s.title.endsWith("mu = 0.1") '
    "&& s.hidden === true; }"
)


def test_a_new_mu_says_its_map_is_loading_then_shows_it(browser, served_explorer):
    if ("deformable", 0.1) not in data.available_maps():
        pytest.fail("the shipped map deformable, mu = 0.1 is missing (assets/maps)")
    page, errors = new_page(browser, 1280, 800)
    try:
        open_explorer(page, served_explorer.url + f"?v0={V0}")
        settle(page)
        assert page.evaluate(_STATE_JS) == {
            "title": "<v*> over 2000 periods\ndeformable, mu = 0.3",
            "hidden": True,
        }
        page.evaluate(_RECORD_JS)
        page.locator(".vt-mu select").select_option("0.1")
        page.wait_for_function(_SHOWN_JS, timeout=budget_ms(60))
        answered(page)
        seen = page.evaluate("() => window.__vtLoad")
        texts = [v for kind, attr, v in seen if kind == "line" and attr == "text"]
        assert any("Loading the map for deformable, mu = 0.1" in t for t in texts), seen
        # shown, the map dimmed, then both undone (in that order)
        dims = [v for kind, _, v in seen if kind == "map"]
        assert len(dims) >= 2 and '"0.35"' in dims[0] and '"0.35"' not in dims[-1], seen
        lines = [v for kind, attr, v in seen if kind == "line" and attr == "styles"]
        assert lines and '"none"' in lines[-1] and '"none"' not in lines[0], seen
    finally:
        page.close()
    assert not errors, errors
