"""The memory diagram and the contact circle, scrubbed through time.

Plain Bokeh figures built once per session and fed new data through their
ColumnDataSources, as app/views/live.py does for the trajectories: rendering
`plots.memory_diagram + plots.contact_circle` through HoloViews took 2.2-3.8 s
from click to drawn, almost all of it building new figures.  The
figures draw what `vibtrans.products.plots` defines (memory_geometry, memory_spans,
contact_geometry, its colours and labels; the exports draw the same with
HoloViews).

After each deformable run (`set_run`) one background run
(`vibtrans.core.simulate.memory_snapshots`, in the executor given) computes the
diagram at SNAPSHOTS times over the run's last WINDOW periods; the slider
scrubs through them with no computing.  The time field and its button show
the diagram at any time of the run (`memory_snapshot`, a run from rest).
"""

import asyncio
import logging

import numpy as np
import panel as pn
import param
from bokeh.models import ColumnDataSource, Line, Patches, Quad, Range1d, Scatter, Text, Title
from bokeh.plotting import figure

from vibtrans.core.simulate import memory_snapshot, memory_snapshots
from vibtrans.products import plots
from vibtrans_explorer.session.latest import LatestJob, at_next_tick
from vibtrans_explorer.session.urlstate import literal
from vibtrans_explorer.views import inputs
from vibtrans_explorer.views.note import note_pane, say
from vibtrans_explorer.views.summary import PREVIOUS_RUN

log = logging.getLogger("vibtrans.explorer.memory")

SNAPSHOTS = 48  # times the slider holds
WINDOW = 1.0  # periods before the run's end that the slider spans
PANEL_WIDTH = 300  # three panels in the explorer's 900 pixels
PANEL_HEIGHT = 300
SQUARE = 210  # the contact circle's frame (pixels)
NOTE_FONT = "11pt"  # the words inside a panel ("in flight: ...")
TOOLS = "pan,wheel_zoom,reset"  # few models per session (app/views/live.py)
EMPTY_TITLE = "memory diagram\n(run a deformable scene)"
_NAN = float("nan")


class SnapshotTime(param.Parameterized):
    """The time of a memory-diagram snapshot; its range is the last run's."""

    t = param.Number(default=0.0, bounds=(0.0, 1.0), doc="t*, periods")


def snapshot_times(t_end, n=SNAPSHOTS, window=WINDOW):
    """The slider's times: n times over the last `window` periods of a run
    ending at t_end (from 0 if it is shorter), periods."""
    return np.linspace(max(0.0, t_end - window), t_end, n)


def _figure(title, xlabel, ylabel, square=False):
    # square: a frame of equal sides, so that the contact circle is round
    size = (
        dict(frame_width=SQUARE, frame_height=SQUARE)
        if square
        else dict(width=PANEL_WIDTH, height=PANEL_HEIGHT)
    )
    # the toolbar at the right: above, it shared the title's row and cut the
    # title ("memory diagram w(h), t* = ..., partial slip") short
    fig = figure(
        title=Title(text=title),
        tools=TOOLS,
        toolbar_location="right",
        x_range=Range1d(0.0, 1.0),
        y_range=Range1d(-1.0, 1.0),
        output_backend="canvas",
        **size,
    )
    fig.title.text_font_size = "9pt"  # "memory diagram w(h), t* = ..., partial slip"
    fig.xaxis.axis_label = xlabel
    fig.yaxis.axis_label = ylabel
    fig.toolbar.logo = None
    return fig


def title_lines(title):
    """A figure's title on two lines, broken before its parenthesis, or else
    after its first comma: "memory diagram w(h)" / "t* = ..., partial slip",
    "spring displacements u(h)" / "|u| <= a* - h", "contact: c = ..., s =
    ..." / "(partial slip)".  On one line they were cut at their figures'
    edges; the break does not depend on the numbers, so a title keeps its
    height (and the figure its frame) while the slider scrubs."""
    head, paren, rest = title.partition(" (")
    if paren:
        return f"{head}\n({rest}"
    return "\n".join(title.split(", ", 1))


def _set_range(rng, lo, hi):
    """New extent, which is also where the reset tool goes back to."""
    rng.update(start=lo, end=hi, reset_start=lo, reset_end=hi)


