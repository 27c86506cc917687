"""The `vibtrans` command line: one subcommand per task (`vibtrans --help` lists them).

Bad input exits with status 2 and one line naming the parameter and its
valid range.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import shlex
import shutil
import sys
from pathlib import Path
from typing import Any

from vibtrans.core.errors import InputError
from vibtrans.maps.outfiles import atomic, check_file, check_folder
from vibtrans.version import __version__


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse prints usage too)
        self.exit(2, f"{self.prog}: error: {message}\n")


def _num(text):
    """A float if the text is one; else the text (Scene names the range)."""
    try:
        return float(text)
    except ValueError:
        return text


def _scene_args(p):
    g = p.add_argument_group("scene (normalized units, docs/MODEL.md)")
    amp = g.add_mutually_exclusive_group(required=True)
    amp.add_argument("--amplitude", type=_num, help="A* (vertical wave amplitude / a0)")
    amp.add_argument("--log-amplitude", type=_num, help="log10 A*")
    mass = g.add_mutually_exclusive_group(required=True)
    mass.add_argument("--mass", type=_num, help="m* = a0 m f^2 / (M g)")
    mass.add_argument("--log-mass", type=_num, help="log10 m*")
    _model_args(g)


def _model_args(g):
    """Everything of a scene but A* and m* (simulate and sweep share these)."""
    g.add_argument("--model", default="deformable", help="deformable | point-mass | vertical")
    for name, default in (("mu", 0.3), ("theta", 1.2), ("nu", 0.3), ("tau", 50.0), ("periods", 2000.0)):
        g.add_argument(f"--{name}", type=_num, default=default)
    g.add_argument("--alpha-t", type=_num, default=0.5, help="point mass: tangential restitution")
    g.add_argument("--stick-rule", default="paper", help="point mass: paper | classical")
    g.add_argument("--fidelity", default="standard", help="preview | standard | reference")
    g.add_argument("--integrator", default="ab4", help="ab4 | verlet")
    _profile_args(g)
    g.add_argument("--rolling", default="none", help=ROLLING_HELP)


PROFILE_HELP = (
    "particle profile: sphere | cone | power:N (z = C r^N, N >= 1) | "
    "flat-sphere:C (flat radius C in units of sqrt(R a0)) | file:PATH (two "
    "columns r z in metres; needs --load-over-modulus); docs/MODEL.md section 10"
)
ROLLING_HELP = (
    "how the particle turns (deformable model): none (slides without turning, "
    "the paper's particle) | solid (a solid sphere, j = 2/5) | shell (a thin "
    "shell, j = 2/3) | J (j = I/(m R^2) in (0, 1]); docs/MODEL.md section 11"
)
STOP_HELP = (
    "full: run every scene to --periods; decided: stop a run once its drift is "
    "known to the fidelity's stated error (regular motion, extrapolated to "
    "--periods) or its Lyapunov exponent calls it chaotic with margin "
    "(vibtrans.core.stopping.DecidedRule)"
)


def _profile_args(g):
    g.add_argument("--profile", default="sphere", help=PROFILE_HELP)
    g.add_argument(
        "--load-over-modulus",
        type=_num,
        default=None,
        help="N0/E* in m^2 (the static load over the contact modulus): file: profiles only",
    )


# the scene's values besides A* and m* (_model_args' options)
MODEL_KEYS = (
    "model mu theta nu tau periods alpha_t stick_rule fidelity integrator profile load_over_modulus rolling"
).split()


def _values(args, keys=MODEL_KEYS):
    """The options `keys` as keyword arguments (by their dest)."""
    return {k: getattr(args, k) for k in keys}


def _log10_value(name, value):
    if isinstance(value, str) or not math.isfinite(value) or abs(value) > 300:
        raise InputError(f"{name} must be a finite real number in [-300, 300], got {value!r}")
    return 10.0**value


def _scene(args):
    from vibtrans.core.params import Scene

    amplitude = (
        args.amplitude if args.log_amplitude is None else _log10_value("log_amplitude", args.log_amplitude)
    )
    mass = args.mass if args.log_mass is None else _log10_value("log_mass", args.log_mass)
    return Scene(amplitude=amplitude, mass=mass, **_values(args))


COMPILING = (
    "compiling the kernels this run needs (numba: once after an install or an "
    "update; later runs load them from the cache) ..."
)


@contextlib.contextmanager
def _progress(label, compiling=False):
    """A progress bar on stderr; yields its update(fraction).  `compiling`: a
    kernel compiling is said above it, the bar back at 0% (a twin may compile after 100%)."""
    from tqdm import tqdm

    from vibtrans.core.kernels.jit import compile_notice

    bar_format = "{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}"
    bar = tqdm(total=1000, desc=label, file=sys.stderr, delay=1.0, leave=False, bar_format=bar_format)

    def notice(name):
        bar.reset()
        bar.write(f"{label}: {COMPILING}", file=sys.stderr)

    try:
        with compile_notice(notice) if compiling else contextlib.nullcontext():
            yield lambda fraction: bar.update(int(round(fraction * 1000)) - bar.n)
    finally:
        bar.close()


def _jsonable(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def _write_netcdf(ds, out):
    # a partial file is never read as data; netCDF4 says RuntimeError("NetCDF:
    # HDF error") when the disk is full
    with atomic(out, errors=(RuntimeError,)) as tmp:
        ds.to_netcdf(tmp)


def _report(out, as_json, width, hidden):
    """`out` as one JSON object, or a line per key (but `hidden`), names right-aligned."""
    if as_json:
        print(json.dumps(out))
        return
    for k, v in out.items():
        if k != hidden:
            print(f"{k:>{width}}: {v}")


def cmd_simulate(args: argparse.Namespace) -> int:
    from vibtrans.analysis.summary import jumped, summarize, twin_scene
    from vibtrans.core.simulate import simulate

    scene = _scene(args)
    if args.out:
        check_file(args.out)  # before the run: a bad path costs no simulation
    window = None if args.window is None else tuple(_num(v) for v in args.window)
    given = dict(samples_per_period=args.samples_per_period, max_steps=args.max_steps, stop=args.stop)
    with _progress("simulate", compiling=True) as update:
        ds = simulate(scene, window=window, progress=update, lyapunov=True, **given)
        twin = None
        # auto: the twin only where no Lyapunov exponent decides (a material point
        # with fewer than three impacts after the ramp)
        if args.twin == "always" or (args.twin == "auto" and jumped(ds) and ds.attrs.get("lyapunov") is None):
            twin = simulate(twin_scene(scene), **given)
    summary = summarize(ds, twin)
    if args.out:
        _write_netcdf(ds, args.out)
    out = {k: _jsonable(v) for k, v in summary._asdict().items()}
    out["scene"] = scene.values()
    if args.stop == "decided":
        # (a run that went to its end has no asymptotic rate: null)
        for k in ("stop_reason", "periods_run", "asymptotic_drift_velocity"):
            out[k] = _jsonable(ds.attrs.get(k))
    _report(out, args.json, 22, "scene")
    return 0


def _orbit_json(orbit):
    out = orbit._asdict()
    out["multipliers"] = [[v.real, v.imag] for v in orbit.multipliers]
    return out


def cmd_orbit(args: argparse.Namespace) -> int:
    from vibtrans.analysis import dynamics as Y
    from vibtrans.core.drivers import scene_law

    scene = _scene(args)
    period = _finite("period", args.period, 1, 64, integer=True)
    guess: tuple[float, ...]
    if args.guess == "run":
        guess = Y.run_guess(scene)
    elif args.guess == "rest":
        guess = Y.rest_guess(scene.amplitude, scene.mass, scene_law(scene))
    else:
        try:
            guess = tuple(float(v) for v in args.guess.split(","))
        except ValueError:
            guess = ()
        if len(guess) != 2 or not all(map(math.isfinite, guess)):
            raise InputError(f"guess must be run, rest or 'Y,VY' (two numbers), got {args.guess!r}")
    la, lm = math.log10(scene.amplitude), math.log10(scene.mass)
    if args.continue_ is None:
        orbit = Y.periodic_orbit(
            scene.amplitude, scene.mass, guess, period, scene.fidelity, law=scene_law(scene)
        )
        out = {**_orbit_json(orbit), "profile": scene.profile}
    else:
        if args.to is None:
            raise InputError("to: --continue needs --to (the log10 value to continue to)")
        to = _finite("to", args.to, -300, 300)
        step = _finite("step", args.step, 1e-4, 0.5)
        law = (scene.fidelity, scene.profile, scene.load_over_modulus)
        branch = Y.continue_orbit(la, lm, args.continue_, to, step, period, guess, *law)
        out = {
            "profile": scene.profile,
            "parameter": branch.parameter,
            "folds": branch.folds,
            "period_doublings": branch.period_doublings,
            "ended": branch.ended,
            "points": [
                {"log_amplitude": p.log_amplitude, "log_mass": p.log_mass, **_orbit_json(p.orbit)}
                for p in branch.points
            ],
        }
    # (rolling turns the particle, not its height: the orbit is the same for
    # every rolling, and is said so where a user would wonder)
    out["rolling"] = scene.rolling
    if scene.rolling != "none":
        out["rolling_note"] = (
            "the vertical motion's orbit: the same for every rolling (docs/MODEL.md section 11)"
        )
    _report(out, args.json, 18, "points")
    if not args.json:
        for p in out.get("points", []):
            print(
                f"  log A* {p['log_amplitude']:8.4f}  log m* {p['log_mass']:8.4f}  "
                f"trace {p['trace']:9.5f}  {'stable' if p['stable'] else 'unstable'}"
            )
    return 0


CURVE_KEYS = ("tau", "periods", "fidelity", "profile", "load_over_modulus")


def cmd_threshold(args: argparse.Namespace) -> int:
    from vibtrans.core.threshold import point_mass_threshold, threshold_amplitude, threshold_curve

    if args.sweep:
        from vibtrans.maps.sweep import command_line, parse_range

        log_mass = parse_range(args.log_mass, "log_mass")
        out = args.out or "vertical.nc"
        check_file(out)
        ds = threshold_curve(log_mass, workers=args.workers, **_values(args, CURVE_KEYS))
        ds.attrs["command"] = command_line()
        _write_netcdf(ds, out)
        print(out)
        return 0
    if args.mass is None:
        raise InputError("threshold needs --mass M (or --sweep)")
    aj = threshold_amplitude(args.mass, rel_tol=args.rel_tol, **_values(args, CURVE_KEYS))
    pm = point_mass_threshold(args.mass)
    out = {"mass": args.mass, "threshold_amplitude": aj, "point_mass_threshold_amplitude": pm}
    out.update(_values(args, ("tau", "periods", "profile")))
    print(json.dumps(out) if args.json else f"A_J* = {aj:.6g}  (point mass: {pm:.6g})")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from vibtrans.tools.bench import main as bench_main

    if args.plot is not None:
        check_file(args.plot, "plot")
    if args.results_dir is not None and args.output is not None:
        raise InputError(
            "--results-dir and --output: give one (a folder for a file named by "
            "the bench and its time, or the file)"
        )
    if args.results_dir is not None:  # refused before the run, not after it
        check_folder(args.results_dir, "results-dir")
    if args.output is not None:
        check_file(args.output, "output")
    given = _values(args, ("quick", "sweep", "work_precision", "plot", "export", "results_dir", "output"))
    command = " ".join(["vibtrans", *(shlex.quote(w) for w in args.words)])
    return bench_main(as_json=args.json, cold=args.cold_start, command=command, **given)


def cmd_sweep(args: argparse.Namespace) -> int:
    from vibtrans.maps.sweep import Sweep, command_line, parse_range, run_sweep

    grid = parse_range(args.log_amplitude, "log_amplitude"), parse_range(args.log_mass, "log_mass")
    given = _values(args, ("chunk_rows", "kind", "chaos", "stop", *MODEL_KEYS))
    sweep = Sweep(*grid, command=command_line(), **given)
    if args.workers is not None and args.workers < 1:
        raise InputError(f"workers must be an integer >= 1, got {args.workers}")
    if not args.adaptive and (args.max_level is not None or args.drift_tolerance is not None):
        raise InputError("--max-level and --drift-tolerance refine an adaptive map: add --adaptive")
    if args.adaptive:
        from vibtrans.maps.adaptive import DEFAULT_DRIFT_TOLERANCE, check_levels, check_tolerance

        if args.kind != "transport":
            raise InputError(f"--adaptive makes drift maps (--kind transport), not --kind {args.kind}")
        if args.max_level is None:
            raise InputError(
                "--adaptive needs --max-level K (1..8): the finest grid's refinements of the coarse grid"
            )
        if args.executor != "threads":
            raise InputError("--adaptive runs on threads or --scheduler, not --executor processes")
        check_levels(sweep, args.max_level)  # before any file is made
        tol = check_tolerance(
            DEFAULT_DRIFT_TOLERANCE if args.drift_tolerance is None else args.drift_tolerance
        )
    out = args.out or _sweep_name(args.model, args.mu, args.profile, sweep.values.get("rolling"))
    new = not os.path.exists(out)
    pool = dict(workers=args.workers, scheduler=args.scheduler)
    check_folder(out, create=False)  # a Zarr store is a folder (resumed if it exists)
    try:
        if args.adaptive:
            from vibtrans.maps.adaptive import run_adaptive

            fraction = run_adaptive(sweep, out, args.max_level, tol, **pool)
            print(out)
            print(f"computed fraction {fraction:.4f}")
            return 0
        run_sweep(sweep, out, executor=args.executor, flush_every=args.flush_every, **pool)
    except OSError as exc:
        if new:  # a store this run began and could not write: not left behind
            shutil.rmtree(out, ignore_errors=True)
        raise InputError(
            f"out: cannot write {out!r} ({exc.strerror or exc}); a store that "
            f"existed before is kept and resumes"
        ) from None
    print(out)
    return 0


def _sweep_name(model, mu, profile, rolling=None):
    """A sweep's default store name: sweep-MODEL-muMU[-PROFILE][-rolling-ROLLING].zarr."""
    name = f"sweep-{model}-mu{mu:g}"
    if profile.startswith("file:"):
        name += "-file-" + os.path.splitext(os.path.basename(profile[5:]))[0]
    elif profile != "sphere":  # file-name-safe: power:3 -> power3
        name += "-" + "".join(c for c in profile if c.isalnum() or c in ".-")
    if rolling is not None:
        name += f"-rolling-{rolling:g}" if isinstance(rolling, float) else f"-rolling-{rolling}"
    return name + ".zarr"


