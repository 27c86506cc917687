"""What a session of the explorer has selected, with no widgets: the
scene's parameters and the page's settings (`ExplorerState`, mirrored in
the URL through `URL_KEYS`), and the ranges the explorer runs.

The settings are the library's: the scene's are `vibtrans.Scene`'s
parameters (`ExplorerScene`: copies of their declarations within the
explorer's limits, `SCENE_LIMITS`), the device's and its particle's tip
are `design.Device` and `designtip.Tip` (the state is one of each: the
Units and Design tabs edit it).  The lists of fields and the link's keys
are read from `.param`."""

import copy
import math

import param

from vibtrans import Scene
from vibtrans.analysis.summary import V0
from vibtrans.core.params import PLANE, ROLLING_NONE, ProfileSpec, check_profile
from vibtrans.core.profiles import FLAT_MAX, N_MIN, parse_profile
from vibtrans.products import design
from vibtrans.products.design import Device
from vibtrans.products.designtip import Tip
from vibtrans_explorer.session.urlstate import literal

# the material of the shipped maps and the paper (Scene's defaults)
MAP_MATERIAL = {"theta": Scene.param.theta.default, "nu": Scene.param.nu.default}
# the shipped maps' ramp and observation time (Scene's defaults); a map on
# demand may have its own (app/session/maprequest.py)
MAP_RUN = {"tau": Scene.param.tau.default, "periods": Scene.param.periods.default}
RUN_TAU = (0.0, 1000.0)  # tau, periods
RUN_PERIODS = (10.0, 10000.0)  # observation time, periods (the step cap refuses costly runs)
# Wider than the shipped maps (vibtrans.core.params.MAP_LOG_*): a scene runs
# wherever the kernels do (a SAW device reaches A* ~ 2e3); the step budget
# refuses the costly ones.
SCENE_LOG_AMPLITUDE = (-6.0, 6.0)  # log10 A*
SCENE_LOG_MASS = (-8.0, 8.0)  # log10 m*
# The explorer's limits on the library's scene settings (each narrower than
# Scene's, whose declaration the explorer's copy keeps: default, doc, the
# message naming the parameter and its range): the two models its maps
# show, mu over the shipped maps' friction range, the run's ramp and
# length (RUN_TAU, RUN_PERIODS).  The state, a map request and the Design
# tab take these (ExplorerScene, `limited`).
SCENE_LIMITS = {
    "model": {"objects": ["deformable", "point-mass"]},
    "mu": {"bounds": (0.01, 1.0), "inclusive_bounds": (True, True)},
    "tau": {"bounds": RUN_TAU, "inclusive_bounds": (True, True)},
    "periods": {"bounds": RUN_PERIODS, "inclusive_bounds": (True, True)},
}
# The explorer's limits on the device (the library takes any positive size;
# a link or a form of the explorer stays within these).
DEVICE_LIMITS = {
    "radius": {"bounds": (1e-9, 1.0), "inclusive_bounds": (False, True)},
    "frequency": {"bounds": (1.0, 1e10)},
    "amplitude": {"bounds": (0.0, 1e-2), "inclusive_bounds": (False, True)},
    "preload": {"bounds": (0.0, 1e3)},
}
# the map tabs, as the URL names them
MAP_TABS = ("map", "vertical", "units", "map-on-demand", "difference", "design")


def limited(source, limits, names=None, base=param.Parameterized, name=None):
    """A Parameterized class (a subclass of `base`) holding copies of the
    parameters `names` of `source` (default: those `limits` names): each
    keeps the library's declaration (default, doc, check) with the
    explorer's limit `limits[name]` (the Parameter's attributes it sets:
    bounds, inclusive_bounds, objects), if any."""
    names = tuple(limits) if names is None else tuple(names)
    params = {}
    for n in names:
        p = copy.deepcopy(source.param[n])  # (its own lists: the library's stay as they are)
        for attribute, value in limits.get(n, {}).items():
            setattr(p, attribute, value)
        params[n] = p
    return type(name or f"Limited{source.__name__}", (base,), params)


# the particle's profiles the explorer offers (docs/MODEL.md
# section 10): the library's kinds but a measured table (file:PATH), which
# names a file on the server (a link must not read the server's files) and
# needs the device's load: the API and the CLI take it
PROFILE_VALUES = (
    f"sphere, cone, power:N (N ≥ {N_MIN:g}), flat-sphere:C (0 ≤ C ≤ {FLAT_MAX:g}, "
    f"the flat's radius in sqrt(R a0))"
)
SPHERE = "sphere"


class ExplorerProfile(ProfileSpec):
    """The particle's profile as the library spells it (`Scene.profile`),
    checked by the library (`check_profile`: its message names the
    parameter and its range); a measured table is refused here."""

    valid_values = PROFILE_VALUES  # urlstate.valid_range's words
    refuse_measured = (
        f"profile: a measured table (file:PATH) is not offered by the "
        f"explorer (a link cannot name a file on the server; the API and "
        f"`vibtrans simulate --profile file:PATH` take it); it must be "
        f"one of {PROFILE_VALUES}"
    )

    def check_text(self, raw):
        """The value of a typed or linked text (urlstate.convert), or the
        library's InputError (a ValueError) saying why not."""
        check_profile(raw, self.refuse_measured)
        return raw


