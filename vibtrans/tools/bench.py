"""Speed benchmark: `vibtrans bench [--quick] [--json]`.

Everything is measured in one run, on one core, after JIT warm-up, as the
best of several repetitions (shared machines are noisy: compare the ratios,
which are measured side by side, more than the absolute times).

* ns per step of the vertical-only Hertz kernel and of the full deformable
  kernel on the same scene (paper point 1: permanent contact, all contact
  states), and their ratio (goal <= 2);
* ns per memory-diagram update alone, on a partial-slip/sliding history;
* seconds for a 2000-period standard scene at paper points 1, 4, 6
  (goal <= 0.1 s each);
* the chaos indicator's cost: a deformable scene measuring its Lyapunov
  exponent over the same scene alone (paper point 1, in contact, and the
  jumping scene log10 A* = 0.5, log10 m* = -2; goal <= 1.3), beside the
  twin's (scene plus tau twin over the scene alone, about 2);
* the particle profile's cost: ns per step of the deformable
  kernel at paper point 1 with a power-law tip (power:3; goal <= 1.2) and a
  tabulated law (flat-sphere:1, interpolated; goal <= 1.5) over the
  sphere's, measured round-robin; and the cost of the profile code itself:
  the sphere's own motion (same steps, same contact states) through the
  power-law path (p = 3/2, its root warm-started), through it with pow()
  at every evaluation, and through the table path (flat-sphere:0, the
  sphere tabulated) over Hertz's path (the profiles' own motions may differ
  from the sphere's: their share of stick, slip and flight steps);
* the rolling particle's cost (docs/MODEL.md section 11): ns per step of
  the rolling kernel on the motion of the particle that does not turn (its
  1/j so small that the contact point is x* exactly: the same records bit
  for bit) over the plain kernel's, at paper points 1, 4, 6, measured
  round-robin: the rolling code's own cost (goal <= 1.05); beside it the
  cost per step of the scenes with a solid and a shell particle, whose
  motion (share of stick, slip and sliding steps) is their own;
* each exact-to-rounding kernel shortcut (models.deformable.SHORT_*: the
  ramp G = 1 once exp(-t^2/tau^2) < 2^-60, sin/cos advanced by rotation)
  switched off alone: its speed-up and the drift difference it makes.

`vibtrans bench --work-precision [--quick] [--json] [--plot FILE]`: error
against cost of both integrators over a ladder of steps (vibtrans.tools.workprecision).

`vibtrans bench --export [--quick] [--json]`: seconds (wall and CPU) to
export the explorer's trajectory figure of paper point 8 at standard
fidelity with its tau twin (`export_bench`), to PNG, SVG and HTML, and each
over a plain one-panel matplotlib PNG's, measured round-robin in one run.

`vibtrans bench --cold-start`: also the cold start (`cold_start`), measured
first, before the bench pins itself to one core: the seconds of a first
`vibtrans simulate` at the README's point on an empty kernel cache, of the
same command on the now warm cache, and their ratio (goal: cold <= 12 s on
a 2-core machine).

`--results-dir DIR` (or `--output FILE`) also writes the run as a JSON
record: the results with the machine, its load and the git commit
(vibtrans.tools.results); `make bench` writes into benchmarks/results/.
"""

from __future__ import annotations

import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np

from vibtrans.analysis.summary import V0, drift_velocity
from vibtrans.core.errors import InputError
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import memory_history, new_memory, reset_memory
from vibtrans.core.params import paper_scene
from vibtrans.core.simulate import simulate


def _best(fn, repeat):
    best = float("inf")
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _interleaved_ns(runs, repeat):
    """Best ns/step of each (scene, simulate keywords) in `runs`, measured
    round-robin so that a noisy neighbour slows them alike."""
    steps = [simulate(sc, **kw).attrs["steps"] for sc, kw in runs]  # warm-up
    best = [float("inf")] * len(runs)
    for _ in range(repeat):
        for i, (sc, kw) in enumerate(runs):
            best[i] = min(best[i], simulate(sc, **kw).attrs["seconds"])
    return [1e9 * b / n for b, n in zip(best, steps)]


SHORTCUTS = {"ramp": D.SHORT_RAMP, "rotation": D.SHORT_ROTATION}


def _shortcut_effects(repeat, points=(1, 4, 6)):
    """Speed-up and result difference of each kernel shortcut, switched off
    alone, at paper points (non-chaotic, so a difference is the shortcut's)."""
    out = {}
    for name, bit in SHORTCUTS.items():
        for point in points:
            sc = paper_scene(point)
            on, off = _interleaved_ns([(sc, {}), (sc, {"shortcuts": D.SHORTCUTS_ALL & ~bit})], repeat)
            v_on = drift_velocity(simulate(sc))
            v_off = drift_velocity(simulate(sc, shortcuts=D.SHORTCUTS_ALL & ~bit))
            out[f"{name}, point {point}"] = {
                "speedup": off / on,
                "drift_difference": abs(v_on - v_off) / max(abs(v_off), V0),
            }
    return out


