"""Figures shared by the explorer (bokeh) and the exporter (matplotlib): one
definition per figure.  Maps, vertical curve and memory diagram are HoloViews
elements; the trajectory figure is plain data (`trajectory_figure`) that each
backend draws directly.  Style options are set per loaded backend with its own
names, so build figures after loading the backends that will render them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import holoviews as hv
import numpy as np

from vibtrans.analysis.summary import TWIN_TAU_OFFSET, V0
from vibtrans.core.errors import InputError
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.core.params import PAPER_POINTS
from vibtrans.products.designconst import AXIS_LABELS, REGIMES, velocity_unit

if TYPE_CHECKING:
    import xarray as xr

STATE_COLORS = {0: "#d9d9d9", 1: "#1b9e77", 2: "#e6ab02", 3: "#d95f02"}  # flight, stick, partial, sliding
CMAP = "RdBu_r"  # blue: against the wave, red: with it (paper Fig. 3)
LOG_A = hv.Dimension("log_amplitude", label="log10 A*")
LOG_M = hv.Dimension("log_mass", label="log10 m*")
M_DIM = hv.Dimension("mass", label="m*")
AJ_DIM = hv.Dimension("threshold_amplitude", label="A_J*")
H_DIM = hv.Dimension("h", label="h (contact depth)", unit="a0")
W_DIM = hv.Dimension("w", label="w (spring anchor)", unit="theta mu a0")
U_DIM = hv.Dimension("u", label="u = b* - w", unit="theta mu a0")
CX_DIM = hv.Dimension("cx", label="x", unit="sqrt(R a0)")
CZ_DIM = hv.Dimension("cz", label="z", unit="sqrt(R a0)")

BACKENDS = ("bokeh", "matplotlib")
FRAGMENT = 2.0  # periods shown at full resolution by trajectory_figure
OVERVIEW_SAMPLES = 5  # samples per period of the whole-run view (app and exports)


# ---------------------------------------------------------------- styling
def style(obj: Any, common: Any = None, bokeh: Any = None, matplotlib: Any = None) -> Any:
    """Apply `common` options plus each backend's own to `obj`, for every loaded
    HoloViews backend (bokeh is loaded if none is)."""
    if not hv.Store.renderers:
        import holoviews.plotting.bokeh  # noqa: F401
    per = {"bokeh": bokeh or {}, "matplotlib": matplotlib or {}}
    for backend in [b for b in BACKENDS if b in hv.Store.renderers]:
        kw = {**(common or {}), **per[backend]}
        if kw:
            obj = obj.opts(backend=backend, **kw)
    return obj


def _coloured(img, cmap, clim, clabel, hover, ticks=None, **common):
    """`img` with a colour bar (`ticks`: [(C, label)]) and a hover naming its axes, then `hover`."""
    bk = dict(tools=["hover"], hover_tooltips=[(d.label, f"${c}") for d, c in zip(img.kdims, "xy")] + hover)
    mp = {}
    if ticks is not None:
        bk["cticks"] = mp["cbar_ticks"] = ticks
    return style(img, dict(cmap=cmap, clim=clim, colorbar=True, clabel=clabel, **common), bk, mp)


def _map_image(ds, *values, vdims, label=""):
    """An image over a map's (log10 A*, log10 m*) of `values`, (amplitude, mass) arrays."""
    axes = (ds["log_amplitude"].values, ds["log_mass"].values)
    return hv.Image((*axes, *(v.T for v in values)), kdims=[LOG_A, LOG_M], vdims=vdims, label=label)


def _styled_line(el, color, width=None, dash=None):
    bk, mp = {"color": color}, {"color": color}
    if width is not None:
        bk["line_width"], mp["linewidth"] = width, width
    if dash is not None:
        bk["line_dash"], mp["linestyle"] = dash, dash
    return style(el, bokeh=bk, matplotlib=mp)


# ---------------------------------------------------------------- drift map
def colour_scale(v: Any, v0: float = V0) -> np.ndarray:
    """The paper's colour C: signed log10(|v|/v0), normalised per side, 0 for |v| <= v0."""
    v = np.asarray(v, dtype=float)
    c = np.zeros_like(v)
    for sign in (1, -1):
        side = sign * v > v0
        if side.any():
            lg = np.log10(sign * v[side] / v0)
            c[side] = sign * lg / max(lg.max(), 1e-300)
    c[~np.isfinite(v)] = np.nan
    return c


def colour_ticks(v: Any, v0: Any = V0, n: int = 3) -> dict[float, str]:
    """Colour-bar ticks {C: drift velocity label} of the paper's scale."""
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    ticks = {0.0: f"\u00b1{v0:g}"}
    for sign in (1, -1):
        side = sign * v[sign * v > v0]
        if side.size == 0:
            continue
        top = np.log10(side.max() / v0)
        for c in np.linspace(0, 1, n + 1)[1:]:
            ticks[sign * float(c)] = _short(sign * v0 * 10 ** (c * top))
    return dict(sorted(ticks.items()))


def _short(v):
    """Two significant digits, without exponents below 1e6 (2813 -> 2800)."""
    a = abs(v)
    if a == 0 or not np.isfinite(a) or a >= 1e6 or a < 1e-3:
        return f"{v:.2g}"
    return f"{round(v, -int(np.floor(np.log10(a))) + 1):g}"


def map_bounds(ds: xr.Dataset) -> tuple[Any, Any, Any, Any]:
    la = ds["log_amplitude"].values
    lm = ds["log_mass"].values
    da = (la[1] - la[0]) / 2 if la.size > 1 else 0.5
    dm = (lm[1] - lm[0]) / 2 if lm.size > 1 else 0.5
    return (la[0] - da, lm[0] - dm, la[-1] + da, lm[-1] + dm)


# ---------------------------------------------------------------- map key
# One legend below the plot collects the entries of every layer (a legend
# inside the map covered its corner and took its clicks).  An entry:
# (label, "patch", (fill, edge)) or (label, "line", (colour, width, dash)).
KEY_NAME = "vibtrans-map-key"
CHAOTIC_GREY = "#9e9e9e"
BOUNDARY_LINE = ("black", 1.5, None)
RESONANCE_LINE = ("black", 1.0, "dashed")
CHAOTIC_LABEL = f"grey: chaotic (tau + {TWIN_TAU_OFFSET:g} twin disagrees)"
BOUNDARY_LABEL = "jumping boundary"
RESONANCE_LABEL = "resonances (fundamental, subharmonic)"
LINEAR_RESONANCE_LINE = ("black", 1.5, "dotted")  # a closed form, not measured lines
LINEAR_RESONANCE_LABEL = "linear contact resonance N*'(1)/(4 pi^2)"


def white_label(v0: float = V0) -> str:
    # short: the key's two columns fit the map's width on a 1024 px screen
    return f"white: no drift (|v*| <= {v0:g})"


