"""The explorer's live trajectory figures: plain Bokeh figures, built once
per session and structure (model, comparison), fed each run's columns.

The panels are the paper's trajectory figure as `vibtrans.products.plots` defines
it (`panel_spec`, `state_bands`, `twin_spec`; the exports draw the same
with HoloViews).  Here they are drawn with Bokeh directly because a
session's server time is what limits how many people one server holds:
building these figures through HoloViews took ~0.8 s per session and
feeding them ~0.15 s per run (measured with py-spy under the load test);
plain figures take a fraction of that, and a run is one data change per
source and a few range changes, sent to the browser as one message.
"""

import numpy as np
from bokeh.core.properties import field, value
from bokeh.layouts import column
from bokeh.models import (
    AllIndices,
    AllLabels,
    BasicTicker,
    BasicTickFormatter,
    CDSView,
    ColumnDataSource,
    Grid,
    HoverTool,
    Legend,
    LegendItem,
    Line,
    LinearAxis,
    LinearScale,
    Quad,
    Range1d,
    Title,
    VArea,
)
from bokeh.plotting import figure

from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.core.units import duration_text
from vibtrans.products import plots
from vibtrans_explorer.views.presentation import scale_fonts

MIN_WIDTH = 360  # the figures take their column's width, at least this
# The frames' heights (their data areas; each figure's height follows its
# title, legend and axes): with the figure's height fixed instead, the
# presentation mode's larger text took the state strip's whole height (its
# bars not drawn) and left a line panel's frame shorter than its right
# axis's label; in presentation mode they grow with the text (`scale_frames`)
LINE_FRAME = 150
STRIP_FRAME = 32  # the state strip (its legend above it, the time axis below)
TIMELINE_BINS = 400  # time bins of the whole-run state timeline
_COLOURS = np.array([plots.STATE_COLORS[k] for k in range(len(STATE_NAMES))])
_NAMES = np.array(STATE_NAMES)
# a panel's second quantity on an axis of its own at the right (plots.py)
RIGHT_AXIS, right_columns = plots.RIGHT_AXIS, plots.right_columns


# Every Bokeh model of a session is serialized to its browser, which costs
# server time per model (~0.3-1 ms under load): the figures keep to the
# models they need (no box zoom, save or per-line hover tools, glyph
# renderers without selection/muted copies, one time axis per block).
TOOLS = "xpan,xwheel_zoom,reset"


class _Shared:
    """The models that hold no state of a figure's own, made once per set of
    figures and referenced by all of them: the axes' value ticker, tick
    formatter and label policy (BokehJS 3.9 computes ticks and labels per
    axis view: `BasicTickFormatter` keeps no precision between calls), the
    figures' linear scale (each figure's frame draws with clones of it,
    `CartesianFrame._get_scales`), the renderers' row filter, and one CDSView per data source (BokehJS keeps a
    view's indices on the CDSView model, computed from its renderer's
    source: renderers of one source can share it, those of two cannot).
    `figure()` and `add_glyph` would make one of each per axis or renderer
    (103 of a set's 301 models), each built by the server, serialized to the
    browser and walked with the document's model graph at the session's
    first run; the figures drawn are the same (docs/how-to/deployment.md)."""

    def __init__(self):
        self.ticker = BasicTicker()
        self.formatter = BasicTickFormatter()
        self.labels = AllLabels()
        self.scale = LinearScale()
        self.rows = AllIndices()
        self._views = {}

    def axis(self, **kw):
        """A linear axis with the shared ticker, formatter and label policy."""
        return LinearAxis(ticker=self.ticker, formatter=self.formatter, major_label_policy=self.labels, **kw)

    def view(self, source):
        """The CDSView of every renderer of `source` (all its rows)."""
        if source.id not in self._views:
            self._views[source.id] = CDSView(filter=self.rows)
        return self._views[source.id]


def binned_title(title):
    """A panel's title over per-bin means: the binning's note on a line of its
    own (on one line the title was wider than the panel's frame)."""
    return f"{title}\n{plots.BINNED_NOTE.strip()}"


