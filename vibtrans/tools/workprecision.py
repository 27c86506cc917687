"""Work-precision study (`vibtrans bench --work-precision [--quick] [--json]
[--plot FILE]`): what each integrator and step costs, and what it buys.

Every scene of `CASES` runs with both integrators on a ladder of steps
(`simulate(steps=(per period, per contact time scale))`) against AB4 at the
reference preset refined twice.  Each point reports its cost (steps, kernel
seconds best of a few, wall seconds); its drift error |v - v_ref| /
max(|v_ref|, V0), the larger of the mean's and the final window's (V0 the
floor: a scene that does not drift has no relative error); and its
trajectory error, max |dx*|, |dy*| over the first `traj_periods` of a run
with a fast ramp (tau = TRAJ_TAU), read by quintic Hermite interpolation
(O(h^6), far below the integrators').  A scene its tau + 1e-3 twin
contradicts is flagged chaotic and left out of the preset summary.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from vibtrans.analysis.summary import V0, chaos_verdict, drift_velocity, final_drift_velocity
from vibtrans.core import fidelity as F
from vibtrans.core.errors import InputError
from vibtrans.core.params import Scene, paper_scene
from vibtrans.core.simulate import simulate

if TYPE_CHECKING:
    import xarray as xr

INTEGRATORS = ("ab4", "verlet")
TRAJ_TAU = 2.0  # ramp of the trajectory runs, periods
GRID = 256  # trajectory comparison grid, points per period
TIMING_BUDGET = 0.3  # repeat a run until its kernel seconds add up to this...
TIMING_REPEATS = 7  # ...or this many runs (best one kept)
BLOWUP = 10.0  # |x*| or |y*| over BLOWUP (1 + max of the reference's): unstable


class Case(NamedTuple):
    name: str
    scene: Scene
    traj_periods: float  # trajectory error over [0, traj_periods]


class Setting(NamedTuple):
    label: str
    per_period: float  # steps per wave period
    per_contact: float  # steps per shortest contact time scale


def _corner(amplitude, mass, **values):
    return Scene(amplitude=amplitude, mass=mass, **values)


# Corners (non-chaotic): m* = 1e-5 at A* = 1e3 is the stiffest scene (8200
# steps per period at "standard"; short runs keep its reference affordable);
# m* = 1e-5 at A* = 1e-3 has its step set by the linear contact oscillation,
# where a contact step too coarse for AB4 shows as an instability; A* = 1e3,
# m* = 1 hops synchronously; m* = 1e5 is the most violent (long flights).
CASES = (
    Case("point 1", paper_scene(1), 20.0),
    Case("point 2", paper_scene(2), 20.0),
    Case("point 4", paper_scene(4), 20.0),
    Case("point 6", paper_scene(6), 20.0),
    Case("point 7", paper_scene(7), 20.0),
    Case("light m*=1e-5 A*=1e3", _corner(1e3, 1e-5, periods=100.0), 5.0),
    Case("light m*=1e-5 A*=1e-3", _corner(1e-3, 1e-5, periods=100.0), 5.0),
    Case("large A*=1e3 m*=1", _corner(1e3, 1.0), 20.0),
    Case("heavy m*=1e5 A*=1e3", _corner(1e3, 1e5), 20.0),
)
# CI size (seconds): point 2's step is set by the contact time scale, the others' by the period
QUICK_CASES = (
    Case("point 1", paper_scene(1, periods=200.0), 10.0),
    Case("point 2", paper_scene(2, periods=200.0), 10.0),
    Case("point 4", paper_scene(4, periods=500.0), 10.0),
    Case("point 6", paper_scene(6, periods=200.0), 10.0),
)


# "P/C": P steps per period, C per contact time scale; 24/4 and 24/8 are below
# AB4's stability limit (C >= ~15) but not Verlet's (C > pi)
def _preset(name, k=1):
    """The preset `name`'s steps, k times finer."""
    p, c = F.FIDELITY[name]
    return Setting(name if k == 1 else f"{name} x{k}", k * p, k * c)


