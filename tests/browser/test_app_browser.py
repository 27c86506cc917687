"""The explorer in a real headless browser (Debian's chromium driven by
Playwright): load, click the map, pick a paper point, a second run feeding
the same figures, a click replacing a running run, cancel, the step cap,
units, URL.

Screenshots (the whole main column, trajectories included) go to
test-artifacts/ (look at them)."""

import os
from pathlib import Path

import pytest
from browserpages import answered, settle
from budget import budget_ms

from vibtrans.analysis.summary import TWIN_TAU_OFFSET

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"


@pytest.fixture(scope="module")
def server(served_explorer):
    """The session's `vibtrans serve` (conftest.py), VIBTRANS_MAX_STEPS = 1e8."""
    return served_explorer.url


@pytest.fixture
def page(browser, server, request):
    pg = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    yield pg
    ARTIFACTS.mkdir(exist_ok=True)
    # the template scrolls its main column itself: a tall viewport shows it all
    pg.set_viewport_size({"width": 1400, "height": 3300})
    settle(pg)  # laid out again at that size
    pg.screenshot(path=str(ARTIFACTS / f"{request.node.name}.png"), full_page=True)
    pg.close()
    assert not errors, errors


def _open(page, url):
    page.goto(url)
    page.wait_for_selector("canvas", timeout=budget_ms(60))
    page.wait_for_selector("text=Paper points", timeout=budget_ms(60))
    settle(page)  # its figures drawn and laid out


def _summary_text(page):
    return page.get_by_text("drift <v*> (mean over the run)").first


# The figures' data sources (Bokeh models in the page): for each one with a
# time column, its id and length.
_SOURCES_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    const d = m.data;
    if (d == null || typeof d !== "object") continue;
    const t = d instanceof Map ? d.get("time") : d["time"];
    if (t !== undefined) out.push([m.id, t.length]);
  }
  return out;
}"""
_MODELS_JS = "() => window.Bokeh.documents.reduce((n, d) => n + d.all_models.size, 0)"
# at least `count` canvases of the page (through the shadow roots Bokeh
# renders into) wider than `width` and taller than `height` CSS px
_BIG_CANVASES_JS = """([width, height, count]) => {
  let n = 0;
  const visit = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) visit(el.shadowRoot);
      if (el.tagName === "CANVAS") {
        const r = el.getBoundingClientRect();
        if (r.width > width && r.height > height) n += 1;
      }
    }
  };
  visit(document);
  return n >= count;
}"""
# each figure: title, the id and extent of its x range
_FIGURES_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.x_range !== undefined && m.renderers !== undefined && m.title != null)
      out.push([m.title.text, m.x_range.id, m.x_range.start, m.x_range.end]);
  return out;
}"""
# a run summary (its bold first line) other than `before`, through the
# nested shadow roots Bokeh renders into
_NEW_SUMMARY_JS = """(before) => {
  let found = false;
  const visit = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) visit(el.shadowRoot);
      if (el.tagName === "STRONG" && el.textContent.includes("mu = ")
          && el.textContent !== before) found = true;
    }
  };
  visit(document);
  return found;
}"""


def _sources(page):
    return dict(page.evaluate(_SOURCES_JS))


def _see(page, text, timeout=None):
    """Wait until `text` is shown (Playwright's text locators pierce the
    shadow DOM that Bokeh renders into; body.innerText does not)."""
    page.get_by_text(text).first.wait_for(timeout=budget_ms(30) if timeout is None else timeout)


def test_page_loads_with_the_map(page, server):
    _open(page, server)
    assert page.locator("canvas").count() >= 1
    box = page.locator("canvas").first.bounding_box()
    assert box["width"] > 600 and box["height"] > 300  # the map, full size


