"""A map on demand's request, with no widgets and no server: its values
(each a parameter with the range it accepts), its checks, its compact URL
form, its sweep and cache key, and its estimated cost.

    request = MapRequest(model="point-mass", mu=0.5, la_from=-1, la_to=1, ...)
    request.problems()        # [] or one message per invalid value
    text = encode(request)    # the `map=` URL value; decode(text) -> (request, errors)
    estimate(request, seconds_per_step, fraction, workers)   # its expected cost

Its stopping rule (`stop`, issue 35): "decided" (the default of a new
request: each point's run ends once its drift is known to the fidelity's
stated error, vibtrans.core.stopping.DecidedRule) or "full" (every point
runs all its periods).  A link written before the rule was part of the
request (one value fewer) meant full runs, and still does.

Its particle's `profile` (issue 34; the library's spec, checked by it as
the page's is: state.ExplorerProfile) is the 18th value; a link without it
(older) means the sphere, as it did.  The material point is rigid: its
requests run and are keyed without a profile (one map whatever it says).
A profile's kernel costs more per step than the sphere's: each point's
work is scaled by PROFILE_STEP_COST (measured once, below).

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
from vibtrans.analysis.summary import CHAOS_LYAPUNOV
from vibtrans.maps.adaptive import DEFAULT_DRIFT_TOLERANCE
from vibtrans.maps.cost import NOT_STEADY, class_periods, decided_class, expected_periods
from vibtrans.core.drivers import law_path, scene_scales
from vibtrans.core.stopping import STOPS
from vibtrans.core.fidelity import scan_step, step_count, time_step

from . import urlstate
from .state import (PROFILE_VALUES, RUN_PERIODS, RUN_TAU, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS,
                    SPHERE, ExplorerProfile, is_sphere)

# the sweep's chaos verdict (vibtrans.maps.sweep.CHAOS_SOURCES): the run's own
# Lyapunov exponent (no twin run; the material point's of its impact map)
CHAOS = "lyapunov"
# a material point's map judged its chaos by the tau twin until 2026-11-27
# (0.2.0 had no exponent for it in maps): its key names the new verdict, so
# that a cache never serves a map of the old verdict as one of the new
POINT_MASS_CHAOS = "impact map"
# the run's share of a jumping point's seconds in a map judged by its tau
# twin (the run and its twin, as long as each other to within their regimes)
TWIN_SHARE = 0.5
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
    stop = param.Selector(default="decided", objects=sorted(STOPS), doc=(
        "the points' stopping rule: decided (each run ends once its drift is known to the "
        "fidelity's stated error, or its chaos verdict is decided) or full (every run to "
        "T_obs)"))
    profile = ExplorerProfile(SPHERE, doc=f"the particle's profile: {PROFILE_VALUES}")

    def profiled(self):
        """Does the request run a profile other than the sphere's (a
        deformable particle's; the material point has none)?"""
        return self.model != "point-mass" and not is_sphere(self.profile)

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
        elif self.profile != SPHERE:
            values["profile"] = self.profile
        return values

    def sweep(self):
        """The vibtrans.Sweep of the finest grid (InputError if invalid)."""
        from vibtrans.maps.sweep import Sweep
        la, lm = self.axes()
        return Sweep(la, lm, chaos=CHAOS, command="explorer map on demand", stop=self.stop,
                     **self.scene_values())

    def cache_request(self):
        """The dict that keys the map in the cache (vibtrans.maps.cache):
        everything that changes a number, nothing that does not.  The
        stopping rule is named where it is not "full" (a full map keeps the
        key it had before the rule existed, as its store's attributes do)."""
        scene = Scene(**self.scene_values())
        return {"scene": {k: getattr(scene, k) for k in sorted(scene.param) if k not in
                          ("name", "amplitude", "mass")},
                "log_amplitude": [self.la_from, self.la_to],
                "log_mass": [self.lm_from, self.lm_to],
                "points_per_axis": self.points_per_axis(), "max_level": self.levels,
                "drift_tolerance": DEFAULT_DRIFT_TOLERANCE, "chaos": CHAOS,
                **({"point_mass_chaos": POINT_MASS_CHAOS} if self.model == "point-mass" else {}),
                **({"stop": self.stop} if self.stop != "full" else {})}

    def title(self):
        scene = (f"{self.model}, mu = {self.mu:g}, theta = {self.theta:g}, nu = {self.nu:g}, "
                 f"tau = {self.tau:g}, {self.periods:g} periods, {self.fidelity}")
        if self.model == "point-mass":
            scene += f", {self.stick_rule} rule, alpha_t = {self.alpha_t:g}"
        elif self.profile != SPHERE:
            scene += f", profile {self.profile}"
        return f"{scene}; {self.rule_text()}"

    def rule_text(self):
        """The stopping rule in words (the map's caption says it)."""
        return STOP_WORDS[self.stop]

    def expected_share(self, profile=None):
        """The expected periods a point runs over T_obs under the request's
        rule (vibtrans.maps.cost.expected_periods; `profile`: (f_end,
        extra periods), else the model's measured one): 1 for full runs."""
        return expected_periods(self.model, self.stop, self.periods, self.tau,
                                profile, self.fidelity) / float(self.periods)

    def copy(self):
        return MapRequest(**self.values())

    def values(self):
        return {k: getattr(self, k) for k in FIELDS}


