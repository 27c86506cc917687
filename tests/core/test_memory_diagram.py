"""Tests for vibtrans.core.kernels.contact: the memory diagram (MMD) of Cattaneo-Mindlin contact.

Sources: closed forms of docs/MODEL.md section 7 (Cattaneo-Mindlin, Mindlin-Deresiewicz,
Masing), the spring-bed rules of docs/MODEL.md section 2, and the slow spring-bed twin
in tests/naive.py.
"""

import functools
import os
import sys

import numpy as np
import pytest
from scipy.integrate import trapezoid  # numpy < 2 has no np.trapezoid

from vibtrans.core.kernels.contact import (
    FLIGHT,
    PARTIAL_SLIP,
    SLIDING,
    STICK,
    anchor_profile,
    memory_step,
    new_memory,
    reset_memory,
    tangential_force_history,
)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from naive import SpringBed, spring_bed_history  # noqa: E402

TOL = 1e-12


# --------------------------------------------------------------------- closed forms
def cm(a, b):
    """Cattaneo-Mindlin, constant a*, |b*| from 0 (docs/MODEL.md section 7), signed."""
    x = np.minimum(np.abs(b), a)
    return np.sign(b) * (a**1.5 - (a - x) ** 1.5)


def md_unload(a, bm, Tm, b):
    """Mindlin-Deresiewicz unloading from (bm, Tm) (docs/MODEL.md section 7)."""
    return Tm - 2.0 * (a**1.5 - (a - (bm - b) / 2.0) ** 1.5)


def md_reload(a, bmin, Tmin, b):
    """Reloading from the unloading minimum (bmin, Tmin): the mirror of md_unload."""
    return Tmin + 2.0 * (a**1.5 - (a - (b - bmin) / 2.0) ** 1.5)


def loop_energy(a, A):
    """Closed-loop integral of T* db* for a Masing loop of half-amplitude A <= a*.

    Integrating md_reload - md_unload over [bmin, bmin + 2A]:
    with Tmin - Tm = -2 [a^1.5 - (a - A)^1.5] and
    int_0^{2A} (a - y/2)^1.5 dy = (4/5) [a^2.5 - (a - A)^2.5],
        W = 4 A [a^1.5 + (a - A)^1.5] - (16/5) [a^2.5 - (a - A)^2.5]
    (small A: W ~ A^3 / (2 sqrt(a)), the classical cubic law).
    """
    return 4.0 * A * (a**1.5 + (a - A) ** 1.5) - 3.2 * (a**2.5 - (a - A) ** 2.5)


def hist(a, b, **kw):
    return tangential_force_history(np.asarray(a, float), np.asarray(b, float), **kw)


# ------------------------------------------------------- Cattaneo-Mindlin (loading)
@pytest.mark.parametrize("a", [0.5, 1.0, 2.3])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_cattaneo_mindlin_monotonic(a, sign):
    # Source: docs/MODEL.md section 7, Cattaneo-Mindlin: T* = a^1.5 - (a - b)^1.5 for
    # 0 <= b <= a, then T* = N* = a^1.5; b falling from 0 is the mirror image.
    b = sign * np.linspace(0.0, 1.6 * a, 641)
    T, sh, st = hist(np.full_like(b, a), b, a_start=a, b_start=0.0)
    assert np.max(np.abs(T - cm(a, b))) <= TOL
    x = np.abs(b)
    partial = (x > 0) & (x < a * (1 - 1e-9))
    sliding = x > a * (1 + 1e-9)
    assert st[0] == STICK and T[0] == 0.0 and sh[0] == a
    assert np.all(st[partial] == PARTIAL_SLIP)
    assert np.max(np.abs(sh[partial] - (a - x[partial]))) <= TOL  # stick core h < a - |b|
    assert np.all(st[sliding] == SLIDING)
    assert np.all(sh[sliding] == 0.0)
    assert np.all(T[sliding] == sign * a**1.5)


