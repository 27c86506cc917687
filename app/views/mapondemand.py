"""The map on demand's work in a session (out of the page
assembler, app/explorer.py): its request panel (views/ondemand.py, built
when its tab opens), the estimate, the request handed to the server's queue
(app/server/mapjobs.py) and its levels drawn on the map as they come, the banner
over the map, "refine this window" on a zoomed shipped map, a click on the
map on demand running its scene, and the way back to the shipped map."""

import asyncio
import functools
import logging
import time

import panel as pn

from vibtrans.core.errors import Cancelled
from vibtrans.core.params import ROLLING_NONE, inertia_ratio
from vibtrans.maps import accuracy as mapaccuracy
from vibtrans.maps.difference import describe
from vibtrans_explorer.server import data, mapjobs
from vibtrans_explorer.session import maprequest, urlstate
from vibtrans_explorer.session.latest import LatestJob
from vibtrans_explorer.session.state import SPHERE, is_sphere
from vibtrans_explorer.views.map import computed_figure
from vibtrans_explorer.views.ondemand import MapRequestPanel

log = logging.getLogger("vibtrans.explorer")

# "refine this window" is offered once the shipped map's zoom box spans
# fewer of its grid cells than this on both axes (beyond its resolution)
REFINE_BELOW_CELLS = 5
# a refinement of the shipped map: the coarse cells and levels of its request
REFINE_CELLS, REFINE_LEVELS = 2, 3
ONDEMAND_TAB = 3  # the map tabs' index of "Map on demand"
# a map on demand's values compared with the selected scene's
_NUMBERS, _WORDS = ("mu", "theta", "nu", "tau", "periods"), ("model", "fidelity", "integrator")


def progress_text(update, n, seconds, cached, finished):
    """The line of an n x n map computing, at an update with its data
    (mapjobs: "level", "chunk" or "done"): the level drawn or computing,
    or once done `cached` or `finished` (str.format of `done`, `total`
    and `seconds`)."""
    done, total = int(update.ds["computed"].values.sum()), n * n
    if update.kind == "done":
        return (cached if update.cached else finished).format(done=done, total=total, seconds=seconds)
    step, so_far = ("drawn", "") if update.kind == "level" else ("computing", " so far")
    return (
        f"Level {update.level} of {update.levels} {step}: {done:,} of {total:,} points computed"
        f"{so_far}, {seconds:.0f} s{update.left_text()} ..."
    )


