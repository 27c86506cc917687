"""The particle's contact profile in device units, for design charts.

A design chart's particle is a body of radius R (its mass, 4/3 pi R^3 rho)
touching the substrate with a tip of a given shape (SI units):

    sphere                 the body's own sphere (Hertz), the default
    cone                   z = r cot(alpha), alpha the half-angle (degrees, 0 < alpha < 90)
    power:N                z = r^N / (N R_t^(N-1)), N >= 1 (N = 1: give the cone's
                           half-angle instead); R_t the tip radius (default R):
                           power:2 is a sphere of radius R_t, and the slope
                           z'(r) = (r / R_t)^(N-1) reaches 1 at r = R_t
    flat-sphere            the sphere R cut flat at radius c (metres): a worn particle
    file:PATH              a measured z(r) table (two columns r z, metres)

Static contact (MDR, docs/MODEL.md section 10), load N0 = m g + P, E* the
contact modulus: for z = C r^n the 1D profile is g = kappa_n C |x|^n,
kappa_n = sqrt(pi) Gamma(n/2 + 1) / Gamma(n/2 + 1/2), so the approach at
contact radius a is d = kappa_n C a^n and N = 2 E* n/(n+1) kappa_n C a^(n+1):

    a0 = (N0 (n+1) (kappa_n C)^(1/n) / (2 E* n))^(n/(n+1)),   a_c = (a0 / (kappa_n C))^(1/n)

(sphere n = 2, C = 1/(2R): Hertz's a0 = (3 N0 / (4 E* sqrt R))^(2/3); cone
n = 1, kappa_1 = pi/2, C = cot alpha: N = (2/pi) E* tan(alpha) d^2, Sneddon).
Flat-ended sphere: with s^2 = a^2 - c^2, d = a s / R and
N = (2 E*/R)(c^2 s + (2/3) s^3) (profiles.FlatSphereProfile); its normalized
flat radius is gamma = c / sqrt(R a0).

The normalized dynamics of a power law does not depend on C or the load
(N* = a*^((n+1)/n)): one map serves a whole chart.  A flat-ended sphere's
gamma and a table's N0/E* do depend on the radius and the load: a chart of
those reads one map, so its points must share them (a chart over frequency
and amplitude at a fixed radius); anything else is refused with that reason.

Validity (`tip_warnings`):
* the profile's slope at the contact edge, z'(a_c), at most MAX_EDGE_SLOPE:
  Hertz and MDR solve a half-space loaded by a nearly flat profile (contact
  radius small against the tip's size: a_c / R for a sphere, (a_c / R_t)^(N-1)
  for power:N); a cone's slope is cot(alpha) at every contact size;
* a cone's pressure p(r) = (E* cot(alpha) / 2) arccosh(a_c / r) is infinite at
  the apex whatever the load (its mean, E* cot(alpha) / 2, does not depend on
  the load either): a real apex yields or wears to a rounded tip, so the
  warning is always given with that mean pressure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import param

from vibtrans.core.errors import InputError
from vibtrans.core.profiles import FlatSphereProfile, PowerLawProfile, TabulatedProfile, read_table

if TYPE_CHECKING:
    from collections.abc import Mapping

# Hertz's (and MDR's) half-space solution assumes a nearly flat profile over
# the contact, a << R (Johnson, Contact Mechanics, 1985, sec. 4.1); a tenth
# is the usual round limit of that "<<", taken here as the largest slope.
MAX_EDGE_SLOPE = 0.1
TIP_KINDS = ("sphere", "cone", "power:N", "flat-sphere", "file:PATH")
# a flat-ended sphere's gamma (or a table's N0/E*) must agree this closely
# over a chart: a map holds one
SHARED_RELATIVE = 1e-9


def kappa(n: float) -> float:
    """MDR's factor of z = C r^n: g(x) = kappa_n C |x|^n."""
    try:
        return math.sqrt(math.pi) * math.gamma(n / 2 + 1) / math.gamma(n / 2 + 0.5)
    except OverflowError:
        # n > 341, where Gamma overflows (a typed N = 1e300 raised): the
        # ratio's series in y = 1/x, x = (n + 1)/2 (DLMF 5.11.13), within
        # about 1e-14 of it from there on
        y = 1.0 / (n / 2 + 0.5)
        series = 1 - y / 8 + y * y / 128 + 5 * y**3 / 1024 - 21 * y**4 / 32768
        return math.sqrt(math.pi) / math.sqrt(y) * series