def test_paper_point_runs_and_plots(page, server):
    _open(page, server)
    select = page.locator("select").filter(has_text="synchronous hopping")
    select.select_option(label="4: synchronous hopping")
    _summary_text(page).wait_for(timeout=budget_ms(60))
    _see(page, "jumping, synchronous, drift against the wave")
    _see(page, "Whole run")
    _see(page, "Last 2 periods at full resolution")
    # the trajectory figure is drawn: its canvases have a real size
    page.wait_for_function(_BIG_CANVASES_JS, arg=[500, 100, 3], timeout=budget_ms(30), polling=100)
    sizes = [c.bounding_box() for c in page.locator("canvas").all()]
    assert sum(1 for b in sizes if b and b["width"] > 500 and b["height"] > 100) >= 3
    # ... and data: the whole run in per-bin envelopes (one source for its
    # panels), the fragment's steps, the tau twin's samples (2000 periods x 5)
    lengths = sorted(_sources(page).values())
    assert len(lengths) == 3 and lengths[0] >= 2 * 40, lengths
    assert 400 in lengths and lengths[-1] >= 10000, lengths
    # one linked time axis for the whole run (its 5 panels), one for the
    # fragment, whose time counts from its start (t0 = 1998: in absolute
    # numbers the motion within a period would hide)
    figures = page.evaluate(_FIGURES_JS)
    whole = {(x, s, e) for t, x, s, e in figures if s == 0 and e == 2000}
    last = {(x, s, e) for t, x, s, e in figures if s == 0 and e == 2}
    titles = [t for t, *_ in figures]
    assert len(whole) == 1 and len(last) == 1, figures
    assert sum(1 for t, x, *_ in figures if (x, 0, 2000) in whole) == 5, figures
    for title in (
        "normal: a*(t), y*(t)",
        "contact state\n(dominant per bin)",
        f"x*(t) and its tau + {TWIN_TAU_OFFSET:g} twin",
        "tangential: b*(t),\nx*(t) - x*(t0)",
    ):
        assert title in titles, titles


def test_a_second_run_feeds_the_same_figures(page, server):
    """A new run sends new data to the figures of the first one: the same
    data sources, no new Bokeh models."""
    _open(page, server)
    box = page.locator("canvas").first.bounding_box()
    page.mouse.click(box["x"] + box["width"] * 0.55, box["y"] + box["height"] * 0.35)
    _summary_text(page).wait_for(timeout=budget_ms(60))
    answered(page)  # the run's figures and data came with it
    first, models = _sources(page), page.evaluate(_MODELS_JS)
    summary = page.locator("strong", has_text="mu = 0.3").first.inner_text()
    page.mouse.click(box["x"] + box["width"] * 0.75, box["y"] + box["height"] * 0.25)
    page.wait_for_function(_NEW_SUMMARY_JS, arg=summary, timeout=budget_ms(60), polling=100)
    answered(page)
    second = _sources(page)
    assert second.keys() == first.keys()
    assert second != first  # new data in them
    assert page.evaluate(_MODELS_JS) == models


def test_both_models_draw_into_the_same_figures(page, server):
    """A set of figures of the first point-mass run's own would cost 1.9 s
    in chromium.  The material point's panels are drawn in the
    deformable particle's figures, with its own titles and quantities."""
    _open(page, server)
    select = page.locator("select").filter(has_text="synchronous hopping")
    select.select_option(label="4: synchronous hopping")
    _summary_text(page).wait_for(timeout=budget_ms(60))
    answered(page)  # the run's figures came with it
    trajectory = lambda: sorted(
        (x, t)
        for t, x, *_ in page.evaluate(_FIGURES_JS)  # noqa: E731
        if not t.startswith("<v*>")
    )
    before = trajectory()
    summary = page.locator("strong", has_text="mu = 0.3").first.inner_text()
    select.select_option(label="10: point mass, chaotic")
    page.wait_for_function(_NEW_SUMMARY_JS, arg=summary, timeout=budget_ms(60), polling=100)
    _see(page, "point-mass:")
    answered(page)
    after = trajectory()
    assert [x for x, _ in after] == [x for x, _ in before]  # the same figures
    titles = {t for _, t in after}
    assert {
        "normal: y*(t)\n(mean, min-max per bin)",
        "forces: N*, T*",
        "tangential: x*(t) - x*(t0)",
    } <= titles, titles
    assert not any(t.startswith("normal: a*(t)") for t in titles), titles


def test_a_new_click_replaces_a_running_run(page, server):
    """One run per session: a click while a run goes on cancels it (without a
    'cancelled' message) and shows the new run."""
    _open(page, server + "?la=2.8&lm=-4.5&fidelity=reference")
    page.locator("button", has_text="Run selected scene").click()
    _see(page, "Running")
    page.locator("select").filter(has_text="synchronous hopping").select_option(
        label="4: synchronous hopping"
    )
    _see(page, "A* = 316.2", timeout=budget_ms(120))
    _summary_text(page).wait_for(timeout=budget_ms(120))
    assert page.get_by_text("Run cancelled.").count() == 0
    assert page.get_by_text("The run failed").count() == 0


