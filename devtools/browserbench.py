"""The explorer's responsiveness as a person sees it, in chromium:

    python -m devtools.browserbench [--repeats 5] [--url URL] [--json] [--check]
    python -m devtools.browserbench --memory-views N [--url URL] [--json] [--check]

Uses a server of its own (kernels compiled first) or the one at --url.  Each
repeat opens a new page and does, in turn: two map clicks (until the run is
drawn), two memory views (a time typed, "Show the memory diagram at t*"),
the trajectory PNG export (until the download), map redraws (colour, mu,
model), the first point-mass run and the first run after "compare with".

A probe in the page times each action from its pointerdown or input event
to the frame after the result is drawn and every plot shown has painted;
"server's reply" is the last websocket message before that.  A busy
indicator (the explorer's vt-busy, a pane's pn-loading, a <progress>,
"Running ..." or a disabled clicked button; Panel's header spinner is
reported apart) must show within 0.3 s of every action longer than that.

Goals on the median of the repeats (the first, warm-up repeat is reported
apart), --check exits 1 when one is missed: memory view and map redraws
<= 0.5 s, PNG export <= 3 s, first point-mass run and first run after
compare <= 1.5 s.  --memory-views N: N memory views (typed times and slider
clicks, 10 a page), counting those lost (no diagram within 30 s) and the
server log's error lines; --check exits 1 on either.
"""

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from . import results
from .server import explorer

VIEWPORT = {"width": 1400, "height": 1000}
BUSY_WITHIN_S = 0.3
ACTION_TIMEOUT_S = 120.0

# the actions in their order, and their goals (seconds, median of the repeats)
GOALS = {
    "map click": None,
    "memory view": 0.5,
    "trajectory PNG export": 3.0,
    "map redraw: colour": 0.5,
    "map redraw: mu": 0.5,
    "map redraw: model": 0.5,
    "first point-mass run": 1.5,
    "first run after compare": 1.5,
}
ACTIONS = list(GOALS)

# map points (log10 A*, log10 m*): a chaotic hopping scene, then a permanent
# contact (the memory diagram's case); consecutive runs differ
CLICKS = [(1.5, -2.0), (1.0, 2.0)]
POINT_MASS_CLICK = (2.5, 4.0)  # the point mass drifting against the wave
COMPARE_CLICK = (0.5, 1.5)

