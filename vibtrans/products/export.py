"""Headless figure export: publication PNG/SVG/PDF with the HoloViews
matplotlib backend (Agg; no display, no browser, no webdriver), standalone
interactive HTML with the bokeh backend (inline resources, no server), and
the paper's figures in one call (`export_paper`).

The figures are the ones the explorer shows (`vibtrans.products.plots`): the same
definitions, rendered by another backend.  Exporting from a process that
serves the explorer is safe: the matplotlib backend is loaded without
changing `hv.Store.current_backend`, and every render names its backend.

Every `export_*` function returns the HoloViews object it rendered
(`export_trajectory`: the `plots.TrajectoryFigure`, drawn without HoloViews).
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
    matplotlib.use("Agg")          # before pyplot is imported (by HoloViews)

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
HSPACE = 0.35            # gap between a layout's columns, in axes widths
MAPS_HSPACE = 0.6        # ... beside a map: its colour bar, ticks and two-line title

# publication defaults: readable fonts, text kept as text in SVG, TrueType in PDF
RC: dict[RcKeyType, Any] = {
    "font.size": 11, "axes.titlesize": 11, "axes.labelsize": 11,
    "xtick.labelsize": 9.5, "ytick.labelsize": 9.5, "legend.fontsize": 9,
    "legend.framealpha": 0.85, "axes.linewidth": 0.8, "axes.formatter.useoffset": False,
    "svg.fonttype": "none", "pdf.fonttype": 42, "ps.fonttype": 42,
    "figure.facecolor": "white", "savefig.facecolor": "white",
}
_ELEMENTS = ("Curve", "Image", "Rectangles", "Polygons", "Points", "Labels", "Text",
             "HLine", "VLine", "VSpan", "Overlay")


# ---------------------------------------------------------------- backends
def ensure_backends() -> None:
    """Load the bokeh and matplotlib plotting backends of HoloViews (their
    option trees) without changing the current backend (bokeh if none was
    selected yet).  Call before building figures to be rendered headless."""
    had = hv.Store.current_backend if hv.Store.renderers else None
    import holoviews.plotting.bokeh  # noqa: F401
    import holoviews.plotting.mpl  # noqa: F401
    hv.Store.set_current_backend(had or "bokeh")     # also fills hv.opts builders


def output_format(out: str | os.PathLike[str], allowed: tuple[str, ...] = FORMATS) -> str:
    ext = Path(out).suffix.lower().lstrip(".")
    if ext not in allowed:
        raise InputError(f"out must end in {', '.join('.' + a for a in allowed)}; got {str(out)!r}")
    return ext


def _check_size(width, height, dpi):
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (
                math.isfinite(v) and 0.5 <= v <= 50):
            raise InputError(f"{name} must be a number of inches in [0.5, 50], got {v!r}")
    if isinstance(dpi, bool) or not isinstance(dpi, (int, np.integer)) or not 20 <= dpi <= 1200:
        raise InputError(f"dpi must be an integer in [20, 1200], got {dpi!r}")
    if width * height * dpi * dpi > MAX_PIXELS:
        raise InputError(f"dpi too large for a {width:g} x {height:g} in figure: "
                         f"{width * dpi:.0f} x {height * dpi:.0f} px is over "
                         f"{MAX_PIXELS:.0e} pixels")


def _publication(obj, width, height, hspace=HSPACE):
    """matplotlib options of a publication figure: axes fill their cells (the
    final size is fixed later), no sub-figure letters, no shared ranges."""
    spec: dict[str, dict[str, Any]] = {k: dict(aspect="auto") for k in _ELEMENTS}
    spec["Layout"] = dict(sublabel_format="", fig_inches=(width, height), hspace=hspace,
                          vspace=0.6)
    spec["Overlay"] = dict(aspect="auto", fig_inches=(width, height))
    spec["Image"] = dict(aspect="auto", fig_inches=(width, height))
    return obj.opts(spec, backend="matplotlib")


def _fit(fig, pad=0.06, rounds=6):
    """Scale and shift every axes (colour bars included) so that everything
    drawn, labels and legends too, fills the canvas with `pad` inches spare.
    The canvas size is not changed (exact pixel size on output)."""
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
            ax.set_position([tx0 + (p.x0 - x0) * sx, ty0 + (p.y0 - y0) * sy,
                             p.width * sx, p.height * sy])


def render(obj: Any, width: float = 7.0, height: float = 5.0, hspace: float = HSPACE) -> Figure:
    """A matplotlib Figure of `obj` at width x height inches (not shown;
    close it with matplotlib.pyplot.close when done); a layout's columns
    `hspace` axes widths apart."""
    ensure_backends()
    obj = _publication(obj, width, height, hspace)
    with matplotlib.rc_context(RC):
        fig = hv.render(obj, backend="matplotlib")
        FigureCanvasAgg(fig)         # HoloViews closed it: attach a headless canvas
        fig.set_size_inches(width, height)
        _fit(fig)
    return fig


def save(obj: Any, out: str | os.PathLike[str], width: float = 7.0, height: float = 5.0,
         dpi: int = DEFAULT_DPI, hspace: float = HSPACE) -> Any:
    """Render `obj` with matplotlib and write out (.png, .svg or .pdf):
    exactly width*dpi x height*dpi pixels for PNG."""
    fmt = output_format(out)
    _check_size(width, height, dpi)
    import matplotlib.pyplot as plt
    fig = render(obj, width, height, hspace)
    try:
        _savefig(fig, out, fmt, dpi)
    finally:
        plt.close(fig)
    return obj


def _savefig(fig, out, fmt, dpi):
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    with matplotlib.rc_context(RC), atomic(out) as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi, metadata=_metadata(fmt))


def _metadata(fmt):
    from vibtrans.version import __version__
    creator = f"vibtrans {__version__}"
    if fmt == "png":
        return {"Software": creator}
    if fmt == "svg":
        return {"Creator": creator, "Date": None}
    return {"Creator": creator, "CreationDate": None}


def export_html(obj: Any, out: str | os.PathLike[str], title: str = "vibtrans") -> Any:
    """A standalone interactive HTML file (Bokeh, resources inline).

    It opens offline, with no server.

    Parameters
    ----------
    obj : object
        A HoloViews object built with the bokeh backend loaded, a Bokeh
        model, or anything Panel can show.
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
    from panel.io.state import set_curdoc
    output_format(out, ("html",))
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    # Panel's save renders into a document of its own but takes its
    # stylesheets from the current one's cache: from a served page's callback
    # it rewrote that page's shared stylesheets to Panel's CDN.  A scratch
    # current document keeps the page's apart.
    with atomic(out) as tmp, set_curdoc(Document()):
        if isinstance(obj, hv.core.dimension.Dimensioned):
            ensure_backends()
            hv.save(obj, tmp, fmt="html", backend="bokeh", resources="inline", title=title)
        elif isinstance(obj, Model):
            from bokeh.embed import file_html
            from bokeh.resources import INLINE
            # a document of its own, whose only root is obj: file_html then
            # uses it as is; without one it copies curdoc()'s callbacks, and
            # in a server callback curdoc() can be a closed page's destroyed
            # document (AttributeError: the .html download never arrived)
            if obj.document is None:
                Document().add_root(obj)
            Path(tmp).write_text(file_html(obj, INLINE, title=title), encoding="utf-8")
        else:
            import panel as pn
            from bokeh.resources import INLINE
            pn.panel(obj).save(tmp, resources=INLINE, title=title, embed=True)
    return obj