def test_the_step_cap_is_a_message(page, server):
    # 1.3e8 steps, over the test server's VIBTRANS_MAX_STEPS = 1e8
    _open(page, server + "?la=3&lm=-5&fidelity=reference")
    page.locator("button", has_text="Run selected scene").click()
    _see(page, "over this server's limit of 1e+08 (VIBTRANS_MAX_STEPS)")
    # the click's acknowledgement ("Running ...") goes with the refusal, and
    # nothing runs
    page.get_by_text("Running").first.wait_for(state="hidden", timeout=budget_ms(30))
    # a later answer of the server (the introduction, added when first
    # opened): a run the click had started would have said so before it
    page.get_by_text("What is this? (a short introduction)").first.click()
    _see(page, "A small particle rests on a surface")
    assert page.get_by_text("Running").count() == 0


def test_click_on_the_map_runs_that_scene(page, server):
    _open(page, server)
    box = page.locator("canvas").first.bounding_box()
    page.mouse.click(box["x"] + box["width"] * 0.55, box["y"] + box["height"] * 0.35)
    _summary_text(page).wait_for(timeout=budget_ms(60))
    la = float(page.locator("input").nth(1).input_value() or "nan")
    assert -3 <= la <= 3
    _see(page, "drift, final 10%")


def test_cancel_stops_a_long_run(page, server):
    # reference fidelity at a light particle: seconds of work, cancelled at once
    _open(page, server + "?la=2.8&lm=-4.5&fidelity=reference")
    page.locator("button", has_text="Run selected scene").click()
    _see(page, "Running")
    page.locator("button", has_text="Cancel").click()
    _see(page, "Run cancelled.")


def test_a_link_runs_its_scene(page, server):
    # the README: a shared link reopens the scene; opening it runs it
    _open(page, server + "?la=2.5&lm=0&model=deformable&fidelity=preview")
    inputs = page.locator("input[type=text], input:not([type])")
    values = [inputs.nth(i).input_value() for i in range(inputs.count())]
    assert "2.5" in values and "0" in values
    _summary_text(page).wait_for(timeout=budget_ms(60))
    _see(page, "A* = 316.2")


def test_bad_url_shows_a_message(page, server):
    _open(page, server + "?la=abc&mu=7&model=rigid")
    _see(page, "URL parameter 'la' (log_amplitude) must be a number in [-6.0, 6.0]")
    _see(page, "URL parameter 'model' (model) must be one of deformable, point-mass")
    # and the defaults are in place
    values = [i.input_value() for i in page.locator("input").all()]
    assert "-0.3" in values


@pytest.mark.parametrize("query", ["la=%C2%B2", "la=1%E2%81%B9", "x=%C2%B2"])
def test_other_script_digits_in_a_link_are_a_message_not_a_500(page, server, query):
    # Panel's own query parser raised on them ('²'.isdigit() is true): a 500 page
    response = page.goto(server + "?" + query)
    assert response.status == 200
    page.wait_for_selector("canvas", timeout=budget_ms(60))
    if query.startswith("la="):
        _see(page, "URL parameter 'la' (log_amplitude) must be a number in [-6.0, 6.0]")


def test_a_scene_outside_the_map_runs_and_says_where_it_is(page, server):
    # lithium niobate at 10 MHz, 1 nm, a 10 um silica particle: A* = 1820
    # log10 A* = 3.26, beyond the map's 3
    _open(page, server + "?la=3.26&lm=-1&fidelity=preview")
    _summary_text(page).wait_for(timeout=budget_ms(60))
    _see(page, "A* = 1820")
    _see(page, "lies outside the map")


