"""Headless figure export: PNG/SVG/PDF with the HoloViews matplotlib backend
(Agg), standalone HTML with bokeh (inline resources), and the paper's figures
(`export_paper`).  The figures are the explorer's (`plots`); loading the
matplotlib backend leaves `hv.Store.current_backend` alone, so a serving
process may export.  Every `export_*` returns what it drew.
"""

from __future__ import annotations

import math
import shlex
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

if "matplotlib.pyplot" not in sys.modules:
    matplotlib.use("Agg")  # before pyplot is imported (by HoloViews)

import holoviews as hv  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from vibtrans.analysis.summary import V0, twin_scene  # noqa: E402
from vibtrans.core.errors import InputError  # noqa: E402
from vibtrans.core.kernels.contact import STATE_NAMES  # noqa: E402
from vibtrans.core.params import PAPER_POINTS, paper_scene  # noqa: E402
from vibtrans.maps.outfiles import atomic  # noqa: E402
from vibtrans.maps.shipped import maps_dir  # noqa: E402
from vibtrans.products import plots  # noqa: E402

if TYPE_CHECKING:
    import os

    import xarray as xr
    from matplotlib.figure import Figure
    from matplotlib.typing import RcKeyType

    from vibtrans.core.params import Scene
    from vibtrans.products.plots import TrajectoryFigure

FORMATS = ("png", "svg", "pdf")
DEFAULT_DPI = 150
FRAGMENT = plots.FRAGMENT
OVERVIEW_SAMPLES = plots.OVERVIEW_SAMPLES
MAX_PIXELS = 60e6
HSPACE = 0.35  # gap between a layout's columns, in axes widths
MAPS_HSPACE = 0.6  # ... beside a map: its colour bar, ticks and two-line title

# publication defaults: readable fonts, text kept as text in SVG, TrueType in PDF
RC: dict[RcKeyType, Any] = {
    "font.size": 11,
    "axes.titlesize": 11,
    "axes.labelsize": 11,
    "xtick.labelsize": 9.5,
    "ytick.labelsize": 9.5,
    "legend.fontsize": 9,
    "legend.framealpha": 0.85,
    "axes.linewidth": 0.8,
    "axes.formatter.useoffset": False,
    "svg.fonttype": "none",
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "figure.facecolor": "white",
    "savefig.facecolor": "white",
}
_ELEMENTS = "Curve Image Rectangles Polygons Points Labels Text HLine VLine VSpan Overlay".split()


# ---------------------------------------------------------------- backends
def ensure_backends() -> None:
    """Load HoloViews' bokeh and matplotlib backends, keeping the current one
    (bokeh if none was selected)."""
    had = hv.Store.current_backend if hv.Store.renderers else None
    import holoviews.plotting.bokeh  # noqa: F401
    import holoviews.plotting.mpl  # noqa: F401

    hv.Store.set_current_backend(had or "bokeh")  # also fills hv.opts builders


def output_format(out: str | os.PathLike[str], allowed: tuple[str, ...] = FORMATS) -> str:
    ext = Path(out).suffix.lower().lstrip(".")
    if ext not in allowed:
        raise InputError(f"out must end in {', '.join('.' + a for a in allowed)}; got {str(out)!r}")
    return ext


def _check_size(width, height, dpi):
    for name, v in (("width", width), ("height", height)):
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float))
            or not (math.isfinite(v) and 0.5 <= v <= 50)
        ):
            raise InputError(f"{name} must be a number of inches in [0.5, 50], got {v!r}")
    if isinstance(dpi, bool) or not isinstance(dpi, (int, np.integer)) or not 20 <= dpi <= 1200:
        raise InputError(f"dpi must be an integer in [20, 1200], got {dpi!r}")
    if width * height * dpi * dpi > MAX_PIXELS:
        raise InputError(
            f"dpi too large for a {width:g} x {height:g} in figure: "
            f"{width * dpi:.0f} x {height * dpi:.0f} px is over "
            f"{MAX_PIXELS:.0e} pixels"
        )


def _fit(fig, pad=0.06, rounds=6):
    """Scale and shift every axes so that everything drawn fills the canvas
    with `pad` inches spare (the canvas size is kept)."""
    W, H = fig.get_size_inches()
    for _ in range(rounds):
        fig.canvas.draw()
        bb = fig.get_tightbbox(fig.canvas.get_renderer())
        x0, x1, y0, y1 = bb.x0 / W, bb.x1 / W, bb.y0 / H, bb.y1 / H
        tx0, tx1, ty0, ty1 = pad / W, 1 - pad / W, pad / H, 1 - pad / H
        if max(abs(x0 - tx0), abs(x1 - tx1), abs(y0 - ty0), abs(y1 - ty1)) < 2e-3:
            break
        sx, sy = (tx1 - tx0) / (x1 - x0), (ty1 - ty0) / (y1 - y0)
        for ax in fig.axes:
            p = ax.get_position(original=True)
            ax.set_position([tx0 + (p.x0 - x0) * sx, ty0 + (p.y0 - y0) * sy, p.width * sx, p.height * sy])


