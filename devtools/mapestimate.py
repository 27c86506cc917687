"""How honest a map on demand's estimate is (issue 32, item 5): maps of
about 100 to 10^4 points, both models, computed by a fresh server's map
jobs (app/mapjobs.py, an empty cache) one after the other; for each, the
estimate the page shows before it starts against the time it took, and the
time to its first picture (the coarse level).

    python -m devtools.mapestimate             # the table
    python -m devtools.mapestimate --json      # the same, machine-readable
    python -m devtools.mapestimate --check     # exit 1 beyond the goals
    python -m devtools.mapestimate --quick     # the three smallest maps
    python -m devtools.mapestimate --own-work  # app/mapjobs.py's constants

Columns: the points computed against the estimate's expected count; the
share of T_obs the computed points ran, weighted by their work as the
estimate's share is, against that share; the estimate and the measured
time; their ratio; the first picture's time; the load average (1 min) as
the map was asked for.

--own-work measures what app/mapjobs.py's MAP_START_SECONDS,
POINT_PASSAGE_SECONDS and WORKER_PYTHON_SECONDS say: maps of 10-period
points (whose runs cost next to nothing) of 81 to 9409 points, each one's
wall time less its runs over the cores, fitted as a start plus a cost per
point computed; and a point's Python in its worker (cost.timed_point's
whole time less its run's), the median over 18 points.

Goals: measured / estimated within [1/1.5, 1.5] for every map; the first
map's coarse level within 3 s of its request.  The first map after the start
is the one a teacher waits for: it is measured as it comes (its workers
started by it), the others after it.  Each map is a new window, so none is
read from the cache.
"""
import argparse
import json
import os
import sys
import tempfile
import threading
import time

RATIO_GOAL = 1.5
FIRST_LEVEL_GOAL_S = 3.0

# (model, fidelity, cells, levels, window): finest grid cells * 2**levels + 1
# per axis: 9 x 9 = 81, 17 x 17 = 289, 33 x 33 = 1089, 65 x 65 = 4225,
# 97 x 97 = 9409 points; windows over the whole regime plane's middle
MAPS = [
    ("deformable", "standard", 4, 2, (-1.0, 1.0, -1.0, 1.0)),
    ("point-mass", "standard", 4, 1, (-0.5, 1.5, -1.0, 1.0)),
    ("deformable", "preview", 4, 1, (0.0, 2.0, -0.5, 1.5)),
    ("deformable", "preview", 4, 3, (-1.5, 1.5, -1.5, 1.5)),
    ("point-mass", "standard", 4, 3, (-1.0, 2.0, -1.0, 1.0)),
    ("deformable", "standard", 8, 3, (-1.0, 2.0, -1.0, 1.0)),
    ("deformable", "preview", 12, 3, (-2.0, 2.0, -2.0, 2.0)),
]


def computed_map(jobs, request, session):
    """Submit `request` and wait for it: (seconds to its first picture,
    seconds to done, the finished map's Dataset)."""
    done = threading.Event()
    times = {}
    t0 = time.perf_counter()

    def on_update(u):
        now = time.perf_counter() - t0
        if u.kind in ("level", "chunk"):
            times.setdefault("first", now)
        if u.final:
            times["done"] = now
            times["kind"] = u.kind
            times["ds"] = u.ds
            done.set()
    jobs.submit(session, request, on_update)
    done.wait()
    if times["kind"] != "done":
        raise SystemExit(f"the map ended {times['kind']}")
    return times.get("first", times["done"]), times["done"], times["ds"]


def run_map(jobs, request, session):
    """(estimate, seconds to the first picture, seconds to done, points
    computed) of one map."""
    est, problems = jobs.estimate(request)
    if problems:
        raise SystemExit(f"refused: {problems}")
    first, took, ds = computed_map(jobs, request, session)
    computed = ds["computed"].values
    # the share of T_obs its computed points ran (1 for full runs), weighted
    # by each point's work as the estimate's share is (MapJobs.expected_work)
    work = jobs.expected_work(request)[0][computed]
    share = (float((work * ds["periods_run"].values[computed]).sum() / work.sum())
             / request.periods if "periods_run" in ds else 1.0)
    return est, first, took, int(computed.sum()), share


