"""Map-level speed against accuracy: each fidelity preset and period count's
map against the standard 2000-period one (log10 A* in [-3, 3], log10 m* in
[-5, 5], mu 0.5): class agreement, median and 90th percentile of the
relative drift difference, steps.  The table is vibtrans/maps/accuracy.py's
MEASURED; stores are kept in --out (a rerun reuses them).

    python -m devtools.map_accuracy --out DIR [--points 41] [--json]
"""

import argparse
import json
import os
import sys

import numpy as np

from vibtrans.maps.difference import map_difference
from vibtrans.maps.sweep import Sweep, open_map, run_sweep

FIDELITIES = ("preview", "standard")
PERIODS = (500.0, 1000.0, 2000.0)
REFERENCE = ("standard", 2000.0)
WINDOW = ((-3.0, 3.0), (-5.0, 5.0))
MU = 0.5


def _map(folder, points, fidelity, periods):
    (a0, a1), (m0, m1) = WINDOW
    sweep = Sweep(
        np.linspace(a0, a1, points),
        np.linspace(m0, m1, points),
        chunk_rows=1,
        mu=MU,
        fidelity=fidelity,
        periods=periods,
    )
    path = os.path.join(folder, f"{fidelity}-{periods:g}-{points}.zarr")
    run_sweep(sweep, path, progress=False)
    return open_map(path)


def study(folder, points=41):
    reference = _map(folder, points, *REFERENCE)
    ref_steps = float(reference["steps"].values.sum())
    rows = []
    for fidelity in FIDELITIES:
        for periods in PERIODS:
            ds = reference if (fidelity, periods) == REFERENCE else _map(folder, points, fidelity, periods)
            diff = map_difference(reference, ds)
            regular = diff["compared"].values & ~diff["chaotic_either"].values
            v1 = diff["drift_velocity_first"].values[regular]
            v2 = diff["drift_velocity_second"].values[regular]
            relative = np.abs(v2 - v1) / np.maximum(np.abs(v1), diff.attrs["v0"])
            rows.append(
                {
                    "fidelity": fidelity,
                    "periods": periods,
                    "class_agreement": diff.attrs["class_agreement"],
                    "median_drift_difference": float(np.median(relative)),
                    "p90_drift_difference": float(np.percentile(relative, 90)),
                    "regular_points": int(regular.sum()),
                    "steps_over_reference": float(ds["steps"].values.sum()) / ref_steps,
                }
            )
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.map_accuracy", description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="folder for the sweeps' stores")
    ap.add_argument("--points", type=int, default=41)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    os.makedirs(a.out, exist_ok=True)
    rows = study(a.out, a.points)
    if a.json:
        print(json.dumps(rows))
        return 0
    for r in rows:
        print(
            f"{r['fidelity']:>9} {r['periods']:6g}: class agrees {100 * r['class_agreement']:5.1f}% "
            f"of {r['regular_points']}, drift difference median {r['median_drift_difference']:.2g}, "
            f"p90 {r['p90_drift_difference']:.2g}; steps {r['steps_over_reference']:.3f} x"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
