"""A map on demand's request, with no widgets and no server: its values
(each a parameter with the range it accepts), its checks, its compact URL
form, its sweep and cache key, and its estimated cost.

    request = MapRequest(model="point-mass", mu=0.5, la_from=-1, la_to=1, ...)
    request.problems()        # [] or one message per invalid value
    text = encode(request)    # the `map=` URL value; decode(text) -> (request, errors)
    estimate(request, seconds_per_step, fraction, workers)   # its expected cost

The finest grid has `cells * 2**levels + 1` points per axis, from the
window's lower to its upper bound: the adaptive refinement
(vibtrans.maps.adaptive) starts on every 2**levels-th point (the coarse grid,
`cells + 1` points per axis) and refines level by level where the map
changes.
"""
import math
from typing import NamedTuple

import numpy as np
import param

from vibtrans import Scene
from vibtrans.maps.adaptive import DEFAULT_DRIFT_TOLERANCE
from vibtrans.core.fidelity import scan_step, step_count, time_step

from . import urlstate
from .state import RUN_PERIODS, RUN_TAU, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS

# the sweep's chaos verdict (vibtrans.maps.sweep.CHAOS_SOURCES): the run's own
# Lyapunov exponent (no twin run; the material point falls back to its twin)
CHAOS = "lyapunov"
# A server's per-request limits: beyond them a request is refused with its
# estimate before anything runs (environment VIBTRANS_MAP_MAX_POINTS and
# VIBTRANS_MAP_MAX_SECONDS set them for `vibtrans serve`, app/mapjobs.py).
MAX_POINTS = 100_000
MAX_SECONDS = 1800.0


class MapRequest(param.Parameterized):
    """What a map on demand computes: the scene's values but A* and m*,
    the window (log10 bounds) and the resolution."""

    model = param.Selector(default="deformable", objects=["deformable", "point-mass"])
    mu = param.Number(default=0.3, bounds=(0.01, 1.0))
    theta = param.Number(default=Scene.param.theta.default, bounds=Scene.param.theta.bounds)
    nu = param.Number(default=Scene.param.nu.default, bounds=(0.01, 0.49))
    tau = param.Number(default=Scene.param.tau.default, bounds=RUN_TAU)
    periods = param.Number(default=Scene.param.periods.default, bounds=RUN_PERIODS)
    fidelity = param.Selector(default="standard", objects=["preview", "standard", "reference"])
    integrator = param.Selector(default="ab4", objects=["ab4", "verlet"])
    stick_rule = param.Selector(default=Scene.param.stick_rule.default,
                                objects=Scene.param.stick_rule.objects)
    alpha_t = param.Number(default=Scene.param.alpha_t.default, bounds=Scene.param.alpha_t.bounds)
    la_from = param.Number(default=-1.0, bounds=SCENE_LOG_AMPLITUDE, doc="log10 A* from")
    la_to = param.Number(default=1.0, bounds=SCENE_LOG_AMPLITUDE, doc="log10 A* to")
    lm_from = param.Number(default=-1.0, bounds=SCENE_LOG_MASS, doc="log10 m* from")
    lm_to = param.Number(default=1.0, bounds=SCENE_LOG_MASS, doc="log10 m* to")
    cells = param.Integer(default=4, bounds=(1, 64), doc="coarse grid cells per axis")
    levels = param.Integer(default=3, bounds=(1, 6), doc="refinement levels K")

    def points_per_axis(self):
        return self.cells * 2 ** self.levels + 1

    def points(self):
        """Points of the finest grid (an upper bound of those computed)."""
        return self.points_per_axis() ** 2

    def axes(self):
        """(log10 A* values, log10 m* values) of the finest grid."""
        n = self.points_per_axis()
        return (np.round(np.linspace(self.la_from, self.la_to, n), 10),
                np.round(np.linspace(self.lm_from, self.lm_to, n), 10))

    def problems(self, max_points=MAX_POINTS):
        """What makes the request impossible, one message each ([] if none)."""
        out = []
        for axis, lo, hi in (("log10 A*", self.la_from, self.la_to),
                             ("log10 m*", self.lm_from, self.lm_to)):
            if not lo < hi:
                out.append(f"the window's {axis} 'from' ({lo:g}) must be below its 'to' "
                           f"({hi:g})")
        if self.points() > max_points:
            out.append(f"{self.points_per_axis()} x {self.points_per_axis()} = "
                       f"{self.points():,} points is over this server's limit of "
                       f"{max_points:,}: fewer coarse cells or levels")
        return out

    def scene_values(self):
        """The scene's values but A* and m* (a dict for vibtrans.Sweep); the
        material point's own rules only for it (they change nothing else)."""
        values = {k: getattr(self, k) for k in ("model", "mu", "theta", "nu", "tau", "periods",
                                                "fidelity", "integrator")}
        if self.model == "point-mass":
            values.update(stick_rule=self.stick_rule, alpha_t=self.alpha_t)
        return values

    def sweep(self):
        """The vibtrans.Sweep of the finest grid (InputError if invalid)."""
        from vibtrans.maps.sweep import Sweep
        la, lm = self.axes()
        return Sweep(la, lm, chaos=CHAOS, command="explorer map on demand",
                     **self.scene_values())

    def cache_request(self):
        """The dict that keys the map in the cache (vibtrans.maps.cache):
        everything that changes a number, nothing that does not."""
        scene = Scene(**self.scene_values())
        return {"scene": {k: getattr(scene, k) for k in sorted(scene.param) if k not in
                          ("name", "amplitude", "mass")},
                "log_amplitude": [self.la_from, self.la_to],
                "log_mass": [self.lm_from, self.lm_to],
                "points_per_axis": self.points_per_axis(), "max_level": self.levels,
                "drift_tolerance": DEFAULT_DRIFT_TOLERANCE, "chaos": CHAOS}

    def title(self):
        scene = (f"{self.model}, mu = {self.mu:g}, theta = {self.theta:g}, nu = {self.nu:g}, "
                 f"tau = {self.tau:g}, {self.periods:g} periods, {self.fidelity}")
        if self.model == "point-mass":
            scene += f", {self.stick_rule} rule, alpha_t = {self.alpha_t:g}"
        return scene

    def copy(self):
        return MapRequest(**self.values())

    def values(self):
        return {k: getattr(self, k) for k in FIELDS}


