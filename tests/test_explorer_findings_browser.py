"""Findings of issue 32's walkthrough, each replayed in chromium: the page
as a newcomer sees it (legends, titles, sizes at 1024x768)."""
import pytest

from browserpages import new_page, open_explorer
from budget import budget_ms
from devtools.chromium import launched

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


@pytest.fixture(scope="module")
def browser():
    with launched() as b:
        yield b


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
