"""What a session of the explorer has selected, with no widgets: the
scene's parameters and the page's settings (`ExplorerState`, mirrored in
the URL through `URL_KEYS`), and the ranges the explorer runs."""
import math

import param

from vibtrans import Scene
from vibtrans.core import units
from vibtrans.core.params import ProfileSpec, check_profile
from vibtrans.core.profiles import N_MIN, parse_profile
from vibtrans.products.design import preset
from vibtrans.analysis.summary import V0

# the material of the shipped maps and the paper (Scene's defaults)
MAP_MATERIAL = {"theta": Scene.param.theta.default, "nu": Scene.param.nu.default}
# the shipped maps' ramp and observation time (Scene's defaults); a map on
# demand may have its own (app/maprequest.py)
MAP_RUN = {"tau": Scene.param.tau.default, "periods": Scene.param.periods.default}
RUN_TAU = (0.0, 1000.0)              # tau, periods
RUN_PERIODS = (10.0, 10000.0)        # observation time, periods (the step cap refuses costly runs)
# Wider than the shipped maps (vibtrans.core.params.MAP_LOG_*): a scene runs
# wherever the kernels do (a SAW device reaches A* ~ 2e3); the step budget
# refuses the costly ones.
SCENE_LOG_AMPLITUDE = (-6.0, 6.0)    # log10 A*
SCENE_LOG_MASS = (-8.0, 8.0)         # log10 m*
# the device's materials (the Units and Design tabs' one list: the library's
# names) and the entry for a material typed as its three properties
MATERIAL_NAMES = tuple(sorted(m.name for m in units.MATERIALS.values()))
CUSTOM_MATERIAL = "custom (E, nu, rho)"
CUSTOM_EXAMPLE = "E=70e9,nu=0.3,rho=2500"   # units.material's custom form (glass's values)
# the map tabs, as the URL names them
# the device the page opens on: the paper's worked example at point 4
PAPER_DEVICE = preset("paper").device
MAP_TABS = ("map", "vertical", "units", "map-on-demand", "difference", "design")
# the fields whose value makes the scene (a run refuses while one is
# invalid), and those of the device (its run refuses while one is)
SCENE_FIELDS = ("log_amplitude", "log_mass", "alpha_t", "mu", "profile")
DEVICE_FIELDS = ("substrate", "particle", "substrate_custom", "particle_custom", "radius",
                 "frequency", "amplitude", "preload")


# the particle's profiles the explorer offers (issue 34; docs/MODEL.md
# section 10): the library's kinds but a measured table (file:PATH), which
# names a file on the server (a link must not read the server's files) and
# needs the device's load: the API and the CLI take it
PROFILE_VALUES = (f"sphere, cone, power:N (N ≥ {N_MIN:g}), flat-sphere:C (C ≥ 0, the flat's "
                  f"radius in sqrt(R a0))")
SPHERE = "sphere"


class ExplorerProfile(ProfileSpec):
    """The particle's profile as the library spells it (`Scene.profile`),
    checked by the library (`check_profile`: its message names the
    parameter and its range); a measured table is refused here."""

    valid_values = PROFILE_VALUES       # urlstate.valid_range's words
    refuse_measured = (f"profile: a measured table (file:PATH) is not offered by the "
                       f"explorer (a link cannot name a file on the server; the API and "
                       f"`vibtrans simulate --profile file:PATH` take it); it must be "
                       f"one of {PROFILE_VALUES}")

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
    return (log_amplitude[0] <= la <= log_amplitude[1]
            and log_mass[0] <= lm <= log_mass[1])


