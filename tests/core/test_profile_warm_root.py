"""The power law's warm-started a*^(1/n) (contact.law_eval_warm;
docs/explanation/performance.md, "Simulation kernels").

Sources: a 40-digit decimal reference (Python's decimal module: a*^(1/n)
rounded once to double), the pow() path it replaces (law_eval, and the same
kernels with law[LAW_ROOT] = 0), and, for whole runs, the bound of rounding
differences in a motion that does not amplify them: at most one unit of
2^-52 per step, relative (measured ~1e-13 at paper points 1, 3, 4, 6, 9).
"""

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest

from vibtrans.core import drivers
from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import (
    LAW_ARG,
    LAW_KIND,
    LAW_ROOT,
    LAW_TABLE,
    PROFILE,
    WARM_EPS,
    WARM_EPS_SHORT,
    WARM_POWER,
    kernel_law,
    kind_of_law,
    law_eval,
    law_history,
    power_kernel_law,
    power_warm,
    tangential_force_history,
)
from vibtrans.core.kernels.dispatch import kernel_for
from vibtrans.core.params import paper_scene
from vibtrans.core.profiles import FlatSphereProfile
from vibtrans.core.simulate import SAMPLES_PER_PERIOD, hertz_params

EPS = 2.0**-52  # one unit in the last place, relative (the upper end)
ULPS = 4  # the stated accuracy (docs/MODEL.md section 10)
ROOTS = [2, 3, 4, 5, 6, 7, 10, 17, 64]


def _pow_law(law):
    """The same law without the warm start: pow() at every evaluation."""
    ref = law.copy()
    ref[LAW_ROOT] = 0.0
    return ref


def _smooth_history(rng, size, steps=(100, 1000)):
    """a* along an oscillation of the kind a contact goes through: `steps`
    steps a period (drawn in that range), a* over a factor up to e^4,
    anywhere in [e^-5, e^5]."""
    i = np.arange(size)
    return math.exp(rng.uniform(-3, 3)) * np.exp(
        rng.uniform(0.1, 2.0) * np.sin(2 * np.pi * i / rng.uniform(*steps) + rng.uniform(0, 2 * np.pi))
    )


def _run(law, n, size=12_000, seed=34, steps=(100, 1000)):
    a = _smooth_history(np.random.default_rng(seed + n), size, steps)
    out = np.empty((size, 3))
    law_history(law, a, out)
    return a, out


def _start_error(a, out, law):
    """|e| = |a* / y0^n - 1| of each evaluation's warm start, y0 the cubic
    extrapolation of the roots before it (as the kernel's)."""
    y = out[:, 1] / law[LAW_ARG]
    y0 = 4.0 * y[3:-1] - 6.0 * y[2:-2] + 4.0 * y[1:-3] - y[:-4]
    return np.abs(a[4:] / y0 ** law[LAW_ROOT] - 1.0)


@pytest.mark.parametrize("n", ROOTS)
@pytest.mark.parametrize("steps", [(100, 1000), (30, 80)], ids=["fine", "coarse"])
def test_warm_root_within_4_ulp_of_pow(n, steps):
    # 2 x 9 exponents x 12000 = 2.2e5 evaluations, most through the warm
    # start; the fine histories take the short (e^2) series nearly always,
    # the coarse ones (30-80 steps a period) put many starts near the largest
    # |e| each series takes (WARM_EPS_SHORT, WARM_EPS): their worst cases
    law = power_kernel_law(n)
    a, out = _run(law, n, steps=steps)
    _, ref = _run(_pow_law(law), n, steps=steps)
    order = out[:, 2]
    assert set(np.unique(order)) <= {0.0, 1.0, 2.0, 4.0}  # 1: a second start
    warm = order > 0.0
    assert warm.mean() > (0.99 if steps[0] == 100 else 0.05)  # the fast path is tested
    e = _start_error(a, out, law)
    short, long_ = (order[4:] == 2.0), (order[4:] == 4.0)
    # each order where its |e| says (the start error recomputed here, to rounding)
    assert np.all(e[short] <= WARM_EPS_SHORT * (1 + 1e-9))
    assert np.all((e[long_] >= WARM_EPS_SHORT * (1 - 1e-9)) & (e[long_] <= WARM_EPS * (1 + 1e-9)))
    if steps[0] == 100:
        assert short.mean() > 0.5
    else:
        assert np.count_nonzero(e[long_] > WARM_EPS / 4) >= 200  # near its limit
    assert not ref[:, 2].any()
    np.testing.assert_allclose(out[:, 0], ref[:, 0], rtol=ULPS * EPS, atol=0)
    np.testing.assert_allclose(out[:, 1], ref[:, 1], rtol=ULPS * EPS, atol=0)
    # the power law's two values are one root: N* = a* y, N*' = p y
    np.testing.assert_allclose(out[:, 0], a * out[:, 1] / law[LAW_ARG], rtol=2 * EPS, atol=0)