STOP_WORDS = {"decided": "each point run until its drift is decided (stop: decided)",
              "full": "every point run all its periods (stop: full)"}

# the URL form: the values in this order, comma-separated (a link keeps
# working while fields are only appended: a link without the appended ones
# takes LEGACY's values for them, what it meant when it was written)
FIELDS = ("model", "mu", "theta", "nu", "tau", "periods", "fidelity", "integrator",
          "stick_rule", "alpha_t", "la_from", "la_to", "lm_from", "lm_to", "cells", "levels",
          "stop", "profile")
# the appended fields' values for an older link: before `stop` every map ran
# in full, before `profile` every particle was the sphere
LEGACY = {"stop": "full", "profile": SPHERE}
assert tuple(LEGACY) == FIELDS[len(FIELDS) - len(LEGACY):]
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
    older = len(FIELDS) - len(parts)
    if not 0 <= older <= len(LEGACY):
        return None, [f"URL parameter '{URL_KEY}' (a map request) must hold {len(FIELDS)} "
                      f"comma-separated values ({', '.join(FIELDS)}; an older link may omit "
                      f"the last {len(LEGACY)}: {', '.join(LEGACY)}); got {len(parts)}"]
    values, errors = {k: LEGACY[k] for k in FIELDS[len(parts):]}, []
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
    of those computed), `steps` (an upper bound of their integration steps:
    every run to T_obs), `computed` (the points the
    refinement is expected to compute) and `seconds` (the expected wall time
    on this server), both from its own measured rates (app/mapjobs.py); None
    while unknown.  `share`: the expected periods a point runs over T_obs
    under the request's stopping rule (1 for full runs), which scales each
    point's work in `seconds`; `stop`: that rule."""
    points: int
    steps: float
    seconds: object
    computed: object = None
    share: float = 1.0
    stop: str = "full"

    def text(self, workers):
        when = ("seconds unknown until this server's speed is measured" if self.seconds is None
                else f"about {duration(self.seconds)} on this server ({workers} "
                     f"core{'s' if workers != 1 else ''}, from its measured speed)")
        some = ("" if self.computed is None else
                f" The refinement computes only where the map changes: about "
                f"{self.computed:,.0f} of them expected.")
        rule = ("" if self.stop == "full" else
                f" (each run stops once its drift is decided: about {self.share:.0%} of "
                f"its periods expected, {self.steps * self.share:.3g} steps)")
        return (f"At most {self.points:,} points ({math.isqrt(self.points)} per axis), "
                f"{self.steps:.3g} integration steps{rule}: {when}.{some}")


def duration(seconds):
    """`seconds` as the page says a map's time: "12 s", "3 min", "1.5 h"."""
    if seconds < 90:
        return f"{max(seconds, 0.1):.2g} s"
    if seconds < 5400:
        return f"{seconds / 60:.2g} min"
    return f"{seconds / 3600:.2g} h"


def point_steps(request, la, lm):
    """Upper bound of the steps of one point's run to T_obs (no twin: the
    chaos verdict is the run's own exponent, CHAOS): under the `decided`
    rule a point is expected to run `request.expected_share()` of it
    (`expected_steps`)."""
    if request.model == "point-mass":
        # event-driven: scanned on its grid (high flights skip it: a bound)
        return step_count(request.periods, scan_step(request.fidelity))
    return step_count(request.periods, time_step(10.0 ** la, 10.0 ** lm, request.fidelity,
                                                 scales=_scales(request.profile)))