class MapOnDemand:
    """A session's map on demand.  state: its ExplorerState; map_view: its
    MapView (set before use); answered(): clear the browser's
    acknowledgement; run(): run the state's scene.  `map_tabs` (the map's
    tabs, set by the page) is shown the map tab when a map starts."""

    def __init__(self, state, answered, run, session):
        self.state = state
        self.answered, self.run = answered, run
        self.map_view = None
        self.map_tabs = None
        # its request panel (built when its tab opens), the request shown,
        # its Ticket while it computes (app/server/mapjobs.py)
        self.map_request_panel = None
        self.ondemand_box = pn.Column(sizing_mode="stretch_width", name="ondemand")
        self.session = session  # its key in the server's map queue
        # the map computing (its Ticket in the server's queue: cancelling its
        # job cancels the session's request there) and the request's
        # estimate; the latest of each wins
        self.map_work = LatestJob()
        self.estimates = LatestJob()
        self._map_shown = None  # (request, ds) of the map on demand drawn
        # the line over the map and the refinement's offer: their widgets
        # made at their first use (most pages never show them)
        self.map_status = self.back_button = self.map_cancel_button = None
        self.map_banner = pn.Row(visible=False, sizing_mode="stretch_width")
        self.refine_button = None
        self.refine_box = pn.Column(visible=False, sizing_mode="stretch_width", margin=0)
        # over the map: the map shown is not of the particle selected (the
        # shipped maps are of a sphere that does not roll); its button made
        # at first use
        self.profile_note = pn.pane.Alert(
            "", alert_type="warning", margin=0, sizing_mode="stretch_width", css_classes=["vt-map-profile"]
        )
        self.profile_button = None
        self.profile_box = pn.Column(
            self.profile_note, visible=False, margin=(0, 10), sizing_mode="stretch_width"
        )
        state.param.watch(
            self.on_profile, ["profile", "rolling", "log_amplitude", "log_mass", *_NUMBERS, *_WORDS]
        )

    def close(self):
        """The session closed: its map stops unless another session waits."""
        mapjobs.jobs().cancel(self.session)

    def request_panel(self):
        """The request's panel, built at its first use (most sessions never
        open it), its values those of the map shown."""
        if self.map_request_panel is None:
            panel = MapRequestPanel(
                self._map_shown[0].copy() if self._map_shown else self.shipped_request(),
                on_compute=self._on_map_compute,
                on_cancel=self._on_map_cancel,
                on_zoom=self._on_use_zoom,
                on_change=self._estimate_later,
            )
            self.map_request_panel = panel
            self.ondemand_box.objects = [panel]
            self._buttons_for_map()
            self._estimate_later()
        return self.map_request_panel

    def shipped_request(self, window=None):
        """A request with the shipped map's values (its stored scene) and
        the selected particle (its profile, whether it rolls), over
        `window` (the selected scene's neighbourhood if None)."""
        s = self.state
        try:
            attrs = data.drift_map(s.model, s.mu).attrs
        except data.MapUnavailable:
            attrs = {}
        scene = {
            k: attrs[f"scene_{k}"]
            for k in ("tau", "periods", "fidelity", "integrator", "theta", "nu", "stick_rule", "alpha_t")
            if f"scene_{k}" in attrs
        }
        if window is None:
            la, lm = s.log_amplitude, s.log_mass
            window = ((round(la - 0.5, 3), round(la + 0.5, 3)), (round(lm - 0.5, 3), round(lm + 0.5, 3)))
        (a0, a1), (m0, m1) = window
        request = maprequest.MapRequest(
            model=s.model,
            mu=s.mu,
            cells=REFINE_CELLS,
            levels=REFINE_LEVELS,
            profile=s.profile,
            rolling=s.rolling,
        )
        values = {**scene, "la_from": a0, "la_to": a1, "lm_from": m0, "lm_to": m1}
        for name, value in values.items():  # out of the request's ranges: its default
            try:
                setattr(
                    request,
                    name,
                    float(value) if name in ("tau", "periods", "theta", "nu", "alpha_t") else value,
                )
            except ValueError:
                pass
        return request

    def _estimate_later(self):
        pn.state.execute(self._estimate_map)

    async def _estimate_map(self):
        """The request's estimated cost (or why it is refused), computed off
        the event loop; an older estimate finishing later is dropped."""
        panel = self.map_request_panel
        if panel is None:
            return
        job = self.estimates.start()
        if panel.errors():
            panel.estimate.object = "*Correct the fields above for an estimate.*"
            return
        request = panel.request.copy()
        panel.estimate.object = "*Estimating ...*"
        jobs = mapjobs.jobs()
        try:
            est, problems = await job.run(jobs.estimate, request)
        except Cancelled:
            return  # an older estimate: a newer one was asked for
        except Exception as exc:
            log.exception("estimating a map failed")
            est, problems = None, [f"{type(exc).__name__}: {urlstate.literal(exc)}"]
        if not self.estimates.is_latest(job):
            return
        lines = [] if est is None else [est.text(jobs.cores)]
        lines.append(mapaccuracy.note(request.fidelity, request.periods))
        lines += [f"**Refused:** {urlstate.literal(p)}." for p in problems]
        panel.estimate.object = "\n\n".join(lines)

    def _on_use_zoom(self):
        (a0, a1), (m0, m1) = self.map_view.view_ranges()
        if None in (a0, a1, m0, m1):
            return
        self.request_panel().set_values(
            la_from=round(a0, 3), la_to=round(a1, 3), lm_from=round(m0, 3), lm_to=round(m1, 3)
        )

    def on_zoom(self, ranges):
        """Offer "refine this window" once the shipped map is zoomed beyond
        its resolution (fewer than REFINE_BELOW_CELLS cells each way)."""
        small = False
        if self.map_view.computed is None and None not in (*ranges[0], *ranges[1]):
            try:
                ds = data.drift_map(self.state.model, self.state.mu)
            except data.MapUnavailable:
                ds = None
            if ds is not None:
                grids = (ds["log_amplitude"].values, ds["log_mass"].values)
                small = all(
                    abs(b - a) < REFINE_BELOW_CELLS * (g[1] - g[0]) for (a, b), g in zip(ranges, grids)
                )
        if small and self.refine_button is None:
            self.refine_button = pn.widgets.Button(
                label="Refine this window (compute it finer)", color="success", css_classes=["vt-map-refine"]
            )
            self.refine_button.on_click(lambda event: self.refine_window())
            self.refine_box.objects = [self.refine_button]
        self.refine_box.visible = bool(small)

    def refine_window(self):
        """Fill the request with the shipped map's values and the zoom box,
        and show it (its estimate beside it) for the user to compute."""
        (a0, a1), (m0, m1) = self.map_view.view_ranges()
        window = ((round(a0, 3), round(a1, 3)), (round(m0, 3), round(m1, 3)))
        self._show_request(self.shipped_request(window))

    def _on_map_compute(self):
        panel = self.map_request_panel
        if panel.errors():
            panel.status.object = "**Not computed:** " + " · ".join(panel.errors())
            return
        pn.state.execute(functools.partial(self.compute_map, panel.request.copy()))

    def _on_map_cancel(self):
        if not self.map_work.running:
            return
        self.map_work.cancel()
        self._map_say(
            "Map cancelled: its finished points are kept on this server; "
            "computing it again resumes from them."
        )
        self._buttons_for_map()

    def _show_banner(self):
        if self.map_status is None:
            self.map_status = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-map-banner"])
            self.back_button = pn.widgets.Button(
                label="Back to the shipped map", css_classes=["vt-map-back", "vt-ack-draw"]
            )
            self.back_button.on_click(lambda event: self.back_to_shipped())
            self.map_cancel_button = pn.widgets.Button(
                label="Cancel map", color="warning", css_classes=["vt-map-cancel-banner"]
            )
            self.map_cancel_button.on_click(lambda event: self._on_map_cancel())
            self.map_banner.objects = [self.map_status, self.map_cancel_button, self.back_button]
        self.map_banner.visible = True

    def _map_say(self, text):
        self._show_banner()
        self.map_status.object = text
        if self.map_request_panel is not None:
            self.map_request_panel.status.object = text

    def _buttons_for_map(self):
        running = self.map_work.running
        if self.map_cancel_button is not None:
            self.map_cancel_button.visible = running
        if self.map_request_panel is not None:
            self.map_request_panel.cancel_button.disabled = not running
            self.map_request_panel.compute_button.disabled = running

    async def compute_map(self, request):
        """Ask the server's queue for the map and draw what it says, level
        by level, until it ends (or another request replaces it)."""
        jobs = mapjobs.jobs()
        loop = asyncio.get_running_loop()
        self._map_say("Estimating the map's cost ...")
        try:
            est, problems = await loop.run_in_executor(None, jobs.estimate, request)
        except Exception as exc:
            log.exception("estimating a map failed")
            est, problems = None, [f"{type(exc).__name__}: {urlstate.literal(exc)}"]
        if problems:
            text = "" if est is None else est.text(jobs.cores) + " "
            self._map_say(f"**Not computed:** {urlstate.literal('; '.join(problems))}. {text}")
            return
        updates = asyncio.Queue()

        def deliver(update):  # a worker thread: hand it to this loop
            loop.call_soon_threadsafe(updates.put_nowait, update)

        job = self.map_work.start()  # (a map computing before: no one's now)
        try:
            jobs.submit(self.session, request, deliver)
        except mapjobs.MapRefused as exc:
            self.map_work.finish(job)
            self._map_say(f"**Not computed:** {urlstate.literal(exc)}.")
            self._buttons_for_map()
            return
        job.when_cancelled(functools.partial(jobs.cancel, self.session))
        self.state.map_request = maprequest.encode(request)
        self._buttons_for_map()
        if self.map_tabs is not None:
            self.map_tabs.active = 0
        started = time.monotonic()
        n = request.points_per_axis()
        self._map_say(
            f"Computing a {n} x {n} map ({request.title()}), about "
            f"{maprequest.duration(est.seconds)} expected ..."
        )
        while True:
            # every level is drawn (at most levels + 1 of them): each shows
            # where the refinement went
            update = await updates.get()
            if not self.map_work.is_latest(job):
                return  # cancelled or replaced: its updates are no one's
            if update.kind == "chunk" and not updates.empty():
                continue  # a newer picture (or the level's) is waiting: draw that
            if update.kind == "queued":
                self._map_say(f"{update.text.capitalize()} ...")
            elif update.kind in ("level", "chunk", "done"):
                if update.shown:
                    # the finest level, drawn already, is the verified map:
                    # no second render (nor redraw in the browser) of it
                    self._map_shown = (request, update.ds)
                else:
                    await self._draw_map(request, update.ds)
                if not self.map_work.is_latest(job):
                    return
                self._map_say(
                    progress_text(
                        update,
                        n,
                        time.monotonic() - started,
                        "Map from this server's cache ({done:,} of {total:,} points computed): "
                        "click it to run a scene there.",
                        "Map finished: {done:,} of {total:,} points computed in {seconds:.0f} s. "
                        "Click it to run a scene there.",
                    )
                )
            elif update.kind == "failed":
                self._map_say(f"**The map failed:** {update.text}")
            elif update.kind == "cancelled":
                self._map_say("Map cancelled.")
            if update.final:
                self.map_work.finish(job)
                self._buttons_for_map()
                return

    async def _draw_map(self, request, ds):
        """Render the map off the event loop, then show it."""
        s = self.state
        title = (
            f"map on demand: {request.model}, mu = {request.mu:g}\nstop: {request.stop}"
            + (f", profile {request.profile}" if request.profiled() else "")
            + (f", rolling {rolling_name(request.rolling)}" if request.rolls() else "")
        )
        window = ((request.la_from, request.la_to), (request.lm_from, request.lm_to))
        try:
            fig = await asyncio.get_running_loop().run_in_executor(
                None, computed_figure, ds, title, request.model, window, s.v0, s.chaotic
            )
        except Exception as exc:
            log.exception("drawing a map on demand failed")
            self._map_say(f"**Drawing the map failed:** {type(exc).__name__}: {urlstate.literal(exc)}")
            return
        if self.state.map_request != maprequest.encode(request):
            return  # the shipped map came back meanwhile
        self._map_shown = (request, ds)
        with pn.io.hold():
            self.map_view.show_computed(fig, window, functools.partial(self._on_computed_click, request))
            self.refine_box.visible = False
            self._show_banner()
            self.on_profile()
            self.answered()

    def computed_map(self):
        """(name, Dataset) of the map on demand shown, or None (the shipped map)."""
        if self.map_view.computed is None or self._map_shown is None:
            return None
        return describe(self._map_shown[1]), self._map_shown[1]

    def on_map_look(self, *events):
        """v0* or the chaotic points' colour changed: the map on demand too."""
        if self.map_view.computed is not None and self._map_shown is not None:
            pn.state.execute(functools.partial(self._draw_map, *self._map_shown))

    def _on_computed_click(self, request, la, lm):
        """A click on the map on demand: the scene there, with the map's
        values (its particle's profile and rolling among them)."""
        values = request.scene_values()
        if request.model != "point-mass":
            values["profile"] = request.profile  # the map's particle (a sphere's too)
        with pn.io.hold():
            self.state.param.update(log_amplitude=la, log_mass=lm, **values)
        self.run()

    def back_to_shipped(self):
        """The shipped map again: at the map on demand's mu if a shipped map
        has it, else at the default mu (the state's: every view follows)."""
        if self.map_work.running:
            self._on_map_cancel()
        self._map_shown = None
        self.map_banner.visible = False
        with pn.io.hold():
            s = self.state
            mus = sorted(mu for (m, mu) in data.available_maps() if m == s.model)
            updates = {"map_request": None}
            if mus and s.mu not in mus:
                updates["mu"] = urlstate.DEFAULT_MU if urlstate.DEFAULT_MU in mus else mus[0]
            s.param.update(**updates)
            self.map_view.show_shipped()
            self.on_profile()
            self.answered()

    # ---------- the particle: its profile, whether it rolls ----------
    def shown_particle(self):
        """(profile, rolling) of the map shown: the map on demand's, else
        the shipped maps' (a sphere that does not roll)."""
        if self._map_shown is not None and self.map_view is not None and self.map_view.computed is not None:
            request = self._map_shown[0]
            return request.profile, request.rolling
        return SPHERE, ROLLING_NONE

    def on_profile(self, *events):
        """Say over the map when it is not of the particle selected: the
        shipped maps are of a sphere that does not roll, so a cone's scene,
        or a rolling sphere's, is never shown on them as if they were its
        own; a button asks for its map on demand.  The material point is
        rigid and has no size: any map of it is its own."""
        s = self.state
        profile, rolling = self.shown_particle()
        point = s.model == "point-mass"
        same_profile = point or s.profile == profile or (is_sphere(s.profile) and is_sphere(profile))
        same_rolling = point or inertia_ratio(s.rolling) == inertia_ratio(rolling)
        shipped = self.map_view is None or self.map_view.computed is None
        where = "the shipped maps are" if shipped else "this map on demand is"
        notes, wanted = [], []
        if not same_profile:
            notes.append(
                f"**This map is the {_particle(profile)}'s** ({where}), not the selected "
                f"{_particle(s.profile)}'s: its colours do not say what the "
                f"{_particle(s.profile)} does. A click on it runs the {_particle(s.profile)} "
                f"there. Request a map on demand for {s.profile} to see its own."
            )
            wanted.append(s.profile)
        if not same_rolling:
            notes.append(
                f"**This map is of a {rolling_phrase(rolling)}** ({where}), not of the selected "
                f"{rolling_phrase(s.rolling)}: its colours do not say where that particle "
                f"drifts. A click on it runs the selected particle there, rolling. Request a "
                f"map on demand for rolling {rolling_name(s.rolling)} to see its own."
            )
            wanted.append(f"rolling {rolling_name(s.rolling)}")
        request = None if shipped or self._map_shown is None else self._map_shown[0]
        if request is not None:
            differs = [
                f"{name} {getattr(request, name):g} (selected: {getattr(s, name):g})"
                for name in _NUMBERS
                if getattr(request, name) != getattr(s, name)
            ]
            differs += [
                f"{name} {getattr(request, name)} (selected: {getattr(s, name)})"
                for name in _WORDS
                if getattr(request, name) != getattr(s, name)
            ]
            if differs:
                notes.append(
                    f"**This map on demand is of another scene**: {'; '.join(differs)}. "
                    f"Its colours do not say what the selected scene does; "
                    f"*Back to the shipped map* shows the shipped one."
                )
            inside = (
                request.la_from <= s.log_amplitude <= request.la_to
                and request.lm_from <= s.log_mass <= request.lm_to
            )
            if not inside:
                notes.append(
                    f"**The selected scene (log10 A\\* = {s.log_amplitude:.4g}, "
                    f"log10 m\\* = {s.log_mass:.4g}) lies off this map on demand** "
                    f"(log10 A\\* {request.la_from:g} to {request.la_to:g}, log10 m\\* "
                    f"{request.lm_from:g} to {request.lm_to:g})."
                )
        shipped_mus = sorted(mu for model, mu in data.available_maps() if model == s.model)
        if shipped and s.mu not in shipped_mus:
            listed = ", ".join(f"{mu:g}" for mu in shipped_mus) or "none"
            notes.append(
                f"**No shipped map has mu = {s.mu:g}** (the {s.model} maps shipped: mu = "
                f"{listed}). Pick one of those, or request a map on demand for mu = "
                f"{s.mu:g}: it is computed here, with its progress shown."
            )
            wanted.append(f"mu {s.mu:g}")
        if notes:
            self.profile_note.object = "\n\n".join(notes)
            if self.profile_button is None:
                self.profile_button = pn.widgets.Button(
                    label="", color="primary", css_classes=["vt-map-profile-request"]
                )
                self.profile_button.on_click(lambda event: self.request_for_profile())
                self.profile_box.append(self.profile_button)
            self.profile_button.label = f"Map on demand for {', '.join(wanted)}"
            self.profile_button.visible = bool(wanted)
        self.profile_box.visible = bool(notes)

    def request_for_profile(self):
        """Fill the request with the shipped map's values, the selected
        particle (profile, rolling) and the selected scene's neighbourhood,
        and show it (its estimate beside it) for the user to compute."""
        self._show_request(self.shipped_request())

    def _show_request(self, request):
        """The request panel filled with `request`'s values, its tab shown."""
        self.request_panel().set_values(**request.values())
        if self.map_tabs is not None:
            self.map_tabs.active = ONDEMAND_TAB


def _particle(profile):
    """A profile in words: "sphere", "cone", "power:3 tip", "flat-sphere:0.5 tip"."""
    return "sphere" if is_sphere(profile) else profile if profile == "cone" else f"{profile} tip"


def rolling_name(rolling):
    """A rolling value as a word: its name, or its number j."""
    return rolling if isinstance(rolling, str) else f"{rolling:g}"


def rolling_phrase(rolling):
    """Whether a particle rolls, in words: "particle that does not roll",
    "solid sphere that rolls (j = 2/5)", "particle that rolls with j = 0.5"."""
    if rolling == ROLLING_NONE:
        return "particle that does not roll"
    if rolling == "solid":
        return "solid sphere that rolls (j = 2/5)"
    if rolling == "shell":
        return "thin shell that rolls (j = 2/3)"
    return f"particle that rolls with j = {rolling_name(rolling)}"
