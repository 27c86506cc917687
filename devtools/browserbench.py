"""The explorer's responsiveness as a person sees it, in a real browser:

    python -m devtools.browserbench [--repeats 5] [--url URL] [--json] [--check]
    python -m devtools.browserbench --memory-views N [--url URL] [--json] [--check]

Starts `vibtrans serve` (tests/netutil.py's Served, the test suite's
server) and waits until its kernels are compiled, or uses the running
server at --url; drives Debian's chromium with Playwright (1400 x 1000).
Every repeat opens a new page (so that "first" means first in a session)
and does, in this order:

  map click           click the map (deformable, the default "tau twin"
                      comparison) at two points in turn: until the run's
                      summary and plots are drawn
  memory view         in the "Memory diagram" tab (opened once), a time typed
                      and "Show the memory diagram at t*" clicked (twice):
                      until the diagram of that time is drawn (its title).
                      A failure is reported with what the page showed (the
                      button's box before and at the click, the field, the
                      plots' titles, the probe's record, a screenshot)
  trajectory PNG      the "trajectory .png" export (vt-export-trajectory-png):
                      until the browser receives the download (a PNG)
  map redraw: colour  grey -> colour (chaotic points), and back at the end
  map redraw: mu      0.3 -> 0.1 -> 0.3
  map redraw: model   deformable -> point-mass -> deformable
  first point-mass run  with the point-mass map shown, click it: the first
                      point-mass run of the session (drawn into the
                      deformable run's figures, reconfigured)
  first run after compare  "compare with" -> "point mass", click the map:
                      the first run with that comparison (relabelled figures)

Each time runs from the action (the pointerdown or input event the page
receives, in the page's clock) to the first animation frame at which the
result is drawn: the summary's first line (bold, "... mu = ...") is the new
run's, or the map figure is a new one or shows new data, or a new figure is shown and no
pane is loading; and every Bokeh plot shown has finished painting
(BokehJS's view.has_finished()); the time is taken at the next frame, once
that frame has been painted.
The download: from the click (this process's clock) to Playwright's
download event.  A probe in the page checks the state every animation
frame: it queries the page's shadow roots (found once, then kept by a
MutationObserver) for the few elements it reads.  Its time counts in every
time measured: 0.09 s of the page's main thread per mu change after a run
on the 2-core machine under load (Chrome traces; walking every element of the
page at every frame took 0.16 s).  "server's reply": from the action to the arrival of the last
websocket message before the result was drawn (a listener on the page's
socket); the server's share (with the network's), the rest is the
browser's: building and painting what came.

Busy indicator (--check requires one within 0.3 s of every action that
takes longer than 0.3 s): something the page did not show before the
action and that says "working" where the person looks: the explorer's
acknowledgement of the action (class vt-busy, shown by the browser at the
click, cleared by the server's answer), a pane with Panel's loading spinner
(class pn-loading), a visible progress bar (<progress>), the summary saying
"Running ..." or "Compiling ...", or the clicked button disabled.  Panel's global busy indicator (the spinning
circle in the template's header, class `loader spin` in pn-busy-container)
is reported in its own column but does not count: it is 20 px in a corner
and spins for any server callback, so it does not tell which action is
working.

--memory-views N: instead of the actions above, N memory views
on new pages of 10 (a deformable run, then typed times and clicks on the
slider's track in turn), each until its diagram is drawn; a view not drawn
within 30 s is lost (now and then a typed time's diagram never came) and
its page is replaced.  It reports the views answered and lost, their
median times, and the error lines of its own server's log; --check exits 1
on a lost view or such a line.

Goals, checked against the median of the repeats; --check exits
1 when one is missed: memory view <= 0.5 s, map redraw <= 0.5 s,
trajectory PNG export <= 3 s, first point-mass run <= 1.5 s, first run
after changing the comparison <= 1.5 s.  The warm-up repeat (the first on
a new server: its map renderings and the export's imports happen there)
is reported in its own column and not counted.

Selectors (names, classes and texts of app/explorer.py):
  the map figure      the plot in a Bokeh model named "map" (its tab), else
                      the plot titled "<v*> over ..."; the one shown
  summary             <strong> containing "mu = " (the summary's first line)
  running             a <p> starting "Running " or "Compiling "
  model, chaotic      buttons "deformable", "point-mass", "grey", "colour"
  mu, compare         the selects labelled "mu (shipped maps)", "compare with"
  memory button       the button "Show the memory diagram at t*"
  PNG export          .vt-export-trajectory-png button
  errors              a visible .alert ("run failed", "limit", "Not run")
  page loaded         the map shown, Bokeh's documents idle
  run tabs            texts "Trajectory", "Memory diagram", "Downloads"
  memory time         .vt-field-t input
  memory slider       .vt-memory-slider .noUi-base (its track)
  busy                .vt-busy, .pn-loading, <progress>, disabled <button>; the header's
                      .loader.spin
"""