@pytest.mark.parametrize("n", [3, 7, 64])
def test_short_series_near_its_limit_within_4_ulp_of_pow(n):
    # these fine histories put thousands of starts within a factor 4 of
    # WARM_EPS_SHORT, the short series' worst case
    law = power_kernel_law(n)
    a, out = _run(law, n)
    _, ref = _run(_pow_law(law), n)
    e = _start_error(a, out, law)
    near = np.flatnonzero((out[4:, 2] == 2.0) & (e > WARM_EPS_SHORT / 4)) + 4
    assert near.size >= 1000
    for col in (0, 1):
        np.testing.assert_allclose(out[near, col], ref[near, col], rtol=ULPS * EPS, atol=0)


def test_short_series_truncation_below_2_to_minus_57():
    # the short series' omitted terms, sum_k>=3 c_k e^k, at its largest |e|
    # (WARM_EPS_SHORT): below 2^-57 of y for every n it serves (|c3| <= 1/16,
    # at n = 2), exactly in rationals
    from fractions import Fraction

    e = Fraction(WARM_EPS_SHORT)
    for n in range(2, 65):
        q = Fraction(1, n)
        c, tail = Fraction(1), Fraction(0)
        for k in range(1, 12):
            c = c * (q - k + 1) / k
            if k >= 3:
                tail += abs(c) * e**k
        assert tail < Fraction(1, 2**57), n


@pytest.mark.parametrize("n", [3, 7, 64])
def test_warm_root_against_a_40_digit_reference(n):
    getcontext().prec = 40
    law = power_kernel_law(n)
    a, out = _run(law, n, size=1500)
    warm = out[:, 2] > 0.0
    assert warm.mean() > 0.99
    root = np.array([float(Decimal(float(x)) ** (Decimal(1) / Decimal(n))) for x in a])
    p = law[LAW_ARG]
    np.testing.assert_allclose(out[warm, 1], p * root[warm], rtol=ULPS * EPS, atol=0)
    np.testing.assert_allclose(out[warm, 0], a[warm] * root[warm], rtol=ULPS * EPS, atol=0)


def test_warm_root_falls_back_to_pow_where_the_start_is_far():
    # a* in random order: no cubic extrapolation lands within WARM_EPS, and
    # the linear one (the second start) only by chance: every other value is
    # pow()'s bit for bit; so are the first two of any history (no second
    # start before two roots), and the cubic start takes over from the fifth
    law = power_kernel_law(3)
    a = np.random.default_rng(5).uniform(1e-3, 50.0, 4000)
    out = np.empty((a.size, 3))
    law_history(law, a, out)
    assert set(np.unique(out[:, 2])) <= {0.0, 1.0}
    assert np.count_nonzero(out[:, 2]) <= 10
    for i in range(a.size):
        if out[i, 2] == 0.0:
            assert (out[i, 0], out[i, 1]) == law_eval(law, a[i])
        else:
            np.testing.assert_allclose(out[i, :2], law_eval(law, a[i]), rtol=ULPS * EPS)
    a2, out2 = _run(law, 3, size=50)
    assert not out2[:2, 2].any() and set(out2[2:4, 2]) <= {0.0, 1.0}
    assert np.all((out2[4:, 2] == 2.0) | (out2[4:, 2] == 4.0))
    assert WARM_EPS <= 2.0**-12  # the series' e^5 term stays below 3e-20 of y


@pytest.mark.parametrize("n", [2, 3, 7, 64])
def test_second_starts_within_4_ulp_where_the_cubic_start_is_far(n):
    # a history whose slope jumps at its newest point (as a stick edge's does
    # when it reaches another segment of the memory), then goes on straight:
    # the cubic start misses by twice the jump, the linear one (2 y1 - y2)
    # takes the e^4 series; with the linear start far too, the caller's
    # k_alt = N*'(a') of a nearby a' (the stick edge's: N*'(a*)); with
    # neither, pow() bit for bit
    law = power_kernel_law(n)
    p = law[LAW_ARG]
    rng = np.random.default_rng(40 + n)

    def root(x):
        return float(Decimal(x) ** (Decimal(1) / Decimal(n)))

    def check(a, warm, k_alt, expect):
        nn, k, _, order = power_warm(law, a, warm, k_alt)
        assert order == expect
        if order == 0:
            assert (nn, k) == law_eval(law, a)
        else:
            ref = root(a)
            np.testing.assert_allclose([k, nn], [p * ref, a * ref], rtol=ULPS * EPS, atol=0)

    for _ in range(300):
        a0 = math.exp(rng.uniform(-4, 4))
        s1 = rng.uniform(-1e-3, 1e-3) * a0
        s2 = s1 + rng.choice([-1, 1]) * rng.uniform(1e-3, 1e-2) * a0
        hist = [a0, a0 + s1, a0 + 2 * s1, a0 + 2 * s1 + s2]
        a = hist[3] + s2
        y = [root(x) for x in hist]
        check(a, (y[3], y[2], y[1], y[0]), 0.0, 1)  # the linear start
        far = (y[3], 0.5 * y[3], y[1], y[0])
        check(a, far, p * root(a * (1 + rng.uniform(-1e-5, 1e-5))), 1)  # the caller's
        check(a, far, 0.0, 0)  # pow
        check(a, far, p * root(a * 1.1), 0)


