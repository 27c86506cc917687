"""The vibtrans explorer's page: layout and callbacks only.

What the session selected is `state.ExplorerState` (mirrored in the URL,
app/session/urlstate.py); its runs are `controller.RunController` (no widgets);
each part of the page is a view in app/views/ (the scene's controls, the
run's buttons, the profile, map, summary, the run's tabs, units, vertical,
exports, ...) bound to the state or fed by the controller's result.  Physics comes
from `vibtrans`, figures from `vibtrans.products.plots` and app/views/live.py.

Serve with `vibtrans serve` (app/server/serve.py: checks the maps first, then
serves while the kernels compile in the background, app/server/warmup.py) or
`panel serve app/explorer.py` (runs then compile what they need).
"""

import functools
import logging
import uuid
import weakref
from types import SimpleNamespace

import holoviews as hv
import panel as pn
import param

from vibtrans import simulate
from vibtrans.core.fidelity import PRESET_NOTES
from vibtrans_explorer.server import data, memory, warmup
from vibtrans_explorer.session import maprequest, urlstate
from vibtrans_explorer.session.controller import CANCELLED, RunController
from vibtrans_explorer.session.latest import at_next_tick
from vibtrans_explorer.session.pagelink import PageLink, map_request_of
from vibtrans_explorer.session.state import (
    DEVICE_FIELDS,
    MAP_MATERIAL,
    MAP_RUN,
    MAP_TABS,
    SCENE_FIELDS,
    URL_KEYS,
    ExplorerState,
)
from vibtrans_explorer.texts import INTRODUCTION, MAP_KEY, POINT_DESCRIPTIONS, PRESENTATION_NOTE, STALE_TEXT
from vibtrans_explorer.views.browserside import ACK_RUN, BrowserAddress, ack_js, ack_listener, ack_pane
from vibtrans_explorer.views.design import DesignPanel
from vibtrans_explorer.views.difference import DifferenceView
from vibtrans_explorer.views.exports import ExportsView
from vibtrans_explorer.views.map import MapView
from vibtrans_explorer.views.mapondemand import MapOnDemand
from vibtrans_explorer.views.presentation import (
    BOKEH_FONT_PX,
    PRESENTATION_SCALE,
    SIDEBAR_WIDTH,
    WRAPPING_TABS,
    ExplorerDesign,
    scale_fonts,
    scale_widths,
)
from vibtrans_explorer.views.profile import ProfileView, RollingView
from vibtrans_explorer.views.runbuttons import RunButtons
from vibtrans_explorer.views.runtabs import RunTabs
from vibtrans_explorer.views.scene import SceneControls
from vibtrans_explorer.views.summary import SummaryView
from vibtrans_explorer.views.tabs import lazy_tabs
from vibtrans_explorer.views.trajectory import TrajectoryView, structure
from vibtrans_explorer.views.units import UnitsPanel
from vibtrans_explorer.views.vertical import VerticalView

hv.extension("bokeh")
# Canvas, not WebGL: the figures hold at most ~10^4 points per curve, which a
# 2D canvas draws in milliseconds, while WebGL without a GPU (software GL:
# headless browsers, VMs, remote desktops) spent ~1.7 s per update copying
# its canvas into every figure (`blit_webgl`, measured in chromium).
hv.renderer("bokeh").webgl = False
log = logging.getLogger("vibtrans.explorer")

# the map's tabs: map, vertical curves, units, map on demand, difference of
# two maps, design chart
VERTICAL_TAB, UNITS_TAB, ONDEMAND_TAB, DIFFERENCE_TAB, DESIGN_TAB = 1, 2, 3, 4, 5
# the state's values a run is made of (a change marks the run shown stale):
# its scene's, and the twin run beside it
SCENE_STATE = (*SCENE_FIELDS, "compare")

# the sidebar's widgets that take its width (`controls`)
SIDEBAR_STRETCHED = (
    pn.widgets.Select,
    pn.widgets.TextInput,
    pn.widgets.RadioButtonGroup,
    pn.widgets.FloatSlider,
)

# the stale note's style while the run shown is the state's, and while it is
# not (`_set_stale_note`): BokehJS sets the properties given and removes those
# given as None (an empty dict would leave the note hidden)
_STALE_HIDDEN, _STALE_SHOWN = {"display": "none"}, {"display": None}


