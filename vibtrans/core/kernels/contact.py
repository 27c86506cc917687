"""Contact laws: Hertz normal force and the Cattaneo-Mindlin memory diagram.

Normalized units (docs/MODEL.md sections 1-2): a* in units of a0, N* = N / N(a0),
b* = b / (theta mu a0), T* = T / (mu N(a0)).

The memory diagram is stored exactly as a polyline w(h) over the contact depth
0 <= h <= a* (h = rho^2 for a sphere), where w = b* - u is the anchor of the
spring that entered contact at depth h.  Stuck springs never change w, so a
committed step touches only the vertices it pushes or pops: O(1) amortized.

Storage (plain arrays, so a kernel can stop and resume anywhere):
    H        float64[capacity, 2]  vertex depth h and sqrt(h) (a radius);
                                   with a profile [capacity, 3]: h, N*'(h), N*(h)
    W, P     float64[capacity]     anchor (minus w_ref), and the running
                                   integral of w h^(-1/2) dh from h = 0
    nvert    int64[2]              vertex count (0: no contact), and how many
                                   leading vertices have an up-to-date P
    memf     float64[3]            (a*, b*) of the last committed step, w_ref
W is stored relative to w_ref (re-based whenever the contact slides or starts)
so that T* = (3/2) b sqrt(a) - (3/4) P never subtracts two large numbers.
"""

import functools
import math
from typing import NamedTuple

import numpy as np

from vibtrans.core.kernels.jit import inline, kernel, specialize, template
from vibtrans.core.profiles import PowerLawProfile

# Contact states (timeline codes; shared by every model).
FLIGHT = 0  # contact loss, a* <= 0
STICK = 1  # full stick, s = c
PARTIAL_SLIP = 2  # 0 < s < c
SLIDING = 3  # total sliding, s = 0, T* = sign(b*') N*
STATE_NAMES = ("flight", "stick", "partial slip", "total sliding")


@inline
def _segment_integral(s0, w0, s1, w1):
    """Exact integral of w h^(-1/2) dh over a segment, w linear in h = s^2.

    In s the integrand 2 w(s^2) is quadratic, so Simpson's rule in s is
    exact, and this form has no cancellation for short segments.
    """
    if s1 <= s0:
        return 0.0
    return (s1 - s0) / 3.0 * (5.0 * w0 + w1 + (w1 - w0) * (s1 + 3.0 * s0) / (s1 + s0))


# ---------------------------------------------------------------- profile laws
# A profile's normal law (docs/MODEL.md section 10) reaches the kernels as a
# float64 array `law` (`kernel_law` below):
#   law[LAW_KIND]   LAW_POWER: N* = a*^p, N*' = p a*^(p-1) (p = law[LAW_ARG])
#                   LAW_TABLE: N*' linear in s = sqrt(a*) on the grid s_i = i ds
#                              (ds = law[LAW_ARG]; exact for the sphere's sqrt, and
#                              fine near a flat's a* = 0), N* its exact integral
#                              (a cubic in s per cell); extrapolated linearly in s
#   law[LAW_K1]     N*'(1): the static contact radius in these units
#   law[LAW_SIZE]   grid points n (LAW_TABLE)
#   law[LAW_INV]    1 / ds (LAW_TABLE: ds a power of 2, so s / ds = s * (1 / ds)
#                   exactly: a multiply, not a divide, finds the cell), then
#                   per cell i (n - 1 of them) LAW_CELL numbers: N*_i, the
#                   cubic's coefficients A, B, C of N* = N*_i + t (A + t (B + t C)),
#                   N*'_i and the slope m of N*' = N*'_i + m t (t = s - s_i):
#                   one cell's numbers side by side (one or two cache lines), and
#                   no division in the evaluation (the cubic's 1/3 precomputed)
# With a profile the memory's vertex array has three columns (new_memory(law=))
# and holds (h, N*'(h), N*(h)) instead of (h, sqrt h): the law is evaluated
# once per new vertex, never in the integrals; P is the running integral of
# w dN*' (the h = 0 atom N*'(0) w(0) included), and T* = b* N*'(a*) - P.  The sphere keeps its own path
# (`law_kind` SPHERE, a compile-time constant): N*' = 1.5 sqrt(h).
# A power law with an integer n = 1/(p - 1) >= 2 (`power:3`, ...) also keeps
# law[LAW_ROOT] = n and, at POW_C1..POW_C4, the binomial coefficients of
# (1 + e)^(1/n): the kernels' warm-started a*^(1/n) (`law_eval_warm`).
LAW_POWER = 0
LAW_TABLE = 1
LAW_KIND, LAW_ARG, LAW_K1, LAW_SIZE, LAW_INV = range(5)
LAW_HEAD = 5
LAW_ROOT = LAW_SIZE  # a power law's integer n (0: none, pow() every time)
POW_C1, POW_C2, POW_C3, POW_C4 = range(LAW_HEAD, LAW_HEAD + 4)
WARM_EPS = 2.0**-12  # the warm start's largest |e| = |a / y0^n - 1| (series error < 3e-20)
WARM_EPS_SHORT = 2.0**-18  # the short (e^2) series' largest |e| (its rest < 2^-57 of y)
WARM_ROOT_MAX = 64  # integer n up to this take the warm start (y0^n: n - 1 multiplies)
NO_WARM = (0.0, 0.0, 0.0, 0.0)  # an empty warm-start history (law_eval_warm)
LAW_CELL = 6  # a table cell's numbers: N*_i, A, B, C, N*'_i, m
CELL_N, CELL_A, CELL_B, CELL_C, CELL_K, CELL_M = range(LAW_CELL)
LAW_GRID_MAX = 64.0  # tables span 0 <= a* <= 64 (beyond: N*' extrapolated linearly in sqrt a*)
LAW_GRID_POINTS = 8193  # uniform in s = sqrt(a*), ds = 1/1024 (a power of 2: LAW_INV)