class ExplorerState(param.Parameterized):
    """What the user selected; mirrored in the URL."""

    model = param.Selector(default="deformable", objects=["deformable", "point-mass"])
    mu = param.Number(default=0.3, bounds=(0.01, 1.0))
    v0 = param.Number(default=V0, bounds=(1e-3, 10.0), doc="white band |v*| <= v0*")
    log_amplitude = param.Number(default=-0.3, bounds=SCENE_LOG_AMPLITUDE)
    log_mass = param.Number(default=1.0, bounds=SCENE_LOG_MASS)
    fidelity = param.Selector(default="standard", objects=["preview", "standard", "reference"])
    integrator = param.Selector(default="ab4", objects=["ab4", "verlet"])
    # the particle's profile (the library's spec; the material point, a
    # rigid point, runs the same whatever it is)
    profile = ExplorerProfile(SPHERE, doc=f"the particle's profile: {PROFILE_VALUES}")
    compare = param.Selector(default="tau twin", objects=["none", "tau twin", "point mass"])
    chaotic = param.Selector(default="grey", objects=["grey", "colour"])
    # what the map shows: the drift, or the chaos indicator (issue 15)
    layer = param.Selector(default="drift velocity",
                           objects=["drift velocity", "Lyapunov exponent"])
    # the period-1 orbit's period doubling and stability region over the map
    orbits = param.Selector(default="no orbit curves",
                            objects=["no orbit curves", "period-1 orbit curves"])
    # one map (the selected model's) or the two models side by side, linked
    maps = param.Selector(default="selected model", objects=["selected model", "both models"])
    # the material point's own rules (docs/MODEL.md section 3)
    stick_rule = param.Selector(default=Scene.param.stick_rule.default,
                                objects=Scene.param.stick_rule.objects)
    alpha_t = param.Number(default=Scene.param.alpha_t.default, bounds=Scene.param.alpha_t.bounds)
    # the material's theta and Poisson ratio: the maps' values (Scene's
    # defaults) unless the Units tab's device set its own
    theta = param.Number(default=Scene.param.theta.default, bounds=Scene.param.theta.bounds)
    nu = param.Number(default=Scene.param.nu.default, bounds=Scene.param.nu.bounds,
                      inclusive_bounds=(False, False))

    # a map on demand's ramp and observation time (a click on it runs its
    # scene); the shipped maps' otherwise
    tau = param.Number(default=Scene.param.tau.default, bounds=RUN_TAU)
    periods = param.Number(default=Scene.param.periods.default, bounds=RUN_PERIODS)
    # the map on demand shown (app/maprequest.py's URL form), None: the shipped map
    map_request = param.String(default=None, allow_None=True)

    # the device of the Units and Design tabs (SI units; one form, two tabs),
    # the paper's worked example at point 4 (the Design tab's "paper" preset)
    substrate = param.Selector(default="glass", objects=[*MATERIAL_NAMES, CUSTOM_MATERIAL])
    particle = param.Selector(default="steel", objects=[*MATERIAL_NAMES, CUSTOM_MATERIAL])
    substrate_custom = param.String(default=CUSTOM_EXAMPLE, doc="E=<Pa>,nu=<->,rho=<kg/m^3>")
    particle_custom = param.String(default=CUSTOM_EXAMPLE, doc="E=<Pa>,nu=<->,rho=<kg/m^3>")
    radius = param.Number(default=PAPER_DEVICE.radius, bounds=(1e-9, 1.0),
                          inclusive_bounds=(False, True), doc="the particle's radius, m")
    frequency = param.Number(default=PAPER_DEVICE.frequency, bounds=(1.0, 1e10),
                             doc="the wave's frequency, Hz")
    amplitude = param.Number(default=PAPER_DEVICE.amplitude, bounds=(0.0, 1e-2),
                             inclusive_bounds=(False, True), doc="the wave's vertical amplitude, m")
    preload = param.Number(default=PAPER_DEVICE.preload, bounds=(0.0, 1e3), doc="pre-load, N")
    # the map tab shown
    tab = param.Selector(default="map", objects=list(MAP_TABS))
    # the typed fields whose text is not a valid value: {parameter: message}
    # (the parameter keeps its last valid value; a run refuses meanwhile)
    invalid = param.Dict(default={}, precedence=-1)

    def material(self, which):
        """The text the library reads for the substrate or particle: its
        name, or the custom material's properties."""
        name = getattr(self, which)
        return getattr(self, f"{which}_custom") if name == CUSTOM_MATERIAL else name

    def device(self):
        """The device in normalized units (units.NormalizedScene), or the
        library's ValueError naming what is wrong."""
        return units.to_normalized(self.material("substrate"), self.material("particle"),
                                   self.radius, self.frequency, self.amplitude,
                                   preload=self.preload)

    def device_scene_values(self):
        """The scene values of the device: (log10 A*, log10 m*, theta, nu)
        unrounded, or ValueError."""
        n = self.device()
        if not n.A_star > 0:
            raise ValueError("the device's A* is not positive")
        return math.log10(n.A_star), math.log10(n.m_star), n.theta, n.nu

    def select_device(self, **scene):
        """The device of the Units and Design tabs (as its form shows it)
        becomes the selected scene: its (log10 A*, m*, theta, nu) unrounded,
        with `scene`'s other values (the Design tab's mu, periods).
        ValueError (the message for "Not run: ...") while one of its fields
        is invalid, or its scene lies outside the explorer's range; then
        nothing changes."""
        errors = self.errors(DEVICE_FIELDS)
        if errors:
            raise ValueError(" · ".join(errors))
        try:
            la, lm, theta, nu = self.device_scene_values()
        except ValueError as exc:
            raise ValueError(f"the device is not a scene: {exc}") from None
        if not within(la, lm, SCENE_LOG_AMPLITUDE, SCENE_LOG_MASS):
            raise ValueError(
                f"the device (log10 A* = {la:.4g}, log10 m* = {lm:.4g}) is outside the "
                f"explorer's range: log10 A* in {list(SCENE_LOG_AMPLITUDE)}, log10 m* in "
                f"{list(SCENE_LOG_MASS)}.")
        self.param.update(log_amplitude=la, log_mass=lm, theta=theta, nu=nu, **scene)

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
        return Scene(amplitude=10 ** self.log_amplitude, mass=10 ** self.log_mass, mu=self.mu,
                     model=self.model, fidelity=self.fidelity, integrator=self.integrator,
                     theta=self.theta, nu=self.nu, stick_rule=self.stick_rule,
                     alpha_t=self.alpha_t, tau=self.tau, periods=self.periods,
                     profile=self.profile)


URL_KEYS = {"model": "model", "mu": "mu", "v0": "v0", "log_amplitude": "la",
            "log_mass": "lm", "fidelity": "fidelity", "integrator": "integrator",
            "compare": "compare", "maps": "maps", "stick_rule": "rule", "alpha_t": "at",
            "layer": "layer", "orbits": "orbits", "tau": "tau", "periods": "periods",
            "theta": "theta", "nu": "nu", "substrate": "substrate", "particle": "particle",
            "radius": "radius", "frequency": "freq", "amplitude": "amp",
            "preload": "preload", "tab": "tab", "profile": "profile"}
# a value's older spellings in links, still accepted: {parameter: {old: new}}
URL_ALIASES = {"model": {"point_mass": "point-mass", "pointmass": "point-mass",
                         "point mass": "point-mass"},
               "compare": {"point-mass": "point mass", "point_mass": "point mass",
                           "tau-twin": "tau twin"}}
