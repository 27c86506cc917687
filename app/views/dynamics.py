"""The run's vertical motion as a dynamical system: its stroboscopic section
(click it to seed new orbits), its period-1 orbit with the Floquet
multipliers, and an orbit diagram along A* or m* that a zoom recomputes.

Plain Bokeh figures fed through ColumnDataSources (as app/views/memory.py),
drawing what `vibtrans.products.plots` names (its dimensions' labels, ORBIT_COLORS);
the computing is `vibtrans.analysis.dynamics`' (section, periodic_orbit,
orbit_diagram), in the executor given, cancelled when a newer request or
run replaces it.  The exports draw the same with HoloViews (`vibtrans
export section | orbit-diagram`).
"""

import functools
import logging
import math

import numpy as np
import panel as pn
from bokeh.events import RangesUpdate, Tap
from bokeh.models import ColumnDataSource, Range1d, Title
from bokeh.plotting import figure

from vibtrans.analysis import dynamics
from vibtrans.products import plots
from vibtrans_explorer.session.latest import LatestJob
from vibtrans_explorer.session.urlstate import literal
from vibtrans_explorer.views.note import note_pane, say

log = logging.getLogger("vibtrans.explorer.dynamics")

SECTION_PERIODS = 300  # iterates of the stroboscopic map per orbit
DIAGRAM_RUNS = 40  # runs along the line per diagram (each a whole run)
DIAGRAM_HALF_WIDTH = 0.5  # decades each side of the run's point at first
DIAGRAM_FINAL = 100.0  # final periods whose take-offs are drawn
MIN_DIAGRAM_WIDTH = 1e-4  # decades: a narrower zoom is not recomputed
TOOLS = "pan,box_zoom,wheel_zoom,reset"
POINT_MASS_TEXT = (
    "The material point's stroboscopic map needs its impact map's Jacobian, "
    "which is not built yet: run a deformable scene for its section and orbits."
)


def _figure(title, xlabel, ylabel, width=440, height=360):
    fig = figure(
        title=Title(text=title),
        tools=TOOLS,
        toolbar_location="above",
        width=width,
        height=height,
        x_range=Range1d(0.0, 1.0),
        y_range=Range1d(0.0, 1.0),
        output_backend="canvas",
    )
    fig.title.text_font_size = "9pt"
    fig.xaxis.axis_label = xlabel
    fig.yaxis.axis_label = ylabel
    fig.toolbar.logo = None
    return fig


def _padded(values, frac=0.05, floor=1e-9):
    lo, hi = float(np.min(values)), float(np.max(values))
    pad = max((hi - lo) * frac, floor * max(1.0, abs(lo), abs(hi)))
    return lo - pad, hi + pad


def _set_range(rng, lo, hi):
    rng.update(start=lo, end=hi, reset_start=lo, reset_end=hi)


def orbit_text(orbit):
    """The period-1 orbit in words (its multipliers and stability)."""
    if not orbit.found:
        return "period-1 orbit: not found from the run's section point (Newton did not converge)"
    m1, m2 = orbit.multipliers
    kind = "elliptic (linearly stable)" if orbit.stable else "hyperbolic (unstable)"
    return (
        f"period-1 orbit at y* = {orbit.y:.5g}, y*' = {orbit.vy:.3g}: trace "
        f"{orbit.trace:.4f}, multipliers {m1:.3g} and {m2:.3g}, {kind}"
    )