@pytest.mark.parametrize("a", [0.5, 2.3])
def test_cattaneo_mindlin_single_jump_is_path_independent(a):
    # Source: docs/MODEL.md section 7 (Cattaneo-Mindlin); monotonic loading at constant a*
    # depends only on the end point, so one big step must equal many small ones.
    for b in np.linspace(-1.4 * a, 1.4 * a, 57):
        T, sh, st = hist([a], [b], a_start=a, b_start=0.0)
        assert abs(T[0] - cm(a, b)) <= TOL


# ----------------------------------------------- Mindlin-Deresiewicz, Masing loops
def _loop(a, bm, A, n, pre=()):
    """History at constant a: optional prefix, load 0 -> bm, unload by 2A, reload."""
    up = np.linspace(0.0, bm, n)[1:]
    down = np.linspace(bm, bm - 2 * A, 2 * n - 1)[1:]
    back = np.linspace(bm - 2 * A, bm, 2 * n - 1)[1:]
    b = np.concatenate([np.asarray(pre, float), up, down, back])
    T, sh, st = hist(np.full_like(b, a), b, a_start=a, b_start=0.0)
    k = len(pre) + len(up)
    return (
        (b[k - 1], T[k - 1]),
        (b[k : k + len(down)], T[k : k + len(down)], st[k : k + len(down)]),
        (b[k + len(down) :], T[k + len(down) :], st[k + len(down) :]),
    )


@pytest.mark.parametrize("a", [0.5, 1.0, 2.3])
def test_mindlin_deresiewicz_loop_from_partial_slip(a):
    # Source: docs/MODEL.md section 7, Mindlin-Deresiewicz unloading from (b_m, T_m)
    # T* = T_m - 2 [a^1.5 - (a - (b_m - b)/2)^1.5], reloading mirrors it from
    # (b_min, T_min); Masing: the loop closes at (b_m, T_m); its area is loop_energy.
    bm = 0.6 * a
    n = 2001
    (b_m, T_m), (bd, Td, sd), (br, Tr, sr) = _loop(a, bm, bm, n)
    assert b_m == bm and abs(T_m - cm(a, bm)) <= TOL
    assert np.max(np.abs(Td - md_unload(a, b_m, T_m, bd))) <= TOL
    b_min, T_min = bd[-1], Td[-1]
    assert abs(T_min + T_m) <= TOL  # symmetric loop: T_min = -T_m
    assert np.max(np.abs(Tr - md_reload(a, b_min, T_min, br))) <= TOL
    assert abs(Tr[-1] - T_m) <= TOL  # Masing: the loop closes
    assert np.all(sd[:-1] == PARTIAL_SLIP) and np.all(sr[:-1] == PARTIAL_SLIP)
    # Dissipated energy: closed-loop integral of T db (trapezoid on the stack's
    # forces) against the analytic integral of the two branches.
    W_stack = trapezoid(np.r_[T_m, Td], np.r_[b_m, bd]) + trapezoid(np.r_[T_min, Tr], np.r_[b_min, br])
    W_trap_cf = trapezoid(md_unload(a, b_m, T_m, np.r_[b_m, bd]), np.r_[b_m, bd]) + trapezoid(
        md_reload(a, b_min, T_min, np.r_[b_min, br]), np.r_[b_min, br]
    )
    W = loop_energy(a, bm)
    assert W > 0
    assert abs(W_stack - W_trap_cf) <= 1e-11 * max(1.0, W)
    # trapezoid error <= L^3/(12 n^2) max|T''| per branch, |T''| <= (3/8)(a - A)^-1/2 here
    h = 2 * bm / (2 * n - 2)
    bound = 2 * (2 * bm) * h**2 / 12 * (3 / 8) / np.sqrt(a - bm)
    assert abs(W_trap_cf - W) <= 1.5 * bound
    assert abs(W_stack - W) <= 1.5 * bound + 1e-11
    # the closed form itself: small-amplitude limit A^3 / (2 sqrt a)
    A = 1e-3 * a
    assert loop_energy(a, A) == pytest.approx(A**3 / (2 * np.sqrt(a)), rel=1e-2)