# Before the page's scripts: the arrival time of every websocket message
# (page clock), from a listener that runs before Bokeh's handler.
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
# error} (ms, page clock) once the result is drawn.
PROBE_JS = r"""
(() => {
if (window.__vtBench) return;
const visible = (el) => el.getClientRects().length > 0;
const isPlot = (m) => m.x_range !== undefined && m.renderers !== undefined;
const plots = () => window.Bokeh.documents.flatMap((d) => [...d.all_models].filter(isPlot));
const titles = () => plots().filter((m) => m.title != null).map((m) => String(m.title.text));
const plotIn = (m) => {     // the first plot in a model (a plot itself, a tab, a layout)
  if (m == null) return null;
  if (isPlot(m)) return m;
  for (const c of [m.child, ...(m.children || []), ...(m.tabs || [])]) {
    const p = plotIn(Array.isArray(c) ? c[0] : c);   // a grid's child: [model, row, col]
    if (p) return p;
  }
  return null;
};
// the map's plot: in a model named "map", else titled "<v*> over ..."; the
// one shown (a replaced figure stays among the models for a while)
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
// The page's shadow roots, kept by MutationObservers (walking every element
// at every frame cost ~0.1 s of a map redraw), each queried for the few
// elements read; a full walk every FULL_WALK_FRAMES frames catches a root
// attached to an element already in the page.
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
const SCANNED = "strong, progress, p, .pn-loading, .vt-busy, .loader, .alert";
const look = (s, el) => {
  const tag = el.tagName, cl = el.classList;
  if (tag === "STRONG") { if (el.textContent.includes("mu = ")) s.summary = el.textContent; }
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
                      ack: false, header: false});
const scan = () => {
  if (++frames % FULL_WALK_FRAMES === 0) adopt(document);
  const s = fresh();
  for (const root of roots) {
    if (root !== document && !root.host.isConnected) continue;
    for (const el of root.querySelectorAll(SCANNED)) look(s, el);
  }
  return s;
};
const B = window.__vtBench = {result: null, target: null};
for (const type of ["pointerdown", "input"])
  window.addEventListener(type, (e) => {
    if (B.active && B.active.t_action === null) {
      B.active.t_action = e.timeStamp;
      const el = e.composedPath()[0];
      B.target = el && el.closest ? el.closest("button") : null;
      B.targetDisabled = B.target ? B.target.disabled : false;
    }
  }, true);
B.mapPlot = mapPlot;
// client coordinates of a map point (log10 A*, log10 m*), the map scrolled into view
B.mapPoint = (x, y) => {
  const m = mapPlot();
  const v = m && window.Bokeh.index.find_one(m);
  if (!v) return null;
  v.el.scrollIntoView({block: "nearest"});
  const r = v.canvas_view.el.getBoundingClientRect();
  return [r.left + v.frame.x_scale.compute(x), r.top + v.frame.y_scale.compute(y)];
};
B.titles = titles;
B.start = (kind, arg) => {
  const base = scan(), map = mapPlot(), baseTitles = new Set(titles());
  const a = B.active = {kind, arg, t_start: performance.now(), t_action: null,
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


# the probe's record of the action under way or just done, then stopped
PROBE_RECORD_JS = """() => {
  const B = window.__vtBench, a = B.active || B.result;
  B.stop();
  return a && {...a, base_data: undefined};
}"""


class BenchError(RuntimeError):
    """The page did not do what the bench asked (a failed run, a missing control)."""


def _sample(a, t_end=None):
    """A probe record as seconds from the action: {"s", "busy_s", "header_busy_s", "reply_s"}."""
    t0 = a["t_action"] if a["t_action"] is not None else a["t_start"]
    end = a["t_done"] if t_end is None else t_end
    times = {"s": end, "busy_s": a["t_busy"], "header_busy_s": a["t_header"], "reply_s": a.get("t_reply")}
    return {k: None if t is None else (t - t0) / 1000.0 for k, t in times.items()}


class Session:
    """One explorer page and the actions on it, each returning a sample (_sample)."""

    def __init__(self, browser, url):
        self.context = browser.new_context(viewport=VIEWPORT)
        self.context.add_init_script(WEBSOCKET_JS)
        self.page = self.context.new_page()
        self.errors = []
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.goto(url)
        self.page.wait_for_selector("canvas", timeout=120000)
        self.page.evaluate(PROBE_JS)
        # loaded: the map drawn and painted; then quiet a moment
        self.page.wait_for_function(
            "() => window.__vtBench.mapPlot() !== null && window.Bokeh.documents.every((d) => d.is_idle)",
            timeout=120000,
        )
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
        return _sample(a)

    def _center(self, locator):
        locator.scroll_into_view_if_needed()
        box = locator.bounding_box()
        if box is None:
            raise BenchError(f"not shown: {locator}")
        return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2

    def run(self, point, expect=None):
        """Click the map at `point` until the run is drawn; `expect`: a text
        of the new summary's first line (the model)."""

        def click():
            xy = self.page.evaluate("([x, y]) => window.__vtBench.mapPoint(x, y)", list(point))
            if xy is None:
                raise BenchError("the map figure is not shown (Bokeh model named 'map')")
            self.page.mouse.click(*xy)

        return self._measure("run", expect, click)

    def tab(self, name):
        self.page.get_by_text(name, exact=True).first.click()
        self.page.wait_for_timeout(500)

    def memory_view(self, t, timeout_s=ACTION_TIMEOUT_S):
        """Type t* and click "Show the memory diagram at t*" until that
        diagram is drawn (the tab opened first, once)."""
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
            # the button where it is when it can take the click (Playwright waits)
            button.click(timeout=ACTION_TIMEOUT_S * 1000)

        return self._evidenced(f"memory view at t* = {t:g}", seen, act, timeout_s)

    def memory_slide(self, fraction, timeout_s=ACTION_TIMEOUT_S):
        """Click the memory diagram's slider at `fraction` of its track until
        the diagram of the nearest snapshot is drawn."""
        track = self.page.locator(".vt-memory-slider .noUi-base").first
        x, y = self._center(track)
        box = track.bounding_box()
        xy = (box["x"] + fraction * box["width"], y)
        seen = {"fraction": fraction, "titles before": self.page.evaluate("() => window.__vtBench.titles()")}
        return self._evidenced(f"slider at {fraction:g}", seen, lambda: self.page.mouse.click(*xy), timeout_s)

    def _evidenced(self, what, seen, act, timeout_s):
        """A memory view measured; when it fails, a BenchError with what the
        page showed: `seen`, the plots' titles, the probe's record, the
        alerts and a screenshot."""
        try:
            return self._measure("title", "memory diagram w(h)\nt* = ", act, timeout_s)
        except Exception as exc:
            lines = [f"{what}: {type(exc).__name__}: {str(exc).splitlines()[0][:200]}"]
            lines += [f"  {k}: {v}" for k, v in seen.items()]
            shot = Path(tempfile.mkdtemp(prefix="browserbench-")) / "failure.png"
            try:
                lines.append(f"  titles now: {self.page.evaluate('() => window.__vtBench.titles()')}")
                lines.append(f"  field now: {self.page.locator('.vt-field-t input').first.input_value()}")
                lines.append(f"  probe: {self.page.evaluate(PROBE_RECORD_JS)}")
                lines.append(f"  alerts: {self.page.locator('.alert').all_inner_texts()}")
                self.page.screenshot(path=str(shot))
                lines.append(f"  screenshot: {shot}")
            except Exception as e:  # noqa: BLE001 - evidence, best effort
                lines.append(f"  (the page: {type(e).__name__})")
            raise BenchError("\n".join(lines)) from exc

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
        # the file comes in the server's reply: all of it is the server's
        return {**_sample(a, t_end=a["t_start"]), "s": s, "reply_s": s}


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
            except Exception as exc:  # noqa: BLE001 - now and then a typed time's diagram never came
                what = (
                    ""
                    if isinstance(exc, BenchError)
                    else f"memory view at t* = {t:g}: {type(exc).__name__}: "
                )
                out.setdefault("failures", []).append(what + str(exc))
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