import argparse
import contextlib
import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from . import results
from .chromium import ARGS, CHROMIUM, served

VIEWPORT = {"width": 1400, "height": 1000}
BUSY_WITHIN_S = 0.3
ACTION_TIMEOUT_S = 120.0

# the explorer's goals (seconds, median of the repeats)
GOALS = {
    "memory view": 0.5,
    "map redraw: colour": 0.5,
    "map redraw: mu": 0.5,
    "map redraw: model": 0.5,
    "trajectory PNG export": 3.0,
    "first point-mass run": 1.5,
    "first run after compare": 1.5,
}
ACTIONS = [
    "map click",
    "memory view",
    "trajectory PNG export",
    "map redraw: colour",
    "map redraw: mu",
    "map redraw: model",
    "first point-mass run",
    "first run after compare",
]

# map points (log10 A*, log10 m*) clicked, inside the shipped maps: a
# chaotic hopping scene, then a permanent contact (the memory diagram's
# case); consecutive runs differ (the summary's first line tells a new run
# from the last one)
CLICKS = [(1.5, -2.0), (1.0, 2.0)]
POINT_MASS_CLICK = (2.5, 4.0)  # the point mass drifting against the wave
COMPARE_CLICK = (0.5, 1.5)

# Before the page's scripts: the arrival time of every websocket message
# (page clock), recorded before Bokeh handles it (a listener added when the
# socket is made runs before the handler Bokeh sets later).
WEBSOCKET_JS = r"""
(() => {
  const Native = window.WebSocket;
  const arrivals = window.__vtArrivals = [];
  window.WebSocket = function (...args) {
    const ws = new Native(...args);
    ws.addEventListener("message", () => {
      arrivals.push(performance.now());
      if (arrivals.length > 5000) arrivals.splice(0, 1000);
    });
    return ws;
  };
  window.WebSocket.prototype = Native.prototype;
  Object.assign(window.WebSocket, Native);
})();
"""