def _design_axis(text, name):
    """'QUANTITY:LO:HI:N' -> (quantity, lo, hi, n); design.design_chart checks the values."""
    parts = str(text).split(":")
    if len(parts) != 4:
        raise InputError(
            f"{name} must be QUANTITY:LO:HI:N (quantity one of frequency, radius, amplitude), got {text!r}"
        )
    q, lo, hi, count = parts
    n = _num(count)
    if isinstance(n, float) and n.is_integer():
        n = int(n)
    return (q, _num(lo), _num(hi), n)


def _fmt(value, unit=""):
    return "n/a" if value is None else f"{value:.4g}{(' ' + unit) if unit else ''}"


def _design_text(dev, q, warnings, reading, rolling="none"):
    tip = "" if q.profile == "sphere" else f" with a {q.profile} tip"
    if rolling != "none":
        tip += f", rolling {rolling}"
    lines = [
        f"device: {dev.particle.name} sphere{tip}, R = {dev.radius:.4g} m, on "
        f"{dev.substrate.name}; f = {dev.frequency:.4g} Hz, A_y = "
        f"{dev.amplitude:.4g} m, pre-load {dev.preload:g} N",
        f"  A* = {q.A_star:.4g}, m* = {q.m_star:.4g} (theta {q.theta:.4g}, nu {q.nu:g}, r {q.r:.4g})",
        f"  a0 = {q.a0:.4g} m, contact radius {q.contact_radius:.4g} m, mean contact "
        f"pressure {q.mean_contact_pressure:.4g} Pa, load {q.load:.4g} N",
        f"  peak surface acceleration {q.peak_acceleration_g:.4g} g, peak velocity "
        f"{q.peak_velocity:.4g} m/s (vertical; horizontal x r)",
        f"  Rayleigh speed {q.rayleigh_speed:.4g} m/s, wavelength {q.rayleigh_wavelength:.4g} m",
        f"  pull-off (w = surface energy): JKR {q.pull_off_jkr:.4g} N, DMT {q.pull_off_dmt:.4g} N",
    ]
    if reading is None:
        lines.append("  drift: not read (the device is off the map used, or no shipped map serves it)")
    else:
        lines += [
            f"  drift ({reading['map']}, nearest grid point): v* = {q.v_star:.4g}, "
            f"v = {q.drift_velocity:.4g} m/s, {reading['regime']}",
            f"  contact time per period {_fmt(q.contact_time, 's')}, travel per period "
            f"{_fmt(q.travel_per_period, 'm')} = {_fmt(q.travel_over_wavelength)} "
            f"wavelengths",
        ]
    lines += [f"warning: {w.message}" for w in warnings] or ["no validity warnings"]
    return "\n".join(lines)