_BOKEH_KEY = dict(name=KEY_NAME, orientation="horizontal", ncols=2, margin=4, padding=4, spacing=10)
_BOKEH_KEY.update(border_line_alpha=0, background_fill_alpha=0)
# below the tick labels and the axis label (offset in font sizes)
_MPL_KEY: dict[str, Any] = dict(loc="upper center", bbox_to_anchor=(0.5, 0.0), borderaxespad=3.4, ncols=2)
_MPL_KEY.update(frameon=False, handlelength=1.8, columnspacing=1.2, fontsize="small")


def _bokeh_key(entries):
    def hook(plot, element):
        from bokeh.models import ColumnDataSource, Legend, LegendItem, Line, Quad

        fig = plot.state
        key = next((m for m in fig.below if getattr(m, "name", None) == KEY_NAME), None)
        if key is None:
            key = Legend(label_text_font_size="9pt", **_BOKEH_KEY)
            fig.add_layout(key, "below")
        have = {getattr(item.label, "value", item.label) for item in key.items}
        for label, kind, spec, shown in entries:
            if label in have:  # hooks run again on a re-render
                continue
            if kind == "patch":
                glyph = Quad(left=0, right=0, top=0, bottom=0, fill_color=spec[0], line_color=spec[1])
            else:
                glyph = Line(x=0, y=0, line_color=spec[0], line_width=spec[1], line_dash=spec[2] or "solid")
            r = fig.add_glyph(ColumnDataSource({}), glyph)  # drawn only as the swatch
            key.items.append(LegendItem(label=label, renderers=[r], visible=shown))

    return hook


def _mpl_key(entries):
    def hook(plot, element):
        from matplotlib.artist import Artist
        from matplotlib.legend import Legend
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        ax = plot.handles["axis"]
        old = next((a for a in ax.artists if a.get_gid() == KEY_NAME), None)
        mine = list(old.entries) if old is not None else []
        mine += [e[:3] for e in entries if e[3] and e[0] not in {m[0] for m in mine}]
        handles: list[Artist] = []
        for _label, kind, spec in mine:
            if kind == "patch":
                handles.append(Patch(facecolor=spec[0], edgecolor=spec[1], linewidth=0.6))
            else:
                handles.append(Line2D([], [], color=spec[0], linewidth=spec[1], linestyle=spec[2] or "solid"))
        if old is not None:
            old.remove()
        key = Legend(ax, handles, [m[0] for m in mine], **_MPL_KEY)
        key.set_gid(KEY_NAME)
        key.entries = mine  # type: ignore[attr-defined]  # read back at the next redraw
        ax.add_artist(key)
        key.set_clip_on(False)  # (add_artist clips to the axes: out of tight layouts)

    return hook


def _keyed(el, entries):
    """`el` with its entries (label, kind, style[, shown]) in the map's key; an
    entry not shown is hidden in the Bokeh key and left out of matplotlib's."""
    entries = [(*e[:3], e[3] if len(e) > 3 else True) for e in entries]
    return style(el, bokeh=dict(hooks=[_bokeh_key(entries)]), matplotlib=dict(hooks=[_mpl_key(entries)]))


def drift_map(
    ds: xr.Dataset, v0: float = V0, chaotic: str = "grey", title: str = "", always_grey: bool = False
) -> hv.Overlay:
    """Drift-velocity heatmap over (log10 A*, log10 m*) in the paper's scale.

    chaotic: "grey" (chaotic points grey) or "colour".  always_grey: keep the
    grey layer and its key entry (hidden) when empty, so every map has the
    same parts and the explorer updates it in place.
    """
    v = ds["drift_velocity"].values  # (amplitude, mass)
    c = colour_scale(v, v0)
    chaos = (ds["chaotic"].values == 1).T
    if chaotic == "grey":
        c = np.where(chaos.T, np.nan, c)
    vdims = [hv.Dimension("C", range=(-1, 1)), hv.Dimension("v", label="<v*>"), "chaotic"]
    img = _map_image(ds, c, v, chaos.T.astype(float), vdims=vdims, label=title)
    ticks = list(colour_ticks(v, v0).items())
    hover = [("<v*>", "@{v}"), (f"chaotic (1: {chaos_reason(ds)})", "@{chaotic}")]
    clabel = f"<v*> (signed log scale)\nwhite: |v*| <= v0* = {v0:g}"
    img = _coloured(img, CMAP, (-1, 1), clabel, hover, ticks)
    key: list[tuple] = [(white_label(v0), "patch", ("white", "#606060"))]
    layers = []
    shown = chaotic == "grey" and bool(chaos.any())
    if shown or always_grey:
        # an all-NaN image has no range: a hidden layer holds ones
        mask = np.where(chaos, 1.0, np.nan) if chaos.any() else np.ones(chaos.shape)
        grey = _map_image(ds, mask.T, vdims=["chaotic"])
        # no hover of its own: it would cover the map's
        layers.append(style(grey, dict(cmap=[CHAOTIC_GREY], alpha=0.9), dict(tools=[], visible=shown)))
        label = f"grey: chaotic ({chaos_reason(ds, short=True)})"
        key.append((label, "patch", (CHAOTIC_GREY, CHAOTIC_GREY), shown))
    return hv.Overlay([_keyed(img, key), *layers])


def chaos_reason(ds: xr.Dataset, short: bool = False) -> str:
    """What a map's chaotic points mean, from its chaos source."""
    if ds.attrs.get("chaos") == "lyapunov":
        from vibtrans.analysis.summary import CHAOS_LYAPUNOV

        if short:
            return f"Lyapunov > {CHAOS_LYAPUNOV:g}/period"
        return f"Lyapunov exponent > {CHAOS_LYAPUNOV:g} per period"
    return f"{'' if short else 'the '}tau + {TWIN_TAU_OFFSET:g} twin disagrees"


def jumping_boundary(vertical: xr.Dataset, model: str = "deformable") -> Any:
    """The jumping boundary as a curve in the (log10 A*, log10 m*) plane."""
    lm = vertical["log_mass"].values
    var = "threshold_amplitude" if model == "deformable" else "point_mass_threshold_amplitude"
    la = np.log10(vertical[var].values)
    curve = _styled_line(hv.Curve((la, lm), LOG_A, LOG_M), *BOUNDARY_LINE)
    return _keyed(curve, [(BOUNDARY_LABEL, "line", BOUNDARY_LINE)])


def resonance_lines(vertical: xr.Dataset, shown: bool = True) -> hv.Overlay:
    """Lines at the fundamental and subharmonic resonances (hidden unless `shown`)."""
    lines = []
    for key in ("fundamental", "subharmonic"):
        name = f"resonance_{key}_log_mass"
        if name in vertical.attrs:
            line = _styled_line(hv.HLine(vertical.attrs[name]), *RESONANCE_LINE)
            lines.append(line if shown else style(line, bokeh=dict(visible=False)))
    if lines:
        lines[0] = _keyed(lines[0], [(RESONANCE_LABEL, "line", RESONANCE_LINE, shown)])
    return hv.Overlay(lines)