# The probe: window.__vtBench.start(kind, arg) before an action, then
# window.__vtBench.result is {t_action, t_done, t_busy, t_header, t_reply,
# action_by, error} (ms, page clock) once the result is drawn.
PROBE_JS = r"""
(() => {
if (window.__vtBench) return;
const visible = (el) => el.getClientRects().length > 0;
const plots = () => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.x_range !== undefined && m.renderers !== undefined) out.push(m);
  return out;
};
const plotIn = (m) => {     // the first plot in a model (a plot itself, a tab, a layout)
  if (m == null) return null;
  if (m.x_range !== undefined && m.renderers !== undefined) return m;
  for (const c of [m.child, ...(m.children || []), ...(m.tabs || [])]) {
    const p = plotIn(Array.isArray(c) ? c[0] : c);   // a grid's child: [model, row, col]
    if (p) return p;
  }
  return null;
};
// the map's plot on the page: in a model named "map" (its tab), else titled
// "<v*> over ..."; the one whose view is shown (a replaced figure stays among
// the document's models for a while)
const shownView = (m) => {
  const v = window.Bokeh.index.find_one(m);
  return v && visible(v.el) ? v : null;
};
const mapPlot = () => {
  const named = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.name === "map") { const p = plotIn(m); if (p) named.push(p); }
  const titled = plots().filter((m) => m.title && String(m.title.text).startsWith("<v*> over"));
  return [...named, ...titled].find(shownView) || null;
};
// the data objects of a map plot's renderers (replaced when the server sends new data)
const mapData = (m) => m ? m.renderers.map((r) => r.data_source ? r.data_source.data : null) : [];
// every plot shown has painted (BokehJS marks a view finished after its paint)
const allPainted = () => {
  for (const m of plots()) {
    const v = window.Bokeh.index.find_one(m);
    if (v && visible(v.el) && !v.has_finished()) return false;
  }
  return true;
};
// The page's shadow roots (Bokeh's and Panel's views each render into one),
// found once and then as nodes are added (a MutationObserver on each root):
// a walk of every element of the page at every frame cost the page's main
// thread 8-15 ms a frame under load, ~0.1-0.16 s of a map redraw (Chrome
// traces); the scan then queries each root for
// the few elements it reads.  A full walk every FULL_WALK_FRAMES frames
// catches a shadow root attached to an element already in the page (no
// mutation says so; not seen in BokehJS or Panel).
const FULL_WALK_FRAMES = 30;
const roots = new Set([document]);
const adopt = (node) => {
  const visit = (el) => {
    const sr = el.shadowRoot;
    if (sr && !roots.has(sr)) {
      roots.add(sr);
      observer.observe(sr, {childList: true, subtree: true});
      adopt(sr);
    }
  };
  if (node.nodeType === 1) visit(node);
  for (const el of node.querySelectorAll("*")) visit(el);
};
const observer = new MutationObserver((records) => {
  for (const r of records) for (const n of r.addedNodes) if (n.nodeType === 1) adopt(n);
});
observer.observe(document, {childList: true, subtree: true});
adopt(document);
let frames = 0;
const SCANNED = "strong, canvas, progress, p, .pn-loading, .vt-busy, .loader, .alert";
const look = (s, el) => {
  const tag = el.tagName, cl = el.classList;
  if (tag === "STRONG") { if (el.textContent.includes("mu = ")) s.summary = el.textContent; }
  else if (tag === "CANVAS") { if (visible(el)) s.canvases.push(el); }
  else if (tag === "PROGRESS") { if (visible(el)) s.progress = true; }
  else if (tag === "P") {
    const t = el.textContent;
    if (t.startsWith("Running ") || t.startsWith("Compiling ")) s.running = true;
  }
  if (cl.contains("pn-loading") && visible(el)) s.loading += 1;
  if (cl.contains("vt-busy") && visible(el)) s.ack = true;
  if (cl.contains("loader") && cl.contains("spin")) s.header = true;
  if (cl.contains("alert") && visible(el)) s.alert = el.textContent;
};
const fresh = () => ({summary: "", alert: "", loading: 0, progress: false, running: false,
                      ack: false, header: false, canvases: []});
const scan = () => {
  if (++frames % FULL_WALK_FRAMES === 0) adopt(document);
  const s = fresh();
  for (const root of roots) {
    if (root !== document && !root.host.isConnected) continue;
    for (const el of root.querySelectorAll(SCANNED)) look(s, el);
  }
  return s;
};
// the walk of every element (the scan before): `B.check()` compares the two
const fullScan = () => {
  const s = fresh();
  const walk = (root) => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) walk(el.shadowRoot);
      look(s, el);
    }
  };
  walk(document);
  return s;
};
const B = window.__vtBench = {result: null, target: null};
for (const type of ["pointerdown", "input"])
  window.addEventListener(type, (e) => {
    if (B.active && B.active.t_action === null) {
      B.active.t_action = e.timeStamp;
      B.active.action_by = type;
      const el = e.composedPath()[0];
      B.target = el && el.closest ? el.closest("button") : null;
      B.targetDisabled = B.target ? B.target.disabled : false;
    }
  }, true);
B.mapPlot = mapPlot;
B.check = () => {         // the scan and the full walk agree
  const a = scan(), b = fullScan();
  const key = (x) => JSON.stringify({...x, canvases: x.canvases.length});
  return key(a) === key(b) ? null : {scan: key(a), walk: key(b)};
};
// client coordinates of a map point (log10 A*, log10 m*), the map scrolled into view
B.mapPoint = (x, y) => {
  const m = mapPlot();
  const v = m && window.Bokeh.index.find_one(m);
  if (!v) return null;
  v.el.scrollIntoView({block: "nearest"});
  const r = v.canvas_view.el.getBoundingClientRect();
  return [r.left + v.frame.x_scale.compute(x), r.top + v.frame.y_scale.compute(y)];
};
// the titles of the plots in the page
const titles = () => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.x_range !== undefined && m.renderers !== undefined && m.title != null)
      out.push(String(m.title.text));
  return out;
};
B.titles = titles;
B.start = (kind, arg) => {
  const base = scan(), seen = new WeakSet(base.canvases), map = mapPlot();
  const baseTitles = new Set(titles());
  const a = B.active = {kind, arg, t_start: performance.now(), t_action: null, action_by: null,
                        t_done: null, t_busy: null, t_header: null, t_reply: null, error: null,
                        base_map: map ? map.id : null, base_data: mapData(map)};
  B.result = null;
  B.target = null;
  const done = (s) => {
    if (kind === "run") {
      if (/run failed|server's limit|Not run/.test(s.alert)) { a.error = s.alert; return true; }
      return s.summary !== "" && s.summary !== base.summary && !s.running && !s.ack
          && (!arg || s.summary.includes(arg)) && allPainted();
    }
    if (kind === "redraw") {
      const m = mapPlot();
      // a new figure, or the shown one with new data (updated in place)
      const fresh = m !== null && (m.id !== a.base_map
        || mapData(m).some((d, i) => d !== a.base_data[i]));
      return fresh && shownView(m).has_finished() && !s.ack && allPainted();
    }
    if (kind === "figure")       // a new figure shown, no pane loading
      return s.canvases.some((c) => !seen.has(c)) && s.loading === 0 && allPainted();
    if (kind === "title")        // a plot titled `arg...` with a new title, no pane loading
      return titles().some((t) => t.startsWith(arg) && !baseTitles.has(t))
          && s.loading === 0 && allPainted();
    return false;                // "watch": busy only, stopped from outside
  };
  const frame = () => {
    if (B.active !== a) return;
    try { step(); } catch (e) { a.error = `the probe failed: ${e}`; B.result = a; B.active = null; }
  };
  const step = () => {
    const s = scan();
    const t = performance.now();
    if (a.t_action !== null) {
      const busy = s.loading > base.loading || (s.progress && !base.progress) || s.running
        || (s.ack && !base.ack)
        || (B.target !== null && B.target.disabled && !B.targetDisabled);
      if (busy && a.t_busy === null) a.t_busy = t;
      if (s.header && !base.header && a.t_header === null) a.t_header = t;
      if (a.t_done === null && done(s)) {
        a.t_done = t;
        // the server's last message before the result was drawn
        const before = (window.__vtArrivals || []).filter((x) => x >= a.t_action && x <= t);
        a.t_reply = before.length ? before[before.length - 1] : null;
        // the next frame: this one, holding the result, has been painted
        requestAnimationFrame(() => {
          a.t_done = performance.now();
          B.result = a;
          B.active = null;
        });
        return;
      }
    }
    requestAnimationFrame(frame);
  };
  requestAnimationFrame(frame);
  return a.t_start;
};
B.stop = () => { const a = B.active; B.active = null; return a; };
})();
"""