def cmd_design(args: argparse.Namespace) -> int:
    from vibtrans.core import units
    from vibtrans.core.params import check_rolling
    from vibtrans.products import design

    pre = design.preset(args.preset) if args.preset else None
    values = {}
    for q in design.AXES:
        if getattr(args, q) is not None:
            values[q] = _finite(q, getattr(args, q), 0.0)
        elif pre is not None:
            values[q] = getattr(pre.device, q)
    substrate = args.substrate or (pre.device.substrate if pre else None)
    particle = args.particle or (pre.device.particle if pre else None)
    if substrate is None or particle is None:
        raise InputError("substrate and particle: give --preset or both --substrate and --particle")
    substrate, particle = units.material(substrate), units.material(particle)
    preload = args.preload if args.preload is not None else (pre.device.preload if pre else 0.0)
    preload = _finite("preload", preload, 0.0, math.inf) if preload else 0.0
    x = _design_axis(args.x, "x") if args.x else (pre.x if pre else None)
    y = _design_axis(args.y, "y") if args.y else (pre.y if pre else None)
    if x is None or y is None:
        raise InputError(
            "x and y: give --preset or both --x and --y (QUANTITY:LO:HI:N, e.g. frequency:1e4:1e6:41)"
        )
    third = [q for q in design.AXES if q not in (x[0], y[0])]
    if len(third) != 1:
        raise InputError(
            f"x and y must be two different quantities among "
            f"{', '.join(design.AXES)}, got {x[0]!r} and {y[0]!r}"
        )
    fixed_q = third[0]
    if fixed_q not in values:
        raise InputError(f"{fixed_q}: the quantity not on an axis needs a value (--{fixed_q})")
    outs = args.out or []
    for out in outs:
        if Path(out).suffix.lower() not in (".png", ".svg", ".pdf", ".nc", ".csv"):
            raise InputError(f"out must end in .png, .svg, .pdf, .nc or .csv, got {out!r}")
        check_file(out)
    surface_energy = _finite("surface_energy", args.surface_energy, 0.0, math.inf)
    mu = _finite("mu", args.mu, 0.0)
    shape = design.tip_shape(
        args.profile, half_angle=args.half_angle, tip_radius=args.tip_radius, flat_radius=args.flat_radius
    )
    rolling = check_rolling(args.rolling)
    device = units.DeviceSpec(substrate, particle, **values, preload=preload) if len(values) == 3 else None
    chart = design.design_chart(
        substrate,
        particle,
        preload,
        x,
        y,
        (fixed_q, values[fixed_q]),
        mu=mu,
        surface_energy=surface_energy,
        maps=args.maps,
        compute=args.compute,
        store_dir=args.store,
        step=_finite("step", args.step, 0.0, 1.0),
        periods=_finite("periods", args.periods, 0.0),
        report=lambda text: print(text, file=sys.stderr),
        workers=args.workers,
        shape=shape,
        rolling=rolling,
    )
    reading = quantities = None
    warnings = []
    if device is not None:
        reading = design.read_device(device, mu=mu, maps=args.maps, chart=chart, shape=shape, rolling=rolling)
        quantities = design.device_quantities(device, reading, surface_energy, shape=shape)
        warnings = design.validity_warnings(device, surface_energy, quantities.drift_velocity, shape=shape)
    chart_warnings = design.chart_warnings(chart)
    for out in outs:
        if Path(out).suffix.lower() in (".nc", ".csv"):
            design.write_chart_data(chart, out)
        else:
            from vibtrans.products.export import export_design

            mark = None if device is None else (getattr(device, x[0]), getattr(device, y[0]))
            export_design(chart, out, device=mark)
    if not args.json:
        if device is not None:
            print(_design_text(device, quantities, warnings, reading, rolling))
        print(
            f"chart: {chart.sizes[y[0]]} x {chart.sizes[x[0]]} points, map "
            f"{chart.attrs['map']} ({chart.attrs['reading']})"
        )
        for text in chart_warnings:
            print(f"chart warning: {text}")
        for out in outs:
            print(out)
        return 0
    grids = ("drift_velocity", "v_star", "regime", "A_star", "m_star")
    out_json = {
        "profile": shape.name,
        "map_profile": chart.attrs["map_profile"],
        **({"rolling": rolling} if rolling != "none" else {}),
        "device": None if quantities is None else {k: _jsonable(v) for k, v in quantities.as_dict().items()},
        "regime": None if reading is None else reading["regime"],
        "warnings": [w.__dict__ for w in warnings],
        "chart_warnings": chart_warnings,
        "chart": {
            "attrs": {k: _jsonable(v) for k, v in chart.attrs.items()},
            x[0]: chart[x[0]].values.tolist(),
            y[0]: chart[y[0]].values.tolist(),
            **{k: [[_jsonable(float(v)) for v in row] for row in chart[k].values] for k in grids},
        },
        "outputs": outs,
    }
    print(json.dumps(out_json))
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    """Serve the explorer: the library's one import of it, done only here, so
    `import vibtrans` and the other commands never load Panel."""
    from vibtrans_explorer.server.serve import serve

    return serve(args)