def _point_note(point):
    """The chosen paper point in full words, under its selector (empty for none)."""
    return f"*Point {point}: {POINT_DESCRIPTIONS[point]}*" if point else ""


def _request():
    """The served session's HTTP request (None outside a served session)."""
    doc = pn.state.curdoc
    ctx = doc.session_context if doc is not None else None
    return getattr(ctx, "request", None) if ctx is not None else None


def _page_location():
    """The page's address in the browser (views.browserside.BrowserAddress;
    None outside a served session): the link written from the state, the
    browser's Back and Forward followed (app/session/pagelink.py).  The
    served page embeds it where Panel's template embeds its Location
    (`serve_page`)."""
    return None if _request() is None else BrowserAddress()


class Explorer(pn.viewable.Viewer):
    """One session's explorer: its state, run controller, views and
    controls.  simulate: the library's (a test passes a stand-in)."""

    presentation = param.Boolean(default=False, doc="large fonts, for a projector")

    def __init__(self, simulate=simulate, **params):
        super().__init__(**params)
        self.state = ExplorerState()
        self.served = pn.state.curdoc is not None and pn.state.curdoc.session_context is not None
        self.controller = RunController(
            self.state, simulate=simulate, schedule=pn.state.execute, refusals=self._field_errors
        )
        self.message = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width")
        self.ack = ack_pane()
        if pn.state.curdoc is not None:  # (the page's acknowledgements)
            pn.state.curdoc.js_on_event("document_ready", ack_listener())
        # the run's buttons and progress (app/views/runbuttons.py)
        self.run_buttons = RunButtons(self.controller, run=self.start_run, answered=self._answered)
        # the scene's controls (app/views/scene.py)
        self.scene_controls = SceneControls(self.state, run=self.start_run, answered=self._answered)
        self.profile_view = ProfileView(self.state)  # the particle's profile, its tip drawn
        self.rolling_view = RollingView(self.state)  # whether (and how) it rolls
        # the views; the run's are in place from the start (empty, disabled),
        # so the first run changes no layout in the page
        self.units_panel = UnitsPanel(self.state, on_run=self._run_device)
        self.units_box = pn.Column(sizing_mode="stretch_width", name="units")  # its widgets: when opened
        self.summary_view = SummaryView(self.units_panel.si_text)
        # a run whose inputs changed since it was made: said over its views
        # shown and hidden by its style (`_set_stale_note`), not by `visible`
        self.stale_note = pn.pane.Alert(
            STALE_TEXT,
            alert_type="warning",
            sizing_mode="stretch_width",
            css_classes=["vt-stale"],
            styles=dict(_STALE_HIDDEN),
        )
        self.presentation_note = pn.pane.Markdown(
            PRESENTATION_NOTE, visible=False, sizing_mode="stretch_width"
        )
        self.trajectories = TrajectoryView()
        # the map on demand (app/views/mapondemand.py)
        self.ondemand = MapOnDemand(
            self.state, answered=self._answered, run=self.start_run, session=f"explorer-{id(self)}"
        )
        self.location = _page_location()
        self.runs_on_load = False  # a link naming a scene runs it (_apply_url)
        self._url_map = None  # a map request named by the link
        self._apply_url()
        # a particle that rolls: its kernels compile in the background now
        # (once per server), before its first run is asked for
        self.state.param.watch(self._on_rolling, "rolling")
        self._on_rolling()
        problems = data.problems()  # damaged or missing shipped files
        if problems:
            self._error("\n\n".join(filter(None, [self.message.object, *problems])))
        self.map_view = MapView(
            self.state,
            self._on_map_click,
            on_tap_js=ack_js(ACK_RUN),
            on_zoom=self.ondemand.on_zoom,
            answered=self._answered,  # a map loaded off the event loop is shown
        )
        self.ondemand.map_view = self.map_view
        self.state.param.watch(
            self._on_map_setting, ["model", "mu", "v0", "chaotic", "maps", "layer", "orbits"], precedence=2
        )  # after the map's redraw
        self.map_key = pn.pane.Markdown(
            MAP_KEY, sizing_mode="stretch_width", css_classes=["vt-map-key"], margin=(0, 10)
        )
        self.map_pane = pn.Column(
            self.ondemand.profile_box,
            self.ondemand.map_banner,
            self.ondemand.refine_box,
            self.map_view.loading_line,
            self.map_view.pane,
            self.map_key,
            sizing_mode="stretch_width",
        )
        self.state.param.watch(self.ondemand.on_map_look, ["v0", "chaotic"])
        self.vertical = VerticalView(self.state)
        self.exports = ExportsView(
            self.state,
            self.map_view,
            answered=self._answered,
            button_classes=["vt-ack-file"],
            shown_map=self.ondemand.computed_map,
        )
        self.difference = DifferenceView(self.state, computed=self.ondemand.computed_map)
        # the run's tabs, each built when first opened (app/views/runtabs.py)
        self.runs = RunTabs(self.trajectories, self.exports, error=self._error)
        self._widths = self.runs.widths  # the widgets' own widths (`scale_widths`)
        self._on_position()
        self.state.param.watch(self._on_position, ["log_amplitude", "log_mass", "model"])
        self.units_panel.param.watch(self._on_device, "marker")
        self._on_device()
        self.state.param.watch(self._on_stale, [*SCENE_STATE, *DEVICE_FIELDS, "invalid"])
        # what the controller publishes, shown
        c = self.controller
        c.param.watch(self._on_status, "status", onlychanged=False)
        c.param.watch(self._on_message, "message", onlychanged=False)
        c.param.watch(self._on_result, "result")
        self.param.watch(self._on_presentation, "presentation")
        if self.served:
            pn.state.on_session_destroyed(self._on_session_destroyed)

    # ---------- URL ----------
    def _apply_url(self):
        """Apply the link's values (app/session/pagelink.py: checked, then the
        address follows the state), and run its scene once the page has
        loaded if the link names one (`_follow_link`)."""
        if self.location is None:
            return
        self.link = PageLink(self.state, self.location, navigated=self._on_navigation)
        values, errors, request = self.link.read(pn.state.session_args or {})
        later = pn.state.onload if self.served else None
        self.runs_on_load = self._follow_link(values, errors, request, later=later)

    def _follow_link(self, values, errors, request, later):
        """What a link does once its values are applied: its errors said (a
        link with an error runs nothing), its map on demand drawn (from the
        cache, or computed again), and its scene run if it names one (log10
        A* or m*).  later(f): f called when the page can take it (None: not
        called).  Returns whether the link's scene runs."""
        self._error(urlstate.message(errors))
        self._url_map = request
        runs = not errors and ("log_amplitude" in values or "log_mass" in values)
        if later is not None and request is not None and not errors:
            later(lambda: pn.state.execute(functools.partial(self.ondemand.compute_map, request)))
        if later is not None and runs:
            later(self.start_run)
        return runs

    def _on_navigation(self, args):
        """The browser's Back or Forward reached another address of the page:
        its scene, as a link names it, in one step (form, marker, map, run)."""
        request, _ = map_request_of(args)
        with pn.io.hold():
            if request is None and self.state.map_request is not None:
                self.ondemand.back_to_shipped()  # (the map on demand leaves the page)
            shown = self.state.map_request
            values, errors, request = self.link.apply(args)
            # a field left with an invalid text shows the link's value (a value
            # the state had already: no change reached the field)
            typed = [name for name in self.state.invalid if name in URL_KEYS]
            if typed:
                self.state.param.trigger(*typed)
            if request is not None and maprequest.encode(request) == shown:
                request = None  # the map shown already
            self._follow_link(values, errors, request, later=lambda f: f())

    def url_query(self):
        """The page's link query (PageLink.query)."""
        return PageLink(self.state, None).query()

    def _error(self, text):
        self.message.object = text
        self.message.visible = bool(text)

    def _field_errors(self):
        """The messages of the scene's invalid typed fields (a run refuses)."""
        return self.state.errors(SCENE_FIELDS)

    # ---------- controls ----------
    def _on_position(self, *events):
        self.map_view.select(self.state.log_amplitude, self.state.log_mass)
        if self.message.object.startswith("Not run:") and not self._field_errors():
            self._error("")  # the fields it named are valid now

    def stale(self):
        """Why the run shown is not the state's (a list of its changed
        values; empty: it is, or there is no run)."""
        result = self.controller.result
        if result is None or result.ran is None:
            return []
        ran, s = result.ran, self.state
        changed = [k for k in SCENE_STATE if getattr(s, k) != ran[k]]
        if self.summary_view.device_run:  # its SI values: the device's
            changed += [k for k in DEVICE_FIELDS if getattr(s, k) != ran[k]]
        changed += [k for k in s.errors(SCENE_FIELDS)]
        return changed

    def _on_stale(self, *events):
        stale = bool(self.stale())
        if self.stale_shown() != stale:
            with pn.io.hold():
                self._set_stale_note(stale)
                self.summary_view.mark_stale(stale)

    def stale_shown(self):
        """Whether the stale note is shown (`_set_stale_note`)."""
        return self.stale_note.styles != _STALE_HIDDEN

    def _set_stale_note(self, stale):
        """Show or hide the stale note by its style, not by `visible`: in
        BokehJS a change of a layout's `visible` lays out again every
        figure of the page's main column (`invalidate_layout` of the layout
        root: ~10 plots, each forcing a style recalculation), which cost
        the browser 0.5-1 s at every mu or model change after a run
        (measured in chromium); a style changes the note's element alone."""
        self.stale_note.styles = dict(_STALE_SHOWN if stale else _STALE_HIDDEN)

    def _on_device(self, *events):
        self.map_view.mark_device(self.units_panel.marker)

    def _on_rolling(self, *events):
        if self.state.rolling != "none":
            warmup.prepare_rolling()

    def _on_map_click(self, la, lm, both):
        """A click on a map: that point's scene, in the map's material; with
        both maps shown, the deformable run beside the point mass's."""
        both = {"model": "deformable", "compare": "point mass"} if both else {}
        self.state.param.update(log_amplitude=la, log_mass=lm, **MAP_MATERIAL, **MAP_RUN, **both)
        self.start_run()

    def _run_device(self, say=None, **scene):
        """Run the device of the Units and Design tabs (ExplorerState.select_device);
        a refusal said over the page, and by `say(text)` where given (beside
        the tab's Run button)."""
        try:
            self.state.select_device(**scene)
        except ValueError as exc:
            self._error(f"Not run: {exc}")
            if say is not None:
                say(f"Not run: {exc}")
            self._answered()  # (the page's "Running ..." said at the click: answered)
            return None
        return self.start_run()

    def _run_design_device(self, mu, periods):
        """Run the Design tab's device (the state's, as the form shows it):
        the deformable particle at its (A*, m*, theta, nu), the tab's mu and
        its map's periods; its drift and time also in SI units."""
        return self._run_device(model="deformable", mu=mu, periods=periods)

    def _on_presentation(self, event):
        """Large text and figure fonts for a projector; the introduction
        folded away so that map and trajectory share the screen."""
        factor = PRESENTATION_SCALE if event.new else 1.0
        with pn.io.hold():
            # Bokeh's font size for its widgets, tabs and text panes (a CSS
            # property their shadow roots inherit); the page's root size,
            # which Bootstrap's buttons and inputs follow, is set in the
            # browser (browserside.py)
            text = {"--bokeh-font-size": f"{BOKEH_FONT_PX * factor:g}px"} if event.new else {}
            for part in (getattr(self, "page", None), getattr(self, "controls_column", None)):
                if part is not None:
                    part.styles = text
            self.presentation_note.visible = event.new
            self.map_view.scale_fonts = (lambda fig: scale_fonts(fig, factor)) if event.new else None
            for fig in self.map_view.figures:
                scale_fonts(fig, factor)
            self.map_view.fit_keys()
            self.trajectories.scale_fonts(factor)
            self.runs.scale_fonts(factor)
            self._scale_tabs(factor)
            if event.new and getattr(self, "intro", None) is not None:
                self.intro.collapsed = True

    def _scale_tabs(self, factor):
        """The map's tabs and the sidebar's drawing at `factor` times their
        text's sizes: their figures' fonts (and those drawn later), the
        widths of their selects and text boxes."""
        for view in (self.vertical, self.difference, self.profile_view):
            view.scale_fonts(factor)
        if self.design_panel is not None:
            self.design_panel.font_scale = factor
            for pane in self.design_panel.chart_pane.select(pn.pane.Bokeh):
                scale_fonts(pane.object, factor)
        for part in (getattr(self, "page", None), getattr(self, "controls_column", None)):
            if part is not None:
                scale_widths(part, factor, self._widths)

    # ---------- runs ----------
    def start_run(self, schedule=True):
        """Run the selected scene (RunController.start): returns the RunJob, or
        None if refused.  The figures of a structure (a comparison or none)
        not shown before are built now, while its kernels run (they release
        the GIL), not when the page loads: a page costs the server less
        (`python -m devtools.pagecost`) and the first run no more."""
        job = self.controller.start(schedule=schedule)
        if job is not None:
            self.scene_controls.claim()
        if job is not None and structure(job.label) not in self.trajectories.views:
            try:
                with pn.io.hold(freeze=True):
                    self.trajectories.view(job.label, job.scene.tau)
            except Exception:  # the run's _show builds them (and reports a failure)
                log.exception("building the trajectory figures failed")
        return job

    def _answered(self, *events):
        """Clear the browser's acknowledgement of an action (ack_listener).  The
        new text always differs from the server's copy (whether or not the
        browser's has reached it), so the change is always sent.  In a
        served session on the document's next tick: Panel sends a pane's
        change at once, while the changes of the answer's Bokeh models (the
        map's sources, a run's figures) go when the callback ends; the
        acknowledgement is cleared after them, not before."""
        at_next_tick(pn.state.curdoc, self._clear_ack)

    def _on_map_setting(self, *events):
        """The map redrawn: answered now, or, while its map loads off the
        event loop, once it is shown (MapView's `answered`)."""
        if not self.map_view.loading:
            self._answered()

    def _clear_ack(self):
        self.ack.object = "" if self.ack.object != "" else "<span></span>"

    def _on_status(self, event):
        if event.new == CANCELLED:
            with pn.io.hold():
                self.summary_view.cancelled()
                self.runs.cancelled()
            self._answered()
        else:
            self.summary_view.say(event.new)

    def _on_message(self, event):
        with pn.io.hold():
            self._error(event.new)
            if event.new:
                self._answered()

    def _on_session_destroyed(self, session_context):
        self.ondemand.close()  # its map, unless another session waits
        if getattr(self, "design_panel", None) is not None:  # (made by main())
            self.design_panel.close()  # and the Design tab's
        self.controller.discard()
        self.runs.clear()
        memory.session_closed(session_context)

    def _on_result(self, event):
        result = event.new
        try:
            with pn.io.hold():
                self._show(result)
                self._answered()
        except Exception as exc:
            log.exception("drawing a run failed: %s", result.scene.values())
            self._error(f"Drawing the run failed: {type(exc).__name__}: {urlstate.literal(exc)}")

    def _show(self, result):
        scene = result.scene
        key = structure(result.label)
        # Everything below goes to the browser as one message: new data for
        # the session's existing figures, no new figure models.  Bokeh
        # recomputes a document's model graph only when models come or go;
        # a frozen hold would recompute it at its end regardless (~30 ms per
        # click under load), so only a first run of a structure freezes.
        with pn.io.hold(freeze=key not in self.trajectories.views):
            self.trajectories.show(result, self.units_panel.period_seconds(scene))
            self.exports.show(result)
            self.summary_view.show(result)
            rolled = self.units_panel.show_run(result)  # (a device's run that rolls)
            if getattr(self, "design_panel", None) is not None:  # (made by main())
                self.design_panel.show_run_note(rolled)
            self._set_stale_note(False)
            self._on_stale()
            self.runs.show(result)
        self.runs.update_open()  # after the frozen hold (RunTabs.update_open)

    # ---------- layout ----------
    def controls(self):
        s, rb, sc = self.state, self.run_buttons, self.scene_controls
        self.controls_column = pn.Column(
            pn.Row(rb.run_button, rb.cancel_button),
            rb.progress,
            *self._drawing(
                [
                    pn.widgets.RadioButtonGroup.from_param(s.param.model, label="model"),
                    sc.mu_select,
                    pn.widgets.RadioButtonGroup.from_param(s.param.maps, label="maps"),
                    sc.v0_slider,
                    pn.widgets.RadioButtonGroup.from_param(s.param.chaotic, label="chaotic points"),
                    pn.widgets.RadioButtonGroup.from_param(s.param.layer, label="map shows"),
                    pn.widgets.RadioButtonGroup.from_param(
                        s.param.orbits, label="period-1 orbit curves (deformable)"
                    ),
                ]
            ),
            sc.point_select,
            pn.pane.Markdown(
                pn.bind(_point_note, sc.point_select.param.value),
                css_classes=["vt-point-note"],
                sizing_mode="stretch_width",
                margin=(0, 10),
            ),
            *sc.fields[:2],
            self.profile_view,
            self.rolling_view,
            pn.widgets.Select.from_param(s.param.fidelity, label="fidelity"),
            pn.pane.Markdown(
                pn.bind(lambda f: f"*{f}: {PRESET_NOTES[f]}*", s.param.fidelity),
                css_classes=["vt-preset-note"],
                sizing_mode="stretch_width",
            ),
            pn.widgets.Select.from_param(s.param.integrator, label="integrator"),
            pn.widgets.Select.from_param(s.param.compare, label="compare with"),
            sc.point_mass_controls,
            # (the page's root sizes follow it in the browser: browserside.py)
            pn.widgets.Toggle.from_param(
                self.param.presentation, label="Presentation mode", css_classes=["vt-presentation"]
            ),
            self.presentation_note,
            sizing_mode="stretch_width",
        )
        # the sidebar's widgets take its width (in presentation mode it is
        # wider, and its texts larger: a paper point's name was cut in a box
        # of the normal width)
        for w in self.controls_column.select(pn.widgets.Widget):
            if isinstance(w, SIDEBAR_STRETCHED) and w.sizing_mode is None:
                w.sizing_mode = "stretch_width"
        return self.controls_column

    def _drawing(self, widgets):
        """`widgets` (each redraws the map) acknowledged in the browser
        (ack_listener; a slider's drag from its first step: the redraw
        follows its release)."""
        for w in widgets:
            w.css_classes = [*w.css_classes, "vt-ack-draw"]
        return widgets

    def main(self):
        self.design_panel = None  # the Design tab's, built when it is first opened
        self.design_box = pn.Column(sizing_mode="stretch_width", name="design")
        tabs = lazy_tabs(
            ("Map", self.map_pane),
            ("Vertical", self.vertical.pane),
            ("Units", self.units_box),
            ("Map on demand", self.ondemand.ondemand_box),
            ("Difference", self.difference.panel),
            ("Design", self.design_box),
            sizing_mode="stretch_width",
            stylesheets=[WRAPPING_TABS],
        )
        tabs.param.watch(self._on_tab, "active")
        self.map_tabs = self.ondemand.map_tabs = tabs
        # the tab shown is the state's (a link opens it)
        tabs.active = MAP_TABS.index(self.state.tab)
        self._on_tab(SimpleNamespace(new=tabs.active))
        tabs.param.watch(lambda e: setattr(self.state, "tab", MAP_TABS[e.new]), "active")
        self.state.param.watch(lambda e: setattr(tabs, "active", MAP_TABS.index(e.new)), "tab")
        # folded: its text is added when it is first opened
        self.intro = pn.Card(
            title="What is this? (a short introduction)",
            collapsed=True,
            sizing_mode="stretch_width",
            css_classes=["vt-introduction"],
        )
        self.intro.param.watch(self._on_intro, "collapsed")
        # Side by side on a wide screen (the map with its summary, the
        # trajectory), one above the other on a narrow one.
        half = {"flex": "1 1 560px", "min-width": "0"}
        self.page = pn.Column(
            self.intro,
            self.message,
            self.scene_controls.where,
            self.ack,
            pn.FlexBox(
                pn.Column(tabs, self.summary_view.pane, styles=half, sizing_mode="stretch_width"),
                pn.Column(self.stale_note, self.runs.tabs, styles=half, sizing_mode="stretch_width"),
                flex_wrap="wrap",
                align_items="flex-start",
                sizing_mode="stretch_width",
            ),
            sizing_mode="stretch_width",
        )
        return self.page

    def _on_tab(self, event):
        if event.new == VERTICAL_TAB:
            self.vertical.build()
        elif event.new == UNITS_TAB and not self.units_box.objects:
            self.units_box.objects = [self._scaled(self.units_panel)]
        elif event.new == ONDEMAND_TAB:
            self.ondemand.request_panel()
        elif event.new == DIFFERENCE_TAB:
            self.difference.build()
        elif event.new == DESIGN_TAB and self.design_panel is None:
            self.design_panel = DesignPanel(on_run=self._run_design_device, state=self.state)
            self.design_panel.show_run_note(self.units_panel.run_note.object)
            self.design_panel.font_scale = self._font_scale()
            self.design_box.objects = [self._scaled(self.design_panel)]

    def _font_scale(self):
        return PRESENTATION_SCALE if self.presentation else 1.0

    def _scaled(self, view):
        """The layout of a view built for a tab, its selects' and text boxes'
        widths at the page's scale before it goes into the page
        (`scale_widths`)."""
        layout = pn.panel(view)
        scale_widths(layout, self._font_scale(), self._widths)
        return layout

    def _on_intro(self, event):
        if not event.new and not self.intro.objects:
            self.intro.append(pn.pane.Markdown(INTRODUCTION, sizing_mode="stretch_width"))

    def __panel__(self):
        return pn.Row(self.controls(), self.main())


