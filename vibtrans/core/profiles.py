"""Axisymmetric particle profiles: normalized normal laws and memory-diagram weights.

Method of Dimensionality Reduction (Popov & Hess; docs/MODEL.md section
"Axisymmetric profiles").  A profile z = f(r) maps to the 1D profile

    g(x) = |x| * integral_0^|x| f'(r) / sqrt(x^2 - r^2) dr,

approach d = g(a) at contact radius a, normal force N(a) = 2 E* int_0^a (d - g(x)) dx.
Normalized: a* = d / a0 with a0 the static approach under the load N0 (= Mg),
N*(a*) = N(d = a* a0) / N0, so N*(1) = 1 for every profile.

dN/dd = 2 E* a (contact radius), so N*'(a*) is the normalized contact radius and
the Cattaneo-Mindlin springs that enter contact at approach h weigh dN*'(h):

    T* = b* N*'(a*) - integral_[0, a*] w(h) dN*'(h)         (memory diagram anchors w)

which for the sphere (N*' = 1.5 sqrt(h)) is contact.py's T* = 1.5 b sqrt(a) - 0.75 P.
Total sliding gives T* = N*(a*) for every profile (N*(0) = 0).

Profiles (all scale-free except the tabulated one, which needs the load):
    sphere          N* = a*^(3/2)
    power:n         z = C r^n, n >= 1: N* = a*^((n+1)/n)   (cone n = 1, sphere n = 2)
    flat-sphere:c   sphere cut flat at radius c; c in units of sqrt(R a0)
    file:PATH       a measured z(r) table (metres), through MDR numerically

The kernels take a profile as `kernels.contact.kernel_law(profile)`: None for the sphere (its
own, unchanged path), else a float64 array (contact.law_eval): the power law's
exponent, or N*'(a*) on a uniform grid with N* its exact integral.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from vibtrans.core.errors import InputError

if TYPE_CHECKING:
    import numpy.typing as npt

PROFILE_KINDS = ("sphere", "cone", "power:N", "flat-sphere:C", "file:PATH")
N_MIN = 1.0  # power-law exponent lower bound (n >= 1: convex profile)
# flat radius upper bound (units sqrt(R a0)): the law squares it twice, and
# a wider flat is the flat punch (N* = a*) to within rounding
FLAT_MAX = 1e50
MIN_TABLE_POINTS_IN_CONTACT = 20  # table rows inside the static contact radius


def _power_stiffness(p, h):
    return p * np.power(h, p - 1.0)


@dataclass(frozen=True)
class PowerLawProfile:
    """z = C r^n; normalized law N* = a*^p with p = (n+1)/n (independent of C)."""

    n: float

    def __post_init__(self):
        n = self.n
        if isinstance(n, bool) or not isinstance(n, (int, float)) or not math.isfinite(n) or n < N_MIN:
            raise InputError(
                f"profile power-law exponent n must be a real number in [{N_MIN:g}, inf), got {n!r}"
            )

    @property
    def name(self) -> str:
        if self.n == 2.0:
            return "sphere"
        if self.n == 1.0:
            return "cone"
        return f"power:{self.n:g}"

    @property
    def exponent(self) -> float:
        """p in N* = a*^p."""
        return (self.n + 1.0) / self.n

    def normal_force(self, a: npt.ArrayLike) -> np.ndarray:
        """N*(a*) (units N0), a* >= 0 in units of a0."""
        return np.power(np.maximum(np.asarray(a, float), 0.0), self.exponent)

    def stiffness(self, a: npt.ArrayLike) -> np.ndarray:
        """dN*/da* = normalized contact radius; the memory springs' cumulative weight."""
        return _power_stiffness(self.exponent, np.maximum(np.asarray(a, float), 0.0))

    def contact_radius(self, a: npt.ArrayLike) -> np.ndarray:
        """Contact radius over the static one: a*^(1/n)."""
        return np.power(np.maximum(np.asarray(a, float), 0.0), 1.0 / self.n)

    def outline(self, rho: npt.ArrayLike) -> np.ndarray:
        """The tip's outline z / a0 at rho = r / (static contact radius):
        z = C r^n and a0 = kappa_n C a_c^n (MDR) give rho^n / kappa_n.

        Finite for every valid n at |rho| <= 1; beyond, +inf where z / a0
        passes the largest float (a steep law: power:400 at rho = 7)."""
        # kappa_n = sqrt(pi) Gamma(n/2 + 1) / Gamma(n/2 + 1/2) as one Pochhammer
        # symbol: the two Gammas overflow from n = 341 while their ratio is ~sqrt(n/2)
        from scipy.special import poch

        kappa = math.sqrt(math.pi) * float(poch(self.n / 2 + 0.5, 0.5))
        with np.errstate(over="ignore"):
            return np.power(np.abs(np.asarray(rho, float)), self.n) / kappa