def _memory_ns(repeat, n=1_000_000):
    t = np.arange(n) / 256.0
    a = 1.0 + 0.8 * np.cos(2 * np.pi * t)  # strong load contrast
    b = 0.5 * np.sin(2 * np.pi * t) + 1e-3 * t  # stick, partial slip, sliding
    H, W, P, nvert, memf = new_memory(4096)
    out = np.empty((n, 3))
    memory_history(H, W, P, nvert, memf, a[:16], b[:16], out)  # warm-up

    def run():
        reset_memory(H, W, P, nvert, memf, 1.0, 0.0)
        memory_history(H, W, P, nvert, memf, a, b, out)

    best, _ = _best(run, repeat)
    states = np.bincount(out[:, 2].astype(int), minlength=4)
    return 1e9 * best / n, states


# `vibtrans simulate` at the README's point (paper point 4), its first run
# after an install compiling its kernels; the goal for that cold start
COLD_START_COMMAND = ("simulate", "--log-amplitude", "2.5", "--log-mass", "0", "--json")
COLD_START_GOAL_S = 12.0
COLD_START_GOAL_CORES = 2


def _timed_command(args, env):
    t0 = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "vibtrans.cli", *args],
        env=env,
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
    )
    seconds = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError(f"vibtrans {' '.join(args)} failed ({r.returncode}): {r.stderr.strip()[-2000:]}")
    return seconds


def cold_start(warm_repeat: int = 3) -> dict[str, Any]:
    """The cold start, measured in one run: `vibtrans simulate` at the
    README's point (COLD_START_COMMAND) in a new process whose kernel cache
    (NUMBA_CACHE_DIR, vibtrans.core.kernels.jit) is a new empty folder, then
    the same command on that folder, now filled (best of `warm_repeat`).
    Keys: cold_seconds, warm_seconds, cold_over_warm, the command, the goal
    (cold <= COLD_START_GOAL_S on a COLD_START_GOAL_CORES-core machine) and
    the cores this process may use."""
    cache = tempfile.mkdtemp(prefix="vibtrans-cold-cache-")
    env = {k: v for k, v in os.environ.items() if k != "VIBTRANS_JIT_CACHE"}
    env["NUMBA_CACHE_DIR"] = cache
    try:
        cold = _timed_command(COLD_START_COMMAND, env)
        warm = min(_timed_command(COLD_START_COMMAND, env) for _ in range(warm_repeat))
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count() or 1
    return {
        "command": "vibtrans " + " ".join(COLD_START_COMMAND),
        "cores": cores,
        "cold_seconds": cold,
        "warm_seconds": warm,
        "warm_repeat": warm_repeat,
        "cold_over_warm": cold / warm,
        "goal_cold_seconds": COLD_START_GOAL_S,
        "goal_cores": COLD_START_GOAL_CORES,
        "goal_cold_met": cold <= COLD_START_GOAL_S if cores <= COLD_START_GOAL_CORES else None,
    }


def _pin_one_core():
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        return True
    except (AttributeError, OSError):
        return False


def run(quick: bool = False) -> dict[str, Any]:
    repeat = 3 if quick else 7
    pinned = _pin_one_core()
    scene = paper_scene(1)
    vertical = scene.replace(model="vertical")
    exact = {"shortcuts": D.SHORTCUTS_ALL & ~D.SHORT_ROTATION}
    ns_def, ns_vert, ns_def_x, ns_vert_x = _interleaved_ns(
        [(scene, {}), (vertical, {}), (scene, exact), (vertical, exact)], repeat
    )
    ns_mem, states = _memory_ns(repeat)
    lyapunov = _lyapunov_cost(repeat)
    profiles = _profile_cost(repeat)
    rolling = rolling_cost(repeat)
    scenes = {}
    for point in (1, 4, 6):
        sc = paper_scene(point)
        simulate(sc)
        best, ds = _best(lambda: simulate(sc), repeat)  # noqa: B023 (called in this iteration)
        scenes[point] = {
            "seconds": best,
            "steps": int(ds.attrs["steps"]),
            "kernel_seconds": float(ds.attrs["seconds"]),
        }
    return {
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}",
        "pinned_to_one_core": pinned,
        "repeat": repeat,
        "vertical_ns_per_step": ns_vert,
        "deformable_ns_per_step": ns_def,
        "deformable_over_vertical": ns_def / ns_vert,
        "exact_trig_vertical_ns_per_step": ns_vert_x,
        "exact_trig_deformable_ns_per_step": ns_def_x,
        "exact_trig_deformable_over_vertical": ns_def_x / ns_vert_x,
        "shortcuts": _shortcut_effects(repeat),
        "memory_update_ns": ns_mem,
        "memory_states_stick_partial_sliding": [int(s) for s in states[1:]],
        "scene_seconds_2000_periods": scenes,
        "lyapunov_cost": lyapunov,
        "profile_cost": profiles,
        "rolling_cost": rolling,
    }


