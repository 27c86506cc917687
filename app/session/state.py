"""What a session of the explorer has selected, with no widgets: the
scene's parameters and the page's settings (`ExplorerState`, mirrored in
the URL through `URL_KEYS`), and the ranges the explorer runs."""
import math

import param

from vibtrans import Scene
from vibtrans.analysis.summary import V0
from vibtrans.core import units
from vibtrans.core.params import ProfileSpec, check_profile
from vibtrans.core.profiles import FLAT_MAX, N_MIN, parse_profile
from vibtrans.products import design, designtip
from vibtrans.products.design import preset
from vibtrans.products.designtip import TipSize

# the material of the shipped maps and the paper (Scene's defaults)
MAP_MATERIAL = {"theta": Scene.param.theta.default, "nu": Scene.param.nu.default}
# the shipped maps' ramp and observation time (Scene's defaults); a map on
# demand may have its own (app/session/maprequest.py)
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
# the particle's tip in SI (the Design tab's; designtip.tip_shape): its
# kind, and the sizes each kind takes
TIP_FIELDS = ("tip", "tip_half_angle", "tip_exponent", "tip_radius", "tip_flat_radius")
DEVICE_FIELDS = ("substrate", "particle", "substrate_custom", "particle_custom", "radius",
                 "frequency", "amplitude", "preload", *TIP_FIELDS)


# the particle's profiles the explorer offers (issue 34; docs/MODEL.md
# section 10): the library's kinds but a measured table (file:PATH), which
# names a file on the server (a link must not read the server's files) and
# needs the device's load: the API and the CLI take it
PROFILE_VALUES = (f"sphere, cone, power:N (N ≥ {N_MIN:g}), flat-sphere:C (0 ≤ C ≤ {FLAT_MAX:g}, "
                  f"the flat's radius in sqrt(R a0))")
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


# the tip's kinds (designtip.TIP_KINDS but a measured table: a link must
# not make the server read a file) and the sizes each takes
TIP_KINDS = ("sphere", "cone", "power", "flat-sphere")
TIP_SIZES = {"sphere": (), "cone": ("tip_half_angle",), "power": ("tip_exponent", "tip_radius"),
             "flat-sphere": ("tip_flat_radius",)}


def tip_values(owner):
    """The tip's arguments of designtip.tip_shape (profile, half_angle,
    tip_radius, flat_radius) from `owner`'s TIP_FIELDS (a Parameterized or
    a dict), the sizes of its kind only."""
    get = owner.get if isinstance(owner, dict) else lambda name: getattr(owner, name)
    kind = get("tip")
    if kind == "sphere":
        return {"profile": "sphere"}
    if kind == "cone":
        return {"profile": "cone", "half_angle": get("tip_half_angle")}
    if kind == "power":
        return {"profile": f"power:{float(get('tip_exponent'))!r}",
                "tip_radius": get("tip_radius")}
    return {"profile": "flat-sphere", "flat_radius": get("tip_flat_radius")}


def tip_shape_of(owner):
    """The checked designtip.TipShape of `owner`'s tip fields (InputError)."""
    return designtip.tip_shape(**tip_values(owner))


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


class TipFields(param.Parameterized):
    """The particle's tip in SI (the Design tab's; docs/MODEL.md section 10,
    "In device units"): its kind and the sizes of each kind (TIP_SIZES); a
    link without them is the sphere.  The explorer's state and the Design
    tab (alone, in tests) hold these."""

    tip = param.Selector(default="sphere", objects=list(TIP_KINDS),
                         doc="the particle's tip: the sphere, a cone, a power law, a flat")
    tip_half_angle = TipSize(60.0, size="half_angle", range_text="a number in (0, 90) (degrees)",
                             doc="the cone's half-angle, degrees")
    tip_exponent = TipSize(3.0, size="exponent", range_text="a number in (1, inf)",
                           doc="the power law's exponent N: z = r^N / (N R_t^(N-1))")
    tip_radius = TipSize(None, size="tip_radius", allow_None=True,
                         range_text="a number in (0, inf) (m), or empty: the particle's radius",
                         doc="the power law's tip radius R_t, m (None: the particle's radius)")
    tip_flat_radius = TipSize(1e-6, size="flat_radius", range_text="a number in [0, inf) (m)",
                              doc="the flat-ended sphere's flat radius, m")


class ExplorerState(TipFields):
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
    # the map on demand shown (app/session/maprequest.py's URL form), None: the shipped map
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
    # (the particle's tip: TipFields')
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
        return self.device_spec().normalized()

    def tip_shape(self):
        """The particle's tip (designtip.TipShape), or the library's InputError."""
        return tip_shape_of(self)

    def device_spec(self):
        """The device as the library takes it (units.DeviceSpec; its values
        are checked where they are used)."""
        return units.DeviceSpec(self.material("substrate"), self.material("particle"),
                                self.radius, self.frequency, self.amplitude,
                                preload=self.preload)

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
        ValueError (the message for "Not run: ...") while one of its fields
        is invalid, or its scene lies outside the explorer's range; then
        nothing changes."""
        errors = self.device_errors()
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
        profile = self.device_tip()[3]
        self.param.update(log_amplitude=la, log_mass=lm, theta=theta, nu=nu, profile=profile,
                          **scene)

    def device_fields(self):
        """The device's fields in use: DEVICE_FIELDS but the sizes of the
        tip's other kinds (hidden: their text does not make the device)."""
        return tuple(k for k in DEVICE_FIELDS
                     if k not in TIP_FIELDS or k == "tip" or k in TIP_SIZES[self.tip])

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
            "preload": "preload", "tab": "tab", "profile": "profile", "tip": "tip",
            "tip_half_angle": "tipa", "tip_exponent": "tipn", "tip_radius": "tipr",
            "tip_flat_radius": "tipc"}
# a value's older spellings in links, still accepted: {parameter: {old: new}}
URL_ALIASES = {"model": {"point_mass": "point-mass", "pointmass": "point-mass",
                         "point mass": "point-mass"},
               "compare": {"point-mass": "point mass", "point_mass": "point mass",
                           "tau-twin": "tau twin"}}