def _finite(name, value, lo=None, hi=None, integer=False):
    """A command-line number, validated (lo alone: above it; lo and hi: in
    [lo, hi]): InputError names the parameter."""
    ok = isinstance(value, float) and math.isfinite(value) and (not integer or value.is_integer())
    if ok and lo is not None:
        ok = lo < value if hi is None else lo <= value <= hi
    if not ok:
        rng = "" if lo is None else f" > {lo:g}" if hi is None else f" in [{lo:g}, {hi:g}]"
        raise InputError(f"{name} must be {'an integer' if integer else 'a number'}{rng}, got {value!r}")
    return int(value) if integer else float(value)


def _export_scene(args):
    """The scene of `export trajectory|memory|section|...`: --point, or --log-amplitude and --log-mass."""
    from vibtrans.core.params import PAPER_POINTS, Scene

    if args.point is not None:
        if args.log_amplitude is not None or args.log_mass is not None:
            raise InputError("point: give either --point or --log-amplitude/--log-mass, not both")
        k = _finite("point", args.point, 1, 10, integer=True)
        la, lm, model = PAPER_POINTS[k]
        if args.model is not None and args.model != model:
            raise InputError(f"model: paper point {k} is a {model} scene, got --model {args.model}")
    else:
        if args.log_amplitude is None or args.log_mass is None:
            raise InputError(f"{args.kind} needs --point N or both --log-amplitude and --log-mass")
        la = _finite("log_amplitude", args.log_amplitude, -300, 300)
        lm = _finite("log_mass", args.log_mass, -300, 300)
        model = args.model or "deformable"
    return Scene(
        amplitude=10.0**la,
        mass=10.0**lm,
        model=model,
        mu=args.mu,
        periods=args.periods,
        fidelity=args.fidelity,
    )


def _open_map(path, option="maps", errors=(OSError,), **kw):
    """A map store, its read errors said as InputError naming `option`."""
    from vibtrans.maps.sweep import open_map

    try:
        return open_map(str(path), **kw)
    except errors as exc:
        raise InputError(f"{option}: {exc}") from None