@dataclass(frozen=True)
class FlatSphereProfile:
    """Sphere (radius R, parabolic) cut flat at radius c: f = 0 for r <= c, (r^2 - c^2)/(2R) beyond.

    MDR: g(x) = (x/R) sqrt(x^2 - c^2) for x > c; with s = sqrt(a^2 - c^2),
    d = a s / R and N = (2E*/R)(c^2 s + (2/3) s^3).  Lengths in units of
    sqrt(R a0): gamma = c / sqrt(R a0), sigma^2 = (sqrt(gamma^4 + 4 a*^2) - gamma^2)/2,
    N* = (gamma^2 sigma + 2 sigma^3 / 3) / (same at a* = 1).
    gamma = 0 is the sphere; gamma -> inf the flat punch (N* -> a*).
    """

    flat_radius: float

    def __post_init__(self):
        c = self.flat_radius
        if (
            isinstance(c, bool)
            or not isinstance(c, (int, float))
            or not math.isfinite(c)
            or not 0 <= c <= FLAT_MAX
        ):
            raise InputError(
                f"profile flat radius (units sqrt(R a0)) must be a real number in "
                f"[0, {FLAT_MAX:g}], got {c!r}"
            )

    @property
    def name(self) -> str:
        return f"flat-sphere:{self.flat_radius:g}"

    def _sigma(self, a):
        g2 = self.flat_radius**2
        a = np.maximum(np.asarray(a, float), 0.0)
        # sigma^2 = 2 a^2 / (sqrt(g^4 + 4 a^2) + g^2): no cancellation for large gamma
        return np.sqrt(2.0 * a * a / (np.sqrt(g2 * g2 + 4.0 * a * a) + g2)) if g2 > 0 else np.sqrt(a)

    def _raw(self, s):
        return self.flat_radius**2 * s + (2.0 / 3.0) * s**3

    def normal_force(self, a: npt.ArrayLike) -> np.ndarray:
        return self._raw(self._sigma(a)) / self._raw(self._sigma(1.0))

    def stiffness(self, a: npt.ArrayLike) -> np.ndarray:
        """dN*/da* = a_c / raw(1), a_c = sqrt(gamma^2 + sigma^2) (units sqrt(R a0)), since dN/dd = 2E* a_c."""
        s, s1 = self._sigma(a), self._sigma(1.0)
        return np.sqrt(self.flat_radius**2 + s * s) / self._raw(s1)

    def contact_radius(self, a: npt.ArrayLike) -> np.ndarray:
        s, s1 = self._sigma(a), self._sigma(1.0)
        return np.sqrt(self.flat_radius**2 + s * s) / math.sqrt(self.flat_radius**2 + s1 * s1)

    def outline(self, rho: npt.ArrayLike) -> np.ndarray:
        """The tip's outline z / a0 at rho = r / (static contact radius):
        z = (r^2 - c^2) / (2R) beyond the flat, r in units of sqrt(R a0)."""
        g2 = self.flat_radius**2
        s1 = float(self._sigma(1.0))
        r2 = np.asarray(rho, float) ** 2 * (g2 + s1 * s1)
        return np.maximum(r2 - g2, 0.0) / 2.0


def mdr_g(r: Any, z: Any, x: Any) -> np.ndarray:
    """MDR 1D profile g(x) of a piecewise-linear z(r) table, exactly (units of z).

    g(x) = x sum_k slope_k [asin(min(r_{k+1}, x)/x) - asin(r_k/x)] over segments below x.
    """
    r = np.asarray(r, float)
    slope = np.diff(z) / np.diff(r)
    x = np.asarray(x, float)
    out = np.zeros_like(x)
    for i, xi in enumerate(x.flat):
        if xi <= 0:
            continue
        lo = np.minimum(r[:-1], xi) / xi
        hi = np.minimum(r[1:], xi) / xi
        out.flat[i] = xi * np.sum(slope * (np.arcsin(hi) - np.arcsin(lo)))
    return out