def linear_resonance_line(log_mass: float, label: str = LINEAR_RESONANCE_LABEL) -> Any:
    """A line at a profile's linear contact resonance log10 m*, in the key as `label`."""
    line = _styled_line(hv.HLine(float(log_mass)), *LINEAR_RESONANCE_LINE)
    return _keyed(line, [(label, "line", LINEAR_RESONANCE_LINE)])


def paper_points(model: str = "deformable", color: str = "black") -> Any:
    """The paper's labelled points of one model."""
    pts = [(la, lm, str(k)) for k, (la, lm, m) in PAPER_POINTS.items() if m == model]
    xs, ys, ls = zip(*pts)
    points = style(hv.Points((xs, ys), [LOG_A, LOG_M]), dict(color=color), dict(size=6), dict(s=18))
    y = np.array(ys)
    # labels up and right of their point; below it at the map's top edge (point 7)
    dy = np.where(y > 4.5, -0.45, 0.12)
    labels = hv.Labels((np.array(xs) + 0.12, y + dy, ls), [LOG_A, LOG_M], "label")
    mp = dict(color=color, size=11, horizontalalignment="left", verticalalignment="bottom")
    labels = style(labels, bokeh=dict(text_color=color), matplotlib=dict(weight="bold", **mp))
    return points * labels


# ---------------------------------------------------------------- vertical
def vertical_curves(vertical: xr.Dataset) -> Any:
    """A_J*(m*) of both models on log axes (paper Fig. 2), resonances marked."""
    m = 10.0 ** vertical["log_mass"].values
    aj = vertical["threshold_amplitude"].values
    pm = vertical["point_mass_threshold_amplitude"].values
    pm = hv.Curve((m, pm), M_DIM, AJ_DIM, label="material point 1/(4 pi^2 m*)")
    de = hv.Curve((m, aj), M_DIM, AJ_DIM, label="deformable (Hertz)")
    layers = [_styled_line(de, "#1f77b4", 2), _styled_line(pm, "black", 1.5, "dashed")]
    names = {"fundamental": "m_c*", "subharmonic": "4 m_c*"}
    for key, value in vertical.attrs.items():  # the resonances stored with the curve
        if not (key.startswith("resonance_") and key.endswith("_log_mass")):
            continue
        name, lm = key[len("resonance_") : -len("_log_mass")], float(value)
        color = "#d62728" if name in names else "grey"
        layers.append(_styled_line(hv.VLine(10.0**lm), color, width=1, dash="dotted"))
        if name in names:
            depth = float(np.interp(lm, vertical["log_mass"].values, aj))
            text = hv.Text(10.0**lm, depth / 2.5, names[name], halign="center", valign="top", fontsize=10)
            layers.append(style(text, bokeh=dict(text_color=color), matplotlib=dict(color=color)))
    finite = aj[np.isfinite(aj) & (aj > 0)]
    lo = 10.0 ** (np.floor(np.log10(finite.min())) - 1) if finite.size else 1e-3
    hi = 10.0 ** (np.ceil(np.log10(finite.max())) + 0.3) if finite.size else 1e4
    opts = dict(logx=True, logy=True, legend_position="top_right", ylim=(lo, hi), xlabel="m*")
    return style(hv.Overlay(layers).relabel("Jumping threshold A_J*(m*)"), dict(ylabel="A_J*", **opts))


# ---------------------------------------------------------------- trajectories
# Defined once as data, drawn by export (matplotlib, Bokeh) and the explorer's
# live view, not through HoloViews: its matplotlib backend took 10-17 s for
# the twelve panels (`vibtrans bench --export`).
OVERVIEW_BINS = 1000  # about 1.5 bins per pixel column at the default 11 in, 150 dpi


def overview_samples(ds: xr.Dataset, window_samples: int = 200) -> xr.Dataset:
    """The run with its full-resolution window thinned to about
    `window_samples` samples (first and last kept; events kept whole)."""
    w0, w1 = ds.attrs.get("window_start"), ds.attrs.get("window_end")
    if w0 is None or w1 is None:
        return ds
    t = ds["time"].values
    inside = np.flatnonzero((t > w0) & (t < w1))
    if inside.size <= window_samples:
        return ds
    k = int(np.ceil(inside.size / window_samples))
    keep = np.ones(t.size, bool)
    keep[inside] = False
    keep[inside[::k]] = True
    keep[inside[-1]] = True
    return ds.isel(time=keep)


def binned(t: Any, columns: Any, bins: Any) -> dict[str, np.ndarray]:
    """Per-bin mean, min and max of each column over `bins` equal time bins
    (empty bins dropped, NaN left out): {"time": centres, c, c_lo, c_hi}."""
    t = np.asarray(t, dtype=float)
    edges = np.linspace(t[0], t[-1], int(bins) + 1)
    start = np.unique(np.searchsorted(t, edges[:-1], side="left"))
    start = start[start < t.size]
    stop = np.r_[start[1:], t.size]
    out = {"time": 0.5 * (t[start] + t[stop - 1])}
    for c, v in columns.items():
        v = np.asarray(v, dtype=float)
        ok = np.isfinite(v)
        count = np.add.reduceat(ok.astype(float), start)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[c] = np.add.reduceat(np.where(ok, v, 0.0), start) / count
        out[f"{c}_lo"] = np.fmin.reduceat(np.where(ok, v, np.nan), start)
        out[f"{c}_hi"] = np.fmax.reduceat(np.where(ok, v, np.nan), start)
    return out


def _state_time(ds, bins):
    """(edges, time): `bins` + 1 edges and the periods spent in each state per bin."""
    t0, t1, vals = _state_runs(ds)
    edges = np.linspace(t0[0], t1[-1], bins + 1)
    # time in each state up to each edge: the runs before it, plus the part of its run
    n = len(STATE_NAMES)
    own = np.zeros((t0.size, n))
    own[np.arange(t0.size), vals] = t1 - t0
    cum = np.vstack([np.zeros(n), np.cumsum(own, axis=0)])
    r = np.clip(np.searchsorted(t0, edges, side="right") - 1, 0, t0.size - 1)
    at = cum[r] + np.where(np.arange(n) == vals[r][:, None], (np.minimum(edges, t1[r]) - t0[r])[:, None], 0.0)
    return edges, np.diff(at, axis=0)


def _dominant_states(ds, bins):
    """(t0, t1, state) runs of the state filling most of each of `bins` bins."""
    edges, share = _state_time(ds, bins)
    dom = share.argmax(axis=1)
    cut = np.flatnonzero(np.diff(dom)) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [bins]])
    return edges[starts], edges[ends], dom[starts]


def state_shares(ds: xr.Dataset, bins: int) -> tuple[Any, np.ndarray]:
    """(edges, shares): each bin's time share per contact state (rows sum to 1)."""
    edges, time = _state_time(ds, int(bins))
    total = time.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return edges, np.where(total > 0, time / total, 0.0)


