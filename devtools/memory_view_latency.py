"""Server-side latency of the explorer's memory view (app/views/memory.py):
the time per scrub step (a slider move: its snapshot drawn into the
figures' sources) and per click (a typed time: memory_snapshot from rest,
then drawn), each including the Bokeh patch message the server sends
(events collected from the session's document and serialized), and the
background run that computes the slider's snapshots.

    python -m devtools.memory_view_latency [--point 9] [--fidelity preview] [--repeat 5]

Prints medians and maxima of wall and CPU seconds.  Compare with the
HoloViews rendering the view replaces (plots.memory_diagram +
plots.contact_circle rendered to Bokeh models and serialized), measured in
the same run.
"""
import argparse
import asyncio
import statistics
import time
from concurrent.futures import ThreadPoolExecutor

import holoviews as hv
import panel as pn
from bokeh.document import Document
from bokeh.protocol import Protocol

from vibtrans import paper_scene
from vibtrans.products import plots
from vibtrans.core.simulate import memory_snapshot, memory_snapshots
from vibtrans_explorer.views.memory import MemoryView, snapshot_times


def _timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - w, time.process_time() - c, out


def _say(name, samples):
    wall = [s[0] for s in samples]
    cpu = [s[1] for s in samples]
    print(f"{name:46s} wall median {statistics.median(wall) * 1e3:8.1f} ms, "
          f"max {max(wall) * 1e3:8.1f} ms; CPU median {statistics.median(cpu) * 1e3:8.1f} ms"
          f" (n = {len(samples)})")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--point", type=int, default=9)
    ap.add_argument("--fidelity", default="preview")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    scene = paper_scene(args.point).replace(model="deformable", fidelity=args.fidelity)
    T = scene.periods
    memory_snapshot(scene, 1.0)                      # kernels loaded
    pool = ThreadPoolExecutor(2)
    doc = Document()
    view = MemoryView(pool)
    root = view.__panel__().get_root(doc)
    doc.add_root(root)
    events = []
    doc.on_change(events.append)
    protocol = Protocol()

    def sent(fn):
        """fn() and the patch message of what it changed, serialized."""
        events.clear()
        fn()
        if events:
            msg = protocol.create("PATCH-DOC", list(events))
            return len(msg.content_json) + sum(len(b.data) for b in msg.buffers)
        return 0

    async def run():
        view.set_run(scene, T)
        while view._job is not None:
            await asyncio.sleep(0.005)

    for _ in range(2):
        asyncio.run(run())             # warm: the figures' first data
    runs = [_timed(lambda: memory_snapshots(scene, list(snapshot_times(T))))
            for _ in range(args.repeat)]
    steps, sizes = [], []
    for _ in range(args.repeat):
        for t in view.times:
            w, c, n = _timed(lambda: sent(lambda: setattr(view.slider, "value", float(t))))
            steps.append((w, c))
            sizes.append(n)
    clicks = []
    for k in range(args.repeat):
        t = round(0.5 * T + 7.3 * k, 3)

        def click():
            view.time_field.input.value = f"{t:g}"
            asyncio.run(view.show_at())
        clicks.append(_timed(lambda: sent(click))[:2])
    computes = [_timed(lambda: memory_snapshot(scene, round(0.5 * T + 7.3 * k, 3)))[:2]
                for k in range(args.repeat)]
    hv.extension("bokeh")
    snap = view.snapshots[-1]

    def holoviews():
        fig = plots.memory_diagram(snap) + plots.contact_circle(snap)
        d = Document()
        d.add_root(hv.render(fig, backend="bokeh"))
        return len(str(d.to_json()))
    holo = [_timed(holoviews)[:2] for _ in range(args.repeat)]
    print(f"scene {args.point}, {args.fidelity}, T = {T:g} periods; panel {pn.__version__}")
    _say(f"background: {len(view.times)} snapshots (one run)", runs)
    _say("scrub step (draw + patch message)", steps)
    print(f"{'':46s} patch message {statistics.median(sizes) / 1e3:.1f} kB median")
    _say("click: memory_snapshot from rest alone", computes)
    _say("click: compute + draw + patch message", clicks)
    _say("replaced: HoloViews render + serialize", holo)
    pool.shutdown()


if __name__ == "__main__":
    main()
