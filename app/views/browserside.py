"""What the explorer's page does in the browser by itself, without a round
trip to a busy server: it acknowledges a user's action at once, sizes
the page for presentation mode, and keeps the page's address in the
browser's history (`BrowserAddress`)."""

import html
import json

import param
from bokeh.models import CustomJS
from panel.custom import JSComponent

from vibtrans_explorer.views.presentation import (
    PRESENTATION_SCALE,
    PRESENTATION_SIDEBAR_VW,
    SIDEBAR_WIDTH,
)

# An action's acknowledgement, shown by the browser at the click (not after a
# round trip to a busy server) and cleared by the server when it answers:
# a busy indicator within 0.3 s for every action that takes longer.
ACK_RUN, ACK_DRAW, ACK_FILE = "Running ...", "Drawing the map ...", "Preparing the file ..."
# a widget's CSS class -> what the browser says when the user acts on it
ACK_CLASSES = {"vt-ack-run": ACK_RUN, "vt-ack-draw": ACK_DRAW, "vt-ack-file": ACK_FILE}


# The acknowledgement's pane (`ack_pane`): a Panel HTML pane, not a Bokeh
# Div.  A Div's view re-renders at every change of its text and then lays
# out again every figure of the page's main column (BokehJS's MarkupView:
# `rerender` -> `compute_layout` of the layout root), which cost the browser
# 0.1-0.3 s at every action (twice per map redraw: once when the
# browser shows the acknowledgement, once when the server clears it).
# Panel's HTML view only replaces its own content, and the pane's height is
# fixed, so nothing else moves.  The browser finds the pane's model by its
# CSS class; Panel's HTML model holds its text HTML-escaped (its view
# decodes it), so the browser writes it escaped too.
ACK_CLASS = "vt-ack"
ACK_HEIGHT = 22


def ack_pane():
    """The page's acknowledgement line (empty until an action)."""
    import panel as pn

    return pn.pane.HTML(
        "",
        height=ACK_HEIGHT,
        sizing_mode="stretch_width",
        css_classes=[ACK_CLASS],
        margin=(0, 10),
        styles={"color": "#555", "font-style": "italic"},
    )


def _ack_text(text):
    """The escaped text of the ack pane's model that shows `text` (class vt-busy)."""
    return html.escape(f'<p class="vt-busy">{text}</p>')


# the ack pane's model in the page (its documents' models, by CSS class)
_FIND_ACK = """const vtAck = () => {
  for (const d of window.Bokeh.documents) for (const m of d.all_models)
    if ((m.css_classes || []).includes(%s)) return m;
  return null;
};
""" % json.dumps(ACK_CLASS)


def ack_js(text):
    """A CustomJS that shows `text` in the ack pane (class vt-busy)."""
    return CustomJS(
        code=_FIND_ACK + f"const ack = vtAck();\nif (ack !== null) ack.text = {json.dumps(_ack_text(text))};"
    )


# One listener for the whole page, not a callback per widget: Panel's
# (jscallback, js_on_click) made it walk every model of every page for its
# links (~15 ms of the event loop per page, `python -m devtools.pagecost`).
# It sees the browser's own changes only (`sync`: not the server's).
_ACK_LISTENER = """
const texts = %s, SCALE = %s, SIDEBAR = %s, SIDEBAR_VW = %s;
const ack = vtAck();
const actions = new Set(["value", "value_throttled", "active", "clicks"]);
const said = (model) => {
  for (const c of (model && model.css_classes) || []) if (c in texts) return texts[c];
  return null;
};
// presentation mode (the toggle of class vt-presentation): the root font
// size, which Bootstrap's rem-sized buttons and inputs follow, and the
// sidebar's width (the template's --sidebar-width), at most a share of
// the screen's
const present = (on) => {
  const root = document.documentElement.style;
  if (on) {
    root.fontSize = `${100 * SCALE}%%`;
    root.setProperty("--sidebar-width", `min(${Math.round(SIDEBAR * SCALE)}px, ${SIDEBAR_VW}vw)`);
  } else {
    root.fontSize = "";
    root.removeProperty("--sidebar-width");
  }
};
if (ack !== null) ack.document.on_change((e) => {
  let model = null;
  if (e.kind === "ModelChanged" && e.sync && e.attr === "active"
      && ((e.model.css_classes || []).includes("vt-presentation")))
    present(e.model.active);
  if (e.kind === "ModelChanged" && e.sync && actions.has(e.attr))
    model = e.model;
  else if (e.kind === "MessageSent" && e.msg_type === "bokeh_event"
           && e.msg_data.event_name === "button_click")
    model = e.msg_data.origin;
  const text = said(model);
  if (text !== null)
    ack.text = text;
});
"""


def ack_listener():
    """A CustomJS, run once the page is ready, that shows in the ack pane
    what the browser is doing (ACK_CLASSES) at every action of the user on
    a widget of one of those classes: a click, a choice, a slider's step;
    and sets the page's root sizes when presentation mode is switched."""
    texts = {c: _ack_text(t) for c, t in ACK_CLASSES.items()}
    return CustomJS(
        code=_FIND_ACK
        + _ACK_LISTENER % (json.dumps(texts), PRESENTATION_SCALE, SIDEBAR_WIDTH, PRESENTATION_SIDEBAR_VW)
    )


# The page's address in the browser's history.  A change of `search` from
# the server is a new entry (pushed unless the address is that already;
# the first one, the link as opened, is replaced); the browser's Back and
# Forward (`popstate`) report the address they reach to the server, which
# restores the scene it names.  Plain ESM, no imports: nothing is loaded
# from another host.
_ADDRESS_ESM = """
export function render({ model }) {
  const go = (replace) => {
    const search = model.search;
    if (!search || search === window.location.search) return;
    const url = window.location.pathname + search + window.location.hash;
    if (replace) window.history.replaceState(window.history.state, "", url);
    else window.history.pushState(null, "", url);
  };
  go(true);
  model.on("search", () => go(false));
  const navigated = () => { model.search = window.location.search; };
  window.addEventListener("popstate", navigated);
  model.on("remove", () => window.removeEventListener("popstate", navigated));
}
"""


class BrowserAddress(JSComponent):
    """The query of the page's address (its link).  Set by the server: the
    browser shows it, as a new entry of its history; set by the browser
    when its Back or Forward reaches another entry of the page (no entry
    added).  Empty: the address as the browser has it.  Takes no room on
    the page."""

    search = param.String(default="", doc="the address's query, '?key=value&...' or empty")

    _esm = _ADDRESS_ESM

    def __init__(self, **params):
        params = {"width": 0, "height": 0, "margin": 0, "sizing_mode": "fixed", **params}
        super().__init__(**params)