def strip_outline(edges: Any, shares: Any, code: Any) -> tuple[np.ndarray, np.ndarray]:
    """One closed polygon (x, y) of state `code`'s layer in a strip stacking
    each bin's shares from the bottom: adjacent bins leave no seams."""
    top = np.cumsum(shares, axis=1)[:, code]
    bottom = top - shares[:, code]
    x = np.repeat(edges, 2)[1:-1]  # e0 e1 e1 e2 e2 ... en
    return (np.concatenate([x, x[::-1]]), np.concatenate([np.repeat(top, 2), np.repeat(bottom, 2)[::-1]]))


def _state_runs(ds):
    """Exact (t0, t1, state) runs over the samples' time span."""
    time = ds["time"].values
    t_start, t_end = float(time[0]), float(time[-1])
    kinds = ds["event_kind"].values
    t_ev = ds["event_time"].values[kinds == R.STATE_CHANGE]
    v_ev = ds["event_value"].values[kinds == R.STATE_CHANGE].astype(int)
    inside = (t_ev > t_start) & (t_ev < t_end)
    t0 = np.concatenate([[t_start], t_ev[inside]])
    vals = np.concatenate([[int(ds["state"].values[0])], v_ev[inside]])
    t1 = np.concatenate([t_ev[inside], [t_end]])
    return t0, t1, vals


def state_bands(ds: xr.Dataset, bins: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t0, t1, state) of the exact runs, or of the dominant state per bin."""
    t0, t1, vals = _dominant_states(ds, int(bins)) if bins else _state_runs(ds)
    keep = t1 > t0
    return t0[keep], t1[keep], vals[keep]


# A rolling particle's rotation (docs/MODEL.md section 11), drawn only for a
# run that rolls: omega R* and the contact point's slip, a0 per period
ROLLING_VARIABLES = ("roll_velocity", "slip_velocity")
ROLLING_PANEL = (
    "rotation: omega R*(t), contact slip",
    "omega R*, slip (a0/period)",
    [("roll_velocity", "omega R*", "#17becf"), ("slip_velocity", "contact slip", "#bcbd22")],
)


def rolls(ds: Any) -> bool:
    """Does the run's particle roll (its Dataset has `ROLLING_VARIABLES`)?"""
    return all(v in ds.variables for v in ROLLING_VARIABLES)


def panel_spec(
    rigid: Any, split_velocity: bool = False, rolling: bool = False
) -> list[tuple[str, str, list[tuple[str, str, str]]]]:
    """The line panels: [(title, y label, [(variable, legend label, colour)])];
    rolling: the rotation's panel last (`ROLLING_PANEL`)."""
    forces = [("N", "N*", "#9467bd"), ("T", "T*", "#8c564b")]
    if rigid:
        return [
            ("normal: y*(t)", "y* (a0)", [("y", "y*", "#ff7f0e")]),
            ("tangential: x*(t)", "x* (a0)", [("x", "x*", "#d62728")]),
            ("forces: N*, T*", "N*, T*", forces),
        ]
    panels = [
        ("normal: a*(t), y*(t)", "a*, y* (a0)", [("a", "a*", "#1f77b4"), ("y", "y*", "#ff7f0e")]),
        (
            "tangential: b*(t), x*(t)",
            "b* (theta mu a0), x* (a0)",
            [("b", "b*", "#2ca02c"), ("x", "x*", "#d62728")],
        ),
    ]
    if split_velocity:
        panels += [
            ("forces: N*, T*", "N*, T*", forces),
            ("relative tangential velocity b*'", "b*' (theta mu a0/period)", [("bdot", "b*'", "#7f7f7f")]),
        ]
    else:
        panels += [("forces: N*, T*, b*'", "N*, T*, b*'", forces + [("bdot", "b*'", "#7f7f7f")])]
    return panels + ([ROLLING_PANEL] if rolling else [])


def timeline_title(bins: int | None = None) -> str:
    return "contact state" + (" (dominant per bin)" if bins else "")


BINNED_NOTE = " (mean, min-max per bin)"  # a binned panel's title ends so


def twin_spec(tau: float, label: str) -> tuple[str, str, list[Any]]:
    """The twin panel: (title, y label, [(legend label, colour, dash)] of run and twin)."""
    # a tau twin is the same scene; another model is a comparison, not a twin
    title = (
        f"x*(t) and its {label} twin"
        if label.startswith("tau")
        else f"x*(t) and the {label} run of the same scene"
    )
    return (title, "x* (a0)", [(f"x*, tau = {tau:g}", "#d62728", None), (f"x*, {label}", "black", "dashed")])


TWIN_LABEL = f"tau + {TWIN_TAU_OFFSET:g}"


def fragment_window(ds: xr.Dataset, window: tuple[float, float] | None = None) -> tuple[float, float]:
    """`window`, else the run's recorded window, else its last FRAGMENT periods."""
    if window is not None:
        return float(window[0]), float(window[1])
    if ds.attrs.get("window_start") is not None and ds.attrs.get("window_end") is not None:
        w0, w1 = float(ds.attrs["window_start"]), float(ds.attrs["window_end"])
        if w1 > w0:
            return w0, w1
    t1 = float(ds["time"].values[-1])
    return max(float(ds["time"].values[0]), t1 - FRAGMENT), t1


@dataclass(frozen=True)
class Trace:
    """One line of a panel; with `lo`, `hi`, `value` holds per-bin means and
    (lo, hi) the bin's envelope."""

    var: str
    label: str
    colour: str
    time: np.ndarray
    value: np.ndarray
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None
    dash: str | None = None  # None: solid; "dashed"


# A panel's second quantity goes on a right axis (on one axis the larger
# flattened the other: N*, T* ~ 1-20 beside b*' in the thousands), dashed, so
# that lines coinciding on their own ranges (b*, x* of a steady slide) both show.
RIGHT_AXIS = ("y", "x", "bdot")
RIGHT_AXIS_DASH = "dashed"


def axis_dash(column: Any, right: Any) -> str | None:
    return RIGHT_AXIS_DASH if column in right else None


def right_columns(columns: Any) -> list[Any] | list[str]:
    """The columns of a panel drawn on its right axis (none if it has one)."""
    if len(columns) < 2:
        return []
    return [c for c in columns if c in RIGHT_AXIS][: len(columns) - 1]


# units of the quantities (docs/MODEL.md; N*, T* are in units of the weight)
AXIS_UNITS = {
    "a": "a0",
    "y": "a0",
    "x": "a0",
    "b": "theta mu a0",
    "bdot": "theta mu a0/period",
    "roll_velocity": "a0/period",
    "slip_velocity": "a0/period",
}


def axis_labels(labels: Any, right: Any) -> tuple[str, str]:
    """(left, right) axis labels of a panel's {column: legend label}: each
    names its quantities and their unit."""

    def named(columns):
        units = {AXIS_UNITS.get(c) for c in columns}
        text = ", ".join(labels[c] for c in columns)
        return text + (f" ({units.pop()})" if len(units) == 1 and None not in units else "")

    return (named([c for c in labels if c not in right]), named([c for c in labels if c in right]))