PROFILE_BENCH = {"power": "power:3", "tabulated": "flat-sphere:1"}


def _profile_same_motion_ns(repeat, point=1):
    """ns per step of the sphere's scene at a paper point through Hertz's
    path, the power-law path (p = 3/2: the sphere's law, n = 2: its root
    warm-started as power:3's is, contact.law_eval_warm), the table path
    (flat-sphere:0, the sphere tabulated) and the power-law path with pow()
    at every evaluation (no warm start: the path before it), with the
    sphere's step, measured round-robin: the same motion (to rounding), so
    the ratios are the profile code's own cost."""
    from vibtrans.core import drivers
    from vibtrans.core.kernels.contact import LAW_ROOT, kernel_law, power_kernel_law
    from vibtrans.core.profiles import FlatSphereProfile
    from vibtrans.core.simulate import SAMPLES_PER_PERIOD, hertz_params

    sc = paper_scene(point)
    p, _, cap = hertz_params(sc, math.inf, -math.inf, SAMPLES_PER_PERIOD, 1, D.SHORTCUTS_ALL, None)
    no_warm = power_kernel_law(2.0)
    no_warm[LAW_ROOT] = 0.0
    laws = [None, power_kernel_law(2.0), kernel_law(FlatSphereProfile(0.0)), no_warm]

    def once(law):
        t0 = time.perf_counter()
        run = drivers.run_hertz(p, sc.integrator, tangential=True, samples_capacity=cap, law=law)
        return time.perf_counter() - t0, int(run.ctr[R.C_STEPS])

    steps = [once(law)[1] for law in laws]  # warm-up
    best = [math.inf] * len(laws)
    for _ in range(repeat):
        for i, law in enumerate(laws):
            best[i] = min(best[i], once(law)[0])
    return [1e9 * b / n for b, n in zip(best, steps)], steps


def _profile_cost(repeat, point=1):
    """ns per step of the deformable kernel with each kind of profile law
    over the sphere's (its own Hertz path), at a paper point, round-robin."""
    sphere = paper_scene(point)
    runs: list[tuple] = [(sphere, {})] + [(sphere.replace(profile=p), {}) for p in PROFILE_BENCH.values()]
    ns = _interleaved_ns(runs, repeat)
    out = {"point": point, "sphere_ns_per_step": ns[0]}
    for (kind, spec), v in zip(PROFILE_BENCH.items(), ns[1:]):
        out[f"{kind}_profile"] = spec
        out[f"{kind}_ns_per_step"] = v
        out[f"{kind}_over_sphere"] = v / ns[0]
    same, steps = _profile_same_motion_ns(repeat, point)
    out["same_motion_steps"] = steps
    out["same_motion_sphere_ns_per_step"] = same[0]
    out["same_motion_power_over_sphere"] = same[1] / same[0]
    out["same_motion_tabulated_over_sphere"] = same[2] / same[0]
    out["same_motion_power_pow_over_sphere"] = same[3] / same[0]
    return out


# 1/j of the rolling kernel's same-motion run: 1 + 1/j == 1.0 exactly
SAME_MOTION_ROLL_RATIO = 1e-300


def rolling_cost(repeat: int, points: tuple[int, ...] = (1, 4, 6)) -> dict[str, Any]:
    """ns per step of the deformable kernel at paper points, round-robin in
    one process: the plain kernel; the rolling kernel on the same motion
    (1/j = SAME_MOTION_ROLL_RATIO: its contact point is x* exactly, its
    records the plain kernel's bit for bit), whose ratio is the rolling
    code's own cost; and the scenes of a solid and a shell particle
    (Scene rolling solid, shell), whose motion differs.  Per point: the
    ns per step, the ratios, whether the same-motion records are equal,
    and each run's share of stick, partial-slip and sliding samples.
    Timed in the calling thread's CPU time (the kernel runs there), best of
    3 x `repeat` rounds: a ratio of a few per cent needs more than the wall
    time of a shared machine gives."""
    from vibtrans.core import drivers
    from vibtrans.core.simulate import SAMPLES_PER_PERIOD, hertz_params

    out: dict[str, Any] = {}
    for point in points:
        sc = paper_scene(point)
        runs = {}
        for name, scene in (
            ("none", sc),
            ("solid", sc.replace(rolling="solid")),
            ("shell", sc.replace(rolling="shell")),
        ):
            p, _, cap = hertz_params(
                scene, math.inf, -math.inf, SAMPLES_PER_PERIOD, 1.0, D.SHORTCUTS_ALL, None
            )
            runs[name] = (p, cap)
        runs["same_motion"] = (runs["none"][0]._replace(roll_ratio=SAME_MOTION_ROLL_RATIO), runs["none"][1])
        integrator = sc.integrator

        def once(p, cap):
            t0 = time.thread_time()
            # (this point's integrator)
            run = drivers.run_hertz(p, integrator, tangential=True, samples_capacity=cap)  # noqa: B023
            return time.thread_time() - t0, run

        first = {name: once(*args)[1] for name, args in runs.items()}  # warm-up
        best = dict.fromkeys(runs, math.inf)
        for _ in range(3 * repeat):
            for name, args in runs.items():
                best[name] = min(best[name], once(*args)[0])
        ns = {name: 1e9 * best[name] / int(first[name].ctr[R.C_STEPS]) for name in runs}
        states = {
            name: [int(v) for v in np.bincount(first[name].samples[:, R.STATE].astype(int), minlength=4)[1:]]
            for name in runs
        }
        out[f"point {point}"] = {
            "ns_per_step": ns,
            "same_motion_over_none": ns["same_motion"] / ns["none"],
            "same_motion_records_equal": bool(
                np.array_equal(first["same_motion"].samples, first["none"].samples)
            ),
            "solid_over_none": ns["solid"] / ns["none"],
            "shell_over_none": ns["shell"] / ns["none"],
            "samples_stick_partial_sliding": states,
        }
    return out


