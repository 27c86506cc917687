"""HoloViews figures built from vibtrans results, shared by the explorer
(bokeh) and the exporter (matplotlib, headless): one definition per figure.

Nothing here integrates anything: inputs are Datasets from `simulate`,
`open_map` and `threshold_curve`.
"""
import numpy as np
import holoviews as hv

from . import records as R
from .contact import STATE_NAMES
from .params import PAPER_POINTS

STATE_COLORS = {0: "#d9d9d9", 1: "#1b9e77", 2: "#e6ab02", 3: "#d95f02"}   # flight, stick, partial, sliding
CMAP = "RdBu_r"          # blue: against the wave, red: with it (paper Fig. 3)
T_DIM = hv.Dimension("time", label="t*", unit="periods")
LOG_A = hv.Dimension("log_amplitude", label="log10 A*")
LOG_M = hv.Dimension("log_mass", label="log10 m*")


def colour_scale(v, v0=0.1):
    """The paper's colour quantity C (eq. colormap): signed log10(|v|/v0),
    normalised separately on each side, 0 inside |v| <= v0."""
    v = np.asarray(v, dtype=float)
    c = np.zeros_like(v)
    pos = v > v0
    neg = v < -v0
    lp = np.log10(np.where(pos, v, v0) / v0)
    ln = np.log10(np.where(neg, -v, v0) / v0)
    if pos.any():
        c[pos] = lp[pos] / max(lp[pos].max(), 1e-300)
    if neg.any():
        c[neg] = -ln[neg] / max(ln[neg].max(), 1e-300)
    c[~np.isfinite(v)] = np.nan
    return c


def _bounds(ds):
    la = ds["log_amplitude"].values
    lm = ds["log_mass"].values
    da = (la[1] - la[0]) / 2 if la.size > 1 else 0.5
    dm = (lm[1] - lm[0]) / 2 if lm.size > 1 else 0.5
    return (la[0] - da, lm[0] - dm, la[-1] + da, lm[-1] + dm)


def drift_map(ds, v0=0.1, chaotic="grey", title=""):
    """Drift-velocity heatmap over (log10 A*, log10 m*) in the paper's scale.

    chaotic: "grey" (chaotic points drawn grey: their colour is not a
    property of the scene) or "colour" (drawn like the others).
    """
    v = ds["drift_velocity"].values                      # (amplitude, mass)
    c = colour_scale(v, v0)
    hover_v = v.T
    chaos = (ds["chaotic"].values == 1).T
    if chaotic == "grey":
        c = np.where((ds["chaotic"].values == 1), np.nan, c)
    img = hv.Image((ds["log_amplitude"].values, ds["log_mass"].values, c.T, hover_v),
                   kdims=[LOG_A, LOG_M], vdims=[hv.Dimension("C", range=(-1, 1)),
                                                hv.Dimension("v", label="<v*>")],
                   label=title)
    img = img.opts(cmap=CMAP, clim=(-1, 1), colorbar=True)
    layers = [img]
    if chaotic == "grey" and chaos.any():
        grey = hv.Image((ds["log_amplitude"].values, ds["log_mass"].values,
                         np.where(chaos, 1.0, np.nan)), kdims=[LOG_A, LOG_M],
                        vdims=["chaotic"]).opts(cmap=["#9e9e9e"], alpha=0.9)
        layers.append(grey)
    return hv.Overlay(layers)


def jumping_boundary(vertical, model="deformable"):
    """The jumping boundary as a curve in the (log10 A*, log10 m*) plane."""
    lm = vertical["log_mass"].values
    var = "threshold_amplitude" if model == "deformable" else "point_mass_threshold_amplitude"
    la = np.log10(vertical[var].values)
    return hv.Curve((la, lm), LOG_A, LOG_M, label="jumping boundary").opts(color="black")


def resonance_lines(vertical):
    """Horizontal lines at the fundamental and subharmonic resonances."""
    lines = []
    for key in ("fundamental", "subharmonic"):
        name = f"resonance_{key}_log_mass"
        if name in vertical.attrs:
            lines.append(hv.HLine(vertical.attrs[name]).opts(color="black", line_dash="dashed")
                         if hv.Store.current_backend == "bokeh" else
                         hv.HLine(vertical.attrs[name]).opts(color="black", linestyle="dashed"))
    return hv.Overlay(lines)


def paper_points(model="deformable"):
    """The paper's labelled points of one model."""
    pts = [(la, lm, str(k)) for k, (la, lm, m) in PAPER_POINTS.items() if m == model]
    xs, ys, ls = zip(*pts)
    points = hv.Points((xs, ys), [LOG_A, LOG_M]).opts(color="black", size=6)
    labels = hv.Labels((np.array(xs) + 0.12, np.array(ys) + 0.12, ls), [LOG_A, LOG_M], "label")
    return points * labels


def _curve(ds, var, label, color):
    return hv.Curve((ds["time"].values, ds[var].values), T_DIM,
                    hv.Dimension(var, label=label), label=label).opts(color=color)


def state_timeline(ds):
    """Contact states as coloured bands over the samples' time span (exact
    change times from the events)."""
    time = ds["time"].values
    t_start, t_end = float(time[0]), float(time[-1])
    kinds = ds["event_kind"].values
    t_ev = ds["event_time"].values[kinds == R.STATE_CHANGE]
    v_ev = ds["event_value"].values[kinds == R.STATE_CHANGE].astype(int)
    inside = (t_ev > t_start) & (t_ev < t_end)
    t0 = np.concatenate([[t_start], t_ev[inside]])
    vals = np.concatenate([[int(ds["state"].values[0])], v_ev[inside]])
    t1 = np.concatenate([t_ev[inside], [t_end]])
    rects = [(a, 0, b, 1, STATE_NAMES[v], STATE_COLORS[v])
             for a, b, v in zip(t0, t1, vals) if b > a]
    el = hv.Rectangles(rects, kdims=[T_DIM, hv.Dimension("y0", label="state"), "x1", "y1"],
                       vdims=["state", "color"])
    return el.opts(color="color", yaxis=None)


def trajectory_panels(ds):
    """The paper's trajectory figure: normal and tangential displacements,
    forces and relative velocity, and the contact-state timeline, on one
    shared time axis."""
    normal = (_curve(ds, "a", "a*", "#1f77b4") * _curve(ds, "y", "y*", "#ff7f0e")).relabel(
        "normal: a*(t), y*(t)")
    tangential = (_curve(ds, "b", "b*", "#2ca02c") * _curve(ds, "x", "x*", "#d62728")).relabel(
        "tangential: b*(t), x*(t)")
    forces = (_curve(ds, "N", "N*", "#9467bd") * _curve(ds, "T", "T*", "#8c564b")
              * _curve(ds, "bdot", "b*'", "#7f7f7f")).relabel("forces: N*, T*, b*'")
    timeline = state_timeline(ds).relabel("contact state")
    return hv.Layout([normal, tangential, forces, timeline]).cols(1)
