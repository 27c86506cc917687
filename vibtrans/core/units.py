"""Materials, Rayleigh-wave and Hertz-contact helpers, SI <-> normalized units.

Normalized units (docs/MODEL.md sections 1 and 5): lengths in units of the static
Hertz compression ``a0`` under the load ``Mg = m g + P``, time in wave periods
``1/f``. Hence

    m* = a0 m f^2 / (Mg),   A* = A_y / a0,   v = a0 f v*.

Everything here is plain numpy/scipy; SI units throughout unless stated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vibtrans.core.errors import InputError, InputTypeError

__all__ = [
    "Material",
    "MATERIALS",
    "material",
    "material_names",
    "custom_material",
    "rayleigh_speed_ratio",
    "rayleigh_speed",
    "amplitude_ratio",
    "stiffness_ratio",
    "effective_modulus",
    "hertz_compression",
    "sphere_mass",
    "DeviceSpec",
    "NormalizedScene",
    "to_normalized",
    "frequency_for_mass_ratio",
    "amplitude_from_normalized",
    "duration_text",
]

_INF = math.inf
_NU = (0.0, 0.5)  # open interval: the elastic range of an isotropic solid with nu > 0


# --------------------------------------------------------------------------- validation
def check_interval(
    name: str, value: Any, lo: Any = -_INF, hi: Any = _INF, lo_open: bool = True, hi_open: bool = True
) -> Any:
    """Return ``value`` as float (or float array) after checking it is finite and
    inside the interval; raise TypeError / ValueError naming ``name`` otherwise."""
    interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    # bool and str convert silently to float in numpy; complex would drop its imaginary part
    if value is None or isinstance(value, (bool, np.bool_, str, bytes)) or np.iscomplexobj(value):
        raise InputTypeError(f"{name} must be a real number in {interval}, got {value!r}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputTypeError(f"{name} must be a real number in {interval}, got {value!r}") from None
    bad = ~np.isfinite(arr)
    bad |= (arr <= lo) if lo_open else (arr < lo)
    bad |= (arr >= hi) if hi_open else (arr > hi)
    if np.any(bad):
        shown = arr if arr.ndim == 0 else arr[bad].flat[0]
        raise InputError(f"{name} must be in {interval}, got {float(shown):g}")
    return _out(arr)


def _out(x):
    """Plain float for scalar results, ndarray otherwise."""
    return float(x) if np.ndim(x) == 0 else np.asarray(x)


def check_positive(name: str, value: Any) -> Any:
    return check_interval(name, value, 0.0, _INF)


def check_nonnegative(name: str, value: Any) -> Any:
    return check_interval(name, value, 0.0, _INF, lo_open=False)


def _poisson(name, value):
    return check_interval(name, value, *_NU)


# --------------------------------------------------------------------------- materials
@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material: E [Pa], Poisson ratio nu [-], density [kg/m^3].

    ``source`` says where the values come from (not compared: two materials with
    equal properties are equal whatever their citation)."""

    name: str
    youngs_modulus: float
    poisson_ratio: float
    density: float
    source: str = field(default="user-supplied values", compare=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise InputTypeError(f"name must be a non-empty string, got {self.name!r}")
        check_positive("youngs_modulus", self.youngs_modulus)
        _poisson("poisson_ratio", self.poisson_ratio)
        check_positive("density", self.density)
        if not isinstance(self.source, str):
            raise InputTypeError(f"source must be a string, got {self.source!r}")


_PAPER = (
    "Terzi, Aleshin, Ghesquiere, Tournat, Vibrational Transportation of Deformable "
    "Axisymmetric Particles (worked example)"
)
MATERIALS: dict[str, Material] = {
    "steel": Material("steel", 200e9, 0.3, 8000.0, f"{_PAPER}: 200 GPa, 0.3, 8000 kg/m^3"),
    "glass": Material("glass", 70e9, 0.3, 2500.0, f"{_PAPER}: 70 GPa, 0.3, 2500 kg/m^3"),
    "stainless_steel": Material(
        "stainless steel",
        193e9,
        0.29,
        8000.0,
        "ASM Handbook vol. 1 (1990), AISI 304 annealed: 193 GPa, 0.29, 8000 kg/m^3",
    ),
    "aluminium": Material(
        "aluminium",
        69e9,
        0.33,
        2700.0,
        "ASM Handbook vol. 2 (1990), alloy 6061-T6: 68.9 GPa, 0.33, 2700 kg/m^3",
    ),
    "brass": Material(
        "brass",
        110e9,
        0.375,
        8530.0,
        "ASM Handbook vol. 2 (1990), cartridge brass C26000: 110 GPa, 0.375, 8530 kg/m^3",
    ),
    "silicon": Material(
        "silicon",
        160e9,
        0.22,
        2329.0,
        "Hopcroft, Nix, Kenny, J. MEMS 19, 229 (2010): isotropic (polycrystalline) "
        "average ~160 GPa, 0.22; density 2329 kg/m^3",
    ),
    # the key stays "quartz" (older name); "fused silica" is how people write it
    "quartz": Material(
        "fused silica",
        72e9,
        0.17,
        2200.0,
        "Corning HPFS 7980 fused silica datasheet: 72.7 GPa, 0.16, 2201 kg/m^3 "
        "(rounded handbook values 72 GPa, 0.17, 2200)",
    ),
    "alumina": Material(
        "alumina", 370e9, 0.22, 3900.0, "CoorsTek AD-995 (99.5% Al2O3) datasheet: 370 GPa, 0.22, 3900 kg/m^3"
    ),
    "ptfe": Material(
        "PTFE",
        0.5e9,
        0.46,
        2200.0,
        "polymer handbooks (e.g. Mark, Physical Properties of Polymers Handbook, 2007): "
        "E 0.4-0.6 GPa (rate dependent), 0.46, 2200 kg/m^3",
    ),
    "polystyrene": Material(
        "polystyrene",
        3.2e9,
        0.34,
        1050.0,
        "polymer handbooks (e.g. Mark, Physical Properties of Polymers Handbook, 2007): "
        "E 3.0-3.5 GPa, 0.34, 1050 kg/m^3 (microsphere powders)",
    ),
    # LiNbO3 and LiTaO3 are anisotropic (trigonal): isotropic APPROXIMATIONS
    "lithium_niobate": Material(
        "lithium niobate",
        170e9,
        0.25,
        4647.0,
        "isotropic approximation from averaged stiffnesses (Weis & Gaylord, Appl. Phys. A "
        "37, 191 (1985) data): ~170 GPa, ~0.25, 4647 kg/m^3",
    ),
    "lithium_tantalate": Material(
        "lithium tantalate",
        222e9,
        0.21,
        7454.0,
        "isotropic (Voigt) average of Smith & Welsh, J. Appl. Phys. 42, 2219 (1971) "
        "stiffnesses c11 233, c12 47, c13 80, c33 275, c44 94 GPa: 222 GPa, 0.21; "
        "7454 kg/m^3",
    ),
}
_ALIASES = {
    "aluminum": "aluminium",
    "fused_silica": "quartz",
    "silica": "quartz",
    "teflon": "ptfe",
    "linbo3": "lithium_niobate",
    "litao3": "lithium_tantalate",
    "ss304": "stainless_steel",
    "304_stainless_steel": "stainless_steel",
    "al2o3": "alumina",
    "ps": "polystyrene",
    "si": "silicon",
}
# the keyword form of a custom material, e.g. "E=70e9,nu=0.3,rho=2500"
CUSTOM_KEYS = {"e": "youngs_modulus", "nu": "poisson_ratio", "rho": "density"}


def material_names() -> list[str]:
    """Every name and alias `material` accepts, as people write them."""
    return sorted({m.name for m in MATERIALS.values()} | set(MATERIALS) | set(_ALIASES))


def custom_material(
    youngs_modulus: float, poisson_ratio: float, density: float, name: str = "custom"
) -> Material:
    """A material by its three properties: E [Pa], nu in (0, 0.5), density [kg/m^3]."""
    return Material(name, youngs_modulus, poisson_ratio, density, source="user-supplied values")


def _parse_custom(text):
    """'E=70e9,nu=0.3,rho=2500' -> Material, or None if the text is no such form."""
    if "=" not in text:
        return None
    values = {}
    for part in text.split(","):
        key, _, value = part.partition("=")
        key = key.strip().lower()
        if key not in CUSTOM_KEYS:
            raise InputError(
                f"custom material {text!r}: unknown property {key!r}; write E=<Pa>,nu=<0..0.5>,rho=<kg/m^3>"
            )
        try:
            values[CUSTOM_KEYS[key]] = float(value)
        except ValueError:
            raise InputError(f"custom material {text!r}: {key} must be a number, got {value!r}") from None
    missing = [k for k, v in CUSTOM_KEYS.items() if v not in values]
    if missing:
        raise InputError(
            f"custom material {text!r} lacks {', '.join(missing)}; write E=<Pa>,nu=<0..0.5>,rho=<kg/m^3>"
        )
    return custom_material(name=f"custom ({text.strip()})", **values)


def material(name: Any) -> Material:
    """Look up a material by (case-insensitive) name or alias ("lithium niobate",
    "LiNbO3", "fused silica", "teflon", ...), or build one from the form
    "E=<Pa>,nu=<->,rho=<kg/m^3>"; InputError lists the valid names."""
    if not isinstance(name, str):
        raise InputTypeError(f"material name must be a string, got {name!r}")
    custom = _parse_custom(name)
    if custom is not None:
        return custom
    key = name.strip().lower().replace(" ", "_").replace("-", "_")
    key = _ALIASES.get(key, key)
    if key not in MATERIALS:
        by_name = {m.name.lower().replace(" ", "_"): k for k, m in MATERIALS.items()}
        key = by_name.get(key, key)
    if key not in MATERIALS:
        raise InputError(
            f"unknown material {name!r}; valid names: "
            f"{', '.join(material_names())}, or E=<Pa>,nu=<0..0.5>,rho=<kg/m^3>"
        )
    return MATERIALS[key]


def as_material(name: str, value: Any) -> Material:
    if isinstance(value, Material):
        return value
    if isinstance(value, str):
        return material(value)
    raise InputTypeError(f"{name} must be a Material or a material name, got {value!r}")


# --------------------------------------------------------------------------- Rayleigh wave
def _brentq(f, xa, xb, xtol, rtol, maxiter=100):
    """scipy.optimize.brentq, operation for operation (its C code,
    scipy/optimize/Zeros/brentq.c, in Python floats: the same IEEE doubles,
    so the same root to the last bit; tests/core/test_units.py compares them).
    Here because importing scipy.optimize cost ~0.55 s of every command that
    makes a Scene (e.g. `vibtrans simulate`, 2.7 s in all).

    Ported from SciPy (BSD-3-Clause; Copyright (c) 2001-2002 Enthought, Inc.,
    2003-2024 SciPy Developers), whose licence terms apply to this function."""
    xpre, xcur = xa, xb
    xblk = fblk = spre = scur = 0.0
    fpre, fcur = f(xpre), f(xcur)
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    for _ in range(maxiter):
        if fpre != 0 and fcur != 0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry  # good short step
            else:
                spre = scur = sbis  # bisect
        else:
            spre = scur = sbis  # bisect
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = f(xcur)
        if math.isnan(fcur):
            raise ValueError(f"the function value at x={xcur} is NaN")
    raise RuntimeError(f"brentq failed to converge after {maxiter} iterations")


def _rayleigh_xi(nu: float) -> float:
    """c_R/c_t for one Poisson ratio: root of the Rayleigh secular equation
    (2 - xi^2)^2 = 4 sqrt(1 - xi^2) sqrt(1 - gamma xi^2), gamma = (c_t/c_l)^2."""
    gamma = (1 - 2 * nu) / (2 * (1 - nu))

    def secular(xi):
        return (2 - xi**2) ** 2 - 4 * math.sqrt(1 - xi**2) * math.sqrt(1 - gamma * xi**2)

    # xi = 0 is a spurious root; the physical one lies in (0.87, 0.96) for nu in (0, 0.5),
    # and secular < 0 at 0.5 and = 1 at xi = 1, so [0.5, 1] brackets it uniquely.
    return _brentq(secular, 0.5, 1.0, xtol=1e-15, rtol=1e-14)


def rayleigh_speed_ratio(nu: float) -> Any:
    """Rayleigh speed over shear speed, c_R/c_t [-], for Poisson ratio nu in (0, 0.5).
    Scalars give a float, arrays an array."""
    nu = _poisson("nu", nu)
    return np.vectorize(_rayleigh_xi, otypes=[float])(nu) if np.ndim(nu) else _rayleigh_xi(nu)


def rayleigh_speed(E: Any, nu: float, rho: Any) -> Any:
    """Rayleigh wave speed c_R [m/s] of an isotropic half-space: E [Pa], nu, rho [kg/m^3]."""
    E, rho = check_positive("E", E), check_positive("rho", rho)
    c_t = np.sqrt(E / (2 * (1 + _poisson("nu", nu)) * rho))  # shear speed sqrt(G/rho)
    return _out(rayleigh_speed_ratio(nu) * c_t)


def amplitude_ratio(nu: Any) -> Any:
    """r(nu) = |u_x| / |u_y| at the free surface for a Rayleigh wave [-] (docs/MODEL.md 1).

    Wavenumbers scaled by k_t = 1 (only ratios matter): k = c_t/c_R,
    q^2 = k^2 - k_l^2, s^2 = k^2 - 1, k_l^2 = (c_t/c_l)^2. The printed formula
    is negative; its magnitude is returned.
    """
    xi = rayleigh_speed_ratio(nu)
    nu = np.asarray(nu, dtype=float)
    k2 = 1.0 / np.asarray(xi) ** 2
    kl2 = (1 - 2 * nu) / (2 * (1 - nu))
    q, s = np.sqrt(k2 - kl2), np.sqrt(k2 - 1.0)
    r = np.abs(np.sqrt(k2) * (1 - 2 * q * s / (k2 + s**2)) / (q * (1 - 2 * k2 / (k2 + s**2))))
    return _out(r)


# --------------------------------------------------------------------------- contact
def stiffness_ratio(E: Any, nu: float, E_p: Any, nu_p: float) -> Any:
    """theta = E*/G*: ratio of normal to tangential Hertz-Mindlin contact stiffness [-].

    Substrate (E [Pa], nu) and particle (E_p [Pa], nu_p). In [1, 1.5] for nu in (0, 0.5).
    """
    E, E_p = check_positive("E", E), check_positive("E_p", E_p)
    nu, nu_p = _poisson("nu", nu), _poisson("nu_p", nu_p)
    tangential = (2 - nu) * (1 + nu) / (2 * E) + (2 - nu_p) * (1 + nu_p) / (2 * E_p)
    return _out(tangential / ((1 - nu**2) / E + (1 - nu_p**2) / E_p))


def effective_modulus(E: Any, nu: float, E_p: Any, nu_p: float) -> Any:
    """Hertz effective modulus E_eff [Pa]: 1/E_eff = (1-nu^2)/E + (1-nu_p^2)/E_p."""
    E, E_p = check_positive("E", E), check_positive("E_p", E_p)
    nu, nu_p = _poisson("nu", nu), _poisson("nu_p", nu_p)
    return _out(1.0 / ((1 - nu**2) / E + (1 - nu_p**2) / E_p))


def hertz_compression(load_N: Any, radius_m: Any, E_eff: Any) -> Any:
    """Static Hertz compression a0 [m] of a sphere (radius [m]) on a half-space
    under load [N]: load = (4/3) E_eff sqrt(R) a0^(3/2)."""
    load_N, radius_m = check_positive("load_N", load_N), check_positive("radius_m", radius_m)
    E_eff = check_positive("E_eff", E_eff)
    return _out((3 * load_N / (4 * E_eff * np.sqrt(radius_m))) ** (2.0 / 3.0))


def sphere_mass(radius_m: Any, density: Any) -> Any:
    """Mass [kg] of a solid sphere of radius [m] and density [kg/m^3]."""
    radius_m, density = check_positive("radius_m", radius_m), check_positive("density", density)
    return _out(4.0 / 3.0 * math.pi * radius_m**3 * density)


# --------------------------------------------------------------------------- SI <-> normalized
@dataclass(frozen=True)
class NormalizedScene:
    """A dimensional device expressed in the model's normalized parameters.

    mass_kg, load_N = m g + P [N], a0 [m], m_star = a0 m f^2/(Mg), A_star = A_y/a0,
    r = r(nu), theta, nu (substrate), c_R [m/s] (substrate), frequency [Hz].
    """

    mass_kg: float
    load_N: float
    a0: float
    m_star: float
    A_star: float
    r: float
    theta: float
    nu: float
    c_R: float
    frequency: float

    @property
    def wavelength(self) -> float:
        """Rayleigh wavelength c_R/f [m]."""
        return self.c_R / self.frequency

    def drift_velocity_si(self, v_star: float) -> Any:
        """Dimensional velocity [m/s] of a normalized one: v = a0 f v*."""
        return _out(self.a0 * self.frequency * check_interval("v_star", v_star))


def static_contact(
    substrate: str | Material, particle: str | Material, radius: Any, preload: Any, g: Any
) -> tuple[Material, Material, Any, Any, Any]:
    """(substrate, particle, mass [kg], load [N], a0 [m]) shared by the converters."""
    sub, par = as_material("substrate", substrate), as_material("particle", particle)
    radius = check_positive("radius", radius)
    preload, g = check_nonnegative("preload", preload), check_nonnegative("g", g)
    mass = sphere_mass(radius, par.density)
    load = mass * g + preload
    if load <= 0:  # only reachable with g = 0 and no preload
        raise InputError(
            f"load m*g + preload must be in (0, inf), got {load:g} (g={g:g}, preload={preload:g})"
        )
    E_eff = effective_modulus(sub.youngs_modulus, sub.poisson_ratio, par.youngs_modulus, par.poisson_ratio)
    return sub, par, mass, load, hertz_compression(load, radius, E_eff)


def to_normalized(
    substrate: str | Material,
    particle: str | Material,
    radius: float,
    frequency: Any,
    amplitude: float,
    preload: float = 0.0,
    g: float = 9.81,
) -> NormalizedScene:
    """Normalize a device: sphere of ``radius`` [m] made of ``particle`` on ``substrate``
    (names or Material), wave ``frequency`` [Hz], vertical amplitude A_y ``amplitude`` [m],
    pre-load ``preload`` [N], gravity ``g`` [m/s^2]. Returns a NormalizedScene."""
    sub, par, mass, load, a0 = static_contact(substrate, particle, radius, preload, g)
    f = check_positive("frequency", frequency)
    A_y = check_nonnegative("amplitude", amplitude)
    nu = sub.poisson_ratio
    return NormalizedScene(
        mass_kg=mass,
        load_N=load,
        a0=a0,
        m_star=a0 * mass * f**2 / load,
        A_star=A_y / a0,
        r=amplitude_ratio(nu),
        theta=stiffness_ratio(sub.youngs_modulus, nu, par.youngs_modulus, par.poisson_ratio),
        nu=nu,
        c_R=rayleigh_speed(sub.youngs_modulus, nu, sub.density),
        frequency=f,
    )


@dataclass(frozen=True)
class DeviceSpec:
    """Dimensional inputs of a device (SI units, see ``to_normalized``)."""

    substrate: str | Material
    particle: str | Material
    radius: float
    frequency: float
    amplitude: float
    preload: float = 0.0
    g: float = 9.81

    def normalized(self) -> NormalizedScene:
        return to_normalized(
            self.substrate, self.particle, self.radius, self.frequency, self.amplitude, self.preload, self.g
        )


def frequency_for_mass_ratio(
    m_star: Any,
    substrate: str | Material,
    particle: str | Material,
    radius: float,
    preload: float = 0.0,
    g: float = 9.81,
) -> Any:
    """Wave frequency f [Hz] at which the device has the given m* (a0 does not depend on f):
    f = sqrt(m* Mg / (a0 m))."""
    m_star = check_positive("m_star", m_star)
    _, _, mass, load, a0 = static_contact(substrate, particle, radius, preload, g)
    return _out(np.sqrt(m_star * load / (a0 * mass)))


def amplitude_from_normalized(A_star: float, a0: float) -> Any:
    """Vertical wave amplitude A_y = A* a0 [m] from A* [-] and a0 [m]."""
    return _out(check_nonnegative("A_star", A_star) * check_positive("a0", a0))


def duration_text(seconds: float) -> str:
    """A time in seconds as text, in the unit that reads best (ns to s)."""
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)):
        if abs(seconds) >= scale:
            return f"{seconds / scale:.4g} {unit}"
    return f"{seconds:.3g} s"