def cmd_export(args: argparse.Namespace) -> int:
    from vibtrans.analysis.summary import twin_scene
    from vibtrans.products import export as E

    kind = args.kind
    if kind == "paper":
        if Path(args.out).suffix.lower() in (".png", ".svg", ".pdf", ".html"):
            raise InputError(f"out: export paper writes a folder of figures, got the file name {args.out!r}")
        check_folder(args.out, create=False)
    else:
        E.output_format(args.out, E.FORMATS + ("html",))
        check_file(args.out)
    sizes = {"dpi": _finite("dpi", args.dpi, 20, 1200, integer=True)}
    for name in ("width", "height"):
        if getattr(args, name) is not None:
            sizes[name] = _finite(name, getattr(args, name), 0.5, 50)
    if kind not in ("trajectory", "paper") and args.window is not None:
        raise InputError(f"window: only export trajectory takes --window, not export {kind}")
    v0 = E.V0 if args.v0 is None else _finite("v0", args.v0, 0)
    if not isinstance(args.mu, float):
        raise InputError(f"mu must be a number, got {args.mu!r}")
    maps = Path(args.maps) if args.maps else E.default_maps_dir()
    if kind in ("heatmap", "vertical", "paper") and not maps.is_dir():
        raise InputError(f"maps: no such folder {str(maps)!r} (give --maps PATH or set VIBTRANS_ASSETS)")
    paper_periods = args.periods  # paper: None leaves each point its own
    if args.periods is None:
        args.periods = 2000.0
    if kind == "heatmap":
        model = args.model or "deformable"
        path = E.map_path(maps, model, args.mu)
        if not path.exists():
            have = sorted(p.name for p in maps.glob("*.zarr"))
            raise InputError(
                f"mu: no drift map {path.name} for model {model}, mu {args.mu:g} in "
                f"{maps} (available: {', '.join(have) or 'none'})"
            )
        ds = _open_map(path, expect={"model": model, "mu": args.mu})
        E.export_heatmap(ds, args.out, v0=v0, vertical=E.load_vertical(maps), chaotic=args.chaotic, **sizes)
    elif kind == "vertical":
        vertical = E.load_vertical(maps)
        if vertical is None:
            raise InputError(f"maps: no vertical.nc (threshold curve) in {maps}")
        E.export_vertical(vertical, args.out, **sizes)
    elif kind == "trajectory":
        scene = _export_scene(args)
        T = scene.periods
        window = None
        if args.window is not None:
            window = tuple(_finite("window", _num(w)) for w in args.window)
            if not 0 <= window[0] < window[1] <= T:
                raise InputError(
                    f"window must satisfy 0 <= T0 < T1 <= {T:g} (periods), "
                    f"got {args.window[0]} {args.window[1]}"
                )
        window = window or (max(0.0, T - E.FRAGMENT), T)
        from vibtrans.core.simulate import simulate

        with _progress("simulate") as update:
            ds = simulate(scene, window=window, samples_per_period=E.OVERVIEW_SAMPLES, progress=update)
            twin = None
            if args.twin:
                twin = simulate(twin_scene(scene), window=window, samples_per_period=E.OVERVIEW_SAMPLES)
        title = None if args.point is None else E.point_title(int(args.point), scene)
        E.export_trajectory(ds, args.out, window=window, twin=twin, title=title, **sizes)
    elif kind == "memory":
        from vibtrans.core.simulate import memory_snapshot

        if args.t is None:
            raise InputError("t: export memory needs --t TIME (periods)")
        t = _finite("t", args.t, 0, args.periods if isinstance(args.periods, float) else 2000.0)
        E.export_memory(memory_snapshot(_export_scene(args), t=t), args.out, **sizes)
    elif kind in ("lyapunov-map", "section", "orbit-diagram", "continuation"):
        _export_dynamics(args, kind, maps, sizes)
    elif kind == "map-difference":
        _export_map_difference(args, maps, v0, sizes)
    else:
        periods = None if paper_periods is None else _finite("periods", paper_periods, 0)
        E.export_paper(args.out, progress=True, maps=maps, dpi=sizes["dpi"], periods=periods, fmt=args.format)
    print(args.out)
    return 0


def _export_dynamics(args, kind, maps, sizes):
    """export lyapunov-map | section | orbit-diagram | continuation."""
    import numpy as np

    from vibtrans.analysis import dynamics as Y
    from vibtrans.analysis.summary import CHAOS_LYAPUNOV
    from vibtrans.products import export as E
    from vibtrans.products import plots

    E.ensure_backends()
    if kind == "lyapunov-map":
        path = maps / "vertical-lyapunov.zarr"
        if not path.exists():
            raise InputError(f"maps: no vertical-lyapunov.zarr in {maps}")
        el = plots.lyapunov_map(_open_map(path), CHAOS_LYAPUNOV)
        vertical = E.load_vertical(maps)
        if vertical is not None:
            el = el * plots.jumping_boundary(vertical, "deformable")
        el = plots.style(
            el * plots.paper_points("deformable", "white"),
            common=dict(title="The vertical motion's Lyapunov exponent (tau 50, 2000 periods)"),
        )
        return E.export_dynamics(el, args.out, **sizes)
    scene = _export_scene(args)
    la, lm = math.log10(scene.amplitude), math.log10(scene.mass)
    if kind == "section":
        n = _finite("section_periods", args.section_periods, 1, 20000, integer=True)
        y, vy = Y.run_guess(scene)
        el = plots.section_figure(
            [Y.section(scene.amplitude, scene.mass, y, vy, n, scene.fidelity)],
            title=f"Stroboscopic section, log10 A* = {la:.3g}, log10 m* = {lm:.3g} ({n} periods)",
        )
        return E.export_dynamics(el, args.out, **sizes)
    if args.along is None or args.to is None:
        raise InputError(f"{kind} needs --along amplitude|mass and --to VALUE (log10)")
    to = _finite("to", args.to, -300, 300)
    start = la if args.along == "amplitude" else lm
    if kind == "orbit-diagram":
        runs = _finite("runs", args.runs, 2, 2000, integer=True)
        final = _finite("final", args.final, 1, scene.periods)
        diagram = Y.orbit_diagram(scene, args.along, np.linspace(start, to, runs), final)
        height = sizes.pop("height", 6.5)
        return E.export_dynamics(plots.orbit_diagram_figure(diagram), args.out, height=height, **sizes)
    step = _finite("step", args.step, 1e-4, 0.5)
    branch = Y.continue_orbit(la, lm, args.along, to, step, 1, Y.run_guess(scene), scene.fidelity)
    return E.export_dynamics(plots.continuation_figure(branch), args.out, **sizes)