@dataclass(frozen=True)
class Panel:
    """One panel over `xlim` (periods): lines (`traces`), or a contact-state
    strip (`strip`: (edges, shares), `strip_outline`'s stacking)."""

    title: str
    ylabel: str
    xlim: tuple
    traces: tuple = ()
    strip: tuple | None = None
    right: tuple = ()  # variables drawn on the panel's right axis

    @property
    def axis_labels(self) -> tuple[str, str]:
        """(left, right) y-axis labels (right "" without a right axis)."""
        if not self.right:
            return self.ylabel, ""
        return axis_labels({t.var: t.label for t in self.traces}, self.right)


@dataclass(frozen=True)
class TrajectoryFigure:
    """A title and columns of panels (whole run, fragment `window`); `bins`:
    the whole run's time bins (None: every sample)."""

    title: str
    columns: tuple
    window: tuple
    bins: int | np.integer | None


def _trace(var, label, colour, data, dash):
    """A `Trace` of `data`'s column `var`, with its envelope where binned."""
    lo, hi = data.get(f"{var}_lo"), data.get(f"{var}_hi")
    return Trace(var, label, colour, data["time"], data[var], lo, hi, dash)


def _line_panels(ds, specs, bins):
    t = ds["time"].values
    variables = {var for _, _, lines in specs for var, _, _ in lines}
    if bins:
        data = binned(t, {v: ds[v].values for v in variables}, bins)
    else:
        data = {"time": t, **{v: ds[v].values for v in variables}}
    xlim = (float(t[0]), float(t[-1]))
    panels = []
    for title, ylabel, lines in specs:
        right = tuple(right_columns([var for var, _, _ in lines]))
        traces = tuple(_trace(v, lab, col, data, axis_dash(v, right)) for v, lab, col in lines)
        panels.append(Panel(title + (BINNED_NOTE if bins else ""), ylabel, xlim, traces, right=right))
    return panels, data


def _twin_panel(ds, data, twin, bins, xlim):
    title, ylabel, ((la, ca, da), (lb, cb, db)) = twin_spec(ds.attrs.get("tau", 50.0), TWIN_LABEL)
    tt, tx = twin["time"].values, twin["x"].values
    other = binned(tt, {"x": tx}, bins) if bins else {"time": tt, "x": tx}
    traces = (_trace("x", la, ca, data, da), _trace("x", lb, cb, other, db))
    return Panel(title + (BINNED_NOTE if bins else ""), ylabel, xlim, traces)


def state_strip(ds: xr.Dataset, bins: int | None = None) -> tuple[tuple[Any, np.ndarray], str]:
    """The contact-state strip (`Panel.strip`) and its title: the exact runs,
    or with `bins` each bin's stacked time shares (exact bands of a long run
    showed as a moire)."""
    if bins:
        return state_shares(ds, bins), SHARES_TITLE
    t0, t1, codes = state_bands(ds)
    return (np.r_[t0, t1[-1:]], np.eye(len(STATE_NAMES))[codes]), timeline_title(None)


SHARES_TITLE = "contact state (time share per bin)"


def trajectory_figure(
    ds: xr.Dataset,
    window: tuple[float, float] | None = None,
    twin: xr.Dataset | None = None,
    title: str | None = None,
    bins: int = OVERVIEW_BINS,
) -> TrajectoryFigure:
    """The trajectory figure: left the whole run (per-bin mean and min-max
    envelope over `bins` bins, state shares; None: every sample), right the
    fragment `window` (`fragment_window`) sample by sample.  Rows:
    `panel_spec` (a particle that rolls: its rotation's panel too), the
    state strip, and x*(t) of both runs with a `twin`."""
    t0, t1 = fragment_window(ds, window)
    t = ds["time"].values
    # (index slicing: a label-based sel builds a pandas hash index first)
    i0, i1 = np.searchsorted(t, t0, side="left"), np.searchsorted(t, t1, side="right")
    if i1 - i0 < 2:
        raise InputError(f"window ({t0:g}, {t1:g}) holds fewer than 2 samples of the run")
    if bins is not None and (isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or bins < 1):
        raise InputError(f"bins must be a positive integer or None, got {bins!r}")
    frag = ds.isel(time=slice(i0, i1))
    rigid = ds.attrs.get("model") == "point-mass"
    specs = panel_spec(rigid, split_velocity=True, rolling=not rigid and rolls(ds))
    columns = []
    for part, part_bins, head in ((ds, bins, "whole run"), (frag, None, f"t* in [{t0:g}, {t1:g}]")):
        panels, data = _line_panels(part, specs, part_bins)
        panels[0] = replace(panels[0], title=f"{head}: {panels[0].title}")
        xlim = panels[0].xlim
        strip, strip_title = state_strip(part, part_bins)
        panels.append(Panel(strip_title, "state", xlim, strip=strip))
        if twin is not None:
            tt = twin["time"].values
            if part is frag:
                j0, j1 = np.searchsorted(tt, t0, side="left"), np.searchsorted(tt, t1, side="right")
                other = twin.isel(time=slice(j0, j1))
            else:
                other = twin
            panels.append(_twin_panel(part, data, other, part_bins, xlim))
        columns.append(tuple(panels))
    if title is None:
        a = ds.attrs
        title = (
            f"{a.get('model')}: A* = {a.get('amplitude', float('nan')):.4g}, "
            f"m* = {a.get('mass', float('nan')):.4g}, mu = {a.get('mu', float('nan')):g}"
        )
    return TrajectoryFigure(str(title), tuple(columns), (t0, t1), bins)


# ---------------------------------------------------------------- memory diagram
# Shared with the explorer's live view (app/views/memory.py).
W_COLOR = "#1f77b4"  # the anchors w(h)
U_COLOR = "#ff7f0e"  # the displacements u(h)
SLIP_TEXT_COLOR = "#a05a00"
FLIGHT_TEXT = "in flight:\nno contact, no memory"  # (two lines: one was cut at a panel's width)
MEMORY_XLABEL = "h (contact depth, a0)"
MEMORY_WLABEL = "w (theta mu a0)"
MEMORY_ULABEL = "u = b* - w (theta mu a0)"
MEMORY_UTITLE = "spring displacements u(h), |u| <= a* - h"
CIRCLE_XLABEL = "x (sqrt(R a0))"
CIRCLE_ZLABEL = "z (sqrt(R a0))"


def memory_title(snapshot: Any) -> str:
    return f"memory diagram w(h), t* = {snapshot['t']:.6g}, {STATE_NAMES[int(snapshot['state'])]}"


SPAN_LABEL_INSET = 0.02  # a band's label starts this fraction of a* inside it


def memory_spans(snapshot: Any) -> list[Any]:
    """The stick core [0, s_h] and slip annulus [s_h, a*] as bands: dicts of
    left, right, color, alpha, label, label_color, label_at ("top" or
    "bottom") and label_x (left-aligned just inside the band: centred, a
    narrow band's label was cut at the panel's edge)."""
    a, s = snapshot["a"], snapshot["stick_depth"]
    inset = SPAN_LABEL_INSET * max(float(a), 0.0)
    slip_colour = STATE_COLORS[3] if s <= 0 else STATE_COLORS[2]
    spans = []
    if s > 0:
        spans.append((0, s, STATE_COLORS[1], 0.18, "stick core", STATE_COLORS[1], "top", inset))
    if a > s:
        spans.append((s, a, slip_colour, 0.25, "slip annulus", SLIP_TEXT_COLOR, "bottom", s + inset))
    keys = ("left", "right", "color", "alpha", "label", "label_color", "label_at", "label_x")
    return [dict(zip(keys, sp)) for sp in spans]