class MemoryView(pn.viewable.Viewer):
    """The memory diagram w(h), the displacements u(h) and the contact
    circle of the session's last deformable run.

    MemoryView(executor): runs its computing in `executor` (a
    concurrent.futures executor; the explorer's RUNNER).  set_run(scene,
    t_end) after each deformable run, clear() when there is none; `error`,
    if set, is called with a message for the page's alert (else the view
    shows it under its controls).
    """

    def __init__(self, executor, **params):
        super().__init__(**params)
        self.executor = executor
        self.error = None
        self.scene = None
        self.times = np.zeros(0)
        self.snapshots = []
        self.work = LatestJob(executor)  # the snapshots of the latest run
        self.a_max = 0.0  # the largest a* over the snapshots (their scale)
        self.shown = None  # the snapshot drawn
        self._following = False  # the slider is moved to the time drawn (no redraw)
        self._build_figures()
        self.at = SnapshotTime()
        self.time_field = inputs.NumberField(
            self.at, "t", "time t* (periods)", width=200, digits=10
        )  # (a sample's time: 1999.1067)
        self.show_button = pn.widgets.Button(
            label="Show the memory diagram at t*", color="primary", disabled=True
        )
        self.show_button.on_click(self._on_show_click)
        # busy at once: the browser disables the button at the click (the
        # server's round trip can take longer than 0.3 s on a busy host);
        # the server enables it again with the answer
        self.show_button.js_on_click(code="source.disabled = true;")
        self.slider = pn.widgets.FloatSlider(
            label="t* (periods), the run's last period",
            start=0.0,
            end=1.0,
            step=0.1,
            value=1.0,
            format="0[.]0000",
            disabled=True,
            width=600,
            css_classes=["vt-memory-slider"],
        )
        self.slider.param.watch(self._on_slide, "value")
        self.busy = pn.indicators.LoadingSpinner(value=True, size=20, visible=False)
        self.status = pn.pane.Markdown("", margin=(0, 5))
        self.note = note_pane()
        # each figure a pane of its own in a wrapping row: the three (~900
        # pixels) did not fit the run tabs' column (~680 pixels at 1024 x
        # 768, ~600 beside the map at 1920 x 1080), and one Bokeh row
        # squeezed the contact circle into an ellipse and cut it at the
        # page's edge; now the circle goes below the other two
        self.figures_pane = pn.FlexBox(
            *(pn.pane.Bokeh(fig) for fig in (self.w_fig, self.u_fig, self.c_fig)),
            flex_wrap="wrap",
            align_items="flex-start",
            name="memory-figures",
        )
        # (rows that wrap: in presentation mode at 1024 pixels the button
        # beside the time's field was cut at the page's edge)
        self.layout = pn.Column(
            pn.Row(self.slider, self.busy, self.status),
            pn.FlexBox(self.time_field, self.show_button, flex_wrap="wrap", align_items="flex-end"),
            self.note,
            self.figures_pane,
        )

    def __panel__(self):
        return self.layout

    # ---------------------------------------------------------------- figures
    def _build_figures(self):
        self.profile = ColumnDataSource({"h": [], "w": [], "u": []})
        self.cone = ColumnDataSource({"h": [], "w": [], "u": []})
        self.apex = ColumnDataSource({"h": [], "w": []})
        self.spans = ColumnDataSource(
            {
                k: []
                for k in (
                    "left",
                    "right",
                    "label_x",
                    "color",
                    "alpha",
                    "label",
                    "label_color",
                    "baseline",
                    "w_bottom",
                    "w_top",
                    "u_bottom",
                    "u_top",
                    "w_text",
                    "u_text",
                )
            }
        )
        self.discs = ColumnDataSource({"xs": [], "ys": [], "color": [], "dash": []})
        self.notes = ColumnDataSource({"x": [], "y": [], "text": []})
        self.circle_notes = ColumnDataSource({"x": [], "y": [], "text": []})
        self.w_fig = _figure(EMPTY_TITLE, plots.MEMORY_XLABEL, plots.MEMORY_WLABEL)
        # the u(h) panel shares the depth axis: zooming one zooms both
        self.u_fig = _figure(title_lines(plots.MEMORY_UTITLE), plots.MEMORY_XLABEL, plots.MEMORY_ULABEL)
        self.u_fig.x_range = self.w_fig.x_range
        self.c_fig = _figure("contact", plots.CIRCLE_XLABEL, plots.CIRCLE_ZLABEL, square=True)
        for fig, y in ((self.w_fig, "w"), (self.u_fig, "u")):
            fig.add_glyph(
                self.spans,
                Quad(
                    left="left",
                    right="right",
                    bottom=f"{y}_bottom",
                    top=f"{y}_top",
                    fill_color="color",
                    fill_alpha="alpha",
                    line_width=0,
                ),
            )
            fig.add_glyph(
                self.spans,
                Text(
                    x="label_x",
                    y=f"{y}_text",
                    text="label",
                    text_color="label_color",
                    text_align="left",
                    text_baseline="baseline",
                    text_font_size="10pt",
                ),
            )
            # the Coulomb cone |b* - w| = a* - h, resp. |u| = a* - h (two lines, NaN between)
            fig.add_glyph(self.cone, Line(x="h", y=y, line_color="black", line_width=1, line_dash="dashed"))
            fig.add_glyph(
                self.profile,
                Line(x="h", y=y, line_width=2, line_color=plots.W_COLOR if y == "w" else plots.U_COLOR),
            )
            fig.add_glyph(
                self.notes,
                Text(
                    x="x",
                    y="y",
                    text="text",
                    text_align="center",
                    text_baseline="middle",
                    text_font_size=NOTE_FONT,
                ),
            )
        self.w_fig.add_glyph(self.apex, Scatter(x="h", y="w", size=7, fill_color="black", line_color="black"))
        self.c_fig.add_glyph(
            self.discs,
            Patches(
                xs="xs", ys="ys", fill_color="color", fill_alpha=0.9, line_color="black", line_dash="dash"
            ),
        )
        self.c_fig.add_glyph(
            self.circle_notes,
            Text(
                x="x",
                y="y",
                text="text",
                text_align="center",
                text_font_size=NOTE_FONT,
                text_baseline="middle",
            ),
        )
        # the words drawn in the panels, each with its own size (in points)
        self._texts = [
            (r.glyph, float(str(r.glyph.text_font_size)[:-2]))
            for fig in (self.w_fig, self.u_fig, self.c_fig)
            for r in fig.renderers
            if isinstance(r.glyph, Text)
        ]

    def show(self, snapshot, limits=None):
        """Draw one snapshot (a dict from memory_snapshot).  limits: (a*
        max) over the slider's times, so that its depth axis and the circle
        keep their scale while it scrubs; None: the snapshot's own."""
        g = plots.memory_geometry(snapshot)
        c = plots.contact_geometry(snapshot)
        a_max = max(float(snapshot["a"]), 0.0) if limits is None else limits
        self.w_fig.title.text = title_lines(plots.memory_title(snapshot))
        self.c_fig.title.text = title_lines(c["title"])
        if g is None:  # in flight: no memory
            self.profile.data = {"h": [], "w": [], "u": []}
            self.cone.data = {"h": [], "w": [], "u": []}
            self.apex.data = {"h": [], "w": []}
            self.spans.data = {k: [] for k in self.spans.data}
            self.notes.data = {"x": [0.5], "y": [0.0], "text": [plots.FLIGHT_TEXT]}
            h_lim = (0.0, max(a_max * 1.02, 1.0))
            w_lim = u_lim = (-1.0, 1.0)
        else:
            a, b, hc = g["a"], g["b"], g["hc"]
            self.profile.data = {"h": g["h"], "w": g["w"], "u": g["u"]}
            (w_up, w_lo), (u_up, u_lo) = g["cone_w"], g["cone_u"]
            self.cone.data = {
                "h": [hc[0], hc[1], _NAN, hc[0], hc[1]],
                "w": [w_up[0], w_up[1], _NAN, w_lo[0], w_lo[1]],
                "u": [u_up[0], u_up[1], _NAN, u_lo[0], u_lo[1]],
            }
            self.apex.data = {"h": [a], "w": [b]}
            self.notes.data = {"x": [], "y": [], "text": []}
            w_lim = g["w_lim"]
            if limits is None:
                h_lim, u_lim = g["h_lim"], g["u_lim"]
            else:  # the same construction, over the slider's times
                pad = 0.08 * a_max
                h_lim, u_lim = (0.0, a_max * 1.02), (-(a_max + pad), a_max + pad)
            spans = plots.memory_spans(snapshot)
            top = [s["label_at"] == "top" for s in spans]
            n = len(spans)
            self.spans.data = {
                "left": [s["left"] for s in spans],
                "right": [s["right"] for s in spans],
                "label_x": [s["label_x"] for s in spans],
                "color": [s["color"] for s in spans],
                "alpha": [s["alpha"] for s in spans],
                "label": [s["label"] for s in spans],
                "label_color": [s["label_color"] for s in spans],
                "baseline": ["top" if t else "bottom" for t in top],
                "w_bottom": [w_lim[0]] * n,
                "w_top": [w_lim[1]] * n,
                "u_bottom": [u_lim[0]] * n,
                "u_top": [u_lim[1]] * n,
                "w_text": [w_lim[1] if t else w_lim[0] for t in top],
                "u_text": [u_lim[1] if t else u_lim[0] for t in top],
            }
        _set_range(self.w_fig.x_range, *h_lim)
        _set_range(self.w_fig.y_range, *w_lim)
        _set_range(self.u_fig.y_range, *u_lim)
        # the circle: its discs (largest first), on a fixed square view
        discs = c["discs"]
        outlines = [plots.disc_outline(d["r"]) for d in discs]
        self.discs.data = {
            "xs": [o[:, 0] for o in outlines],
            "ys": [o[:, 1] for o in outlines],
            "color": [d["color"] for d in discs],
            "dash": ["dashed" if d["dashed"] else "solid" for d in discs],
        }
        self.circle_notes.data = (
            {"x": [], "y": [], "text": []}
            if discs
            else {"x": [0.0], "y": [0.0], "text": ["in flight: no contact"]}
        )
        rmax = max(np.sqrt(a_max), 1.0) * 1.1
        _set_range(self.c_fig.x_range, -rmax, rmax)
        _set_range(self.c_fig.y_range, -rmax, rmax)
        self.shown = snapshot

    def _blank(self):
        for src in (
            self.profile,
            self.cone,
            self.apex,
            self.spans,
            self.discs,
            self.notes,
            self.circle_notes,
        ):
            src.data = {k: [] for k in src.data}
        self.w_fig.title.text = EMPTY_TITLE
        self.c_fig.title.text = "contact"
        self.shown = None

    # ---------------------------------------------------------------- the run
    def set_run(self, scene, t_end):
        """A new run to show: its scene (deformable; any other model clears
        the view) and its end t_end (periods).  Cancels the snapshots of the
        run it replaces, starts those of this one, and enables the view."""
        self.work.cancel()
        if scene is None or scene.model != "deformable":
            self.clear()
            return
        self.scene = scene
        self.times = snapshot_times(float(t_end))
        self.snapshots = []
        with pn.io.hold():
            self._blank()
            self._say("")
            self.at.param.t.bounds = (0.0, float(t_end))
            # the field and the slider on the same time: the run's end,
            # which the snapshots' last is and is drawn first
            self.at.t = min(round(float(self.times[-1]), 4), float(t_end))
            self.show_button.disabled = False
            t0, t1 = float(self.times[0]), float(self.times[-1])
            step = (t1 - t0) / (len(self.times) - 1) if t1 > t0 else 1.0
            # end before start: Bokeh's slider needs end > start
            self.slider.param.update(start=t0, end=max(t1, t0 + step), step=step, value=t1, disabled=True)
        job = self.work.start()
        job.submit(memory_snapshots, scene, list(self.times), cancel=job.event)
        self._busy(self._job_text())
        self.work.deliver(job, self._show_snapshots, self._snapshots_failed)

    def scale_sizes(self, factor):
        """The panels at `factor` times their size, and the words inside
        them (presentation mode: the text grows, the frames with it; the
        panels wrap onto more rows)."""
        for fig in (self.w_fig, self.u_fig):
            fig.update(width=round(PANEL_WIDTH * factor), height=round(PANEL_HEIGHT * factor))
        self.c_fig.update(frame_width=round(SQUARE * factor), frame_height=round(SQUARE * factor))
        for glyph, points in self._texts:
            glyph.text_font_size = f"{points * factor:.3g}pt"

    @property
    def computing(self):
        """Whether the snapshots of the run shown are still to come."""
        return self.work.running

    def clear(self):
        """No run (or not a deformable one): empty and disabled."""
        self.work.cancel()
        self.scene = None
        self.times = np.zeros(0)
        self.snapshots = []
        with pn.io.hold():
            self._blank()
            self._say("")
            self._busy("")
            self.show_button.disabled = True
            self.slider.disabled = True

    def _snapshots_failed(self, exc):
        log.error("memory snapshots failed: %s", self.scene.values(), exc_info=exc)
        self._busy("")
        self._say(f"The memory diagram failed: {type(exc).__name__}: {literal(exc)}")

    def _show_snapshots(self, snaps):
        """The latest run's snapshots (at the page's next tick: work.deliver)."""
        self.snapshots = snaps
        self.a_max = max(max(s["a"] for s in snaps), 0.0)
        with pn.io.hold():
            self._busy("")
            self.slider.disabled = False
            if self.shown is None:
                self._show_index(len(snaps) - 1)
            else:
                # a time the user typed was shown meanwhile: it stays
                # (drawing the last period over it replaced what was asked for)
                self._agree(self.shown["t"])

    # ---------------------------------------------------------------- controls
    def _index(self, value):
        """The snapshot nearest to a slider value."""
        return int(np.clip(np.argmin(np.abs(self.times - value)), 0, len(self.snapshots) - 1))

    def _on_slide(self, event):
        if self.snapshots and not self._following:
            with pn.io.hold():
                self._show_index(self._index(event.new))

    def _show_index(self, i):
        self.show(self.snapshots[i], limits=self.a_max)
        self._agree(self.snapshots[i]["t"])

    def _agree(self, t):
        """The slider and the time field show the time drawn, t (periods):
        the field exactly (4 decimals, within the run), the slider where it
        has that time in its range (its own value moved without redrawing)."""
        self.at.t = min(max(round(float(t), 4), self.at.param.t.bounds[0]), self.at.param.t.bounds[1])
        if len(self.times) and self.slider.start <= t <= self.slider.end:
            self._following = True
            try:
                self.slider.value = float(t)
            finally:
                self._following = False

    def mark_previous(self):
        """A newer run was cancelled: the diagram shown is the previous run's."""
        if self.scene is not None:
            self.status.object = f"*{PREVIOUS_RUN}*"

    def _on_show_click(self, event):
        pn.state.execute(self.show_at)

    async def show_at(self):
        """Show the diagram at the time field's t* (a run from rest to t*)."""
        if self.scene is None:
            return
        if self.time_field.error:
            with pn.io.hold():
                self._say("Not shown: " + self.time_field.error)
                # the browser disabled the button at the click: enabled again
                # (set twice: the server's copy may not have followed the browser's)
                self.show_button.disabled = True
                self.show_button.disabled = False
            return
        t, scene = self.at.t, self.scene
        doc = pn.state.curdoc  # (the click's: the answer goes to its next tick)
        # busy: the button, disabled until the answer.  Not a loading
        # overlay on the figures, nor a status text or a spinner shown: each
        # is a change of a layout's css_classes, visible or size, and
        # BokehJS lays out every figure of the page again at each (twice per
        # view, on and off: 0.2-0.3 s of the browser's main thread on a calm
        # host; docs/how-to/deployment.md 2.2)
        with pn.io.hold():
            self._say("")
            self.show_button.disabled = True  # one at a time per session
        snap = None
        try:
            snap = await asyncio.wrap_future(self.executor.submit(memory_snapshot, scene, t))
        except ValueError as exc:
            self._say(str(exc))
        except Exception as exc:
            log.exception("memory snapshot failed: %s at t = %s", scene.values(), t)
            self._say(f"The memory diagram failed: {type(exc).__name__}: {literal(exc)}")

        def answer():
            with pn.io.hold():
                self.show_button.disabled = self.scene is None
                if snap is not None and scene is self.scene:  # not replaced meanwhile
                    self.show(snap)
                    self._agree(snap["t"])

        at_next_tick(doc, answer)

    def _job_text(self):
        return f"computing the memory diagram at {len(self.times)} times ..."

    def _busy(self, text):
        self.busy.visible = bool(text)
        self.status.object = text

    def _say(self, text):
        """A message: the explorer's (error callback) or the view's own."""
        say(self, text)
