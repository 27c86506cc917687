"""Validated scene parameters (dimensionless) and the paper's ten scenes.

A `Scene` is everything a run needs; every value is checked on assignment,
and a bad one raises ValueError naming the parameter and its valid range
(NaN, inf, wrong type, out of domain): nothing is clamped.

Units (docs/MODEL.md section 1): A* = A_y / a0, m* = a0 m f^2 / (M g), time in
wave periods.
"""

from __future__ import annotations

import functools
import math
import numbers
import re
import sys
from typing import TYPE_CHECKING, Any

import param

from vibtrans.core.errors import InputError
from vibtrans.core.profiles import PROFILE_KINDS, parse_profile
from vibtrans.core.units import amplitude_ratio

if TYPE_CHECKING:
    from vibtrans.core.profiles import FlatSphereProfile, PowerLawProfile, TabulatedProfile

MODELS = ("deformable", "point-mass", "vertical")
INTEGRATORS = ("ab4", "verlet")
FIDELITIES = ("preview", "standard", "reference")
STICK_RULES = ("paper", "classical")
# Rolling (docs/MODEL.md section 11): the particle's moment of inertia about
# its centre, I = j m R^2, by name; "none" is the paper's particle, which
# slides without turning.
ROLLING_NAMES = {"solid": 0.4, "shell": 2.0 / 3.0}
ROLLING_NONE = "none"
ROLLING_RANGE = "rolling must be none, solid (j = 2/5), shell (j = 2/3) or a number j = I/(m R^2) in (0, 1]"


def _interval(lo, hi, inclusive):
    left = "[" if inclusive[0] and lo is not None else "("
    right = "]" if inclusive[1] and hi is not None else ")"
    lo_s = "-inf" if lo is None else f"{lo:g}"
    hi_s = "inf" if hi is None else f"{hi:g}"
    return f"{left}{lo_s}, {hi_s}{right}"


class Physical(param.Number):
    """A finite real number in a (half-)open or closed interval.

    Its error message always says the parameter's name and valid range.
    """

    def _validate(self, val):
        if val is None and self.allow_None:
            return
        lo, hi = self.bounds if self.bounds is not None else (None, None)
        rng = _interval(lo, hi, self.inclusive_bounds)
        name = self.name or "value"
        if isinstance(val, bool) or not isinstance(val, numbers.Real):
            raise InputError(f"{name} must be a real number in {rng}, got {val!r}")
        try:
            v = float(val)
        except OverflowError:
            raise InputError(f"{name} must be in {rng}, got an integer too large") from None
        ok = math.isfinite(v)
        if ok and lo is not None:
            ok = v >= lo if self.inclusive_bounds[0] else v > lo
        if ok and hi is not None:
            ok = v <= hi if self.inclusive_bounds[1] else v < hi
        if not ok:
            raise InputError(f"{name} must be in {rng}, got {val!r}")


def check_profile(val: Any, refuse_measured: str | None = None) -> None:
    """InputError naming the parameter and its range unless `val` is a
    profile's spec (a file: spec is checked when its table is read);
    `refuse_measured`: the message refusing a measured table (file:PATH),
    for an entry point that cannot take one."""
    if not isinstance(val, str):
        raise InputError(f"profile must be one of {', '.join(PROFILE_KINDS)}; got {val!r}")
    if val.startswith("file:"):
        if refuse_measured:
            raise InputError(refuse_measured)
        return
    parse_profile(val)  # raises naming the parameter and its range


class ProfileSpec(param.String):
    """An axisymmetric particle profile: sphere | cone | power:N (N >= 1) |
    flat-sphere:C (0 <= C <= 1e50, units sqrt(R a0)) | file:PATH (a table r z in
    metres; needs the scene's load_over_modulus).  docs/MODEL.md section 10.
    A subclass for an entry point that cannot take a measured table (a
    link, a form) sets `refuse_measured` to the message that says why."""

    refuse_measured = None

    def _validate(self, val):
        check_profile(val, self.refuse_measured)