def explorer_template(explorer):
    """The page of `explorer`.  A template keeps the controls in their own
    root (a plain Row of controls and plots collapsed the trajectory plots)."""
    return pn.template.BootstrapTemplate(
        title="vibtrans: vibrational transport explorer",
        sidebar=[explorer.controls()],
        main=[explorer.main()],
        sidebar_width=SIDEBAR_WIDTH,
        design=ExplorerDesign,
    )


PAGE_TITLE = "vibtrans explorer"


def create_app():
    """One session's explorer page (a Panel template)."""
    return explorer_template(Explorer())


# each open page's explorer, by its document: where a failure in one of its
# callbacks is said (`report_failure`); forgotten when its session ends
# (`serve_page`)
_PAGES = weakref.WeakKeyDictionary()
FAILURE_TEXT = (
    "Something failed in the server while it answered the page (reference "
    "{reference}): what you did last may not have taken effect.  Reload the page "
    "to start again; the server's log names the cause under that reference."
)


def failure_reference():
    """A short reference that ties what a user sees to the server's log."""
    return uuid.uuid4().hex[:8]


def report_failure(exception):
    """Panel's exception handler (`pn.config.exception_handler`, set by the
    server): a callback that raised is logged with its traceback, and its
    page says so in its own words, with no traceback and no server path."""
    reference = failure_reference()
    log.error("a page's callback failed (reference %s)", reference, exc_info=exception)
    explorer = _PAGES.get(pn.state.curdoc) if pn.state.curdoc is not None else None
    if explorer is not None:
        explorer._error(FAILURE_TEXT.format(reference=reference))