@dataclass(frozen=True, eq=False)
class TipShape:
    """A tip shape in SI (`tip_shape` builds and checks one).  kind: sphere,
    power (n; cone: n = 1 with half_angle in degrees; tip_radius in m or
    None for the particle radius), flat-sphere (flat_radius, m) or file
    (path; table r, z in m)."""

    kind: str = "sphere"
    n: float = 2.0
    half_angle: float | None = None
    tip_radius: float | None = None
    flat_radius: float | None = None
    path: str | None = None
    table: tuple = field(default=(), repr=False)

    @property
    def name(self) -> str:
        """The shape as a reader names it (charts' attrs, JSON)."""
        if self.kind == "sphere":
            return "sphere"
        if self.kind == "power":
            if self.n == 1.0:
                return f"cone (half-angle {self.half_angle:g} deg)"
            tip = "the particle radius" if self.tip_radius is None else f"{self.tip_radius:g} m"
            return f"power:{self.n:g} (tip radius {tip})"
        if self.kind == "flat-sphere":
            return f"flat-sphere (flat radius {self.flat_radius:g} m)"
        return f"file:{self.path}"

    @property
    def is_sphere(self) -> bool:
        return self.kind == "sphere"


def _real(name, value, lo, hi, lo_open=True, hi_open=True, unit=""):
    ok = (
        not isinstance(value, bool)
        and isinstance(value, (int, float, np.floating))
        and math.isfinite(value)
        and (value > lo if lo_open else value >= lo)
        and (value < hi if hi_open else value <= hi)
    )
    if not ok:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        raise InputError(f"{name} must be a real number in {lb}{lo:g}, {hi:g}{rb}{unit}, got {value!r}")
    return float(value)


def tip_shape(
    profile: str | TipShape = "sphere",
    half_angle: float | None = None,
    tip_radius: float | None = None,
    flat_radius: float | None = None,
) -> TipShape:
    """A checked TipShape from a profile name (TIP_KINDS) and its SI sizes:
    half_angle [deg] for a cone (or power:1), tip_radius [m] for power:N
    (optional), flat_radius [m] for flat-sphere.  A size the profile does
    not use is refused (nothing is silently ignored)."""
    if isinstance(profile, TipShape):
        return profile
    if not isinstance(profile, str):
        raise InputError(f"profile must be one of {', '.join(TIP_KINDS)}, got {profile!r}")
    given = {"half_angle": half_angle, "tip_radius": tip_radius, "flat_radius": flat_radius}

    def only(*names):
        for k, v in given.items():
            if v is not None and k not in names:
                used = " and ".join(names) if names else "no size"
                raise InputError(f"{k} does not apply to profile {profile!r} (it takes {used})")

    if profile == "sphere":
        only()
        return TipShape()
    if profile.startswith("file:"):
        only()
        path = profile[5:]
        table = read_table(path)
        return TipShape("file", path=path, table=(table[:, 0].copy(), table[:, 1].copy()))
    if profile.startswith("flat-sphere"):
        if profile != "flat-sphere":
            raise InputError(
                "design takes the flat radius in metres: profile 'flat-sphere' "
                f"with flat_radius (--flat-radius), got {profile!r}"
            )
        only("flat_radius")
        if flat_radius is None:
            raise InputError("profile flat-sphere needs flat_radius (--flat-radius, m, in [0, inf))")
        return TipShape(
            "flat-sphere",
            flat_radius=_real("flat_radius", flat_radius, 0.0, math.inf, lo_open=False, unit=" m"),
        )
    if profile == "cone":
        n = 1.0
    elif profile.startswith("power:"):
        try:
            n = float(profile[6:])
        except ValueError:
            raise InputError(f"profile power parameter must be a number, got {profile[6:]!r}") from None
        PowerLawProfile(n)  # n >= 1, with its message
    else:
        raise InputError(f"profile must be one of {', '.join(TIP_KINDS)}, got {profile!r}")
    if n == 1.0:
        only("half_angle")
        if half_angle is None:
            raise InputError("profile cone needs half_angle (--half-angle, degrees, in (0, 90))")
        return TipShape("power", 1.0, half_angle=_real("half_angle", half_angle, 0.0, 90.0, unit=" degrees"))
    only("tip_radius")
    if tip_radius is not None:
        tip_radius = _real("tip_radius", tip_radius, 0.0, math.inf, unit=" m")
    if n == 2.0 and tip_radius is None:
        return TipShape()
    return TipShape("power", n, tip_radius=tip_radius)