def render(obj: Any, width: float = 7.0, height: float = 5.0, hspace: float = HSPACE) -> Figure:
    """A matplotlib Figure of `obj` (close it with pyplot.close when done)."""
    ensure_backends()
    # axes fill their cells, no sub-figure letters, no shared ranges
    spec: dict[str, dict[str, Any]] = {k: dict(aspect="auto") for k in _ELEMENTS}
    spec["Layout"] = dict(sublabel_format="", fig_inches=(width, height), hspace=hspace, vspace=0.6)
    spec["Overlay"] = dict(aspect="auto", fig_inches=(width, height))
    spec["Image"] = dict(aspect="auto", fig_inches=(width, height))
    obj = obj.opts(spec, backend="matplotlib")
    with matplotlib.rc_context(RC):
        fig = hv.render(obj, backend="matplotlib")
        FigureCanvasAgg(fig)  # HoloViews closed it: attach a headless canvas
        fig.set_size_inches(width, height)
        _fit(fig)
    return fig


def save(
    obj: Any,
    out: str | os.PathLike[str],
    width: float = 7.0,
    height: float = 5.0,
    dpi: int = DEFAULT_DPI,
    hspace: float = HSPACE,
) -> Any:
    """Render `obj` with matplotlib to .png (width*dpi x height*dpi px), .svg or .pdf."""
    fmt = output_format(out)
    _check_size(width, height, dpi)
    _saved(render(obj, width, height, hspace), out, fmt, dpi)
    return obj


def _saved(fig, out, fmt, dpi):
    """Write `fig` to `out` (no date: the same figure, the same bytes) and close it."""
    import matplotlib.pyplot as plt

    from vibtrans.version import __version__

    creator = f"vibtrans {__version__}"
    meta: dict[str, Any] = {"Software": creator}
    if fmt != "png":
        meta = {"Creator": creator, "Date" if fmt == "svg" else "CreationDate": None}
    try:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        with matplotlib.rc_context(RC), atomic(out) as tmp:
            fig.savefig(tmp, format=fmt, dpi=dpi, metadata=meta)
    finally:
        plt.close(fig)


def export_html(obj: Any, out: str | os.PathLike[str], title: str = "vibtrans") -> Any:
    """A standalone interactive HTML file (Bokeh, resources inline, no server).

    Parameters
    ----------
    obj : object
        A HoloViews object (bokeh backend loaded), a Bokeh model, or anything Panel shows.
    out : str or os.PathLike
        The .html file.
    title : str
        The page's title.

    Returns
    -------
    object
        `obj`.

    Raises
    ------
    InputError
        If `out` does not end in .html.
    """
    from bokeh.document import Document
    from bokeh.model import Model
    from bokeh.resources import INLINE
    from panel.io.state import set_curdoc

    output_format(out, ("html",))
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    # Panel's save takes stylesheets from the current document's cache (from a
    # served page it rewrote the page's): a scratch current document keeps them apart
    with atomic(out) as tmp, set_curdoc(Document()):
        if isinstance(obj, hv.core.dimension.Dimensioned):
            ensure_backends()
            hv.save(obj, tmp, fmt="html", backend="bokeh", resources="inline", title=title)
        elif isinstance(obj, Model):
            from bokeh.embed import file_html

            # a document of its own: else file_html copies curdoc()'s, which in a
            # server callback can be a closed page's destroyed document
            if obj.document is None:
                Document().add_root(obj)
            Path(tmp).write_text(file_html(obj, INLINE, title=title), encoding="utf-8")
        else:
            import panel as pn

            pn.panel(obj).save(tmp, resources=INLINE, title=title, embed=True)
    return obj


def _write(obj, out, width, height, dpi, html_cell=None):
    """PNG/SVG/PDF through matplotlib; .html through bokeh, each panel
    `html_cell` (w, h) pixels (default: from the inches)."""
    output_format(out, FORMATS + ("html",))
    if Path(out).suffix.lower() != ".html":
        return save(obj, out, width, height, dpi)
    w, h = html_cell or (int(width * 100), int(height * 100))
    spec = {k: dict(width=w, height=h) for k in ("Curve", "Image", "Rectangles", "Polygons", "Overlay")}
    spec["Curve"]["tools"] = spec["Image"]["tools"] = ["hover"]
    return export_html(obj.opts(spec, backend="bokeh"), out)