# The contact law a kernel is compiled for, its `law_kind` (a compile-time
# constant: a kind's kernels leave the other kinds' code out)
SPHERE = 0  # Hertz's own N* = a*^(3/2), N*' = 1.5 sqrt(a*): no law array read
PROFILE = 1  # a profile's law array (a table or a power law), its kind read at each use
WARM_POWER = 2  # a power law with an integer n alone: the warm-started root, no kind tests
LAW_KINDS = ("sphere", "profile", "warm-power")


def kernel_law(profile):
    """The kernels' form of a profile (contact.law_eval): None for the sphere
    (Hertz's own path, bit for bit as before profiles), a power law's
    [LAW_POWER, p, p, 0, 0], else a table [LAW_TABLE, ds, N*'(1), n, 1/ds,
    LAW_CELL numbers per cell] of N*' on the grid s_i = i ds uniform in s = sqrt(a*) (0 <= a* <=
    LAW_GRID_MAX), N*' linear in s on each cell and N* its exact integral,
    both scaled so that N*(1) = 1 exactly (the rest state's force balance).
    """
    if isinstance(profile, PowerLawProfile):
        if profile.n == 2.0:
            return None
        return power_kernel_law(profile.n)
    s = np.linspace(0.0, math.sqrt(LAW_GRID_MAX), LAW_GRID_POINTS)
    ds = float(s[1])
    k = np.asarray(profile.stiffness(s * s), float)
    m = np.diff(k) / ds
    si = s[:-1]
    # int over a cell of (k_i + m (x - s_i)) 2 x dx
    cell = 2.0 * ds * (k[:-1] * si + ds * (0.5 * (k[:-1] + m * si) + m * ds / 3.0))
    N = np.concatenate(([0.0], np.cumsum(cell)))
    i1 = int(round(1.0 / ds))
    scale = 1.0 / N[i1]  # a* = 1 is a grid point
    k, N = k * scale, N * scale
    assert ds == 2.0 ** round(math.log2(ds))  # (LAW_INV exact)
    # per cell: N* = N*_i + int_si^s (k_i + m (x - si)) 2 x dx as a cubic in t = s - si
    m = np.diff(k) / ds
    k0 = k[:-1]
    cells = np.empty((s.size - 1, LAW_CELL))
    cells[:, CELL_N] = N[:-1]
    cells[:, CELL_A] = 2.0 * k0 * si
    cells[:, CELL_B] = k0 + m * si
    cells[:, CELL_C] = (2.0 / 3.0) * m
    cells[:, CELL_K] = k0
    cells[:, CELL_M] = m
    return np.concatenate(([LAW_TABLE, ds, k[i1], float(s.size), 1.0 / ds], cells.ravel()))


