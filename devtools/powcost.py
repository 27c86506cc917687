"""What a power-law profile's `a^(1/n)` costs in the kernels' setting: a
numba loop of dependent evaluations (each result feeds the next argument,
as the step's a* feeds the next step), ns per evaluation over the loop
alone, for libm's `pow`, `exp(q log a)` and `sqrt` (the sphere's).
docs/MODEL.md section 10, "The power law's root" (why a warm start replaces it).

    python -m devtools.powcost
"""
import math
import time

import numba as nb

N = 10_000_000


def _chain(evaluate):
    """A loop of n dependent evaluations of `evaluate(x, q)` (a jitted
    function): each result feeds the next argument."""
    @nb.njit(nogil=True)
    def run(a, q, n):
        x, s = a, 0.0
        for _ in range(n):
            y = evaluate(x, q)
            s += y
            x = 1.0 + 1e-9 * y + 0.5e-12 * x
        return s
    return run


EVALUATIONS = {
    "loop": nb.njit(lambda x, q: x),                          # the loop alone
    "sqrt": nb.njit(lambda x, q: math.sqrt(x)),               # the sphere's
    "pow": nb.njit(lambda x, q: x ** q),                      # a power law's
    "exp_log": nb.njit(lambda x, q: math.exp(q * math.log(x))),
}


def main(repeat=5):
    best = {}
    for name, evaluate in EVALUATIONS.items():
        f = _chain(evaluate)
        f(1.3, 1 / 3, 10)                     # compiled off the clock
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
