"""What the browser tests share: a page of a screen's size whose JavaScript
errors are collected, and the explorer opened in it.  Waits are on page events
(a selector, a text); their time limits are budgets scaled to the machine
(tests/budget.py), so a busy machine gets longer before a hang fails."""

import re

from budget import budget_ms


def new_page(browser, width, height):
    """(page of width x height, the list its page errors are appended to)."""
    page = browser.new_page(viewport={"width": width, "height": height})
    page.set_default_timeout(budget_ms(30))  # Playwright's own default, scaled
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    return page, errors


# every Bokeh document of the page has rendered its roots (BokehJS's
# Document.is_idle: true once each root's views are first drawn)
_IDLE_JS = (
    "() => window.Bokeh !== undefined && window.Bokeh.documents.length > 0 "
    "&& window.Bokeh.documents.every((d) => d.is_idle)"
)
# two animation frames: the browser has laid out and painted what was drawn
_FRAMES_JS = "() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))"
# the page's fonts loaded (text laid out in its own font)
_FONTS_JS = "() => document.fonts.ready.then(() => true)"
# what a layout change moves: the document's scroll size and the box of each
# figure (BokehJS's view of each plot)
BOXES_JS = """() => {
  const out = [document.scrollingElement.scrollWidth, document.scrollingElement.scrollHeight];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.x_range === undefined || m.renderers === undefined) continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v) continue;
    const r = v.el.getBoundingClientRect();
    out.push(m.id, r.left, r.top, r.width, r.height);
  }
  return out;
}"""


# the page's acknowledgement of an action (app/views/browserside.py: shown by
# the browser at the action, a `.vt-busy` line, cleared by the server after
# its answer's changes) is not shown
_ANSWERED_JS = """() => {
  const visit = (root) => {
    for (const e of root.querySelectorAll("*")) {
      if (e.classList.contains("vt-busy") && e.textContent.trim()) return false;
      if (e.shadowRoot && !visit(e.shadowRoot)) return false;
    }
    return true;
  };
  return visit(document);
}"""


def answered(page, timeout_s=60):
    """Wait until the server has answered the last acknowledged action (a
    run, a map redraw, a file: the page's acknowledgement line is cleared
    after the answer's changes)."""
    page.wait_for_function(_ANSWERED_JS, timeout=budget_ms(timeout_s), polling=50)


def frames(page):
    """Wait for two animation frames: the browser has laid out and painted
    what it was given."""
    page.evaluate(_FRAMES_JS)


def settle(page, timeout_s=60):
    """Wait until the page's Bokeh documents have rendered (is_idle) and
    its fonts have loaded, then for two animation frames (layout and
    paint, e.g. after a resize)."""
    page.wait_for_function(_IDLE_JS, timeout=budget_ms(timeout_s))
    page.evaluate(_FONTS_JS)
    page.evaluate(_FRAMES_JS)


def steady(page, what_js=BOXES_JS, still_frames=5, timeout_s=60):
    """`settle`, then wait until the page stays put: `what_js` (a page
    function; default BOXES_JS, the figures' boxes and the scroll size)
    returns the same for `still_frames` animation frames in a row (a CSS
    transition, a resize or a layout pass has ended)."""
    settle(page, timeout_s)
    page.evaluate("() => { window.__vtSteady = null; }")
    page.wait_for_function(
        f"""() => {{
      const now = JSON.stringify(({what_js})());
      const s = window.__vtSteady;
      if (s && s.last === now) s.same += 1; else window.__vtSteady = {{last: now, same: 0}};
      return window.__vtSteady.same >= {int(still_frames)};
    }}""",
        timeout=budget_ms(timeout_s),
    )  # evaluated at every animation frame


def changed(page, what_js, last, timeout_ms, polling=100):
    """Wait until the page function `what_js` returns something other than
    `last` (JSON text, as `read` gives it): the next change of what it
    reads; returns the new value as JSON text.  Checked every `polling` ms."""
    handle = page.wait_for_function(
        f"(last) => {{ const now = JSON.stringify(({what_js})()); return now !== last && now; }}",
        arg=last,
        timeout=timeout_ms,
        polling=polling,
    )
    return handle.json_value()


def read(page, what_js):
    """The page function `what_js`'s value as JSON text (for `changed`)."""
    return page.evaluate(f"() => JSON.stringify(({what_js})())")


def open_explorer(page, url):
    """Load the explorer at `url` and wait for its map and its controls."""
    page.goto(url)
    page.wait_for_selector("canvas", timeout=budget_ms(60))
    page.get_by_text("Paper points").first.wait_for(timeout=budget_ms(60))