def _flat_sphere_s(c, X):
    """s > 0 with c^2 s + (2/3) s^3 = X (arrays): Cardano's root, then Newton."""
    c2 = c * c
    p, q = 1.5 * c2, -1.5 * X
    disc = np.sqrt(q * q / 4 + p**3 / 27)
    s = np.cbrt(-q / 2 + disc) + np.cbrt(-q / 2 - disc)
    # Cardano cancels for a large flat: a few Newton steps polish any start
    s = np.where(s > 0, s, np.minimum(np.cbrt(1.5 * X), X / np.maximum(c2, 1e-300)))
    for _ in range(6):
        f = c2 * s + (2.0 / 3.0) * s**3 - X
        s = s - f / (c2 + 2.0 * s * s)
    return s


def _shared(name, values, why):
    values = np.asarray(values, float)
    lo, hi = float(np.min(values)), float(np.max(values))
    if hi - lo > SHARED_RELATIVE * max(abs(hi), abs(lo)):
        raise InputError(
            f"{name} spans [{lo:.4g}, {hi:.4g}] over the chart ({why}); a map "
            f"holds one value: chart over frequency and amplitude at a fixed radius"
        )
    return float(values.flat[0])


@dataclass(frozen=True)
class TipContact:
    """The static contact of a tip under its load (arrays, SI): a0 [m],
    contact_radius [m], edge_slope z'(a_c) [-], mean_pressure [Pa]; and the
    normalized profile the dynamics takes (Scene's `profile`, with
    `load_over_modulus` [m^2] for a table; None otherwise)."""

    a0: np.ndarray
    contact_radius: np.ndarray
    edge_slope: np.ndarray
    mean_pressure: np.ndarray
    profile: str
    load_over_modulus: float | None = None


def static_contact(shape: Any, radius: Any, load: Any, E_eff: Any) -> TipContact:
    """TipContact of a tip shape on a body of `radius` [m] under `load` [N]
    (broadcastable arrays), contact modulus E_eff [Pa].  A flat-ended
    sphere's gamma or a table's N0/E* must be shared by all the points
    (InputError otherwise, see the module's text)."""
    shape = tip_shape(shape)
    radius, load = np.broadcast_arrays(np.asarray(radius, float), np.asarray(load, float))
    if shape.kind == "sphere":
        a0 = (3 * load / (4 * E_eff * np.sqrt(radius))) ** (2.0 / 3.0)
        ac = np.sqrt(radius * a0)
        return TipContact(a0, ac, ac / radius, load / (np.pi * ac**2), "sphere")
    if shape.kind == "power":
        n = shape.n
        if n == 1.0:
            t = math.tan(math.radians(shape.half_angle))  # (0 for an angle that underflows: 5e-324)
            C = np.full(radius.shape, 1.0 / t if t else math.inf)
        else:
            rt = radius if shape.tip_radius is None else np.full(radius.shape, shape.tip_radius)
            C = 1.0 / (n * rt ** (n - 1.0))
        kc = kappa(n) * C
        a0 = (load * (n + 1) * kc ** (1.0 / n) / (2 * E_eff * n)) ** (n / (n + 1))
        ac = (a0 / kc) ** (1.0 / n)
        slope = n * C * ac ** (n - 1.0)
        return TipContact(a0, ac, slope, load / (np.pi * ac**2), PowerLawProfile(n).name)
    if shape.kind == "flat-sphere":
        c = shape.flat_radius
        s = _flat_sphere_s(np.full(radius.shape, c), load * radius / (2 * E_eff))
        ac = np.sqrt(c * c + s * s)
        a0 = ac * s / radius
        gamma = _shared(
            "the flat-ended sphere's gamma = c / sqrt(R a0)",
            c / np.sqrt(radius * a0),
            "it depends on the radius and the load",
        )
        FlatSphereProfile(gamma)
        return TipContact(a0, ac, ac / radius, load / (np.pi * ac**2), f"flat-sphere:{gamma:.10g}")
    lom = _shared(
        "the load over the contact modulus N0/E*",
        load / E_eff,
        "a measured profile's normalized law depends on the load",
    )
    r, z = shape.table
    prof = TabulatedProfile(r, z, lom, name=f"file:{shape.path}")
    ac = prof.static_contact_radius
    slope = float(np.interp(ac, 0.5 * (r[1:] + r[:-1]), np.diff(z) / np.diff(r)))
    full = np.ones(radius.shape)
    return TipContact(
        prof.a0 * full, ac * full, slope * full, load / (np.pi * ac**2), f"file:{shape.path}", lom
    )


