"""The maps of docs/DYNAMICS.md section 6: a particle that does not roll, a
thin shell and a solid sphere that roll, over the shipped domain (41 x 41
points, mu 0.3, each point run until its drift is decided), their regimes
side by side and the rolling particles' drift over the one's that does not
roll.

    python -m devtools.rolling_maps compute [--store DIR] [--workers N]
    python -m devtools.rolling_maps figure [--store DIR] [--out docs/figures/rolling-regimes.png]

`compute` runs the three sweeps (`vibtrans sweep --rolling R --stop decided
--log-amplitude=-3:3:0.15 --log-mass=-5:5:0.25`, several minutes each on two
cores; an interrupted one resumes) into DIR/rolling-{none,shell,solid}.zarr;
`figure` draws the figure from them and prints the numbers the section
quotes (JSON).
"""

import argparse
import json
import os
import sys

import numpy as np

from vibtrans.core.params import ROLLING_NAMES
from vibtrans.maps.sweep import open_map
from vibtrans.products.design import REGIMES, regime_of
from vibtrans.products.plots import REGIME_COLORS

ROLLINGS = ("none", "shell", "solid")
GRID = ("--log-amplitude=-3:3:0.15", "--log-mass=-5:5:0.25")
STORE = "rolling-maps"
FIGURE = os.path.join("docs", "figures", "rolling-regimes.png")
SYNCHRONOUS = REGIMES.index("synchronous hopping")


def store_path(folder, rolling):
    return os.path.join(folder, f"rolling-{rolling}.zarr")


def compute(folder, workers=None):
    """The three sweeps into `folder` (the library's CLI, as a user runs it)."""
    from vibtrans.cli import main

    os.makedirs(folder, exist_ok=True)
    for rolling in ROLLINGS:
        argv = [
            "sweep",
            "--rolling",
            rolling,
            "--stop",
            "decided",
            *GRID,
            "--out",
            store_path(folder, rolling),
        ]
        if workers:
            argv += ["--workers", str(workers)]
        main(argv)


def load(folder):
    """{rolling: (map, regime index per point)} of the three stores."""
    out = {}
    for rolling in ROLLINGS:
        ds = open_map(store_path(folder, rolling), expect={"model": "deformable", "mu": 0.3})
        regime = regime_of(
            ds["drift"].values, ds["contact"].values, ds["pattern"].values, ds["chaotic"].values
        )
        out[rolling] = (ds, regime)
    return out


def numbers(maps):
    """What section 6 quotes: regime counts, points whose regime changed,
    where the vertical motion's verdicts agree, and the drift ratios."""
    base, base_regime = maps["none"]
    out = {"points": int(base_regime.size)}
    for rolling, (ds, regime) in maps.items():
        row = {"regimes": {name: int((regime == k).sum()) for k, name in enumerate(REGIMES)}}
        if rolling != "none":
            changed = regime != base_regime
            moves = {}
            for i, j in np.argwhere(changed):
                key = f"{REGIMES[base_regime[i, j]]} -> {REGIMES[regime[i, j]]}"
                moves[key] = moves.get(key, 0) + 1
            row["same_regime"] = int((~changed).sum())
            row["moves"] = moves
            for name in ("contact", "pattern", "chaotic"):
                row[f"same_{name}"] = int((ds[name].values == base[name].values).sum())
            j = ROLLING_NAMES[rolling]
            ratio = ds["final_drift_velocity"].values / base["final_drift_velocity"].values
            sync = base_regime == SYNCHRONOUS
            row["synchronous_ratio_near_j"] = int((sync & (np.abs(ratio - j / (1 + j)) < 0.05)).sum())
            row["synchronous_ratio_near_1"] = int((sync & (np.abs(ratio - 1) < 0.05)).sum())
            row["j_over_1_plus_j"] = j / (1 + j)
            for k in (1, 2):  # the sliding regimes: drift over the non-rolling one's
                where = base_regime == k
                row[f"{REGIMES[k]}: median drift ratio"] = float(
                    np.median(ds["drift_velocity"].values[where] / base["drift_velocity"].values[where])
                )
        out[rolling] = row
    return out