# The page's text as a user reads it: its text nodes, those in shadow roots
# too (Panel's panes and widgets draw inside them), but not its scripts' or
# styles'; `DEEP_JS` defines vtDeep(root) (every element, shadow roots
# entered) and vtText(element) (its text and its shadow root's).
DEEP_JS = """
const vtDeep = (root, out = []) => {
  for (const e of root.querySelectorAll("*")) {
    out.push(e);
    if (e.shadowRoot) vtDeep(e.shadowRoot, out);
  }
  return out;
};
const vtText = (root) => {
  const out = [];
  const walk = (r) => {
    const it = document.createTreeWalker(r, NodeFilter.SHOW_TEXT);
    for (let n = it.nextNode(); n; n = it.nextNode()) {
      const tag = n.parentNode ? n.parentNode.nodeName : "";
      if (tag !== "SCRIPT" && tag !== "STYLE") out.push(n.nodeValue);
    }
    if (r.shadowRoot) walk(r.shadowRoot);
    for (const e of r.querySelectorAll("*")) if (e.shadowRoot) walk(e.shadowRoot);
  };
  walk(root);
  return out.join(" ");
};
"""


def page_text(page):
    """Everything the page shows as text (`DEEP_JS`'s vtText of its body)."""
    return page.evaluate(f"() => {{ {DEEP_JS} return vtText(document.body); }}")


# the text of the shown elements of a CSS class (a field's message under it)
SHOWN_TEXT_JS = (
    "(cls) => {"
    + DEEP_JS
    + """
  return vtDeep(document).filter((e) => e.classList.contains(cls) && e.getClientRects().length > 0)
    .map((e) => vtText(e)).join(" ").trim();
}"""
)


def shown_text(page, css_class):
    """The text of the shown elements of class `css_class` ("" if none)."""
    return page.evaluate(SHOWN_TEXT_JS, css_class)


# A text field's last text has reached the server: every model of its CSS
# class has its value in its tags (app/views/inputs.read_back: the server
# writes there the text it read, or the one it wrote).
_READ_BACK_JS = """(cls) => {
  let found = false;
  for (const d of window.Bokeh.documents) for (const m of d.all_models)
    if ((m.css_classes || []).includes(cls) && m.tags !== undefined && "value" in m) {
      found = true;
      if (m.tags.length === 0 || m.tags[0] !== m.value) return false;
    }
  return found;
}"""


def read_back(page, css_class, timeout_s=30):
    """Wait until the server has read the text of the field(s) of class
    `css_class` (`_READ_BACK_JS`): it has handled what was typed and
    committed there, and what the page sent before (in the order sent); its
    answer (the value applied, a message) may come a message later."""
    page.wait_for_function(_READ_BACK_JS, arg=css_class, timeout=budget_ms(timeout_s), polling=50)


# what the server's log says when something failed (a traceback, a failed
# callback, Bokeh's write outside the document's lock)
SERVER_ERRORS = ("Traceback", "ERROR", "Exception", "_pending_writes")


# Bokeh's keep-alive race (docs/how-to/deployment.md 2.3): a page closing as
# a ping is sent; Bokeh's failure, not the explorer's, and nothing is lost
KEEP_ALIVE_RACE = ("in on_close", "assert self._session is not None")


def small_chart_offer(page, draw, **fields):
    """On the Design tab: a 3 x 3 chart over 1e5-1.2e5 Hz and 1e-8-1.2e-8 m (with `fields`
    typed first), Draw pressed: the map-on-demand offer's pane."""
    for name, value in (
        *fields.items(),
        ("x_lo", "1e5"),
        ("x_hi", "1.2e5"),
        ("x_points", "3"),
        ("y_lo", "1e-8"),
        ("y_hi", "1.2e-8"),
        ("y_points", "3"),
    ):
        field = page.locator(f".vt-design-fields .vt-field-{name} input").first
        field.fill(value)
        field.press("Enter")
        read_back(page, f"vt-field-{name}")  # (applied before Draw reads it)
    draw.click()
    return page.locator(".vt-design-offer").first


def _keep_alive_race(block):
    """Does the traceback that starts `block` (lines) end in Bokeh's
    keep-alive race: an AssertionError, raised in on_close?"""
    end = next((i for i, line in enumerate(block) if re.match(r"\w+(Error|Exception)\b", line)), None)
    return (
        end is not None
        and block[end].startswith("AssertionError")
        and all(any(s in line for line in block[:end]) for s in KEEP_ALIVE_RACE)
    )


def server_errors(log, lines_after=40):
    """The failures in the server's log text `log`: each line with one of
    SERVER_ERRORS and the lines after it (a traceback whole), "" if none;
    Bokeh's keep-alive race is not the explorer's failure."""
    lines = log.splitlines()
    bad = [k for k, line in enumerate(lines) if any(e in line for e in SERVER_ERRORS)]
    bad = [k for k in bad if not _keep_alive_race(lines[k : k + lines_after])]
    return "\n---\n".join("\n".join(lines[k : k + lines_after]) for k in bad[:3])