@pytest.mark.parametrize("a", [0.5, 1.0, 2.3])
def test_unloading_past_the_mirror_point_follows_the_virgin_curve(a):
    # Source: docs/MODEL.md section 7 (Mindlin-Deresiewicz + Masing) and section 2 rules.
    # After loading to b_m < a from virgin, unloading follows md_unload only while
    # b_m - b <= 2 b_m (the reversed slip annulus then covers the old one); past
    # b = -b_m the whole memory is overwritten and T* follows the mirror of the virgin
    # curve, -[a^1.5 - (a + b)^1.5], down to total sliding at b = -a.
    bm = 0.4 * a
    up = np.linspace(0.0, bm, 201)[1:]
    down = np.linspace(bm, -1.3 * a, 1701)[1:]
    b = np.r_[up, down]
    T, sh, st = hist(np.full_like(b, a), b, a_start=a)
    Tm = cm(a, bm)
    Td, sd = T[len(up) :], st[len(up) :]
    first = down >= -bm
    assert np.max(np.abs(Td[first] - md_unload(a, bm, Tm, down[first]))) <= TOL
    assert np.max(np.abs(Td[~first] - cm(a, down[~first]))) <= TOL
    assert np.all(sd[down < -a * (1 + 1e-9)] == SLIDING)
    assert np.all(Td[down < -a * (1 + 1e-9)] == -(a**1.5))


@pytest.mark.parametrize("a", [0.5, 1.0, 2.3])
def test_mindlin_deresiewicz_loop_after_total_sliding(a):
    # Source: docs/MODEL.md section 7: unloading from (b_m, T_m = N*) after total
    # sliding, T* = N* - 2 [a^1.5 - (a - (b_m - b)/2)^1.5], valid for b_m - b <= 2a
    # (it reaches -N* exactly at b_m - b = 2a, then slides); a loop of
    # half-amplitude A = 0.8 a closes (Masing) with area loop_energy(a, A).
    N = a**1.5
    bs = 1.3 * a  # slid through: T = N, memory wiped
    # (i) unloading all the way: md_unload, then total sliding at -N
    b = np.r_[np.linspace(0.0, bs, 301)[1:], np.linspace(bs, bs - 2.5 * a, 2501)[1:]]
    T, sh, st = hist(np.full_like(b, a), b, a_start=a)
    k = 300
    assert np.all(T[k - 60 : k] == N) and np.all(st[k - 60 : k] == SLIDING)
    bd, Td, sd = b[k:], T[k:], st[k:]
    valid = bs - bd <= 2 * a
    assert np.max(np.abs(Td[valid] - md_unload(a, bs, N, bd[valid]))) <= TOL
    assert abs(md_unload(a, bs, N, bs - 2 * a) + N) <= TOL
    assert np.all(sd[bs - bd > 2 * a * (1 + 1e-9)] == SLIDING)
    assert np.all(Td[bs - bd > 2 * a * (1 + 1e-9)] == -N)
    # (ii) closed loop of half-amplitude A after sliding
    A = 0.8 * a
    n = 2001
    (b_m, T_m), (bd, Td, sd), (br, Tr, sr) = _loop(a, bs, A, n)
    assert T_m == N
    assert np.max(np.abs(Td - md_unload(a, b_m, T_m, bd))) <= TOL
    b_min, T_min = bd[-1], Td[-1]
    assert np.max(np.abs(Tr - md_reload(a, b_min, T_min, br))) <= TOL
    assert abs(Tr[-1] - N) <= TOL
    W_stack = trapezoid(np.r_[T_m, Td], np.r_[b_m, bd]) + trapezoid(np.r_[T_min, Tr], np.r_[b_min, br])
    h = 2 * A / (2 * n - 2)
    bound = 2 * (2 * A) * h**2 / 12 * (3 / 8) / np.sqrt(a - A)
    assert abs(W_stack - loop_energy(a, A)) <= 1.5 * bound + 1e-11