@pytest.mark.parametrize(
    "law",
    [power_kernel_law(2.5), power_kernel_law(1.0), kernel_law(FlatSphereProfile(1.0))],
    ids=["power2.5", "cone", "table"],
)
def test_laws_without_warm_start_are_law_eval(law):
    # a non-integer n, the cone (a^1) and tables: law_eval itself, bit for bit
    assert law[LAW_KIND] == LAW_TABLE or law[LAW_ROOT] == 0.0
    a = _smooth_history(np.random.default_rng(3), 3000)
    out = np.empty((a.size, 3))
    law_history(law, a, out)
    assert not out[:, 2].any()
    for i in range(0, a.size, 7):
        assert (out[i, 0], out[i, 1]) == law_eval(law, a[i])


def test_power_law_memory_with_warm_start_against_pow():
    # the memory diagram with the warm start at a* and at the stick edge
    # against the same history through pow(): T* and s_h to rounding
    t = np.arange(20_000) / 256.0
    a = 1.0 + 0.8 * np.cos(2 * np.pi * t)
    b = 0.5 * np.sin(2 * np.pi * t) + 1e-3 * t
    law = power_kernel_law(3)
    T, sh, st = tangential_force_history(a, b, law=law)
    T0, sh0, st0 = tangential_force_history(a, b, law=_pow_law(law))
    assert np.array_equal(st, st0)
    np.testing.assert_allclose(T, T0, rtol=0, atol=1e-13 * np.max(np.abs(T0)))
    np.testing.assert_allclose(sh, sh0, rtol=1e-12, atol=0)


@pytest.mark.parametrize("point", [1, 3, 4, 6, 9])
def test_power3_run_drift_matches_the_pow_path(point):
    # non-chaotic scenes of power:3 (points 2, 8 and 10 are chaotic with this
    # tip: any rounding change, this one included, moves their drift
    # entirely); the bound: a rounding difference per step, not amplified
    sc = paper_scene(point).replace(profile="power:3")
    law = drivers.scene_law(sc)
    p, _, cap = hertz_params(sc, math.inf, -math.inf, SAMPLES_PER_PERIOD, 1, D.SHORTCUTS_ALL, None)
    runs = [
        drivers.run_hertz(p, sc.integrator, tangential=True, samples_capacity=cap, law=L)
        for L in (law, _pow_law(law))
    ]
    steps = int(runs[1].ctr[R.C_STEPS])
    assert int(runs[0].ctr[R.C_STEPS]) == steps
    x, x0 = runs[0].state[D.S_X], runs[1].state[D.S_X]
    assert abs(x - x0) <= steps * EPS * abs(x0)


@pytest.mark.parametrize("lyapunov", [False, True], ids=["plain", "lyapunov"])
def test_power_kernels_are_the_profile_kernels_bit_for_bit(monkeypatch, lyapunov):
    # a warm-started power law runs in kernels of its own (deformable.py,
    # WARM_POWER: the law's kind a compile-time constant); the general
    # profile kernels give the same records, bit for bit (point 6: jumps,
    # sliding, second starts and pow at the stick edge)
    sc = paper_scene(6).replace(profile="power:3", periods=100.0)
    law = drivers.scene_law(sc)
    power = {lyap: D.hertz_kernel(D.HertzVariant(True, lyap, WARM_POWER)) for lyap in (False, True)}
    general = {lyap: D.hertz_kernel(D.HertzVariant(True, lyap, PROFILE)) for lyap in (False, True)}
    assert kernel_for("deformable", False, kind_of_law(law)) is power[False]
    assert kernel_for("deformable", True, kind_of_law(law)) is power[True]
    assert kernel_for("deformable", False, kind_of_law(_pow_law(law))) is general[False]
    table = kernel_law(FlatSphereProfile(1.0))
    assert kernel_for("deformable", False, kind_of_law(table)) is general[False]
    p, _, cap = hertz_params(sc, math.inf, -math.inf, SAMPLES_PER_PERIOD, 1, D.SHORTCUTS_ALL, None)
    runs = []
    for own in (True, False):
        if not own:
            monkeypatch.setattr(drivers, "kind_of_law", lambda law: PROFILE)
        runs.append(
            drivers.run_hertz(
                p,
                sc.integrator,
                tangential=True,
                samples_capacity=cap,
                law=law,
                lyapunov_from=1.0 if lyapunov else None,
            )
        )
    a, b = runs
    assert int(a.ctr[R.C_STEPS]) > 10_000
    assert np.array_equal(a.samples, b.samples) and np.array_equal(a.events, b.events)
    assert np.array_equal(a.state, b.state)
    if lyapunov:
        assert np.array_equal(a.tangent, b.tangent)
