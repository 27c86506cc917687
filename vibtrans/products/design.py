"""Design charts in device units: where a device sits on the drift maps, how
fast and which way its particle moves, and where the model stops holding.

A chart varies two of (frequency, radius, amplitude), maps each device to
(A*, m*) (docs/MODEL.md 1, 5) and reads a map of the same mu, theta and nu:
shipped, computed on request (`compute=True`), else refused.  It reads the
nearest grid point (categories do not blend), at most h/2 decades away:
tests/products/test_design.py reads v* = -168 where a direct run gives -176.8, within
the spread of the 3 x 3 neighbours.  SI units unless a name says otherwise.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import param

from vibtrans.core import units
from vibtrans.core.errors import InputError, InputTypeError
from vibtrans.core.params import ROLLING_NONE, check_rolling, inertia_ratio
from vibtrans.core.units import DeviceSpec
from vibtrans.products import designtip

# (in a module of their own: the command line's parser needs them without numpy)
from vibtrans.products.designconst import (  # noqa: F401
    AXIS_LABELS,
    DEFAULT_SURFACE_ENERGY,
    MAP_STEP,
    PRESET_NAMES,
    REGIMES,
    velocity_unit,
)
from vibtrans.products.designtip import TipShape, tip_shape  # noqa: F401

if TYPE_CHECKING:
    import os
    from collections.abc import Callable

    import numpy.typing as npt
    import xarray as xr

    from vibtrans.core.units import DeviceSpec, Material

G_STANDARD = 9.81  # m/s^2, the converter's default gravity (units.to_normalized)

# ---------------------------------------------------------------- validity thresholds
# Interatomic spacing 0.2-0.3 nm (Kittel, ch. 1): a smaller Hertz compression
# is a number, not a deformation; a continuum contact needs ten spacings across.
ATOMIC_SPACING = 2e-10  # m
MIN_CONTACT_RADIUS = 10 * ATOMIC_SPACING  # m
ADHESION_RATIO = 0.1  # pull-off "comparable to" the load: a tenth of m g + P
# The model drops k_R x (docs/MODEL.md 1): warn from a hundredth of a
# wavelength per period (a phase slip of 0.063 rad).
TRAVEL_FRACTION = 0.01
# A particle that rolls carries its contact patch over its surface by the
# rolled arc; the memory diagram is a fixed bed of springs (docs/MODEL.md
# section 11): warn where one contact episode rolls a tenth of the contact
# radius or more (about 6% of the contact's area then fresh, at its edge).
ROLL_CONTACT_FRACTION = 0.1
# Pull-off of a sphere on a flat: JKR 1.5 pi w R, DMT 2 pi w R (the larger: it warns first).
JKR_FACTOR = 1.5 * math.pi
DMT_FACTOR = 2.0 * math.pi

# ---------------------------------------------------------------- chart axes
AXES = ("frequency", "radius", "amplitude")
MAX_AXIS_POINTS = 400  # per axis: 160000 chart points at most
# The shipped maps are at theta = 1.2, nu = 0.3.  Steel on glass (theta =
# 1.214) reads them: its direct run changed by 1.5e-5 relative from theta =
# 1.2; 0.005 in nu moves r by 0.25% (units.amplitude_ratio).
THETA_TOLERANCE = 0.02
NU_TOLERANCE = 0.005
MAX_COMPUTE_POINTS = 20000  # a computed window larger than this is refused
COMPUTE_FIDELITY = "preview"
SYNCHRONOUS_PATTERNS = (1, 2)  # sweep.PATTERNS: synchronous, multi-synchronous
_UNITS = {"frequency": "Hz", "radius": "m", "amplitude": "m"}


# ---------------------------------------------------------------- presets
@dataclass(frozen=True)
class Preset:
    """A named device and its chart's axes (name, lo, hi, n); the third quantity is the device's."""

    name: str
    device: DeviceSpec
    x: tuple
    y: tuple
    note: str


def _paper_device():
    """The paper's worked example (steel on glass) at its point 4; R_p = 0.5 mm:
    its "R_p = 1e-3 m" read as the diameter reproduces its numbers (docs/MODEL.md 5)."""
    from vibtrans.core.params import PAPER_POINTS

    log_a, log_m, _ = PAPER_POINTS[4]
    radius = 0.5e-3
    f = units.frequency_for_mass_ratio(10.0**log_m, "glass", "steel", radius)
    a0 = units.to_normalized("glass", "steel", radius, f, 0.0).a0
    return DeviceSpec("glass", "steel", radius, f, 10.0**log_a * a0)


# The paper's figures for its worked example and this model's (tests/products/test_design.py
# runs the device): the paper's v* ~ -1e3 is the drift once settled, which
# a 2000-period run (the maps', the explorer's) has not reached
PAPER_NOTE = (
    "Terzi et al.'s worked example: 1 mm steel ball on glass at its point 4. The "
    "paper gives v* ~ -1e3, v ~ 9 cm/s; this model's 2000-period run (the maps' "
    "and the Run's) gives v* = -299 (-2.7 cm/s), because its drift is still "
    "accelerating at the run's end (last tenth -569); it settles at -1295 "
    "(-11.7 cm/s) after about 5000 periods, and over 10000 periods the mean is "
    "-1014 (-9.2 cm/s), the paper's order"
)


def _presets():
    saw = DeviceSpec("lithium niobate", "steel", 0.5e-3, 10e6, 10e-9, preload=1.0)
    powder = DeviceSpec("lithium niobate", "fused silica", 10e-6, 10e6, 1e-9)
    return {
        "paper": Preset(
            "paper", _paper_device(), ("frequency", 1e4, 1e6, 41), ("amplitude", 1e-9, 5e-7, 41), PAPER_NOTE
        ),
        "saw-motor": Preset(
            "saw-motor",
            saw,
            ("amplitude", 1e-9, 3e-8, 21),
            ("radius", 0.25e-3, 1e-3, 21),
            "SAW motor: steel balls (1 mm diameter) pressed on lithium "
            "niobate by a 1 N pre-load, 10 MHz, 10 nm",
        ),
        "saw-powder": Preset(
            "saw-powder",
            powder,
            ("amplitude", 1e-10, 2e-9, 21),
            ("radius", 2e-6, 20e-6, 21),
            "SAW powder: 10 um silica particle on lithium niobate, 10 MHz, 1 nm (A* = 1820, a0 = 5.5e-13 m)",
        ),
        "feeder": Preset(
            "feeder",
            DeviceSpec("aluminium", "PTFE", 2e-3, 400.0, 2e-6),
            ("frequency", 300.0, 3000.0, 21),
            ("amplitude", 2e-7, 2e-5, 21),
            "vibratory-feeder-like: 4 mm PTFE part on an aluminium track, 400 Hz, 2 um",
        ),
    }


def preset(name: str) -> Preset:
    """One of the named example devices.

    Parameters
    ----------
    name : str
        One of PRESET_NAMES ("paper", "saw-motor", "saw-powder", "feeder").

    Returns
    -------
    Preset
        The device and the chart's axes.

    Raises
    ------
    InputError
        Listing the names, if `name` is not one of them.
    """
    if not isinstance(name, str) or name not in PRESET_NAMES:
        raise InputError(f"preset must be one of {', '.join(PRESET_NAMES)}, got {name!r}")
    return _presets()[name]


# The device's materials as a form offers them (the library's names), and
# the entry for a material given by its three properties (its `*_custom`
# text, units.material's custom form: by default glass's values)
MATERIAL_NAMES = tuple(sorted(m.name for m in units.MATERIALS.values()))
CUSTOM_MATERIAL = "custom (E, nu, rho)"
CUSTOM_EXAMPLE = "E=70e9,nu=0.3,rho=2500"


class Device(param.Parameterized):
    """A device in SI units as a form or a link gives it: units.DeviceSpec's
    values, by default the "paper" preset's (the paper's worked example at
    its point 4).

    The values are kept as given; the library checks them where it uses
    them (`device_spec().normalized()`: an InputError naming the parameter
    and its valid range).  An entry point may narrow a parameter's range
    (the explorer's link and forms do).

    Parameters
    ----------
    substrate, particle : str
        The materials: one of MATERIAL_NAMES, or CUSTOM_MATERIAL for the
        properties given in `substrate_custom` / `particle_custom`.
    substrate_custom, particle_custom : str
        A custom material's properties, "E=<Pa>,nu=<->,rho=<kg/m^3>".
    radius : float
        The particle's radius, m.
    frequency : float
        The wave's frequency, Hz.
    amplitude : float
        The wave's vertical amplitude A_y, m.
    preload : float
        The pre-load P, N.
    """

    _paper = _paper_device()
    substrate: param.Selector = param.Selector(
        default=units.material(_paper.substrate).name,
        objects=[*MATERIAL_NAMES, CUSTOM_MATERIAL],
        doc="the substrate's material",
    )
    particle: param.Selector = param.Selector(
        default=units.material(_paper.particle).name,
        objects=[*MATERIAL_NAMES, CUSTOM_MATERIAL],
        doc="the particle's material",
    )
    substrate_custom = param.String(
        default=CUSTOM_EXAMPLE, doc="a custom substrate's properties: E=<Pa>,nu=<->,rho=<kg/m^3>"
    )
    particle_custom = param.String(
        default=CUSTOM_EXAMPLE, doc="a custom particle's properties: E=<Pa>,nu=<->,rho=<kg/m^3>"
    )
    radius = param.Number(default=_paper.radius, doc="the particle's radius, m")
    frequency = param.Number(default=_paper.frequency, doc="the wave's frequency, Hz")
    amplitude = param.Number(default=_paper.amplitude, doc="the wave's vertical amplitude, m")
    preload = param.Number(default=_paper.preload, doc="the pre-load, N")
    del _paper

    def material(self, which: str) -> str:
        """The text the library reads for a material (units.material).

        Parameters
        ----------
        which : str
            "substrate" or "particle".

        Returns
        -------
        str
            Its name, or the custom material's properties.
        """
        name = getattr(self, which)
        return getattr(self, f"{which}_custom") if name == CUSTOM_MATERIAL else name

    def device_spec(self) -> DeviceSpec:
        """The device as the library takes it.

        Returns
        -------
        units.DeviceSpec
            Its values (checked where they are used: `normalized()`).
        """
        return DeviceSpec(
            self.material("substrate"),
            self.material("particle"),
            self.radius,
            self.frequency,
            self.amplitude,
            preload=self.preload,
        )


# ---------------------------------------------------------------- device quantities
@dataclass(frozen=True)
class DeviceQuantities:
    """What practitioners check about a device (SI; docs/MODEL.md 5): mass,
    load m g + P, a0, contact radius, mean contact pressure, A*, m*, theta,
    r, nu, the tip (profile, edge_slope at the contact edge, scene_profile);
    Rayleigh speed and wavelength, peak vertical acceleration [g] and
    velocity; JKR and DMT pull-off.  From a map reading (else None): v*,
    drift velocity, contact time per period, travel per period and over the
    wavelength."""

    mass: float
    load: float
    a0: float
    contact_radius: float
    mean_contact_pressure: float
    A_star: float
    m_star: float
    theta: float
    r: float
    nu: float
    rayleigh_speed: float
    rayleigh_wavelength: float
    peak_acceleration_g: float
    peak_velocity: float
    pull_off_jkr: float
    pull_off_dmt: float
    v_star: float | None = None
    drift_velocity: float | None = None
    contact_time: float | None = None
    travel_per_period: float | None = None
    travel_over_wavelength: float | None = None
    profile: str = "sphere"
    edge_slope: float | None = None
    scene_profile: str = "sphere"

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _device(device):
    if not isinstance(device, DeviceSpec):
        raise InputTypeError(f"device must be a units.DeviceSpec, got {device!r}")
    return device


def _device_tip(device, shape):
    """(NormalizedScene, TipContact, A*, m*) of a device with a tip shape."""
    s = device.normalized()
    if tip_shape(shape).is_sphere:  # the converter's own numbers
        a_c = math.sqrt(device.radius * s.a0)
        p = s.load_N / (math.pi * a_c**2)
        c0, ca, slope, p = (np.asarray(v) for v in (s.a0, a_c, a_c / device.radius, p))
        tip = designtip.TipContact(c0, ca, slope, p, "sphere")
        return s, tip, s.A_star, s.m_star
    tip = designtip.static_contact(shape, device.radius, s.load_N, _e_eff(device))
    a0, a_c = float(tip.a0), float(tip.contact_radius)
    # (sizes whose contact under- or overflows: a0 or a_c^2 of 0 divided by zero)
    if not (0 < a0 < math.inf and 0 < a_c < math.inf and np.all(np.isfinite(tip.mean_pressure))):
        raise InputError(
            f"the tip's static contact (approach a0 = {a0:g} m, contact radius {a_c:g} m) is "
            f"past what its contact law computes: its sizes (exponent N, tip radius, "
            f"half-angle) are too far from the particle's"
        )
    return s, tip, device.amplitude / a0, a0 * s.mass_kg * device.frequency**2 / s.load_N


def _e_eff(device):
    sub = units.as_material("substrate", device.substrate)
    par = units.as_material("particle", device.particle)
    return units.effective_modulus(
        sub.youngs_modulus, sub.poisson_ratio, par.youngs_modulus, par.poisson_ratio
    )


def device_quantities(
    device: Any, reading: Any = None, surface_energy: float = DEFAULT_SURFACE_ENERGY, shape: Any = None
) -> DeviceQuantities:
    """DeviceQuantities of a DeviceSpec; `reading` (`read_device`) adds the
    drift; `shape`: the tip (None: the sphere)."""
    device = _device(device)
    w = units.check_nonnegative("surface_energy", surface_energy)
    shape = tip_shape("sphere" if shape is None else shape)
    s, tip, A_star, m_star = _device_tip(device, shape)
    a_c = float(tip.contact_radius)
    a0 = float(tip.a0)
    omega = 2 * math.pi * device.frequency
    load, f, amp, radius = s.load_N, device.frequency, device.amplitude, device.radius
    q = dict(mass=s.mass_kg, load=load, a0=a0, contact_radius=a_c)
    q.update(mean_contact_pressure=load / (math.pi * a_c**2))
    q.update(A_star=A_star, m_star=m_star, theta=s.theta, r=s.r, nu=s.nu, rayleigh_speed=s.c_R)
    q.update(rayleigh_wavelength=s.wavelength, peak_acceleration_g=omega**2 * amp / G_STANDARD)
    q.update(peak_velocity=omega * amp, pull_off_jkr=JKR_FACTOR * w * radius)
    q.update(pull_off_dmt=DMT_FACTOR * w * radius)
    q.update(profile=shape.name, edge_slope=float(tip.edge_slope), scene_profile=tip.profile)
    if reading is not None and np.isfinite(reading["v_star"]):
        v_star = float(reading["v_star"])
        v = s.drift_velocity_si(reading["v_star"]) if shape.is_sphere else a0 * f * v_star
        q.update(v_star=v_star, drift_velocity=v, contact_time=float(reading["contact_fraction"]) / f)
        q.update(travel_per_period=v / f, travel_over_wavelength=abs(v) / s.c_R)
    return DeviceQuantities(**q)


@dataclass(frozen=True)
class ValidityWarning:
    """One failed assumption: a short code, the message, the value and its threshold."""

    code: str
    message: str
    value: float
    threshold: float


def validity_warnings(
    device: Any,
    surface_energy: float = DEFAULT_SURFACE_ENERGY,
    drift_velocity: float | None = None,
    shape: Any = None,
) -> list[Any]:
    """Where the model's assumptions fail for a device (ValidityWarning list):
    a0 below ATOMIC_SPACING; contact radius below MIN_CONTACT_RADIUS; the tip's
    (designtip.tip_warnings); DMT pull-off at least ADHESION_RATIO of the load;
    with a drift velocity [m/s], travel per period at least TRAVEL_FRACTION of
    the Rayleigh wavelength."""
    shape = tip_shape("sphere" if shape is None else shape)
    q = device_quantities(device, surface_energy=surface_energy, shape=shape)
    out = []
    if q.a0 < ATOMIC_SPACING:
        msg = (
            f"static compression a0 = {q.a0:.3g} m is below the interatomic spacing "
            f"({ATOMIC_SPACING:g} m): the continuum Hertz contact is not physical here"
        )
        out.append(ValidityWarning("a0-subatomic", msg, q.a0, ATOMIC_SPACING))
    if q.contact_radius < MIN_CONTACT_RADIUS:
        msg = (
            f"contact radius {q.contact_radius:.3g} m is below {MIN_CONTACT_RADIUS:g} m "
            f"(ten interatomic spacings): Hertz theory does not hold"
        )
        out.append(ValidityWarning("contact-subatomic", msg, q.contact_radius, MIN_CONTACT_RADIUS))
    _, tip, _, _ = _device_tip(_device(device), shape)
    out += [
        ValidityWarning(w.code, w.message, w.value, w.threshold)
        for w in designtip.tip_warnings(shape, tip, _e_eff(device))
    ]
    ratio = q.pull_off_dmt / q.load
    if ratio >= ADHESION_RATIO:
        msg = (
            f"adhesion (DMT pull-off 2 pi w R = {q.pull_off_dmt:.3g} N with "
            f"w = {float(surface_energy):g} J/m^2) is {ratio:.3g} times the load m g + P = "
            f"{q.load:.3g} N (smooth surfaces: roughness lowers it, set the surface energy); "
            f"the model neglects adhesion: count it in the pre-load "
            f"(--preload, the paper's parameter for such forces) or treat the results as "
            f"qualitative"
        )
        out.append(ValidityWarning("adhesion", msg, ratio, ADHESION_RATIO))
    if drift_velocity is not None:
        v = units.check_interval("drift_velocity", drift_velocity)
        travel = abs(v) / q.rayleigh_speed
        if travel >= TRAVEL_FRACTION:
            msg = (
                f"the particle travels {travel:.3g} wavelengths per period (|v| / c_R); the "
                f"model neglects k_R x, valid only well below {TRAVEL_FRACTION:g}"
            )
            out.append(ValidityWarning("travel", msg, travel, TRAVEL_FRACTION))
    return out


def rolling_warning(
    max_episode_roll: float | None, a0: float, contact_radius: float
) -> ValidityWarning | None:
    """The fixed contact patch of a run that rolls (docs/MODEL.md section 11).

    Parameters
    ----------
    max_episode_roll : float or None
        The run's largest rolled arc within one contact episode, in a0 (its
        attribute `max_episode_roll`, `Summary.max_episode_roll`); None: the
        particle does not roll.
    a0 : float
        The device's static compression [m].
    contact_radius : float
        Its static contact radius [m] (sqrt(R a0) for the sphere; a tip's own).

    Returns
    -------
    ValidityWarning or None
        'rolling-patch' where max_episode_roll a0 is at least
        ROLL_CONTACT_FRACTION of the contact radius: the patch has moved over
        the particle's surface, onto material the memory diagram does not
        hold; None where it stays small (or the particle does not roll).

    Raises
    ------
    InputError
        If a value is not a finite number (a0 and the radius positive).
    """
    if max_episode_roll is None:
        return None
    roll = units.check_interval("max_episode_roll", max_episode_roll, 0.0, math.inf, lo_open=False)
    a0 = units.check_positive("a0", a0)
    radius = units.check_positive("contact_radius", contact_radius)
    share = roll * a0 / radius
    if share < ROLL_CONTACT_FRACTION:
        return None
    return ValidityWarning(
        "rolling-patch",
        f"the particle rolled {roll:.3g} a0 = {roll * a0:.3g} m within one "
        f"contact, {share:.3g} of the contact radius {radius:.3g} m (at or above "
        f"{ROLL_CONTACT_FRACTION:g}): the contact patch moved over the particle's surface "
        f"onto material whose loading history the model does not hold (a fixed patch, "
        f"docs/MODEL.md section 11); treat the tangential motion as qualitative",
        share,
        ROLL_CONTACT_FRACTION,
    )


def chart_warnings(chart: xr.Dataset) -> list[Any]:
    """`validity_warnings`' thresholds over a design chart: one line per
    threshold some points cross, with how many ("... at 12 of 1681 points");
    a NaN crosses none."""
    out = []
    n = chart["a0"].size
    slope = designtip.MAX_EDGE_SLOPE
    for var, below, threshold, what in (  # below: strictly below; False: at or above
        ("a0", True, ATOMIC_SPACING, "a0 below the interatomic spacing"),
        ("contact_radius", True, MIN_CONTACT_RADIUS, "contact radius below ten interatomic spacings"),
        ("adhesion_ratio", False, ADHESION_RATIO, "DMT pull-off at least a tenth of the load"),
        (
            "travel_over_wavelength",
            False,
            TRAVEL_FRACTION,
            "travel per period at least a hundredth of the wavelength",
        ),
        (
            "edge_slope",
            None,
            slope,
            f"tip profile's slope at the contact edge above "
            f"{slope:g} (contact radius against the tip's size)",
        ),
    ):
        if var not in chart:
            continue
        vals = chart[var].values
        if below is None:
            bad = int((vals > threshold).sum())
        else:
            bad = int(((vals < threshold) if below else (vals >= threshold)).sum())
        if bad:
            out.append(f"{what} at {bad} of {n} points")
    if str(chart.attrs.get("profile", "sphere")).startswith("cone"):
        out.append(f"a cone's apex pressure is infinite (it yields or wears round) at all {n} points")
    return out


# ---------------------------------------------------------------- device -> (A*, m*)
def _axis(spec, name):
    """(quantity, n log-spaced values) of an axis spec (quantity, lo, hi, n)."""
    if not isinstance(spec, (tuple, list)) or len(spec) != 4:
        raise InputError(f"{name} must be (quantity, lo, hi, n), got {spec!r}")
    q, lo, hi, n = spec
    if q not in AXES:
        raise InputError(f"{name} quantity must be one of {', '.join(AXES)}, got {q!r}")
    lo = units.check_positive(f"{name} lo ({q})", lo)
    hi = units.check_positive(f"{name} hi ({q})", hi)
    if not hi > lo:
        raise InputError(f"{name} ({q}) must have lo < hi, got {lo:g} and {hi:g}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 2 <= n <= MAX_AXIS_POINTS:
        raise InputError(f"{name} ({q}) points must be an integer in [2, {MAX_AXIS_POINTS}], got {n!r}")
    return q, np.geomspace(lo, hi, int(n))


def normalize_grid(
    substrate: str | Material,
    particle: str | Material,
    radius: float,
    frequency: float,
    amplitude: float,
    preload: float = 0.0,
    g: float = G_STANDARD,
    shape: Any = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a0 [m], A*, m*) of devices given as broadcastable arrays: the
    vectorized `units.to_normalized`; shape: the tip (None: the sphere)."""
    return _normalize_tip(substrate, particle, radius, frequency, amplitude, preload, g, shape)[:3]


def _normalize_tip(substrate, particle, radius, frequency, amplitude, preload, g, shape):
    """normalize_grid's (a0, A*, m*) and the tip's TipContact."""
    sub = units.as_material("substrate", substrate)
    par = units.as_material("particle", particle)
    radius = np.asarray(units.check_positive("radius", radius), dtype=float)
    frequency = np.asarray(units.check_positive("frequency", frequency), dtype=float)
    amplitude = np.asarray(units.check_positive("amplitude", amplitude), dtype=float)
    preload = units.check_nonnegative("preload", preload)
    g = units.check_positive("g", g)
    mass = units.sphere_mass(radius, par.density)
    load = mass * g + preload
    E_eff = units.effective_modulus(
        sub.youngs_modulus, sub.poisson_ratio, par.youngs_modulus, par.poisson_ratio
    )
    shape = tip_shape("sphere" if shape is None else shape)
    if shape.is_sphere:
        a0 = (3 * load / (4 * E_eff * np.sqrt(radius))) ** (2.0 / 3.0)
        a_c = np.sqrt(radius * a0)
        tip = designtip.TipContact(a0, a_c, a_c / radius, load / (np.pi * a_c**2), "sphere")
    else:
        tip = designtip.static_contact(shape, radius, load, E_eff)
        a0 = tip.a0
    return a0, amplitude / a0, a0 * mass * frequency**2 / load, tip


def materials_theta_nu(substrate: str | Material, particle: str | Material) -> tuple[float, float]:
    """(theta, nu) of a substrate / particle pair (docs/MODEL.md 1)."""
    sub = units.as_material("substrate", substrate)
    par = units.as_material("particle", particle)
    theta = units.stiffness_ratio(
        sub.youngs_modulus, sub.poisson_ratio, par.youngs_modulus, par.poisson_ratio
    )
    return theta, sub.poisson_ratio


# ---------------------------------------------------------------- which map
def shipped_map_path(mu: float, maps: Any = None) -> Path:
    from vibtrans.maps.shipped import maps_dir

    return Path(maps or maps_dir()) / f"deformable-mu{float(mu):g}.zarr"


def _grid_range(values, step):
    lo = math.floor(np.nanmin(values) / step) * step
    hi = math.ceil(np.nanmax(values) / step) * step
    return np.round(np.arange(lo, hi + step / 2, step), 10)


def _shipped_problems(
    ds, theta, nu, mu, log_a, log_m, profile="sphere", load_over_modulus=None, rolling=ROLLING_NONE
):
    """Why a map cannot serve these points (texts; empty if it can); profile:
    the normalized profile they need (the map's scene_profile); rolling: how
    the particle turns (the map's scene_rolling, absent for none)."""
    problems = []
    mr = ds.attrs.get("scene_rolling", ROLLING_NONE)
    if inertia_ratio(mr) != inertia_ratio(rolling):
        problems.append(f"rolling {rolling} (map: {mr})")
    mp = ds.attrs.get("scene_profile", "sphere")
    if mp != profile:
        problems.append(f"profile {profile} (map: {mp})")
    elif load_over_modulus is not None and not math.isclose(
        float(ds.attrs.get("scene_load_over_modulus", math.nan)),
        load_over_modulus,
        rel_tol=designtip.SHARED_RELATIVE,
    ):
        problems.append(
            f"load over modulus {load_over_modulus:.4g} m^2 (map: {ds.attrs.get('scene_load_over_modulus')})"
        )
    if not math.isclose(ds.attrs.get("scene_mu", math.nan), mu, rel_tol=1e-12):
        problems.append(f"mu {mu:g} (map: {ds.attrs.get('scene_mu')})")
    mt, mn = ds.attrs["scene_theta"], ds.attrs["scene_nu"]
    if abs(theta - mt) > THETA_TOLERANCE:
        problems.append(
            f"theta {theta:.4g} of the materials differs from the map's {mt:g} "
            f"by more than {THETA_TOLERANCE:g}"
        )
    if abs(nu - mn) > NU_TOLERANCE:
        problems.append(
            f"nu {nu:.4g} of the substrate differs from the map's {mn:g} by more than {NU_TOLERANCE:g}"
        )
    for label, vals, grid in (
        ("log10 A*", log_a, ds["log_amplitude"].values),
        ("log10 m*", log_m, ds["log_mass"].values),
    ):
        lo, hi = float(np.min(vals)), float(np.max(vals))
        if lo < grid[0] or hi > grid[-1]:
            problems.append(
                f"{label} spans [{lo:.3g}, {hi:.3g}], outside the map's [{grid[0]:g}, {grid[-1]:g}]"
            )
    return problems


def compute_cost(log_amplitude: Any, log_mass: Any, values: Any) -> tuple[int, Any, int]:
    """(points, periods, integration steps: an upper estimate) of a sweep."""
    from vibtrans.core.params import Scene
    from vibtrans.core.simulate import estimate_steps

    steps = 0
    for la in log_amplitude:
        for lm in log_mass:
            steps += estimate_steps(Scene(amplitude=10.0**la, mass=10.0**lm, **values))
    return len(log_amplitude) * len(log_mass), values["periods"], steps


def computed_map(
    log_a: npt.ArrayLike,
    log_m: npt.ArrayLike,
    mu: float,
    theta: float,
    nu: float,
    store_dir: str | os.PathLike[str],
    step: Any = MAP_STEP,
    periods: float = 2000.0,
    tau: float = 50.0,
    fidelity: str = COMPUTE_FIDELITY,
    report: Any = print,
    workers: int | None = None,
    profile: str = "sphere",
    load_over_modulus: float | None = None,
    rolling: str | float = ROLLING_NONE,
) -> tuple[xr.Dataset, str]:
    """The normalized window covering (log_a, log_m) on a `step`-decade grid,
    swept into a store under `store_dir` (kept: a rerun reuses or resumes
    it); the cost is reported first.  (map, store path)."""
    from vibtrans.maps.outfiles import check_folder
    from vibtrans.maps.sweep import Sweep, open_map, run_sweep

    step = units.check_interval("step", step, 0.0, 1.0, hi_open=False)
    store_dir = check_folder(store_dir, "store_dir")
    la, lm = _grid_range(log_a, step), _grid_range(log_m, step)
    if la.size < 2:
        la = np.round(np.array([la[0], la[0] + step]), 10)
    if lm.size < 2:
        lm = np.round(np.array([lm[0], lm[0] + step]), 10)
    n = la.size * lm.size
    span = f"log10 A* [{la[0]:g}, {la[-1]:g}]", f"log10 m* [{lm[0]:g}, {lm[-1]:g}]"
    if n > MAX_COMPUTE_POINTS:
        raise InputError(
            f"the window to compute has {n} points ({la.size} in {span[0]} x "
            f"{lm.size} in {span[1]} at step {step:g}), more than "
            f"{MAX_COMPUTE_POINTS}; use a coarser step or narrower axes"
        )
    values: dict[str, Any] = dict(
        model="deformable", mu=mu, theta=theta, nu=nu, tau=tau, periods=periods, fidelity=fidelity
    )
    if profile != "sphere":  # (the sphere's keys, and stores, unchanged)
        values["profile"] = profile
        if load_over_modulus is not None:
            values["load_over_modulus"] = float(load_over_modulus)
    rolling = check_rolling(rolling)
    if rolling != ROLLING_NONE:  # (a particle that does not turn: keys as before)
        values["rolling"] = rolling
    points, per, steps = compute_cost(la, lm, values)
    key = json.dumps(
        {**values, "la": [la[0], la[-1], la.size], "lm": [lm[0], lm[-1], lm.size]}, sort_keys=True
    )
    path = Path(store_dir) / f"design-{hashlib.sha256(key.encode()).hexdigest()[:16]}.zarr"
    verb = "reading (resuming if unfinished)" if path.exists() else "computing"
    material = f"mu {mu:g}, theta {theta:.4g}, nu {nu:.4g}"
    material += "" if profile == "sphere" else f", profile {profile}"
    material += "" if rolling == ROLLING_NONE else f", rolling {rolling}"
    report(
        f"{verb} a {fidelity} map: {la.size} x {lm.size} = {points} points x {per:g} periods, about "
        f"{steps:.3g} integration steps ({span[0]}, {span[1]}, step {step:g}; {material})"
    )
    sweep = Sweep(la, lm, command=f"vibtrans design ({key})", **values)
    run_sweep(sweep, str(path), workers=workers, progress=False)
    return open_map(str(path)), str(path)


# ---------------------------------------------------------------- reading
def _nearest(grid, values):
    """Index of the nearest grid value to each value (grid increasing)."""
    i = np.clip(np.searchsorted(grid, values), 1, grid.size - 1)
    left = values - grid[i - 1] <= grid[i] - values
    return np.where(left, i - 1, i)


def regime_of(drift: Any, contact: Any, pattern: Any, chaotic: Any) -> np.ndarray:
    """Regime index (REGIMES; -1 not computed) from a map's flags."""
    drift, contact = np.asarray(drift), np.asarray(contact)
    pattern, chaotic = np.asarray(pattern), np.asarray(chaotic)
    r = np.full(drift.shape, REGIMES.index("other hopping"), dtype=np.int8)
    r = np.where(np.isin(pattern, SYNCHRONOUS_PATTERNS), REGIMES.index("synchronous hopping"), r)
    with_, against = REGIMES.index("sliding with the wave"), REGIMES.index("sliding against the wave")
    sliding = np.where(drift > 0, with_, against)
    r = np.where(contact == 0, sliding, r)
    r = np.where(drift == 0, REGIMES.index("no drift"), r)
    r = np.where(chaotic == 1, REGIMES.index("chaotic"), r)
    return np.where(drift < -1, -1, r).astype(np.int8)


def read_map(map_ds: xr.Dataset, log_a: npt.ArrayLike, log_m: npt.ArrayLike) -> dict[Any, Any]:
    """Nearest-grid-point values at (log_a, log_m): v_star, drift, contact,
    pattern, chaotic, contact_fraction, log_amplitude_read, log_mass_read
    (undone points: NaN / -2)."""
    ga, gm = map_ds["log_amplitude"].values, map_ds["log_mass"].values
    ia, im = _nearest(ga, np.asarray(log_a)), _nearest(gm, np.asarray(log_m))
    done = map_ds["point_done"].values[ia] if "point_done" in map_ds else np.ones(ia.shape, dtype=bool)
    out = {}
    for name, key in (
        ("v_star", "drift_velocity"),
        ("drift", "drift"),
        ("contact", "contact"),
        ("pattern", "pattern"),
        ("chaotic", "chaotic"),
        ("contact_fraction", "contact_fraction"),
    ):
        vals = map_ds[key].values[ia, im]
        out[name] = np.where(done, vals, np.nan if vals.dtype.kind == "f" else -2)
    out["log_amplitude_read"], out["log_mass_read"] = ga[ia], gm[im]
    return out


def _shipped_map(log_a, log_m, mu, theta, nu, maps, profile="sphere", rolling=ROLLING_NONE):
    """(the shipped map of `mu` if it serves these points, else None; why not)."""
    from vibtrans.core.errors import StoreMismatch
    from vibtrans.maps.sweep import open_map

    if profile != "sphere":
        return None, [f"the shipped maps are the sphere's; profile {profile} needs a map of its own"]
    if check_rolling(rolling) != ROLLING_NONE:
        return None, [
            f"the shipped maps are of a particle that does not turn; rolling {rolling} needs a map of its own"
        ]
    path = shipped_map_path(mu, maps)
    if not path.exists():
        return None, [f"no shipped map for mu = {mu:g} (shipped: mu 0.1, 0.3, 1)"]
    try:
        ds = open_map(str(path), expect={"model": "deformable", "mu": float(mu)})
    except StoreMismatch as exc:
        return None, [str(exc)]
    problems = _shipped_problems(ds, theta, nu, mu, log_a, log_m)
    return (None if problems else ds), problems


class NoMapCovers(InputError):
    """design_chart's refusal when no shipped map serves the chart; `need`:
    the MapNeed, the map it would read."""

    def __init__(self, message: str, need: Any) -> None:
        super().__init__(message)
        self.need = need


def _map_need(
    mu, theta, nu, log_a, log_m, problems, profile="sphere", load_over_modulus=None, rolling=ROLLING_NONE
):
    la, lm = ((float(np.min(v)), float(np.max(v))) for v in (log_a, log_m))
    return MapNeed(
        float(mu),
        float(theta),
        float(nu),
        la,
        lm,
        tuple(problems),
        profile,
        load_over_modulus,
        check_rolling(rolling),
    )


@dataclass(frozen=True)
class ChartGrid:
    """A chart's devices in the normalized plane: the axes' quantities and
    values (SI), the fixed one, the devices' arrays (dims (y, x)), their a0,
    A*, m*, theta and nu of the materials, the tip."""

    substrate: units.Material
    particle: units.Material
    x: str
    x_values: np.ndarray
    y: str
    y_values: np.ndarray
    fixed: str
    fixed_value: float
    devices: dict
    a0: np.ndarray
    A_star: np.ndarray
    m_star: np.ndarray
    theta: float
    nu: float
    shape: TipShape
    tip: designtip.TipContact


def chart_grid(
    substrate: str | Material,
    particle: str | Material,
    preload: float = 0.0,
    x: tuple = ("frequency", 1e4, 1e6, 41),
    y: tuple = ("amplitude", 1e-9, 1e-6, 41),
    fixed: tuple = ("radius", 0.5e-3),
    g: float = G_STANDARD,
    shape: Any = None,
) -> ChartGrid:
    """The chart's ChartGrid (every value checked: InputError names it)."""
    sub = units.as_material("substrate", substrate)
    par = units.as_material("particle", particle)
    xq, xv = _axis(x, "x")
    yq, yv = _axis(y, "y")
    if not isinstance(fixed, (tuple, list)) or len(fixed) != 2:
        raise InputError(f"fixed must be (quantity, value), got {fixed!r}")
    fq, fv = fixed
    if xq == yq or fq in (xq, yq) or fq not in AXES:
        raise InputError(
            f"x, y and fixed must be the three quantities {', '.join(AXES)} "
            f"once each, got x {xq!r}, y {yq!r}, fixed {fq!r}"
        )
    fv = units.check_positive(f"fixed {fq}", fv)
    X, Y = np.meshgrid(xv, yv)
    dev = {xq: X, yq: Y, fq: np.full(X.shape, fv)}
    shape = tip_shape("sphere" if shape is None else shape)
    a0, A, M, tip = _normalize_tip(
        sub, par, dev["radius"], dev["frequency"], dev["amplitude"], preload, g, shape
    )
    theta, nu = materials_theta_nu(sub, par)
    return ChartGrid(sub, par, xq, xv, yq, yv, fq, fv, dev, a0, A, M, theta, nu, shape, tip)


@dataclass(frozen=True)
class MapNeed:
    """The normalized map a chart reads (mu, theta, nu, the log10 A* and m*
    spans) and why the shipped map of that mu cannot serve (empty: it can)."""

    mu: float
    theta: float
    nu: float
    log_amplitude: tuple
    log_mass: tuple
    shipped_problems: tuple
    profile: str = "sphere"
    load_over_modulus: float | None = None
    rolling: str | float = ROLLING_NONE


def chart_needs(
    substrate: str | Material,
    particle: str | Material,
    preload: float = 0.0,
    x: tuple = ("frequency", 1e4, 1e6, 41),
    y: tuple = ("amplitude", 1e-9, 1e-6, 41),
    fixed: tuple = ("radius", 0.5e-3),
    mu: Any = 0.3,
    maps: Any = None,
    g: float = G_STANDARD,
    shape: Any = None,
    rolling: str | float = ROLLING_NONE,
) -> MapNeed:
    """The MapNeed of a chart (design_chart's arguments); nothing is computed."""
    grid = chart_grid(substrate, particle, preload, x, y, fixed, g, shape)
    mu = units.check_positive("mu", mu)
    rolling = check_rolling(rolling)
    log_a, log_m = np.log10(grid.A_star), np.log10(grid.m_star)
    _, problems = _shipped_map(log_a, log_m, mu, grid.theta, grid.nu, maps, grid.tip.profile, rolling)
    return _map_need(
        mu, grid.theta, grid.nu, log_a, log_m, problems, grid.tip.profile, grid.tip.load_over_modulus, rolling
    )


def design_chart(
    substrate: str | Material,
    particle: str | Material,
    preload: float = 0.0,
    x: tuple = ("frequency", 1e4, 1e6, 41),
    y: tuple = ("amplitude", 1e-9, 1e-6, 41),
    fixed: tuple = ("radius", 0.5e-3),
    mu: float = 0.3,
    surface_energy: float = DEFAULT_SURFACE_ENERGY,
    maps: str | os.PathLike[str] | None = None,
    compute: bool = False,
    store_dir: str | os.PathLike[str] | None = None,
    step: float = MAP_STEP,
    periods: float = 2000.0,
    report: Callable[[str], object] = print,
    workers: int | None = None,
    g: float = G_STANDARD,
    map_ds: xr.Dataset | None = None,
    map_name: str = "given map",
    shape: TipShape | None = None,
    rolling: str | float = ROLLING_NONE,
) -> xr.Dataset:
    """The design chart: a device's drift over two of its SI quantities, each
    point read (nearest grid point) from a shipped map, a computed window or `map_ds`.

    Parameters
    ----------
    substrate, particle : str or Material
        The materials (a name of MATERIALS, or a Material).
    preload : float
        Extra normal load on the particle [N].
    x, y : tuple
        (quantity, lo, hi, n), quantity among AXES, n log-spaced points.
    fixed : tuple
        (the third quantity, value).
    mu : float
        Friction coefficient.
    surface_energy : float
        Work of adhesion [J/m^2], for the adhesion ratio.
    maps : str or os.PathLike, optional
        Folder of the shipped maps; None: `maps_dir()`.
    compute : bool
        Compute the window (preview fidelity) when no shipped map serves, else refuse.
    store_dir : str or os.PathLike, optional
        Where computed windows are stored; needed with `compute`.
    step, periods : float
        Grid step (decades) and T_obs of a computed window.
    report : callable
        Called with a line of text on what is read or computed.
    workers : int, optional
        Workers of a computed window.
    g : float
        Gravity [m/s^2].
    map_ds : xarray.Dataset, optional
        A normalized map to read instead (refused unless it serves the chart).
    map_name : str
        `map_ds`'s name in the chart's attrs.
    shape : TipShape, optional
        The particle's tip (None: the sphere); the map read is that profile's.
    rolling : str or float
        How the particle turns (Scene's `rolling`); the map read is that
        particle's (the shipped maps' particle does not turn).

    Returns
    -------
    xarray.Dataset
        Over dims (y, x) in SI: drift_velocity [m/s] = a0 f v*, v_star, drift,
        contact, pattern, chaotic, regime (REGIMES index), contact_fraction,
        A_star, m_star, a0, contact_radius, edge_slope, adhesion_ratio and
        travel_over_wavelength; attrs name the map read (and a turning
        particle's rolling).

    Raises
    ------
    InputError
        If a value is outside its range, `compute` lacks `store_dir`, or
        `map_ds` does not serve the chart.
    NoMapCovers
        If no shipped map serves the chart and `compute` is False.
    """
    import xarray as xr

    grid = chart_grid(substrate, particle, preload, x, y, fixed, g, shape)
    tip, sub, par = grid.tip, grid.substrate, grid.particle
    xq, yq, fq = grid.x, grid.y, grid.fixed
    mu = units.check_positive("mu", mu)
    rolling = check_rolling(rolling)
    w = units.check_nonnegative("surface_energy", surface_energy)
    if compute and store_dir is None:
        raise InputError("store_dir (--store) is needed to compute a map")
    dev, a0, A, M = grid.devices, grid.a0, grid.A_star, grid.m_star
    theta, nu = grid.theta, grid.nu
    log_a, log_m = np.log10(A), np.log10(M)
    profile: dict[str, Any] = dict(profile=tip.profile, load_over_modulus=tip.load_over_modulus)
    if map_ds is not None:
        problems = _shipped_problems(map_ds, theta, nu, mu, log_a, log_m, **profile, rolling=rolling)
        if problems:
            raise InputError(f"the {map_name} does not serve this chart: " + "; ".join(problems))
        source = map_name
    else:
        map_ds, problems = _shipped_map(log_a, log_m, mu, theta, nu, maps, tip.profile, rolling)
        source = f"shipped: {shipped_map_path(mu, maps).name}"
        if map_ds is None and not compute:
            need = _map_need(mu, theta, nu, log_a, log_m, problems, **profile, rolling=rolling)
            raise NoMapCovers(
                "no shipped map covers this chart: "
                + "; ".join(problems)
                + ". Compute the window with --compute (API: compute=True; a "
                "preview-fidelity sweep, cost printed first) or narrow the axes",
                need,
            )
        if map_ds is None:
            run: dict[str, Any] = dict(store_dir=store_dir, step=step, periods=periods, report=report)
            map_ds, where = computed_map(
                log_a, log_m, mu, theta, nu, workers=workers, **run, **profile, rolling=rolling
            )
            source = f"computed: {where}"
    got = read_map(map_ds, log_a, log_m)
    v = a0 * dev["frequency"] * got["v_star"]
    c_R = units.rayleigh_speed(sub.youngs_modulus, sub.poisson_ratio, sub.density)
    load = units.sphere_mass(dev["radius"], par.density) * g + preload
    grid_step = round(float(np.diff(map_ds["log_amplitude"].values[:2])[0]), 10)
    regime = regime_of(got["drift"], got["contact"], got["pattern"], got["chaotic"])
    variables = {  # name: (values, description or {attrs})
        "drift_velocity": (v, {"units": "m/s", "description": "a0 f v*"}),
        "v_star": (got["v_star"], "<v*> read on the map"),
        "drift": (got["drift"], "-1 against the wave, 0 none, 1 with"),
        "contact": (got["contact"], "0 permanent contact, 1 jumping"),
        "pattern": (got["pattern"], "sweep.PATTERNS index"),
        "chaotic": (got["chaotic"], "1 chaotic"),
        "regime": (regime, ", ".join(f"{i} {r}" for i, r in enumerate(REGIMES))),
        "contact_fraction": (got["contact_fraction"], "time share in contact, last 10% of the run"),
        "A_star": (A, "A_y / a0"),
        "m_star": (M, "a0 m f^2 / (m g + P)"),
        "log_amplitude_read": (got["log_amplitude_read"], "log10 A* of the map point read"),
        "log_mass_read": (got["log_mass_read"], "log10 m* of the map point read"),
        "a0": (a0, {"units": "m"}),
        "contact_radius": (np.broadcast_to(tip.contact_radius, a0.shape).copy(), {"units": "m"}),
        "edge_slope": (
            np.broadcast_to(tip.edge_slope, a0.shape).copy(),
            "the tip profile's slope at the static contact edge",
        ),
        "adhesion_ratio": (DMT_FACTOR * w * dev["radius"] / load, "DMT pull-off 2 pi w R over m g + P"),
        "travel_over_wavelength": (
            np.abs(v) / c_R,
            "|v| / c_R: travel per period over the Rayleigh wavelength",
        ),
    }
    data = {
        k: ((yq, xq), vals, a if isinstance(a, dict) else {"description": a})
        for k, (vals, a) in variables.items()
    }
    coords = {
        q: (q, vals, {"units": _UNITS[q], "long_name": AXIS_LABELS[q]})
        for q, vals in ((xq, grid.x_values), (yq, grid.y_values))
    }
    attrs = dict(substrate=sub.name, particle=par.name, preload_N=float(preload), gravity=float(g))
    attrs.update(mu=float(mu), theta=float(theta), nu=float(nu), surface_energy=float(w))
    attrs.update(x=xq, y=yq, fixed=fq, profile=grid.shape.name, map_profile=tip.profile)
    attrs.update(fixed_value=float(grid.fixed_value), fixed_units=_UNITS[fq], map=source)
    m = map_ds.attrs
    attrs.update(
        map_theta=float(m["scene_theta"]),
        map_nu=float(m["scene_nu"]),
        map_periods=float(m["scene_periods"]),
        map_fidelity=str(m["scene_fidelity"]),
    )
    attrs.update(
        map_step=grid_step,
        reading=f"nearest grid point: the map point read is at most "
        f"{grid_step / 2:g} decades from the device in log10 A* and in log10 m*",
        rayleigh_speed=float(c_R),
    )
    if rolling != ROLLING_NONE:
        attrs["rolling"] = rolling
    return xr.Dataset(data, coords=coords, attrs=attrs)


def read_device(
    device: DeviceSpec,
    mu: float = 0.3,
    maps: str | os.PathLike[str] | None = None,
    chart: xr.Dataset | None = None,
    map_ds: xr.Dataset | None = None,
    map_name: str = "given map",
    shape: TipShape | None = None,
    rolling: str | float = ROLLING_NONE,
) -> dict[str, Any] | None:
    """The map reading at one device: from `map_ds`, else `chart`'s map (the
    device itself, not the nearest chart point), else the shipped map.

    Parameters
    ----------
    device : DeviceSpec
        The device in SI units (a preset's `device`).
    mu : float
        Friction coefficient.
    maps : str or os.PathLike, optional
        Folder of the shipped maps; None: `maps_dir()`.
    chart : xarray.Dataset, optional
        A design chart whose map to read.
    map_ds : xarray.Dataset, optional
        A normalized map to read.
    map_name : str
        `map_ds`'s name in the reading.
    shape : TipShape, optional
        The particle's tip (None: the sphere).
    rolling : str or float
        How the particle turns (Scene's `rolling`).

    Returns
    -------
    dict or None
        v_star, contact_fraction, regime and map; None when no map serves
        the device (outside, other theta/nu/mu, another profile or rolling).

    Raises
    ------
    InputError
        If a value is outside its range.
    """
    from vibtrans.maps.sweep import open_map

    shape = tip_shape("sphere" if shape is None else shape)
    s, tip, A_star, m_star = _device_tip(_device(device), shape)
    la, lm = np.log10([A_star]), np.log10([m_star])
    rolling = check_rolling(rolling)
    need = (tip.profile, tip.load_over_modulus, rolling)
    if map_ds is not None:
        if _shipped_problems(map_ds, s.theta, s.nu, float(mu), la, lm, *need):
            return None
        return _reading(map_ds, la, lm, map_name)
    path = shipped_map_path(mu, maps)
    if chart is not None and chart.attrs["map"].startswith("computed: "):
        path = Path(chart.attrs["map"].split(": ", 1)[1])
    elif not shape.is_sphere or rolling != ROLLING_NONE:
        return None  # the shipped maps are a sphere's that does not turn
    if not path.exists():
        return None
    ds = open_map(str(path))
    if _shipped_problems(ds, s.theta, s.nu, float(mu), la, lm, *need) and (
        chart is None
        or ds.attrs.get("scene_profile", "sphere") != tip.profile
        or inertia_ratio(ds.attrs.get("scene_rolling", ROLLING_NONE)) != inertia_ratio(rolling)
    ):
        return None
    ga, gm = ds["log_amplitude"].values, ds["log_mass"].values
    if not (ga[0] <= la[0] <= ga[-1] and gm[0] <= lm[0] <= gm[-1]):
        return None
    return _reading(ds, la, lm, path.name)


def _reading(ds, la, lm, name):
    got = read_map(ds, la, lm)
    regime = regime_of(got["drift"], got["contact"], got["pattern"], got["chaotic"])
    return {
        "v_star": float(got["v_star"][0]),
        "contact_fraction": float(got["contact_fraction"][0]),
        "regime": REGIMES[int(regime[0])],
        "map": name,
    }


def write_chart_data(chart: xr.Dataset, out: str | os.PathLike[str]) -> str | os.PathLike[str]:
    """The chart's numbers to .nc (every variable) or .csv (a row per point)."""
    from vibtrans.maps.outfiles import atomic, check_file

    check_file(out)
    ext = Path(out).suffix.lower()
    if ext == ".nc":
        with atomic(out, errors=(RuntimeError,)) as tmp:
            chart.to_netcdf(tmp)
    elif ext == ".csv":
        with atomic(out) as tmp:
            chart.to_dataframe().reset_index().to_csv(tmp, index=False)
    else:
        raise InputError(f"out must end in .nc or .csv for the chart's data, got {str(out)!r}")
    return out