def memory_geometry(snapshot: Any) -> dict[str, Any] | None:
    """What the memory diagram draws (None in flight): h, w, u = b* - w; hc =
    (0, a*) with the Coulomb cone's lines cone_w = b* +- (a* - hc), cone_u =
    +-(a* - hc); the limits w_lim, u_lim, h_lim."""
    a, b = float(snapshot["a"]), float(snapshot["b"])
    h = np.asarray(snapshot["h"], dtype=float)
    w = np.asarray(snapshot["w"], dtype=float)
    if h.size == 0 or a <= 0:
        return None
    hc = np.array([0.0, a])
    pad = 0.08 * a
    cone_u = [sgn * (a - hc) for sgn in (1, -1)]
    w_lim = (min(w.min(), b - a) - pad, max(w.max(), b + a) + pad)
    g = dict(a=a, b=b, h=h, w=w, u=b - w, hc=hc, cone_w=[b + c for c in cone_u], cone_u=cone_u)
    return g | dict(w_lim=w_lim, u_lim=(-(a + pad), a + pad), h_lim=(0, a * 1.02))


def _spans(snapshot, y0, y1):
    layers = []
    for sp in memory_spans(snapshot):
        mp = dict(color=None, facecolor=sp["color"], edgecolor="none")
        span = hv.VSpan(sp["left"], sp["right"])
        layers.append(style(span, dict(alpha=sp["alpha"]), dict(color=sp["color"]), mp))
        y, at = (y1, "top") if sp["label_at"] == "top" else (y0, "bottom")
        text = hv.Text(sp["label_x"], y, sp["label"], halign="left", valign=at, fontsize=10)
        layers.append(style(text, dict(color=sp["label_color"])))
    return layers


def memory_diagram(snapshot: Any) -> hv.Layout:
    """The memory diagram at one instant (`memory_snapshot`): spring anchors
    w(h) with the Coulomb cone |b* - w| = a* - h, and displacements u(h) =
    b* - w with |u| = a* - h; stick core and slip annulus shaded."""
    title = memory_title(snapshot)
    g = memory_geometry(snapshot)
    if g is None:
        heads = ((W_DIM, title), (U_DIM, "spring displacements u(h)"))
        empty = [
            hv.Overlay([hv.Curve([], H_DIM, d), hv.Text(0.5, 0.0, FLIGHT_TEXT)]).relabel(t) for d, t in heads
        ]
        return hv.Layout(empty).cols(2)
    panels = []
    for dim, y, colour, ylabel, head in (
        (W_DIM, "w", W_COLOR, MEMORY_WLABEL, title),
        (U_DIM, "u", U_COLOR, MEMORY_ULABEL, MEMORY_UTITLE),
    ):
        names = ["Coulomb cone" if y == "w" else "", ""]
        cone = [hv.Curve((g["hc"], c), H_DIM, dim, label=n) for c, n in zip(g[f"cone_{y}"], names)]
        layers = _spans(snapshot, *g[f"{y}_lim"]) + [_styled_line(c, "black", 1, "dashed") for c in cone]
        layers.append(_styled_line(hv.Curve((g["h"], g[y]), H_DIM, dim, label=f"{y}(h)"), colour, 2))
        if y == "w":  # the cone's apex (a*, b*)
            apex = hv.Points([(g["a"], g["b"])], [H_DIM, W_DIM])
            layers.append(style(apex, dict(color="black"), dict(size=7), dict(s=25)))
        opts = dict(xlim=g["h_lim"], show_legend=False, xlabel=MEMORY_XLABEL, ylabel=ylabel)
        panels.append(style(hv.Overlay(layers).relabel(head), dict(ylim=g[f"{y}_lim"], **opts)))
    return hv.Layout(panels).cols(2)


def disc_outline(r: Any, n: int = 181) -> np.ndarray:
    """A closed circle of radius r about the origin: (n, 2) points."""
    phi = np.linspace(0, 2 * np.pi, n)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi)])


def contact_geometry(snapshot: Any) -> dict[str, Any]:
    """What the contact circle draws: c = sqrt(a*), s = sqrt(s_h), the view's
    half-width rmax, the title and the discs (dicts of r, color, dashed, label)."""
    a = max(float(snapshot["a"]), 0.0)
    s_h = min(max(float(snapshot["stick_depth"]), 0.0), a)
    c, s = np.sqrt(a), np.sqrt(s_h)
    title = f"contact: c = {c:.3g}, s = {s:.3g} ({STATE_NAMES[int(snapshot['state'])]})"
    discs = []
    if c > 0:
        slip = STATE_COLORS[3] if s <= 0 else STATE_COLORS[2]
        outer = (slip, "slip annulus") if s < c else (STATE_COLORS[1], "stick")
        discs.append(dict(r=c, color=outer[0], dashed=False, label=outer[1]))
        if 0 < s < c:
            discs.append(dict(r=s, color=STATE_COLORS[1], dashed=True, label="stick core"))
    return dict(c=c, s=s, rmax=max(c, 1.0) * 1.1, title=title, discs=discs)


def contact_circle(snapshot: Any) -> Any:
    """The contact seen from above: circle sqrt(a*), stick core sqrt(s_h)."""
    g = contact_geometry(snapshot)
    layers = []
    for d in g["discs"]:
        bk = dict(color=d["color"], line_color="black")
        mp = dict(color=None, facecolor=d["color"], edgecolor="black")
        if d["dashed"]:
            bk["line_dash"], mp["linestyle"] = "dashed", "dashed"
        disc = hv.Polygons([disc_outline(d["r"])], [CX_DIM, CZ_DIM], label=d["label"])
        layers.append(style(disc, dict(alpha=0.9), bk, mp))
    if not g["discs"]:
        layers.append(hv.Text(0, 0, "in flight: no contact"))
    lim = (-g["rmax"], g["rmax"])
    opts = dict(xlim=lim, ylim=lim, data_aspect=1, show_legend=False, xlabel=CIRCLE_XLABEL)
    return style(hv.Overlay(layers).relabel(g["title"]), dict(ylabel=CIRCLE_ZLABEL, **opts))


# ---------------------------------------------------------------- dynamics
LYAPUNOV_FLOOR = 1e-4  # the indicator map's colour range, log10 lambda in [-4, 0]
LAMBDA_DIM = hv.Dimension("log_lambda", label="log10 lambda (per period)", range=(-4.0, 0.0))
Y_DIM = hv.Dimension("y", label="y* (a0, down)")
VY_DIM = hv.Dimension("vy", label="y*' (a0 per period)")
PHASE_DIM = hv.Dimension("phase", label="take-off phase (t mod 1)", range=(0.0, 1.0))
TRACE_DIM = hv.Dimension("trace", label="trace of the period-1 Jacobian")
ORBIT_COLORS = tuple(
    "#1f77b4 #d62728 #2ca02c #9467bd #ff7f0e #8c564b #e377c2 #17becf #bcbd22 #7f7f7f".split()
)
DIFFERENCE_DIM = hv.Dimension("log_difference", label="s(v2) - s(v1)")
CLASS_CHANGE_COLOUR = "black"