def _lyapunov_cost(repeat):
    """ns per step of each scene alone, with its Lyapunov exponent and with
    its tau twin (twice the steps), measured round-robin: the ratios."""
    from vibtrans.analysis.summary import twin_scene

    out = {}
    for name, sc in (
        ("contact (paper point 1)", paper_scene(1)),
        ("jumping (log A* 0.5, log m* -2)", paper_scene(1).replace(amplitude=10**0.5, mass=10**-2.0)),
    ):
        alone, measured, twin = _interleaved_ns(
            [(sc, {}), (sc, {"lyapunov": True}), (twin_scene(sc), {})], repeat
        )
        out[name] = {
            "scene_ns_per_step": alone,
            "lyapunov_over_scene": measured / alone,
            "scene_plus_twin_over_scene": (alone + twin) / alone,
        }
    return out


def export_bench(quick: bool = False, point: int = 8) -> dict[str, Any]:
    """The explorer's trajectory export (its Export buttons call
    `export.export_trajectory(ds, out, twin=twin)`) of paper `point`'s
    scene as the explorer runs it: 2000 periods at standard fidelity,
    OVERVIEW_SAMPLES per period, the last FRAGMENT periods at full
    resolution, and its tau twin (point 8 hops and is chaotic: the twin is
    drawn).  Best of several round-robin repetitions of: the simulation of
    the reference (`_reference_png`, one plain matplotlib panel), the PNG,
    SVG and HTML exports; wall and CPU (process) seconds, and each export's
    CPU time over the reference's (the ratio is what to compare between
    machines and loads)."""
    import shutil
    import tempfile

    from vibtrans.analysis.summary import twin_scene
    from vibtrans.products import export, plots

    repeat = 2 if quick else 5
    scene = paper_scene(point)
    T = scene.periods

    ds = simulate(scene, window=(T - plots.FRAGMENT, T), samples_per_period=plots.OVERVIEW_SAMPLES)
    twin = simulate(twin_scene(scene), samples_per_period=plots.OVERVIEW_SAMPLES)
    formats = ("png", "svg", "html")
    tmp = tempfile.mkdtemp(prefix="vibtrans-bench-")
    wall = {k: float("inf") for k in ("reference", *formats)}
    cpu = dict(wall)
    try:
        jobs = {"reference": lambda: _reference_png(f"{tmp}/reference.png")}
        jobs["reference"]()
        for fmt in formats:
            jobs[fmt] = (lambda f: lambda: export.export_trajectory(ds, f"{tmp}/trajectory.{f}", twin=twin))(
                fmt
            )
            jobs[fmt]()  # warm-up: imports, fonts
        for _ in range(repeat):
            for name, job in jobs.items():
                w, c = time.perf_counter(), time.process_time()
                job()
                wall[name] = min(wall[name], time.perf_counter() - w)
                cpu[name] = min(cpu[name], time.process_time() - c)
    finally:
        shutil.rmtree(tmp)
    out = {
        "point": point,
        "samples": int(ds.sizes["time"]),
        "twin_samples": int(twin.sizes["time"]),
        "repeat": repeat,
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}",
        "load_average_1min": os.getloadavg()[0],
    }  # at the end of the measurements
    for name in wall:
        out[f"{name}_seconds"] = wall[name]
        out[f"{name}_cpu_seconds"] = cpu[name]
    for fmt in formats:
        out[f"{fmt}_over_reference"] = cpu[fmt] / cpu["reference"]
    return out


