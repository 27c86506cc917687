"""The browser twin of tests/app/test_explorer_state.py: a seeded
random walk of a few hundred steps in chromium (map clicks, typed values
valid and invalid, mu, model and paper-point choices, Run), checking after
each step, from the page's DOM and its Bokeh documents, that the URL, the
fields, the selectors, the map's marker and the run's heading show one
scene; and that the server logged no error meanwhile (a failed callback,
Bokeh's `_pending_writes`).  STEPS and SEED: VIBTRANS_TWIN_STEPS,
VIBTRANS_TWIN_SEED."""

import json
import os
import random
import time
from urllib.parse import parse_qs

import pytest
from browserpages import DEEP_JS, changed, frames, new_page, open_explorer, read, settle
from budget import budget, budget_ms
from playwright.sync_api import TimeoutError as PageTimeout

from devtools.chromium import launched
from vibtrans.core.params import PAPER_POINTS
from vibtrans_explorer.views.scene import CHOOSE_POINT

pytestmark = pytest.mark.browser

STEPS = int(os.environ.get("VIBTRANS_TWIN_STEPS", 200))
SEED = int(os.environ.get("VIBTRANS_TWIN_SEED", 32))
SETTLE_S = 15.0  # the longest a step's answer may take, idle (scaled by budget())
SERVER_ERRORS = ("Traceback", "ERROR", "_pending_writes")

# the page's view of the scene: URL, fields, selectors, marker sources, heading
_PAGE_JS = (
    "() => {"
    + DEEP_JS
    + """
  // Panel's widgets live in shadow roots: a selector "A B" is looked up as
  // an element of class A, then B inside it (through shadow roots)
  const all = vtDeep;
  const find = (sel) => {
    const [outer, inner] = sel.split(" ");
    for (const e of all(document)) if (e.matches(outer)) {
      const roots = [e, ...(e.shadowRoot ? [e.shadowRoot] : [])];
      for (const r of roots) for (const c of all(r)) if (c.matches(inner)) return c;
    }
    return null;
  };
  const value = (sel) => { const e = find(sel); return e ? e.value : null; };
  const shown = (sel) => { const e = find(sel + " div");
                           return !!(e && e.textContent.trim()); };
  const selected = (sel) => { const e = find(sel);
                              return e && e.selectedIndex >= 0 ? e.options[e.selectedIndex].text
                                                               : null; };
  const sources = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    const d = m.data;
    if (d == null || typeof d !== "object" || m.selected === undefined) continue;
    const get = (k) => d instanceof Map ? d.get(k) : d[k];
    const keys = (d instanceof Map ? [...d.keys()] : Object.keys(d)).sort().join(",");
    if (keys === "x,y" && get("x").length === 1)
      sources.push([Number(get("x")[0]), Number(get("y")[0])]);
  }
  const summary = [...document.querySelectorAll("*")].find(
    e => e.children.length < 50 && /^\\S+: A\\* = /.test(e.textContent.trim()));
  return {search: window.location.search, la: value(".vt-field-log_amplitude input"),
          lm: value(".vt-field-log_mass input"),
          la_error: shown(".vt-error-log_amplitude"), lm_error: shown(".vt-error-log_mass"),
          mu: selected(".vt-mu select"), points: selected(".vt-paper-points select"),
          sources: sources, ack: (all(document).find(e => e.matches(".vt-busy")) || {}).textContent || ""};
}"""
)


def _query(search):
    q = parse_qs(search.lstrip("?"))
    return {k: v[0] for k, v in q.items()}