class BenchError(RuntimeError):
    """The page did not do what the bench asked (a failed run, a missing control)."""


def _seconds(a, t_end=None):
    """(duration s, busy s, header busy s, last reply s) of a probe record,
    from the action."""
    t0 = a["t_action"] if a["t_action"] is not None else a["t_start"]
    end = a["t_done"] if t_end is None else t_end

    def rel(t):
        return None if t is None else (t - t0) / 1000.0

    return rel(end), rel(a["t_busy"]), rel(a["t_header"]), rel(a.get("t_reply"))


class Session:
    """One explorer page and the actions on it; every action returns a
    sample {"s", "busy_s", "header_busy_s"} (seconds from the action)."""

    def __init__(self, browser, url):
        self.context = browser.new_context(viewport=VIEWPORT)
        self.context.add_init_script(WEBSOCKET_JS)
        self.page = self.context.new_page()
        self.errors = []
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        t0 = time.perf_counter()
        self.page.goto(url)
        self.page.wait_for_selector("canvas", timeout=120000)
        self.page.evaluate(PROBE_JS)
        # loaded: the map drawn and painted; then quiet a moment, so no
        # action meets the page's start
        self.page.wait_for_function(
            "() => window.__vtBench.mapPlot() !== null && window.Bokeh.documents.every((d) => d.is_idle)",
            timeout=120000,
        )
        self.load_s = time.perf_counter() - t0
        self.memory_open = False
        self.page.wait_for_timeout(1500)

    def close(self):
        self.context.close()
        if self.errors:
            raise BenchError(f"JavaScript errors in the page: {self.errors}")

    def _measure(self, kind, arg, act, timeout_s=ACTION_TIMEOUT_S):
        self.page.evaluate("([k, a]) => window.__vtBench.start(k, a)", [kind, arg])
        act()
        self.page.wait_for_function("() => window.__vtBench.result", timeout=timeout_s * 1000, polling=50)
        a = self.page.evaluate("() => window.__vtBench.result")
        if a["error"]:
            raise BenchError(f"{kind}: {a['error']}")
        if a["t_action"] is None:
            raise BenchError(f"{kind}: the page saw no pointerdown or input event")
        s, busy, header, reply = _seconds(a)
        return {"s": s, "busy_s": busy, "header_busy_s": header, "reply_s": reply}

    def _click_map(self, point):
        xy = self.page.evaluate("([x, y]) => window.__vtBench.mapPoint(x, y)", list(point))
        if xy is None:
            raise BenchError("the map figure is not shown (Bokeh model named 'map')")
        self.page.mouse.click(*xy)

    def _center(self, locator):
        locator.scroll_into_view_if_needed()
        box = locator.bounding_box()
        if box is None:
            raise BenchError(f"not shown: {locator}")
        return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2

    def run(self, point, expect=None):
        """Click the map at `point` until the run is drawn; `expect`: a text
        the new summary's first line holds (the model)."""
        return self._measure("run", expect, lambda: self._click_map(point))

    def tab(self, name):
        """Open one of the run's tabs (Trajectory, Animation, Memory
        diagram, Downloads)."""
        self.page.get_by_text(name, exact=True).first.click()
        self.page.wait_for_timeout(500)

    def memory_view(self, t, timeout_s=ACTION_TIMEOUT_S):
        """Type t* in the memory diagram's field and click its button:
        until the diagram of that time is drawn.  The tab is opened first
        (once: its snapshots of the last period computed and drawn)."""
        if not self.memory_open:
            self.tab("Memory diagram")
            self.page.wait_for_function(
                "() => window.__vtBench.titles().some((t) => t.startsWith('memory diagram w(h)\\nt* = '))",
                timeout=ACTION_TIMEOUT_S * 1000,
            )
            self.memory_open = True
        field = self.page.locator(".vt-field-t input").first
        field.fill(f"{t:g}")
        field.press("Tab")
        button = self.page.get_by_role("button", name="Show the memory diagram at t*")
        button.scroll_into_view_if_needed()
        seen = {"box before": button.bounding_box(), "field before": field.input_value()}

        def act():
            seen["box at click"] = button.bounding_box()
            seen["enabled at click"] = button.is_enabled()
            seen["field at click"] = field.input_value()
            # the button, where it is when it can take the click (Playwright
            # waits until it is enabled, in place and not covered): not the
            # point where it was before the measurement began
            button.click(timeout=ACTION_TIMEOUT_S * 1000)

        try:
            return self._measure("title", "memory diagram w(h)\nt* = ", act, timeout_s)
        except Exception as exc:
            raise BenchError(self._evidence(f"memory view at t* = {t:g}", exc, seen)) from exc

    def memory_slide(self, fraction, timeout_s=ACTION_TIMEOUT_S):
        """Click the memory diagram's slider at `fraction` of its track (the
        slider jumps there: noUiSlider's tap): until the diagram of the
        snapshot nearest to that time is drawn (a new title)."""
        track = self.page.locator(".vt-memory-slider .noUi-base").first
        track.scroll_into_view_if_needed()
        box = track.bounding_box()
        if box is None:
            raise BenchError("the memory diagram's slider is not shown")
        xy = (box["x"] + fraction * box["width"], box["y"] + box["height"] / 2)
        seen = {"fraction": fraction, "titles before": self.page.evaluate("() => window.__vtBench.titles()")}
        try:
            return self._measure(
                "title", "memory diagram w(h)\nt* = ", lambda: self.page.mouse.click(*xy), timeout_s
            )
        except Exception as exc:
            raise BenchError(self._evidence(f"slider at {fraction:g}", exc, seen)) from exc

    def _evidence(self, what, exc, seen):
        """What the page showed when an action failed: the exception, what
        `seen` holds, the plots' titles, the field and the probe's record,
        and a screenshot (its path)."""
        page = self.page
        lines = [f"{what}: {type(exc).__name__}: {str(exc).splitlines()[0][:200]}"]
        lines += [f"  {k}: {v}" for k, v in seen.items()]
        for name, get in (
            ("titles now", lambda: page.evaluate("() => window.__vtBench.titles()")),
            ("field now", lambda: page.locator(".vt-field-t input").first.input_value()),
            (
                "probe",
                lambda: page.evaluate(
                    "() => { const a = window.__vtBench.active || window.__vtBench.result;"
                    " return a && {...a, base_data: undefined}; }"
                ),
            ),
            ("alerts", lambda: page.locator(".alert").all_inner_texts()),
        ):
            try:
                lines.append(f"  {name}: {get()}")
            except Exception as e:  # noqa: BLE001 - evidence, best effort
                lines.append(f"  {name}: ({type(e).__name__})")
        try:
            page.evaluate("() => window.__vtBench.stop()")
            shot = Path(tempfile.mkdtemp(prefix="browserbench-")) / "failure.png"
            page.screenshot(path=str(shot))
            lines.append(f"  screenshot: {shot}")
        except Exception as e:  # noqa: BLE001
            lines.append(f"  screenshot: ({type(e).__name__})")
        return "\n".join(lines)

    def redraw_button(self, name):
        button = self.page.get_by_role("button", name=name, exact=True).first
        button.scroll_into_view_if_needed()
        return self._measure("redraw", None, lambda: button.click(timeout=ACTION_TIMEOUT_S * 1000))

    def redraw_select(self, label, value):
        select = self.page.get_by_label(label, exact=True)
        select.scroll_into_view_if_needed()
        return self._measure("redraw", None, lambda: select.select_option(value))

    def select(self, label, value):
        """Change a select whose change draws nothing to wait for."""
        self.page.get_by_label(label, exact=True).select_option(value)
        self.page.wait_for_timeout(500)

    def trajectory_png(self):
        xy = self._center(self.page.locator(".vt-export-trajectory-png").locator("button, a").first)
        self.page.evaluate("() => window.__vtBench.start('watch', null)")
        t0 = time.perf_counter()
        with self.page.expect_download(timeout=ACTION_TIMEOUT_S * 1000) as dl:
            self.page.mouse.click(*xy)
        s = time.perf_counter() - t0
        a = self.page.evaluate("() => window.__vtBench.stop()")
        with open(dl.value.path(), "rb") as f:
            head = f.read(8)
        if not head.startswith(b"\x89PNG"):
            raise BenchError(f"the trajectory export is not a PNG: {head!r}")
        _, busy, header, _ = _seconds(a, t_end=a["t_start"])
        # the file comes in the server's reply: all of it is the server's
        return {"s": s, "busy_s": busy, "header_busy_s": header, "reply_s": s}


