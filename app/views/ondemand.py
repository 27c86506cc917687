"""The "Map on demand" tab: a map request's fields (app/session/maprequest.py),
its estimated cost shown before anything runs, Compute and Cancel, and
what the computation is doing.  The explorer runs it (app/server/mapjobs.py) and
draws the map in the map tab."""

import functools

import panel as pn

from vibtrans_explorer.session.maprequest import FIELDS, MapRequest
from vibtrans_explorer.views import inputs
from vibtrans_explorer.views.profile import ProfileView, RollingView

INTRO = (
    "**A drift map of your own**: any model, friction, material, ramp, run length "
    "and fidelity, over any window of the (log10 A\\*, log10 m\\*) plane, even beyond "
    "the shipped maps'. It is computed on this server coarse first, then refined level "
    "by level where the map changes, each level drawn in the map tab as it finishes; a "
    "map computed once (by anyone) comes back at once from the server's cache. Click "
    "it to run a scene there; the page's link reopens it."
)
RESOLUTION = (
    "*The finest grid has cells x 2^K + 1 points per axis; the first pass computes cells + 1 per axis.*"
)
STOP_NOTE = (
    "*Stopping rule: **decided** ends each point's run once its drift is known to the "
    "fidelity's stated error (a regular motion's rate extrapolated to T_obs, a chaos "
    "verdict with margin, a flight that lasts past T_obs); a drift that is not steady "
    "runs to the end. **full** runs every point all its periods. The map's title "
    "says which rule made it.*"
)


class MapRequestPanel(pn.viewable.Viewer):
    """The request's widgets.  on_compute(), on_cancel(), on_zoom() (fill
    the window from the map's zoom), on_change() (a value changed: a new
    estimate) are the explorer's."""

    def __init__(self, request=None, on_compute=None, on_cancel=None, on_zoom=None, on_change=None, **params):
        super().__init__(**params)
        self.request = request or MapRequest()
        r = self.request
        number = {
            name: inputs.NumberField(r, name, label, width=140)
            for name, label in (
                ("mu", "mu"),
                ("theta", "theta"),
                ("nu", "nu (Poisson)"),
                ("tau", "tau (periods)"),
                ("periods", "periods"),
                ("alpha_t", "alpha_t"),
                ("la_from", "log10 A* from"),
                ("la_to", "log10 A* to"),
                ("lm_from", "log10 m* from"),
                ("lm_to", "log10 m* to"),
                ("cells", "coarse cells per axis"),
                ("levels", "levels K"),
            )
        }
        self.fields = list(number.values())
        # (wider than the fields: "deformable" was cut in presentation mode)
        select = {
            name: pn.widgets.Select.from_param(
                r.param[name], label=label, width=170, css_classes=[f"vt-map-{name}"]
            )
            for name, label in (
                ("model", "model"),
                ("fidelity", "fidelity"),
                ("integrator", "integrator"),
                ("stick_rule", "stick rule"),
                ("stop", "stopping rule"),
            )
        }
        self.point_mass = pn.Row(select["stick_rule"], number["alpha_t"], visible=r.model == "point-mass")
        # the particle's profile (a view of the request's; the material point is rigid)
        self.profile = ProfileView(r, drawing=False, width=290)
        # and whether it rolls (the shipped maps' particle does not)
        self.rolling = RollingView(r, width=290)
        r.param.watch(lambda e: setattr(self.point_mass, "visible", e.new == "point-mass"), "model")
        self.zoom_button = pn.widgets.Button(label="Use the map's current zoom", css_classes=["vt-map-zoom"])
        self.compute_button = pn.widgets.Button(
            label="Compute map", color="primary", css_classes=["vt-map-compute"]
        )
        self.cancel_button = pn.widgets.Button(
            label="Cancel map", color="warning", disabled=True, css_classes=["vt-map-cancel"]
        )
        for button, fn in (
            (self.zoom_button, on_zoom),
            (self.compute_button, on_compute),
            (self.cancel_button, on_cancel),
        ):
            if fn is not None:
                button.on_click(lambda event, fn=fn: fn())
        self.estimate = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-map-estimate"])
        self.status = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-map-status"])
        if on_change is not None:
            r.param.watch(lambda *e: on_change(), list(FIELDS))
        # rows that wrap where the tab is narrower than four fields (half of
        # a 1024-pixel screen: the fourth was cut at the page's edge)
        row = functools.partial(
            pn.FlexBox, flex_wrap="wrap", align_items="flex-start", sizing_mode="stretch_width"
        )
        self._layout = pn.Column(
            pn.pane.Markdown(INTRO, sizing_mode="stretch_width"),
            row(select["model"], number["mu"], number["theta"], number["nu"]),
            row(number["tau"], number["periods"], select["fidelity"], select["integrator"]),
            self.point_mass,
            self.profile,
            self.rolling,
            row(number["la_from"], number["la_to"], number["lm_from"], number["lm_to"]),
            self.zoom_button,
            row(number["cells"], number["levels"], select["stop"]),
            pn.pane.Markdown(RESOLUTION, sizing_mode="stretch_width"),
            pn.pane.Markdown(STOP_NOTE, sizing_mode="stretch_width"),
            self.estimate,
            pn.Row(self.compute_button, self.cancel_button),
            self.status,
            sizing_mode="stretch_width",
            name="map-request",
        )

    def errors(self):
        """The fields' messages (a field whose text is not a valid value)."""
        return [f.error for f in [*self.fields, self.profile, self.rolling] if f.error]

    def set_values(self, **values):
        self.request.param.update(**values)

    def __panel__(self):
        return self._layout