def _html_size(obj, width_px, height_px):
    spec = {k: dict(width=width_px, height=height_px) for k in
            ("Curve", "Image", "Rectangles", "Polygons", "Overlay")}
    spec["Curve"]["tools"] = ["hover"]
    spec["Image"]["tools"] = ["hover"]
    return obj.opts(spec, backend="bokeh")


def _write(obj, out, width, height, dpi, html_cell=None):
    """PNG/SVG/PDF through matplotlib; .html through bokeh (each panel
    html_cell=(w, h) pixels, default from the figure's inches)."""
    if Path(out).suffix.lower() == ".html":
        w, h = html_cell or (int(width * 100), int(height * 100))
        return export_html(_html_size(obj, w, h), out)
    return save(obj, out, width, height, dpi)


# ---------------------------------------------------------------- figures
def heatmap_figure(map_ds: xr.Dataset, v0: float = V0, vertical: xr.Dataset | None = None,
                   chaotic: str = "grey", title: str | None = None):
    """The explorer's map (same layers): drift velocity in the paper's colour
    scale, jumping boundary (and resonances, deformable), paper points."""
    ensure_backends()
    if isinstance(v0, bool) or not isinstance(v0, (int, float)) or not (
            math.isfinite(v0) and v0 > 0):
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


def export_heatmap(map_ds: xr.Dataset, out: str | os.PathLike[str], v0: float = V0,
                   vertical: xr.Dataset | None = None, dpi: int = DEFAULT_DPI, width: float = 7.0,
                   height: float = 5.2, chaotic: str = "grey", title: str | None = None) -> Any:
    """The drift map of a sweep, as a figure file.

    Parameters
    ----------
    map_ds : xarray.Dataset
        A map, as `open_map` returns it.
    out : str or os.PathLike
        The file: .png, .svg, .pdf or .html (interactive).
    v0 : float
        Drift speeds below this (a0 per period) are drawn as no drift.
    vertical : xarray.Dataset, optional
        The jumping threshold (`open_vertical`), drawn over the map.
    dpi : int
        Resolution of a raster output.
    width, height : float
        Size in inches.
    chaotic : str
        How chaotic points are drawn ("grey": a grey layer).
    title : str, optional
        The figure's title; None: the map's.

    Returns
    -------
    object
        The figure drawn (a HoloViews object).

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    return _write(heatmap_figure(map_ds, v0, vertical, chaotic, title), out, width, height,
                  dpi)


def export_trajectory(ds: xr.Dataset, out: str | os.PathLike[str],
                      window: tuple[float, float] | None = None, twin: xr.Dataset | None = None,
                      dpi: int = DEFAULT_DPI, width: float = 11.0, height: float | None = None,
                      title: str | None = None) -> TrajectoryFigure:
    """A run's trajectory figure, as a file.

    The whole run as per-bin mean and min-max envelope, and the
    full-resolution fragment `window`; with a twin run (tau + 1e-3), a last
    row compares x*(t).  Matplotlib draws .png, .svg and .pdf; Bokeh .html.

    Parameters
    ----------
    ds : xarray.Dataset
        A run, as `simulate` returns it.
    out : str or os.PathLike
        The file: .png, .svg, .pdf or .html.
    window : tuple of float, optional
        (t0, t1) of the fragment; None: the run's recorded window, else its
        last 2 periods.
    twin : xarray.Dataset, optional
        The tau + 1e-3 twin run.
    dpi : int
        Resolution of a raster output.
    width, height : float
        Size in inches.
        None height: from the number of rows.
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
    import matplotlib.pyplot as plt
    fig = render_trajectory(figure, width, height)
    try:
        _savefig(fig, out, fmt, dpi)
    finally:
        plt.close(fig)
    return figure