# --memory-views: views per page, and how long an answer may take before it is lost
MEMORY_VIEWS_PER_PAGE = 10
MEMORY_LOST_AFTER_S = 30.0
MEMORY_CLICK = CLICKS[1]  # a permanent contact: a memory at every time


def memory_views(browser, url, n, log=print):
    """n memory views, typed times and slider clicks in turn, on new pages
    of MEMORY_VIEWS_PER_PAGE after one run: {"views", "answered": [samples],
    "lost": [what the page showed]}; a lost view's page is replaced."""
    answered, lost = [], []
    done = page_no = 0
    while done < n:
        page_no += 1
        session = Session(browser, url)
        try:
            session.run(MEMORY_CLICK, "deformable:")
            for i in range(min(MEMORY_VIEWS_PER_PAGE, n - done)):
                done += 1
                try:
                    if i % 2 == 0:  # a time of the last period, new each time
                        t = 1999.0 + round(((done * 0.37) % 1.0) * 0.96 + 0.02, 3)
                        sample = {**session.memory_view(t, MEMORY_LOST_AFTER_S), "how": f"typed {t:g}"}
                    else:
                        f = 0.05 + ((done * 0.29) % 0.9)
                        sample = {**session.memory_slide(f, MEMORY_LOST_AFTER_S), "how": f"slider {f:.2f}"}
                    answered.append(sample)
                except Exception as exc:  # noqa: BLE001 - counted and said
                    lost.append(f"page {page_no}, view {i + 1}: {exc}")
                    log(f"lost: {lost[-1]}")
                    break  # the page's state is unknown: a new page
        finally:
            session.close()
        log(f"page {page_no}: {done} of {n} views, {len(lost)} lost")
    return {"views": done, "answered": answered, "lost": lost}