def check_rolling(val: Any) -> str | float:
    """The canonical form of a rolling value: "none", "solid", "shell" or
    j = I/(m R^2) as a float in (0, 1] (a number or its text); else
    InputError naming the parameter and its range."""
    if isinstance(val, str):
        text = val.strip()
        if text == ROLLING_NONE or text in ROLLING_NAMES:
            return text
        try:
            number: Any = float(text)
        except ValueError:
            raise InputError(f"{ROLLING_RANGE}; got {val!r}") from None
    elif isinstance(val, numbers.Real) and not isinstance(val, bool):
        number = val
    else:
        raise InputError(f"{ROLLING_RANGE}; got {val!r}")
    try:
        j = float(number)
    except OverflowError:
        raise InputError(f"{ROLLING_RANGE}; got an integer too large") from None
    if not 0.0 < j <= 1.0:  # (NaN fails too)
        raise InputError(f"{ROLLING_RANGE}; got {val!r}")
    return j


def inertia_ratio(rolling: Any) -> float | None:
    """j = I/(m R^2) of a rolling value (`check_rolling`); None: no rolling."""
    value = check_rolling(rolling)
    if value == ROLLING_NONE:
        return None
    return ROLLING_NAMES[value] if isinstance(value, str) else value


# a number as a link or a field spells it: plain decimals (no nan, inf, 1_0)
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]{1,4})?")


class RollingSpec(param.Parameter):
    """How the particle turns: none (it slides without turning, the paper's
    model), solid (a solid sphere, j = 2/5), shell (a thin shell, j = 2/3) or
    j = I/(m R^2) in (0, 1]; docs/MODEL.md section 11."""

    valid_values = f"{ROLLING_NONE}, {', '.join(ROLLING_NAMES)}, or a number j in (0, 1]"

    def _validate(self, val):
        check_rolling(val)

    def check_text(self, raw: str) -> str | float:
        """The value of a typed or linked text (j as a plain decimal), or
        InputError naming the parameter and its range."""
        if raw not in (ROLLING_NONE, *ROLLING_NAMES) and not _DECIMAL.fullmatch(raw):
            raise InputError(f"{ROLLING_RANGE}; got {raw!r}")
        return check_rolling(raw)


@functools.lru_cache(maxsize=32)
def _profile_shape(profile, load_over_modulus):
    """The profile object of a spec, parsed once (a file profile's MDR costs
    milliseconds; scenes are copied often)."""
    return parse_profile(profile, load_over_modulus)


def _choice(name, value, options):
    if value not in options:
        raise InputError(f"{name} must be one of {', '.join(options)}; got {value!r}")
    return value


# m* from the smallest normal float up: below it (a subnormal m*) 1/m* is
# infinite, and a particle at rest, zero net force, got 0 * inf = NaN for
# its acceleration (a NaN take-off time; found by tests/core/test_bad_input_properties.py)
MASS_MIN = sys.float_info.min


@functools.lru_cache(maxsize=64)
def _amplitude_ratio_of(nu):
    """r(nu) (units.amplitude_ratio, a root of the Rayleigh equation) once
    per Poisson ratio: a map asks for it at each of its points."""
    return float(amplitude_ratio(nu))


def _above(lo: float, default: Any, doc: str, closed: bool = False, **kw: Any) -> Physical:
    """A Physical in (lo, inf), or [lo, inf) when `closed`."""
    return Physical(default, bounds=(lo, None), inclusive_bounds=(closed, False), doc=doc, **kw)


