"""The figures of docs/DYNAMICS.md: the period-1 orbit's stability over the
shipped map's zones; the chart (`period_one_chart` on the shipped grid, a few
minutes) is read from --chart, else computed there.

    python -m devtools.dynamics_figures [--chart assets/maps/period-one.nc] [--out docs/figures]
"""

import argparse
import json
import math
import os
import sys
from importlib import resources

import numpy as np
import xarray as xr

from vibtrans.analysis import dynamics as Y
from vibtrans.analysis.summary import CHAOS_LYAPUNOV
from vibtrans.maps.sweep import open_map, open_vertical

M_C = 1.5 / (4.0 * math.pi**2)  # w0 = 2 pi: the fundamental contact resonance


def chart(path):
    if os.path.exists(path):
        return xr.load_dataset(path)
    ds = Y.period_one_chart(
        np.round(np.arange(-3.0, 3.0001, 0.05), 10), np.round(np.arange(-5.0, 5.0001, 0.05), 10)
    )
    tmp = path + ".partial"
    ds.to_netcdf(tmp)
    os.replace(tmp, path)
    return ds


def _shipped():
    maps = resources.files("vibtrans_assets") / "maps"
    return (
        open_map(str(maps / "deformable-mu0.3.zarr"), {"model": "deformable"}),
        open_map(str(maps / "vertical-lyapunov.zarr")),
        open_vertical(str(maps / "vertical.nc")),
    )


def stability_numbers(p1):
    """How the period-1 orbit's stability lines up with the shipped regimes (one grid)."""
    drift, lyap, _ = _shipped()
    sync = drift["pattern"].values == 1
    jumping = drift["contact"].values == 1
    chaos = lyap["lyapunov"].values > CHAOS_LYAPUNOV
    exists = p1["exists"].values
    stable_hopping = p1["stable"].values & p1["in_flight"].values
    hyperbolic = exists & ~p1["stable"].values
    la, lm = drift["log_amplitude"].values, drift["log_mass"].values
    edges = {}
    for a in (-0.5, 0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0):
        i = int(np.argmin(np.abs(la - a)))
        doubled = lm[p1["trace"].values[i] < -2.0]
        synchronous = lm[sync[i] & (lm > -1.2)]
        edges[f"{a:g}"] = {
            "period_doubling_log_mass": float(doubled.max()) if doubled.size else None,
            "synchronous_left_edge_log_mass": float(synchronous.min()) if synchronous.size else None,
        }
    patterns = drift["pattern"].values[stable_hopping & ~sync & jumping]
    return {
        "log10_4_m_c": math.log10(4 * M_C),
        "synchronous": int(sync.sum()),
        "synchronous_with_stable_period_one_hopping_orbit": int((sync & stable_hopping).sum()),
        "stable_period_one_hopping": int(stable_hopping.sum()),
        "stable_period_one_hopping_not_synchronous": {
            name: int((patterns == code).sum())
            for code, name in ((2, "multi-synchronous"), (3, "chaotic (twin)"), (4, "irregular"))
        },
        "chaotic": int(chaos.sum()),
        "chaotic_period_one_not_followed": int((chaos & ~exists).sum()),
        "chaotic_period_one_hyperbolic": int((chaos & hyperbolic).sum()),
        "chaotic_period_one_stable": int((chaos & p1["stable"].values).sum()),
        "edges_by_log_amplitude": edges,
    }


def stability_figure(p1, out):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure

    drift, lyap, vertical = _shipped()
    la, lm = drift["log_amplitude"].values, drift["log_mass"].values
    zones = np.zeros(drift["pattern"].shape)  # 0 contact / other jumping
    zones[drift["contact"].values == 1] = 1
    zones[drift["pattern"].values == 1] = 2  # synchronous (shipped map)
    zones[lyap["lyapunov"].values > CHAOS_LYAPUNOV] = 3  # chaotic by the exponent
    fig = Figure(figsize=(8.0, 5.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    cmap = ListedColormap(["#ffffff", "#dcdcdc", "#9ecae1", "#fdae6b"])
    ax.pcolormesh(lm, la, zones, cmap=cmap, vmin=-0.5, vmax=3.5, shading="nearest")
    pl, pm = p1["log_amplitude"].values, p1["log_mass"].values
    tr = p1["trace"].values
    ax.contour(pm, pl, np.where(np.isfinite(tr), tr, 3.0), levels=[-2.0], colors="crimson", linewidths=1.2)
    ax.contour(
        pm, pl, p1["exists"].values.astype(float), levels=[0.5], colors="k", linewidths=1.0, linestyles="--"
    )
    ax.contour(
        pm,
        pl,
        (p1["stable"].values & p1["in_flight"].values).astype(float),
        levels=[0.5],
        colors="navy",
        linewidths=1.0,
    )
    ax.plot(vertical["log_mass"], np.log10(vertical["threshold_amplitude"]), color="k", lw=0.8)
    for factor, name in ((1, "m_c*"), (4, "4 m_c*")):
        ax.axvline(math.log10(factor * M_C), color="0.3", lw=0.6, ls=":")
        ax.text(math.log10(factor * M_C) + 0.05, 2.75, name, fontsize=8)
    handles = [
        ax.plot([], [], color=c, ls=s)[0]
        for c, s in (("crimson", "-"), ("k", "--"), ("navy", "-"), ("k", "-"))
    ]
    from matplotlib.patches import Patch

    handles += [Patch(color=c) for c in ("#9ecae1", "#fdae6b", "#dcdcdc")]
    ax.legend(
        handles,
        [
            "period-1 orbit: trace = -2 (period doubling)",
            "end of the continued period-1 orbit (fold or lost)",
            "stable period-1 hopping orbit (boundary)",
            "jumping threshold A_J*(m*)",
            "synchronous (shipped map, mu 0.3)",
            f"chaotic (Lyapunov exponent > {CHAOS_LYAPUNOV:g})",
            "other jumping",
        ],
        fontsize=7,
        loc="lower left",
    )
    ax.set_xlabel("log10 m*")
    ax.set_ylabel("log10 A*")
    ax.set_xlim(-5, 5)
    ax.set_ylim(-3, 3)
    ax.set_title("The period-1 orbit's stability over the regimes (deformable, tau 50, 2000 periods)")
    fig.savefig(out, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="python -m devtools.dynamics_figures", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--chart", default="assets/maps/period-one.nc")
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    p1 = chart(a.chart)
    stability_figure(p1, os.path.join(a.out, "period-one-stability.png"))
    print(json.dumps(stability_numbers(p1), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