def power_kernel_law(n):
    """The kernels' form of the power law z = C r^n (N* = a*^p, p = (n+1)/n):
    [LAW_POWER, p, p, root, 0, c1, c2, c3, c4] with root = n for an integer
    2 <= n <= WARM_ROOT_MAX (0 otherwise) and c_k the binomial coefficients
    of (1 + e)^(1/n) (`law_eval_warm`)."""
    n = float(n)
    p = (n + 1.0) / n
    q = 1.0 / n
    integral = n == math.floor(n) and 2.0 <= n <= WARM_ROOT_MAX
    c = [q]
    for k in range(2, 5):
        c.append(c[-1] * (q - k + 1.0) / k)
    return np.array([LAW_POWER, p, p, n if integral else 0.0, 0.0] + c)


def law_scales(law):
    """(N*'(1), p) of a kernel law for the time step's contact scales
    (fidelity.contact_time_scale): p the power law's exponent, 2 for a table
    (a convex profile's N* grows at most as a*^2, the cone's)."""
    return float(law[LAW_K1]), float(law[LAW_ARG]) if law[LAW_KIND] == LAW_POWER else 2.0


def kind_of_law(law):
    """The kernels' `law_kind` of a kernel law (None: the sphere): WARM_POWER
    for a power law with the warm-started root (law[LAW_ROOT] != 0), its own
    kernels; PROFILE for any other law."""
    if law is None:
        return SPHERE
    if law[LAW_KIND] != LAW_TABLE and law[LAW_ROOT] != 0.0:
        return WARM_POWER
    return PROFILE


@inline
def law_eval(law, a):
    """(N*, N*') of the profile law at a* (a* <= 0: (0, N*'(0)))."""
    if law[LAW_KIND] == LAW_POWER:
        p = law[LAW_ARG]
        if a <= 0.0:
            return 0.0, 0.0
        q = p - 1.0
        # the cone (q = 1): a^1 = a exactly, no pow() to call;
        # N* = a* y, N*' = p y with y = a*^(p - 1)
        y = a if q == 1.0 else a**q
        return a * y, p * y
    n = int(law[LAW_SIZE])
    if a <= 0.0:
        return 0.0, law[LAW_HEAD + CELL_K]
    s = math.sqrt(a)
    i = int(s * law[LAW_INV])  # 1 / ds exactly (a power of 2)
    if i > n - 2:
        i = n - 2  # beyond the grid: the last cell's curves
    t = s - i * law[LAW_ARG]
    j = LAW_HEAD + LAW_CELL * i
    # the cubic in Estrin's order (t^2 beside the linear parts: two multiply-add
    # levels fewer on the step's critical path than Horner's)
    return (
        (law[j + CELL_N] + t * law[j + CELL_A]) + (t * t) * (law[j + CELL_B] + t * law[j + CELL_C]),
        law[j + CELL_K] + law[j + CELL_M] * t,
    )


@inline
def law_eval_warm(law, a, warm, k_alt, law_kind):
    """`law_eval` with a warm start: (N*, N*', the new history).

    For a power law with an integer n = law[LAW_ROOT] (N* = a* y, N*' = p y,
    y = a*^(1/n)), `warm` holds the last four roots y (newest first) of the
    same call site on consecutive steps (`power_warm`; k_alt: its second
    start's N*', 0.0 for none); otherwise (a non-integer n, a table)
    `law_eval`.  `law_kind` = WARM_POWER (a compile-time constant: the
    kernels of such laws alone, deformable.py) skips the law's kind tests.
    docs/MODEL.md section 10."""
    if law_kind != WARM_POWER and (law[LAW_KIND] != LAW_POWER or law[LAW_ROOT] == 0.0):
        nn, k = law_eval(law, a)
        return nn, k, warm
    if a <= 0.0:
        return 0.0, 0.0, NO_WARM
    nn, k, y, _ = power_warm(law, a, warm, k_alt)
    return nn, k, (y, warm[0], warm[1], warm[2])


@inline
def _power_yn(law, y0):
    """y0^n, n = law[LAW_ROOT] (n - 1 multiplies in order; n = 2 and 3, the
    common tips, without the loop's count and exit: the same bits)."""
    nr = law[LAW_ROOT]
    if nr == 3.0:
        return y0 * y0 * y0
    if nr == 2.0:
        return y0 * y0
    yn = y0
    for _ in range(int(nr) - 1):
        yn *= y0
    return yn


@inline
def _power_rescue(law, a, y0):
    """The root y = a*^(1/n) from the start y0 by the e^4 series if
    |e| <= WARM_EPS (`power_warm`), else 0.0 (no start)."""
    if y0 > 0.0:
        yn = _power_yn(law, y0)
        if yn > 0.0:
            e = (a - yn) * (1.0 / yn)
            if abs(e) <= WARM_EPS:
                return y0 + (y0 * e) * (law[POW_C1] + e * (law[POW_C2] + e * (law[POW_C3] + e * law[POW_C4])))
    return 0.0