def _consistent(page_state):
    """The page's scene, read from its DOM, in agreement (None) or what
    disagrees (a string)."""
    q = _query(page_state["search"])
    if not {"la", "lm", "mu", "model"} <= set(q):
        return f"not the page's URL (yet): {page_state['search']!r}"
    la, lm, mu, model = float(q["la"]), float(q["lm"]), float(q["mu"]), q["model"]
    for name, value, error in (("la", la, "la_error"), ("lm", lm, "lm_error")):
        text = page_state[name]
        if page_state[error]:
            continue  # an invalid text, said under the field
        try:
            if float(text) != value:
                return f"field {name} {text!r} != URL {value!r}"
        except (TypeError, ValueError):
            return f"field {name} {text!r} is no number and has no message"
    if page_state["mu"] is None or float(page_state["mu"]) != mu:
        return f"mu selector {page_state['mu']!r} != URL {mu!r}"
    if [la, lm] not in [list(s) for s in page_state["sources"]]:
        return f"no marker at the URL's ({la}, {lm}): {page_state['sources']}"
    point = next((k for k, p in PAPER_POINTS.items() if p == (la, lm, model)), 0)
    shown = page_state["points"] or CHOOSE_POINT
    if (point == 0) != (shown == CHOOSE_POINT) or (point and not shown.startswith(f"{point}:")):
        return f"paper points shows {shown!r}, the scene is point {point}"
    return None


def _settled(page, deadline):
    """Wait until the page's scene agrees everywhere; its state then."""
    text = read(page, _PAGE_JS)
    while True:
        got = json.loads(text)
        problem = f"the server has not answered ({got['ack']!r} shown)" if got["ack"] else _consistent(got)
        if problem is None:
            return got
        left = deadline - time.monotonic()
        try:
            # the page's next change (an answer of the server's arriving)
            text = changed(page, _PAGE_JS, text, timeout_ms=max(left, 0.001) * 1000)
        except PageTimeout:
            raise AssertionError(f"the page disagrees with itself: {problem}") from None


def _map_box(page):
    """The map's canvas on screen now: a model or mu change redraws the map,
    so the canvas found may be replaced before its box is read: look again."""
    canvas = page.locator(".vt-map canvas >> visible=true").first
    deadline = time.monotonic() + budget(60)
    while time.monotonic() < deadline:
        canvas.wait_for(timeout=budget_ms(60))
        box = canvas.bounding_box()
        if box is not None and box["width"] > 0:
            return box
        frames(page)  # laid out again
    raise AssertionError("the map's canvas was never on screen for a click")


def test_a_random_walk_keeps_one_scene(served_explorer):
    rng = random.Random(SEED)
    log_start = len(served_explorer.text())
    with launched() as browser:
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        # a link with a mu no shipped map has: shown as it is
        page.goto(served_explorer.url + "?la=0.5&lm=1&mu=0.5&fidelity=preview&compare=none")
        page.wait_for_selector("canvas", timeout=budget_ms(60))
        page.wait_for_selector(".vt-paper-points select", timeout=budget_ms(60))
        got = _settled(page, time.monotonic() + budget(60))
        assert float(_query(got["search"])["mu"]) == 0.5 and got["mu"] == "0.5"
        page.locator(".vt-mu select").select_option("0.3")
        _settled(page, time.monotonic() + budget(60))
        done = []
        for _ in range(STEPS):
            kind = rng.choice(["click", "click", "type", "type", "bad", "mu", "model", "point", "run"])
            if kind == "click":
                box = _map_box(page)
                page.mouse.click(
                    box["x"] + box["width"] * rng.uniform(0.25, 0.75),
                    box["y"] + box["height"] * rng.uniform(0.25, 0.75),
                )
            elif kind in ("type", "bad"):
                name = rng.choice(["log_amplitude", "log_mass"])
                text = (
                    f"{rng.uniform(-1, 2):.3f}"
                    if kind == "type"
                    else rng.choice(["abc", "", "99", "1e400", "nan"])
                )
                field = page.locator(f".vt-field-{name} input")
                field.fill(text)
                field.press("Enter")
            elif kind == "mu":
                options = page.locator(".vt-mu select option").all_text_contents()
                page.locator(".vt-mu select").select_option(rng.choice(options))
            elif kind == "model":
                page.locator(
                    ".vt-ack-draw button", has_text=rng.choice(["deformable", "point-mass"])
                ).first.click()
            elif kind == "point":
                labels = page.locator(".vt-paper-points select option").all_text_contents()
                page.locator(".vt-paper-points select").select_option(label=rng.choice(labels[1:]))
            else:
                page.locator("button", has_text="Run selected scene").click()
            done.append(kind)
            # no wait first: the browser shows its acknowledgement of each
            # action at once (typed values: the field disagrees with the URL)
            # until the server's answer, which _settled waits for
            _settled(page, time.monotonic() + budget(SETTLE_S))
        page.close()
    assert not errors, errors
    log = served_explorer.text()[log_start:]
    lines = log.splitlines()
    bad = [k for k, line in enumerate(lines) if any(e in line for e in SERVER_ERRORS)]
    # each error with the lines after it: the traceback whole
    assert not bad, "\n---\n".join("\n".join(lines[k : k + 40]) for k in bad[:3])
    assert len(done) == STEPS


