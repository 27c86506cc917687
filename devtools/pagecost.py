"""What one page costs the server's event loop: building a session's page as
the server does (`explorer.serve_page`), then Bokeh's document checks
(`Document.validate`), after the warm-up's prerender of the shipped maps.
`page_cpu_s`: CPU time per page (steadier than wall time).  The goal: a
page <= 0.1 s.

    python -m devtools.pagecost [--pages N] [--json]
"""

import argparse
import json
import statistics
import sys
import time

from bokeh.document import Document
from panel.io.state import set_curdoc

from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import data
from vibtrans_explorer.views import map as map_view

from . import results


def _page():
    """(seconds to build a page, its CPU seconds, seconds of the checks, models)."""
    doc = Document()
    with set_curdoc(doc):
        t0, c0 = time.perf_counter(), time.process_time()
        E.serve_page()
        t1, c1 = time.perf_counter(), time.process_time()
        doc.validate()
        t2 = time.perf_counter()
    return t1 - t0, c1 - c0, t2 - t1, len(doc.models)


def run(pages):
    problems = data.preload()
    if problems:
        raise RuntimeError("; ".join(problems))
    map_view.prerender()  # as the server's warm-up
    for _ in range(2):  # warm-up: imports, caches
        _page()
    wall, cpu, checks = [], [], []
    for _ in range(pages):
        page, page_cpu, check, models = _page()
        wall.append(page)
        cpu.append(page_cpu)
        checks.append(check)
    return {
        "pages": pages,
        "page_s_served": statistics.median(wall),
        "page_cpu_s": statistics.median(cpu),
        "checks_s": statistics.median(checks),
        "page_and_checks_s": statistics.median(w + c for w, c in zip(wall, checks)),
        "models": models,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.pagecost", description=__doc__.splitlines()[0])
    ap.add_argument("--pages", type=results.bounded(int, 1, 200), default=10, help="pages to build")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    out = run(a.pages)
    if a.json:
        print(json.dumps(out))
    else:
        results.show(out, digits=4)
    return out


if __name__ == "__main__":
    main()