@inline
def power_warm(law, a, warm, k_alt):
    """(N*, N*', y = a*^(1/n), the warm start's order: 2, 4, 1 (a second
    start) or 0 for pow) of a power law with law[LAW_ROOT] = n and a* > 0,
    warm-started.

    The cubic extrapolation y0 of the history `warm` (no dependence on a*:
    off the step's critical path) is corrected by the series
    y = y0 (1 + e)^(1/n) = y0 (1 + c1 e + c2 e^2 + ...), e = (a* - yn) (1/yn),
    yn = y0^n (a* - yn exact: they agree to 2^-12; 1/yn does not depend on
    a*), in Horner's order: for |e| <= WARM_EPS_SHORT = 2^-18 (most steps:
    four operations after e) to its e^2 term (the rest < 2^-57 of y: |c3| <=
    1/16 for n >= 2), for |e| <= WARM_EPS = 2^-12 to its e^4 term (the rest
    < 3e-20 of y).  Where the cubic start is farther (an impact, a stick
    edge that kinks or jumps) two second starts take the e^4 series under
    the same bound (order 1): the linear extrapolation 2 y1 - y2 of the
    history, then the root of `k_alt` (an N*' = p y known to the caller,
    the step's own a*'s at the stick edge; 0.0: none); otherwise (no
    history yet) pow.  All orders are the root to rounding (N* = a* y, N*' =
    p y within 4 x 2^-52 of pow's).  docs/MODEL.md section 10."""
    p = law[LAW_ARG]
    y0 = 4.0 * warm[0] - 6.0 * warm[1] + 4.0 * warm[2] - warm[3]
    yn = _power_yn(law, y0)
    if y0 > 0.0 and yn > 0.0:
        r = 1.0 / yn
        d = a - yn
        e = d * r
        ae = abs(e)
        if ae <= WARM_EPS_SHORT:
            y = y0 + (y0 * e) * (law[POW_C1] + e * law[POW_C2])
            return a * y, p * y, y, 2
        if ae <= WARM_EPS:
            y = y0 + (y0 * e) * (law[POW_C1] + e * (law[POW_C2] + e * (law[POW_C3] + e * law[POW_C4])))
            return a * y, p * y, y, 4
    if warm[1] > 0.0:
        y = _power_rescue(law, a, 2.0 * warm[0] - warm[1])
        if y > 0.0:
            return a * y, p * y, y, 1
    if k_alt > 0.0:
        y = _power_rescue(law, a, k_alt / p)
        if y > 0.0:
            return a * y, p * y, y, 1
    y = a ** (p - 1.0)
    return a * y, p * y, y, 0


@kernel
def law_history(law, a, out):
    """The kernels' evaluation (`law_eval_warm`, one call site, its history
    carried from each a*[i] to the next) along a sequence: out[i] = (N*, N*',
    the warm start's order: 2.0 or 4.0 where taken, 1.0 for a second start,
    0.0 for pow: `power_warm`).  For tests and benchmarks."""
    warm = NO_WARM
    for i in range(a.shape[0]):
        order = 0
        if law[LAW_KIND] == LAW_POWER and law[LAW_ROOT] != 0.0 and a[i] > 0.0:
            order = power_warm(law, a[i], warm, 0.0)[3]
        nn, k, warm = law_eval_warm(law, a[i], warm, 0.0, PROFILE)
        out[i, 0] = nn
        out[i, 1] = k
        out[i, 2] = order


@inline
def _segment_integral_law(h0, k0, n0, w0, h1, k1, n1, w1):
    """Exact integral of w dN*'(h) over a segment, w linear in h, from the
    ends' (h, N*'(h) = k, N*(h) = n, w): w0 (k1 - k0) + (w1 - w0) (k1 - (n1 - n0) / (h1 - h0))."""
    if h1 <= h0:
        return 0.0
    return w0 * (k1 - k0) + (w1 - w0) * (k1 - (n1 - n0) / (h1 - h0))


@inline
def _push(H, W, nvert, h, sqrt_h, w):
    n = nvert[0]
    H[n, 0] = h
    H[n, 1] = sqrt_h
    W[n] = w
    nvert[0] = n + 1