# ---------------------------------------------------------------- figures
def heatmap_figure(
    map_ds: xr.Dataset,
    v0: float = V0,
    vertical: xr.Dataset | None = None,
    chaotic: str = "grey",
    title: str | None = None,
) -> Any:
    """The explorer's map: drift, jumping boundary, resonances, paper points."""
    ensure_backends()
    if isinstance(v0, bool) or not isinstance(v0, (int, float)) or not (math.isfinite(v0) and v0 > 0):
        raise InputError(f"v0 must be a positive number, got {v0!r}")
    if chaotic not in ("grey", "colour"):
        raise InputError(f"chaotic must be grey or colour, got {chaotic!r}")
    model = map_ds.attrs.get("scene_model", "deformable")
    mu = map_ds.attrs.get("scene_mu", float("nan"))
    periods = map_ds.attrs.get("scene_periods", float("nan"))
    el = plots.drift_map(map_ds, v0=v0, chaotic=chaotic, title=f"{model}, mu = {mu:g}")
    if vertical is not None:
        el = el * plots.jumping_boundary(vertical, model)
        if model == "deformable":
            el = el * plots.resonance_lines(vertical)
    el = el * plots.paper_points(model)
    if title is None:
        title = f"<v*> over {periods:g} periods: {model}, mu = {mu:g}"
        if "point_done" in map_ds and not bool(map_ds["point_done"].values.all()):
            title += " (partial map)"
        if chaotic == "grey" and bool((map_ds["chaotic"].values == 1).any()):
            title += "; grey: chaotic"
    x0, y0, x1, y1 = plots.map_bounds(map_ds)
    return plots.style(el, common=dict(title=title, xlim=(x0, x1), ylim=(y0, y1)))


