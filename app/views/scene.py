"""The sidebar's scene controls, each a view of the session's state: the
paper points, v0* on a log slider, mu among the model's shipped maps, the
typed log10 A* and m*, the material point's own controls, and the note
that says when the scene lies outside the map.  A control never keeps a
copy of the scene: it sets the state, and the state's watchers set it."""

import math

import panel as pn
from bokeh.models import CustomJSTickFormatter

from vibtrans.core.params import MAP_LOG_AMPLITUDE, MAP_LOG_MASS, PAPER_POINTS
from vibtrans_explorer.server import data
from vibtrans_explorer.session.state import MAP_MATERIAL, MAP_RUN, ExplorerState, within
from vibtrans_explorer.texts import POINT_LABELS
from vibtrans_explorer.views import inputs

CHOOSE_POINT = "choose a paper point"  # the selector naming none


class SceneControls:
    """SceneControls(state, run, answered): `run()` runs the state's scene (a
    paper point chosen), `answered()` clears the browser's acknowledgement
    (a v0* that rounds to its old value redraws nothing)."""

    def __init__(self, state, run, answered):
        self.state, self.run, self.answered = state, run, answered
        self._pointing = False  # the selector follows the state: no run
        # a fresh page has run nothing: its selector names no point (its
        # scene is point 1's) until the page runs or moves the scene
        self._claimed = False
        self.point_select = pn.widgets.Select(
            label="Paper points",
            options={CHOOSE_POINT: 0, **{f"{k}: {v}": k for k, v in POINT_LABELS.items()}},
            css_classes=["vt-ack-run", "vt-paper-points"],
        )
        self.point_select.param.watch(self._on_point, "value")
        # v0* on a log scale (a linear slider from 0.001 to 10 could not reach
        # the small values); it shows v0* itself
        lo, hi = ExplorerState.param.v0.bounds
        self.v0_slider = pn.widgets.FloatSlider(
            label="v0* (white band |v*| <= v0*)",
            start=math.log10(lo),
            end=math.log10(hi),
            step=0.05,
            value=math.log10(state.v0),
            format=CustomJSTickFormatter(code="return Number((10 ** tick).toPrecision(2))"),
        )
        self.v0_slider.param.watch(self._on_v0_slider, "value_throttled")
        state.param.watch(self._on_v0, "v0")
        # mu offers the shipped maps of the model shown (no blank map)
        # (and the mu in use when no shipped map has it: shown as it is)
        self.mu_select = pn.widgets.Select.from_param(
            state.param.mu, options=self._mu_options(), label="mu (shipped maps)", css_classes=["vt-mu"]
        )
        state.param.watch(self._on_model, ["model", "mu"])  # before the map's redraw
        # typed numbers: checked like a link's, applied only when valid
        self.fields = [
            inputs.NumberField(state, "log_amplitude", "log10 A*"),
            inputs.NumberField(state, "log_mass", "log10 m*"),
        ]
        # the material point's controls (its alpha_t field joins self.fields),
        # shown when it runs; built, hidden, once a served page has loaded
        # (not with the page: most sessions never show them), so that the
        # first switch to the point mass only shows them (built at that
        # switch, their new views cost the browser's redraw of the map
        # 0.1-0.3 s more)
        self.point_mass_controls = pn.Column(margin=0, name="point-mass-controls")
        state.param.watch(self._on_point_mass_shown, ["model", "compare"])
        self._on_point_mass_shown()
        doc = pn.state.curdoc
        if doc is not None and doc.session_context is not None:
            pn.state.onload(self._build_point_mass_controls)
        self.where = pn.pane.Alert(
            "", alert_type="info", visible=False, sizing_mode="stretch_width", name="where"
        )
        self._on_position()
        state.param.watch(self._on_position, ["log_amplitude", "log_mass", "model"])

    def paper_point(self):
        """The paper point the selector names: the one the state's scene is
        (its log10 A*, m* and model), once the page has run or moved the
        scene (`claim`), else 0."""
        s = self.state
        return next(
            (
                k
                for k, (la, lm, model) in PAPER_POINTS.items()
                if self._claimed and (la, lm, model) == (s.log_amplitude, s.log_mass, s.model)
            ),
            0,
        )

    def claim(self):
        """A run started: the selector names the state's paper point."""
        if not self._claimed:
            self._claimed = True
            self._on_position()

    def _on_point(self, event):
        k = event.new
        if not k or self._pointing:
            return
        la, lm, model = PAPER_POINTS[k]
        self._claimed = True  # (point 1 on a fresh page moves nothing)
        self.state.param.update(model=model, log_amplitude=la, log_mass=lm, **MAP_MATERIAL, **MAP_RUN)
        self.run()

    def _on_position(self, *events):
        self._claimed = self._claimed or bool(events)  # the scene moved
        la, lm = self.state.log_amplitude, self.state.log_mass
        k = self.paper_point()
        if self.point_select.value != k:  # a click or a link on a paper point shows it
            self._pointing = True
            try:
                self.point_select.value = k
            finally:
                self._pointing = False
        inside = within(la, lm, MAP_LOG_AMPLITUDE, MAP_LOG_MASS)
        self.where.object = (
            ""
            if inside
            else (
                f"The selected scene (log10 A* = {la:g}, log10 m* = {lm:g}) lies outside the "
                f"map (log10 A* in [{MAP_LOG_AMPLITUDE[0]:g}, {MAP_LOG_AMPLITUDE[1]:g}], log10 m* "
                f"in [{MAP_LOG_MASS[0]:g}, {MAP_LOG_MASS[1]:g}]): it runs all the same, without "
                f"a map colour to compare with."
            )
        )
        self.where.visible = not inside

    def _on_v0_slider(self, event):
        v0 = float(f"{10.0**event.new:.2g}")
        lo, hi = ExplorerState.param.v0.bounds
        self.state.v0 = min(max(v0, lo), hi)  # 10**(log10 bound) may round past it
        self.answered()  # also when v0* rounds to its old value: no redraw

    def _on_v0(self, event):
        x = math.log10(event.new)
        if abs(self.v0_slider.value - x) > 1e-9:
            self.v0_slider.value = x

    def _on_point_mass_shown(self, *events):
        s = self.state
        shown = s.model == "point-mass" or s.compare == "point mass"
        if shown:
            self._build_point_mass_controls()
        self.point_mass_controls.visible = shown

    def _build_point_mass_controls(self):
        if self.point_mass_controls.objects:
            return
        s = self.state
        alpha_t = inputs.NumberField(s, "alpha_t", "alpha_t (point mass: tangential restitution)")
        self.fields.append(alpha_t)
        self.point_mass_controls.objects = [
            pn.widgets.Select.from_param(s.param.stick_rule, label="stick rule (point mass: slide -> stick)"),
            alpha_t,
        ]

    def _mu_options(self):
        """The mus of the model's shipped maps, and the one in use if no
        shipped map has it (a link's, a map on demand's, a device's): the
        selector shows the value run, the map says it has no map for it."""
        model = self.state.model
        shipped = {mu for (m, mu) in data.available_maps() if m == model}
        return sorted({*shipped, self.state.mu})

    def _on_model(self, *events):
        options = self._mu_options()
        if list(self.mu_select.options) != options:
            self.mu_select.options = options