@inline
def _put(H, W, i, h, sqrt_h, w):
    H[i, 0] = h
    H[i, 1] = sqrt_h
    W[i] = w


@inline
def _put_law(H, W, i, h, k, nn, w):
    """A profile vertex: (h, N*'(h), N*(h)) and its anchor w."""
    H[i, 0] = h
    H[i, 1] = k
    H[i, 2] = nn
    W[i] = w


@inline
def _pop_to(nvert, n):
    nvert[0] = n
    if nvert[1] > n:
        nvert[1] = n


@template(inline)
def _integrals_to(H, W, P, i, n, law):
    """Bring the running integrals P of vertices i..n-1 up to date (the
    leading i are); return P[n - 1].  Only pushed vertices are stale, so a
    vertex pushed and popped within one step costs nothing."""
    if i <= 0:
        if law_kind != SPHERE:
            P[0] = W[0] * H[0, 1]  # the springs entering at h = 0 (a flat)
        else:
            P[0] = 0.0
        i = 1
    while i < n:
        if law_kind != SPHERE:
            P[i] = P[i - 1] + _segment_integral_law(
                H[i - 1, 0], H[i - 1, 1], H[i - 1, 2], W[i - 1], H[i, 0], H[i, 1], H[i, 2], W[i]
            )
        else:
            P[i] = P[i - 1] + _segment_integral(H[i - 1, 1], W[i - 1], H[i, 1], W[i])
        i += 1
    return P[n - 1]


@template(inline)
def _integrals(H, W, P, nvert, law):
    """`_integrals_to` on the whole stack, recorded in nvert[1]."""
    n = nvert[0]
    p = _integrals_to(H, W, P, nvert[1], n, law)
    nvert[1] = n
    return p


def new_memory(capacity=256, law=None):
    """Memory of a particle set down without tangential load at a* = 1, b* = 0.

    Every spring in 0 <= h <= 1 is stuck with u = 0 (docs/MODEL.md section 2).
    Returns (H, W, P, nvert, memf): H[:, 0] = h, H[:, 1] = sqrt(h) of the
    vertices; nvert = (vertex count, count with up-to-date P).
    With a profile `law` (kernel_law) H has a third column and the vertices
    hold (h, N*'(h), N*(h)) (`reset_memory_law`).
    """
    H = np.zeros((capacity, 2 if law is None else 3))
    W = np.zeros(capacity)
    P = np.zeros(capacity)
    nvert = np.zeros(2, dtype=np.int64)
    memf = np.array([1.0, 0.0, 0.0])
    if law is None:
        reset_memory(H, W, P, nvert, memf, 1.0, 0.0)
    else:
        reset_memory_law(H, W, P, nvert, memf, 1.0, 0.0, law)
    return H, W, P, nvert, memf


@kernel
def reset_memory(H, W, P, nvert, memf, a, b):
    """Virgin contact at (a*, b*): all springs stuck with u = 0."""
    nvert[0] = 0
    nvert[1] = 0
    memf[0] = a
    memf[1] = b
    memf[2] = b
    if a > 0.0:
        _push(H, W, nvert, 0.0, 0.0, 0.0)
        _push(H, W, nvert, a, math.sqrt(a), 0.0)
        _sphere_integrals(H, W, P, nvert, memf)


@kernel
def reset_memory_law(H, W, P, nvert, memf, a, b, law):
    """`reset_memory` for a profile law (vertices hold (h, N*'(h), N*(h)):
    H has three columns, `new_memory(law=)`)."""
    nvert[0] = 0
    nvert[1] = 0
    memf[0] = a
    memf[1] = b
    memf[2] = b
    if a > 0.0:
        _put_law(H, W, 0, 0.0, law_eval(law, 0.0)[1], 0.0, 0.0)
        na, ka = law_eval(law, a)
        _put_law(H, W, 1, a, ka, na, 0.0)
        nvert[0] = 2
        _profile_integrals(H, W, P, nvert, law)


# Where the clamp finds the top vertex (h = a1): a compile-time constant.
_TOP_STORED = 0  # on the stack
_TOP_LOAD = 1  # not stored: (a1, bp), the load point (loading)
_TOP_CUT = 2  # not stored: (a1, wt), the cut top segment (unloading)