def export_heatmap(
    map_ds: xr.Dataset,
    out: str | os.PathLike[str],
    v0: float = V0,
    vertical: xr.Dataset | None = None,
    dpi: int = DEFAULT_DPI,
    width: float = 7.0,
    height: float = 5.2,
    chaotic: str = "grey",
    title: str | None = None,
) -> Any:
    """The drift map of a sweep, as a figure file.

    Parameters
    ----------
    map_ds : xarray.Dataset
        A map (`open_map`).
    out : str or os.PathLike
        .png, .svg, .pdf or .html (interactive).
    v0 : float
        Drift speeds below this (a0 per period) are drawn as no drift.
    vertical : xarray.Dataset, optional
        The jumping threshold (`open_vertical`), drawn over the map.
    dpi, width, height : number
        Raster resolution; size in inches.
    chaotic : str
        "grey" (chaotic points grey) or "colour".
    title : str, optional
        The figure's title; None: the map's.

    Returns
    -------
    object
        The HoloViews figure drawn.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    return _write(heatmap_figure(map_ds, v0, vertical, chaotic, title), out, width, height, dpi)


def export_trajectory(
    ds: xr.Dataset,
    out: str | os.PathLike[str],
    window: tuple[float, float] | None = None,
    twin: xr.Dataset | None = None,
    dpi: int = DEFAULT_DPI,
    width: float = 11.0,
    height: float | None = None,
    title: str | None = None,
) -> TrajectoryFigure:
    """A run's trajectory figure (`plots.trajectory_figure`), as a file.

    Parameters
    ----------
    ds : xarray.Dataset
        A run (`simulate`).
    out : str or os.PathLike
        .png, .svg, .pdf (matplotlib) or .html (Bokeh).
    window : tuple of float, optional
        (t0, t1) of the full-resolution fragment; None: the run's recorded
        window, else its last 2 periods.
    twin : xarray.Dataset, optional
        The tau + 1e-3 twin run, compared in a last row.
    dpi, width, height : number
        Raster resolution; size in inches (None height: from the rows).
    title : str, optional
        The figure's title; None: the scene's.

    Returns
    -------
    TrajectoryFigure
        The figure drawn, as data.

    Raises
    ------
    InputError
        If `out`'s extension, the window or a size is not accepted.
    """
    fmt = output_format(out, FORMATS + ("html",))
    if height is None:
        height = (13.0 if twin is not None else 11.0) + (2.0 if plots.rolls(ds) else 0.0)
    figure = plots.trajectory_figure(ds, window=window, twin=twin, title=title)
    if fmt == "html":
        export_html(trajectory_bokeh(figure), out, title=figure.title)
        return figure
    _check_size(width, height, dpi)
    _saved(render_trajectory(figure, width, height), out, fmt, dpi)
    return figure


# The trajectory figure, drawn with matplotlib and Bokeh directly (plots.py says why).
LINE_WIDTH = 1.5
ENVELOPE_ALPHA = 0.3  # a per-bin min-max band: fill, outline opacity and width
ENVELOPE_EDGE_ALPHA = 0.6
ENVELOPE_EDGE_WIDTH = 0.6
TIME_LABEL = "t* (periods)"


def _mpl_panel(ax, panel):
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    ax.set_title(panel.title)
    ax.set_xlabel(TIME_LABEL)
    ax.set_xlim(*panel.xlim)
    ax.xaxis.set_major_locator(MaxNLocator(5))
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    handles: list = []
    if panel.strip is not None:
        edges, shares = panel.strip
        for code, name in enumerate(STATE_NAMES):
            if shares[:, code].any():
                # one polygon per state, not snapped: a band narrower than a pixel
                # keeps its share (a collection: add_patch walked every vertex in Python)
                x, y = plots.strip_outline(edges, shares, code)
                colour = plots.STATE_COLORS[code]
                poly = PolyCollection([np.column_stack([x, y])], snap=False, facecolors=colour, linewidths=0)
                ax.add_collection(poly, autolim=False)
                handles.append(Patch(facecolor=colour, label=name))
        ax.set_ylim(0.0, 1.8)  # the bands below, their legend above
        ax.set_yticks([])
        ax.spines["left"].set_visible(False)
        ax.legend(handles=handles, loc="upper left", ncols=4)
        return
    left_label, right_label = panel.axis_labels
    twin: Any = None
    if panel.right:
        twin = ax.twinx()
        twin.spines["top"].set_visible(False)
        twin.set_ylabel(right_label)
    for tr in panel.traces:
        on = twin if tr.var in panel.right else ax
        dash = "--" if tr.dash == "dashed" else "-"
        band = None
        if tr.lo is not None:
            # outlined: a bin far taller than its neighbours (an impact) stays a visible spike
            look = dict(edgecolor=to_rgba(tr.colour, ENVELOPE_EDGE_ALPHA), linewidth=ENVELOPE_EDGE_WIDTH)
            fill = to_rgba(tr.colour, ENVELOPE_ALPHA)
            band = on.fill_between(tr.time, tr.lo, tr.hi, facecolor=fill, linestyle=dash, **look)
        (line,) = on.plot(
            tr.time, tr.value, color=tr.colour, linewidth=LINE_WIDTH, linestyle=dash, label=tr.label
        )
        handles.append(line if band is None else (band, line))
    ax.set_ylabel(left_label)
    if twin is not None:
        # the panel's axes above its twin's, see-through: its legend is over the twin's lines
        ax.set_zorder(twin.get_zorder() + 1)
        ax.patch.set_visible(False)
    ax.legend(handles, [tr.label for tr in panel.traces], loc="best")


def render_trajectory(figure: Any, width: float = 11.0, height: float = 13.0) -> Figure:
    """A matplotlib Figure of a `plots.TrajectoryFigure`, its columns side by side."""
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    with matplotlib.rc_context(RC):
        fig = Figure(figsize=(width, height))
        FigureCanvasAgg(fig)
        rows = max(len(col) for col in figure.columns)
        axes = fig.subplots(rows, len(figure.columns), squeeze=False)
        for j, col in enumerate(figure.columns):
            for i in range(rows):
                if i < len(col):
                    _mpl_panel(axes[i, j], col[i])
                else:
                    axes[i, j].set_visible(False)
        fig.suptitle(figure.title, fontsize=14)
        # run once here, without a draw: as the figure's engine it would run in
        # savefig's dry draw and again in its real one
        ConstrainedLayoutEngine(w_pad=0.04, h_pad=0.04, hspace=0.03, wspace=0.06).execute(fig)
    return fig


def trajectory_bokeh(figure: Any, cell: tuple[int, int] = (650, 180)) -> Any:
    """A Bokeh layout of a `plots.TrajectoryFigure`: the title, then the
    columns, each panel `cell` (w, h) pixels, a column on one linked time axis."""
    import html
    from itertools import zip_longest

    from bokeh.layouts import column, gridplot
    from bokeh.models import ColumnDataSource, Div, HoverTool, Legend, LegendItem, Range1d
    from bokeh.plotting import figure as bokeh_figure

    width, height = cell
    grid = []
    for col in figure.columns:
        x_range = Range1d(*col[0].xlim)
        figs = []
        for panel in col:
            tools = dict(tools="xpan,xwheel_zoom,box_zoom,reset,save", active_scroll="xwheel_zoom")
            f = bokeh_figure(title=panel.title, width=width, height=height, x_range=x_range, **tools)
            f.xaxis.axis_label = TIME_LABEL
            f.toolbar.logo = None
            figs.append(f)
            items = []
            if panel.strip is not None:
                edges, shares = panel.strip
                for code, name in enumerate(STATE_NAMES):
                    if shares[:, code].any():
                        x, y = plots.strip_outline(edges, shares, code)
                        # no outline: over a long run's narrow bands it was all one saw
                        r = f.patch(x=x, y=y, fill_color=plots.STATE_COLORS[code], line_width=0, line_alpha=0)
                        items.append(LegendItem(label=name, renderers=[r]))
                f.y_range = Range1d(0.0, 1.8)
                f.yaxis.visible = False
                f.ygrid.visible = False
                f.add_layout(Legend(items=items, location="top_left", orientation="horizontal"))
                continue
            lines: list = []
            sides: dict = {False: [], True: []}  # renderers on the left, right axis
            left_label, right_label = panel.axis_labels
            if panel.right:
                from bokeh.models import DataRange1d, LinearAxis

                f.extra_y_ranges = {"right": DataRange1d()}
                f.add_layout(LinearAxis(y_range_name="right", axis_label=right_label), "right")
            for tr in panel.traces:
                axis = {"y_range_name": "right"} if tr.var in panel.right else {}
                data = {"time": tr.time, "value": tr.value}
                drawn = []
                if tr.lo is not None:
                    data.update(lo=tr.lo, hi=tr.hi)
                src = ColumnDataSource(data)
                line = dict(line_color=tr.colour, line_dash=tr.dash or "solid", source=src, **axis)
                if tr.lo is not None:
                    fill = dict(fill_color=tr.colour, fill_alpha=ENVELOPE_ALPHA, source=src)
                    drawn.append(f.varea(x="time", y1="lo", y2="hi", **fill, **axis))
                    drawn += [
                        f.line(x="time", y=edge, line_alpha=ENVELOPE_EDGE_ALPHA, line_width=1, **line)
                        for edge in ("lo", "hi")
                    ]
                r = f.line(x="time", y="value", line_width=LINE_WIDTH, **line)
                lines.append(r)
                items.append(LegendItem(label=tr.label, renderers=[r, *drawn]))
                sides[bool(axis)].extend([r, *drawn])
            if panel.right:
                # each axis fits its own quantities only
                f.y_range.renderers = sides[False]
                f.extra_y_ranges["right"].renderers = sides[True]
            f.yaxis[0].axis_label = left_label
            tips = [("t*", "@time{0.0000}"), ("value", "$y{0.0000}")]
            f.add_tools(HoverTool(renderers=lines, tooltips=tips))
            f.add_layout(Legend(items=items, location="top_left"), "right")
        grid.append(figs)
    rows = [list(row) for row in zip_longest(*grid)]
    return column(Div(text=f"<h3>{html.escape(figure.title)}</h3>"), gridplot(rows, toolbar_location="right"))


# ---------------------------------------------------------------- data files
def samples_csv(ds: xr.Dataset) -> str:
    """The run's samples as CSV (a row per instant, a column per time-axis
    variable) after a comment header with the scene and the units."""
    import io

    names = [v for v in ds.data_vars if ds[v].dims == ("time",)]
    scene = ", ".join(
        f"{k}={ds.attrs[k]}"
        for k in ("model", "amplitude", "mass", "mu", "theta", "nu", "tau", "periods")
        if k in ds.attrs
    )
    head = [
        "# vibtrans run: " + scene,
        "# time in wave periods, lengths in a0 (x, y, a), b in theta mu a0; state: "
        + ", ".join(f"{i} {n}" for i, n in enumerate(STATE_NAMES)),
    ]
    if "x" in ds and ds.sizes.get("time", 0) > 2:
        from vibtrans.analysis.summary import drift_velocity, steadiness

        head.append(f"# drift <v*> = {drift_velocity(ds):.6g} a0 per period; {steadiness(ds)[1]}")
    buf = io.StringIO()
    buf.write("\n".join(head) + "\n")
    ds[names].to_dataframe().to_csv(buf, float_format="%.17g")
    return buf.getvalue()


def map_window(map_ds: xr.Dataset, log_amplitude: Any, log_mass: Any) -> xr.Dataset:
    """The map's points inside [log_amplitude] x [log_mass] (closed ranges)."""
    (a0, a1), (m0, m1) = sorted(log_amplitude), sorted(log_mass)
    la, lm = map_ds["log_amplitude"], map_ds["log_mass"]
    return map_ds.sel(log_amplitude=la[(la >= a0) & (la <= a1)], log_mass=lm[(lm >= m0) & (lm <= m1)])