def repeat(browser, url):
    """One repeat on a new page: {action: [samples]}."""
    out = {k: [] for k in ACTIONS}
    session = Session(browser, url)
    try:
        for point in CLICKS:
            out["map click"].append(session.run(point, "deformable:"))
        for t in (1999.3, 1999.7):
            try:
                out["memory view"].append(session.memory_view(t))
            except Exception as exc:  # noqa: BLE001 - reported, not hidden
                # seen: now and then a typed time's diagram never
                # came (1 in ~45 pages, clicked at a point measured before
                # the action; not seen since the click goes to the button);
                # the failure says what the page showed
                out.setdefault("failures", []).append(
                    str(exc)
                    if isinstance(exc, BenchError)
                    else f"memory view at t* = {t:g}: {type(exc).__name__}: {exc}"
                )
        session.tab("Downloads")
        out["trajectory PNG export"].append(session.trajectory_png())
        session.tab("Trajectory")
        out["map redraw: colour"].append(session.redraw_button("colour"))
        out["map redraw: mu"].append(session.redraw_select("mu (shipped maps)", "0.1"))
        out["map redraw: mu"].append(session.redraw_select("mu (shipped maps)", "0.3"))
        out["map redraw: model"].append(session.redraw_button("point-mass"))
        out["first point-mass run"].append(session.run(POINT_MASS_CLICK, "point-mass:"))
        out["map redraw: model"].append(session.redraw_button("deformable"))
        session.select("compare with", "point mass")
        out["first run after compare"].append(session.run(COMPARE_CLICK, "deformable:"))
        out["map redraw: colour"].append(session.redraw_button("grey"))
    finally:
        session.close()
    return out