def map_difference_figure(diff: xr.Dataset) -> Any:
    """Two maps compared (`map_difference`): s(v2) - s(v1) in decades (red:
    the second drifts more towards +x), black where the drift class differs,
    grey where either is chaotic; colours saturate at the 99th percentile."""
    d = diff["log_difference"].values
    chaotic = diff["chaotic_either"].values
    shown = np.where(chaotic, np.nan, d)
    finite = np.abs(shown[np.isfinite(shown)])
    # up to the next half decade (a few outliers would wash out the rest)
    top = max(0.5, float(np.ceil(2.0 * np.percentile(finite, 99)) / 2.0)) if finite.size else 0.5
    v1, v2 = diff["drift_velocity_first"].values, diff["drift_velocity_second"].values
    vdims = [DIFFERENCE_DIM, hv.Dimension("v1", label="<v*> first"), hv.Dimension("v2", label="<v*> second")]
    img = _map_image(diff, shown, v1, v2, vdims=vdims)
    hover = [("<v*> first", "@{v1}"), ("<v*> second", "@{v2}"), ("difference (decades)", "@{log_difference}")]
    clabel = f"s(v2) - s(v1), decades\n(v0* = {diff.attrs['v0']:g})"
    img = _coloured(img, "RdBu_r", (-top, top), clabel, hover)
    key = [
        ("black: drift class differs", "patch", (CLASS_CHANGE_COLOUR, CLASS_CHANGE_COLOUR)),
        ("grey: chaotic in either map", "patch", (CHAOTIC_GREY, CHAOTIC_GREY)),
    ]
    layers = [_keyed(img, key)]
    changed = diff["class_changed"].values & ~chaotic  # a chaotic point's change is noise
    for mask, colour in ((chaotic, CHAOTIC_GREY), (changed, CLASS_CHANGE_COLOUR)):
        if mask.any():
            layer = _map_image(diff, np.where(mask, 1.0, np.nan), vdims=["mask"])
            layers.append(style(layer, common=dict(cmap=[colour], alpha=0.9), bokeh=dict(tools=[])))
    a = diff.attrs
    agreement = (
        "no point regular in both"
        if not np.isfinite(a["class_agreement"])
        else f"drift class agrees at {100 * a['class_agreement']:.1f}% of "
        f"{a['regular_points']} regular points, median relative difference "
        f"{a['median_relative_difference']:.2g}"
    )
    return style(
        hv.Overlay(layers),
        common=dict(title=f"{a['second']}  against  {a['first']}\n{agreement}"),
        matplotlib=dict(aspect=1.2, fontsize={"title": 9}),
    )


def lyapunov_map(ds: xr.Dataset, threshold: float, title: str = "") -> Any:
    """log10 of the vertical motion's Lyapunov exponent over the map (floored
    at LYAPUNOV_FLOOR), the chaos threshold marked on the colour bar."""
    lam = ds["lyapunov"].values
    c = np.log10(np.clip(lam, LYAPUNOV_FLOOR, None))
    img = _map_image(ds, c, lam, vdims=[LAMBDA_DIM, hv.Dimension("lam", label="lambda")], label=title)
    mark = (float(np.log10(threshold)), f"{threshold:g} (chaotic above)")
    ticks = [(-4.0, "<= 1e-4"), (-3.0, "1e-3"), mark, (-1.0, "0.1"), (0.0, "1")]
    clabel = "Lyapunov exponent of the\nvertical motion, per period"
    return _coloured(img, "viridis", (-4.0, 0.0), clabel, [("lambda", "@{lam}")], ticks)


def section_figure(orbits: Any, title: str = "Stroboscopic section (t = 0 mod 1)") -> Any:
    """Sections of several orbits (float64[n, 2] arrays of (y*, y*')), one colour each."""
    layers = []
    for k, pts in enumerate(orbits):
        el = hv.Scatter((pts[:, 0], pts[:, 1]), kdims=[Y_DIM], vdims=[VY_DIM], label=f"orbit {k + 1}")
        color = ORBIT_COLORS[k % len(ORBIT_COLORS)]
        layers.append(style(el, dict(color=color), dict(size=3, tools=["hover"]), dict(s=4)))
    if not layers:
        layers = [hv.Scatter(([], []), kdims=[Y_DIM], vdims=[VY_DIM])]
    return style(hv.Overlay(layers), common=dict(title=title))


def orbit_diagram_figure(diagram: Any) -> Any:
    """Take-off phases and section points y* against the parameter, two panels."""
    name = LOG_A if diagram.parameter == "amplitude" else LOG_M
    tail = f"final {diagram.final_periods:g} periods"
    panels = []
    for x, y, dim, colour, title in (
        (diagram.phase_value, diagram.phase, PHASE_DIM, "#1f77b4", "take-off phases"),
        (diagram.section_value, diagram.section_y, Y_DIM, "#444444", "section y*(k)"),
    ):
        bk = dict(size=2, color=colour, responsive=True, height=260)
        el = hv.Scatter((x, y), kdims=[name], vdims=[dim])
        panels.append(style(el, dict(title=f"{title}, {tail}"), bk, dict(s=1, color=colour, aspect=2.5)))
    return (panels[0] + panels[1]).cols(1)


def continuation_figure(branch: Any) -> Any:
    """A continued orbit's trace against its parameter, with trace = +-2 and
    the folds and period doublings."""
    key = 0 if branch.parameter == "amplitude" else 1
    name = LOG_A if branch.parameter == "amplitude" else LOG_M
    x = np.array([p[key] for p in branch.points])
    tr = np.array([p.orbit.trace for p in branch.points])
    curve = hv.Curve((x, tr), kdims=[name], vdims=[TRACE_DIM], label="period-1 orbit")
    layers = [_styled_line(curve, "#1f77b4", 1.5)]
    for level in (2.0, -2.0):
        layers.append(_styled_line(hv.HLine(level), "#888888", 1.0, "dashed"))
    for points, color, level, label in (
        (branch.folds, "#d62728", 2.0, "fold (trace = 2)"),
        (branch.period_doublings, "#2ca02c", -2.0, "period doubling (trace = -2)"),
    ):
        if points:
            el = hv.Scatter((points, [level] * len(points)), kdims=[name], vdims=[TRACE_DIM], label=label)
            layers.append(style(el, bokeh=dict(color=color, size=9), matplotlib=dict(color=color, s=40)))
    return style(hv.Overlay(layers), common=dict(title=f"continuation along {name.label}: {branch.ended}"))