def _figure(title, ylabel, x_range, frame_height, shared, time_axis=True):
    """A panel: its value axis (left) and grid lines, and (`time_axis`) a
    time axis below; without, only the time's grid lines (the block's
    bottom panel has its axis).  Every axis and grid from the `shared`
    models."""
    fig = figure(
        title=Title(text=title),
        sizing_mode="stretch_width",
        min_width=MIN_WIDTH,
        height=None,
        frame_height=frame_height,
        x_range=x_range,
        y_range=Range1d(0.0, 1.0),
        tools=TOOLS,
        active_scroll="xwheel_zoom",
        output_backend="canvas",
        x_axis_type=None,
        y_axis_type=None,
    )
    fig.x_scale = fig.y_scale = shared.scale
    if time_axis:
        fig.add_layout(shared.axis(axis_label="t* (periods)"), "below")
    fig.add_layout(shared.axis(axis_label=ylabel), "left")
    fig.add_layout(Grid(dimension=0, ticker=shared.ticker))
    fig.add_layout(Grid(dimension=1, ticker=shared.ticker))
    fig.toolbar.logo = None
    return fig


def _lines(fig, sources, lines, shared, right=(), envelope=False):
    """Lines [(column, legend label, colour, dash), ...] of `sources` (one
    per line), a legend outside on the right, one hover for them all.
    Columns in `right` use the figure's right axis (`fig.extra_y_ranges`).
    envelope: each line is a per-bin mean, drawn over its min-max band
    (columns <col>_lo, <col>_hi).  shared: the set's `_Shared` models."""
    items, renderers = [], []
    for source, (col, label, colour, dash) in zip(sources, lines):
        axis = {"y_range_name": "right"} if col in right else {}
        axis["view"] = shared.view(source)
        band = VArea(x="time", y1=f"{col}_lo", y2=f"{col}_hi", fill_color=colour, fill_alpha=0.3)
        drawn = [fig.add_glyph(source, band, **axis)] if envelope else []
        line = Line(x="time", y=col, line_color=colour, line_width=1.5, line_dash=dash or "solid")
        r = fig.add_glyph(source, line, **axis)
        renderers.append(r)
        items.append(LegendItem(label=label, renderers=[r, *drawn]))
    fig.add_tools(HoverTool(renderers=renderers, tooltips=[("t*", "@time{0.0000}"), ("value", "$y{0.0000}")]))
    fig.add_layout(Legend(items=items, location="top_left"), "right")
    return items


class _Panel:
    """One line panel of a block, drawn for either model: the deformable
    particle's quantities (`panel_spec(False)`), of which the material
    point's (`panel_spec(True)`, the same panels with fewer quantities) are
    a subset.  `configure` shows one model's: its quantities, on a left
    axis and (two or more) a right one, its title and labels.  A point-mass
    run after a deformable one then draws into the same figures (the
    browser built a new set in 1-2 s)."""

    def __init__(self, fig, items, right_axis, specs):
        self.fig, self.right_axis = fig, right_axis
        self.items = dict(zip((c for c, _, _ in specs[False][2]), items))  # column -> its item
        self.specs = specs  # {rigid: (title, y label, [(column, label, colour)])}
        self.columns, self.right = [], []

    def configure(self, rigid):
        title, ylabel, lines = self.specs[rigid]
        cols = [c for c, _, _ in lines]
        right = right_columns(cols)
        left_label, right_label = plots.axis_labels({c: label for c, label, _ in lines}, right)
        self.fig.title.text = title
        self.fig.left[0].axis_label = left_label if right else ylabel
        if self.right_axis is not None:
            self.right_axis.visible = bool(right)
            if right:
                self.right_axis.axis_label = right_label
        for col, item in self.items.items():
            item.visible = col in cols
            for r in item.renderers:
                r.visible = col in cols
                r.y_range_name = "right" if col in right else "default"
                if hasattr(r.glyph, "line_dash"):  # (its line, not its band)
                    r.glyph.line_dash = plots.axis_dash(col, right) or "solid"
        self.columns, self.right = cols, right


