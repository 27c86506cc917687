"""Where a map redraw's time goes in the browser: a Chrome performance
trace of mu and model changes on a served explorer page.

    python -m devtools.redrawtrace URL [--repeats 4] [--json] [--save DIR]

Opens the page as devtools/browserbench.py does (its Session: 1400 x 1000,
its probe and websocket listener), then for each repeat records a trace
(Playwright's `browser.start_tracing`, categories devtools.timeline and
the invalidation tracking) around each of: mu 0.3 -> 0.1, mu 0.1 -> 0.3,
model deformable -> point-mass, point-mass -> deformable.  Each change is
measured exactly as browserbench measures it (from the input or
pointerdown event to the frame after the redraw is painted, the page's
clock); the trace's events on the renderer's main thread inside that
interval are summed by phase (self time: Recalculate Style, Layout,
Paint/PrePaint/Layerize, Composite, GC, script, parse, other) and the rest
of the interval is idle (waiting for the server, or for the next frame).

It also names what invalidated style and layout inside the interval (the
invalidation tracking's node names and reasons, the scripts' functions
that set them), and the probe's own cost (its frame callbacks)."""
import argparse
import collections
import json
import sys
import tempfile
import time
from pathlib import Path

from .browserbench import CHROMIUM, ARGS, Session

# the phases (`--light`: these alone; the invalidation tracking and the
# stacks cost the page much more time than they measure, so their phase
# totals are inflated: use them to find the cause, the light ones to count)
CATEGORIES = ["devtools.timeline", "disabled-by-default-devtools.timeline",
              "disabled-by-default-devtools.timeline.frame", "blink.user_timing", "v8"]
CAUSES = ["disabled-by-default-devtools.timeline.invalidationTracking",
          "disabled-by-default-devtools.timeline.stack", "devtools.timeline.async"]

PHASES = {
    "UpdateLayoutTree": "style", "RecalculateStyles": "style", "ScheduleStyleRecalculation": "style",
    "Layout": "layout", "UpdateLayerTree": "layout",
    "Paint": "paint", "PrePaint": "paint", "Layerize": "paint", "PaintImage": "paint",
    "RasterTask": "paint", "UpdateLayer": "paint", "Decode Image": "paint",
    "CompositeLayers": "composite", "Commit": "composite",
    "MinorGC": "gc", "MajorGC": "gc", "V8.GC_SCAVENGER": "gc", "BlinkGC.AtomicPhase": "gc",
    "ThreadState::performIdleLazySweep": "gc", "V8.GCIncrementalMarking": "gc",
    "V8.GCFinalizeMC": "gc", "V8.GC_MC_BACKGROUND_MARKING": "gc", "CppGC.AtomicMark": "gc",
    "FunctionCall": "script", "EvaluateScript": "script", "v8.compile": "script",
    "v8.callFunction": "script", "TimerFire": "script", "FireAnimationFrame": "script",
    "EventDispatch": "script", "v8.run": "script", "V8.Execute": "script",
    "XHRReadyStateChange": "script", "ProfileCall": "script", "RunMicrotasks": "script",
    "FireIdleCallback": "script", "v8.evaluateModule": "script",
    "ParseHTML": "parse", "ParseAuthorStyleSheet": "parse",
    "HitTest": "other", "RunTask": "other", "ThreadControllerImpl::RunTask": "other",
}

MARK_JS = "() => { performance.mark('vt-sync'); return performance.now(); }"


def _main_thread(events):
    """(pid, tid) of the page's renderer main thread."""
    names = {(e["pid"], e["tid"]): e["args"]["name"] for e in events
             if e.get("ph") == "M" and e.get("name") == "thread_name"}
    mains = [k for k, v in names.items() if v == "CrRendererMain"]
    # the one with most events (the page's; about:blank has another)
    counts = collections.Counter((e["pid"], e["tid"]) for e in events)
    return max(mains, key=lambda k: counts[k])