def export_vertical(
    vertical: xr.Dataset,
    out: str | os.PathLike[str],
    dpi: int = DEFAULT_DPI,
    width: float = 6.5,
    height: float = 4.8,
) -> Any:
    """The jumping threshold A_J*(m*) of both models on log axes (paper Fig. 2).

    Parameters
    ----------
    vertical : xarray.Dataset
        The curve (`open_vertical`).
    out : str or os.PathLike
        .png, .svg, .pdf or .html.
    dpi, width, height : number
        Raster resolution; size in inches.

    Returns
    -------
    object
        The HoloViews figure drawn.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    ensure_backends()
    return _write(plots.vertical_curves(vertical), out, width, height, dpi)


def export_dynamics(
    el: Any, out: str | os.PathLike[str], dpi: int = DEFAULT_DPI, width: float = 7.0, height: float = 5.2
) -> Any:
    """A figure of the dynamics, as a file.

    Parameters
    ----------
    el : object
        A `plots` figure: lyapunov_map, section_figure, orbit_diagram_figure,
        continuation_figure or map_difference_figure.
    out : str or os.PathLike
        .png, .svg, .pdf or .html.
    dpi, width, height : number
        Raster resolution; size in inches.

    Returns
    -------
    object
        `el`.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    return _write(el, out, width, height, dpi)