def is_sphere(profile):
    """Does the spec run the sphere's own law (Hertz's path: the shipped
    maps' particle)?  'sphere' and 'power:2' do; 'flat-sphere:0' is the
    sphere tabulated (equal to rounding, not bit for bit)."""
    shape = parse_profile(profile)
    return getattr(shape, "n", None) == 2.0


def within(la, lm, log_amplitude, log_mass):
    """Is (log10 A*, log10 m*) inside the closed ranges given?"""
    return log_amplitude[0] <= la <= log_amplitude[1] and log_mass[0] <= lm <= log_mass[1]


# the library's scene settings a session chooses: Scene's but its point on
# the plane (the state's log10 A* and m*, a map request's window) and a
# measured profile's load (the explorer offers no measured table)
SETTINGS = tuple(k for k in Scene.param if k not in ("name", *PLANE, "load_over_modulus"))


class ExplorerScene(limited(Scene, SCENE_LIMITS, SETTINGS, name="ExplorerSceneSettings")):
    """The scene's settings a session chooses (the state's, a map
    request's): Scene's parameters within SCENE_LIMITS, and the particle's
    profile without a measured table (ExplorerProfile).  The state's theta
    and nu are the maps' (Scene's defaults) unless a device set its own;
    its tau and periods the shipped maps' unless a click on a map on
    demand ran that map's."""

    profile = ExplorerProfile(SPHERE, doc=f"the particle's profile: {PROFILE_VALUES}")

    @param.depends("model", watch=True)
    def _point_does_not_roll(self):
        # the material point has no size to turn (docs/MODEL.md section 11):
        # its scene is the one Scene takes (the rolling selector says so)
        if rolling_refused(self.model, self.rolling):
            self.rolling = ROLLING_NONE


def rolling_refused(model, rolling):
    """Why `rolling` cannot go with `model` (the library's rule: only the
    deformable particle turns), or "" when it can."""
    if rolling == ROLLING_NONE or model == "deformable":
        return ""
    return (
        f"rolling must be none with model {model} (the material point has no size to "
        f"turn); with model deformable it is {ExplorerScene.param.rolling.valid_values}"
    )


def link_conflicts(values, url_keys):
    """(values, errors): a link's checked values (urlstate.parse) that are
    valid alone but not together, refused with a message naming the URL
    key and what it takes; the refused value is left out (its parameter
    keeps its default, and the link runs nothing)."""
    model = values.get("model", ExplorerScene.param.model.default)
    why = rolling_refused(model, values.get("rolling", ROLLING_NONE))
    if not why:
        return values, []
    given = values["rolling"]
    given = f"{given:g}" if isinstance(given, float) else given
    values = {k: v for k, v in values.items() if k != "rolling"}
    return values, [f"URL parameter '{url_keys['rolling']}' (rolling): {literal(why)}; got '{given}'"]


# the device of the Units and Design tabs (SI units; one form, two tabs)
# within the explorer's limits
ExplorerDevice = limited(Device, DEVICE_LIMITS, base=Device, name="ExplorerDevice")