LADDER = (
    *(Setting(f"{p}/{c}", p, c) for p, c in ((24, 4), (24, 8), (16, 16), (24, 16), (32, 16))),
    _preset("preview"),
    _preset("preview", 2),
    _preset("standard"),
    _preset("standard", 2),
    _preset("standard", 4),
    _preset("reference"),
)
QUICK_LADDER = (Setting("32/16", 32, 16), LADDER[5], LADDER[7], LADDER[8])
REFERENCE = _preset("reference", 2)
QUICK_REFERENCE = LADDER[-1]


class Point(NamedTuple):
    """One (scene, integrator, step) of the study."""

    scene: str
    integrator: str
    setting: str  # ladder label ("preview", "standard", ... are the presets)
    steps_per_period: float  # 1 / h
    h: float  # step, periods
    steps: int  # committed steps of the drift run
    seconds: float  # kernel seconds of the drift run (best of repeats)
    wall_seconds: float  # wall seconds of simulate (drift run)
    drift_velocity: float
    final_drift_velocity: float
    drift_error: float  # max of the mean and final-window relative errors
    mean_drift_error: float
    final_drift_error: float
    traj_error_x: float  # max |dx*| over the first traj_periods periods
    traj_error_y: float
    traj_error: float  # max of the two
    traj_periods: float
    stable: bool  # False: the run failed, gave non-finite values or blew up
    chaotic: bool  # the scene's tau + 1e-3 twin disagrees
    reference_drift: float


# ------------------------------------------------------------------ running
def run_setting(scene: Scene, setting: Any, integrator: str, **kw: Any) -> xr.Dataset:
    """simulate(scene) with the step of `setting` and `integrator`."""
    return simulate(
        scene.replace(integrator=integrator),
        steps=(setting.per_period, setting.per_contact),
        max_steps=math.inf,
        **kw,
    )


def _timed_drift_run(scene, setting, integrator, repeat=True):
    t0 = time.perf_counter()
    ds = run_setting(scene, setting, integrator)
    wall = time.perf_counter() - t0
    best = float(ds.attrs["seconds"])
    spent, n = best, 1
    while repeat and spent < TIMING_BUDGET and n < TIMING_REPEATS:
        s = float(run_setting(scene, setting, integrator).attrs["seconds"])
        best, spent, n = min(best, s), spent + s, n + 1
    return ds, best, wall


def _trajectory_run(case, setting, integrator):
    T = case.traj_periods
    sc = case.scene.replace(tau=TRAJ_TAU, periods=T)
    return run_setting(sc, setting, integrator, window=(0.0, T), samples_per_period=1)


def hermite(ds: xr.Dataset, tq: Any) -> tuple[Any, Any]:
    """(x*, y*) at times tq of a run recorded at every step: quintic Hermite
    interpolation of position, velocity and acceleration (from T*, N*)."""
    t = ds["time"].values
    keep = np.concatenate([[True], np.diff(t) > 0])  # drop repeated instants
    t = t[keep]
    m, mu = float(ds.attrs["mass"]), float(ds.attrs["mu"])
    i = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, t.size - 2)
    d = t[i + 1] - t[i]
    s = (tq - t[i]) / d
    s2, s3 = s * s, s * s * s
    s4, s5 = s3 * s, s3 * s2
    h00 = 1 - 10 * s3 + 15 * s4 - 6 * s5
    h10 = s - 6 * s3 + 8 * s4 - 3 * s5
    h20 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5
    h01 = 10 * s3 - 15 * s4 + 6 * s5
    h11 = -4 * s3 + 7 * s4 - 3 * s5
    h21 = 0.5 * s3 - s4 + 0.5 * s5
    out = []
    for pos, vel, acc in (("x", "vx", -mu * ds["T"].values / m), ("y", "vy", (1.0 - ds["N"].values) / m)):
        p = ds[pos].values[keep]
        v = ds[vel].values[keep]
        a = acc[keep]
        out.append(
            h00 * p[i]
            + h10 * d * v[i]
            + h20 * d * d * a[i]
            + h01 * p[i + 1]
            + h11 * d * v[i + 1]
            + h21 * d * d * a[i + 1]
        )
    return out[0], out[1]