def _intervals(events, thread):
    """Complete events of a thread as (start us, end us, name, args), sorted
    (B/E pairs joined)."""
    out, stack = [], collections.defaultdict(list)
    for e in events:
        if (e.get("pid"), e.get("tid")) != thread:
            continue
        ph = e.get("ph")
        if ph == "X" and "dur" in e:
            out.append((e["ts"], e["ts"] + e["dur"], e["name"], e.get("args", {})))
        elif ph == "B":
            stack[e["name"]].append(e)
        elif ph == "E" and stack[e["name"]]:
            b = stack[e["name"]].pop()
            out.append((b["ts"], e["ts"], e["name"], {**b.get("args", {}), **e.get("args", {})}))
    out.sort(key=lambda x: (x[0], -x[1]))
    return out


def self_times(intervals, t0, t1):
    """Self time (ms) per event name, clipped to [t0, t1] (us), and the
    time covered by top-level events (busy, ms)."""
    selfs = collections.Counter()
    stack = []           # [(end, name, children's time so far)]
    busy = 0.0

    def close(until):
        while stack and stack[-1][0] <= until:
            end, name, start, child = stack.pop()
            own = (min(end, t1) - max(start, t0)) - child
            selfs[name] += max(own, 0.0)
            if stack:
                stack[-1][3] += min(end, t1) - max(start, t0)
    for s, e, name, _ in intervals:
        if e <= t0 or s >= t1:
            continue
        close(s)
        if not stack:
            busy += min(e, t1) - max(s, t0)
        stack.append([e, name, s, 0.0])
    close(float("inf"))
    return {k: v / 1000 for k, v in selfs.items()}, busy / 1000


def phases(selfs):
    out = collections.Counter()
    for name, ms in selfs.items():
        out[PHASES.get(name, "other")] += ms
    return out


def _frames(stack):
    return [f"{f.get('functionName') or '(anon)'}@{_file(f.get('url'))}:{f.get('lineNumber')}"
            for f in (stack or [])[:4]]


def _file(url):
    """A script's file name, without its query."""
    return Path((url or "").split("?")[0]).name


def invalidations(events, thread, t0, t1):
    """What invalidated style and layout in [t0, t1] (us): Counter of
    (kind, node name, reason, first frames)."""
    out = collections.Counter()
    for e in events:
        if (e.get("pid"), e.get("tid")) != thread or not t0 <= e.get("ts", 0) <= t1:
            continue
        name = e.get("name", "")
        if "Invalidat" not in name and name not in ("ScheduleStyleRecalculation",
                                                     "InvalidateLayout"):
            continue
        d = e.get("args", {}).get("data", {})
        node = d.get("nodeName") or ""
        reason = d.get("reason") or d.get("invalidationList") or d.get("changedAttribute") \
            or d.get("changedClass") or d.get("changedPseudo") or d.get("changedId") or ""
        if isinstance(reason, list):
            reason = ";".join(sorted({str(r.get("classes") or r.get("id") or r) for r in reason}))
        out[(name, node[:60], str(reason)[:80], " < ".join(_frames(d.get("stackTrace"))))] += 1
    return out


def forced(intervals, t0, t1):
    """Style and layout forced by scripts inside [t0, t1]: their events
    nested in a script's event (ms per (phase, script function))."""
    out = collections.Counter()
    scripts = [(s, e, a) for s, e, n, a in intervals
               if n in ("FunctionCall", "FireAnimationFrame", "TimerFire", "EventDispatch")]
    for s, e, n, a in intervals:
        if n not in ("UpdateLayoutTree", "Layout") or e <= t0 or s >= t1:
            continue
        inner = [x for x in scripts if x[0] <= s and e <= x[1]]
        where = "(not in a script: the frame's own)"
        if inner:
            st, en, args = max(inner, key=lambda x: x[0])
            d = args.get("data", {})
            where = (f"{d.get('functionName') or d.get('type') or ''}"
                     f"@{_file(d.get('url'))}:{d.get('lineNumber', '')}")
        out[(n, where)] += (min(e, t1) - max(s, t0)) / 1000
    return out