def own_work():
    """(start seconds, seconds per point computed, worker Python seconds,
    rows): app/mapjobs.py's constants measured on this host."""
    import numpy as np
    from vibtrans.maps.cost import timed_point
    from vibtrans_explorer import mapjobs, maprequest
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        jobs = mapjobs.MapJobs(folder=folder)
        jobs.start_helpers()
        first = maprequest.MapRequest(model="deformable", fidelity="standard", cells=4,
                                      levels=1)
        python = []
        for repeat in range(3):
            for la in (-1.0, 0.0, 1.0):
                for lm in (-1.0, 0.0, 1.0):
                    point, whole = timed_point(first.scene_values(), la, lm,
                                               maprequest.CHAOS, first.stop)
                    if repeat:                  # the first round warms up
                        python.append(whole - point["seconds"])
        # the first map starts the workers: measured, not fitted
        for i, (model, _, cells, levels, (a0, a1, m0, m1)) in enumerate(
                [MAPS[2], MAPS[2], MAPS[0], *MAPS[3:]]):
            request = maprequest.MapRequest(model=model, fidelity="preview", cells=cells,
                                            levels=levels, la_from=a0 + 0.01 * i, la_to=a1,
                                            lm_from=m0, lm_to=m1, periods=10.0)
            _, wall, ds = computed_map(jobs, request, f"own-{i}")
            computed = ds["computed"].values
            runs = float(np.nansum(ds["seconds"].values[computed]))
            rows.append({"points": request.points(), "computed": int(computed.sum()),
                         "wall_s": wall, "runs_s": runs, "own_s": wall - runs / jobs.cores})
        jobs.stop_workers()
    fitted = rows[1:]
    n = np.array([r["computed"] for r in fitted], dtype=float)
    own = np.array([r["own_s"] for r in fitted])
    start, per_point = np.linalg.lstsq(np.column_stack([np.ones_like(n), n]), own,
                                       rcond=None)[0]
    return float(start), float(per_point), float(np.median(python)), rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--check", action="store_true")
    parser.add_argument("--quick", action="store_true", help="the three smallest maps")
    parser.add_argument("--own-work", action="store_true",
                        help="measure app/mapjobs.py's constants of a map's own work")
    args = parser.parse_args(argv)
    from vibtrans_explorer import kernels, mapjobs, maprequest
    kernels.start()
    kernels.wait()
    if args.own_work:
        start, per_point, python, rows = own_work()
        if args.json:
            print(json.dumps({"start_s": start, "per_point_s": per_point,
                              "worker_python_s": python, "maps": rows}, indent=1))
        else:
            for r in rows:
                print(f"{r['points']:6d} points, {r['computed']:5d} computed: "
                      f"{r['wall_s']:6.2f} s, runs {r['runs_s']:5.2f} s, own {r['own_s']:6.2f} s")
            print(f"own work: {start:.2f} s + {per_point * 1e3:.2f} ms a point computed "
                  f"(the first map, which starts the workers, left out); a point's Python "
                  f"in its worker {python * 1e3:.2f} ms; load average {os.getloadavg()[0]:.1f}")
        return 0
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        jobs = mapjobs.MapJobs(folder=folder)
        jobs.start_helpers()
        for i, (model, fidelity, cells, levels, (a0, a1, m0, m1)) in enumerate(
                MAPS[:3] if args.quick else MAPS):
            request = maprequest.MapRequest(model=model, fidelity=fidelity, cells=cells,
                                            levels=levels, la_from=a0, la_to=a1,
                                            lm_from=m0, lm_to=m1)
            load = os.getloadavg()[0]
            est, first, took, computed, share = run_map(jobs, request, f"bench-{i}")
            rows.append({"load": load, "model": model, "fidelity": fidelity,
                         "points": request.points(),
                         "computed": computed, "expected_computed": est.computed,
                         "share_run": share, "expected_share": est.share,
                         "estimated_s": est.seconds,
                         "measured_s": took, "first_picture_s": first,
                         "ratio": took / est.seconds if est.seconds else None})
        jobs.stop_workers()
    ok = all(r["ratio"] is not None and 1 / RATIO_GOAL <= r["ratio"] <= RATIO_GOAL
             for r in rows) and rows[0]["first_picture_s"] <= FIRST_LEVEL_GOAL_S
    if args.json:
        print(json.dumps({"maps": rows, "ratio_goal": RATIO_GOAL,
                          "first_level_goal_s": FIRST_LEVEL_GOAL_S, "ok": ok}, indent=1))
    else:
        print(f"{'model':>11} {'fidelity':>8} {'points':>6} {'computed':>8} {'expected':>8} "
              f"{'ran':>5} {'expected':>8} {'estimated':>9} {'measured':>8} {'ratio':>6} "
              f"{'first':>6} {'load':>5}")
        for r in rows:
            est = f"{r['estimated_s']:9.1f}" if r["estimated_s"] else f"{'-':>9}"
            ratio = f"{r['ratio']:6.2f}" if r["ratio"] else f"{'-':>6}"
            print(f"{r['model']:>11} {r['fidelity']:>8} {r['points']:>6} {r['computed']:>8} "
                  f"{r['expected_computed']:8.0f} {r['share_run']:5.2f} "
                  f"{r['expected_share']:8.2f} {est} {r['measured_s']:8.1f} {ratio} "
                  f"{r['first_picture_s']:6.1f} {r['load']:5.1f}")
        print(f"goals: ratio within 1/{RATIO_GOAL:g}..{RATIO_GOAL:g}, the first map's coarse "
              f"level within {FIRST_LEVEL_GOAL_S:g} s: {'met' if ok else 'NOT met'}")
    return 0 if ok or not args.check else 1


if __name__ == "__main__":
    sys.exit(main())