# The trajectory figure is drawn with matplotlib and Bokeh directly, not
# through HoloViews (plots.py, "trajectories", says why): its twelve panels
# are a few lines, bands and polygons each.
LINE_WIDTH = 1.5
ENVELOPE_ALPHA = 0.3         # a per-bin min-max band: fill, outline opacity and width
ENVELOPE_EDGE_ALPHA = 0.6
ENVELOPE_EDGE_WIDTH = 0.6
TIME_LABEL = "t* (periods)"


def _mpl_panel(ax, panel):
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator
    ax.set_title(panel.title)
    ax.set_xlabel(TIME_LABEL)
    ax.set_xlim(*panel.xlim)
    ax.xaxis.set_major_locator(MaxNLocator(5))
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    if panel.strip is not None:
        from matplotlib.collections import PolyCollection
        edges, shares = panel.strip
        handles: list = []
        for code, name in enumerate(STATE_NAMES):
            if shares[:, code].any():
                # one polygon per state, not snapped to pixels: a band
                # narrower than a pixel keeps its share of the pixel (a
                # collection: add_patch walked its thousands of vertices
                # in Python for the data limits, which are set here)
                x, y = plots.strip_outline(edges, shares, code)
                ax.add_collection(PolyCollection([np.column_stack([x, y])], snap=False,
                                                 facecolors=plots.STATE_COLORS[code],
                                                 linewidths=0), autolim=False)
                handles.append(Patch(facecolor=plots.STATE_COLORS[code], label=name))
        # the bands fill the strip's lower part, their legend the upper
        ax.set_ylim(0.0, 1.8)
        ax.set_yticks([])
        ax.spines["left"].set_visible(False)
        ax.legend(handles=handles, loc="upper left", ncols=4)
        return
    handles = []
    # the panel's right-axis quantities (y* beside a*, ...) on an axis of
    # their own, as the explorer draws them (plots.RIGHT_AXIS)
    left_label, right_label = panel.axis_labels
    twin: Any = None
    if panel.right:
        twin = ax.twinx()
        twin.spines["top"].set_visible(False)
        twin.set_ylabel(right_label)
    for tr in panel.traces:
        on = twin if tr.var in panel.right else ax
        band = None
        if tr.lo is not None:
            # outlined: a bin far taller than its neighbours (an impact's
            # force) stays a visible spike, as the line of every sample drew it
            band = on.fill_between(tr.time, tr.lo, tr.hi,
                                   facecolor=to_rgba(tr.colour, ENVELOPE_ALPHA),
                                   edgecolor=to_rgba(tr.colour, ENVELOPE_EDGE_ALPHA),
                                   linewidth=ENVELOPE_EDGE_WIDTH,
                                   linestyle="--" if tr.dash == "dashed" else "-")
        line, = on.plot(tr.time, tr.value, color=tr.colour, linewidth=LINE_WIDTH,
                        linestyle="--" if tr.dash == "dashed" else "-", label=tr.label)
        handles.append(line if band is None else (band, line))
    ax.set_ylabel(left_label)
    if twin is not None:
        # the panel's axes above its twin's, see-through: its legend (one
        # for both axes) is drawn over the twin's lines
        ax.set_zorder(twin.get_zorder() + 1)
        ax.patch.set_visible(False)
    ax.legend(handles, [tr.label for tr in panel.traces], loc="best")