def cpu_ms(events, thread, t0, t1):
    """The main thread's CPU time (ms) in its tasks that start inside
    [t0, t1]: the trace's thread durations (`tdur`) of its top-level tasks
    (RunTask).  Wall durations grow when other processes take the cores;
    thread time does not (much): the measure to compare on a shared machine."""
    return sum(e.get("tdur", 0) for e in events
               if (e.get("pid"), e.get("tid")) == thread and e.get("ph") == "X"
               and e.get("name") == "RunTask" and t0 <= e.get("ts", 0) < t1) / 1000


def probe_ms(intervals, t0, t1):
    """The bench's probe (its animation-frame callback `frame`, an evaluated
    script: no URL) inside [t0, t1]: its calls' time, what they forced
    included (ms)."""
    return sum((min(e, t1) - max(s, t0)) / 1000 for s, e, n, a in intervals
               if n == "FunctionCall" and s < t1 and e > t0
               and a.get("data", {}).get("functionName") == "frame"
               and not a.get("data", {}).get("url"))


def measure(browser, session, kind, act, save=None, categories=CATEGORIES + CAUSES):
    """Trace one change: (bench sample, phase totals ms, idle ms, invalidations,
    forced, self times)."""
    page = session.page
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as f:
        path = f.name
    browser.start_tracing(page=page, path=path, categories=categories)
    now_ms = page.evaluate(MARK_JS)
    sample = act()
    a = page.evaluate("() => window.__vtBench.result")
    page.wait_for_timeout(200)
    browser.stop_tracing()
    trace = json.loads(Path(path).read_text())
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    Path(path).unlink()
    thread = _main_thread(events)
    mark = [e for e in events if e.get("name") == "vt-sync" and e.get("ph") in ("R", "I", "n", "b")]
    if not mark:
        raise RuntimeError("the sync mark is not in the trace")
    offset = mark[0]["ts"] - now_ms * 1000           # trace us = page ms * 1000 + offset
    t0 = a["t_action"] * 1000 + offset
    t1 = a["t_done"] * 1000 + offset
    reply = a["t_reply"] * 1000 + offset if a["t_reply"] is not None else None
    if save:
        Path(save).mkdir(parents=True, exist_ok=True)
        Path(save, f"{kind}.json").write_text(json.dumps(
            {"t0": t0, "t1": t1, "reply": reply, "thread": thread, "events": events}))
    iv = _intervals(events, thread)
    selfs, busy = self_times(iv, t0, t1)
    ph = phases(selfs)
    ph["idle"] = (t1 - t0) / 1000 - busy
    before = None
    if reply is not None:     # the browser's share before the server's last reply
        sb, bb = self_times(iv, t0, reply)
        before = {"ms": (reply - t0) / 1000, "busy": bb, **phases(sb)}
    probe = probe_ms(iv, t0, t1)
    cpu = cpu_ms(events, thread, t0, t1)
    return {"kind": kind, "s": sample["s"], "reply_s": sample["reply_s"],
            "phases_ms": dict(ph), "before_reply": before, "probe_ms": probe, "cpu_ms": cpu,
            "invalidations": invalidations(events, thread, t0, t1),
            "forced": forced(iv, t0, t1), "selfs": selfs}


