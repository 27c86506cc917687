"""The chaos indicator's threshold from the shipped grid (docs/DYNAMICS.md):
the histogram of the vertical motion's Lyapunov exponent and its agreement
with the shipped maps' tau-twin verdicts.

    python -m devtools.lyapunov_study [--figure FILE] [--json]
"""

import argparse
import json
import sys
from importlib import resources

import numpy as np

from vibtrans.analysis.summary import CHAOS_LYAPUNOV
from vibtrans.maps.sweep import open_map

FLOOR = 1e-5  # |lambda| below this is drawn in the first bin


def _maps():
    root = resources.files("vibtrans_assets") / "maps"
    lyap = open_map(str(root / "vertical-lyapunov.zarr"))
    deformable = {
        mu: open_map(str(root / f"deformable-mu{mu}.zarr"), {"model": "deformable"})
        for mu in ("0.1", "0.3", "1")
    }
    return lyap, deformable


def _point_mass():
    root = resources.files("vibtrans_assets") / "maps"
    lam = open_map(str(root / "point-mass-lyapunov.zarr"))["lyapunov"].values
    twin = open_map(str(root / "point-mass-mu0.3.zarr"), {"model": "point-mass"})
    twin = twin["chaotic"].values == 1
    measured = np.isfinite(lam)
    chaotic = lam > CHAOS_LYAPUNOV
    return {
        "points": int(lam.size),
        "measured": int(measured.sum()),
        "no_impacts_after_the_ramp": int(np.isnan(lam).sum()),
        "rides_the_surface": int(np.isneginf(lam).sum()),
        "measured_below_threshold": int((measured & ~chaotic).sum()),
        "smallest_measured": float(np.min(lam[measured])) if measured.any() else None,
        "twin_chaotic": int(twin.sum()),
        "both_chaotic": int((twin & chaotic).sum()),
        "twin_only_unmeasured": int((twin & ~measured).sum()),
        "twin_only_measured": int((twin & measured & ~chaotic).sum()),
        "lyapunov_only": int((chaotic & ~twin).sum()),
    }


def study():
    lyap, deformable = _maps()
    lam = lyap["lyapunov"].values
    jumping = lyap["contact"].values == 1
    chaotic = lam > CHAOS_LYAPUNOV
    out = {
        "threshold": CHAOS_LYAPUNOV,
        "points": int(lam.size),
        "jumping": int(jumping.sum()),
        "chaotic": int(chaotic.sum()),
        "chaotic_in_permanent_contact": int((chaotic & ~jumping).sum()),
        "negative": int((lam < 0).sum()),
        "most_negative": float(np.nanmin(lam)),
        "undefined": int(np.isnan(lam).sum()),
        "bins_per_decade_jumping": {
            f"[{lo:g}, {hi:g})": int(((lam >= lo) & (lam < hi) & jumping).sum())
            for lo, hi in ((1e-4, 1e-3), (1e-3, 3e-3), (3e-3, 1e-2), (1e-2, 3e-2), (3e-2, 1e-1), (1e-1, 1.0))
        },
        "maps": {},
    }
    for mu, ds in deformable.items():
        twin = ds["chaotic"].values == 1
        # the coarser maps (0.1-decade grids) sit on every other point of the 0.05 grid
        on = (
            lyap["lyapunov"]
            .sel(log_amplitude=ds["log_amplitude"], log_mass=ds["log_mass"], method="nearest", tolerance=1e-6)
            .values
        )
        chaotic = on > CHAOS_LYAPUNOV
        out["maps"][mu] = {
            "twin_chaotic": int(twin.sum()),
            "both_chaotic": int((twin & chaotic).sum()),
            "twin_only": int((twin & ~chaotic).sum()),
            "lyapunov_only": int((~twin & chaotic).sum()),
            "agreement": float(np.mean(twin == chaotic)),
            "points": int(twin.size),
        }
    out["point_mass"] = _point_mass()
    return out, lyap


def figure(lyap, path):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    lam = lyap["lyapunov"].values.ravel()
    jumping = lyap["contact"].values.ravel() == 1
    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    bins = np.linspace(np.log10(FLOOR), 0.0, 61)
    for sel, label in ((~jumping, "permanent contact"), (jumping, "jumping")):
        ax.hist(
            np.log10(np.clip(lam[sel], FLOOR, None)),
            bins=bins,
            alpha=0.6,
            label=f"{label} ({sel.sum()} points)",
        )
    ax.axvline(np.log10(CHAOS_LYAPUNOV), color="k", ls="--", label=f"threshold {CHAOS_LYAPUNOV:g} per period")
    ax.set_yscale("log")
    ax.set_xlabel(
        f"log10 lambda, the vertical motion's largest Lyapunov exponent per "
        f"period\n(first bin: lambda <= {FLOOR:g}, negative values included)"
    )
    ax.set_ylabel("grid points")
    ax.set_title("The shipped grid (121 x 201, 2000 periods, tau 50, standard)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="python -m devtools.lyapunov_study", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--figure", help="write the histogram to this PNG")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    out, lyap = study()
    if a.figure:
        figure(lyap, a.figure)
    print(json.dumps(out, indent=None if a.json else 1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