def render_trajectory(figure: Any, width: float = 11.0, height: float = 13.0) -> Figure:
    """A matplotlib Figure of a `plots.TrajectoryFigure`, width x height
    inches, its columns side by side (close it with
    matplotlib.pyplot.close when done)."""
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
        # constrained layout places titles, labels and legends without a
        # draw (the HoloViews figures' _fit drew up to 7 times); run once,
        # here: as the figure's engine it would run in savefig's dry draw
        # and again in its real one, a dry draw that no engine makes needless
        ConstrainedLayoutEngine(w_pad=0.04, h_pad=0.04, hspace=0.03,
                                wspace=0.06).execute(fig)
    return fig


def trajectory_bokeh(figure: Any, cell: tuple[int, int] = (650, 180)) -> Any:
    """A Bokeh layout of a `plots.TrajectoryFigure` (standalone HTML): the
    title, then the columns side by side, each panel `cell` = (width,
    height) pixels, a column's panels on one linked, zoomable time axis."""
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
            f = bokeh_figure(title=panel.title, width=width, height=height, x_range=x_range,
                             tools="xpan,xwheel_zoom,box_zoom,reset,save",
                             active_scroll="xwheel_zoom")
            f.xaxis.axis_label = TIME_LABEL
            f.toolbar.logo = None
            items = []
            if panel.strip is not None:
                edges, shares = panel.strip
                for code, name in enumerate(STATE_NAMES):
                    if shares[:, code].any():
                        x, y = plots.strip_outline(edges, shares, code)
                        # no outline: over a long run's narrow bands it was
                        # all one saw (bokeh outlines in black by default)
                        r = f.patch(x=x, y=y, fill_color=plots.STATE_COLORS[code],
                                    line_width=0, line_alpha=0)
                        items.append(LegendItem(label=name, renderers=[r]))
                f.y_range = Range1d(0.0, 1.8)
                f.yaxis.visible = False
                f.ygrid.visible = False
                f.add_layout(Legend(items=items, location="top_left",
                                    orientation="horizontal"))
            else:
                lines: list = []
                on_left: list = []
                on_right: list = []
                left_label, right_label = panel.axis_labels
                if panel.right:
                    from bokeh.models import DataRange1d, LinearAxis
                    f.extra_y_ranges = {"right": DataRange1d()}
                    f.add_layout(LinearAxis(y_range_name="right", axis_label=right_label),
                                 "right")
                for tr in panel.traces:
                    axis = {"y_range_name": "right"} if tr.var in panel.right else {}
                    data = {"time": tr.time, "value": tr.value}
                    if tr.lo is not None:
                        data.update(lo=tr.lo, hi=tr.hi)
                    src = ColumnDataSource(data)
                    drawn = []
                    if tr.lo is not None:
                        drawn.append(f.varea(x="time", y1="lo", y2="hi", fill_color=tr.colour,
                                             fill_alpha=ENVELOPE_ALPHA, source=src, **axis))
                        drawn += [f.line(x="time", y=edge, line_color=tr.colour,
                                         line_alpha=ENVELOPE_EDGE_ALPHA, line_width=1,
                                         line_dash=tr.dash or "solid", source=src, **axis)
                                  for edge in ("lo", "hi")]
                    r = f.line(x="time", y="value", line_color=tr.colour,
                               line_width=LINE_WIDTH, line_dash=tr.dash or "solid", source=src,
                               **axis)
                    lines.append(r)
                    items.append(LegendItem(label=tr.label, renderers=[r, *drawn]))
                    (on_right if axis else on_left).extend([r, *drawn])
                if panel.right:
                    # each axis fits its own quantities only
                    f.y_range.renderers = on_left
                    f.extra_y_ranges["right"].renderers = on_right
                f.yaxis[0].axis_label = left_label
                f.add_tools(HoverTool(renderers=lines, tooltips=[("t*", "@time{0.0000}"),
                                                                 ("value", "$y{0.0000}")]))
                f.add_layout(Legend(items=items, location="top_left"), "right")
            figs.append(f)
        grid.append(figs)
    rows = [list(row) for row in zip_longest(*grid)]
    return column(Div(text=f"<h3>{html.escape(figure.title)}</h3>"),
                  gridplot(rows, toolbar_location="right"))


