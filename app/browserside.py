"""What the explorer's page does in the browser by itself, without a round
trip to a busy server: it acknowledges a user's action at once, and sizes
the page for presentation mode."""
import json

from bokeh.models import CustomJS

from .presentation import PRESENTATION_SCALE, SIDEBAR_WIDTH

# An action's acknowledgement, shown by the browser at the click (not after a
# round trip to a busy server) and cleared by the server when it answers:
# a busy indicator within 0.3 s for every action that takes longer.
ACK_RUN, ACK_DRAW, ACK_FILE = "Running ...", "Drawing the map ...", "Preparing the file ..."
# a widget's CSS class -> what the browser says when the user acts on it
ACK_CLASSES = {"vt-ack-run": ACK_RUN, "vt-ack-draw": ACK_DRAW, "vt-ack-file": ACK_FILE}


def ack_js(ack, text):
    """A CustomJS that shows `text` in the Div `ack` (class vt-busy)."""
    return CustomJS(args={"ack": ack}, code=f"ack.text = '<p class=\"vt-busy\">{text}</p>'")


# One listener for the whole page, not a callback per widget: Panel's
# (jscallback, js_on_click) made it walk every model of every page for its
# links (~15 ms of the event loop per page, `python -m devtools.pagecost`).
# It sees the browser's own changes only (`sync`: not the server's).
_ACK_LISTENER = """
const texts = %s, SCALE = %s, SIDEBAR = %s;
const actions = new Set(["value", "value_throttled", "active", "clicks"]);
const said = (model) => {
  for (const c of (model && model.css_classes) || []) if (c in texts) return texts[c];
  return null;
};
// presentation mode (the toggle of class vt-presentation): the root font
// size, which Bootstrap's rem-sized buttons and inputs follow, and the
// sidebar's width (the template's --sidebar-width)
const present = (on) => {
  const root = document.documentElement.style;
  if (on) {
    root.fontSize = `${100 * SCALE}%%`;
    root.setProperty("--sidebar-width", `${Math.round(SIDEBAR * SCALE)}px`);
  } else {
    root.fontSize = "";
    root.removeProperty("--sidebar-width");
  }
};
ack.document.on_change((e) => {
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
    ack.text = `<p class="vt-busy">${text}</p>`;
});
"""


def ack_listener(ack):
    """A CustomJS, run once the page is ready, that shows in the Div `ack`
    what the browser is doing (ACK_CLASSES) at every action of the user on
    a widget of one of those classes: a click, a choice, a slider's step;
    and sets the page's root sizes when presentation mode is switched."""
    return CustomJS(args={"ack": ack}, code=_ACK_LISTENER % (
        json.dumps(ACK_CLASSES), PRESENTATION_SCALE, SIDEBAR_WIDTH))