# --memory-views: views per page, and how long an answer may take before
# it counts as lost (the slowest answers seen under load: ~5 s)
MEMORY_VIEWS_PER_PAGE = 10
MEMORY_LOST_AFTER_S = 30.0
MEMORY_CLICK = CLICKS[1]  # a permanent contact: a memory at every time


def memory_views(browser, url, n, log=print):
    """n memory views (typed times and slider moves in turn, on new pages of
    MEMORY_VIEWS_PER_PAGE each, after one deformable run): {"views": n,
    "answered": [samples], "lost": [what the page showed]}.  A view whose
    diagram is not drawn within MEMORY_LOST_AFTER_S is lost (now
    and then a typed time's diagram never came); the page is then closed
    and the next one opened."""
    answered, lost = [], []
    done = 0
    page_no = 0
    while done < n:
        page_no += 1
        session = Session(browser, url)
        try:
            session.run(MEMORY_CLICK, "deformable:")
            for i in range(min(MEMORY_VIEWS_PER_PAGE, n - done)):
                done += 1
                k = done
                try:
                    if i % 2 == 0:  # typed: a time of the last period, new each time
                        t = 1999.0 + round(((k * 0.37) % 1.0) * 0.96 + 0.02, 3)
                        sample = session.memory_view(t, MEMORY_LOST_AFTER_S)
                        sample["how"] = f"typed {t:g}"
                    else:  # the slider, somewhere else on its track
                        f = 0.05 + ((k * 0.29) % 0.9)
                        sample = session.memory_slide(f, MEMORY_LOST_AFTER_S)
                        sample["how"] = f"slider {f:.2f}"
                    answered.append(sample)
                except Exception as exc:  # noqa: BLE001 - counted and said
                    lost.append(f"page {page_no}, view {i + 1}: {exc}")
                    log(f"lost: {lost[-1]}")
                    break  # the page's state is unknown: a new page
        finally:
            session.close()
        log(f"page {page_no}: {done} of {n} views, {len(lost)} lost")
    return {"views": done, "answered": answered, "lost": lost}