# ---------------------------------------------------------------- data files
def samples_csv(ds: xr.Dataset) -> str:
    """The run's samples as CSV text: one row per recorded instant, a
    column per variable on the time axis (normalized units, docs/MODEL.md
    section 4), after a comment header with the scene and the units.  The
    events (take-offs, landings, state changes) are in the netCDF file."""
    import io
    names = [v for v in ds.data_vars if ds[v].dims == ("time",)]
    head = ["# vibtrans run: " + ", ".join(f"{k}={ds.attrs[k]}" for k in (
        "model", "amplitude", "mass", "mu", "theta", "nu", "tau", "periods") if k in ds.attrs),
        "# time in wave periods, lengths in a0 (x, y, a), b in theta mu a0; state: "
        + ", ".join(f"{i} {n}" for i, n in enumerate(STATE_NAMES))]
    if "x" in ds and ds.sizes.get("time", 0) > 2:
        from vibtrans.analysis.summary import drift_velocity, steadiness
        head.append(f"# drift <v*> = {drift_velocity(ds):.6g} a0 per period; "
                    f"{steadiness(ds)[1]}")
    buf = io.StringIO()
    buf.write("\n".join(head) + "\n")
    ds[names].to_dataframe().to_csv(buf, float_format="%.17g")
    return buf.getvalue()


def map_window(map_ds: xr.Dataset, log_amplitude: Any, log_mass: Any) -> xr.Dataset:
    """The map's points inside [log_amplitude] x [log_mass] (closed ranges,
    e.g. a zoomed view's), with the map's attributes."""
    (a0, a1), (m0, m1) = sorted(log_amplitude), sorted(log_mass)
    la, lm = map_ds["log_amplitude"], map_ds["log_mass"]
    return map_ds.sel(log_amplitude=la[(la >= a0) & (la <= a1)],
                      log_mass=lm[(lm >= m0) & (lm <= m1)])