# the URL form: the values in this order, comma-separated (a link keeps
# working while fields are only appended)
FIELDS = ("model", "mu", "theta", "nu", "tau", "periods", "fidelity", "integrator",
          "stick_rule", "alpha_t", "la_from", "la_to", "lm_from", "lm_to", "cells", "levels")
URL_KEY = "map"


def _text(value):
    return value if isinstance(value, str) else f"{value:.10g}"


def encode(request):
    """The request as the URL's `map=` value."""
    return ",".join(_text(getattr(request, k)) for k in FIELDS)


def decode(raw):
    """(MapRequest or None, errors): the URL's `map=` value checked field by
    field (urlstate.convert: the same rules as the other URL values), then
    as a whole (MapRequest.problems, without a server's point limit)."""
    raw = urlstate._text(raw)
    if len(raw) > urlstate.MAX_LENGTH * len(FIELDS):
        return None, [f"URL parameter '{URL_KEY}' (a map request) is too long"]
    parts = raw.split(",")
    if len(parts) != len(FIELDS):
        return None, [f"URL parameter '{URL_KEY}' (a map request) must hold {len(FIELDS)} "
                      f"comma-separated values ({', '.join(FIELDS)}); got {len(parts)}"]
    values, errors = {}, []
    for name, text in zip(FIELDS, parts):
        p = MapRequest.param[name]
        try:
            values[name] = urlstate.convert(p, text)
        except ValueError:
            errors.append(f"URL parameter '{URL_KEY}': {name} must be "
                          f"{urlstate.valid_range(p)}; got '{urlstate.shown(text.strip())}'")
    if errors:
        return None, errors
    request = MapRequest(**values)
    problems = request.problems(max_points=math.inf)
    if problems:
        return None, [f"URL parameter '{URL_KEY}': {p}" for p in problems]
    return request, []