def _named_map(text, maps, option):
    """A drift map named on the command line: a store's path, or a shipped
    map's name (deformable-mu0.3, point-mass-mu0.3, ...)."""
    path = Path(text)
    if not path.exists():
        path = Path(maps) / (text if text.endswith(".zarr") else text + ".zarr")
        if not path.exists():
            have = sorted(p.stem for p in Path(maps).glob("*-mu*.zarr"))
            raise InputError(
                f"{option}: no store {text!r} and no shipped map of that name in "
                f"{maps} (shipped: {', '.join(have) or 'none'})"
            )
    return _open_map(path, option, (OSError, ValueError))


def _export_map_difference(args, maps, v0, sizes):
    from vibtrans.maps.difference import map_difference
    from vibtrans.products import export as E
    from vibtrans.products import plots

    if not args.map or not args.other:
        raise InputError(
            "map-difference needs --map A and --other B (a store's path or a "
            "shipped map's name such as deformable-mu0.3)"
        )
    diff = map_difference(_named_map(args.map, maps, "map"), _named_map(args.other, maps, "other"), v0=v0)
    E.ensure_backends()
    E.export_dynamics(plots.map_difference_figure(diff), args.out, **sizes)
    a = diff.attrs
    print(
        f"{a['second']} against {a['first']}: {a['compared_points']} points compared, "
        f"{a['regular_points']} regular in both; drift class agrees at "
        f"{100 * a['class_agreement']:.1f}%, median relative drift difference "
        f"{a['median_relative_difference']:.3g}"
    )