# ------------------------------------------------- sliding, contact loss, re-contact
def test_total_sliding_is_exactly_coulomb():
    # Source: docs/MODEL.md section 2: in total sliding every spring sits at its
    # limit u = a* - h, which integrates to T* = a*^(3/2) = N*; and the states
    # table (T* = sign(b*') N*, s = 0).
    a = np.linspace(1.0, 2.0, 401)
    b = 3.0 * (a - 1.0) + 1.2  # starts slid through, |db| = 3 da > da
    T, sh, st = hist(a, b)
    assert np.all(st == SLIDING) and np.all(sh == 0.0)
    assert np.max(np.abs(T - a**1.5)) <= TOL
    # shrinking contact while sliding backwards
    a2 = np.linspace(2.0, 0.3, 301)
    b2 = -2.5 - 2.0 * (2.0 - a2)  # first step |db| = 2.5 > a: slid through
    T, sh, st = hist(a2, b2, a_start=2.0, b_start=0.0)
    assert np.all(st == SLIDING)
    assert np.max(np.abs(T + a2**1.5)) <= TOL


def test_contact_loss_and_virgin_recontact():
    # Source: docs/MODEL.md section 2 rules 1 and 4 (springs that leave forget; new
    # springs enter with u = 0) and the states list (a* <= 0: flight, T* = 0).
    # Load into sliding, lift off (a* down through 0, b* moving in the air), set
    # down at constant b* = bc, then load tangentially at constant a*: pure
    # Cattaneo-Mindlin from bc again, both directions.
    a1 = 0.8
    for direction in (1.0, -1.0):
        seg = [
            (np.full(50, 1.0), np.linspace(0.0, 1.5, 51)[1:]),  # slide, T = N
            (np.linspace(1.0, -0.5, 61)[1:], np.full(60, 1.5)),  # lift off
            (np.full(20, -0.5), np.linspace(1.5, 2.0, 21)[1:]),  # b moves in flight
            (np.array([a1]), np.array([2.0])),  # set down at b = 2
            (np.full(200, a1), 2.0 + direction * np.linspace(0.0, 1.2 * a1, 201)[1:]),
        ]
        a = np.concatenate([s[0] for s in seg])
        b = np.concatenate([s[1] for s in seg])
        T, sh, st = hist(a, b)
        flight = a <= 0.0
        assert flight.sum() >= 40
        assert np.all(st[flight] == FLIGHT) and np.all(T[flight] == 0.0) and np.all(sh[flight] == 0.0)
        assert np.all(st[~flight] != FLIGHT)
        k = 50 + 60 + 20
        assert st[k] == STICK and T[k] == 0.0
        assert np.max(np.abs(T[k + 1 :] - cm(a1, b[k + 1 :] - 2.0))) <= TOL


def test_recontact_within_a_step_attaches_on_the_line():
    # Source: docs/MODEL.md section 2: within a straight-line step, a spring that
    # enters at depth h attaches at the b* where the step's line crosses a* = h.  Contact restarting within a
    # step from (a0 < 0, b0) to (a1, b1): w(h) = bc + (b1 - bc) h / a1 with bc the
    # b* at a* = 0, so u = (b1 - bc)(1 - h/a1) and, if |b1 - bc| <= a1 (no spring
    # past its limit),  T* = (3/4) (b1 - bc)/a1 * (4/3) a1^1.5 = (b1 - bc) sqrt(a1).
    a0, b0, a1 = -0.4, 1.0, 0.6
    for b1 in (1.2, 0.85, 1.0, 1.5, 0.3):
        bc = b0 + (b1 - b0) * (-a0) / (a1 - a0)
        T, sh, st = hist([a0, a1], [b0, b1], a_start=0.5, b_start=b0)
        assert st[0] == FLIGHT and T[0] == 0.0
        if abs(b1 - bc) < a1:
            assert st[1] == STICK
            assert abs(T[1] - (b1 - bc) * np.sqrt(a1)) <= TOL
        else:  # steeper than the cone: slides at once
            assert st[1] == SLIDING
            assert abs(T[1] - np.sign(b1 - bc) * a1**1.5) <= TOL


