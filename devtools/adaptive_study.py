"""Adaptive against uniform drift map on one window: points computed, their
fraction, drift-class agreement at computed and filled points, wall seconds.

    python -m devtools.adaptive_study                      # 41 x 41, K = 3
    python -m devtools.adaptive_study --log-amplitude=-0.8:0.8:0.05 \\
        --log-mass=-1:0.6:0.05 --max-level 3 --periods 500

Both maps run the same scene (preview fidelity by default) on all local
cores; the uniform one is a run_sweep over the finest grid.
"""
import argparse
import os
import tempfile
import time

import numpy as np

from vibtrans.maps.adaptive import DEFAULT_DRIFT_TOLERANCE, run_adaptive
from vibtrans.maps.sweep import Sweep, open_map, parse_range, run_sweep


def compare(adaptive, uniform):
    """Agreement of an adaptive map with the uniform one (both open_map'ed)."""
    comp = adaptive["computed"].values
    steady = uniform["chaotic"].values == 0
    same = adaptive["drift"].values == uniform["drift"].values
    filled = ~comp
    return {
        "points": int(comp.size), "computed": int(comp.sum()),
        "fraction": float(comp.mean()),
        "computed_identical": bool(all(
            np.array_equal(adaptive[v].values[comp], uniform[v].values[comp], equal_nan=True)
            for v in uniform.data_vars if v not in ("seconds", "done", "digest",
                                                    "point_done"))),
        "class_computed_steady": float(same[comp & steady].mean()) if (comp & steady).any()
        else float("nan"),
        "class_filled_steady": float(same[filled & steady].mean()) if (filled & steady).any()
        else float("nan"),
        "class_filled_all": float(same[filled].mean()) if filled.any() else float("nan"),
        "filled_steady": int((filled & steady).sum()),
    }


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--log-amplitude", default="-1.5:0.5:0.05")
    p.add_argument("--log-mass", default="-1.8:0.2:0.05")
    p.add_argument("--max-level", type=int, default=3)
    p.add_argument("--drift-tolerance", type=float, default=DEFAULT_DRIFT_TOLERANCE)
    p.add_argument("--periods", type=float, default=500.0)
    p.add_argument("--fidelity", default="preview")
    p.add_argument("--model", default="deformable")
    p.add_argument("--workers", type=int)
    args = p.parse_args(argv)
    sweep = Sweep(parse_range(args.log_amplitude, "log_amplitude"),
                  parse_range(args.log_mass, "log_mass"), model=args.model,
                  periods=args.periods, fidelity=args.fidelity)
    with tempfile.TemporaryDirectory() as tmp:
        ua, ad = os.path.join(tmp, "uniform.zarr"), os.path.join(tmp, "adaptive.zarr")
        t0 = time.perf_counter()
        run_sweep(sweep, ua, workers=args.workers, progress=False)
        t_uniform = time.perf_counter() - t0
        t0 = time.perf_counter()
        run_adaptive(sweep, ad, args.max_level, args.drift_tolerance, workers=args.workers,
                     progress=False)
        t_adaptive = time.perf_counter() - t0
        r = compare(open_map(ad), open_map(ua))
    shape = f"{sweep.log_amplitude.size} x {sweep.log_mass.size}"
    print(f"window log10 A* {args.log_amplitude}, log10 m* {args.log_mass} ({shape}), "
          f"{args.model}, {args.fidelity}, {args.periods:g} periods, K = {args.max_level}, "
          f"drift tolerance {args.drift_tolerance:g}")
    print(f"computed {r['computed']} of {r['points']} points (fraction {r['fraction']:.3f})")
    print(f"computed points identical to the uniform sweep: {r['computed_identical']}")
    print(f"drift class agreement: computed non-chaotic {r['class_computed_steady']:.4f}, "
          f"filled non-chaotic {r['class_filled_steady']:.4f} ({r['filled_steady']} points), "
          f"all filled {r['class_filled_all']:.4f}")
    print(f"wall seconds: uniform {t_uniform:.1f}, adaptive {t_adaptive:.1f}")
    return r


if __name__ == "__main__":
    main()