def outline(shape: Any, r: Any, radius: float) -> Any:
    """The tip's outline z(r) [m] at radii r [m] (arrays) of a body of
    `radius` [m]: for a drawing of the tip (sphere and flat-sphere: the
    parabolic profile the contact law uses, r^2 / (2R) beyond the flat)."""
    shape = tip_shape(shape)
    r = np.abs(np.asarray(r, float))
    if shape.kind == "sphere":
        return r * r / (2 * radius)
    if shape.kind == "power":
        if shape.n == 1.0:
            return r / math.tan(math.radians(shape.half_angle))
        rt = radius if shape.tip_radius is None else shape.tip_radius
        return r**shape.n / (shape.n * rt ** (shape.n - 1.0))
    if shape.kind == "flat-sphere":
        c = shape.flat_radius
        return np.where(r > c, (r * r - c * c) / (2 * radius), 0.0)
    tr, tz = shape.table
    return np.interp(r, tr, tz, right=np.nan)


@dataclass(frozen=True)
class TipWarning:
    """One tip-specific failed assumption (as design.ValidityWarning)."""

    code: str
    message: str
    value: float
    threshold: float


def tip_warnings(shape: Any, contact: Any, E_eff: float) -> list[Any]:
    """TipWarnings of a tip's static contact (`static_contact` at one point):
    'tip-slope' (slope at the contact edge above MAX_EDGE_SLOPE) and
    'cone-apex' (always for a cone: its apex pressure is singular)."""
    shape = tip_shape(shape)
    out = []
    slope = float(np.max(contact.edge_slope))
    ac = float(np.max(contact.contact_radius))
    if slope > MAX_EDGE_SLOPE:
        size = {
            "sphere": "the sphere's radius",
            "flat-sphere": "the sphere's radius",
            "file": "the measured profile",
        }.get(shape.kind, "the tip radius")
        if shape.kind == "power" and shape.n == 1.0:
            size = "the cone: cot(half-angle) at any size"
        out.append(
            TipWarning(
                "tip-slope",
                f"the profile's slope at the contact edge (contact radius {ac:.3g} m) "
                f"is {slope:.3g}, above {MAX_EDGE_SLOPE:g} ({size}): Hertz and MDR assume a "
                f"nearly flat profile over the contact (a half-space); treat the results as "
                f"qualitative",
                slope,
                MAX_EDGE_SLOPE,
            )
        )
    if shape.kind == "power" and shape.n == 1.0:
        t = math.tan(math.radians(shape.half_angle))
        pm = E_eff / (2 * t) if t else math.inf
        out.append(
            TipWarning(
                "cone-apex",
                f"a cone's contact pressure (E* cot(alpha)/2) arccosh(a/r) is infinite "
                f"at its apex at any load (mean pressure {pm:.3g} Pa, the same at every load): a "
                f"real apex yields or wears round; the sharp elastic cone holds while that rounded "
                f"region is small against the contact radius {ac:.3g} m",
                pm,
                0.0,
            )
        )
    return out


class TipSize(param.Number):
    """One size of the particle's tip in SI as a Param parameter (the
    explorer's page state holds four), checked by `tip_shape` (its
    InputError names the parameter and its valid range; nothing clamped)
    whether set in code, typed or linked (the explorer's link reader takes
    a plain decimal, then calls `library_check`; an empty text is
    None where allow_None: the tip radius, the particle's own).  `size`:
    which (half_angle [deg], exponent, tip_radius [m], flat_radius [m]);
    `range_text`: its range in words (for a form's or a link's message)."""

    __slots__ = ["size", "range_text"]

    def __init__(self, default: Any = None, size: Any = None, range_text: str = "", **params: Any) -> None:
        self.size = size
        self.range_text = range_text
        super().__init__(default=default, **params)

    def library_check(self, value: Any) -> float | None:
        """The library's check of `value` (InputError, a ValueError, if refused)."""
        if value is None and self.allow_None:
            return None
        if self.size == "exponent":
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise InputError(f"the tip's exponent N must be a real number in (1, inf), got {value!r}")
            if value == 1:
                raise InputError(
                    "the tip's exponent N must be a real number in (1, inf), "
                    "got 1 (N = 1 is the cone: choose the tip 'cone' and give its "
                    "half-angle)"
                )
            tip_shape(f"power:{float(value)!r}")
        elif self.size == "half_angle":
            tip_shape("cone", half_angle=value)
        elif self.size == "tip_radius":
            tip_shape("power:3", tip_radius=value)
        else:
            tip_shape("flat-sphere", flat_radius=value)
        return float(value)

    def _validate(self, val):
        super()._validate(val)
        self.library_check(val)