@pytest.mark.parametrize(
    "typed, shown",
    [
        ("99", "got '99'"),
        ("-10", "got '-10'"),
        ("1e400", "got '1e400'"),
        ("abc", "got 'abc'"),
        ("", "the field is empty"),
    ],
)
def test_a_bad_number_is_a_message_and_nothing_runs(page, server, typed, shown):
    _open(page, server)
    field = page.locator(".vt-field-log_amplitude input")
    field.fill(typed)
    field.press("Enter")
    _see(page, f"log10 A* must be a number in [-6.0, 6.0]; {shown}")
    page.locator("button", has_text="Run selected scene").click()
    _see(page, "Not run: log10 A* must be")
    # corrected, the message goes and the value is used
    field.fill("0.5")
    field.press("Enter")
    page.locator("button", has_text="Run selected scene").click()
    _summary_text(page).wait_for(timeout=budget_ms(60))
    _see(page, "A* = 3.162")


def test_units_view_moves_the_marker(page, server):
    _open(page, server)
    page.get_by_text("Units", exact=True).first.click()
    _see(page, "Rayleigh speed c_R")
    field = page.locator(".vt-field-frequency input").first
    field.fill("250e3")
    field.press("Enter")
    # m* grows as f^2: 1.08e5 Hz -> 2.5e5 Hz moves the marker up by log10(5.36) = 0.73
    _see(page, "(log10 0.7")
    # a bad value is a message beside the field, not a silent revert
    field.fill("-5")
    field.press("Enter")
    _see(page, "frequency (Hz) must be a number in")


def test_a_device_runs_with_its_own_material_and_si_units(page, server):
    # lithium niobate at 10 MHz, 1 nm, a 10 um silica particle (for which
    # A* = 1820; with the glass here A* = 1700), beyond the map; the run uses
    # the device's theta (1.2001) and nu (0.25), and the SI row is this device's
    _open(page, server + "?fidelity=preview")
    page.get_by_text("Units", exact=True).first.click()
    _see(page, "Rayleigh speed c_R")
    page.locator(".vt-substrate select").first.select_option("lithium niobate")
    page.locator(".vt-particle select").first.select_option("glass")  # silica
    for key, value in (("radius", "1e-5"), ("frequency", "1e7"), ("amplitude", "1e-9")):
        f = page.locator(f".vt-field-{key} input").first
        f.fill(value)
        f.press("Enter")
    _see(page, "outside the map (the scene runs all the same)")
    page.locator("button", has_text="Run this device's scene").click()
    _summary_text(page).wait_for(timeout=budget_ms(120))
    _see(page, "(the maps: 1.2, 0.3)")
    # the drift and the run's length in SI units (time in seconds)
    _see(page, "periods, lasts")
    _see(page, "(the device of the Units and Design tabs)")


def test_teaching_view_and_export(page, server):
    _open(page, server)
    # the page opens on paper point 1's scene, not run: the paper-points
    # selector names no point; picking 1 runs it
    select = page.locator("select").filter(has_text="synchronous hopping")
    assert select.input_value() == select.locator("option", has_text="choose a paper point").get_attribute(
        "value"
    )
    select.select_option(label=select.locator("option", has_text="1: contact, drift -x").text_content())
    _summary_text(page).wait_for(timeout=budget_ms(60))
    # the memory tab computes the run's last period when opened (app/views/memory.py)
    page.get_by_text("Memory diagram", exact=True).click()
    # a snapshot drawn: the diagram's title names its time
    page.wait_for_function(
        """() => (page_figures => page_figures.some(
        f => f[0].startsWith("memory diagram w(h)\\nt* = ")))((%s)())"""
        % _FIGURES_JS,
        timeout=budget_ms(60),
        polling=250,
    )
    page.get_by_text("Downloads", exact=True).click()
    for kind in ("trajectory-png", "map-svg"):
        with page.expect_download(timeout=budget_ms(120)) as dl:
            page.locator(f".vt-export-{kind}").locator("button, a").first.click()
        path = dl.value.path()
        size = os.path.getsize(path)
        assert size > 10_000, (kind, size)
        head = open(path, "rb").read(8)
        assert head.startswith(b"\x89PNG") if kind.endswith("png") else b"<" in head


def test_data_downloads(page, server):
    _open(page, server + "?la=2.5&lm=0&fidelity=preview")
    _summary_text(page).wait_for(timeout=budget_ms(60))
    page.get_by_text("Downloads", exact=True).click()
    for cls, check in (
        (".vt-data-run-csv", lambda b: b.startswith(b"# vibtrans run")),
        (".vt-data-run-nc", lambda b: b[:3] == b"CDF" or b[:4] == b"\x89HDF"),
        (".vt-data-map-window-nc", lambda b: b[:3] == b"CDF" or b[:4] == b"\x89HDF"),
    ):
        with page.expect_download(timeout=budget_ms(60)) as dl:
            page.locator(cls).locator("button, a").first.click()
        body = open(dl.value.path(), "rb").read()
        assert check(body), (cls, body[:40])