class DynamicsView(pn.viewable.Viewer):
    """Section and orbit diagram of the session's last Hertz run.

    DynamicsView(executor).  set_run(scene) after each run (a material
    point shows why it has none), clear() when there is none; `error`, if
    set, is called with a message for the page's alert.
    """

    def __init__(self, executor, **params):
        super().__init__(**params)
        self.executor = executor
        self.error = None
        self.scene = None
        self.phase = 0.0
        self.orbits = []  # float64[n, 2] per orbit, the run's first
        # its work, one of each kind at a time (the latest request wins)
        self.work = {what: LatestJob(executor) for what in ("orbit", "section", "diagram")}
        self.diagram_window = None  # (parameter, lo, hi) drawn
        self._history = []  # windows before the zooms (back)
        self._build()

    def __panel__(self):
        return self.layout

    # ---------------------------------------------------------------- figures
    def _build(self):
        self.points = ColumnDataSource({"y": [], "vy": [], "color": []})
        self.fixed = ColumnDataSource({"y": [], "vy": []})
        self.section_fig = _figure(
            "stroboscopic section: run a deformable scene", plots.Y_DIM.label, plots.VY_DIM.label
        )
        self.section_fig.scatter("y", "vy", color="color", size=3, source=self.points)
        self.section_fig.scatter(
            "y", "vy", marker="star", size=14, fill_color="gold", line_color="black", source=self.fixed
        )
        self.section_fig.on_event(Tap, self._on_tap)
        self.phases = ColumnDataSource({"x": [], "phase": []})
        self.diagram_fig = _figure("orbit diagram", plots.LOG_A.label, plots.PHASE_DIM.label, width=520)
        self.diagram_fig.scatter("x", "phase", size=2, color=plots.ORBIT_COLORS[0], source=self.phases)
        _set_range(self.diagram_fig.y_range, 0.0, 1.0)
        self.diagram_fig.on_event(RangesUpdate, self._on_ranges)
        self.back_button = pn.widgets.Button(label="Back (remove the last orbit)", disabled=True)
        self.clear_button = pn.widgets.Button(label="Clear the seeded orbits", disabled=True)
        self.back_button.on_click(lambda e: self._drop(len(self.orbits) - 1))
        self.clear_button.on_click(lambda e: self._drop(1))
        self.along = pn.widgets.RadioButtonGroup(options=["amplitude", "mass"], value="amplitude")
        self.along.param.watch(lambda e: self._diagram_reset(), "value")
        self.diagram_back = pn.widgets.Button(label="Back (previous window)", disabled=True)
        self.diagram_reset = pn.widgets.Button(label="Reset the window", disabled=True)
        self.diagram_back.on_click(lambda e: self._diagram_back())
        self.diagram_reset.on_click(lambda e: self._diagram_reset())
        self.orbit_status = pn.pane.Markdown("", margin=(0, 5))
        self.section_status = pn.pane.Markdown("", margin=(0, 5))
        self.diagram_status = pn.pane.Markdown("", margin=(0, 5))
        self.note = note_pane()
        self.section_pane = pn.pane.Bokeh(self.section_fig, name="section")
        self.diagram_pane = pn.pane.Bokeh(self.diagram_fig, name="orbit-diagram")
        self.layout = pn.Column(
            pn.pane.Markdown(
                "The vertical motion seen once per period (t = the run's end mod 1): a "
                "regular orbit draws points or closed curves, a chaotic one fills an area. "
                "**Click the section** to start a new orbit there (wave fully on), in a new "
                "colour. The orbit diagram shows the take-off phases of the final "
                f"{DIAGRAM_FINAL:g} periods of runs along a line through this scene; "
                "**zoom it** to recompute it in the window.",
                margin=(0, 5),
            ),
            self.note,
            self.orbit_status,
            # side by side where the page is wide enough, else one below the other
            pn.FlexBox(
                pn.Column(
                    self.section_pane, pn.Row(self.back_button, self.clear_button), self.section_status
                ),
                pn.Column(
                    self.diagram_pane,
                    pn.FlexBox(self.along, self.diagram_back, self.diagram_reset),
                    self.diagram_status,
                ),
                flex_wrap="wrap",
                sizing_mode="stretch_width",
            ),
        )

    # ---------------------------------------------------------------- the run
    def set_run(self, scene, ds):
        """A new run: its scene and Dataset (its section starts where it ends)."""
        self.clear()
        if scene.model == "point-mass":
            self._say(POINT_MASS_TEXT)
            return
        self.scene = scene
        t_end = float(ds["time"].values[-1])
        self.phase = t_end - math.floor(t_end)
        y, vy = float(ds["y"].values[-1]), float(ds["vy"].values[-1])
        # two lines: in one, the title was cut at the figure's width (1024 x 768)
        self.section_fig.title.text = (
            f"stroboscopic section at t = {self.phase:.3g} mod 1\n(click to seed an orbit)"
        )
        self._seed(y, vy, first=True)
        self._start(
            "orbit",
            dynamics.periodic_orbit,
            scene.amplitude,
            scene.mass,
            (y, vy),
            1,
            scene.fidelity,
            phase=self.phase,
        )
        self.orbit_status.object = "finding the period-1 orbit ..."
        self._diagram_reset()

    def clear(self):
        for work in self.work.values():
            work.cancel()
        self.scene = None
        self.orbits = []
        self._history = []
        self.diagram_window = None
        with pn.io.hold():
            self.points.data = {"y": [], "vy": [], "color": []}
            self.fixed.data = {"y": [], "vy": []}
            self.phases.data = {"x": [], "phase": []}
            for pane in (self.orbit_status, self.section_status, self.diagram_status):
                pane.object = ""
            self._say("")
            self._buttons()

    # ---------------------------------------------------------------- jobs
    def _start(self, what, fn, *args, cancellable=False, **kwargs):
        """fn in the executor (one job per kind: a newer one cancels it);
        cancellable: fn takes the job's cancel event (`cancel=`)."""
        work = self.work[what]
        job = work.start()
        if cancellable:
            kwargs["cancel"] = job.event
        job.submit(fn, *args, **kwargs)
        work.deliver(job, functools.partial(self._show, what), functools.partial(self._failed, what))

    @property
    def computing(self):
        """Whether any of its work (orbit, section, diagram) is still to come."""
        return any(work.running for work in self.work.values())

    def _failed(self, what, exc):
        log.error("dynamics %s failed: %s", what, self.scene and self.scene.values(), exc_info=exc)
        self._say(f"The {what} failed: {type(exc).__name__}: {literal(exc)}")
        self._status(what, "")
        self._buttons()

    def _show(self, what, out):
        with pn.io.hold():
            getattr(self, f"_show_{what}")(out)
            self._buttons()

    def _status(self, what, text):
        {"orbit": self.orbit_status, "section": self.section_status, "diagram": self.diagram_status}[
            what
        ].object = text

    # ---------------------------------------------------------------- section
    def _seed(self, y, vy, first=False):
        s = self.scene
        self._start(
            "section",
            dynamics.section,
            s.amplitude,
            s.mass,
            y,
            vy,
            SECTION_PERIODS,
            s.fidelity,
            phase=self.phase,
            cancellable=True,
        )
        self.section_status.object = (
            f"iterating the map {SECTION_PERIODS} times from y* = {y:.4g}, y*' = {vy:.4g} ..."
        )
        self._seeding_first = first

    def _on_tap(self, event):
        if self.scene is None or self.work["section"].running:
            return
        self._seed(float(event.x), float(event.y))
        self._buttons()

    def _show_section(self, pts):
        finite = np.isfinite(pts).all(axis=1)
        if not finite.all():  # a seed deep in the contact: the step cannot follow
            pts = pts[: np.argmin(finite)]
        if self._seeding_first:
            self.orbits = [pts]
        else:
            self.orbits.append(pts)
        self._draw_section()
        self.section_status.object = (
            f"{len(self.orbits)} orbit(s); the last ended early: it left the step's range"
            if not finite.all()
            else f"{len(self.orbits)} orbit(s) of {SECTION_PERIODS} periods"
        )

    def _draw_section(self, keep_view=None):
        ys, vys, colors = [], [], []
        for k, pts in enumerate(self.orbits):
            ys.append(pts[:, 0])
            vys.append(pts[:, 1])
            colors += [plots.ORBIT_COLORS[k % len(plots.ORBIT_COLORS)]] * len(pts)
        y = np.concatenate(ys) if ys else np.zeros(0)
        vy = np.concatenate(vys) if vys else np.zeros(0)
        self.points.data = {"y": y, "vy": vy, "color": colors}
        if len(self.orbits) == 1 and y.size:  # the run's orbit sets the view
            _set_range(self.section_fig.x_range, *_padded(y, 0.3, 1e-6))
            _set_range(self.section_fig.y_range, *_padded(vy, 0.3, 1e-6))

    def _drop(self, keep):
        """Keep the first `keep` orbits (back: all but the last; clear: the run's)."""
        self.orbits = self.orbits[: max(keep, 1)]
        self._draw_section()
        self.section_status.object = f"{len(self.orbits)} orbit(s)"
        self._buttons()

    def _show_orbit(self, orbit):
        self.orbit_status.object = orbit_text(orbit)
        self.fixed.data = {"y": [orbit.y], "vy": [orbit.vy]} if orbit.found else {"y": [], "vy": []}

    # ---------------------------------------------------------------- diagram
    def _diagram_reset(self):
        if self.scene is None:
            return
        self._history = []
        along = self.along.value
        x = math.log10(getattr(self.scene, along))
        self._diagram(along, x - DIAGRAM_HALF_WIDTH, x + DIAGRAM_HALF_WIDTH)

    def _diagram_back(self):
        if self._history:
            self._diagram(*self._history.pop(), remember=False)

    def _on_ranges(self, event):
        """A zoom or pan of the diagram: recompute it in the new window."""
        if self.scene is None or self.diagram_window is None or event.x0 is None:
            return
        along, lo, hi = self.diagram_window
        x0, x1 = float(event.x0), float(event.x1)
        if abs(x0 - lo) < 1e-9 and abs(x1 - hi) < 1e-9:
            return  # our own range update
        if not x1 - x0 >= MIN_DIAGRAM_WIDTH:
            self.diagram_status.object = f"a window under {MIN_DIAGRAM_WIDTH:g} decades is not recomputed"
            return
        self._diagram(along, x0, x1)

    def _diagram(self, along, lo, hi, remember=True):
        if remember and self.diagram_window is not None:
            self._history.append(self.diagram_window)
        self.diagram_window = (along, lo, hi)
        values = np.linspace(lo, hi, DIAGRAM_RUNS)
        self._start(
            "diagram", dynamics.orbit_diagram, self.scene, along, values, DIAGRAM_FINAL, cancellable=True
        )
        dim = plots.LOG_A if along == "amplitude" else plots.LOG_M
        self.diagram_fig.xaxis.axis_label = dim.label
        self.diagram_status.object = (
            f"computing {DIAGRAM_RUNS} runs over {dim.label} in [{lo:.4g}, {hi:.4g}] ..."
        )
        self._buttons()

    def _show_diagram(self, diagram):
        self.phases.data = {"x": diagram.phase_value, "phase": diagram.phase}
        _, lo, hi = self.diagram_window
        _set_range(self.diagram_fig.x_range, lo, hi)
        self.diagram_fig.title.text = (
            f"take-off phases, final {diagram.final_periods:g} periods, {len(diagram.values)} runs"
        )
        self.diagram_status.object = f"{diagram.phase.size} take-offs; zoom to recompute in the window"

    # ---------------------------------------------------------------- controls
    def _buttons(self):
        busy = self.work["section"].running
        self.back_button.disabled = busy or len(self.orbits) < 2
        self.clear_button.disabled = busy or len(self.orbits) < 2
        self.diagram_back.disabled = not self._history
        self.diagram_reset.disabled = self.scene is None

    def _say(self, text):
        say(self, text)