# ------------------------------------------------------------------- varying a*
def test_normal_loading_at_constant_b_keeps_stick_and_force():
    # Source: docs/MODEL.md section 2 rules 1-3, derived: at constant b*, a growing a*
    # adds springs with u = 0 (zero contribution to T*) and widens every limit
    # a* - h, so no spring slides: full stick, T* unchanged, s_h = a*.  Normal
    # unloading back to the starting a* only removes those u = 0 springs (T* still
    # unchanged); below it, the springs at the edge slide: from a Cattaneo-Mindlin
    # state (a0, b) the force is Cattaneo-Mindlin at the current a*,
    # T* = a^1.5 - (a - b)^1.5 with s_h = a - b for a > b, and total sliding
    # T* = N*(a) once a <= b.
    a0, b0 = 1.0, 0.3
    up = np.linspace(a0, 2.5, 61)[1:]
    down = np.linspace(2.5, 0.1, 97)[1:]
    b_load = np.linspace(0.0, b0, 31)[1:]
    a = np.r_[np.full(30, a0), up, down]
    b = np.r_[b_load, np.full(len(up) + len(down), b0)]
    T, sh, st = hist(a, b, a_start=a0)
    T0 = cm(a0, b0)
    assert abs(T[29] - T0) <= TOL and st[29] == PARTIAL_SLIP
    i_up = slice(30, 30 + len(up))
    assert np.all(st[i_up] == STICK) and np.all(sh[i_up] == a[i_up])
    assert np.max(np.abs(T[i_up] - T0)) <= TOL
    Td, sd, shd = T[30 + len(up) :], st[30 + len(up) :], sh[30 + len(up) :]
    above = down > a0 * (1 + 1e-9)
    assert np.all(sd[above] == STICK) and np.max(np.abs(Td[above] - T0)) <= TOL
    below = down <= a0
    assert np.max(np.abs(Td[below] - cm(down[below], b0))) <= TOL
    ps = (down < a0 * (1 - 1e-9)) & (down > b0 * (1 + 1e-9))
    assert np.all(sd[ps] == PARTIAL_SLIP)
    assert np.max(np.abs(shd[ps] - (down[ps] - b0))) <= TOL
    sl = down < b0 * (1 - 1e-9)
    assert sl.sum() > 5 and np.all(sd[sl] == SLIDING)


def test_normal_loading_after_total_sliding_freezes_force():
    # Source: docs/MODEL.md section 2, derived as above: from total sliding at (a0, b),
    # growing a* at constant b* keeps T* = N*(a0) < N*(a) in full stick.
    a = np.r_[np.full(40, 1.0), np.linspace(1.0, 2.0, 41)[1:]]
    b = np.r_[np.linspace(0.0, 1.5, 41)[1:], np.full(40, 1.5)]
    T, sh, st = hist(a, b)
    assert st[39] == SLIDING and T[39] == 1.0
    assert np.all(st[40:] == STICK)
    assert np.max(np.abs(T[40:] - 1.0)) <= TOL
    assert np.all(T[41:] < a[41:] ** 1.5)


# ---------------------------------------------------------------- random histories
HISTORIES = [  # (seed, steps, a_start, b_start)
    (11, 300, 1.0, 0.0),
    (13, 700, 0.4, -0.3),
    (14, 1200, 1.0, 0.0),
    (15, 1600, 1.0, 0.0),
    (16, 2000, -0.2, 0.5),
]
M_LEVELS = (2000, 8000, 32000)