def _relative_title(title):
    """A fragment panel's title: x* counted from the window's start, on a
    line of its own after another quantity (on one line the title was wider
    than its frame at 1024 pixels in presentation mode)."""
    if ", x*(t)" in title:
        return title.replace(", x*(t)", ",\nx*(t) - x*(t0)")
    return title.replace("x*(t)", "x*(t) - x*(t0)")


def _timeline(title, x_range, shared):
    # (its parenthesis on a line of its own, as a binned panel's note)
    fig = _figure(title.replace(" (", "\n("), "state", x_range, STRIP_FRAME, shared)
    fig.yaxis.visible = False
    fig.ygrid.visible = False
    source = ColumnDataSource({"left": [], "right": [], "color": [], "state": []})
    bands = Quad(left="left", right="right", bottom=0.0, top=1.0, fill_color="color", line_width=0)
    r = fig.add_glyph(source, bands, view=shared.view(source))
    fig.add_tools(
        HoverTool(renderers=[r], tooltips=[("state", "@state"), ("t*", "@left{0.000} to @right{0.000}")])
    )
    # the colours named on the page, not only on hover: one entry per state
    # the run shows, grouped by the browser from the bands' names (two models)
    fig.add_layout(
        Legend(
            items=[LegendItem(label=field("state"), renderers=[r])],
            orientation="horizontal",
            location="top_left",
            margin=2,
            padding=2,
            label_text_font_size="9pt",
            border_line_alpha=0,
        ),
        "above",
    )
    return fig, source


def _extent(arrays):
    """(low, high) of finite values with 5% padding; (-1, 1) if none."""
    lo, hi = np.inf, -np.inf
    for a in arrays:
        a = a[np.isfinite(a)]
        if a.size:
            lo, hi = min(lo, float(a.min())), max(hi, float(a.max()))
    if not np.isfinite(lo):
        return -1.0, 1.0
    pad = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.05
    return lo - pad, hi + pad


def time_label(t0=None, period_seconds=None):
    """The time axis's label: periods (from t0 if given), and the period in
    seconds when the run is a device's."""
    text = "t* (periods)" if t0 is None else f"t* - t0 (periods; t0 = {t0:g})"
    if period_seconds is not None:
        text += f"; 1 period = {duration_text(period_seconds)}"
    return text