class Estimate(NamedTuple):
    """A map's expected cost: `points` of the finest grid (an upper bound
    of those computed), `steps` (an upper bound of their integration steps,
    runs and twins), `computed` (the points the refinement is expected to
    compute) and `seconds` (the expected wall time on this server), both
    from its own measured rates (app/mapjobs.py); None while unknown."""
    points: int
    steps: float
    seconds: object
    computed: object = None

    def text(self, workers):
        when = ("seconds unknown until this server's speed is measured" if self.seconds is None
                else f"about {_duration(self.seconds)} on this server ({workers} "
                     f"core{'s' if workers != 1 else ''}, from its measured speed)")
        some = ("" if self.computed is None else
                f" The refinement computes only where the map changes: about "
                f"{self.computed:,.0f} of them expected.")
        return (f"At most {self.points:,} points ({math.isqrt(self.points)} per axis), "
                f"{self.steps:.3g} integration steps: {when}.{some}")


def _duration(seconds):
    if seconds < 90:
        return f"{max(seconds, 0.1):.2g} s"
    if seconds < 5400:
        return f"{seconds / 60:.2g} min"
    return f"{seconds / 3600:.2g} h"


def point_steps(request, la, lm):
    """Upper bound of the steps of one point (its run and, where the
    verdict needs one, its chaos twin)."""
    if request.model == "point-mass":
        # event-driven: scanned on its grid; a jumping point runs a twin
        return 2 * step_count(request.periods, scan_step(request.fidelity))
    return step_count(request.periods, time_step(10.0 ** la, 10.0 ** lm, request.fidelity))


def bound_steps(request):
    """The upper bound of the steps of each point of the finest grid (an
    array indexed [log_amplitude, log_mass])."""
    la, lm = request.axes()
    return np.array([[point_steps(request, a, m) for m in lm] for a in la], dtype=float)


def reference_work(request, reference):
    """Each finest-grid point's expected cost in `reference`'s seconds: a
    shipped map of the model (its points' measured `seconds`, read at the
    nearest of its points), scaled by the steps of the request's run over
    those of the reference's (length and fidelity).  None if the window is
    not inside the reference's."""
    ref_la = reference["log_amplitude"].values
    ref_lm = reference["log_mass"].values
    la, lm = request.axes()
    if la.min() < ref_la.min() or la.max() > ref_la.max() or \
            lm.min() < ref_lm.min() or lm.max() > ref_lm.max():
        return None
    ia = np.abs(la[:, None] - ref_la[None, :]).argmin(axis=1)
    im = np.abs(lm[:, None] - ref_lm[None, :]).argmin(axis=1)
    seconds = reference["seconds"].values[np.ix_(ia, im)]
    ref = request.copy()
    ref.param.update(periods=float(reference.attrs["scene_periods"]),
                     fidelity=reference.attrs["scene_fidelity"])
    steps = bound_steps(request)
    ref_steps = np.array([[point_steps(ref, ref_la[i], ref_lm[j]) for j in im] for i in ia],
                         dtype=float)
    work = seconds * steps / ref_steps
    return np.where(np.isfinite(work), work, np.nanmedian(work))


def estimate(request, seconds_per_work=None, work=None, computed=1.0, workers=1,
             start_seconds=0.0, point_seconds=0.0):
    """The request's Estimate (refuse it by `problems` first: this walks
    every point of the finest grid).  work: each finest-grid point's cost in
    some unit (default: its bounded steps), seconds_per_work: this server's
    wall seconds per unit of it on one worker; computed: the points the
    refinement is expected to compute (a boolean array of the finest grid,
    or the share of it); start_seconds, point_seconds: the map's own work,
    once and per point computed."""
    steps = bound_steps(request)
    work = steps if work is None else work
    if isinstance(computed, np.ndarray):
        n, total = float(computed.sum()), float(work[computed].sum())
    else:
        n, total = computed * request.points(), computed * float(work.sum())
    seconds = (None if seconds_per_work is None else
               start_seconds + n * point_seconds + total * seconds_per_work / max(1, workers))
    return Estimate(request.points(), float(steps.sum()), seconds, n)