PERIOD_DOUBLING_LINE = ("#d62728", 1.5, None)
STABLE_ORBIT_LINE = ("#1f3a93", 1.5, "dashed")
PERIOD_DOUBLING_LABEL = "period-1 orbit: period doubling (trace = -2)"
STABLE_ORBIT_LABEL = "period-1 hopping orbit: stable inside"


def period_one_curves(chart: xr.Dataset) -> hv.Overlay:
    """Contours of the period-1 orbit's doubling (trace = -2) and of its
    stable hopping region (`period_one_chart`), named in the map's key."""
    la, lm = chart["log_amplitude"].values, chart["log_mass"].values
    trace = np.where(np.isfinite(chart["trace"].values), chart["trace"].values, 3.0)
    stable = (chart["stable"].values & chart["in_flight"].values).astype(float)
    lines = []
    for z, level, line, label in (
        (trace, -2.0, PERIOD_DOUBLING_LINE, PERIOD_DOUBLING_LABEL),
        (stable, 0.5, STABLE_ORBIT_LINE, STABLE_ORBIT_LABEL),
    ):
        img = hv.Image((la, lm, z.T), kdims=[LOG_A, LOG_M])
        c = hv.operation.contours(img, levels=[level], overlaid=False)
        lines.append(_keyed(_styled_line(c, *line), [(label, "line", line)]))
    return hv.Overlay(lines)


# ---------------------------------------------------------------- design chart
REGIME_COLORS = dict(zip(REGIMES, "#4d4d4d #b2182b #2166ac #1b7837 #e08214 #762a83".split()))
SPEED_CONTOUR = ("#303030", 0.8, "dotted")
DEVICE_MARKER = "#000000"


def level_lines(x: Any, y: Any, z: Any, level: Any) -> list:
    """Contour lines of z (shape (y, x)) at `level`: (n, 2) arrays (NaN cells left out)."""
    import contourpy

    z = np.ma.masked_invalid(np.asarray(z, float))
    gen = contourpy.contour_generator(np.asarray(x, float), np.asarray(y, float), z, line_type="Separate")
    return [seg for seg in gen.lines(level) if len(seg) > 1]


def _padded(u):
    """u with one more point at each end, a hundredth of a step out."""
    d0, d1 = (u[1] - u[0]) / 100, (u[-1] - u[-2]) / 100
    return np.concatenate([[u[0] - d0], u, [u[-1] + d1]])


def design_figure(chart: xr.Dataset, device: Any = None, title: str | None = None) -> Any:
    """The design chart (`design_chart`) on log axes in device units: signed
    drift in the paper's log scale, regimes outlined, equal-speed contours at
    whole decades, `device` (x, y) marked."""
    xq, yq = chart.attrs["x"], chart.attrs["y"]
    x, y = chart[xq].values, chart[yq].values
    v = chart["drift_velocity"].values
    unit, scale = velocity_unit(v)
    vu = v / scale
    moving = (chart["drift"].values != 0) & np.isfinite(vu)
    # the colour scale's floor: the slowest drifting point, one significant digit down
    v0 = float(np.nanmin(np.abs(vu[moving]))) if moving.any() else 1.0
    v0 = math.floor(v0 / 10 ** math.floor(math.log10(v0))) * 10 ** math.floor(math.log10(v0))
    c = np.where(moving, colour_scale(np.where(moving, vu, 0.0), v0), 0.0)
    c = np.where(np.isfinite(vu), c, np.nan)
    xd = hv.Dimension(xq, label=AXIS_LABELS[xq])
    yd = hv.Dimension(yq, label=AXIS_LABELS[yq])
    vdims = [hv.Dimension("C", range=(-1, 1)), hv.Dimension("v", label=f"v ({unit})")]
    mesh = hv.QuadMesh((x, y, c, vu), kdims=[xd, yd], vdims=vdims)
    ticks = list(colour_ticks(np.where(moving, vu, 0.0), v0).items())
    clabel = f"drift velocity ({unit})\nsigned log scale\nwhite: no drift"
    hover = [(f"drift velocity ({unit})", "@{v}")]
    mesh = _coloured(mesh, CMAP, (-1, 1), clabel, hover, ticks, logx=True, logy=True)
    layers: list = []
    key: list[tuple] = []
    lx, ly = np.log10(x), np.log10(y)
    regime = chart["regime"].values
    for k, name in enumerate(REGIMES):
        inside = (regime == k).astype(float)
        if not inside.any():
            continue
        # padded with "outside": a zone reaching the chart's edge is closed along it
        px, py = _padded(lx), _padded(ly)
        lines = [
            10.0 ** np.clip(seg, [lx[0], ly[0]], [lx[-1], ly[-1]])
            for seg in level_lines(px, py, np.pad(inside, 1), 0.5)
        ]
        colour = REGIME_COLORS[name]
        key.append((name, "line", (colour, 2.0, None)))
        if lines:
            layers.append(_styled_line(hv.Path(lines, kdims=[xd, yd]), colour, 2.0))
    speed = np.where(moving, np.abs(vu), np.nan)
    if np.isfinite(speed).any():
        lo, hi = np.nanmin(speed), np.nanmax(speed)
        labels = []
        for e in range(int(math.ceil(np.log10(lo))), int(math.floor(np.log10(hi))) + 1):
            segs = level_lines(lx, ly, np.log10(speed), e)
            if not segs:
                continue
            layers.append(_styled_line(hv.Path([10.0**s for s in segs], kdims=[xd, yd]), *SPEED_CONTOUR))
            longest = max(segs, key=len)
            mx, my = 10.0 ** longest[len(longest) // 2]
            labels.append((mx, my, f"{10.0**e:g}"))
        if labels:
            key.append((f"equal speed ({unit})", "line", SPEED_CONTOUR))
            text = hv.Labels(labels, kdims=[xd, yd], vdims=["text"])
            layers.append(style(text, bokeh=dict(text_font_size="8pt"), matplotlib=dict(fontsize=8)))
    if device is not None:
        pt = hv.Points([tuple(device)], kdims=[xd, yd])
        # (Bokeh's marker names are lower case: "X" passes its check and is not drawn)
        bk, mp = dict(marker="x", size=14, line_width=3), dict(marker="X", s=120)
        layers.append(style(pt, dict(color=DEVICE_MARKER), bk, mp))
        key.append(("x: the device", "line", (DEVICE_MARKER, 2.0, None)))
    if title is None:
        a = chart.attrs
        # (lines short enough for half a screen in presentation mode)
        title = (
            f"{a['particle']} on {a['substrate']}\n{a['fixed']} = {a['fixed_value']:.3g} "
            f"{a['fixed_units']}, mu = {a['mu']:g}\n({a['map']})"
        )
        tip = a.get("profile", "sphere")
        if tip != "sphere":  # (a second line: the first fills a half-page chart)
            title += f"\nthe particle's tip: {tip} (profile {a['map_profile']})"
    el = hv.Overlay([_keyed(mesh, key), *layers])
    return style(el, common=dict(title=title, logx=True, logy=True, xlim=(x[0], x[-1]), ylim=(y[0], y[-1])))
