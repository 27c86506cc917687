"""A map on demand's request, with no widgets and no server: its values
(each a parameter with the range it accepts), its checks, its compact URL
form, its sweep and cache key, and its a-priori time.

    request = MapRequest(model="point-mass", mu=0.5, la_from=-1, la_to=1, ...)
    request.problems()        # [] or one message per invalid value
    text = encode(request)    # the `map=` URL value; decode(text) -> (request, errors)
    estimate(request, step_seconds, workers)   # its a-priori time (Estimate)

Its stopping rule (`stop`): "decided" (the default of a new
request: each point's run ends once its drift is known to the fidelity's
stated error, vibtrans.core.stopping.DecidedRule) or "full" (every point
runs all its periods).  A link written before the rule was part of the
request (one value fewer) meant full runs, and still does.

Its particle's `profile` (the library's spec, checked by it as
the page's is: state.ExplorerProfile) is the 18th value; a link without it
(older) means the sphere, as it did.  The material point is rigid: its
requests run and are keyed without a profile (one map whatever it says).

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
from vibtrans.core.drivers import scene_scales
from vibtrans.core.fidelity import scan_step, step_count, time_step
from vibtrans.core.params import POINT_MASS_SETTINGS
from vibtrans.core.stopping import STOPS
from vibtrans.maps.adaptive import DEFAULT_DRIFT_TOLERANCE
from vibtrans.maps.cost import expected_time_share
from vibtrans_explorer.session import urlstate
from vibtrans_explorer.session.state import (
    SCENE_LOG_AMPLITUDE,
    SCENE_LOG_MASS,
    SETTINGS,
    SPHERE,
    ExplorerScene,
    is_sphere,
    rolling_refused,
)

# the sweep's chaos verdict (vibtrans.maps.sweep.CHAOS_SOURCES): the run's own
# Lyapunov exponent (no twin run; the material point's of its impact map)
CHAOS = "lyapunov"
# a material point's map judged its chaos by the tau twin in older versions
# (0.2.0 had no exponent for it in maps): its key names the new verdict, so
# that a cache never serves a map of the old verdict as one of the new
POINT_MASS_CHAOS = "impact map"
# A server's per-request limits: beyond them a request is refused with its
# a-priori time before anything runs (environment VIBTRANS_MAP_MAX_POINTS and
# VIBTRANS_MAP_MAX_SECONDS set them for `vibtrans serve`, app/server/mapjobs.py).
MAX_POINTS = 100_000
MAX_SECONDS = 1800.0
# the share of the finest grid the refinement computes, by the finest grid's
# points per axis (measured on maps of 4 coarse cells, 1 to 6 levels, over
# the regime plane's middle; a map of more coarse cells computes the share
# of its own points per axis: the refinement follows the regimes' boundaries,
# so its points grow with the grid's side, not its area)
COMPUTED_SHARE = ((9, 0.9), (17, 0.66), (33, 0.45), (65, 0.3), (129, 0.2), (257, 0.15))
# a map's own seconds besides its points (its store, its levels' pictures,
# its points' passage to the workers and back): most of a map of a few
# seconds, which without it came out at 2-5x its a-priori time (81 to 1089
# points, one worker, a 2-core host)
MAP_START_SECONDS = 0.4


class MapRequest(ExplorerScene):
    """What a map on demand computes: the scene's settings (ExplorerScene's:
    the library's within the explorer's limits), the window (log10 bounds)
    and the resolution."""

    la_from = param.Number(default=-1.0, bounds=SCENE_LOG_AMPLITUDE, doc="log10 A* from")
    la_to = param.Number(default=1.0, bounds=SCENE_LOG_AMPLITUDE, doc="log10 A* to")
    lm_from = param.Number(default=-1.0, bounds=SCENE_LOG_MASS, doc="log10 m* from")
    lm_to = param.Number(default=1.0, bounds=SCENE_LOG_MASS, doc="log10 m* to")
    cells = param.Integer(default=4, bounds=(1, 64), doc="coarse grid cells per axis")
    levels = param.Integer(default=3, bounds=(1, 6), doc="refinement levels K")
    stop = param.Selector(
        default="decided",
        objects=sorted(STOPS),
        doc=(
            "the points' stopping rule: decided (each run ends once its drift is known to the "
            "fidelity's stated error, or its chaos verdict is decided) or full (every run to "
            "T_obs)"
        ),
    )

    def profiled(self):
        """Does the request run a profile other than the sphere's (a
        deformable particle's; the material point has none)?"""
        return self.model != "point-mass" and not is_sphere(self.profile)

    def rolls(self):
        """Does the request's particle turn (docs/MODEL.md section 11)?"""
        return self.rolling != "none"

    def points_per_axis(self):
        return self.cells * 2**self.levels + 1

    def points(self):
        """Points of the finest grid (an upper bound of those computed)."""
        return self.points_per_axis() ** 2

    def axes(self):
        """(log10 A* values, log10 m* values) of the finest grid."""
        n = self.points_per_axis()
        return (
            np.round(np.linspace(self.la_from, self.la_to, n), 10),
            np.round(np.linspace(self.lm_from, self.lm_to, n), 10),
        )

    def problems(self, max_points=MAX_POINTS):
        """What makes the request impossible, one message each ([] if none)."""
        out = []
        for axis, lo, hi in (("log10 A*", self.la_from, self.la_to), ("log10 m*", self.lm_from, self.lm_to)):
            if not lo < hi:
                out.append(f"the window's {axis} 'from' ({lo:g}) must be below its 'to' ({hi:g})")
        if rolling_refused(self.model, self.rolling):
            out.append(rolling_refused(self.model, self.rolling))
        if self.points() > max_points:
            out.append(
                f"{self.points_per_axis()} x {self.points_per_axis()} = "
                f"{self.points():,} points is over this server's limit of "
                f"{max_points:,}: fewer coarse cells or levels"
            )
        return out

    def scene_values(self):
        """The scene's values but A* and m* (a dict for vibtrans.Sweep); the
        material point's own rules only for it (they change nothing else)."""
        values = {k: getattr(self, k) for k in SETTINGS if k not in (*POINT_MASS_SETTINGS, "profile")}
        if self.model == "point-mass":
            values.update({k: getattr(self, k) for k in POINT_MASS_SETTINGS})
        elif self.profile != SPHERE:
            values["profile"] = self.profile
        return values

    def sweep(self):
        """The vibtrans.Sweep of the finest grid (InputError if invalid)."""
        from vibtrans.maps.sweep import Sweep

        la, lm = self.axes()
        return Sweep(
            la, lm, chaos=CHAOS, command="explorer map on demand", stop=self.stop, **self.scene_values()
        )

    def cache_request(self):
        """The dict that keys the map in the cache (vibtrans.maps.cache):
        everything that changes a number, nothing that does not.  The
        stopping rule is named where it is not "full" (a full map keeps the
        key it had before the rule existed, as its store's attributes do)."""
        scene = Scene(**self.scene_values())
        # (a particle that does not roll keeps the key it had before rolling)
        return {
            "scene": {
                k: getattr(scene, k)
                for k in sorted(scene.param)
                if k not in ("name", "amplitude", "mass") and not (k == "rolling" and scene.rolling == "none")
            },
            "log_amplitude": [self.la_from, self.la_to],
            "log_mass": [self.lm_from, self.lm_to],
            "points_per_axis": self.points_per_axis(),
            "max_level": self.levels,
            "drift_tolerance": DEFAULT_DRIFT_TOLERANCE,
            "chaos": CHAOS,
            **({"point_mass_chaos": POINT_MASS_CHAOS} if self.model == "point-mass" else {}),
            **({"stop": self.stop} if self.stop != "full" else {}),
        }

    def title(self):
        scene = (
            f"{self.model}, mu = {self.mu:g}, theta = {self.theta:g}, nu = {self.nu:g}, "
            f"tau = {self.tau:g}, {self.periods:g} periods, {self.fidelity}"
        )
        if self.model == "point-mass":
            scene += f", {self.stick_rule} rule, alpha_t = {self.alpha_t:g}"
        elif self.profile != SPHERE:
            scene += f", profile {self.profile}"
        if self.rolls():
            scene += f", rolling {_text(self.rolling)}"
        return f"{scene}; {self.rule_text()}"

    def rule_text(self):
        """The stopping rule in words (the map's caption says it)."""
        return STOP_WORDS[self.stop]

    def copy(self):
        return MapRequest(**self.values())

    def values(self):
        return {k: getattr(self, k) for k in FIELDS}