def _median(xs):
    return statistics.median(xs) if xs else None


def _stats(samples):
    slow = [x for x in samples if x["s"] > BUSY_WITHIN_S]

    def within(key):
        return sum(x[key] is not None and x[key] <= BUSY_WITHIN_S for x in slow)

    xs = sorted(x["s"] for x in samples)
    return {
        "n": len(xs),
        "min_s": xs[0] if xs else math.nan,
        "median_s": statistics.median(xs) if xs else math.nan,
        "max_s": xs[-1] if xs else math.nan,
        "reply_median_s": _median([x["reply_s"] for x in samples if x["reply_s"] is not None]),
        "slow": len(slow),
        "busy_within": within("busy_s"),
        "header_busy_within": within("header_busy_s"),
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
        row["goal_s"] = goal = GOALS[action]
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


def _machine():
    return "{} cores, load average {:.2f} {:.2f} {:.2f} at the end".format(os.cpu_count(), *os.getloadavg())


def run(repeats, url=None, log=print):
    """Warm-up plus `repeats` repeats against `url` (or a server of its own)."""
    with explorer(url) as (browser, url, _):
        log("warm-up repeat ...")
        warmup = repeat(browser, url)
        done = []
        for i in range(repeats):
            log(f"repeat {i + 1}/{repeats} ...")
            done.append(repeat(browser, url))
    failures = [f for r in [warmup, *done] for f in r.get("failures", [])]
    for f in failures:
        log(f"failed: {f}")
    return {"rows": summarize(warmup, done), "repeats": repeats, "failures": failures, "machine": _machine()}


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


def _log(m):
    print(m, file=sys.stderr)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.browserbench", description=__doc__.splitlines()[0])
    ap.add_argument(
        "--repeats", type=results.bounded(int, 1, 50), default=5, help="repeats after a warm-up one"
    )
    ap.add_argument("--url", help="a running explorer (its kernels compiled) instead of a server of its own")
    views = results.bounded(int, 1, 1000)
    ap.add_argument("--memory-views", type=views, metavar="N", help="instead of the actions: N memory views")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    ap.add_argument("--check", action="store_true", help="exit 1 if a goal is missed")
    results.add_option(ap)
    argv = sys.argv[1:] if argv is None else list(argv)
    a = ap.parse_args(argv)
    a.command = " ".join(["python -m devtools.browserbench", *argv])
    if a.memory_views is not None:
        return _memory_main(a)
    begun = results.begin()
    out = run(a.repeats, a.url, log=_log)
    out["missed"] = misses = missed(out["rows"])
    results.save("browserbench", out, begun, a.results_dir, a.command)
    if a.json:
        print(json.dumps(out))
    else:
        print(table(out["rows"]))
        print(f"\n{out['repeats']} repeats; {out['machine']}")
        print("goals missed:\n  " + "\n  ".join(misses) if misses else "all goals met")
    if a.check and misses:
        sys.exit(1)
    return out


def _memory_main(a):
    begun = results.begin()
    with explorer(a.url) as (browser, url, server):
        out = memory_views(browser, url, a.memory_views, _log)
        errors = server.errors()[0] if server else []
    answered = out["answered"]
    xs = [x["s"] for x in answered]
    summary = {
        "views": out["views"],
        "answered": len(xs),
        "lost": out["lost"],
        "median_s": _median(xs),
        "reply_median_s": _median([x["reply_s"] for x in answered if x["reply_s"] is not None]),
        **{
            f"{how}_median_s": _median([x["s"] for x in answered if x["how"].startswith(how)])
            for how in ("typed", "slider")
        },
        "max_s": max(xs, default=None),
        "server_errors": errors if a.url is None else None,
        "machine": _machine(),
    }
    results.save(
        "browserbench-memory-views", {**summary, "samples": answered}, begun, a.results_dir, a.command
    )
    if a.json:
        print(json.dumps({**summary, "samples": answered}))
    else:
        print(json.dumps(summary, indent=1))
    if a.check and (out["lost"] or errors):
        sys.exit(1)
    return summary


if __name__ == "__main__":
    main()