class ExplorerState(Tip, ExplorerDevice, ExplorerScene):
    """What the user selected; mirrored in the URL.  Its scene's settings
    are ExplorerScene's, its device and the particle's tip the library's
    (Device within DEVICE_LIMITS, Tip): the Units and Design tabs edit
    them here."""

    v0 = param.Number(default=V0, bounds=(1e-3, 10.0), doc="white band |v*| <= v0*")
    log_amplitude = param.Number(default=-0.3, bounds=SCENE_LOG_AMPLITUDE)
    log_mass = param.Number(default=1.0, bounds=SCENE_LOG_MASS)
    compare = param.Selector(default="tau twin", objects=["none", "tau twin", "point mass"])
    chaotic = param.Selector(default="grey", objects=["grey", "colour"])
    # what the map shows: the drift, or the chaos indicator
    layer = param.Selector(default="drift velocity", objects=["drift velocity", "Lyapunov exponent"])
    # the period-1 orbit's period doubling and stability region over the map
    orbits = param.Selector(default="no orbit curves", objects=["no orbit curves", "period-1 orbit curves"])
    # one map (the selected model's) or the two models side by side, linked
    maps = param.Selector(default="selected model", objects=["selected model", "both models"])
    # the map on demand shown (app/session/maprequest.py's URL form), None: the shipped map
    map_request = param.String(default=None, allow_None=True)
    # the map tab shown
    tab = param.Selector(default="map", objects=list(MAP_TABS))
    # the typed fields whose text is not a valid value: {parameter: message}
    # (the parameter keeps its last valid value; a run refuses meanwhile)
    invalid = param.Dict(default={}, precedence=-1)

    def device(self):
        """The device in normalized units (units.NormalizedScene), or the
        library's ValueError naming what is wrong."""
        return self.device_spec().normalized()

    def device_tip(self):
        """(A*, m*, a0 [m], the normalized profile) of the device with its
        tip (design.device_quantities; the sphere: the converter's own
        numbers), or the library's ValueError."""
        if self.tip == "sphere":
            n = self.device()
            return n.A_star, n.m_star, n.a0, SPHERE
        q = design.device_quantities(self.device_spec(), shape=self.tip_shape())
        return q.A_star, q.m_star, q.a0, q.scene_profile

    def device_scene_values(self):
        """The scene values of the device: (log10 A*, log10 m*, theta, nu)
        unrounded, or ValueError.  With a tip, its A* and m* (its own a0)."""
        n = self.device()
        A_star, m_star, _, _ = self.device_tip()
        if not A_star > 0:
            raise ValueError("the device's A* is not positive")
        return math.log10(A_star), math.log10(m_star), n.theta, n.nu

    def select_device(self, **scene):
        """The device of the Units and Design tabs (as its form shows it)
        becomes the selected scene: its (log10 A*, m*, theta, nu) unrounded,
        with `scene`'s other values (the Design tab's mu, periods).
        ValueError (the message for "Not run: ...", Markdown) while one of its
        fields is invalid, or its scene lies outside the explorer's range;
        then nothing changes."""
        errors = self.device_errors()
        if errors:
            raise ValueError(" · ".join(errors))
        try:
            la, lm, theta, nu = self.device_scene_values()
        except ValueError as exc:
            raise ValueError(f"the device is not a scene: {literal(exc)}") from None
        if not within(la, lm, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS):
            raise ValueError(
                literal(
                    f"the device (log10 A* = {la:.4g}, log10 m* = {lm:.4g}) is outside the "
                    f"explorer's range: log10 A* in {list(SCENE_LOG_AMPLITUDE)}, log10 m* in "
                    f"{list(SCENE_LOG_MASS)}."
                )
            )
        profile = self.device_tip()[3]
        self.param.update(log_amplitude=la, log_mass=lm, theta=theta, nu=nu, profile=profile, **scene)

    def device_fields(self):
        """The device's fields in use: DEVICE_FIELDS but the sizes of the
        tip's other kinds (hidden: their text does not make the device)."""
        return tuple(k for k in DEVICE_FIELDS if k not in TIP_FIELDS or k == "tip" or k in self.sizes())

    def device_errors(self):
        """The messages of the device's invalid typed fields (in use)."""
        return self.errors(self.device_fields())

    def errors(self, fields):
        """The messages of the invalid typed fields among `fields`."""
        return [msg for name, msg in self.invalid.items() if name in fields]

    def set_invalid(self, name, message):
        """Record (message) or clear ("") a typed field's error."""
        invalid = dict(self.invalid)
        if message:
            invalid[name] = message
        else:
            invalid.pop(name, None)
        if invalid != self.invalid:
            self.invalid = invalid

    def scene(self):
        """The selected scene (a vibtrans.Scene; ValueError if invalid)."""
        return Scene(
            amplitude=10**self.log_amplitude,
            mass=10**self.log_mass,
            **{k: getattr(self, k) for k in SETTINGS},
        )


# the fields whose value makes the scene (a run refuses while one is
# invalid): its settings and its point
SCENE_FIELDS = (*SETTINGS, "log_amplitude", "log_mass")
# the particle's tip in SI (the Design tab's; designtip.Tip): its kind, and
# the sizes each kind takes
TIP_FIELDS = tuple(k for k in Tip.param if k != "name")
# the device's fields (its run refuses while one is invalid): Device's and its tip's
DEVICE_FIELDS = (*(k for k in Device.param if k != "name"), *TIP_FIELDS)
# The link: every parameter of the state but the page's own bookkeeping (the
# map on demand has its own key, maprequest.URL_KEY), the map's colour of
# chaos and a custom material's properties; some under a short key.
NOT_IN_LINK = ("name", "chaotic", "map_request", "invalid", "substrate_custom", "particle_custom")
SHORT_KEYS = {
    "log_amplitude": "la",
    "log_mass": "lm",
    "stick_rule": "rule",
    "alpha_t": "at",
    "frequency": "freq",
    "amplitude": "amp",
    "tip_half_angle": "tipa",
    "tip_exponent": "tipn",
    "tip_radius": "tipr",
    "tip_flat_radius": "tipc",
}
URL_KEYS = {k: SHORT_KEYS.get(k, k) for k in ExplorerState.param if k not in NOT_IN_LINK}
# a value's older spellings in links, still accepted: {parameter: {old: new}}
URL_ALIASES = {
    "model": {"point_mass": "point-mass", "pointmass": "point-mass", "point mass": "point-mass"},
    "compare": {"point-mass": "point mass", "point_mass": "point mass", "tau-twin": "tau twin"},
}
