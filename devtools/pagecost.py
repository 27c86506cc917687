"""What one page costs the server's event loop, which every session shares:
building a session's page (the explorer, its template attached to the
document; the run's figures are built when a run starts, the memory
diagram when its tab opens).  Pages are built in-process, alternately as
the server builds them (`explorer.create_app`: the page attached in one
pass) and plainly (the template's roots attached one at a time), so that
the ratio comes from one run on a shared machine; `page_cpu_s` is the
process's CPU time per page as served (less sensitive to other processes
than the wall-clock figures).  The shipped maps are prerendered first, as
the server's warm-up does: pages opened before it ends also stat the maps
not yet read (~0.02 s each).  A third kind, "own", as served but with
Bokeh's and Panel's own code instead of the server's cheaper lookups and
shortcuts (app/propertycache.py, app/panelshortcuts.py), gives their
effect as `own_over_served`.  Issue 14's goal: a page <= 0.1 s.

    python -m devtools.pagecost [--pages N] [--json]
"""
import argparse
import json
import statistics
import sys
import time

from bokeh.document import Document
from panel.io.state import set_curdoc

from vibtrans_explorer import data, panelshortcuts, propertycache
from vibtrans_explorer import explorer as E
from vibtrans_explorer.views import map as map_view


def _page(kind):
    """(seconds to build and attach a page, its CPU seconds, models in the
    document); kind: "plain", "served" or "own" (served without
    app/propertycache.py and app/panelshortcuts.py)."""
    doc = Document()
    if kind == "own":
        propertycache.uninstall()
        panelshortcuts.uninstall()
    try:
        with set_curdoc(doc):
            t0, c0 = time.perf_counter(), time.process_time()
            if kind == "plain":
                template = E.explorer_template(E.Explorer())
            else:
                template = E.create_app()
            template.server_doc(doc)
            t1, c1 = time.perf_counter(), time.process_time()
    finally:
        propertycache.install()           # as the server does (app/server.py)
        panelshortcuts.install()
    return t1 - t0, c1 - c0, len(doc.models)


KINDS = ("plain", "served", "own")


def run(pages):
    problems = data.preload()
    if problems:
        raise RuntimeError("; ".join(problems))
    # as a served explorer after its warm-up (app/server.py): every map
    # rendered and read, so a page's check of the shipped files stats none
    map_view.prerender()
    was_installed = propertycache.installed(), panelshortcuts.installed()
    try:
        for kind in KINDS + KINDS:                        # warm-up: imports, caches
            _page(kind)
        wall = {kind: [] for kind in KINDS}
        cpu = []
        for _ in range(pages):
            for kind in KINDS:
                page, page_cpu, models = _page(kind)
                wall[kind].append(page)
                if kind == "served":
                    cpu.append(page_cpu)
    finally:
        for module, was in zip((propertycache, panelshortcuts), was_installed):
            if not was:
                module.uninstall()
    plain, served, own = (statistics.median(wall[kind]) for kind in KINDS)
    return {"pages": pages, "page_s_plain": plain, "page_s_served": served,
            "served_over_plain": served / plain, "page_s_own": own,
            "own_over_served": own / served,
            "page_cpu_s": statistics.median(cpu), "models": models}


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.pagecost", description=__doc__.splitlines()[0])
    ap.add_argument("--pages", type=int, default=10, help="pages of each kind (1-200)")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if not 1 <= a.pages <= 200:
        ap.error(f"--pages must be in [1, 200], got {a.pages}")
    out = run(a.pages)
    if a.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:>24}: {v:.4f}" if isinstance(v, float) else f"{k:>24}: {v}")
    return out


if __name__ == "__main__":
    main()
