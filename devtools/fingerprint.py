"""Save every output of the reference runs, to prove a restructuring
bit-identical (`python -m devtools.fingerprint save FILE`, then after the
change `python -m devtools.fingerprint compare FILE`).

Covered: the ten paper points in all three models (whole run plus a
full-resolution window), memory snapshots, random (a*, b*) histories through
the memory diagram (four kinds), first take-offs and threshold amplitudes,
and the Lyapunov exponent's attributes (`simulate(..., lyapunov=True)`) at
the paper points and across the jumping region.
Compared with np.array_equal (NaN equal to NaN); the wall time attribute
`seconds` is left out.
"""

import argparse
import sys

import numpy as np


def _runs():
    from vibtrans import paper_scene, simulate
    from vibtrans.core.kernels.contact import tangential_force_history
    from vibtrans.core.simulate import memory_snapshot
    from vibtrans.core.threshold import first_takeoff, threshold_amplitude

    out = {}
    for k in range(1, 11):
        for model in ("deformable", "point-mass", "vertical"):
            for integ in ("ab4", "verlet"):
                if model == "point-mass" and integ == "verlet":
                    continue
                for periods, window in ((2000.0, (1990.0, 1992.0)), (60.0, None)):
                    sc = paper_scene(k).replace(model=model, integrator=integ, periods=periods)
                    ds = simulate(sc, window=window)
                    key = f"p{k}/{model}/{integ}/{periods:g}"
                    for name, var in ds.variables.items():
                        out[f"{key}/{name}"] = np.asarray(var.values)
                    for name, val in ds.attrs.items():
                        if name != "seconds":
                            out[f"{key}/@{name}"] = np.asarray("None" if val is None else val)
        for t in (0.37, 3.5, 17.25):
            snap = memory_snapshot(paper_scene(k).replace(model="deformable"), t=t)
            for name, val in snap.items():
                out[f"snap{k}/{t}/{name}"] = np.asarray(val)
    rng = np.random.default_rng(20261123)
    for i in range(40):
        n = 400
        kind = i % 4
        if kind == 0:  # random walk in both
            a = 1.0 + np.cumsum(rng.normal(0, 0.05, n))
            b = np.cumsum(rng.normal(0, 0.05, n))
        elif kind == 1:  # oscillating normal load, drifting tangent
            s = np.linspace(0, 20, n)
            a = 1.0 + 0.8 * np.sin(s * rng.uniform(0.5, 3))
            b = 0.3 * np.sin(s * rng.uniform(0.5, 3)) + 0.01 * s
        elif kind == 2:  # with losses of contact
            a = 0.5 + np.cumsum(rng.normal(0, 0.1, n))
            b = np.cumsum(rng.normal(0, 0.2, n))
        else:  # large random jumps
            a = rng.uniform(-0.2, 3.0, n)
            b = rng.uniform(-3.0, 3.0, n)
        T, sh, st = tangential_force_history(a, b)
        out[f"hist{i}/T"], out[f"hist{i}/sh"], out[f"hist{i}/st"] = T, sh, st
    lyapunov_scenes = [(f"p{k}", paper_scene(k)) for k in range(1, 11)]
    lyapunov_scenes += [
        (f"a{la}m{lm}", paper_scene(1).replace(amplitude=10.0**la, mass=10.0**lm))
        for la in (-1.5, 0.0, 0.5, 1.5, 2.5)
        for lm in (-4.0, -2.0, 0.0, 3.0)
    ]
    for name, sc in lyapunov_scenes:
        for model in ("deformable", "vertical"):
            for integ in ("ab4", "verlet"):
                ds = simulate(sc.replace(model=model, integrator=integ, periods=300.0), lyapunov=True)
                for attr in ("lyapunov", "lyapunov_from", "lyapunov_start", "steps"):
                    val = ds.attrs[attr]
                    out[f"lyapunov/{name}/{model}/{integ}/{attr}"] = np.asarray(
                        "None" if val is None else val
                    )
                out[f"lyapunov/{name}/{model}/{integ}/y"] = np.asarray(ds["y"].values)
    for lm in (-3.0, -1.0, 0.5, 2.0):
        for la in (-1.0, 0.0, 1.0):
            out[f"takeoff/{la}/{lm}"] = np.asarray(first_takeoff(10**la, 10**lm, periods=300.0))
        out[f"threshold/{lm}"] = np.asarray(threshold_amplitude(10**lm, periods=200.0))
    return out


def _equal(a, b):
    if a.shape != b.shape or a.dtype.kind != b.dtype.kind:
        return False
    if a.dtype.kind == "f":
        return np.array_equal(a, b, equal_nan=True)
    return np.array_equal(a, b)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=("save", "compare"))
    ap.add_argument("file")
    args = ap.parse_args(argv)
    runs = _runs()
    if args.action == "save":
        np.savez_compressed(args.file, **runs)
        print(f"saved {len(runs)} arrays to {args.file}")
        return 0
    ref = np.load(args.file)
    missing = sorted(set(ref.files) ^ set(runs))
    differ = [k for k in ref.files if k in runs and not _equal(ref[k], runs[k])]
    for k in missing[:20]:
        print("only in one:", k)
    for k in differ[:20]:
        print("differs:", k)
    print(f"{len(ref.files)} reference arrays: {len(differ)} differ, {len(missing)} present on one side only")
    return 1 if differ or missing else 0


if __name__ == "__main__":
    sys.exit(main())