def export_memory(
    snapshot: dict[str, Any],
    out: str | os.PathLike[str],
    dpi: int = DEFAULT_DPI,
    width: float = 13.0,
    height: float = 4.2,
) -> Any:
    """The memory diagram at one instant and the contact circle, as a file.

    Parameters
    ----------
    snapshot : dict
        A snapshot (`vibtrans.core.simulate.memory_snapshot`).
    out : str or os.PathLike
        .png, .svg, .pdf or .html.
    dpi, width, height : number
        Raster resolution; size in inches.

    Returns
    -------
    object
        The HoloViews layout drawn.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    ensure_backends()
    el = (plots.memory_diagram(snapshot) + plots.contact_circle(snapshot)).cols(3)
    return _write(el, out, width, height, dpi, html_cell=(420, 380))


def export_work_precision(
    results: Any,
    out: str | os.PathLike[str],
    dpi: int = DEFAULT_DPI,
    width: float = 12.0,
    height: float = 5.6,
    targets: tuple[float, float] = (0.05, 0.005),
    reference: str = "the reference preset refined twice",
) -> Figure:
    """Work-precision diagram of `workprecision.study` points (or their dicts):
    drift error (left) and trajectory error (right) against kernel seconds,
    log-log; a colour per scene, a marker per integrator, presets edged in
    black, dashed lines at the drift-error `targets`."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    fmt = output_format(out)
    _check_size(width, height, dpi)
    rows = [r if isinstance(r, dict) else r._asdict() for r in results]

    def num(v):
        return math.inf if v in ("inf", None) else float(v)

    floor = 1e-12  # exact agreement drawn at the floor
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    integrators = list(dict.fromkeys(r["integrator"] for r in rows))
    colours = matplotlib.colormaps["tab10"]
    markers = {"ab4": "o", "verlet": "s"}
    presets = {"preview", "standard", "reference"}
    series: dict[tuple, list] = {}  # (scene, integrator) -> stable points, coarse to fine, one per step
    for r in sorted(rows, key=lambda r: -num(r["h"])):
        pts = series.setdefault((r["scene"], r["integrator"]), [])
        new = r["setting"] in presets or all(p["h"] != r["h"] for p in pts)
        if new and r["stable"] and math.isfinite(num(r["seconds"])):
            pts.append(r)
    with matplotlib.rc_context(RC):
        fig = Figure(figsize=(width, height))
        FigureCanvasAgg(fig)
        axes = fig.subplots(1, 2)
        for ax, key, label in (
            (axes[0], "drift_error", "relative drift error"),
            (axes[1], "traj_error", "trajectory error, max |dx*|, |dy*| (a0)"),
        ):
            for i, scene in enumerate(scenes):
                for integ in integrators:
                    pts = series.get((scene, integ), [])
                    if not pts:
                        continue
                    xs = [num(r["seconds"]) for r in pts]
                    ys = [max(num(r[key]), floor) for r in pts]
                    mk, c = markers.get(integ, "^"), colours(i % 10)
                    ls = "-" if integ == "ab4" else ":"
                    ax.plot(xs, ys, ls=ls, lw=1.0, color=c, marker=mk, ms=4.5, mfc=c, mec="none", alpha=0.9)
                    pre = [(x, y) for x, y, r in zip(xs, ys, pts) if r["setting"] in presets]
                    if pre:
                        ax.plot(*zip(*pre), ls="none", marker=mk, ms=7, mfc="none", mec="black", mew=1.0)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("kernel seconds (best of repeats)")
            ax.set_ylabel(label)
            ax.grid(True, which="major", lw=0.4, alpha=0.5)
        for t in targets:
            axes[0].axhline(t, color="grey", ls="--", lw=0.8)
        chaotic = {r["scene"] for r in rows if r.get("chaotic")}
        handles = [
            Line2D([], [], color=colours(i % 10), lw=2, label=s + (" (chaotic)" if s in chaotic else ""))
            for i, s in enumerate(scenes)
        ]
        for g in integrators:
            ls, label = ("-", g.upper()) if g == "ab4" else (":", g.capitalize())
            handles.append(Line2D([], [], color="black", ls=ls, marker=markers.get(g, "^"), label=label))
        handles.append(
            Line2D([], [], ls="none", marker="o", ms=7, mfc="none", mec="black", label="fidelity preset")
        )
        fig.legend(handles=handles, loc="lower center", ncol=6, frameon=False)
        fig.suptitle(
            f"Work-precision: error against cost, vs {reference} (AB4); "
            f"dashed: drift error {' and '.join(f'{t:g}' for t in targets)}"
        )
        fig.subplots_adjust(bottom=0.24, wspace=0.28)
        _fit(fig)
    _saved(fig, out, fmt, dpi)
    return fig