def _export_parser(sub):
    e = sub.add_parser(
        "export",
        help="figures as PNG/SVG/PDF (matplotlib, headless) or HTML; the paper's set",
        description="Headless figure export. heatmap: a shipped drift map; trajectory: a scene's "
        "run (whole run + full-resolution window); vertical: A_J*(m*); memory: the "
        "memory diagram at time --t; paper: the paper's figures into the folder --out.",
    )
    e.add_argument(
        "kind",
        choices=(
            "heatmap trajectory vertical memory paper lyapunov-map section orbit-diagram continuation "
            "map-difference"
        ).split(),
    )
    e.add_argument(
        "--out", required=True, help="FILE.png|svg|pdf (or .html: interactive bokeh); paper: a folder"
    )
    e.add_argument("--model", help="deformable | point-mass (heatmap: which map)")
    e.add_argument("--mu", type=_num, default=0.3)
    e.add_argument("--point", type=_num, help="paper point 1-10 (trajectory, memory)")
    e.add_argument("--log-amplitude", type=_num, help="log10 A* (trajectory, memory)")
    e.add_argument("--log-mass", type=_num, help="log10 m* (trajectory, memory)")
    e.add_argument(
        "--periods", type=_num, help="observation time, periods (trajectory, memory; paper: all points)"
    )
    e.add_argument("--fidelity", default="standard", help="preview | standard | reference")
    e.add_argument("--t", type=_num, help="memory: time of the memory diagram, periods")
    e.add_argument(
        "--window",
        nargs=2,
        metavar=("T0", "T1"),
        help="trajectory: full-resolution fragment (default: the last 2 periods)",
    )
    e.add_argument(
        "--twin", action="store_true", help="trajectory: add the tau + 1e-3 twin run (chaos check)"
    )
    e.add_argument(
        "--v0", type=_num, default=None, help="heatmap: white band |v*| <= v0* (default 0.1, analysis.V0)"
    )
    e.add_argument(
        "--chaotic",
        default="grey",
        choices=("grey", "colour"),
        help="heatmap: chaotic points grey or coloured",
    )
    e.add_argument("--dpi", type=_num, default=150.0, help="dots per inch (PNG size = dpi x inches)")
    e.add_argument("--width", type=_num, help="figure width, inches")
    e.add_argument("--height", type=_num, help="figure height, inches")
    e.add_argument(
        "--maps",
        help="folder of the maps (default: the maps installed with "
        "vibtrans, or $VIBTRANS_ASSETS/maps if set)",
    )
    e.add_argument(
        "--format", default="png", choices=("png", "svg", "pdf"), help="paper: file format of the figures"
    )
    e.add_argument(
        "--along",
        choices=("amplitude", "mass"),
        help="orbit-diagram, continuation: the parameter varied (log10)",
    )
    e.add_argument("--to", type=_num, help="orbit-diagram, continuation: the log10 value to reach")
    e.add_argument("--runs", type=_num, default=100.0, help="orbit-diagram: runs along the line (2-2000)")
    e.add_argument(
        "--final", type=_num, default=100.0, help="orbit-diagram: final periods whose take-offs are drawn"
    )
    e.add_argument("--step", type=_num, default=0.02, help="continuation: decades per step")
    e.add_argument(
        "--section-periods",
        type=_num,
        default=500.0,
        help="section: periods iterated from where the run ends (1-20000)",
    )
    e.add_argument(
        "--map",
        help="map-difference: the first map (a store's path or a shipped map's name, e.g. deformable-mu0.1)",
    )
    e.add_argument("--other", help="map-difference: the map compared with it")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="vibtrans")
    p.add_argument("--version", action="version", version=f"vibtrans {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("simulate", help="run one scene and print its drift and regime")
    _scene_args(s)
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--out", help="write the trajectory to FILE.nc (netCDF)")
    s.add_argument("--window", nargs=2, metavar=("T0", "T1"), help="record every step in [T0, T1] (periods)")
    s.add_argument("--samples-per-period", type=int, default=10)
    s.add_argument("--max-steps", type=float, default=2e8, help="refuse scenes estimated to need more steps")
    s.add_argument(
        "--twin",
        default="auto",
        choices=("auto", "always", "never"),
        help="run the tau + 1e-3 twin (twin_chaotic; the chaos verdict where no "
        "Lyapunov exponent is measured); auto: if it jumps and has none",
    )
    s.add_argument("--stop", default="full", choices=("full", "decided"), help=STOP_HELP)

    o = sub.add_parser(
        "orbit",
        help="periodic orbit of the vertical motion's stroboscopic "
        "map, its Floquet multipliers and continuation",
    )
    _scene_args(o)
    o.add_argument("--period", type=_num, default=1.0, help="k: a period-k orbit (1-64)")
    o.add_argument(
        "--guess",
        default="run",
        help="run (where the scene's run ends), rest (the small-amplitude contact orbit) or Y,VY",
    )
    o.add_argument(
        "--continue",
        dest="continue_",
        choices=("amplitude", "mass"),
        help="continue the orbit along log10 A* or log10 m*",
    )
    o.add_argument("--to", type=_num, help="with --continue: the log10 value to reach")
    o.add_argument("--step", type=_num, default=0.02, help="with --continue: decades per step")
    o.add_argument("--json", action="store_true")

    t = sub.add_parser("threshold", help="jumping threshold A_J*(m*) of the vertical motion")
    t.add_argument("--mass", type=_num)
    t.add_argument("--sweep", action="store_true", help="the whole curve over --log-mass")
    t.add_argument("--log-mass", default="-5:5:0.01", help="with --sweep: start:stop:step")
    t.add_argument("--workers", type=int)
    t.add_argument("--out", help="with --sweep: FILE.nc")
    t.add_argument("--tau", type=_num, default=50.0)
    t.add_argument("--periods", type=_num, default=2000.0)
    t.add_argument("--fidelity", default="standard")
    t.add_argument("--rel-tol", type=_num, default=1e-3)
    _profile_args(t)
    t.add_argument("--json", action="store_true")

    w = sub.add_parser("sweep", help="drift map over (log10 A*, log10 m*), resumable Zarr store")
    _model_args(w)
    w.add_argument("--log-amplitude", default="-3:3:0.05", help="start:stop:step (inclusive)")
    w.add_argument("--log-mass", default="-5:5:0.05", help="start:stop:step (inclusive)")
    w.add_argument("--chunk-rows", type=int, default=4, help="amplitudes per stored chunk")
    w.add_argument(
        "--kind",
        default="transport",
        choices=("transport", "lyapunov"),
        help="transport: drift maps; lyapunov: the vertical motion's Lyapunov "
        "exponent alone (--model vertical)",
    )
    w.add_argument(
        "--chaos",
        default="lyapunov",
        choices=("lyapunov", "twin"),
        help="transport: chaos from each run's Lyapunov exponent (the material "
        "point's: of its impact map), or from the tau twin (as the shipped maps)",
    )
    w.add_argument("--stop", default="full", choices=("full", "decided"), help=STOP_HELP)
    w.add_argument("--out", help="PATH.zarr (resumed if it exists and matches)")
    w.add_argument("--scheduler", help="dask.distributed scheduler address tcp://HOST:PORT")
    w.add_argument("--workers", type=int, help="local workers (default: all cores)")
    w.add_argument(
        "--executor",
        default="threads",
        choices=("threads", "processes"),
        help="local pool kind (threads measured faster)",
    )
    w.add_argument(
        "--flush-every",
        type=_num,
        default=None,
        metavar="SECONDS",
        help="write finished chunks together at most every SECONDS (default "
        "2; 0: each chunk as it finishes); a kill loses at most that much "
        "finished work",
    )
    w.add_argument(
        "--adaptive",
        action="store_true",
        help="refine only where a cell's corners disagree (drift class, contact, "
        "chaos, drift velocity): the grid above is the finest level; "
        "resumes from OUT.partial/",
    )
    w.add_argument(
        "--max-level",
        type=int,
        help="with --adaptive: finest level K (1..8); the coarse grid is every "
        "2^K-th point, so (points - 1) must be a multiple of 2^K on both axes",
    )
    w.add_argument(
        "--drift-tolerance",
        type=_num,
        help="with --adaptive: refine where the corners' drift velocities spread "
        "more than this times max(0.1, max|v*|) (default 0.5)",
    )

    v = sub.add_parser("serve", help="serve the explorer on localhost")
    v.add_argument("--port", type=int, default=5006)
    v.add_argument("--address", default="127.0.0.1", help="interface to listen on (0.0.0.0 in the container)")
    v.add_argument(
        "--allow-websocket-origin",
        action="append",
        metavar="HOST[:PORT]",
        help="public host whose pages may connect (repeatable; default: "
        "$VIBTRANS_ALLOWED_ORIGINS, else localhost:PORT; docs/SECURITY.md)",
    )
    v.add_argument(
        "--num-procs",
        type=int,
        default=1,
        help="server processes sharing the port (0: one per core; Bokeh's own "
        "multi-process serving: each process warms up its own kernels and "
        "map workers).  A page's HTTP request and its websocket may land in "
        "different processes, which then both build its session "
        "(bokeh#10183); instances on separate ports behind a proxy with "
        "sticky sessions avoid that (docs/how-to/deployment.md, docs/SECURITY.md)",
    )
    v.add_argument(
        "--use-xheaders",
        action="store_true",
        help="take the client's address and scheme from the proxy's X-Real-Ip, "
        "X-Forwarded-For and X-Forwarded-Proto headers (only behind a "
        "proxy that sets them; docs/SECURITY.md)",
    )
    v.add_argument(
        "--unused-session-lifetime",
        type=int,
        default=15000,
        metavar="MS",
        help="drop a closed session's state after this many ms",
    )
    v.add_argument(
        "--check-unused-sessions",
        type=int,
        default=17000,
        metavar="MS",
        help="look for closed sessions every this many ms",
    )
    v.add_argument(
        "--map-cache",
        metavar="DIR",
        help="folder of the maps on demand computed, shared by every session "
        "(default: $VIBTRANS_MAP_CACHE, else ~/.cache/vibtrans/maps)",
    )
    v.add_argument(
        "--map-cache-mb",
        type=int,
        default=2048,
        metavar="MB",
        help="size cap of that folder; the least recently used maps go first",
    )
    v.add_argument(
        "--map-cores",
        type=int,
        metavar="N",
        help="cores a map on demand computes on (one map at a time; default: "
        "$VIBTRANS_MAP_CORES, else all cores but one, which stays for "
        "the sessions' clicks)",
    )
    v.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run the points of maps on demand on this dask.distributed "
        "cluster instead of this machine's cores",
    )

    b = sub.add_parser("bench", help="speed benchmark (ratios measured in one run)")
    b.add_argument("--quick", action="store_true")
    b.add_argument("--json", action="store_true")
    b.add_argument(
        "--sweep", action="store_true", help="points/s of a sweep on 1 and 2 workers, processes vs threads"
    )
    b.add_argument(
        "--work-precision",
        action="store_true",
        help="error against cost of both integrators over a ladder of steps "
        "(vibtrans.tools.workprecision; full: a few minutes, --quick: < 30 s)",
    )
    b.add_argument("--plot", help="with --work-precision: write the diagram to FILE.png|svg|pdf")
    b.add_argument(
        "--export",
        action="store_true",
        help="seconds to export the explorer's trajectory figure (PNG, SVG, HTML) "
        "of paper point 8 with its twin, and over its simulation's",
    )
    b.add_argument(
        "--cold-start",
        action="store_true",
        help="also time a first `vibtrans simulate` on an empty kernel cache "
        "against the same on a warm one (about half a minute)",
    )
    b.add_argument(
        "--results-dir",
        metavar="DIR",
        help="also write the run as JSON (results, machine, load, git commit) "
        "into DIR, named by the bench and its UTC start",
    )
    b.add_argument("--output", metavar="FILE", help="as --results-dir, into FILE")

    _export_parser(sub)
    _design_parser(sub)
    p.description = f"Command line: vibtrans {' | '.join(sub.choices)}."
    return p


