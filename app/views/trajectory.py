"""The run's trajectory figures (app/views/live.py): one set per structure
(model, comparison) shown so far, built once per session and then fed new
data; only the run's structure is visible."""

import logging

import panel as pn

from vibtrans.products.plots import FRAGMENT
from vibtrans_explorer.views.live import LiveTrajectory
from vibtrans_explorer.views.presentation import scale_fonts

log = logging.getLogger("vibtrans.explorer")


def structure(label):
    """The figures' structure of a run: whether a comparison run is drawn
    beside it.  Every comparison shares one set of figures, relabelled, and
    both models draw into the same figures (app/views/live.py): changing the
    comparison or the model builds no new figures."""
    return "beside a comparison" if label is not None else "alone"


class TrajectoryView:
    def __init__(self):
        self.views = {}  # structure(label) -> LiveTrajectory
        self.panel = pn.Column(sizing_mode="stretch_width", name="trajectory-figures")
        self.font_scale = 1.0  # presentation mode's, for the figures built later

    def scale_fonts(self, factor):
        """The figures built so far at `factor` times Bokeh's font sizes
        (presentation mode), and those built later too."""
        self.font_scale = factor
        for view in self.views.values():
            scale_fonts(view.whole, factor)
            scale_fonts(view.part, factor)
            view.scale_frames(factor)

    def view(self, label, tau):
        """The session's figures of a run's structure: built once, then fed
        by `show`."""
        key = structure(label)
        view = self.views.get(key)
        if view is None:
            view = LiveTrajectory(label, FRAGMENT, tau)
            view.panel = pn.Column(
                pn.pane.Markdown("**Whole run** (linked, zoomable time axis)"),
                pn.pane.Bokeh(view.whole, name="whole-run", sizing_mode="stretch_width"),
                pn.pane.Markdown(
                    f"**Last {FRAGMENT:g} periods at full resolution** (time "
                    f"and x\\* counted from the window's start, so the motion "
                    f"within a period shows)"
                ),
                pn.pane.Bokeh(view.part, name="fragment", sizing_mode="stretch_width"),
                sizing_mode="stretch_width",
                visible=False,
            )  # until its run is shown
            if self.font_scale != 1.0:
                scale_fonts(view.whole, self.font_scale)
                scale_fonts(view.part, self.font_scale)
                view.scale_frames(self.font_scale)
            self.views[key] = view
            self.panel.append(view.panel)
        return view

    def show(self, result, period_seconds=None):
        scene = result.scene
        key = structure(result.label)
        view = self.view(result.label, scene.tau)
        if result.label is not None and view.label != result.label:
            view.relabel(scene.tau, result.label)
        view.show(result.ds, result.other, period_seconds, rigid=scene.model == "point-mass")
        if self.font_scale != 1.0:  # (a rolling run's panel, built at its first run)
            for block in (view.over, view.last):
                if block.rolling_figure is not None:
                    scale_fonts(block.rolling_figure, self.font_scale)
        for k, v in self.views.items():
            v.panel.visible = k == key

    def clear(self):
        self.views.clear()
