"""Where a profile's law is evaluated in the deformable kernel, per step
(issue 34; docs/MODEL.md section 10, "Speed"): the kernel run as plain
Python (NUMBA_DISABLE_JIT, so slow: keep `--periods` small) with the law's
evaluations counted by call site, and, for a power law with an integer n,
how many of them took the warm start (its short e^2 or its long e^4
series) and how many fell back to pow().
Also the run's steps, its contact states and its mean memory size, to tell
a profile's own cost from a different motion.

    python -m devtools.profilecalls [--periods 100] [--points 1,3,6]
           [--profiles sphere,power:3,flat-sphere:1,cone]

Call sites: `_contact_force` (the step's N*, N*' at a*), `_clamp` (the new
stick-edge vertex of a partial-slip step), `_record_step` (sampled steps
only), `reset_memory_law` (a run's start).
"""
import os

os.environ["NUMBA_DISABLE_JIT"] = "1"     # before numba is imported
os.environ["VIBTRANS_JIT_CACHE"] = "0"

import argparse  # noqa: E402
import collections  # noqa: E402
import sys  # noqa: E402

import numpy as np  # noqa: E402


def _get(where, name):
    return where[name] if isinstance(where, dict) else getattr(where, name)


def _set(where, name, value):
    if isinstance(where, dict):
        where[name] = value
    else:
        setattr(where, name, value)


def count(profile, point, periods):
    """Per-step counts of one run (a dict)."""
    from vibtrans.core.kernels import contact as C
    from vibtrans.core.kernels import deformable as D
    from vibtrans.core.params import paper_scene
    from vibtrans.core.simulate import simulate

    calls = collections.Counter()
    states = collections.Counter()
    vertices = []
    law_eval, power_warm = C.law_eval, C.power_warm

    def site():
        """The kernel phase that asked for the law (past the law's own layers)."""
        f = sys._getframe(2)
        while f.f_code.co_name in ("law_eval", "law_eval_warm", "power_warm") \
                or f.f_code.co_name.startswith("counted_"):
            f = f.f_back
        return f.f_code.co_name

    def counted_law_eval(law, a):
        calls[site()] += 1
        return law_eval(law, a)

    def counted_power_warm(law, a, warm, k_alt):
        out = power_warm(law, a, warm, k_alt)
        kind = {0: "pow", 1: "second start e^4"}.get(out[3], f"warm e^{out[3]}")
        calls[f"{site()} ({kind})"] += 1
        return out

    def counting(clamp):
        def counted_clamp(*args):
            out = clamp(*args)
            states[C.STATE_NAMES[out[2]]] += 1
            vertices.append(args[3][0])
            return out
        return counted_clamp

    patches = [(C, "law_eval", counted_law_eval), (D, "law_eval", counted_law_eval),
               (C, "power_warm", counted_power_warm)]
    # the memory diagram's copies for each law kind (contact.memory_steps,
    # jit.specialize) look their callees up in a namespace of their own
    for kind in range(len(C.LAW_KINDS)):
        space = C.memory_steps(kind).commit.__globals__
        patches += [(space, "law_eval", counted_law_eval),
                    (space, "_clamp", counting(space["_clamp"]))]
    saved = [(where, name, _get(where, name)) for where, name, _ in patches]
    try:
        for where, name, f in patches:
            _set(where, name, f)
        scene = paper_scene(point).replace(periods=float(periods))
        if profile != "sphere":
            scene = scene.replace(profile=profile)
        steps = int(simulate(scene).attrs["steps"])
    finally:
        for where, name, f in saved:
            _set(where, name, f)
    total = sum(states.values())
    return {"steps": steps,
            "per_step": {k: v / steps for k, v in sorted(calls.items())},
            "states": {k: v / total for k, v in sorted(states.items())},
            "mean_vertices": float(np.mean(vertices)) if vertices else 0.0}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=float, default=100.0)
    ap.add_argument("--points", default="1,3,6")
    ap.add_argument("--profiles", default="sphere,power:3,flat-sphere:1,cone")
    args = ap.parse_args(argv)
    for point in (int(p) for p in args.points.split(",")):
        for profile in args.profiles.split(","):
            c = count(profile, point, args.periods)
            per = ", ".join(f"{k} {v:.3f}" for k, v in c["per_step"].items()) or "none"
            st = ", ".join(f"{k} {v:.2f}" for k, v in c["states"].items())
            print(f"point {point} {profile:14s} steps {c['steps']}; per step: {per}; "
                  f"states: {st}; mean vertices {c['mean_vertices']:.1f}")


if __name__ == "__main__":
    main()
