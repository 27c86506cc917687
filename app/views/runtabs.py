"""The run's tabs: its trajectory, the particle's animation, the memory
diagram, the downloads and the dynamics (section and orbit diagram).  What
the first screen does not show is not built for it (a session's page costs
the event loop that every session shares): the animation, the memory
diagram and the dynamics are built when their tab is first opened, and
each is fed the last run when it is looked at."""

import panel as pn

from vibtrans_explorer.session.controller import RUNNER
from vibtrans_explorer.texts import ANIMATION_TEXT, DYNAMICS_TEXT, MEMORY_TEXT
from vibtrans_explorer.views.animation import ParticleAnimation
from vibtrans_explorer.views.dynamics import DynamicsView
from vibtrans_explorer.views.memory import MemoryView
from vibtrans_explorer.views.presentation import WRAPPING_TABS, scale_fonts, scale_widths
from vibtrans_explorer.views.tabs import lazy_tabs

# the tabs, in order (0: the trajectory)
ANIMATION_TAB, MEMORY_TAB, DOWNLOADS_TAB, DYNAMICS_TAB = 1, 2, 3, 4


class RunTabs:
    """trajectories: the TrajectoryView; exports: the ExportsView; error(text)
    says a failure on the page."""

    def __init__(self, trajectories, exports, error):
        self.trajectories, self.exports, self.error = trajectories, exports, error
        self.result = None  # the last run shown (a RunResult)
        self.animation = None  # the views, built when first opened
        self.memory_view = None
        self.dynamics_view = None
        self.animated = None  # the RunResult the animation shows
        self._memory_pending = None  # the run each has not seen yet
        self._dynamics_pending = None
        self.animation_box = pn.Column(sizing_mode="stretch_width")
        self.memory_box = pn.Column(sizing_mode="stretch_width")
        self.dynamics_box = pn.Column(sizing_mode="stretch_width")
        self.tabs = lazy_tabs(
            ("Trajectory", trajectories.panel),
            ("Animation", self.animation_box),
            ("Memory diagram", self.memory_box),
            ("Downloads", exports.panel),
            ("Dynamics", self.dynamics_box),
            sizing_mode="stretch_width",
            name="trajectory",
            stylesheets=[WRAPPING_TABS],
        )
        self.tabs.param.watch(self._on_tab, "active")
        self.font_scale = 1.0  # presentation mode's, for the views built later
        # the widgets' own widths (`scale_widths`), the page's one record
        # of them (a second would take a scaled width for a widget's own)
        self.widths = {}

    def scale_fonts(self, factor):
        """The views built so far at `factor` times their text's sizes
        (presentation mode: the figures' fonts, the sizes that grow with
        them, the widths of their selects and text boxes), and those built
        later too."""
        self.font_scale = factor
        for view in (self.animation, self.memory_view, self.dynamics_view):
            if view is not None:
                self._scale(view)

    def _scale(self, view):
        sizes = getattr(view, "scale_sizes", None)
        if sizes is not None:
            sizes(self.font_scale)
        viewable = pn.panel(view)
        scale_widths(viewable, self.font_scale, self.widths)
        for pane in viewable.select(pn.pane.Bokeh):
            scale_fonts(pane.object, self.font_scale)

    def _place(self, box, text, view):
        """A view built for a tab into its box, its figures at the page's
        font scale already: a figure changed after it went into the page
        could reach the browser before the figure did (BokehJS: "reference
        p3659 isn't known", and the view never showed), so every change a
        new view needs (the fonts, the run) is made before it is placed."""
        self._scale(view)
        box.objects = [pn.pane.Markdown(text), view]

    def show(self, result):
        """A new run: each tab shows it when opened, the open one at
        `update_open`."""
        self.result = result
        self._memory_pending = (result.scene, float(result.ds["time"].values[-1]))
        self._dynamics_pending = result

    def update_open(self):
        """The open tab's view shows the last run.  Called outside a frozen
        hold: models it changes or adds while the document's model graph is
        frozen reach the browser as references to models it was never sent
        ("reference p4188 isn't known": the Dynamics tab, opened before its
        run's result came, never showed its section)."""
        self._update(self.tabs.active)

    def cancelled(self):
        """A run cancelled: what the tabs show is the previous run's."""
        if self.memory_view is not None:
            self.memory_view.mark_previous()

    def clear(self):
        """The session closed: the views' background work cancelled."""
        if self.memory_view is not None:
            self.memory_view.clear()  # cancels its background snapshots
        if self.dynamics_view is not None:
            self.dynamics_view.clear()  # and its sections and diagrams
        self.trajectories.clear()

    def _on_tab(self, event):
        if event.new == DOWNLOADS_TAB:
            self.exports.build()
        self._update(event.new)

    def _update(self, tab):
        if tab == MEMORY_TAB:
            self._update_memory()
        elif tab == ANIMATION_TAB:
            self._update_animation()
        elif tab == DYNAMICS_TAB:
            self._update_dynamics()

    def _update_dynamics(self):
        """The section and orbit diagram of the last run, computed when first
        looked at."""
        new = self.dynamics_view is None
        if new:
            self.dynamics_view = DynamicsView(RUNNER)
            self.dynamics_view.error = self.error
        pending, self._dynamics_pending = self._dynamics_pending, None
        if pending is not None:
            self.dynamics_view.set_run(pending.scene, pending.ds)
        if new:
            self._place(self.dynamics_box, DYNAMICS_TEXT, self.dynamics_view)

    def _update_animation(self):
        """The animation of the last run, built when first looked at."""
        new = self.animation is None
        if new:
            self.animation = ParticleAnimation()
        result = self.result
        if result is not None and self.animated is not result:
            self.animated = result
            self.animation.show(result.scene, result.ds)
        if new:
            self._place(self.animation_box, ANIMATION_TEXT, self.animation)

    def _update_memory(self):
        """The memory view of the last run, computed when first looked at."""
        new = self.memory_view is None
        if new:
            self.memory_view = MemoryView(RUNNER)
            self.memory_view.error = self.error
        pending, self._memory_pending = self._memory_pending, None
        if pending is not None:
            self.memory_view.set_run(*pending)  # clears it for a point mass
        if new:
            self._place(self.memory_box, MEMORY_TEXT, self.memory_view)