# ---------------------------------------------------------------- paper
def default_maps_dir() -> Path:
    """The shipped maps (`vibtrans.maps_dir()`)."""
    return maps_dir()


def map_path(maps_dir: str | os.PathLike[str], model: str, mu: float) -> Path:
    return Path(maps_dir) / f"{model}-mu{mu:g}.zarr"


def load_vertical(maps_dir: str | os.PathLike[str]) -> xr.Dataset | None:
    """The checked vertical curve of maps_dir, or None if it has none."""
    from vibtrans.maps.sweep import open_vertical

    path = Path(maps_dir) / "vertical.nc"
    return open_vertical(str(path)) if path.exists() else None


# paper figure number -> what it shows
PAPER_FIGURES = {
    2: ("vertical", None),
    3: ("maps", None),
    **{4 + k - 1: ("trajectory", k) for k in range(1, 9)},  # Figs. 4-11: points 1-8
    13: ("trajectory", 9),
    14: ("trajectory", 10),
}
TWIN_POINTS = (8, 10)  # chaotic: shown with their chaos twin (analysis.twin_scene)


def point_title(point: int, scene: Scene) -> str:
    la, lm, model = PAPER_POINTS[point]
    return f"Point {point}: {model}, A* = 10^{la:g}, m* = 10^{lm:g}, mu = {scene.mu:g}"