def serve_page():
    """The server's page function: this session's page built into its
    document (`pn.state.curdoc`) by Panel's public `server_doc`.  The page's
    address is the explorer's own component (`_page_location`), embedded
    as the template's `location` root, where Panel's template embeds its
    Location: Panel's Location parses the browser's query in its own
    watcher and fails on some texts ('?la=²': '²'.isdigit() is true,
    int('²') raises; docs/how-to/deployment.md), so the served page has
    none.  Outside a served session (no address), Panel's default.
    Attached under one `Document.models.freeze()` (Bokeh's public context:
    the document's model graph recomputed once, not after each of the
    template's ~10 roots; ~20% of a page, `python -m devtools.pagecost`).
    Returns None: Panel then serves the document as built."""
    explorer = Explorer()
    doc = pn.state.curdoc
    _PAGES[doc] = explorer
    memory.explorer_built(explorer)
    # forgotten when the session ends, not when its document dies: the entry
    # would keep the explorer (its views, state and runs, ~9 MB) through the
    # release's collection that takes the document, frozen until the next
    pn.state.on_session_destroyed(lambda session_context: _PAGES.pop(doc, None))
    address = explorer.location
    with doc.models.freeze():
        explorer_template(explorer).server_doc(doc, title=PAGE_TITLE, location=address is None)
        if address is not None:
            # served by Panel, which forgets it when the session ends (a root
            # added by hand stayed in Panel's registry of views, and with it
            # the session's document); the template gave the page its extras
            before = {id(root) for root in doc.roots}
            with pn.config.set(browser_info=False, notifications=False):
                address.server_doc(doc, title=PAGE_TITLE, location=False)
            root = next(root for root in doc.roots if id(root) not in before)
            root.name = "location"  # the root the template embeds as the page's location


if pn.state.served:
    serve_page()