def _scales(profile):
    """The profile's time-step scales (vibtrans.core.drivers.scene_scales;
    None: the sphere's)."""
    return scene_scales(Scene(profile=profile))


# A profile's kernel cost per step over the sphere's (Hertz's own path), per
# contact-law path (vibtrans.core.drivers.law_path): the deformable kernel
# at paper point 1, best of 7, measured round-robin in one run
# (vibtrans.tools.bench._profile_cost; `vibtrans bench --json`, its
# `profile_cost`) on the development host (2 cores shared, 2026-11-27 14:01
# UTC, after the warm-started root: sphere 51.1 ns/step, cone 1.00x,
# power:3 1.38-1.50x in six runs, power:4 1.47x, power:2.5 2.03x,
# flat-sphere:1 1.41-1.45x, flat-sphere:0.5 1.39x; the power law again
# 17:11-17:17 UTC after the short warm series, docs/MODEL.md section 10:
# power:3 1.30-1.36x in six runs).
PROFILE_STEP_COST = {"cone": 1.0, "power": 1.33, "power-pow": 2.03, "table": 1.43}


def step_cost(request):
    """Each point's work per step over the sphere's: 1 for the sphere and
    the material point, else PROFILE_STEP_COST of the profile's path."""
    if not request.profiled():
        return 1.0
    return PROFILE_STEP_COST[law_path(Scene(profile=request.profile))]


def bound_steps(request):
    """The upper bound of the steps of each point of the finest grid (an
    array indexed [log_amplitude, log_mass])."""
    la, lm = request.axes()
    return np.array([[point_steps(request, a, m) for m in lm] for a in la], dtype=float)


def expected_steps(request, profile=None):
    """Each finest-grid point's expected steps under the request's
    stopping rule: `bound_steps` times `request.expected_share(profile)`."""
    return bound_steps(request) * request.expected_share(profile)


def nearest_points(request, reference):
    """The indices (of log_amplitude, of log_mass) of `reference`'s point
    nearest each finest-grid point of the request, or None if the window is
    not inside the reference's."""
    ref_la = reference["log_amplitude"].values
    ref_lm = reference["log_mass"].values
    la, lm = request.axes()
    if la.min() < ref_la.min() or la.max() > ref_la.max() or \
            lm.min() < ref_lm.min() or lm.max() > ref_lm.max():
        return None
    return (np.abs(la[:, None] - ref_la[None, :]).argmin(axis=1),
            np.abs(lm[:, None] - ref_lm[None, :]).argmin(axis=1))


def reference_classes(request, reference):
    """Each finest-grid point's class for the `decided` rule, read on
    `reference` (a full map of the model) at its nearest point
    (vibtrans.maps.cost.decided_class), its chaos the verdict maps on demand
    judge by (replay_reference), or None for a reference made with the
    rule, or a window outside it."""
    if reference.attrs.get("stop", "full") != "full":
        return None
    nearest = nearest_points(request, reference)
    if nearest is None:
        return None
    at = np.ix_(*nearest)
    reference = replay_reference(reference)
    return decided_class(*(reference[name].values[at] for name in (
        "drift_velocity", "final_drift_velocity", "chaotic", "contact",
        "takeoffs_per_period")))


def reference_share(request, reference, learned=None):
    """Each finest-grid point's expected periods over T_obs under the
    request's stopping rule, from its class in `reference`
    (reference_classes; vibtrans.maps.cost.class_periods, with `learned`
    periods per class); None for full runs or where the classes are
    unknown."""
    classes = None if request.stop == "full" else reference_classes(request, reference)
    if classes is None:
        return None
    return class_periods(request.model, classes, request.periods, request.tau,
                         request.fidelity, learned) / float(request.periods)