class Scene(param.Parameterized):
    """One simulated scene, in the paper's normalized units.

    Every parameter is checked when set; `replace` makes a changed copy.

    Parameters
    ----------
    amplitude : float
        A*: vertical wave amplitude / a0 (the maps span 1e-3 to 1e3).
    mass : float
        m* = a0 m f^2 / (M g) (the maps span 1e-5 to 1e5).
    mu : float
        Friction coefficient.
    theta : float
        Tangential/normal compliance ratio, in [1, 1.5].
    nu : float
        Substrate Poisson ratio, in (0, 0.5): sets the Rayleigh ratio r.
    tau : float
        Ramp time of the wave, periods (0: no ramp).
    periods : float
        Observation time T_obs, wave periods.
    alpha_t : float
        Material point: tangential restitution at rebounds.
    model : str
        "deformable", "point-mass" or "vertical".
    integrator : str
        "ab4" or "verlet".
    fidelity : str
        "preview", "standard" or "reference".
    stick_rule : str
        Material point's slide-to-stick rule: "paper" or "classical".
    profile : str
        The particle's profile (deformable and vertical models), one of
        PROFILE_KINDS (e.g. "power:3").
    load_over_modulus : float, optional
        N0/E* [m^2], for file: profiles (their table is in metres).
    rolling : str or float
        How the particle turns (deformable model): "none" (the paper's
        particle), "solid" (j = 2/5), "shell" (j = 2/3) or j = I/(m R^2)
        in (0, 1], given as a number or its text.

    Raises
    ------
    InputError
        If a parameter is unknown or outside its range.
    """

    amplitude = _above(
        0, 10**-0.3, "A*: vertical wave amplitude / a0 (the map spans 1e-3 to 1e3)", closed=True
    )
    mass = _above(MASS_MIN, 10.0, "m* = a0 m f^2 / (M g) (the map spans 1e-5 to 1e5)", closed=True)
    mu = _above(0, 0.3, "friction coefficient (typically 0.01 to 1)")
    theta = Physical(1.2, bounds=(1.0, 1.5), doc="tangential/normal compliance ratio theta")
    nu = Physical(
        0.3,
        bounds=(0.0, 0.5),
        inclusive_bounds=(False, False),
        doc="substrate Poisson ratio (sets the Rayleigh ratio r)",
    )
    tau = _above(0, 50.0, "ramp time of the wave, periods (0: no ramp)", closed=True)
    periods = _above(0, 2000.0, "observation time T_obs, wave periods")
    alpha_t = Physical(0.5, bounds=(0.0, 1.0), doc="point mass: tangential restitution at rebounds")
    model: param.Selector = param.Selector(default="deformable", objects=list(MODELS))
    integrator: param.Selector = param.Selector(default="ab4", objects=list(INTEGRATORS))
    fidelity: param.Selector = param.Selector(default="standard", objects=list(FIDELITIES))
    stick_rule: param.Selector = param.Selector(
        default="paper",
        objects=list(STICK_RULES),
        doc="point mass slide->stick rule (docs/MODEL.md section 3)",
    )
    profile = ProfileSpec(
        "sphere", doc="particle profile (deformable and vertical models): " + ", ".join(PROFILE_KINDS)
    )
    load_over_modulus = _above(
        0,
        None,
        "N0/E*, m^2: the static load over the contact modulus "
        "(file: profiles only, whose table is in metres)",
        allow_None=True,
    )
    rolling = RollingSpec(
        ROLLING_NONE,
        doc="how the particle turns (deformable model): none, "
        "solid (j = 2/5), shell (j = 2/3) or j = I/(m R^2) in (0, 1]",
    )

    def __init__(self, **params: Any) -> None:
        for key, options in (
            ("model", MODELS),
            ("integrator", INTEGRATORS),
            ("fidelity", FIDELITIES),
            ("stick_rule", STICK_RULES),
        ):
            if key in params:
                _choice(key, params[key], options)
        unknown = set(params) - set(self.param) - {"name"}
        if unknown:
            raise InputError(f"unknown scene parameter(s): {', '.join(sorted(unknown))}")
        if "rolling" in params:
            params = {**params, "rolling": check_rolling(params["rolling"])}
        super().__init__(**params)
        self.profile_shape()  # a file profile is read and checked now
        if self.rolling != ROLLING_NONE and self.model != "deformable":
            why = (
                "the material point has no size to turn"
                if self.model == "point-mass"
                else "the vertical model has no tangential motion"
            )
            raise InputError(
                f"rolling applies to the deformable model only ({why}): "
                f"use rolling='none' with model={self.model!r}; got "
                f"rolling={self.rolling!r}"
            )

    @property
    def inertia_ratio(self) -> float | None:
        """j = I/(m R^2) of a rolling particle; None: it does not turn."""
        return inertia_ratio(self.rolling)

    def profile_shape(self) -> TabulatedProfile | PowerLawProfile | FlatSphereProfile:
        """The profile object (vibtrans.core.profiles) of this scene; its
        kernels' law: vibtrans.core.drivers.scene_law(scene)."""
        return _profile_shape(self.profile, self.load_over_modulus)

    @property
    def r(self) -> float:
        """Rayleigh horizontal/vertical amplitude ratio r(nu)."""
        return _amplitude_ratio_of(float(self.nu))

    def values(self) -> dict[str, Any]:
        """The scene as a plain dict (attributes of results, JSON).  The
        profile's load appears only where it is set (a file: profile),
        rolling only where the particle rolls (a scene that does not keeps
        the values, the results' attributes and the map keys it had before
        rolling existed)."""
        return {
            k: getattr(self, k)
            for k in self.param
            if k != "name"
            and not (k == "load_over_modulus" and self.load_over_modulus is None)
            and not (k == "rolling" and self.rolling == ROLLING_NONE)
        }

    def replace(self, **changes: Any) -> Scene:
        """A copy with some values changed (validated)."""
        return Scene(**{**self.values(), **changes})