@template(inline)
def memory_commit(H, W, P, nvert, memf, a1, c1, b1, law, n1, warm):
    """Commit one step of (a*, b*) to (a1, b1); return (T*, s_h, state, warm).

    (a*, b*) moves along a straight line during the step.  c1 = sqrt(a1) (the
    contact radius; the caller has it from N*).  s_h is the depth of the stick
    core edge (stick radius s = sqrt(s_h)).  The caller guarantees capacity
    for 3 more vertices.
    With a `law_kind` other than SPHERE (the copy's: memory_steps) the
    profile `law` replaces the sphere's: c1 = N*'(a1), n1 = N*(a1) (the
    caller has both from the law),
    and `warm` is the stick edge's warm-start history (law_eval_warm; the
    caller keeps it from step to step; NO_WARM for the sphere), returned
    updated.
    """
    a0 = memf[0]
    b0 = memf[1]
    memf[0] = a1
    memf[1] = b1
    if a1 <= 0.0:
        _pop_to(nvert, 0)  # every spring left contact and forgets
        return 0.0, 0.0, FLIGHT, warm
    n = nvert[0]
    # (`<= 0` for counts, here and below, tells the compiler that n - 1 is a
    # valid index afterwards: it drops the negative-index wraparound checks.)
    # One call site of the clamp: each inlined copy of it costs compile time.
    top = _TOP_STORED
    wt = 0.0
    if n <= 0:
        # Contact (re)starts within the step: springs attach at the b* where
        # the step's line crosses a* = 0.
        bc = b0
        if a0 < 0.0:
            bc = b0 + (b1 - b0) * (-a0) / (a1 - a0)
        memf[2] = bc
        if law_kind != SPHERE:
            _put_law(H, W, 0, 0.0, law_eval(law, 0.0)[1], 0.0, 0.0)
            _put_law(H, W, 1, a1, c1, n1, b1 - bc)
            nvert[0] = 2
        else:
            _push(H, W, nvert, 0.0, 0.0, 0.0)
            _push(H, W, nvert, a1, c1, b1 - bc)
        n = 2
    elif a1 > a0:
        # New springs lie on the segment from the old apex to (a1, b1): the
        # clamp pushes that vertex itself if it survives (it usually slips).
        top = _TOP_LOAD
    elif a1 < a0:
        # Springs deeper than a1 leave contact: pop them, cut the top segment
        # at a1 (the clamp pushes that vertex only if it survives).
        hp = H[n - 1, 0]
        wp = W[n - 1]
        while n > 1 and H[n - 1, 0] > a1:  # the vertex h = 0 stays
            hp = H[n - 1, 0]
            wp = W[n - 1]
            n -= 1
        hq = H[n - 1, 0]
        if hq < a1:
            wq = W[n - 1]
            top = _TOP_CUT
            wt = wq + (wp - wq) * (a1 - hq) / (hp - hq)
    return _clamp(H, W, P, nvert, memf, a1, c1, b1 - memf[2], n, top, wt, law, n1, warm)