class TabulatedProfile:
    """A measured profile z(r) (metres, r from 0) through MDR, for a load ratio N0 / E* (metres^2).

    Validation (each message names the parameter): r starts at 0 and increases,
    z(0) = 0, z nondecreasing and convex (slopes nondecreasing), and the table
    fine enough: at least MIN_TABLE_POINTS_IN_CONTACT rows inside the static
    contact radius, and the table reaching a_max_star times the static approach.
    """

    def __init__(
        self,
        r: Any,
        z: Any,
        load_over_modulus: float,
        a_max_star: float = 8.0,
        samples: int = 4001,
        name: str = "file",
    ) -> None:
        r = np.asarray(r, float)
        z = np.asarray(z, float)
        if r.ndim != 1 or r.shape != z.shape or r.size < 3:
            raise InputError("profile table must have two equal-length columns r, z with at least 3 rows")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(z))):
            raise InputError("profile table r, z must be finite numbers")
        if r[0] != 0.0 or np.any(np.diff(r) <= 0):
            raise InputError("profile table r must start at 0 and increase strictly")
        if z[0] != 0.0:
            raise InputError(f"profile table z(0) must be 0 (the apex), got {z[0]!r}")
        slope = np.diff(z) / np.diff(r)
        if np.any(slope < 0):
            raise InputError("profile table z must be nondecreasing in r (monotonic profile)")
        if np.any(np.diff(slope) < -1e-9 * max(1.0, float(np.max(np.abs(slope))))):
            raise InputError("profile table z must be convex in r (slopes nondecreasing)")
        if not (
            isinstance(load_over_modulus, (int, float))
            and math.isfinite(load_over_modulus)
            and load_over_modulus > 0
        ):
            raise InputError(
                f"profile load N0/E* must be a real number in (0, inf) m^2, got {load_over_modulus!r}"
            )
        self.name = name
        target = 0.5 * load_over_modulus
        x, g, n_over = self._laws(r, z, r[-1], samples)
        if n_over[-1] >= target and g[-1] > 0:
            # second pass on a grid spanning only the contacts of interest (a* <= a_max_star)
            i = int(np.searchsorted(n_over, target))
            d_static = float(np.interp(target, n_over[: i + 1], g[: i + 1]))
            j = min(int(np.searchsorted(g, 1.05 * a_max_star * d_static)) + 1, x.size - 1)
            x, g, n_over = self._laws(r, z, x[j], samples)
        if n_over[-1] < target:
            raise InputError(
                "profile table too short: the static load needs a contact radius beyond its last r"
            )
        i = int(np.searchsorted(n_over, target))
        a_static = np.interp(target, n_over[: i + 1], x[: i + 1])
        d0 = float(np.interp(a_static, x, g))
        if np.count_nonzero(r <= a_static) < MIN_TABLE_POINTS_IN_CONTACT:
            raise InputError(
                f"profile table too coarse: fewer than {MIN_TABLE_POINTS_IN_CONTACT} rows "
                f"inside the static contact radius {a_static:.3g} m"
            )
        if g[-1] < a_max_star * d0:
            raise InputError(f"profile table too short: it must reach an approach of {a_max_star:g} a0")
        k0 = int(np.flatnonzero(g <= 0.0)[-1])  # the flat part (g = 0) enters at a* = 0 at once
        x, g, n_over = x[k0:], g[k0:], n_over[k0:]
        self.a0 = d0
        self.static_contact_radius = a_static
        self._table = (r, z)
        self._x = x
        self._a = g / d0  # a* at contact radius x (increasing)
        self._N = n_over / target  # N*
        self._k = 2.0 * x * d0 / load_over_modulus  # dN*/da* = 2 E* a_c a0 / N0
        self.a_max = float(self._a[-1])

    def normal_force(self, a: npt.ArrayLike) -> np.ndarray:
        return np.interp(np.maximum(np.asarray(a, float), 0.0), self._a, self._N)

    @staticmethod
    def _laws(r, z, x_max, samples):
        x = np.linspace(0.0, x_max, samples)
        g = mdr_g(r, z, x)
        # N(a)/(2E*) = int_0^a (g(a) - g(x)) dx = a g(a) - G(a), G the running integral of g
        G = np.concatenate(([0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(x))))
        return x, g, x * g - G

    def stiffness(self, a: npt.ArrayLike) -> np.ndarray:
        """dN*/da* = 2 E* a_c a0 / N0."""
        return np.interp(np.maximum(np.asarray(a, float), 0.0), self._a, self._k)

    def contact_radius(self, a: npt.ArrayLike) -> np.ndarray:
        """Contact radius over the static one at a* (the table's MDR)."""
        x = np.interp(np.maximum(np.asarray(a, float), 0.0), self._a, self._x)
        return x / self.static_contact_radius

    def outline(self, rho: npt.ArrayLike) -> np.ndarray:
        """The measured outline z / a0 at rho = r / (static contact radius)
        (NaN beyond the table)."""
        r, z = self._table
        return (
            np.interp(np.abs(np.asarray(rho, float)) * self.static_contact_radius, r, z, right=np.nan)
            / self.a0
        )