# ------------------------------------------------------------------ the browser's history
def _at(page, la):
    """Wait until the page's address names log10 A* = `la` and the page
    agrees with it everywhere (fields, selectors, marker); its state."""
    deadline = time.monotonic() + budget(60)
    got = _settled(page, deadline)
    while float(_query(got["search"])["la"]) != la:
        assert time.monotonic() < deadline, f"the address stays at {got['search']!r}"
        page.wait_for_function(
            "(s) => window.location.search !== s", arg=got["search"], timeout=budget_ms(60)
        )
        got = _settled(page, deadline)
    return got


def _shows_run(page, amplitude):
    """Wait until the summary is of a run at A* = `amplitude` (its heading)
    and no stale note says the form has changed since."""
    page.locator("strong", has_text=f"A* = {amplitude}, m* = ").first.wait_for(timeout=budget_ms(120))
    page.locator(".vt-stale").first.wait_for(state="hidden", timeout=budget_ms(30))


def test_back_forward_and_reload_restore_the_scene_of_the_address(browser, served_explorer):
    """The browser's Back and Forward reach the page's earlier and later
    addresses: the form, the map's marker, the paper points and the run
    shown follow the address (Panel's Location changed the address alone:
    Back showed la=-0.3 over a form and a run at 0.5); a reload keeps the
    scene the address names."""
    page, errors = new_page(browser, 1280, 800)
    open_explorer(page, served_explorer.url + "?la=-0.3&lm=1&fidelity=preview&compare=none")
    _at(page, -0.3)
    _shows_run(page, "0.5012")  # scene A, run by its link
    field = page.locator(".vt-field-log_amplitude input")
    field.fill("0.5")
    field.press("Enter")
    _at(page, 0.5)
    page.locator("button", has_text="Run selected scene").click()
    _shows_run(page, "3.162")  # scene B
    entries = page.evaluate("() => history.length")
    page.go_back()
    a = _at(page, -0.3)
    _shows_run(page, "0.5012")
    assert a["la"] == "-0.3" and page.evaluate("() => history.length") == entries
    page.go_forward()
    b = _at(page, 0.5)
    _shows_run(page, "3.162")
    page.reload()
    page.wait_for_selector("canvas", timeout=budget_ms(60))
    assert _at(page, 0.5)["search"] == b["search"]
    _shows_run(page, "3.162")
    page.close()
    assert not errors, errors


def test_a_link_with_an_error_stays_in_the_address_until_a_change(browser, served_explorer):
    """A link with an error is kept in the address while its message shows
    (it was rewritten to the defaults at once: the user could not see what
    was wrong in it); the first change writes the state's address."""
    page, errors = new_page(browser, 1280, 800)
    open_explorer(page, served_explorer.url + "?la=abc&mu=0.3")
    page.get_by_text("URL parameter 'la' (log_amplitude) must be").first.wait_for(timeout=budget_ms(60))
    # a round trip to the server after the page connected (its text added
    # when the introduction first opens): any rewrite of the address is in
    page.get_by_text("What is this? (a short introduction)").first.click()
    page.get_by_text("The wave travels towards").first.wait_for(timeout=budget_ms(30))
    settle(page)
    assert page.evaluate("() => window.location.search") == "?la=abc&mu=0.3"
    page.locator(".vt-mu select").select_option("0.1")
    page.wait_for_function("() => window.location.search.includes('mu=0.1')", timeout=budget_ms(60))
    # (the page has run nothing: its paper-point list names none, which the
    # random walk's agreement check would take for point 1's disagreement)
    search = page.evaluate("() => window.location.search")
    assert "la=abc" not in search and float(_query(search)["la"]) == -0.3
    page.close()
    assert not errors, errors
