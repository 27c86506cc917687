"""What a power-law profile's `a^(1/n)` costs in the kernels' setting: a
numba loop of dependent evaluations (each result feeds the next argument,
as the step's a* feeds the next step), ns per evaluation over the loop
alone, for libm's `pow`, `exp(q log a)` and `sqrt` (the sphere's).
docs/MODEL.md section 10, "Why the power law stays near 2x".

    python -m devtools.powcost
"""
import math
import time

import numba as nb

N = 10_000_000


@nb.njit(nogil=True, cache=True)
def _none(a, q, n):
    x, s = a, 0.0
    for _ in range(n):
        y = x
        s += y
        x = 1.0 + 1e-9 * y + 0.5e-12 * x
    return s


@nb.njit(nogil=True, cache=True)
def _sqrt(a, q, n):
    x, s = a, 0.0
    for _ in range(n):
        y = math.sqrt(x)
        s += y
        x = 1.0 + 1e-9 * y + 0.5e-12 * x
    return s


@nb.njit(nogil=True, cache=True)
def _pow(a, q, n):
    x, s = a, 0.0
    for _ in range(n):
        y = x ** q
        s += y
        x = 1.0 + 1e-9 * y + 0.5e-12 * x
    return s


@nb.njit(nogil=True, cache=True)
def _exp_log(a, q, n):
    x, s = a, 0.0
    for _ in range(n):
        y = math.exp(q * math.log(x))
        s += y
        x = 1.0 + 1e-9 * y + 0.5e-12 * x
    return s


def main(repeat=5):
    best = {}
    for name, f in (("loop", _none), ("sqrt", _sqrt), ("pow", _pow), ("exp_log", _exp_log)):
        f(1.3, 1 / 3, 10)                     # compiled (or loaded) off the clock
        t = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            f(1.3, 1 / 3, N)
            t = min(t, time.perf_counter() - t0)
        best[name] = 1e9 * t / N
    for name in ("sqrt", "pow", "exp_log"):
        print(f"{name:8s} {best[name] - best['loop']:5.1f} ns per dependent evaluation")
    return best


if __name__ == "__main__":
    main()