# The domain of the paper's maps (its Fig. 3) and of the shipped ones.
MAP_LOG_AMPLITUDE = (-3.0, 3.0)  # log10 A*
MAP_LOG_MASS = (-5.0, 5.0)  # log10 m*

# The paper's labelled points (docs/MODEL.md section 6): (log10 A*, log10 m*, model).
PAPER_POINTS = {
    1: (-0.3, 1.0, "deformable"),
    2: (1.0, -2.7, "deformable"),
    3: (-0.3, -3.0, "deformable"),
    4: (2.5, 0.0, "deformable"),
    5: (2.5, 1.5, "deformable"),
    6: (0.25, 0.8, "deformable"),
    7: (0.0, 5.0, "deformable"),
    8: (1.7, -2.0, "deformable"),
    9: (2.7, -4.4, "point-mass"),
    10: (1.2, -1.0, "point-mass"),
}


def paper_scene(point: int, **overrides: Any) -> Scene:
    """Scene of one of the paper's ten labelled points.

    The points share mu = 0.3, theta = 1.2 and tau = 50; `PAPER_POINTS`
    gives each one's model, log10 A* and log10 m*.

    Parameters
    ----------
    point : int
        The point's number, 1 to 10.
    **overrides
        Scene parameters to set instead of the point's (e.g. `periods=60`).

    Returns
    -------
    Scene
        The point's scene, with the overrides applied.

    Raises
    ------
    InputError
        If `point` is not 1-10 or an override is outside its range.
    """
    if point not in PAPER_POINTS:
        raise InputError(f"point must be one of 1-10, got {point!r}")
    la, lm, model = PAPER_POINTS[point]
    return Scene(amplitude=10**la, mass=10**lm, model=model, **overrides)


# A scene's point on the regime plane (a map's axes, log10 A* and log10 m*),
# and the material point's own settings (no other model reads them): the
# groups of Scene's parameters that a map and an entry point treat apart.
PLANE = ("amplitude", "mass")
POINT_MASS_SETTINGS = ("alpha_t", "stick_rule")