def main(argv=None):
    from playwright.sync_api import sync_playwright
    ap = argparse.ArgumentParser(prog="python -m devtools.redrawtrace")
    ap.add_argument("url")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--save", help="a folder for the raw traces (last repeat)")
    ap.add_argument("--top", type=int, default=12)
    ap.add_argument("--light", action="store_true", help="the phases' categories only "
                    "(no invalidation tracking or stacks: less overhead, no causes)")
    ap.add_argument("--as-bench", action="store_true", help="first the bench's actions "
                    "before its mu change (two runs, a memory view, the PNG export, colour)")
    a = ap.parse_args(argv)
    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        try:
            for rep in range(a.repeats + 1):         # the first: warm-up, not counted
                session = Session(browser, a.url)
                frames = []
                session.page.on("websocket", lambda ws: ws.on(
                    "framereceived", lambda payload: frames.append(
                        (time.perf_counter(), len(payload)))))
                if a.as_bench:          # the page as browserbench has it at its mu change
                    from .browserbench import CLICKS
                    for point in CLICKS:
                        session.run(point, "deformable:")
                    try:        # (browserbench's known flake: a diagram that never came)
                        session.memory_view(1999.3)
                    except Exception as exc:        # noqa: BLE001 - said, not hidden
                        print(f"memory view failed: {type(exc).__name__}", file=sys.stderr)
                    session.tab("Downloads")
                    session.trajectory_png()
                    session.tab("Trajectory")
                    session.redraw_button("colour")
                steps = [("mu 0.1", lambda: session.redraw_select("mu (shipped maps)", "0.1")),
                         ("mu 0.3", lambda: session.redraw_select("mu (shipped maps)", "0.3")),
                         ("model point-mass", lambda: session.redraw_button("point-mass")),
                         ("model deformable", lambda: session.redraw_button("deformable"))]
                for kind, act in steps:
                    del frames[:]
                    t_start = time.perf_counter()
                    r = measure(browser, session, kind, act,
                                save=a.save if rep == a.repeats else None,
                                categories=CATEGORIES if a.light else CATEGORIES + CAUSES)
                    r["frames"] = [(round(t - t_start, 3), n) for t, n in frames
                                   if t - t_start < r["s"] + 0.3]
                    print(f"  websocket frames received (s from the start, bytes): "
                          f"{r['frames']}", file=sys.stderr)
                    r["repeat"] = rep
                    rows.append(r)
                    print(f"rep {rep} {kind}: {r['s']:.3f} s (reply {r['reply_s']}, "
                          f"main thread CPU {r['cpu_ms']:.0f} ms) "
                          + " ".join(f"{k} {v:.0f}" for k, v in sorted(r["phases_ms"].items())),
                          file=sys.stderr)
                session.close()
        finally:
            browser.close()
    measured = [r for r in rows if r["repeat"] > 0]
    report(measured, a.top)
    if a.json:
        print(json.dumps([{k: v for k, v in r.items() if k not in ("invalidations", "forced")}
                          for r in measured]))


def report(rows, top):
    import statistics
    by = collections.defaultdict(list)
    for r in rows:
        by[r["kind"].split()[0]].append(r)
    for kind, rs in by.items():
        print(f"\n== {kind} changes: {len(rs)}; bench time median "
              f"{statistics.median(r['s'] for r in rs):.3f} s, server's reply median "
              f"{statistics.median(r['reply_s'] or 0 for r in rs):.3f} s")
        keys = sorted({k for r in rs for k in r["phases_ms"]})
        print("phase totals (ms, mean per change): " + ", ".join(
            f"{k} {statistics.mean(r['phases_ms'].get(k, 0) for r in rs):.0f}" for k in keys))
        br = [r["before_reply"] for r in rs if r["before_reply"]]
        if br:
            bk = sorted({k for b in br for k in b})
            print("  before the server's last reply: " + ", ".join(
                f"{k} {statistics.mean(b.get(k, 0) for b in br):.0f}" for k in bk))
        print(f"  the main thread's CPU time (thread time of its tasks): "
              f"median {statistics.median(r['cpu_ms'] for r in rs):.0f} ms")
        print(f"  the bench's probe (its frame callbacks, what they forced included): "
              f"{statistics.mean(r['probe_ms'] for r in rs):.0f} ms")
        selfs = collections.Counter()
        for r in rs:
            selfs.update({k: v / len(rs) for k, v in r["selfs"].items()})
        print("  top events (self ms per change): " + ", ".join(
            f"{k} {v:.0f}" for k, v in selfs.most_common(top)))
        forced_ = collections.Counter()
        for r in rs:
            forced_.update({k: v / len(rs) for k, v in r["forced"].items()})
        print("  style/layout by where (ms per change):")
        for (n, where), v in forced_.most_common(top):
            print(f"    {v:6.1f}  {n:16s} {where}")
        inv = collections.Counter()
        for r in rs:
            inv.update(r["invalidations"])
        print("  invalidations (count over the changes):")
        for k, v in inv.most_common(top * 2):
            print(f"    {v:5d}  {' | '.join(k)}")


if __name__ == "__main__":
    main()