def _stats(samples):
    xs = sorted(x["s"] for x in samples)
    slow = [x for x in samples if x["s"] > BUSY_WITHIN_S]
    busy_ok = [x for x in slow if x["busy_s"] is not None and x["busy_s"] <= BUSY_WITHIN_S]
    header_ok = [x for x in slow if x["header_busy_s"] is not None and x["header_busy_s"] <= BUSY_WITHIN_S]
    replies = [x["reply_s"] for x in samples if x["reply_s"] is not None]
    if not xs:  # every sample failed (run()'s "failures" say why)
        return {
            "n": 0,
            "min_s": math.nan,
            "median_s": math.nan,
            "max_s": math.nan,
            "reply_median_s": None,
            "slow": 0,
            "busy_within": 0,
            "header_busy_within": 0,
        }
    return {
        "n": len(xs),
        "min_s": xs[0],
        "median_s": statistics.median(xs),
        "max_s": xs[-1],
        "reply_median_s": statistics.median(replies) if replies else None,
        "slow": len(slow),
        "busy_within": len(busy_ok),
        "header_busy_within": len(header_ok),
    }


def summarize(warmup, repeats):
    """Per action: statistics over the repeats, the warm-up's times, the goal
    and whether it is met (median), busy indicators on the slow samples."""
    rows = {}
    for action in ACTIONS:
        samples = [x for r in repeats for x in r[action]]
        row = _stats(samples)
        row["warmup_s"] = [round(x["s"], 3) for x in warmup[action]]
        row["samples_s"] = [round(x["s"], 3) for x in samples]
        for key in ("busy_s", "header_busy_s", "reply_s"):
            row[key + "_samples"] = [None if x[key] is None else round(x[key], 3) for x in samples]
        goal = GOALS.get(action)
        row["goal_s"] = goal
        row["goal_met"] = None if goal is None else bool(row["median_s"] <= goal)
        row["busy_met"] = row["busy_within"] == row["slow"]
        rows[action] = row
    return rows


def table(rows):
    """The results as a Markdown table."""
    lines = [
        "| action | warm-up | min | median | max | n | goal | met | server's reply "
        "(median) | busy <= 0.3 s (of > 0.3 s) | header spinner <= 0.3 s |",
        "|---" * 11 + "|",
    ]
    for action, r in rows.items():
        goal = "-" if r["goal_s"] is None else f"<= {r['goal_s']:g} s"
        met = "-" if r["goal_met"] is None else ("yes" if r["goal_met"] else "**no**")
        busy = f"{r['busy_within']}/{r['slow']}" + ("" if r["busy_met"] else " **no**")
        warm = ", ".join(f"{x:.2f}" for x in r["warmup_s"]) or "-"
        reply = "-" if r["reply_median_s"] is None else f"{r['reply_median_s']:.2f}"
        lines.append(
            f"| {action} | {warm} | {r['min_s']:.2f} | {r['median_s']:.2f} | "
            f"{r['max_s']:.2f} | {r['n']} | {goal} | {met} | {reply} | {busy} | "
            f"{r['header_busy_within']}/{r['slow']} |"
        )
    return "\n".join(lines)


@contextlib.contextmanager
def _browser_and_server(url, log, server_errors=None):
    """(chromium, the explorer's URL): `url`, or a server of the bench's own,
    started and its kernels compiled, stopped at the end.  server_errors: a
    list given the lines of that server's log that report an error (a
    traceback's last line, Bokeh's "_pending_writes")."""
    from playwright.sync_api import sync_playwright

    server = None
    if url is None:
        server = served()
        log("starting vibtrans serve ...")
        server.wait_page()
        server.wait_kernels()
        url = server.url
    try:
        if not Path(CHROMIUM).exists():
            raise BenchError(f"Debian's chromium is required at {CHROMIUM} (make browser)")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
            try:
                yield browser, url
            finally:
                browser.close()
    except BaseException:
        if server is not None:
            print(f"the server's log:\n{server.text()[-3000:]}", file=sys.stderr)
        raise
    finally:
        if server is not None:
            if server_errors is not None:
                server_errors += [
                    line
                    for line in server.text().splitlines()
                    if "_pending_writes" in line
                    or line.startswith(
                        ("RuntimeError", "AttributeError", "ValueError", "TypeError", "KeyError")
                    )
                ]
            server.stop()


def run(repeats, url=None, log=print):
    """Warm-up plus `repeats` repeats against `url` (or a server of its own):
    {"rows": {...}, "page_load_s": [...], "machine": "..."}."""
    with _browser_and_server(url, log) as (browser, url):
        log("warm-up repeat ...")
        warmup = repeat(browser, url)
        results = []
        for i in range(repeats):
            log(f"repeat {i + 1}/{repeats} ...")
            results.append(repeat(browser, url))
    load = os.getloadavg()
    failures = [f for r in [warmup, *results] for f in r.get("failures", [])]
    for f in failures:
        log(f"failed: {f}")
    return {
        "rows": summarize(warmup, results),
        "repeats": repeats,
        "failures": failures,
        "machine": f"{os.cpu_count()} cores, load average {load[0]:.2f} {load[1]:.2f} "
        f"{load[2]:.2f} at the end",
    }