@template(inline)
def _clamp(H, W, P, nvert, memf, a1, c1, bp, n, top, wt, law, n1, warm):
    """Coulomb clamp of the polyline into the cone |bp - w| <= a1 - h.

    The top vertex sits at h = a1 (c1 = sqrt(a1)); bp = b1 - w_ref; n >= 1 is
    the vertex count (nvert[0] may still count vertices popped above n).  With
    `top` = _TOP_LOAD (loading) that vertex, (a1, bp), is not stored yet, with
    _TOP_CUT (unloading) it is (a1, wt), the cut top segment's end: it is
    pushed only if it survives the clamp (it usually slips: saves a push and a
    pop per slip step).
    Returns (T*, s_h, state, warm).
    """
    # Rounding (re-basing, cone-line vertices) must not invent slip: a spring
    # counts as past its limit only beyond a few ulps of the cone's scale.
    tol = 4e-16 * (a1 + abs(bp) + abs(W[0]))
    side = 0.0
    if top == _TOP_LOAD:
        # the top is at bp by construction; test the vertex below it
        d2 = W[n - 1] - bp
        if abs(d2) > a1 - H[n - 1, 0] + tol:
            side = 1.0 if d2 > 0.0 else -1.0
    else:
        nb = n  # vertices below the top
        if top == _TOP_CUT:
            d = wt - bp
        else:
            d = W[n - 1] - bp
            nb = n - 1
        if d > tol:
            side = 1.0
        elif d < -tol:
            side = -1.0
        elif nb >= 1:
            d2 = W[nb - 1] - bp
            if abs(d2) > a1 - H[nb - 1, 0] + tol:
                side = 1.0 if d2 > 0.0 else -1.0
    # The stack's count and P's up-to-date count stay in registers until the
    # step ends (stores to nvert would be re-read at once).
    ip = min(nvert[1], n)
    if side == 0.0:
        # No spring reached its limit: full stick.
        if top != _TOP_STORED:
            if law_kind != SPHERE:
                _put_law(H, W, n, a1, c1, n1, bp)
            else:
                _put(H, W, n, a1, c1, bp)
            n += 1
        elif W[n - 1] != bp:
            W[n - 1] = bp
            ip = min(ip, n - 1)
        nvert[0] = n
        nvert[1] = n
        if law_kind != SPHERE:
            return bp * c1 - _integrals_to(H, W, P, ip, n, law), a1, STICK, warm
        return (1.5 * bp * c1 - 0.75 * _integrals_to(H, W, P, ip, n, law), a1, STICK, warm)
    # Walk down, dropping the vertices outside the cone (slip annulus).
    if top == _TOP_LOAD:
        hl = a1
        wl = bp
    elif top == _TOP_CUT:
        hl = a1
        wl = wt
    else:
        hl = H[n - 1, 0]
        wl = W[n - 1]
        n -= 1
    fk = 0.0
    while n > 0:
        fk = side * (W[n - 1] - bp) - (a1 - H[n - 1, 0])
        if fk <= tol:
            break
        hl = H[n - 1, 0]
        wl = W[n - 1]
        n -= 1
    if n <= 0:
        # The slip annulus reached the centre: total sliding, T* = +-N*.
        # Re-base the anchors on b1 (cheap here: the stack is two vertices).
        memf[2] += bp
        if law_kind != SPHERE:
            _put_law(H, W, 0, 0.0, H[0, 1], 0.0, side * a1)
            _put_law(H, W, 1, a1, c1, n1, 0.0)
            nvert[0] = 2
            nvert[1] = 0
            return -side * n1, 0.0, SLIDING, warm
        _put(H, W, 0, 0.0, 0.0, side * a1)
        _put(H, W, 1, a1, c1, 0.0)
        nvert[0] = 2
        nvert[1] = 0
        return -side * a1 * c1, 0.0, SLIDING, warm
    # The stick edge hs: where the cone line w = bp + side (a1 - h) meets the
    # stack segment k -> l (fk: vertex k's cone test, from the walk).  The
    # segment's slope and the denominator do not depend on this step's load
    # (unless l is the cut top), so both divisions stay off the step's
    # critical path; the integrals over k -> hs (straight in h) and over the
    # slip annulus hs -> a1 (on the cone line) are closed forms in sqrt(h).
    hk = H[n - 1, 0]
    sk = H[n - 1, 1]
    wk = W[n - 1]
    lam = max(-fk, 0.0) * (1.0 / (side * (wl - wk) + (hl - hk)))
    hs = hk + lam * (hl - hk)
    ps = _integrals_to(H, W, P, min(ip, n), n, law)  # P at vertex k
    if law_kind != SPHERE:
        # the stick edge's N*, N*'; the annulus on the cone line, by parts:
        # int w dN*' = bp (k1 - ks) - side (a1 - hs) ks + side (N1 - Ns)
        ks = sk
        ns = H[n - 1, 2]
        if hs > hk:
            nk = ns
            ns, ks, warm = law_eval_warm(law, hs, warm, c1, law_kind)
            ws = bp + side * (a1 - hs)
            # w dN*' over k -> hs, w on the stack segment (slope off the critical path)
            slope = (wl - wk) / (hl - hk)
            ps += wk * (ks - sk) + slope * ((hs - hk) * ks - (ns - nk))
            _put_law(H, W, n, hs, ks, ns, ws)
            P[n] = ps
            n += 1
        else:
            hs = hk
        pa = ps + bp * (c1 - ks) - side * (a1 - hs) * ks + side * (n1 - ns)
        _put_law(H, W, n, a1, c1, n1, bp)
        P[n] = pa
        nvert[0] = n + 1
        nvert[1] = n + 1
        return bp * c1 - pa, hs, PARTIAL_SLIP, warm
    s = sk
    if hs > hk:
        s = math.sqrt(hs)
        ds = s - sk
        slope = (wl - wk) / (hl - hk)
        ps += ds * (2.0 * wk + (2.0 / 3.0) * slope * ds * (s + 2.0 * sk))
        _put(H, W, n, hs, s, bp + side * (a1 - hs))
        P[n] = ps
        n += 1
    else:
        hs = hk
    # annulus: integral of (bp + side (a1 - h)) h^(-1/2) dh from hs to a1
    pa = ps + (c1 - s) * (2.0 * (bp + side * a1) - (2.0 / 3.0) * side * (a1 + c1 * s + hs))
    _put(H, W, n, a1, c1, bp)
    P[n] = pa
    nvert[0] = n + 1
    nvert[1] = n + 1
    return 1.5 * bp * c1 - 0.75 * pa, hs, PARTIAL_SLIP, warm