def trajectory_error(ds: xr.Dataset, ref: Any, periods: float, grid: Any = GRID) -> tuple[float, float]:
    """(max |dx*|, max |dy*|) over [0, periods] on a grid of `grid` per period."""
    tq = np.linspace(0.0, periods, int(round(periods * grid)) + 1)
    x1, y1 = hermite(ds, tq)
    x0, y0 = hermite(ref, tq)
    return float(np.max(np.abs(x1 - x0))), float(np.max(np.abs(y1 - y0)))


def _rel(v, v_ref, floor=V0):
    return abs(v - v_ref) / max(abs(v_ref), floor)


def _finite(ds):
    return all(np.isfinite(ds[k].values).all() for k in ("x", "vx", "y", "vy"))


def _bounded(ds, ref):
    """|x*|, |y*| within BLOWUP (1 + the reference's extent): an unstable AB4
    step launches the particle (y* ~ 1e8) rather than overflow."""
    return all(
        np.max(np.abs(ds[k].values)) <= BLOWUP * (1.0 + np.max(np.abs(ref[k].values))) for k in ("x", "y")
    )


def study(
    quick: bool = False,
    cases: Any = None,
    ladder: Any = None,
    reference: Any = None,
    integrators: Any = INTEGRATORS,
    progress: Any = None,
) -> list[Any]:
    """The study: a `Point` per scene, integrator and ladder setting."""
    cases = cases or (QUICK_CASES if quick else CASES)
    ladder = ladder or (QUICK_LADDER if quick else LADDER)
    reference = reference or (QUICK_REFERENCE if quick else REFERENCE)
    simulate(cases[0].scene.replace(periods=1.0))  # JIT warm-up
    points = []
    for case in cases:
        t0 = time.perf_counter()
        ref = run_setting(case.scene, reference, "ab4")
        ref_traj = _trajectory_run(case, reference, "ab4")
        base = simulate(case.scene, max_steps=math.inf)
        twin = simulate(case.scene.replace(tau=case.scene.tau + 1e-3), max_steps=math.inf)
        chaotic = bool(chaos_verdict(base, twin))
        v_ref, vf_ref = drift_velocity(ref), final_drift_velocity(ref)
        del base, twin
        for integrator in integrators:
            done: dict = {}  # h -> Point (settings that give the same step)
            for setting in ladder:
                h = _step(case.scene, setting)
                if h in done:
                    points.append(done[h]._replace(setting=setting.label))
                    continue
                p = _point(case, setting, integrator, ref, ref_traj, v_ref, vf_ref, chaotic)
                done[h] = p
                points.append(p)
        if progress is not None:
            progress(f"{case.name}: {time.perf_counter() - t0:.1f} s")
    return points


def _step(scene, setting):
    per_period, per_contact = setting.per_period, setting.per_contact
    return min(1.0 / per_period, F.contact_time_scale(scene.amplitude, scene.mass) / per_contact)


def _point(case, setting, integrator, ref, ref_traj, v_ref, vf_ref, chaotic):
    nan, inf = math.nan, math.inf
    h = _step(case.scene, setting)
    try:
        ds, seconds, wall = _timed_drift_run(case.scene, setting, integrator)
        traj = _trajectory_run(case, setting, integrator)
        stable = _finite(ds) and _finite(traj) and _bounded(ds, ref) and _bounded(traj, ref_traj)
    except (ValueError, FloatingPointError, ZeroDivisionError, OverflowError):
        ds, stable = None, False
    head, tail = (case.name, integrator, setting.label), (case.traj_periods, stable, chaotic, v_ref)
    if not stable:
        cost: tuple[int, float, float] = (
            (0, nan, nan) if ds is None else (int(ds.attrs["steps"]), seconds, wall)
        )
        return Point(*head, 1.0 / h, h, *cost, nan, nan, inf, inf, inf, inf, inf, inf, *tail)
    v, vf = drift_velocity(ds), final_drift_velocity(ds)
    ex, ey = trajectory_error(traj, ref_traj, case.traj_periods)
    em, ef = _rel(v, v_ref), _rel(vf, vf_ref)
    h = float(ds.attrs["h"])  # the same as _step's
    errors = (max(em, ef), em, ef, ex, ey, max(ex, ey))
    return Point(*head, 1.0 / h, h, int(ds.attrs["steps"]), seconds, wall, v, vf, *errors, *tail)