class _Block:
    """One column of panels on one shared time axis: the line panels of
    `panel_spec`, the state timeline, and (whole run, with a comparison) the
    twin panel.  With `bins`, the line panels show each quantity's per-bin
    mean over its min-max band (every sample of a 2000-period run on 900
    pixels drew solid bands)."""

    def __init__(self, timeline_title, bins, shared, twin=None, relative=False):
        self.x_range = Range1d(0.0, 1.0)
        # relative: time and x* counted from the block's first sample (over
        # two periods at t* ~ 2000, x* ~ 10^3 moves by ~1: in absolute
        # numbers the ticks read 2000.5, 4123.2 and the motion hides)
        self.relative = relative
        models = {rigid: self._specs(plots.panel_spec(rigid), relative) for rigid in (False, True)}
        for full, fewer in zip(*models.values(), strict=True):  # (the _Panel premise)
            assert {c for c, _, _ in fewer[2]} <= {c for c, _, _ in full[2]}
        self.variables = sorted(
            {col for _, _, lines in models[False] for col, _, _ in lines}
            | ({"x"} if twin is not None else set())
        )
        self.bins = bins
        self.source = self._source(self.variables)
        self.figures, self.panels = [], []
        self.shared = shared
        # a rolling particle's rotation (plots.ROLLING_PANEL): its figure
        # built at the first run that rolls, shown for those only
        self.rolling_figure = self.rolling_source = None
        self.scale = 1.0  # presentation mode's (`scale_frames`)
        for i, (title, ylabel, lines) in enumerate(models[False]):
            cols = [col for col, _, _ in lines]
            right = right_columns(cols)
            fig = self._line_figure(title, ylabel)
            right_axis = None
            if right:
                fig.extra_y_ranges = {"right": Range1d(0.0, 1.0)}
                right_axis = shared.axis(y_range_name="right")
                fig.add_layout(right_axis, "right")
            items = _lines(
                fig,
                [self.source] * len(lines),
                [(*line, plots.axis_dash(line[0], right)) for line in lines],
                shared,
                right,
                envelope=bool(bins),
            )
            specs = {
                rigid: (binned_title(m[i][0]) if bins else m[i][0], *m[i][1:]) for rigid, m in models.items()
            }
            self.panels.append(_Panel(fig, items, right_axis, specs))
            self.figures.append(fig)
        self.twin_source = None
        if twin is not None:
            title, ylabel, ((la, ca, da), (lb, cb, db)) = twin
            fig = _figure(title, ylabel, self.x_range, LINE_FRAME, shared, time_axis=False)
            self.twin_source = ColumnDataSource({"time": [], "x": []})
            self.twin_items = _lines(
                fig, [self.source, self.twin_source], [("x", la, ca, da), ("x", lb, cb, db)], shared
            )
            self.twin_figure = fig
        # the state timeline at the bottom carries the block's time axis
        self.timeline, self.bands = _timeline(timeline_title, self.x_range, shared)
        self.layout = column(
            [*self.figures, *([self.twin_figure] if twin else []), self.timeline], sizing_mode="stretch_width"
        )
        self.rigid = None
        self.configure(False)

    def _build_rolling(self):
        """The rotation's figure (plots.ROLLING_PANEL), placed under the
        line panels."""
        title, ylabel, lines = plots.ROLLING_PANEL
        fig = self._line_figure(title, ylabel)
        self.rolling_source = self._source([c for c, _, _ in lines])
        lines = [(*line, None) for line in lines]
        _lines(fig, [self.rolling_source] * len(lines), lines, self.shared, envelope=bool(self.bins))
        self.rolling_figure = fig
        if self.scale != 1.0:
            scale_fonts(fig, self.scale)
            fig.frame_height = round(LINE_FRAME * self.scale)
        children = list(self.layout.children)
        children.insert(len(self.figures), fig)
        self.layout.children = children

    def _line_figure(self, title, ylabel):
        """A line panel (its time axis: the timeline's, below)."""
        title = binned_title(title) if self.bins else title
        return _figure(title, ylabel, self.x_range, LINE_FRAME, self.shared, time_axis=False)

    def _source(self, columns):
        """A source of the time and `columns` (binned: their bands too)."""
        bands = [f"{c}_{e}" for c in columns for e in ("lo", "hi")] if self.bins else []
        return ColumnDataSource({c: [] for c in ["time", *columns, *bands]})

    def _data(self, t, raw):
        """A source's data: the samples `raw` at times `t`, or their bins."""
        return plots.binned(t, raw, self.bins) if self.bins else {"time": t, **raw}

    def _show_rolling(self, ds, t):
        """The rotation's panel of a run that rolls (built at the first);
        hidden for one that does not.  t: the samples' times as drawn."""
        rolls = plots.rolls(ds)
        if rolls and self.rolling_figure is None:
            self._build_rolling()
        if self.rolling_figure is None:
            return
        self.rolling_figure.visible = rolls
        if not rolls:
            return
        raw = {c: ds[c].values for c in plots.ROLLING_VARIABLES}
        self.rolling_source.data = self._data(t, raw)
        lo, hi = _extent(list(raw.values()))
        self.rolling_figure.y_range.update(start=lo, end=hi)

    @staticmethod
    def _specs(specs, relative):
        if not relative:
            return specs
        return [
            (
                _relative_title(title),
                ylabel.replace("x* (a0)", "x* - x*(t0) (a0)"),
                [(c, f"{label} - x*(t0)" if c == "x" else label, colour) for c, label, colour in lines],
            )
            for title, ylabel, lines in specs
        ]

    def scale_frames(self, factor):
        """The frames' heights at `factor` times their own (presentation mode)."""
        self.scale = factor
        rolling = [self.rolling_figure] if self.rolling_figure is not None else []
        for fig in [*self.figures, *([self.twin_figure] if self.twin_source is not None else []), *rolling]:
            fig.frame_height = round(LINE_FRAME * factor)
        self.timeline.frame_height = round(STRIP_FRAME * factor)

    def configure(self, rigid):
        """Draw the deformable particle's panels or the material point's."""
        if rigid != self.rigid:
            for panel in self.panels:
                panel.configure(rigid)
            self.rigid = rigid

    def show(self, ds, twin=None, period_seconds=None):
        """New data for every source and the axes to its extent.
        period_seconds: the wave period of the device run (its time axis
        also reads in seconds), or None."""
        t = ds["time"].values
        # (a material point has no a*, b*, b*': their lines are hidden)
        raw = {v: ds[v].values if v in ds else np.full(t.shape, np.nan) for v in self.variables}
        t0 = float(t[0])
        if self.relative:
            t = t - t0
            raw["x"] = raw["x"] - raw["x"][0]
        self.timeline.xaxis.axis_label = time_label(t0 if self.relative else None, period_seconds)
        self.source.data = self._data(t, raw)
        self._show_rolling(ds, t)
        self.x_range.update(start=float(t[0]), end=float(t[-1]))
        for panel in self.panels:
            lo, hi = _extent([raw[c] for c in panel.columns if c not in panel.right])
            panel.fig.y_range.update(start=lo, end=hi)
            if panel.right:
                lo, hi = _extent([raw[c] for c in panel.right])
                panel.fig.extra_y_ranges["right"].update(start=lo, end=hi)
        if self.twin_source is not None:
            tt, tx = (twin["time"].values, twin["x"].values) if twin is not None else (np.zeros(0),) * 2
            self.twin_source.data = {"time": tt, "x": tx}
            lo, hi = _extent([raw["x"], tx])
            self.twin_figure.y_range.update(start=lo, end=hi)
        t0, t1, codes = plots.state_bands(ds, self.bins)
        if self.relative:
            t0, t1 = t0 - float(ds["time"].values[0]), t1 - float(ds["time"].values[0])
        self.bands.data = {"left": t0, "right": t1, "color": _COLOURS[codes], "state": _NAMES[codes]}