STOP_WORDS = {
    "decided": "each point run until its drift is decided (stop: decided)",
    "full": "every point run all its periods (stop: full)",
}

# The URL form: a request's parameters, comma-separated, in the order links
# hold them (the form's first sixteen, then those appended since).  A link
# keeps working while fields are only appended: a link without the appended
# ones takes LEGACY's values for them, what it meant when it was written.
FIELDS = (
    "model",
    "mu",
    "theta",
    "nu",
    "tau",
    "periods",
    "fidelity",
    "integrator",
    "stick_rule",
    "alpha_t",
    "la_from",
    "la_to",
    "lm_from",
    "lm_to",
    "cells",
    "levels",
    "stop",
    "profile",
    "rolling",
)
# the appended fields' values for an older link: before `stop` every map ran
# in full, before `profile` every particle was the sphere, before `rolling`
# no particle turned
LEGACY = {"stop": "full", "profile": SPHERE, "rolling": "none"}
assert tuple(LEGACY) == FIELDS[len(FIELDS) - len(LEGACY) :]
# (every parameter of a request is in its link, once)
assert sorted(FIELDS) == sorted(k for k in MapRequest.param if k != "name")
URL_KEY = "map"


def _text(value):
    return value if isinstance(value, str) else f"{value:.10g}"


# appended fields a link leaves out at their LEGACY value (a particle that
# does not roll keeps the link it had before rolling)
OMITTED_AT_LEGACY = ("rolling",)