# ----------------------------------------------------------------- analysis
def pareto_front(points: Any, scene: Scene, error: str = "drift_error", cost: str = "seconds") -> list[Any]:
    """One scene's points that no other beats on both cost and error, by cost."""
    pts = sorted(
        (p for p in points if p.scene == scene and p.stable),
        key=lambda p: (getattr(p, cost), getattr(p, error)),
    )
    front, best = [], math.inf
    for p in pts:
        e = getattr(p, error)
        if e < best:
            front.append(p)
            best = e
    return front


def pareto_fronts(points: Any, error: str = "drift_error", cost: str = "seconds") -> dict[Any, list[Any]]:
    """{scene: pareto_front} of every scene."""
    scenes = list(dict.fromkeys(p.scene for p in points))
    return {s: pareto_front(points, s, error, cost) for s in scenes}


class PresetSummary(NamedTuple):
    setting: str
    integrator: str
    max_drift_error: float  # over the non-chaotic scenes
    worst_scene: str
    max_drift_error_drifting: float  # over the non-chaotic scenes with |v_ref| > V0
    worst_drifting_scene: str
    max_traj_error: float
    seconds: float  # total kernel seconds, non-chaotic scenes
    steps: int
    speed_vs_standard: float  # total seconds of standard AB4 / total seconds here
    min_speed_vs_standard: float  # the smallest per-scene ratio
    steps_vs_standard: float  # total steps of standard AB4 / total steps here


def preset_summary(points: Any, settings: Any = None, baseline: tuple = ("standard", "ab4")) -> list[Any]:
    """Per setting (default: the presets) and integrator, the max drift error
    over the non-chaotic scenes and the speed against `baseline`."""
    settings = settings or [s for s in F.FIDELITY if any(p.setting == s for p in points)]
    ok = [p for p in points if not p.chaotic]
    base = {p.scene: p for p in ok if (p.setting, p.integrator) == baseline}
    out = []
    for s in settings:
        for integ in dict.fromkeys(p.integrator for p in ok):
            pts = [p for p in ok if p.setting == s and p.integrator == integ and p.scene in base]
            if not pts:
                continue
            worst = max(pts, key=lambda p: p.drift_error)
            drifting = [p for p in pts if abs(p.reference_drift) > V0]
            worst_d = max(drifting, key=lambda p: p.drift_error) if drifting else None
            sec = sum(p.seconds for p in pts)
            steps = sum(p.steps for p in pts)
            wd: tuple[float, str] = (worst_d.drift_error, worst_d.scene) if worst_d else (math.nan, "")
            speed: tuple[float, float, float] = (
                sum(base[p.scene].seconds for p in pts) / sec,
                min(base[p.scene].seconds / p.seconds for p in pts),
                sum(base[p.scene].steps for p in pts) / max(steps, 1),
            )
            out.append(
                PresetSummary(
                    s,
                    integ,
                    worst.drift_error,
                    worst.scene,
                    *wd,
                    max(p.traj_error for p in pts),
                    sec,
                    steps,
                    *speed,
                )
            )
    return out


# ------------------------------------------------------------------ report
def table(points: Any) -> str:
    """The study as text, one line per point."""
    lines = [
        f"{'scene':<22} {'integ':<6} {'setting':<12} {'steps/T':>8} {'steps':>9} "
        f"{'seconds':>8} {'wall':>7} {'drift err':>9} {'traj err':>9} {'dx':>9} {'dy':>9}"
    ]
    for p in points:
        flag = "" if p.stable else "  UNSTABLE"
        flag += "  (chaotic)" if p.chaotic else ""
        lines.append(
            f"{p.scene:<22} {p.integrator:<6} {p.setting:<12} "
            f"{p.steps_per_period:8.0f} {p.steps:9d} {p.seconds:8.4f} "
            f"{p.wall_seconds:7.3f} {p.drift_error:9.2e} {p.traj_error:9.2e} "
            f"{p.traj_error_x:9.2e} {p.traj_error_y:9.2e}{flag}"
        )
    return "\n".join(lines)