def reference_work(request, reference):
    """Each finest-grid point's expected cost in `reference`'s seconds: a
    shipped map of the model (its points' measured `seconds`, read at the
    nearest of its points), scaled by the steps of the request's run over
    those of the reference's (length and fidelity), each run to T_obs (a
    reference made with the `decided` rule: its seconds over the share of
    its periods it ran; one judged by its tau twin: TWIN_SHARE of its
    jumping points' seconds, the run's without its twin).  None if the
    window is not inside the reference's."""
    nearest = nearest_points(request, reference)
    if nearest is None:
        return None
    ia, im = nearest
    ref_la = reference["log_amplitude"].values
    ref_lm = reference["log_mass"].values
    seconds = reference["seconds"].values[np.ix_(ia, im)]
    if "twin_chaotic" in reference or reference.attrs.get("chaos", "twin") == "twin":
        # a reference judged by its tau twin ran one beside each jumping
        # point, about as long as the run: the request's points run none (CHAOS)
        jumping = reference["contact"].values[np.ix_(ia, im)] == 1
        seconds = np.where(jumping, TWIN_SHARE * seconds, seconds)
    if reference.attrs.get("stop", "full") != "full":
        run = reference["periods_run"].values[np.ix_(ia, im)]
        seconds = seconds * float(reference.attrs["scene_periods"]) / run
    ref = request.copy()
    ref.param.update(periods=float(reference.attrs["scene_periods"]),
                     fidelity=reference.attrs["scene_fidelity"],
                     profile=reference.attrs.get("scene_profile", SPHERE))
    steps = bound_steps(request)
    ref_steps = np.array([[point_steps(ref, ref_la[i], ref_lm[j]) for j in im] for i in ia],
                         dtype=float)
    work = seconds * steps / ref_steps
    return np.where(np.isfinite(work), work, np.nanmedian(work))


def replay_reference(reference):
    """`reference` (a shipped map) with the chaos verdict maps on demand
    judge by (CHAOS: the run's own exponent above
    analysis.summary.CHAOS_LYAPUNOV; a point that measured none is not
    chaotic), for replaying the refinement on it
    (vibtrans.maps.adaptive.predict_refinement).  The shipped deformable
    maps' verdict is that one already; the material point's shipped map
    judged its chaos by the tau twin (POINT_MASS_CHAOS) and calls nearly all
    of the plane's middle chaotic, a sea the refinement leaves alone, where
    the runs' own exponents draw boundaries that it refines (the 33 x 33 map
    of mapestimate: 270 points predicted on the twin's verdict, 488 on the
    exponent's, 446 computed)."""
    if "lyapunov" not in reference:
        return reference
    lam = reference["lyapunov"].values
    chaotic = (np.isfinite(lam) & (lam > CHAOS_LYAPUNOV)).astype(reference["chaotic"].dtype)
    return reference.assign(chaotic=(reference["chaotic"].dims, chaotic))


def unknown_drift_reference(reference):
    """`reference` (replay_reference's) with the drift of its not-steady
    points (vibtrans.maps.cost.decided_class) unknown (NaN: a cell holding
    one is refined, maps.adaptive.disagree): the refinement's bound where
    such drifts scatter from point to point (cost.NOT_STEADY_REFINED)."""
    classes = decided_class(*(reference[name].values for name in (
        "drift_velocity", "final_drift_velocity", "chaotic", "contact",
        "takeoffs_per_period")))
    v = reference["drift_velocity"]
    return reference.assign(drift_velocity=(v.dims, np.where(classes == NOT_STEADY, np.nan,
                                                             v.values)))


def estimate(request, seconds_per_work=None, work=None, computed=1.0, workers=1,
             start_seconds=0.0, point_seconds=0.0, profile=None, share=None):
    """The request's Estimate (refuse it by `problems` first: this walks
    every point of the finest grid).  work: each finest-grid point's cost in
    some unit when run to T_obs (default: its bounded steps), scaled here by
    the periods it is expected to run under the request's stopping rule
    (`request.expected_share(profile)`); seconds_per_work: this server's
    wall seconds per unit of the work actually run, on one worker;
    computed: the points the refinement is expected to compute (an array of
    the finest grid: boolean, or each point's expected count, a weight >= 0;
    or the share of the grid); start_seconds,
    point_seconds: the map's own work, once and per point computed; share:
    each point's expected periods over T_obs (reference_share), else the
    same for all (`request.expected_share(profile)`)."""
    steps = bound_steps(request)
    work = steps if work is None else work
    weight = (np.asarray(computed, dtype=float) if isinstance(computed, np.ndarray)
              else np.full(work.shape, float(computed)))
    if share is not None:
        # the mean share of the work, weighted by it (what the total scales by)
        weighted = work * weight
        share = (float((weighted * share).sum() / weighted.sum()) if weighted.sum() > 0
                 else 1.0)
    else:
        share = request.expected_share(profile)
    n, total = float(weight.sum()), float((work * weight).sum())
    seconds = (None if seconds_per_work is None else
               start_seconds + n * point_seconds
               + share * total * seconds_per_work / max(1, workers))
    return Estimate(request.points(), float(steps.sum()), seconds, n, share, request.stop)