def encode(request):
    """The request as the URL's `map=` value."""
    texts = [_text(getattr(request, k)) for k in FIELDS]
    while (
        FIELDS[len(texts) - 1] in OMITTED_AT_LEGACY
        and getattr(request, FIELDS[len(texts) - 1]) == LEGACY[FIELDS[len(texts) - 1]]
    ):
        texts.pop()
    return ",".join(texts)


def decode(raw):
    """(MapRequest or None, errors): the URL's `map=` value checked field by
    field (urlstate.convert: the same rules as the other URL values), then
    as a whole (MapRequest.problems, without a server's point limit)."""
    raw = urlstate.as_text(raw)
    if len(raw) > urlstate.MAX_LENGTH * len(FIELDS):
        return None, [f"URL parameter '{URL_KEY}' (a map request) is too long"]
    parts = raw.split(",")
    older = len(FIELDS) - len(parts)
    if not 0 <= older <= len(LEGACY):
        return None, [
            f"URL parameter '{URL_KEY}' (a map request) must hold {len(FIELDS)} "
            f"comma-separated values ({', '.join(FIELDS)}; an older link may omit "
            f"the last {len(LEGACY)}: {', '.join(LEGACY)}); got {len(parts)}"
        ]
    values, errors = {k: LEGACY[k] for k in FIELDS[len(parts) :]}, []
    for name, text in zip(FIELDS, parts):
        p = MapRequest.param[name]
        try:
            values[name] = urlstate.convert(p, text)
        except ValueError:
            errors.append(
                f"URL parameter '{URL_KEY}': {name} must be "
                f"{urlstate.valid_range(p)}; got '{urlstate.shown(text.strip())}'"
            )
    if errors:
        return None, errors
    request = MapRequest(**values)
    problems = request.problems(max_points=math.inf)
    if problems:
        return None, [f"URL parameter '{URL_KEY}': {p}" for p in problems]
    return request, []


class Estimate(NamedTuple):
    """A map's a-priori time, before any of its points has run: `points` of
    the finest grid, `computed` the points the refinement is expected to
    compute (expected_points), `steps` their expected integration
    steps under the request's stopping rule, `seconds` their time at this
    server's measured cost per step and per point over its map workers."""

    points: int
    computed: float
    steps: float
    seconds: float

    def text(self, workers):
        return (
            f"At most {self.points:,} points ({math.isqrt(self.points)} per axis); the "
            f"refinement computes only where the map changes: about {self.computed:,.0f} "
            f"of them expected, {self.steps:.3g} integration steps: about "
            f"{duration(self.seconds)} on this server ({workers} "
            f"core{'s' if workers != 1 else ''}, from its measured time per step). "
            f"The time left is shown as the map computes."
        )


def duration(seconds):
    """`seconds` as the page says a map's time: "12 s", "3 min", "1.5 h"."""
    if seconds < 90:
        return f"{max(seconds, 0.1):.2g} s"
    if seconds < 5400:
        return f"{seconds / 60:.2g} min"
    return f"{seconds / 3600:.2g} h"


def bound_steps(request):
    """The upper bound of the steps of each point of the finest grid, each
    run to T_obs (an array indexed [log_amplitude, log_mass])."""
    if request.model == "point-mass":
        # event-driven: scanned on its grid (high flights skip it: a bound)
        steps = step_count(request.periods, scan_step(request.fidelity))
        return np.full((request.points_per_axis(),) * 2, float(steps))
    scales = scene_scales(Scene(profile=request.profile))
    la, lm = request.axes()
    return np.array(
        [
            [
                step_count(request.periods, time_step(10.0**a, 10.0**m, request.fidelity, scales=scales))
                for m in lm
            ]
            for a in la
        ],
        dtype=float,
    )


def estimate(request, step_seconds, point_seconds=0.0, workers=1):
    """The request's a-priori Estimate: MAP_START_SECONDS + the points
    expected to be computed x (their mean expected steps x `step_seconds`,
    this server's measured seconds per step of the request's kernel, +
    `point_seconds`, a point's measured cost besides its steps) over
    `workers`.  Refuse the request by
    `problems` first: this walks every point of the finest grid."""
    steps = bound_steps(request)
    computed = expected_points(request)
    per_point = float(steps.mean()) * expected_time_share(
        request.model, request.stop, request.periods, request.tau, request.fidelity
    )
    return Estimate(
        request.points(),
        computed,
        computed * per_point,
        MAP_START_SECONDS + computed * (per_point * step_seconds + point_seconds) / max(1, workers),
    )


def expected_points(request):
    """The points the refinement is expected to compute: COMPUTED_SHARE
    (interpolated in log points per axis) of the finest grid."""
    n, share = zip(*COMPUTED_SHARE)
    return float(np.interp(np.log(request.points_per_axis()), np.log(n), share)) * request.points()


def seconds_left(elapsed, done, expected):
    """A computing map's remaining seconds as a progress bar says them
    (tqdm's, dask's): `elapsed` / `done` points x the points still expected
    (`expected`, at least those done); None before the first point."""
    if done <= 0:
        return None
    return elapsed / done * max(float(expected) - done, 0.0)