def _reference_png(out):
    """The stable reference of `export_bench`: one plain matplotlib panel
    (a 1000-point line, title, labels, legend) written to PNG at the
    exports' 150 dpi: what a machine and its load make of matplotlib."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = np.linspace(0.0, 10.0, 1000)
    fig = Figure(figsize=(5.0, 3.0), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.plot(t, np.sin(2 * np.pi * t), label="sin")
    ax.set_title("reference")
    ax.set_xlabel("t")
    ax.set_ylabel("y")
    ax.legend()
    fig.savefig(out, dpi=150)


def main(
    quick: bool = False,
    as_json: bool = False,
    sweep: bool = False,
    work_precision: bool = False,
    plot: Any = None,
    export: bool = False,
    cold: bool = False,
    results_dir: Any = None,
    output: Any = None,
    command: str | None = None,
) -> int:
    """`vibtrans bench`: run the bench the flags choose, print it (or one
    JSON object with `as_json`) and, with `results_dir` (a folder) or
    `output` (a file), write its record (vibtrans.tools.results; `command`:
    the command line it records, default this process's)."""
    from vibtrans.tools import results as results_file

    if plot is not None and not work_precision:
        raise InputError("plot: only bench --work-precision takes --plot")
    if cold and (work_precision or export or sweep):
        raise InputError(
            "cold-start: only the default bench (no --sweep, --export or --work-precision) takes --cold-start"
        )
    if results_dir is not None and output is not None:
        raise InputError(
            "results-dir and output: give one (a folder for a file named by "
            "the bench and its time, or the file)"
        )
    begun = results_file.begin()
    saved: dict[str, Any] = {}
    if work_precision:
        from vibtrans.tools.workprecision import main as wp_main

        pinned = _pin_one_core()
        status = wp_main(quick=quick, as_json=as_json, plot=plot, pinned=pinned, on_result=saved.update)
        name = "bench-work-precision"
    elif export:
        name = "bench-export"
        pinned = _pin_one_core()
        saved = export_bench(quick)
        saved["pinned_to_one_core"] = pinned
        status = _print_export(saved, quick, as_json)
    elif sweep:
        name = "bench-sweep"
        saved = sweep_bench(quick)
        if as_json:
            print(json.dumps(saved))
        else:
            for k, v in saved.items():
                print(f"  {k:>36}: {v:.4g}" if isinstance(v, float) else f"  {k:>36}: {v}")
        status = 0
    else:
        name = "bench"
        start = cold_start() if cold else None  # before run() pins this process
        saved = run(quick)
        if start is not None:
            saved["cold_start"] = start
        status = _print_run(saved, quick, as_json)
    if results_dir is not None or output is not None:
        saved["quick"] = quick
        record = results_file.result_record(name, saved, begun, command=command)
        path = results_file.write_result(record, folder=results_dir, output=output)
        print(f"results: {path}", file=sys.stderr)
    return status


def _print_export(r, quick, as_json):
    if as_json:
        print(json.dumps(r))
        return 0
    pinned = r["pinned_to_one_core"]
    print(
        f"vibtrans bench --export ({'quick' if quick else 'full'}; best of "
        f"{r['repeat']}; {r['machine']}; one core: {pinned}; load "
        f"{r['load_average_1min']:.1f})"
    )
    print(
        f"  paper point {r['point']}, standard, {r['samples']} samples + twin "
        f"{r['twin_samples']}; reference (one plain matplotlib panel to PNG): "
        f"{r['reference_seconds']:.3f} s wall, {r['reference_cpu_seconds']:.3f} s CPU"
    )
    for fmt in ("png", "svg", "html"):
        print(
            f"  trajectory export .{fmt:<4} {r[fmt + '_seconds']:6.2f} s wall, "
            f"{r[fmt + '_cpu_seconds']:6.2f} s CPU, {r[fmt + '_over_reference']:6.1f} x "
            "reference CPU" + ("   (goal <= 3 s)" if fmt == "png" else "")
        )
    return 0


def _print_run(r, quick, as_json):
    if as_json:
        print(json.dumps(r))
        return 0
    print(
        f"vibtrans bench ({'quick' if quick else 'full'}; best of {r['repeat']}; "
        f"{r['machine']}; one core: {r['pinned_to_one_core']})"
    )
    print(f"  vertical-only kernel   {r['vertical_ns_per_step']:8.1f} ns/step")
    print(f"  deformable kernel      {r['deformable_ns_per_step']:8.1f} ns/step")
    print(f"  ratio                  {r['deformable_over_vertical']:8.2f}   (goal <= 2)")
    print(
        f"  with exact sin/cos (rotation shortcut off): vertical "
        f"{r['exact_trig_vertical_ns_per_step']:.1f}, deformable "
        f"{r['exact_trig_deformable_ns_per_step']:.1f} ns/step, ratio "
        f"{r['exact_trig_deformable_over_vertical']:.2f}"
    )
    print(f"  memory-diagram update  {r['memory_update_ns']:8.1f} ns")
    for point, s in r["scene_seconds_2000_periods"].items():
        print(
            f"  paper point {point}, 2000 periods, standard: {s['seconds']:.4f} s "
            f"({s['steps']} steps)   (goal <= 0.1 s)"
        )
    for name, c in r["lyapunov_cost"].items():
        print(
            f"  chaos indicator, {name}: scene + Lyapunov exponent "
            f"{c['lyapunov_over_scene']:.2f} x scene (goal <= 1.3); scene + twin "
            f"{c['scene_plus_twin_over_scene']:.2f} x"
        )
    c = r["profile_cost"]
    print(
        f"  profiles, paper point {c['point']}: sphere {c['sphere_ns_per_step']:.1f} ns/step; "
        f"{c['power_profile']} {c['power_over_sphere']:.2f} x (goal <= 1.2); "
        f"{c['tabulated_profile']} {c['tabulated_over_sphere']:.2f} x (goal <= 1.5)"
    )
    print(
        f"  profile code, the sphere's own motion: power-law path "
        f"{c['same_motion_power_over_sphere']:.2f} x, table path "
        f"{c['same_motion_tabulated_over_sphere']:.2f} x Hertz's (power-law path with "
        f"pow() at every evaluation {c['same_motion_power_pow_over_sphere']:.2f} x)"
    )
    for point, c in r["rolling_cost"].items():
        print(
            f"  rolling, paper {point}: rolling kernel on the same motion "
            f"{c['same_motion_over_none']:.3f} x (goal <= 1.05; records equal: "
            f"{c['same_motion_records_equal']}); solid {c['solid_over_none']:.2f} x, shell "
            f"{c['shell_over_none']:.2f} x per step (their own motion)"
        )
    print("  shortcuts (each switched off alone): speed-up, relative drift difference")
    for k, e in r["shortcuts"].items():
        print(f"    {k:<20} x{e['speedup']:5.2f}   {e['drift_difference']:.1e}")
    cs = r.get("cold_start")
    if cs is not None:
        print(
            f"  cold start, {cs['command']}: {cs['cold_seconds']:.1f} s on an empty kernel "
            f"cache, {cs['warm_seconds']:.2f} s warm, ratio {cs['cold_over_warm']:.1f}   "
            f"(goal: cold <= {cs['goal_cold_seconds']:g} s on {cs['goal_cores']} cores; "
            f"{cs['cores']} here)"
        )
    return 0


# The sweep window: log10 A* in [-3, 3], log10 m* in [-5, 5], mu 0.5
SWEEP_WINDOW = ((-3.0, 3.0), (-5.0, 5.0))
SWEEP_MU = 0.5


def _window_sweep(points, **values):
    from vibtrans.maps.sweep import Sweep

    (a0, a1), (m0, m1) = SWEEP_WINDOW
    return Sweep(
        np.linspace(a0, a1, points), np.linspace(m0, m1, points), chunk_rows=1, mu=SWEEP_MU, **values
    )


def sweep_step_ratio(quick: bool = False) -> dict[str, Any]:
    """The figure of a sweep's overhead, measured in one run: a
    standard, 2000-period sweep of the 41 x 41 window (SWEEP_WINDOW; quick:
    11 x 11, 500 periods) on all local cores, as

        (wall seconds x cores) / (the points' integration steps x the
        vertical-only kernel's seconds per step on one core),

    the kernel timed round-robin in the same run.  1 would be a sweep that
    does nothing but vertical steps on every core; the deformable step
    itself costs ~1.9 of them (`vibtrans bench`).  The points judge chaos by
    their Lyapunov exponent (no twin runs).  Split in two factors:
    `sweep_kernel_step_ratio`, the points' kernel calls alone (by their own
    clocks, the cores all busy), and `sweep_overhead_factor`, the rest (the
    Python around each point, the store's writes, cores left waiting)."""
    import shutil
    import tempfile

    from vibtrans.core.simulate import warmup
    from vibtrans.maps.sweep import run_sweep

    warmup()
    points, periods = (11, 500.0) if quick else (41, 2000.0)
    sweep = _window_sweep(points, periods=periods)
    cores = os.cpu_count() or 1
    vertical = paper_scene(1).replace(model="vertical")
    (ns_before,) = _interleaved_ns([(vertical, {})], 3)
    tmp = tempfile.mkdtemp()
    try:
        t0 = time.perf_counter()
        run_sweep(sweep, f"{tmp}/s.zarr", workers=cores, progress=False)
        wall = time.perf_counter() - t0
        import xarray as xr

        store = xr.open_zarr(f"{tmp}/s.zarr", consolidated=False)
        steps = int(store["steps"].values.sum())
        kernel_seconds = float(store["seconds"].values.sum())
    finally:
        shutil.rmtree(tmp)
    (ns_after,) = _interleaved_ns([(vertical, {})], 3)
    ns = min(ns_before, ns_after)
    ratio = wall * cores / (steps * ns * 1e-9)
    kernels = kernel_seconds / (steps * ns * 1e-9)
    # the ratio split in two: the points' kernel calls alone (their own
    # clocks, all cores busy) and the rest (Python around each point,
    # waiting, writing the store) as a factor
    return {
        "sweep_points": points * points,
        "sweep_periods": periods,
        "cores": cores,
        "sweep_seconds": wall,
        "sweep_steps": steps,
        "vertical_ns_per_step": ns,
        "sweep_step_ratio": ratio,
        "sweep_kernel_step_ratio": kernels,
        "sweep_overhead_factor": ratio / kernels,
    }


def preview_window_times(quick: bool = False) -> dict[str, Any]:
    """The progressive preview: an adaptive preview, 500-period map of
    the same window (41 x 41 finest points, 3 levels: a 6 x 6 coarse grid;
    quick: 17 x 17, 2 levels, 200 periods) on all local cores; seconds to
    the first (coarse) image and to the complete map."""
    import shutil
    import tempfile

    from vibtrans.core.simulate import warmup
    from vibtrans.maps.adaptive import run_adaptive

    warmup()
    points, levels, periods = (17, 2, 200.0) if quick else (41, 3, 500.0)
    sweep = _window_sweep(points, periods=periods, fidelity="preview")
    first = []
    tmp = tempfile.mkdtemp()
    try:
        t0 = time.perf_counter()
        fraction = run_adaptive(
            sweep,
            f"{tmp}/a.zarr",
            levels,
            progress=False,
            on_level=lambda level, ds: first.append(time.perf_counter() - t0),
        )
        total = time.perf_counter() - t0
    finally:
        shutil.rmtree(tmp)
    return {
        "preview_points": points * points,
        "preview_levels": levels,
        "preview_periods": periods,
        "preview_computed_fraction": fraction,
        "preview_first_image_seconds": first[0],
        "preview_window_seconds": total,
    }


def sweep_bench(quick: bool = False) -> dict[str, Any]:
    """Points per second of a small sweep on 1 and 2 workers, processes vs
    threads, measured in one run (parallel efficiency = rate(2) / (2 rate(1)));
    then the sweep_step_ratio and the progressive preview's times."""
    import shutil
    import tempfile

    from vibtrans.maps.sweep import Sweep, parse_range, run_sweep

    grid = ("0:2:0.5", "-3:1:0.5") if quick else ("-1:2.5:0.25", "-3:2:0.25")
    sweep = Sweep(
        parse_range(grid[0], "a"), parse_range(grid[1], "m"), chunk_rows=1, periods=500.0 if quick else 2000.0
    )
    n = sweep.log_amplitude.size * sweep.log_mass.size
    out = {"points": n, "periods": sweep.values["periods"]}
    tmp = tempfile.mkdtemp()
    try:
        for executor in ("processes", "threads"):
            for workers in (1, 2):
                path = f"{tmp}/{executor}{workers}.zarr"
                t0 = time.perf_counter()
                run_sweep(sweep, path, workers=workers, progress=False, executor=executor)
                out[f"{executor}_{workers}_points_per_second"] = n / (time.perf_counter() - t0)
            out[f"{executor}_parallel_efficiency"] = out[f"{executor}_2_points_per_second"] / (
                2 * out[f"{executor}_1_points_per_second"]
            )
    finally:
        shutil.rmtree(tmp)
    out.update(sweep_step_ratio(quick))
    out.update(preview_window_times(quick))
    out.update(decided_trade(quick))
    return out


# The `decided` rule's trade: the shipped maps' grid (assets/maps: log10 A* -3:3:0.05,
# log10 m* -5:5:0.05, 121 x 201; tau 50, 2000 periods, standard, mu 0.3),
# every DECIDED_STRIDE-th point on both axes (the whole grid is ~4 minutes
# per map and rule on an idle 2-core machine), run with --stop full and
# --stop decided in one run.
SHIPPED_GRID = ("-3:3:0.05", "-5:5:0.05")
DECIDED_STRIDE = 4
DECIDED_MODELS = ("deformable", "point-mass")


def _strided(text, stride):
    start, stop, step = (float(v) for v in text.split(":"))
    return f"{start}:{stop}:{step * stride}"


def decided_trade(
    quick: bool = False, stride: int | None = None, keep: Any = None, models: Any = DECIDED_MODELS
) -> dict[str, Any]:
    """The speed/accuracy trade of the `decided` stopping rule,
    measured in one run: each model's sample of the shipped grid (every
    `stride`-th point; quick: a 6 x 6 sample over 500 periods) swept with
    stop="full" and with stop="decided", on all cores.  Keys:
    decided_speedup (full / decided CPU time of this process, the models
    together; decided_wall_speedup: the same in wall time);
    decided_class_agreement (drift class and contact agree, where neither
    map calls the point chaotic); decided_drift_within_error (regular
    drifting points of the full map, |v*| > V0 and not chaotic in either:
    |v_decided - v_full| <= STATED_DRIFT_ERROR x |v_full|); per model the
    same, the chaos verdicts' agreement, the fraction of each stop reason,
    the mean periods run, the rule's speedup ceiling on that map
    (speedup_ceiling: T_obs over the periods if its ran-to-end points ran
    T_obs and all others stopped at the earliest, maps.cost.minimum_periods)
    and estimate_ratio (maps.cost's estimate of the decided map's time from
    the full map's, over the measured time: the map-on-demand estimate's
    accuracy, goal within 1.5x).  keep: a folder to leave the four stores
    in (<model>-<stop>.zarr), for a difference map."""
    import os
    import shutil
    import tempfile

    from vibtrans.core.fidelity import STATED_DRIFT_ERROR
    from vibtrans.core.stopping import REASONS, STOP_RAN_TO_END
    from vibtrans.maps.cost import expected_time_share, minimum_periods
    from vibtrans.maps.sweep import Sweep, open_map, parse_range, run_sweep

    stride = (30 if quick else DECIDED_STRIDE) if stride is None else stride
    periods = 500.0 if quick else 2000.0
    la = parse_range(_strided(SHIPPED_GRID[0], stride), "log_amplitude")
    lm = parse_range(_strided(SHIPPED_GRID[1], stride), "log_mass")
    folder = keep or tempfile.mkdtemp()
    os.makedirs(folder, exist_ok=True)
    out: dict[str, Any] = {
        "decided_grid": f"{la.size} x {lm.size} (every {stride}th point of the shipped 121 x 201 grid)",
        "decided_periods": periods,
    }
    seconds = {"full": 0.0, "decided": 0.0}
    cpu = {"full": 0.0, "decided": 0.0}
    agree_n = agree_k = within_n = within_k = 0
    try:
        for model in models:
            maps = {}
            for stop in ("full", "decided"):
                path = f"{folder}/{model}-{stop}.zarr"
                shutil.rmtree(path, ignore_errors=True)
                sweep = Sweep(la, lm, chunk_rows=1, model=model, mu=0.3, periods=periods, stop=stop)
                c0, t0 = time.process_time(), time.perf_counter()
                run_sweep(sweep, path, progress=False)
                wall, used = time.perf_counter() - t0, time.process_time() - c0
                seconds[stop] += wall
                cpu[stop] += used
                out[f"decided_{model}_{stop}_seconds"] = wall
                out[f"decided_{model}_{stop}_cpu_seconds"] = used
                maps[stop] = open_map(path)
            full, dec = maps["full"], maps["decided"]
            regular = (full["chaotic"].values != 1) & (dec["chaotic"].values != 1)
            same = (full["drift"].values == dec["drift"].values) & (
                full["contact"].values == dec["contact"].values
            )
            vf, vd = full["drift_velocity"].values, dec["drift_velocity"].values
            drifting = regular & (np.abs(vf) > V0)
            ok = np.abs(vd - vf) <= STATED_DRIFT_ERROR["standard"] * np.abs(vf)
            out[f"decided_{model}_speedup"] = (
                out[f"decided_{model}_full_cpu_seconds"] / out[f"decided_{model}_decided_cpu_seconds"]
            )
            out[f"decided_{model}_wall_speedup"] = (
                out[f"decided_{model}_full_seconds"] / out[f"decided_{model}_decided_seconds"]
            )
            out[f"decided_{model}_class_agreement"] = float(same[regular].mean())
            out[f"decided_{model}_drift_within_error"] = (
                float(ok[drifting].mean()) if drifting.any() else None
            )
            out[f"decided_{model}_regular_drifting_points"] = int(drifting.sum())
            out[f"decided_{model}_mean_periods_run"] = float(dec["periods_run"].mean())
            # the rule's ceiling on this map: the points run to T_obs cost a full
            # run, the others at least the ramp and the first window (t_min)
            tau = float(dec.attrs["scene_tau"])
            f_end = float((dec["stop_reason"].values == STOP_RAN_TO_END).mean())
            out[f"decided_{model}_speedup_ceiling"] = periods / (
                f_end * periods + (1.0 - f_end) * min(periods, minimum_periods(tau))
            )
            # the map-on-demand estimate (maps.cost, the shipped-grid profile)
            # from the full map's time, against the decided map's measured time
            out[f"decided_{model}_estimate_ratio"] = (
                out[f"decided_{model}_full_cpu_seconds"]
                * expected_time_share(model, "decided", periods, tau)
                / out[f"decided_{model}_decided_cpu_seconds"]
            )
            out[f"decided_{model}_chaos_agreement"] = float(
                (full["chaotic"].values == dec["chaotic"].values).mean()
            )
            reasons = dec["stop_reason"].values
            for code, name in enumerate(REASONS):
                if code:
                    out[f"decided_{model}_{name}_fraction"] = float((reasons == code).mean())
            agree_n += int(regular.sum())
            agree_k += int(same[regular].sum())
            within_n += int(drifting.sum())
            within_k += int(ok[drifting].sum())
    finally:
        if keep is None:
            shutil.rmtree(folder, ignore_errors=True)
    # CPU time of this process (all its threads): on a machine shared with
    # other work, wall time measures the neighbours as much as the rule
    out["decided_speedup"] = cpu["full"] / cpu["decided"]
    out["decided_wall_speedup"] = seconds["full"] / seconds["decided"]
    out["decided_class_agreement"] = agree_k / agree_n if agree_n else None
    out["decided_drift_within_error"] = within_k / within_n if within_n else None
    return out