@functools.cache
def random_history(seed, n):
    """Smooth-ish random (a*, b*) walk: a* oscillates and dips below 0 (flight),
    b* is an AR(1)-velocity walk whose speed switches between slow (stick and
    partial slip) and fast (total sliding); a few holds of a* or b*."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    a_noise = np.zeros(n)
    b = np.zeros(n)
    va = vb = x = bb = 0.0
    for i in range(n):
        va = 0.95 * va + rng.normal(0.0, 0.01)
        x = 0.995 * (x + va)
        a_noise[i] = x
        vb = 0.9 * vb + rng.normal(0.0, 0.004 if rng.random() < 0.5 else 0.03)
        if rng.random() < 0.05:
            vb = 0.0
        bb += vb
        b[i] = bb
    period = rng.uniform(120.0, 300.0)
    a = 0.7 + 0.9 * np.sin(2 * np.pi * k / period + rng.uniform(0, 2 * np.pi)) + 0.5 * a_noise
    for _ in range(4):
        i0 = int(rng.integers(0, n - 20))
        length = int(rng.integers(3, 15))
        if rng.random() < 0.5:
            a[i0 : i0 + length] = a[i0]
        else:
            b[i0 : i0 + length] = b[i0]
    return a, b


@functools.cache
def stack_run(idx):
    seed, n, a0, b0 = HISTORIES[idx]
    a, b = random_history(seed, n)
    return hist(a, b, a_start=a0, b_start=b0)


@functools.cache
def bed_run(idx, M):
    seed, n, a0, b0 = HISTORIES[idx]
    a, b = random_history(seed, n)
    return spring_bed_history(a, b, M, a_start=a0, b_start=b0)


def test_random_histories_cover_every_state():
    # Source: guard for the comparisons below (they must exercise flight,
    # re-contact within a step with b* moving, stick, partial slip, sliding).
    for idx, (seed, n, a0, b0) in enumerate(HISTORIES):
        a, b = random_history(seed, n)
        T, sh, st = stack_run(idx)
        assert set(np.unique(st)) == {FLIGHT, STICK, PARTIAL_SLIP, SLIDING}, seed
        prev_a = np.r_[a0, a[:-1]]
        prev_b = np.r_[b0, b[:-1]]
        assert np.any((prev_a < 0) & (a > 0) & (b != prev_b)), seed


@pytest.mark.slow
@pytest.mark.parametrize("idx", range(len(HISTORIES)))
def test_random_history_force_converges_to_stack(idx):
    # Source: docs/MODEL.md section 2, the spring bed (tests/naive.py) versus the exact
    # polyline.  The springs are exact; only the bed's quadrature of T* errs, and
    # the error must fall faster than 1/M (measured: about M^-1.5).
    T, sh, st = stack_run(idx)
    scale = np.max(np.abs(T))
    errs = []
    for M in M_LEVELS:
        Tb = np.array([r["T"] for r in bed_run(idx, M)])
        errs.append(np.max(np.abs(Tb - T)) / scale)
    print(
        f"history {HISTORIES[idx][0]}: rel. max error for M = {M_LEVELS}: "
        + ", ".join(f"{e:.2e}" for e in errs)
    )
    assert errs[0] > errs[1] > errs[2]
    assert errs[0] / errs[1] > 4.0 and errs[1] / errs[2] > 4.0
    assert errs[2] < 2e-3
    assert errs[2] < 1e-5


@pytest.mark.parametrize("idx", range(len(HISTORIES)))
def test_random_history_states_and_stick_depth_match_springs(idx):
    # Source: docs/MODEL.md section 2 (slip annulus at the edge, stick core below) versus
    # the springs clipped during each step in tests/naive.py: the stack's s_h lies
    # between the deepest surely-stuck spring and the shallowest surely-sliding
    # one, the sliding springs form one band at the edge, and wherever the bed is
    # unambiguous the states agree.
    T, sh, st = stack_run(idx)
    steps = bed_run(idx, 8000)
    for i, r in enumerate(steps):
        assert r["contiguous"], (idx, i)
        if r["state"] == FLIGHT:
            assert st[i] == FLIGHT
            continue
        assert st[i] != FLIGHT
        assert r["s_lo"] - 1e-12 <= sh[i] <= r["s_hi"] + 1e-12, (idx, i, r, sh[i], st[i])
        if r["state"] is None or r["ambiguous"]:
            continue
        if r["state"] == PARTIAL_SLIP:
            assert st[i] == PARTIAL_SLIP, (idx, i)
        if st[i] == STICK:
            assert r["state"] == STICK, (idx, i)
        if st[i] == SLIDING:
            assert r["state"] == SLIDING, (idx, i)


@pytest.mark.slow
@pytest.mark.parametrize("idx", [0, 2, 4])
def test_anchor_profile_matches_springs_pointwise(idx):
    # Source: docs/MODEL.md section 2, "Exact, fast representation": the polyline w(h)
    # is the anchor b* - u(h) of every spring, so at each spring of the bed it
    # must agree to rounding, step by step (independent of M).
    seed, n, a0, b0 = HISTORIES[idx]
    a, b = random_history(seed, n)
    H, W, P, nvert, memf = new_memory(n + 8)
    reset_memory(H, W, P, nvert, memf, a0, b0)
    steps = bed_run(idx, 2000)
    T_ref, sh_ref, st_ref = stack_run(idx)
    bed = SpringBed(2000, max(a0, float(a.max()), 1e-3), a0, b0)
    for i in range(n):
        T, s, state = memory_step(H, W, P, nvert, memf, a[i], b[i])
        bed.step(a[i], b[i])
        assert (T, s, state) == (T_ref[i], sh_ref[i], st_ref[i])
        hs, ws = bed.anchors()
        if a[i] <= 0.0:
            assert nvert[0] == 0 and hs.size == 0
            continue
        Hv, Wv = anchor_profile(H, W, nvert, memf)
        assert Hv[0] == 0.0 and Hv[-1] == a[i] and Wv[-1] == pytest.approx(b[i], abs=1e-12)
        assert np.all(np.diff(Hv) >= 0.0)
        if hs.size:
            assert np.max(np.abs(np.interp(hs, Hv, Wv) - ws)) <= 1e-10, (idx, i)
        assert steps[i]["n_on"] == hs.size


def test_invariants_on_random_histories():
    # Source: docs/MODEL.md section 2: Coulomb bound |T*| <= N*, equality exactly in
    # total sliding (s = 0) with a* > 0 (and conversely, except on a step that
    # does not move at all, which holds T* where it was); flight iff a* <= 0 with T* = 0; s_h = a*
    # in full stick, 0 in sliding, strictly inside (0, a*) in partial slip.
    for seed in range(100, 120):
        a, b = random_history(seed, 2000)
        T, sh, st = hist(a, b)
        N = np.where(a > 0, np.maximum(a, 0.0) ** 1.5, 0.0)
        assert np.all(np.abs(T) <= N + TOL)
        c = a > 0
        assert np.array_equal(st == FLIGHT, ~c)
        assert np.all(T[~c] == 0.0)
        at_limit = np.abs(T) >= N - TOL
        assert np.all(at_limit[st == SLIDING])
        # |T*| = N* without sliding only where nothing moved: a step repeating the
        # committed point right after total sliding (the contact holds at the limit)
        prev_a, prev_b = np.r_[1.0, a[:-1]], np.r_[0.0, b[:-1]]
        held = (a == prev_a) & (b == prev_b)
        odd = c & at_limit & (st != SLIDING)
        assert np.all(held[odd]), (seed, np.flatnonzero(odd & ~held))
        assert np.all(np.abs(T[odd]) == np.abs(T[np.flatnonzero(odd) - 1]))
        assert np.all(sh[st == STICK] == a[st == STICK])
        assert np.all(sh[st == SLIDING] == 0.0)
        p = st == PARTIAL_SLIP
        assert np.all((sh[p] > 0.0) & (sh[p] < a[p])), seed


def test_repeated_point_is_full_stick():
    # Source: docs/MODEL.md section 2, the clamp: when no vertex leaves the cone and
    # the top does not move, the contact is in full stick; rules 2-3: with db* = 0 and da* = 0 no
    # spring is pushed, none slides (the spring bed reports no clipped spring).
    bad = []
    for seed in range(200, 206):
        a, b = random_history(seed, 800)
        a2, b2 = np.repeat(a, 2), np.repeat(b, 2)
        T, sh, st = hist(a2, b2)
        assert np.max(np.abs(T[1::2] - T[0::2])) <= TOL
        rep = st[1::2]
        bad += [(seed, int(st[2 * i]), int(rep[i])) for i in np.flatnonzero((rep != STICK) & (rep != FLIGHT))]
    assert not bad, f"{len(bad)} repeated points not in stick, e.g. {bad[:5]}"