def export_paper(
    out_dir: str | os.PathLike[str],
    progress: bool = True,
    maps: str | os.PathLike[str] | None = None,
    dpi: int = DEFAULT_DPI,
    periods: float | None = None,
    fmt: str = "png",
) -> dict[Any, Any]:
    """Regenerate the paper's figures into a folder.

    One file per figure and an index.md naming each figure's scene and the
    command that makes it alone (a figure whose data is missing: not made).

    Parameters
    ----------
    out_dir : str or os.PathLike
        The folder, created if missing.
    progress : bool
        Show a progress bar on stderr.
    maps : str or os.PathLike, optional
        Folder of the shipped maps; None: `default_maps_dir()`.
    dpi : int
        Resolution of raster figures.
    periods : float, optional
        T_obs of the trajectories' runs; None: the paper's.
    fmt : str
        "png", "svg" or "pdf".

    Returns
    -------
    dict
        {figure number: path, or None where not made}.

    Raises
    ------
    InputError
        If `fmt` or `dpi` is not accepted.
    """
    from tqdm import tqdm

    from vibtrans.core.simulate import simulate
    from vibtrans.maps.sweep import open_map

    if fmt not in FORMATS:
        raise InputError(f"fmt must be one of {', '.join(FORMATS)}, got {fmt!r}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"out must be a folder for the paper's figures, got the file {out_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)
    maps = Path(maps) if maps is not None else default_maps_dir()
    ensure_backends()
    vertical = load_vertical(maps)
    maps_arg = "" if maps == default_maps_dir() else f" --maps {shlex.quote(str(maps))}"
    made: dict = {}
    rows: list[tuple] = []
    path: Path | None
    start = time.perf_counter()
    bar = tqdm(PAPER_FIGURES.items(), desc="paper figures", file=sys.stderr, disable=not progress, unit="fig")
    for number, (kind, point) in bar:
        name = {"vertical": "vertical", "maps": "drift-maps"}.get(kind, f"point{point}")
        path = out_dir / f"fig{number:02d}-{name}.{fmt}"
        note = ""
        if kind == "vertical":
            what = "Jumping threshold A_J*(m*): deformable (Hertz) vs material point, resonances marked"
            scene = f"vertical model, tau = 50, T_obs = 2000 (`{maps / 'vertical.nc'}`)"
            cmd = f"vibtrans export vertical --out {path.name}{maps_arg}"
            if vertical is None:
                path, note = None, f"not made: no {maps / 'vertical.nc'}"
            else:
                export_vertical(vertical, path, dpi=dpi)
        elif kind == "maps":
            what = "Drift-velocity maps in the paper's colour scale: (a) deformable, (b) material point"
            scene = "mu = 0.3, theta = 1.2, nu = 0.3, tau = 50, T_obs = 2000 (shipped maps)"
            cmd = (
                f"vibtrans export heatmap --model deformable --out fig03a.{fmt}{maps_arg}; "
                f"vibtrans export heatmap --model point-mass --out fig03b.{fmt}{maps_arg}"
            )
            panels = []
            for model in ("deformable", "point-mass"):
                try:
                    ds = open_map(str(map_path(maps, model, 0.3)))
                except (OSError, ValueError) as exc:
                    note += f"{model} map missing ({exc}); "
                    continue
                if not bool(ds["done"].values.all()):
                    note += f"{model} map partial ({int(ds['done'].sum())}/{ds.sizes['chunk']} chunks); "
                letter = "(a)" if model == "deformable" else "(b)"
                panels.append(heatmap_figure(ds, vertical=vertical, title=f"{letter} {model}, mu = 0.3"))
            if panels:
                save(hv.Layout(panels).cols(2), path, width=13.0, height=5.2, dpi=dpi, hspace=MAPS_HSPACE)
            else:
                path, note = None, "not made: " + note
        else:
            la, lm, model = PAPER_POINTS[point]
            sc = paper_scene(point) if periods is None else paper_scene(point, periods=periods)
            window = (max(0.0, sc.periods - FRAGMENT), sc.periods)
            ds = simulate(sc, window=window, samples_per_period=OVERVIEW_SAMPLES)
            twin = None
            what = f"Paper point {point} ({model}): whole run and last {FRAGMENT:g} periods"
            cmd = f"vibtrans export trajectory --point {point} --out {path.name}"
            if point in TWIN_POINTS:
                twin = simulate(twin_scene(sc), window=window, samples_per_period=OVERVIEW_SAMPLES)
                what, cmd = what + ", with its tau + 1e-3 twin", cmd + " --twin"
            scene = (
                f"{model}, log10 A* = {la:g}, log10 m* = {lm:g}, mu = {sc.mu:g}, "
                f"theta = {sc.theta:g}, tau = {sc.tau:g}, T_obs = {sc.periods:g}, "
                f"{sc.fidelity}, {sc.integrator}"
            )
            cmd += "" if periods is None else f" --periods {periods:g}"
            export_trajectory(ds, path, twin=twin, dpi=dpi, title=point_title(point, sc))
        made[number] = path
        rows.append((number, path, what, scene, cmd, note.rstrip("; ")))
    bar.close()
    _write_index(out_dir, rows, maps, time.perf_counter() - start, dpi, periods)
    return made


def _write_index(out_dir, rows, maps, seconds, dpi, periods):
    from vibtrans.version import __version__

    lines = [
        "# The paper's figures, regenerated by vibtrans",
        "",
        f"Made by `vibtrans export paper --out {out_dir}"
        f"{'' if maps == default_maps_dir() else ' --maps ' + str(maps)}"
        f"{'' if dpi == DEFAULT_DPI else f' --dpi {dpi}'}"
        f"{'' if periods is None else f' --periods {periods:g}'}` "
        f"(vibtrans {__version__}, {seconds:.0f} s). Maps from `{maps}`.",
        "",
    ]
    for number, path, what, scene, cmd, note in rows:
        lines += [f"## Fig. {number}: {what}", ""]
        if path is not None:
            lines += [f"![Fig. {number}]({Path(path).name})", ""]
        lines += [f"- scene: {scene}", f"- alone: `{cmd}`"]
        if note:
            lines.append(f"- note: {note}")
        lines.append("")
    with atomic(Path(out_dir) / "index.md") as tmp:
        Path(tmp).write_text("\n".join(lines))


def export_design(
    chart: xr.Dataset,
    out: str | os.PathLike[str],
    device: tuple[float, float] | None = None,
    dpi: int = DEFAULT_DPI,
    width: float = 7.5,
    height: float = 6.0,
    title: str | None = None,
) -> Any:
    """A design chart, as a figure file.

    Parameters
    ----------
    chart : xarray.Dataset
        A chart (`design_chart`).
    out : str or os.PathLike
        .png, .svg, .pdf or .html.
    device : tuple of float, optional
        (x, y) of a device to mark, in the chart's coordinates.
    dpi, width, height : number
        Raster resolution; size in inches.
    title : str, optional
        The figure's title; None: the chart's.

    Returns
    -------
    object
        The HoloViews figure drawn.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    ensure_backends()
    el = plots.design_figure(chart, device, title).opts(
        {k: dict(aspect="auto") for k in ("QuadMesh", "Path", "Labels", "Points")}, backend="matplotlib"
    )
    return _write(el, out, width, height, dpi)