def read_table(path: str) -> np.ndarray:
    """A profile file's two columns r, z (m) as an (n, 2) array; InputError if unreadable."""
    try:
        table = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise InputError(
            f"profile file {path!r} must be a readable two-column text table r z (m): {exc}"
        ) from None
    if table.shape[1] != 2:
        raise InputError(f"profile file {path!r} must have two columns r z (m), got {table.shape[1]}")
    return table


def parse_profile(
    text: str,
    load_over_modulus: float | None = None,
) -> TabulatedProfile | PowerLawProfile | FlatSphereProfile:
    """'sphere' | 'cone' | 'power:N' | 'flat-sphere:C' | 'file:PATH' -> profile object.

    file:PATH is a two-column text table r, z in metres and needs the load N0/E* (m^2).
    """
    if isinstance(text, str) and text.startswith("file:"):
        path = text[5:]
        if load_over_modulus is None:
            raise InputError("profile file:PATH needs the load N0/E* (load_over_modulus, m^2, in (0, inf))")
        table = read_table(path)
        return TabulatedProfile(table[:, 0], table[:, 1], load_over_modulus, name=text)
    if not isinstance(text, str):
        raise InputError(f"profile must be one of {', '.join(PROFILE_KINDS)}; got {text!r}")
    if text == "sphere":
        return PowerLawProfile(2.0)
    if text == "cone":
        return PowerLawProfile(1.0)
    kind, _, arg = text.partition(":")
    if kind in ("power", "flat-sphere") and arg:
        try:
            value = float(arg)
        except ValueError:
            raise InputError(f"profile {kind} parameter must be a number, got {arg!r}") from None
        return PowerLawProfile(value) if kind == "power" else FlatSphereProfile(value)
    raise InputError(f"profile must be one of {', '.join(PROFILE_KINDS)}; got {text!r}")


def linear_resonance_mass(profile: Any) -> float:
    """m*_res = N*'(1) / (4 pi^2): the m* where the linearized contact
    oscillation about the static approach, sqrt(N*'(1) / m*) radians per
    wave period, meets the wave's 2 pi (docs/DYNAMICS.md section 5; the
    sphere: 1.5 / (4 pi^2) = 0.038).  `profile`: a profile object or its
    spec ('cone', 'power:3', 'flat-sphere:0.5'; a table needs its object)."""
    if isinstance(profile, str):
        profile = parse_profile(profile)
    return float(profile.stiffness(1.0)) / (4.0 * math.pi**2)


def tangential_force(profile: Any, a: Any, b: Any, w_of_h: Any, h_grid: Any) -> float:
    """Reference (slow, numpy) T* = b N*'(a) - int_[0,a] w dN*'(h), for tests and twins."""
    h = h_grid[h_grid <= a]
    k = profile.stiffness(h)
    w = w_of_h(h)
    atom = k[0] * w[0]  # springs entering at h = 0 (flat part): weight N*'(0)
    return b * float(profile.stiffness(a)) - atom - float(np.sum(0.5 * (w[1:] + w[:-1]) * np.diff(k)))