def figure(maps, out):
    """Top: the three maps' regimes; bottom: the final drift of the shell and
    of the solid sphere over the non-rolling particle's, and its histogram
    over the synchronous zone (lines at j/(1 + j))."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import BoundaryNorm, ListedColormap

    base, base_regime = maps["none"]
    la, lm = base["log_amplitude"].values, base["log_mass"].values
    extent = (lm[0] - 0.125, lm[-1] + 0.125, la[0] - 0.075, la[-1] + 0.075)
    cmap = ListedColormap([REGIME_COLORS[r] for r in REGIMES])
    norm = BoundaryNorm(np.arange(-0.5, len(REGIMES)), cmap.N)
    fig, axes = plt.subplots(2, 3, figsize=(15, 9.5), constrained_layout=True)
    words = {"none": "does not roll", "shell": "thin shell, j = 2/3", "solid": "solid sphere, j = 2/5"}
    for ax, rolling in zip(axes[0], ROLLINGS):
        regime = np.ma.masked_less(maps[rolling][1], 0)
        ax.imshow(
            regime,
            origin="lower",
            extent=extent,
            aspect="auto",
            cmap=cmap,
            norm=norm,
            interpolation="nearest",
        )
        changed = int((maps[rolling][1] != base_regime).sum())
        ax.set_title(
            f"{words[rolling]}" + ("" if rolling == "none" else f" ({changed} points change regime)")
        )
        ax.set_xlabel("log10 m*")
        ax.set_ylabel("log10 A*")
    handles = [plt.Rectangle((0, 0), 1, 1, color=REGIME_COLORS[r]) for r in REGIMES]
    axes[0][2].legend(handles, REGIMES, loc="lower right", fontsize=8, framealpha=0.9)
    ratio_cmap = plt.get_cmap("viridis").copy()
    ratio_cmap.set_bad("#dddddd")
    sync = base_regime == SYNCHRONOUS
    for ax, rolling in zip(axes[1][:2], ("shell", "solid")):
        ds = maps[rolling][0]
        ratio = ds["final_drift_velocity"].values / base["final_drift_velocity"].values
        shown = np.where(np.abs(base["drift_velocity"].values) > 0.1, ratio, np.nan)
        im = ax.imshow(
            np.ma.masked_invalid(shown),
            origin="lower",
            extent=extent,
            aspect="auto",
            cmap=ratio_cmap,
            vmin=0.0,
            vmax=1.2,
            interpolation="nearest",
        )
        ax.set_title(
            f"{words[rolling]}: final drift over the non-rolling one's\n(grey: no drift without rolling)"
        )
        ax.set_xlabel("log10 m*")
        ax.set_ylabel("log10 A*")
        fig.colorbar(im, ax=ax, shrink=0.85)
    ax = axes[1][2]
    for rolling, colour in (("shell", "#e08214"), ("solid", "#2166ac")):
        ds = maps[rolling][0]
        ratio = (ds["final_drift_velocity"].values / base["final_drift_velocity"].values)[sync]
        ax.hist(ratio, bins=np.linspace(0.0, 1.1, 45), color=colour, alpha=0.6, label=words[rolling])
        j = ROLLING_NAMES[rolling]
        ax.axvline(j / (1 + j), color=colour, linestyle="dashed")
    ax.set_title(
        f"synchronous hopping ({int(sync.sum())} points): final drift ratio\n"
        f"(dashed: j / (1 + j), 2/5 and 2/7)"
    )
    ax.set_xlabel("drift over the non-rolling particle's")
    ax.set_ylabel("points")
    ax.legend(fontsize=8)
    fig.suptitle("A particle that rolls: regimes and drift (deformable, mu 0.3, 2000 periods, stop: decided)")
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m devtools.rolling_maps", description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("compute", "figure"))
    ap.add_argument("--store", default=STORE, help="the maps' folder")
    ap.add_argument("--out", default=FIGURE, help="the figure (figure)")
    ap.add_argument("--workers", type=int, default=None, help="sweep workers (compute)")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if a.what == "compute":
        compute(a.store, a.workers)
        return 0
    maps = load(a.store)
    figure(maps, a.out)
    print(json.dumps(numbers(maps), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