def summary_table(summaries: Any) -> str:
    """The preset summaries as text, a line each."""
    lines = [
        f"{'setting':<12} {'integ':<6} {'drift err':>9} {'(scene)':<22} "
        f"{'drifting':>9} {'(scene)':<9} {'traj err':>9} {'seconds':>8} "
        f"{'speed':>6} {'worst':>6} {'steps':>6}"
    ]
    for s in summaries:
        dscene = s.worst_drifting_scene.replace("point ", "p")
        lines.append(
            f"{s.setting:<12} {s.integrator:<6} {s.max_drift_error:9.2e} "
            f"{s.worst_scene:<22} {s.max_drift_error_drifting:9.2e} {dscene:<9} "
            f"{s.max_traj_error:9.2e} {s.seconds:8.3f} "
            f"{s.speed_vs_standard:6.2f} {s.min_speed_vs_standard:6.2f} "
            f"{s.steps_vs_standard:6.2f}"
        )
    return "\n".join(lines)


def jsonable(points: Any) -> list[dict[str, Any]]:
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
        return v

    return [{k: clean(v) for k, v in p._asdict().items()} for p in points]


def main(
    quick: bool = False, as_json: bool = False, plot: Any = None, pinned: Any = None, on_result: Any = None
) -> int:
    """`vibtrans bench --work-precision`: the tables (or JSON), the diagram to
    `plot`; on_result(results), if given, receives the JSON object's dict."""
    import json
    import os
    import platform
    import sys

    if plot is not None:
        from vibtrans.products.export import FORMATS, output_format

        try:  # a bad name fails before the run
            output_format(plot, FORMATS)
        except ValueError:
            raise InputError(
                f"plot must end in {', '.join('.' + f for f in FORMATS)}; got {plot!r}"
            ) from None
    t0 = time.perf_counter()
    points = study(
        quick, progress=None if as_json else (lambda s: print(f"  {s}", file=sys.stderr, flush=True))
    )
    seconds = time.perf_counter() - t0
    presets = preset_summary(points)
    ladder = preset_summary(points, settings=list(dict.fromkeys(p.setting for p in points)))
    if plot is not None:
        from vibtrans.products.export import export_work_precision

        ref = QUICK_REFERENCE if quick else REFERENCE
        export_work_precision(points, plot, reference=f"'{ref.label}' ({ref.per_period:g} steps/period)")
    out = {
        "machine": f"{platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, python {platform.python_version()}",
        "pinned_to_one_core": pinned,
        "quick": quick,
        "seconds": seconds,
        "points": jsonable(points),
        "presets": jsonable(presets),
        "settings": jsonable(ladder),
        "pareto_drift": {
            s: [p.setting + "/" + p.integrator for p in f] for s, f in pareto_fronts(points).items()
        },
    }
    if on_result is not None:
        on_result(out)
    if as_json:
        print(json.dumps(out))
        return 0
    print(
        f"vibtrans bench --work-precision ({'quick' if quick else 'full'}; "
        f"{seconds:.0f} s; one core: {pinned}); errors against the "
        f"{(QUICK_REFERENCE if quick else REFERENCE).label} (AB4) run"
    )
    print(table(points))
    print(
        "\nPresets: max drift error over the non-chaotic scenes (and over those that drift,"
        " |v*| > V0), max\ntrajectory error, kernel seconds, speed against standard AB4 "
        "(total, worst scene, steps):"
    )
    print(summary_table(presets))
    print("\nEvery ladder setting (candidate presets):")
    print(summary_table(ladder))
    print("\nPareto front of drift error against seconds:")
    for s, front in pareto_fronts(points).items():
        print(f"  {s:<22} " + ", ".join(f"{p.setting}/{p.integrator} ({p.drift_error:.1e})" for p in front))
    if plot is not None:
        print(f"\nwrote {plot}")
    return 0