def _design_parser(sub):
    from vibtrans.products.designconst import DEFAULT_SURFACE_ENERGY, MAP_STEP, PRESET_NAMES

    d = sub.add_parser(
        "design",
        help="design chart in device units: drift velocity over two of frequency, "
        "radius and amplitude, regimes, validity warnings",
    )
    d.add_argument("--preset", help=" | ".join(PRESET_NAMES))
    d.add_argument(
        "--substrate", help="material name (e.g. glass, 'lithium niobate') or E=<Pa>,nu=<->,rho=<kg/m^3>"
    )
    d.add_argument("--particle", help="material name or E=<Pa>,nu=<->,rho=<kg/m^3>")
    d.add_argument("--radius", type=_num, help="particle radius, m")
    d.add_argument("--frequency", type=_num, help="wave frequency, Hz")
    d.add_argument("--amplitude", type=_num, help="vertical wave amplitude A_y, m")
    d.add_argument("--x", help="QUANTITY:LO:HI:N (frequency | radius | amplitude), log-spaced")
    d.add_argument("--y", help="QUANTITY:LO:HI:N")
    d.add_argument("--preload", type=_num, help="pre-load P, N (default 0 or the preset's)")
    d.add_argument("--mu", type=_num, default=0.3, help="friction coefficient")
    d.add_argument(
        "--profile",
        default="sphere",
        help="the particle's tip: sphere | cone (needs --half-angle) | power:N "
        "(z = r^N / (N R_t^(N-1)), R_t = --tip-radius, default the radius) | "
        "flat-sphere (needs --flat-radius) | file:PATH (two columns r z, m); "
        "a chart of another profile than the sphere reads a map of its own "
        "(--compute); docs/MODEL.md section 10",
    )
    d.add_argument(
        "--rolling",
        default="none",
        help=ROLLING_HELP + "; a chart of a particle that turns reads a map of its own (--compute)",
    )
    d.add_argument("--half-angle", type=_num, help="cone half-angle, degrees in (0, 90)")
    d.add_argument("--tip-radius", type=_num, help="power:N tip radius R_t, m")
    d.add_argument("--flat-radius", type=_num, help="flat-sphere: radius of the flat, m")
    d.add_argument(
        "--surface-energy",
        type=_num,
        default=DEFAULT_SURFACE_ENERGY,
        help=f"work of adhesion w, J/m^2 (default {DEFAULT_SURFACE_ENERGY:g}: "
        f"van der Waals, Hamaker 1e-19 J)",
    )
    d.add_argument(
        "--out", action="append", help="FILE.png|svg|pdf (chart) or FILE.nc|csv (its data); may repeat"
    )
    d.add_argument("--json", action="store_true", help="print the chart's numbers as JSON")
    d.add_argument(
        "--compute",
        action="store_true",
        help="compute the normalized window when no shipped map serves "
        "(preview fidelity; the cost is printed first)",
    )
    d.add_argument(
        "--store", default="vibtrans-design-maps", help="folder of computed windows (reused by later runs)"
    )
    d.add_argument("--step", type=_num, default=MAP_STEP, help="computed window's grid step, decades")
    d.add_argument("--periods", type=_num, default=2000.0, help="computed window's observation time, periods")
    d.add_argument("--workers", type=int, default=None)
    d.add_argument("--maps", help="folder of the shipped maps (default: installed)")


_VALUE_OPTIONS = {
    f"--{k}" for k in "log-amplitude log-mass amplitude mass mu theta nu tau periods alpha-t".split()
}


def _glue_negative_values(argv):
    """`--log-mass -5:5:0.05` -> `--log-mass=-5:5:0.05`: argparse would take a
    value starting with '-' (other than a plain negative number) for an option."""
    out: list[str] = []
    for word in argv:
        if out and out[-1] in _VALUE_OPTIONS and word.startswith("-"):
            out[-1] += "=" + word
        else:
            out.append(word)
    return out


def main(argv: list[str] | None = None) -> Any:
    words = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(_glue_negative_values(words))
    # only a real command line may be re-executed (cmd_serve); a caller of
    # main(argv) (tests, scripts) keeps its process
    args.argv = words if argv is None else None
    args.words = words  # what was asked, for a record of the run
    try:
        return globals()[f"cmd_{args.command}"](args)  # cmd_NAME runs subcommand NAME
    except InputError as exc:  # refused input: one line, status 2 (a bug keeps its traceback)
        print(f"vibtrans {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