@kernel
def memory_step(H, W, P, nvert, memf, a1, b1):
    """Non-inlined entry point of `memory_commit` (tests, benchmarks)."""
    return _sphere_commit(H, W, P, nvert, memf, a1, math.sqrt(max(a1, 0.0)), b1, memf, 0.0, NO_WARM)[:3]


@kernel
def memory_step_law(H, W, P, nvert, memf, a1, b1, law):
    """`memory_step` for a profile law (memory from `reset_memory_law`)."""
    n1, k1 = law_eval(law, a1)
    return _profile_commit(H, W, P, nvert, memf, a1, k1, b1, law, n1, NO_WARM)[:3]


@kernel
def memory_history(H, W, P, nvert, memf, a, b, out):
    """Commit a whole (a*, b*) history; out[i] = (T*, s_h, state).

    The caller provides capacity >= len(a) + 4 vertices.
    """
    for i in range(a.shape[0]):
        a1 = a[i]
        T, sh, st, _ = _sphere_commit(
            H, W, P, nvert, memf, a1, math.sqrt(max(a1, 0.0)), b[i], memf, 0.0, NO_WARM
        )
        out[i, 0] = T
        out[i, 1] = sh
        out[i, 2] = st


@kernel
def memory_history_law(H, W, P, nvert, memf, a, b, law, out):
    """`memory_history` for a profile law (memory from `reset_memory_law`),
    the kernels' way: warm-started (law_eval_warm) at a* and at the stick edge."""
    wa = NO_WARM
    ws = NO_WARM
    for i in range(a.shape[0]):
        n1, k1, wa = law_eval_warm(law, a[i], wa, 0.0, PROFILE)
        T, sh, st, ws = _profile_commit(H, W, P, nvert, memf, a[i], k1, b[i], law, n1, ws)
        out[i, 0] = T
        out[i, 1] = sh
        out[i, 2] = st


def tangential_force_history(a, b, a_start=1.0, b_start=0.0, law=None):
    """T*, s_h and state along an (a*, b*) history from a virgin contact.

    Convenience wrapper for tests and teaching views: returns three arrays.
    `law`: a profile's kernel law (kernel_law; None:
    the sphere's own path).
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    H, W, P, nvert, memf = new_memory(a.shape[0] + 8, law)
    out = np.empty((a.shape[0], 3))
    if law is None:
        reset_memory(H, W, P, nvert, memf, a_start, b_start)
        memory_history(H, W, P, nvert, memf, a, b, out)
    else:
        reset_memory_law(H, W, P, nvert, memf, a_start, b_start, law)
        memory_history_law(H, W, P, nvert, memf, a, b, law, out)
    return out[:, 0], out[:, 1], out[:, 2].astype(np.int8)


def anchor_profile(H, W, nvert, memf):
    """The memory diagram now: (h, w) vertices, w in absolute b* units."""
    n = int(nvert[0])
    return H[:n, 0].copy(), W[:n] + memf[2]


class MemorySteps(NamedTuple):
    """The memory diagram's compiled steps for one contact law kind."""

    commit: object  # memory_commit's copy: (H, W, P, nvert, memf, a1, c1, b1, law, n1, warm)
    integrals: object  # _integrals's copy: (H, W, P, nvert, law)


@functools.cache
def memory_steps(law_kind):
    """The memory diagram's steps (`memory_commit` and what it calls,
    inlined) for one contact law kind, `law_kind` a global constant of the
    copies (jit.specialize): the sphere's leave the profiles' code out."""
    copies = specialize(
        (_integrals_to, _integrals, _clamp, memory_commit),
        LAW_KINDS[law_kind].replace("-", "_"),
        law_kind=law_kind,
    )
    return MemorySteps(copies["memory_commit"], copies["_integrals"])


# this module's own kernels: the sphere's and the profile laws' steps
_sphere_commit, _sphere_integrals = memory_steps(SPHERE)
_profile_commit, _profile_integrals = memory_steps(PROFILE)
