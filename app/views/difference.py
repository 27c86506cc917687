"""The "Difference" tab: two drift maps compared: mu 0.1
against 0.3, the deformable particle against the material point, a map on
demand against a shipped map.  The comparison is the library's
(`vibtrans.maps.difference.map_difference`, drawn by `plots.map_difference_figure`,
the same as `vibtrans compare`); this view only picks the two maps and
shows the result."""

import asyncio
import logging

import panel as pn

from vibtrans.core.errors import InputError
from vibtrans.maps.difference import map_difference
from vibtrans.products import plots
from vibtrans_explorer.server import data
from vibtrans_explorer.session.urlstate import literal
from vibtrans_explorer.views.map import MAP_FRAME_HEIGHT, MIN_WIDTH
from vibtrans_explorer.views.presentation import scale_fonts
from vibtrans_explorer.views.render import rendered

log = logging.getLogger("vibtrans.explorer")

COMPUTED = "map on demand"
INTRO = (
    "**Two maps compared.** The second map's drift against the first's at the first "
    "map's points, in decades of the maps' signed log scale s(v) = sign(v) log10(1 + "
    "|v|/v0\\*): red where the second drifts more towards +x, blue less, black where "
    "the drift class (against, none, with the wave) differs, grey where either map "
    "calls the point chaotic (its drift is not a property of the scene), blank where "
    "the maps do not both have the point. A map on demand appears here once it is "
    "shown in the map tab."
)


def shipped_label(model, mu):
    return f"{model}, mu = {mu:g} (shipped)"


def difference_figure(first, second, v0):
    """(figure, Dataset) of second against first (off the event loop)."""
    diff = map_difference(first, second, v0)
    _, fig = rendered(plots.map_difference_figure, diff)
    fig.document.remove_root(fig)
    # the map's frame height (the default figure's left its colour bar
    # shorter than the bar's title); the title names the maps, on two lines,
    # and the summary above the figure says how they agree (on the figure,
    # a line of that was wider than its frame)
    fig.update(
        sizing_mode="stretch_width",
        min_width=MIN_WIDTH,
        width=None,
        height=None,
        frame_height=MAP_FRAME_HEIGHT,
    )
    a = diff.attrs
    fig.title.text = f"{a['second']}\nagainst {a['first']}"
    return fig, diff