class LiveTrajectory:
    """The trajectory figures of one structure (a run alone, or beside a
    comparison run), for either model: the whole run (its samples; the
    state timeline as the dominant state per bin; with a comparison
    `label`, x*(t) of the run and of the comparison run) over one linked,
    zoomable time axis, and the last `fragment` periods at full resolution
    on another.  `whole` and `part` are their Bokeh layouts; `show` feeds
    them and draws the run's model's panels."""

    def __init__(self, label, fragment, tau):
        self.fragment = fragment
        twin = plots.twin_spec(tau, label) if label else None
        shared = _Shared()
        self.over = _Block(plots.timeline_title(TIMELINE_BINS), TIMELINE_BINS, shared, twin)
        self.last = _Block(plots.timeline_title(None), None, shared, relative=True)
        self.whole, self.part = self.over.layout, self.last.layout
        self.label = label
        self.runs = 0

    def scale_frames(self, factor):
        """Every frame's height at `factor` times its own (presentation mode:
        they grow with the text)."""
        for block in (self.over, self.last):
            block.scale_frames(factor)

    def relabel(self, tau, label):
        """Name the comparison run `label` (a tau twin, or the other model:
        one set of figures serves every comparison)."""
        title, ylabel, lines = plots.twin_spec(tau, label)
        block = self.over
        block.twin_figure.title.text = title
        for item, (text, _, _) in zip(block.twin_items, lines):
            item.label = value(text)  # (a bare string set later is a column name)
        self.label = label

    def show(self, ds, other=None, period_seconds=None, rigid=False):
        """Show a run (and its comparison run `other`): the whole run from
        its overview samples, the fragment from its last periods (time and
        x* from the fragment's start).  rigid: the run is the material
        point's.  period_seconds: see _Block.show."""
        for block in (self.over, self.last):
            block.configure(rigid)
        self.over.show(plots.overview_samples(ds), other, period_seconds)
        t = ds["time"].values
        # (isel: a label-based sel builds a pandas hash index of the times first)
        start = int(np.searchsorted(t, t[-1] - self.fragment))
        self.last.show(ds.isel(time=slice(start, None)), period_seconds=period_seconds)
        self.runs += 1