def test_the_introduction_opens_and_explains(page, server):
    _open(page, server)
    page.get_by_text("What is this? (a short introduction)").first.click()
    _see(page, "The wave travels towards")
    _see(page, "the motion is")


_FRAME_JS = """() => { for (const doc of window.Bokeh.documents) {
  const s = doc.get_model_by_name("anim-frame"); if (s) return s.value; } return null; }"""


def test_the_animation_tab_plays_the_run(page, server):
    """The particle on the wave, in the explorer: the Animation
    tab shows the last run's final periods and plays them in the browser."""
    _open(page, server + "?la=0.3&lm=-2&fidelity=preview&compare=none")
    _summary_text(page).wait_for(timeout=budget_ms(60))
    page.get_by_text("Animation", exact=True).click()
    page.wait_for_function(f"({_FRAME_JS})() !== null", timeout=budget_ms(60))
    page.get_by_role("button", name="Play").click()
    page.wait_for_function(f"({_FRAME_JS})() > 0", timeout=budget_ms(10), polling=100)
    page.get_by_role("button", name="Pause").click()


_ACK_JS = """() => { let shown = false;
  const visit = (root) => { for (const el of root.querySelectorAll("*")) {
    if (el.shadowRoot) visit(el.shadowRoot);
    if (el.classList.contains("vt-busy")) shown = true; } };
  visit(document); return shown; }"""

# Counts the acknowledgements the browser shows (the server only ever clears
# the Div): on a warm server the answer can clear one before a check by
# evaluate() comes back, so each action is judged by this count rising.
_COUNT_ACKS_JS = """() => { window.vtAcks = 0;
  const ack = [...window.Bokeh.documents[0].all_models].find(
    (m) => (m.css_classes || []).includes("vt-ack"));
  ack.properties.text.change.connect(() => {
    if (ack.text.includes("vt-busy")) window.vtAcks += 1; }); }"""


def _acknowledged(page, action):
    """Run `action` (a click, a choice); True if the browser showed an
    acknowledgement meanwhile (only the page's listener shows one: the
    server's answers clear it)."""
    before = page.evaluate("() => window.vtAcks")
    action()
    return page.evaluate("() => window.vtAcks") > before


def test_a_click_is_acknowledged_at_once_and_cleared_by_the_answer(page, server):
    """A busy indicator on every action over 0.3 s.  The browser
    shows "Running ..." at the click itself (no round trip to the server),
    and the server's answer clears it; the same for a map redraw."""
    _open(page, server + "?fidelity=preview&compare=none")
    page.evaluate(_COUNT_ACKS_JS)
    box = page.locator("canvas").first.bounding_box()
    assert _acknowledged(
        page, lambda: page.mouse.click(box["x"] + box["width"] * 0.55, box["y"] + box["height"] * 0.35)
    )
    _summary_text(page).wait_for(timeout=budget_ms(60))
    page.wait_for_function(f"() => !({_ACK_JS})()", timeout=budget_ms(30))
    assert _acknowledged(page, page.get_by_role("button", name="colour", exact=True).click)
    page.wait_for_function(f"() => !({_ACK_JS})()", timeout=budget_ms(30))
    # the run button, a paper point, a download: each acknowledged at once
    # (one listener for the page: its cost per page)
    assert _acknowledged(page, page.locator("button", has_text="Run selected scene").click)
    page.wait_for_function(f"() => !({_ACK_JS})()", timeout=budget_ms(60))
    select = page.locator("select").filter(has_text="synchronous hopping")
    assert _acknowledged(page, lambda: select.select_option(label="3: contact, no drift"))
    page.wait_for_function(f"() => !({_ACK_JS})()", timeout=budget_ms(60))
    page.get_by_text("Downloads", exact=True).click()
    with page.expect_download(timeout=budget_ms(60)):
        assert _acknowledged(page, page.locator(".vt-data-run-csv").locator("button, a").first.click)
    page.wait_for_function(f"() => !({_ACK_JS})()", timeout=budget_ms(30))