class DifferenceView:
    """The tab's widgets.  state: the explorer's (its v0*); computed():
    (name, Dataset) of the map on demand shown, or None."""

    def __init__(self, state, computed=lambda: None):
        self.state, self.computed = state, computed
        self.diff = None  # the Dataset shown
        self.font_scale = 1.0  # presentation mode's (`scale_fonts`)
        self.panel = pn.Column(sizing_mode="stretch_width", name="difference")
        self._built = False

    def build(self):
        """Made when the tab is first opened (a page's widgets cost the
        event loop that every session shares); the list of maps is refreshed
        every time (a map on demand may have been shown since)."""
        if not self._built:
            self._built = True
            # one under the other, as wide as the tab (side by side at 330
            # pixels each, the second was off the page and their choices cut
            # in presentation mode)
            self.first = pn.widgets.Select(
                label="first map", sizing_mode="stretch_width", max_width=600, css_classes=["vt-diff-first"]
            )
            self.second = pn.widgets.Select(
                label="second map (compared with the first)",
                sizing_mode="stretch_width",
                max_width=600,
                css_classes=["vt-diff-second"],
            )
            self.button = pn.widgets.Button(
                label="Show the difference", color="primary", css_classes=["vt-diff-show"]
            )
            self.button.on_click(self._on_show)
            self.message = pn.pane.Alert(
                "",
                alert_type="warning",
                visible=False,
                sizing_mode="stretch_width",
                css_classes=["vt-diff-message"],
            )
            self.summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-diff-summary"])
            self.figure = pn.Column(sizing_mode="stretch_width")
            self.panel.objects = [
                pn.pane.Markdown(INTRO, sizing_mode="stretch_width"),
                self.first,
                self.second,
                self.button,
                self.message,
                self.summary,
                self.figure,
            ]
        self.refresh()

    def choices(self):
        """{label: ("shipped", model, mu) or ("computed",)}: the maps one can compare."""
        out = {shipped_label(m, mu): ("shipped", m, mu) for (m, mu) in sorted(data.available_maps())}
        shown = self.computed()
        if shown is not None:
            out[f"{COMPUTED}: {shown[0]}"] = ("computed",)
        return out

    def refresh(self):
        options = self.choices()
        labels = list(options)
        old = list(self.first.options)
        keep = [w.value if w.value in labels else None for w in (self.first, self.second)]
        computed = [l for l in labels if l.startswith(COMPUTED)]
        if computed and computed[0] not in old:
            # a map on demand new here: compared at once, on its own grid
            # (the comparison is at the first map's points: a small window
            # read at the shipped grid's points would be a few stripes),
            # with the shipped map of its model and mu if there is one
            attrs = self.computed()[1].attrs
            shipped = shipped_label(attrs.get("scene_model"), attrs.get("scene_mu", float("nan")))
            keep = [computed[0], shipped if shipped in labels else keep[0]]
        self.first.options, self.second.options = labels, labels
        # by default, the example: the deformable particle against the
        # material point at mu 0.3
        first = keep[0] or next(
            (l for l in labels if l.startswith("deformable, mu = 0.3")), labels[0] if labels else None
        )
        second = keep[1] or next(
            (l for l in labels if l.startswith("point-mass")), labels[-1] if labels else None
        )
        self.first.value, self.second.value = first, second

    def _dataset(self, label):
        kind = self.choices().get(label)
        if kind is None:
            raise InputError(f"the map {label!r} is no longer there: choose another")
        if kind[0] == "computed":
            return self.computed()[1]
        return data.drift_map(kind[1], kind[2])

    async def _on_show(self, event=None):
        await self.show()

    async def show(self):
        """The difference of the two maps chosen, drawn (or a message saying
        why not: the same map twice, maps that share no point)."""
        self.message.visible = False
        if self.first.value == self.second.value:
            self._say("Choose two different maps.")
            return
        self.button.loading = True
        try:
            first, second = self._dataset(self.first.value), self._dataset(self.second.value)
            fig, diff = await asyncio.get_running_loop().run_in_executor(
                None, difference_figure, first, second, self.state.v0
            )
        except (InputError, data.MapUnavailable) as exc:
            self._say(str(exc))
            return
        except Exception as exc:  # a bug: said, and logged with its traceback
            log.exception("the difference of two maps failed")
            self._say(f"Comparing the maps failed: {type(exc).__name__}: {literal(exc)}")
            return
        finally:
            self.button.loading = False
        self.diff = diff
        a = diff.attrs
        agreement = (
            "no point is regular in both maps"
            if a["regular_points"] == 0
            else f"the drift class agrees at **{100 * a['class_agreement']:.1f}%** of the "
            f"{a['regular_points']} points regular in both; the median relative "
            f"drift difference |v2 - v1| / max(|v1|, v0\\*) is "
            f"{a['median_relative_difference']:.2g}"
        )
        self.summary.object = (
            f"**{literal(a['second'])}** against **{literal(a['first'])}**: "
            f"{a['compared_points']} points compared; {agreement}."
        )
        scale_fonts(fig, self.font_scale)  # (before it goes into the page)
        self.figure.objects = [pn.pane.Bokeh(fig, sizing_mode="stretch_width")]

    def scale_fonts(self, factor):
        """The figure's text at `factor` times Bokeh's sizes (presentation
        mode), and when one is drawn later."""
        self.font_scale = factor
        for pane in self.figure.select(pn.pane.Bokeh) if self._built else []:
            scale_fonts(pane.object, factor)

    def _say(self, text):
        self.message.object = text
        self.message.visible = True