def missed(rows):
    """The goals missed: [text]."""
    out = []
    for action, r in rows.items():
        if r["goal_met"] is False:
            out.append(f"{action}: median {r['median_s']:.2f} s > {r['goal_s']:g} s")
        if not r["busy_met"]:
            out.append(
                f"{action}: a busy indicator within {BUSY_WITHIN_S} s in "
                f"{r['busy_within']} of {r['slow']} actions over {BUSY_WITHIN_S} s"
            )
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.browserbench", description=__doc__.splitlines()[0])
    ap.add_argument(
        "--repeats",
        type=int,
        default=5,
        help="measured repeats (1-50), each on a new page, after one warm-up repeat",
    )
    ap.add_argument(
        "--url", help="a running explorer (its kernels compiled) instead of a server of the bench's own"
    )
    ap.add_argument(
        "--memory-views",
        type=int,
        metavar="N",
        help="instead of the "
        "actions: N memory views (1-1000; typed times and slider moves in "
        "turn, 10 per page), counting those whose diagram never reached the "
        "page (--check: exit 1 if one did not)",
    )
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    ap.add_argument(
        "--check", action="store_true", help="exit 1 if a goal is missed (medians, busy indicators)"
    )
    results.add_option(ap)
    argv = sys.argv[1:] if argv is None else list(argv)
    a = ap.parse_args(argv)
    a.command = " ".join(["python -m devtools.browserbench", *argv])
    if not 1 <= a.repeats <= 50:
        ap.error(f"--repeats must be in [1, 50], got {a.repeats}")
    if a.memory_views is not None:
        if not 1 <= a.memory_views <= 1000:
            ap.error(f"--memory-views must be in [1, 1000], got {a.memory_views}")
        return _memory_main(a)
    begun = results.begin()
    out = run(a.repeats, a.url, log=lambda m: print(m, file=sys.stderr))
    misses = missed(out["rows"])
    results.save("browserbench", {**out, "missed": misses}, begun, a.results_dir, a.command)
    if a.json:
        print(json.dumps({**out, "missed": misses}))
    else:
        print(table(out["rows"]))
        print(f"\n{out['repeats']} repeats; {out['machine']}")
        print("goals missed:\n  " + "\n  ".join(misses) if misses else "all goals met")
    if a.check and misses:
        sys.exit(1)
    return out


def _memory_main(a):
    log = lambda m: print(m, file=sys.stderr)  # noqa: E731
    errors = []
    begun = results.begin()
    with _browser_and_server(a.url, log, errors) as (browser, url):
        out = memory_views(browser, url, a.memory_views, log)
    load = os.getloadavg()
    xs = sorted(x["s"] for x in out["answered"])
    replies = sorted(x["reply_s"] for x in out["answered"] if x["reply_s"] is not None)
    by = {
        how: sorted(x["s"] for x in out["answered"] if x["how"].startswith(how))
        for how in ("typed", "slider")
    }
    summary = {
        "views": out["views"],
        "answered": len(xs),
        "lost": out["lost"],
        "median_s": statistics.median(xs) if xs else None,
        "reply_median_s": statistics.median(replies) if replies else None,
        **{f"{how}_median_s": statistics.median(v) if v else None for how, v in by.items()},
        "max_s": xs[-1] if xs else None,
        "server_errors": errors if a.url is None else None,
        "machine": f"{os.cpu_count()} cores, load average {load[0]:.2f} {load[1]:.2f} "
        f"{load[2]:.2f} at the end",
    }
    results.save(
        "browserbench-memory-views", {**summary, "samples": out["answered"]}, begun, a.results_dir, a.command
    )
    if a.json:
        print(json.dumps({**summary, "samples": out["answered"]}))
    else:

        def s3(x):
            return "-" if x is None else f"{x:.3f} s"

        print(
            f"memory views: {summary['views']}, answered {summary['answered']}, "
            f"lost {len(out['lost'])}; median {s3(summary['median_s'])} (typed "
            f"{s3(summary['typed_median_s'])}, slider {s3(summary['slider_median_s'])}), "
            f"server's reply median {s3(summary['reply_median_s'])}, max "
            f"{s3(summary['max_s'])}; {summary['machine']}"
        )
        for x in out["lost"]:
            print(f"lost: {x}")
        if a.url is None:
            print(f"the server's log: {len(errors)} error lines" + "".join(f"\n  {e}" for e in errors[:10]))
    if a.check and (out["lost"] or errors):
        sys.exit(1)
    return summary


if __name__ == "__main__":
    main()