# The kinds of tip its sizes give (TIP_KINDS but a measured table, which a
# path gives: tip_shape("file:PATH")), and the sizes each takes (Tip's)
TIP_SIZES: dict[str, tuple[str, ...]] = {
    "sphere": (),
    "cone": ("tip_half_angle",),
    "power": ("tip_exponent", "tip_radius"),
    "flat-sphere": ("tip_flat_radius",),
}


def tip_arguments(values: Mapping[str, Any]) -> dict[str, Any]:
    """`tip_shape`'s arguments of a Tip's values.

    Parameters
    ----------
    values : mapping
        A Tip's values by name: its kind (`tip`) and that kind's sizes at least.

    Returns
    -------
    dict
        profile, and half_angle, tip_radius or flat_radius as the kind takes.
    """
    kind = values["tip"]
    if kind == "sphere":
        return {"profile": "sphere"}
    if kind == "cone":
        return {"profile": "cone", "half_angle": values["tip_half_angle"]}
    if kind == "power":
        return {"profile": f"power:{float(values['tip_exponent'])!r}", "tip_radius": values["tip_radius"]}
    return {"profile": "flat-sphere", "flat_radius": values["tip_flat_radius"]}


class Tip(param.Parameterized):
    """The particle's tip in SI as a form or a link gives it (docs/MODEL.md
    section 10, "In device units"): its kind and the sizes of each kind
    (TIP_SIZES), each checked by `tip_shape` as it is set (TipSize: its
    InputError names the size and its range); by default the sphere.

    Parameters
    ----------
    tip : str
        The kind: one of TIP_SIZES ("sphere", "cone", "power", "flat-sphere").
    tip_half_angle : float
        The cone's half-angle, degrees, in (0, 90).
    tip_exponent : float
        The power law's exponent N > 1: z = r^N / (N R_t^(N-1)).
    tip_radius : float or None
        The power law's tip radius R_t, m (None: the particle's radius).
    tip_flat_radius : float
        The flat-ended sphere's flat radius, m, at least 0.
    """

    tip: param.Selector = param.Selector(
        default="sphere",
        objects=list(TIP_SIZES),
        doc="the particle's tip: the sphere, a cone, a power law, a flat",
    )
    tip_half_angle = TipSize(
        60.0,
        size="half_angle",
        range_text="a number in (0, 90) (degrees)",
        doc="the cone's half-angle, degrees",
    )
    tip_exponent = TipSize(
        3.0,
        size="exponent",
        range_text="a number in (1, inf)",
        doc="the power law's exponent N: z = r^N / (N R_t^(N-1))",
    )
    tip_radius = TipSize(
        None,
        size="tip_radius",
        allow_None=True,
        range_text="a number in (0, inf) (m), or empty: the particle's radius",
        doc="the power law's tip radius R_t, m (None: the particle's radius)",
    )
    tip_flat_radius = TipSize(
        1e-6,
        size="flat_radius",
        range_text="a number in [0, inf) (m)",
        doc="the flat-ended sphere's flat radius, m",
    )

    def sizes(self) -> tuple[str, ...]:
        """The names of the sizes its kind takes (the others do not make the tip).

        Returns
        -------
        tuple of str
            Names of its parameters, TIP_SIZES[tip].
        """
        return TIP_SIZES[self.tip]

    def tip_shape(self) -> TipShape:
        """The tip as the design charts take it.

        Returns
        -------
        TipShape
            Checked by `tip_shape`.

        Raises
        ------
        InputError
            Naming a size outside its range.
        """
        return tip_shape(**tip_arguments(self.param.values()))