def export_vertical(vertical: xr.Dataset, out: str | os.PathLike[str], dpi: int = DEFAULT_DPI,
                    width: float = 6.5, height: float = 4.8) -> Any:
    """The jumping threshold A_J*(m*) of both models on log axes (paper Fig. 2).

    Parameters
    ----------
    vertical : xarray.Dataset
        The curve, as `open_vertical` returns it.
    out : str or os.PathLike
        The file: .png, .svg, .pdf or .html.
    dpi : int
        Resolution of a raster output.
    width, height : float
        Size in inches.

    Returns
    -------
    object
        The figure drawn (a HoloViews object).

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    ensure_backends()
    return _write(plots.vertical_curves(vertical), out, width, height, dpi)


def export_dynamics(el: Any, out: str | os.PathLike[str], dpi: int = DEFAULT_DPI,
                    width: float = 7.0, height: float = 5.2) -> Any:
    """A map-like figure of the dynamics, as a file.

    Parameters
    ----------
    el : object
        A figure of `plots`: lyapunov_map, section_figure,
        orbit_diagram_figure, continuation_figure or map_difference_figure
        (the explorer's).
    out : str or os.PathLike
        The file: .png, .svg, .pdf or .html.
    dpi : int
        Resolution of a raster output.
    width, height : float
        Size in inches.

    Returns
    -------
    object
        The figure drawn.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    return _write(el, out, width, height, dpi)


def memory_figure(snapshot: Any) -> Any:
    """Memory diagram w(h), spring displacements u(h) and the contact circle."""
    ensure_backends()
    mem = plots.memory_diagram(snapshot)
    return (mem + plots.contact_circle(snapshot)).cols(3)


def export_memory(snapshot: dict[str, Any], out: str | os.PathLike[str], dpi: int = DEFAULT_DPI,
                  width: float = 13.0, height: float = 4.2) -> Any:
    """The memory diagram at one instant, as a figure file.

    Parameters
    ----------
    snapshot : dict
        A snapshot, as `vibtrans.core.simulate.memory_snapshot` returns it.
    out : str or os.PathLike
        The file: .png, .svg, .pdf or .html.
    dpi : int
        Resolution of a raster output.
    width, height : float
        Size in inches.

    Returns
    -------
    object
        The figure drawn.

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    return _write(memory_figure(snapshot), out, width, height, dpi, html_cell=(420, 380))


def export_work_precision(results: Any, out: str | os.PathLike[str], dpi: int = DEFAULT_DPI,
                          width: float = 12.0, height: float = 5.6,
                          targets: tuple[float, float] = (0.05, 0.005),
                          reference: str = "the reference preset refined twice") -> Figure:
    """Work-precision diagram of `workprecision.study` points (named tuples or
    their dicts): error against kernel seconds, log-log; left the relative
    drift error, right the trajectory error; one colour per scene, one marker
    per integrator (AB4 circles, Verlet squares), the fidelity presets with a
    black edge; dashed lines at the drift-error targets (preview, standard).
    Each scene's points are joined from coarse to fine step."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    fmt = output_format(out)
    _check_size(width, height, dpi)
    rows = [r if isinstance(r, dict) else r._asdict() for r in results]

    def num(v):
        return math.inf if v in ("inf", None) else float(v)
    floor = 1e-12                      # exact agreement drawn at the floor
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    integrators = list(dict.fromkeys(r["integrator"] for r in rows))
    colours = matplotlib.colormaps["tab10"]
    markers = {"ab4": "o", "verlet": "s"}
    presets = {"preview", "standard", "reference"}
    with matplotlib.rc_context(RC):
        fig = Figure(figsize=(width, height))
        FigureCanvasAgg(fig)
        axes = fig.subplots(1, 2)
        for ax, key, label in ((axes[0], "drift_error", "relative drift error"),
                               (axes[1], "traj_error", "trajectory error, max |dx*|, |dy*| (a0)")):
            for i, scene in enumerate(scenes):
                for integ in integrators:
                    pts, seen = [], set()       # coarse to fine; one point per step
                    for r in sorted((r for r in rows if r["scene"] == scene
                                     and r["integrator"] == integ and r["stable"]
                                     and math.isfinite(num(r["seconds"]))),
                                    key=lambda r: -num(r["h"])):
                        if r["h"] not in seen or r["setting"] in presets:
                            seen.add(r["h"])
                            pts.append(r)
                    if not pts:
                        continue
                    xs = [num(r["seconds"]) for r in pts]
                    ys = [max(num(r[key]), floor) for r in pts]
                    mk = markers.get(integ, "^")
                    ax.plot(xs, ys, ls="-" if integ == "ab4" else ":", lw=1.0,
                            color=colours(i % 10), marker=mk, ms=4.5, mfc=colours(i % 10),
                            mec="none", alpha=0.9)
                    pre = [(x, y) for x, y, r in zip(xs, ys, pts) if r["setting"] in presets]
                    if pre:
                        ax.plot(*zip(*pre), ls="none", marker=mk, ms=7, mfc="none",
                                mec="black", mew=1.0)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("kernel seconds (best of repeats)")
            ax.set_ylabel(label)
            ax.grid(True, which="major", lw=0.4, alpha=0.5)
        for t in targets:
            axes[0].axhline(t, color="grey", ls="--", lw=0.8)
        chaotic = {r["scene"] for r in rows if r.get("chaotic")}
        handles = [Line2D([], [], color=colours(i % 10), lw=2,
                          label=s + (" (chaotic)" if s in chaotic else ""))
                   for i, s in enumerate(scenes)]
        handles += [Line2D([], [], color="black", ls="-" if g == "ab4" else ":",
                           marker=markers.get(g, "^"), label=g.upper() if g == "ab4" else
                           g.capitalize()) for g in integrators]
        handles.append(Line2D([], [], ls="none", marker="o", ms=7, mfc="none", mec="black",
                              label="fidelity preset"))
        fig.legend(handles=handles, loc="lower center", ncol=6, frameon=False)
        fig.suptitle(f"Work-precision: error against cost, vs {reference} (AB4); "
                     f"dashed: drift error {' and '.join(f'{t:g}' for t in targets)}")
        fig.subplots_adjust(bottom=0.24, wspace=0.28)
        _fit(fig)
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        with atomic(out) as tmp:
            fig.savefig(tmp, format=fmt, dpi=dpi, metadata=_metadata(fmt))
    return fig


# ---------------------------------------------------------------- paper
def default_maps_dir() -> Path:
    """The shipped maps (vibtrans.maps_dir(): $VIBTRANS_ASSETS/maps, else
    the maps installed with the package)."""
    return maps_dir()


def map_path(maps_dir: str | os.PathLike[str], model: str, mu: float) -> Path:
    return Path(maps_dir) / f"{model}-mu{mu:g}.zarr"


def load_vertical(maps_dir: str | os.PathLike[str]) -> xr.Dataset | None:
    """The vertical curve of maps_dir, checked (sweep.open_vertical), or None
    if there is none; StoreMismatch (a ValueError) if it is unusable."""
    from vibtrans.maps.sweep import open_vertical
    path = Path(maps_dir) / "vertical.nc"
    return open_vertical(str(path)) if path.exists() else None


def paper_trajectory(point: int, periods: float | None = None,
                     window: tuple[float, float] | None = None, twin: bool = False,
                     progress: Any = None) -> tuple[Scene, xr.Dataset, xr.Dataset | None]:
    """Run a paper point as the figures show it: decimated overview and the
    full-resolution window (default: the last 2 periods)."""
    from vibtrans.core.simulate import simulate
    scene = paper_scene(point) if periods is None else paper_scene(point, periods=periods)
    T = scene.periods
    window = window or (max(0.0, T - FRAGMENT), T)
    ds = simulate(scene, window=window, samples_per_period=OVERVIEW_SAMPLES, progress=progress)
    other = None
    if twin:
        other = simulate(twin_scene(scene), window=window,
                         samples_per_period=OVERVIEW_SAMPLES)
    return scene, ds, other


# paper figure number -> what it shows
PAPER_FIGURES = {
    2: ("vertical", None),
    3: ("maps", None),
    **{4 + k - 1: ("trajectory", k) for k in range(1, 9)},   # Figs. 4-11: points 1-8
    13: ("trajectory", 9),
    14: ("trajectory", 10),
}
TWIN_POINTS = (8, 10)      # chaotic: shown with their chaos twin (analysis.twin_scene)


def point_title(point: int, scene: Scene) -> str:
    """Title of a paper point's trajectory figure."""
    la, lm, model = PAPER_POINTS[point]
    return f"Point {point}: {model}, A* = 10^{la:g}, m* = 10^{lm:g}, mu = {scene.mu:g}"


def _point_command(point, out):
    la, lm, model = PAPER_POINTS[point]
    cmd = (f"vibtrans export trajectory --point {point} --out {out}")
    return cmd + (" --twin" if point in TWIN_POINTS else "")


def export_paper(out_dir: str | os.PathLike[str], progress: bool = True,
                 maps: str | os.PathLike[str] | None = None,
                 dpi: int = DEFAULT_DPI, periods: float | None = None,
                 fmt: str = "png") -> dict[Any, Any]:
    """Regenerate the paper's figures into a folder.

    One file per figure, and an index.md naming each figure's scene and the
    command that makes it alone.  A figure whose data is missing is listed in
    the index as not made.

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
    bar = tqdm(PAPER_FIGURES.items(), total=len(PAPER_FIGURES), desc="paper figures",
               file=sys.stderr, disable=not progress, unit="fig")
    for number, (kind, point) in bar:
        name = f"fig{number:02d}"
        path = out_dir / f"{name}.{fmt}"
        note = ""
        if kind == "vertical":
            name += "-vertical"
            path = out_dir / f"{name}.{fmt}"
            what = ("Jumping threshold A_J*(m*): deformable (Hertz) vs material point, "
                    "resonances marked")
            scene = f"vertical model, tau = 50, T_obs = 2000 (`{maps / 'vertical.nc'}`)"
            cmd = f"vibtrans export vertical --out {path.name}{maps_arg}"
            if vertical is None:
                path, note = None, f"not made: no {maps / 'vertical.nc'}"
            else:
                export_vertical(vertical, path, dpi=dpi)
        elif kind == "maps":
            name += "-drift-maps"
            path = out_dir / f"{name}.{fmt}"
            what = ("Drift-velocity maps in the paper's colour scale: (a) deformable, "
                    "(b) material point")
            scene = "mu = 0.3, theta = 1.2, nu = 0.3, tau = 50, T_obs = 2000 (shipped maps)"
            cmd = (f"vibtrans export heatmap --model deformable --out fig03a.{fmt}{maps_arg}; "
                   f"vibtrans export heatmap --model point-mass --out fig03b.{fmt}{maps_arg}")
            panels = []
            for model in ("deformable", "point-mass"):
                p = map_path(maps, model, 0.3)
                try:
                    ds = open_map(str(p))
                except (OSError, ValueError) as exc:
                    note += f"{model} map missing ({exc}); "
                    continue
                if not bool(ds["done"].values.all()):
                    note += (f"{model} map partial ({int(ds['done'].sum())}/"
                             f"{ds.sizes['chunk']} chunks); ")
                letter = "(a)" if model == "deformable" else "(b)"
                panels.append(heatmap_figure(ds, vertical=vertical,
                                             title=f"{letter} {model}, mu = 0.3"))
            if panels:
                save(hv.Layout(panels).cols(2), path, width=13.0, height=5.2, dpi=dpi,
                     hspace=MAPS_HSPACE)
            else:
                path = None
                note = "not made: " + note
        else:
            la, lm, model = PAPER_POINTS[point]
            name += f"-point{point}"
            path = out_dir / f"{name}.{fmt}"
            sc, ds, twin = paper_trajectory(point, periods=periods, twin=point in TWIN_POINTS)
            what = f"Paper point {point} ({model}): whole run and last {FRAGMENT:g} periods" + (
                ", with its tau + 1e-3 twin" if twin is not None else "")
            scene = (f"{model}, log10 A* = {la:g}, log10 m* = {lm:g}, mu = {sc.mu:g}, "
                     f"theta = {sc.theta:g}, tau = {sc.tau:g}, T_obs = {sc.periods:g}, "
                     f"{sc.fidelity}, {sc.integrator}")
            cmd = _point_command(point, path.name)
            if periods is not None:
                cmd += f" --periods {periods:g}"
            export_trajectory(ds, path, twin=twin, dpi=dpi, title=point_title(point, sc))
        made[number] = path
        rows.append((number, path, what, scene, cmd, note.rstrip("; ")))
    bar.close()
    seconds = time.perf_counter() - start
    _write_index(out_dir, rows, maps, seconds, dpi, fmt, periods)
    return made


def _write_index(out_dir, rows, maps, seconds, dpi, fmt, periods):
    from vibtrans.version import __version__
    lines = ["# The paper's figures, regenerated by vibtrans", "",
             f"Made by `vibtrans export paper --out {out_dir}"
             f"{'' if maps == default_maps_dir() else ' --maps ' + str(maps)}"
             f"{'' if dpi == DEFAULT_DPI else f' --dpi {dpi}'}"
             f"{'' if periods is None else f' --periods {periods:g}'}` "
             f"(vibtrans {__version__}, {seconds:.0f} s). Maps from `{maps}`.", ""]
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


def export_design(chart: xr.Dataset, out: str | os.PathLike[str],
                  device: tuple[float, float] | None = None,
                  dpi: int = DEFAULT_DPI, width: float = 7.5, height: float = 6.0,
                  title: str | None = None) -> Any:
    """A design chart, as a figure file.

    Parameters
    ----------
    chart : xarray.Dataset
        A chart, as `design_chart` returns it.
    out : str or os.PathLike
        The file: .png, .svg, .pdf or .html.
    device : tuple of float, optional
        (x, y) of a device to mark, in the chart's coordinates.
    dpi : int
        Resolution of a raster output.
    width, height : float
        Size in inches.
    title : str, optional
        The figure's title; None: the chart's.

    Returns
    -------
    object
        The figure drawn (a HoloViews object).

    Raises
    ------
    InputError
        If `out`'s extension or a size is not accepted.
    """
    output_format(out, FORMATS + ("html",))
    ensure_backends()
    el = plots.design_figure(chart, device, title).opts(
        {k: dict(aspect="auto") for k in ("QuadMesh", "Path", "Labels", "Points")},
        backend="matplotlib")
    return _write(el, out, width, height, dpi)
