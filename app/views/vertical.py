"""The Vertical tab: the jumping threshold A_J*(m*) of both models (the
shipped vertical curve), the resonances, and the selected scene marked."""

import functools

import holoviews as hv
import numpy as np
import panel as pn
from bokeh.document import Document
from bokeh.models import ColumnDataSource

from vibtrans.products import plots
from vibtrans_explorer.server import data
from vibtrans_explorer.session.state import is_sphere
from vibtrans_explorer.views.map import in_document
from vibtrans_explorer.views.presentation import scale_fonts
from vibtrans_explorer.views.render import rendered

HEIGHT = 450


def vertical_element(vertical):
    lm = vertical["log_mass"].values
    # the map's axes: log10 A* across, log10 m* up (the curve A_J*(m*) drawn
    # as m* against A_J*), so a scene sits where it sits on the map
    de = hv.Curve(
        (np.log10(vertical["threshold_amplitude"].values), lm),
        plots.LOG_A,
        plots.LOG_M,
        label="deformable (Hertz)",
    )
    pm = hv.Curve(
        (np.log10(vertical["point_mass_threshold_amplitude"].values), lm),
        plots.LOG_A,
        plots.LOG_M,
        label="material point",
    ).opts(line_dash="dashed")
    lines = [
        hv.HLine(vertical.attrs[k]).opts(color="grey", line_dash="dotted")
        for k in vertical.attrs
        if k.startswith("resonance_") and k.endswith("log_mass")
    ]
    return hv.Overlay([de, pm, *lines]).opts(
        height=HEIGHT,
        title="Jumping threshold A_J*(m*), axes as the map's\nright of a curve, the particle jumps",
        legend_position="top_right",
    )


@functools.lru_cache(maxsize=1)
def _vertical_json():
    vertical = data.vertical_curve()
    if vertical is None:
        return None
    doc, _ = rendered(vertical_element, vertical)
    return doc.to_json()


class VerticalView:
    """The threshold curves with the selected scene (yellow) on them: a
    scene above its model's curve leaves the substrate."""

    def __init__(self, state):
        self.state = state
        self.scene = ColumnDataSource({"x": [state.log_amplitude], "y": [state.log_mass]})
        self.pane = pn.Column(sizing_mode="stretch_width", name="vertical")
        self._built = False
        self.figure = None
        self.font_scale = 1.0  # presentation mode's (`scale_fonts`)
        self.profile_note = None  # the curve is the sphere's: said
        state.param.watch(self._moved, ["log_amplitude", "log_mass"])
        state.param.watch(self._on_profile, "profile")

    def build(self):
        """The figure, built when the tab is first opened (not with the page)."""
        if self._built:
            return
        self._built = True
        js = _vertical_json()
        if js is None:
            self.pane.objects = [pn.pane.Markdown("The vertical curve is not shipped.")]
            return
        doc = Document.from_json(js)
        fig = doc.roots[0]
        doc.remove_root(fig)
        fig.update(sizing_mode="stretch_width", width=None)
        r = fig.scatter(
            "x", "y", source=self.scene, size=14, marker="circle", color="yellow", line_color="black"
        )
        fig.legend[0].items.append(_legend_item("the selected scene", r))
        scale_fonts(fig, self.font_scale)  # (before it goes into the page)
        self.figure = fig
        self.profile_note = pn.pane.Alert(
            "",
            alert_type="warning",
            visible=False,
            sizing_mode="stretch_width",
            css_classes=["vt-vertical-profile"],
        )
        self.pane.objects = [self.profile_note, pn.pane.Bokeh(fig, sizing_mode="stretch_width")]
        self._on_profile()

    def scale_fonts(self, factor):
        """The figure's text at `factor` times Bokeh's sizes (presentation
        mode), and when it is built later."""
        self.font_scale = factor
        if self.figure is not None:
            scale_fonts(self.figure, factor)

    def _on_profile(self, *events):
        """The shipped curve is the sphere's: with another profile, say so
        (the library computes its own: `vibtrans threshold --profile`)."""
        if self.profile_note is None:
            return
        profile = self.state.profile
        self.profile_note.object = (
            f"**The deformable curve is the sphere's** (Hertz, shipped), not the selected "
            f"{profile}'s: its threshold differs. `vibtrans threshold --profile {profile} "
            f"--mass M` computes it at a mass m*. The material point's curve holds for "
            f"any profile (a rigid point)."
        )
        self.profile_note.visible = not is_sphere(profile)

    def _moved(self, *events):
        in_document(self.scene, {"x": [self.state.log_amplitude], "y": [self.state.log_mass]})


def _legend_item(label, renderer):
    from bokeh.models import LegendItem

    return LegendItem(label=label, renderers=[renderer])
