"""The vibtrans explorer: a drift map over (log10 A*, log10 m*) with
on-demand trajectories.  Layout, widgets and callbacks only: physics comes
from `vibtrans`, figures from `vibtrans.plots`.

Serve with `vibtrans serve` (warms the JIT and loads the maps first) or
`panel serve app/explorer.py`.
"""
import asyncio
import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor

import holoviews as hv
import numpy as np
import panel as pn
import param
from holoviews.operation.downsample import downsample1d

from vibtrans import Cancelled, Scene, estimate_steps, plots, simulate, units
from vibtrans.analysis import summarize
from vibtrans.params import PAPER_POINTS
from vibtrans.simulate import memory_snapshot

from . import data

hv.extension("bokeh")

# One pool for the process: numba kernels release the GIL, so runs proceed
# while the server keeps serving other sessions.
RUNNER = ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2),
                            thread_name_prefix="vibtrans-run")
MAX_STEPS = int(float(os.environ.get("VIBTRANS_MAX_STEPS", 5e7)))
OVERVIEW_SAMPLES = 5          # samples per period in the whole-run view
OVERVIEW_BINS = 400           # time bins of the whole-run state timeline
PLOT_WIDTH = 900
FRAGMENT = 2.0                # periods at full resolution at the end of the run

POINT_LABELS = {
    1: "permanent contact, drift against the wave",
    2: "permanent contact, drift with the wave",
    3: "permanent contact, no drift",
    4: "synchronous hopping (hovering)",
    5: "multi-synchronous hopping",
    6: "long contact + jump, uniform drift",
    7: "long contact + jump, slow acceleration",
    8: "chaotic hopping",
    9: "point mass: symmetric sliding",
    10: "point mass: chaotic hopping",
}


class ExplorerState(param.Parameterized):
    """What the user selected; mirrored in the URL."""

    model = param.Selector(default="deformable", objects=["deformable", "point-mass"])
    mu = param.Number(default=0.3, bounds=(0.01, 1.0))
    v0 = param.Number(default=0.1, bounds=(1e-3, 10.0), doc="white band |v*| <= v0*")
    log_amplitude = param.Number(default=-0.3, bounds=(-3.0, 3.0))
    log_mass = param.Number(default=1.0, bounds=(-5.0, 5.0))
    fidelity = param.Selector(default="standard", objects=["preview", "standard", "reference"])
    integrator = param.Selector(default="ab4", objects=["ab4", "verlet"])
    compare = param.Selector(default="tau twin", objects=["none", "tau twin", "point mass"])
    chaotic = param.Selector(default="grey", objects=["grey", "colour"])


URL_KEYS = {"model": "model", "mu": "mu", "v0": "v0", "log_amplitude": "la",
            "log_mass": "lm", "fidelity": "fidelity", "integrator": "integrator",
            "compare": "compare"}


class Explorer(pn.viewable.Viewer):
    def __init__(self, **params):
        super().__init__(**params)
        self.state = ExplorerState()
        self._cancel = None
        self.message = pn.pane.Alert("", alert_type="danger", visible=False,
                                     sizing_mode="stretch_width")
        self.progress = pn.indicators.Progress(value=0, max=100, visible=False,
                                               sizing_mode="stretch_width", name="progress")
        self.cancel_button = pn.widgets.Button(name="Cancel", button_type="warning",
                                               disabled=True)
        self.cancel_button.on_click(self._on_cancel)
        self.run_button = pn.widgets.Button(name="Run selected scene", button_type="primary")
        self.run_button.on_click(self._on_run_click)
        self.point_select = pn.widgets.Select(
            name="Paper points", options={"-": 0, **{f"{k}: {v}": k for k, v in POINT_LABELS.items()}})
        self.point_select.param.watch(self._on_point, "value")
        self.summary = pn.pane.Markdown("Click the map or pick a paper point.",
                                        width=PLOT_WIDTH, name="summary")
        self.trajectory = pn.Column(name="trajectory")
        self.units_panel = UnitsPanel(self)
        self._last = None
        self.teaching = self._teaching()
        self.exports = self._exports()
        self._apply_url()
        self.map_pane = pn.pane.HoloViews(self._map_dmap(), name="map", linked_axes=False)
        self.tap.param.watch(self._on_tap, ["x", "y"])

    # ---------- URL ----------
    def _apply_url(self):
        if pn.state.location is None:
            return
        args = pn.state.session_args or {}
        errors = []
        for name, key in URL_KEYS.items():
            if key not in args:
                continue
            raw = args[key][0].decode(errors="replace")
            try:
                value = raw if isinstance(self.state.param[name], param.Selector) else float(raw)
                if isinstance(value, float) and not math.isfinite(value):
                    raise ValueError
                setattr(self.state, name, value)
            except Exception:
                p = self.state.param[name]
                rng = (f"one of {', '.join(map(str, p.objects))}" if isinstance(p, param.Selector)
                       else f"a number in [{p.bounds[0]}, {p.bounds[1]}]")
                errors.append(f"URL parameter '{key}' ({name}) must be {rng}; got '{raw}'")
        if (self.state.model, self.state.mu) not in data.available_maps():
            errors.append(f"no shipped map for model={self.state.model}, mu={self.state.mu:g}; "
                          f"showing mu = 0.3")
            self.state.mu = 0.3
        if errors:
            self._error(" · ".join(errors) + " — using the defaults for those.")
        pn.state.location.sync(self.state, URL_KEYS)

    def _error(self, text):
        self.message.object = text
        self.message.visible = bool(text)

    # ---------- map ----------
    def _map_dmap(self):
        vertical = data.vertical_curve()

        @pn.depends(self.state.param.model, self.state.param.mu, self.state.param.v0,
                    self.state.param.chaotic)
        def heatmap(model, mu, v0, chaotic):
            ds = data.drift_map(model, mu)
            el = plots.drift_map(ds, v0=v0, chaotic=chaotic,
                                 title=f"{model}, mu = {mu:g}")
            if vertical is not None:
                el = el * plots.jumping_boundary(vertical, model).select(
                    log_amplitude=(-3.0, 3.0))
                if model == "deformable":
                    el = el * plots.resonance_lines(vertical)
            el = el * plots.paper_points(model)
            return el.opts(hv.opts.Image(tools=["hover"], width=PLOT_WIDTH, height=460,
                                         title=f"<v*> over 2000 periods: {model}, mu = {mu:g}"))

        @pn.depends(self.state.param.log_amplitude, self.state.param.log_mass,
                    self.units_panel.param.marker)
        def marker(log_amplitude, log_mass, marker, x=None, y=None):
            units_marker = marker
            sel = hv.Points([(log_amplitude, log_mass)], [plots.LOG_A, plots.LOG_M]).opts(
                color="yellow", size=14, marker="circle", line_color="black")
            if units_marker is not None:
                sel = sel * hv.Points([units_marker], [plots.LOG_A, plots.LOG_M]).opts(
                    color="lime", size=14, marker="diamond", line_color="black")
            return sel

        # The Tap stream lives on the marker layer: a stream bound to a
        # DynamicMap of overlays via `source` is not linked to the plot.
        self.tap = hv.streams.Tap(x=None, y=None)
        return hv.DynamicMap(heatmap) * hv.DynamicMap(marker, streams=[self.tap])

    def _on_tap(self, *events):
        x, y = self.tap.x, self.tap.y
        if x is None or y is None:
            return
        self.state.param.update(log_amplitude=float(np.clip(round(x, 3), -3, 3)),
                                log_mass=float(np.clip(round(y, 3), -5, 5)))
        pn.state.execute(self._run)

    def _on_point(self, event):
        k = event.new
        if not k:
            return
        la, lm, model = PAPER_POINTS[k]
        self.state.param.update(model=model, log_amplitude=la, log_mass=lm,
                                mu=0.3 if (model, self.state.mu) not in data.available_maps()
                                else self.state.mu)
        pn.state.execute(self._run)

    def _on_run_click(self, event):
        pn.state.execute(self._run)

    def _on_cancel(self, event):
        if self._cancel is not None:
            self._cancel.set()

    # ---------- runs ----------
    def scene(self):
        s = self.state
        return Scene(amplitude=10 ** s.log_amplitude, mass=10 ** s.log_mass, mu=s.mu,
                     model=s.model, fidelity=s.fidelity, integrator=s.integrator)

    async def _run(self):
        if self._cancel is not None:          # one run per session at a time
            self._cancel.set()
        try:
            scene = self.scene()
            steps = estimate_steps(scene)
        except ValueError as exc:
            self._error(str(exc))
            return
        if steps > MAX_STEPS:
            self._error(f"This scene needs about {steps:.2g} steps, over this server's limit "
                        f"of {MAX_STEPS:.2g}: lower the fidelity or choose another point.")
            return
        self._error("")
        cancel = threading.Event()
        self._cancel = cancel
        done = [0.0]
        self.progress.value, self.progress.visible = 0, True
        self.cancel_button.disabled = False
        self.summary.object = f"Running {scene.model} at A* = {scene.amplitude:.4g}, " \
                              f"m* = {scene.mass:.4g} ..."
        T = scene.periods

        # The comparison run goes in parallel with the main one (the kernels
        # release the GIL); a tau twin that turns out unneeded (no jump) is
        # simply not shown.
        other_scene = None
        if self.state.compare == "tau twin":
            other_scene = scene.replace(tau=scene.tau + 1e-3)
        elif self.state.compare == "point mass" and scene.model == "deformable":
            other_scene = scene.replace(model="point-mass")
        main = RUNNER.submit(simulate, scene, window=(T - FRAGMENT, T),
                             samples_per_period=OVERVIEW_SAMPLES,
                             progress=lambda f: done.__setitem__(0, f), cancel=cancel,
                             max_steps=MAX_STEPS)
        second = None if other_scene is None else RUNNER.submit(
            simulate, other_scene, samples_per_period=OVERVIEW_SAMPLES, cancel=cancel,
            max_steps=MAX_STEPS)
        try:
            while not (main.done() and (second is None or second.done())):
                self.progress.value = int(100 * done[0])
                await asyncio.sleep(0.05)
            ds = main.result()
            other = None if second is None else second.result()
            if other is not None and self.state.compare == "tau twin" \
                    and not (ds["event_kind"].values == 0).any():
                other = None
        except Cancelled:
            self.summary.object = "Run cancelled."
            return
        except Exception as exc:          # a failed run harms only this session
            self._error(f"The run failed: {exc}")
            self.summary.object = ""
            return
        finally:
            self.progress.visible = False
            self.cancel_button.disabled = True
            if self._cancel is cancel:
                self._cancel = None
        self._show(scene, ds, other)

    def _show(self, scene, ds, other):
        twin = other if (other is not None and other.attrs["model"] == scene.model) else None
        s = summarize(ds, twin)
        self.units_panel.last_drift = s.drift_velocity
        si = self.units_panel.si_text(s.drift_velocity)
        chaos = {None: "not checked", True: "chaotic (tau + 1e-3 twin disagrees)",
                 False: "robust (tau + 1e-3 twin agrees)"}[s.chaotic]
        self.summary.object = "\n".join([
            f"**{scene.model}: A\\* = {scene.amplitude:.4g}, m\\* = {scene.mass:.4g}, "
            f"mu = {scene.mu:g}**", "",
            "| quantity | value |", "|---|---|",
            f"| drift <v*> (mean over the run) | **{s.drift_velocity:.4g}** |",
            f"| drift, final 10% | {s.final_drift_velocity:.4g} |",
            f"| regime | {s.contact}, {s.drift}{', ' + s.pattern if s.pattern else ''} |",
            f"| chaos verdict | {chaos} |",
            f"| take-offs | {s.takeoffs} ({s.takeoffs_per_period:.3g} per period at the end) |",
            f"| contact fraction (final 10%) | {s.contact_fraction:.3f} |",
            f"| cost | {s.steps:,} steps, {s.seconds:.3f} s ({scene.fidelity}, {scene.integrator}) |",
        ] + ([f"| in SI units | {si} |"] if si else []))
        self._last = (scene, ds, twin)
        T = float(ds["time"].values[-1])
        frag = ds.sel(time=slice(T - FRAGMENT, T))
        # The whole run: curves min-max/LTTB-downsampled to the plot's width
        # (re-sampled on zoom), the state timeline as the dominant state per
        # bin; the fragment below is exact.
        overview = plots.trajectory_panels(ds, timeline_bins=OVERVIEW_BINS)
        if other is not None:
            label = "tau + 1e-3" if twin is not None else "point mass"
            overview = overview + plots.twin_comparison(ds, other, label=label)
        overview = downsample1d(overview, width=PLOT_WIDTH)
        opts = [hv.opts.Curve(width=PLOT_WIDTH, height=190, tools=["hover"]),
                hv.opts.Overlay(width=PLOT_WIDTH, height=190, legend_position="right"),
                hv.opts.Rectangles(width=PLOT_WIDTH, height=90, tools=["hover"])]
        self.trajectory[:] = [
            pn.pane.Markdown("**Whole run** (linked, zoomable time axis)"),
            pn.pane.HoloViews(overview.opts(*opts).cols(1), linked_axes=False),
            pn.pane.Markdown(f"**Last {FRAGMENT:g} periods at full resolution**"),
            pn.pane.HoloViews(plots.trajectory_panels(frag).opts(*opts).cols(1),
                              linked_axes=False),
            self.teaching if scene.model == "deformable" else pn.pane.Markdown(""),
            self.exports,
        ]
        self.memory_time.param.update(start=0.0, end=T, value=round(T - 0.5, 3))
        self.memory_pane.object = None

    # ---------- teaching views ----------
    def _teaching(self):
        self.memory_time = pn.widgets.FloatInput(name="time t* (periods)", value=1999.5,
                                                 start=0.0, end=2000.0, step=0.05, width=200)
        go = pn.widgets.Button(name="Show the memory diagram at t*", button_type="primary")
        go.on_click(lambda e: pn.state.execute(self._show_memory))
        self.memory_pane = pn.pane.HoloViews(None, linked_axes=False)
        return pn.Column(
            pn.pane.Markdown("**Memory diagram and contact circle** (Cattaneo-Mindlin with "
                             "history): the anchors w(h) of the springs over the contact "
                             "depth, their displacements u(h) with the Coulomb cone, and the "
                             "stick core inside the slip annulus."),
            pn.Row(self.memory_time, go), self.memory_pane)

    async def _show_memory(self):
        if self._last is None:
            return
        scene = self._last[0]
        t = float(self.memory_time.value)
        try:
            snap = await asyncio.wrap_future(RUNNER.submit(memory_snapshot, scene, t))
        except ValueError as exc:
            self._error(str(exc))
            return
        fig = plots.memory_diagram(snap) + plots.contact_circle(snap)
        self.memory_pane.object = fig.opts(
            hv.opts.Curve(width=380, height=300), hv.opts.Overlay(width=380, height=300))

    # ---------- export ----------
    def _exports(self):
        def download(kind, fmt):
            def callback():
                import tempfile

                from vibtrans import export
                out = os.path.join(tempfile.mkdtemp(prefix="vibtrans-"), f"{kind}.{fmt}")
                if kind == "map":
                    export.export_heatmap(data.drift_map(self.state.model, self.state.mu), out,
                                          v0=self.state.v0, vertical=data.vertical_curve())
                elif self._last is not None:
                    scene, ds, twin = self._last
                    export.export_trajectory(ds, out, twin=twin)
                return out
            return pn.widgets.FileDownload(callback=callback, filename=f"vibtrans-{kind}.{fmt}",
                                           label=f"{kind} .{fmt}", button_type="light",
                                           css_classes=[f"vt-export-{kind}-{fmt}"], width=150)
        return pn.Column(pn.pane.Markdown("**Export** (same figures as `vibtrans export`)"),
                         pn.Row(*(download(k, f) for k in ("map", "trajectory")
                                  for f in ("png", "svg", "html"))))

    # ---------- layout ----------
    def vertical_view(self):
        vertical = data.vertical_curve()
        if vertical is None:
            return pn.pane.Markdown("The vertical curve is not shipped.")
        lm = vertical["log_mass"].values
        de = hv.Curve((lm, np.log10(vertical["threshold_amplitude"].values)),
                      plots.LOG_M, plots.LOG_A, label="deformable (Hertz)")
        pm = hv.Curve((lm, np.log10(vertical["point_mass_threshold_amplitude"].values)),
                      plots.LOG_M, plots.LOG_A, label="material point").opts(line_dash="dashed")
        lines = [hv.VLine(vertical.attrs[k]).opts(color="grey", line_dash="dotted")
                 for k in vertical.attrs if k.startswith("resonance_") and k.endswith("log_mass")]
        return pn.pane.HoloViews(hv.Overlay([de, pm, *lines]).opts(
            responsive=True, min_height=450, title="Jumping threshold A_J*(m*)",
            legend_position="top_right"), sizing_mode="stretch_width", name="vertical")

    def controls(self):
        s = self.state
        return pn.Column(
            pn.widgets.RadioButtonGroup.from_param(s.param.model, name="model"),
            pn.widgets.Select.from_param(s.param.mu, options=sorted(
                {mu for (m, mu) in data.available_maps()}), name="mu (shipped maps)"),
            pn.widgets.FloatSlider.from_param(s.param.v0, start=0.001, end=10, step=0.01,
                                              name="v0* (white band)"),
            pn.widgets.RadioButtonGroup.from_param(s.param.chaotic, name="chaotic points"),
            self.point_select,
            pn.widgets.FloatInput.from_param(s.param.log_amplitude, name="log10 A*", step=0.05),
            pn.widgets.FloatInput.from_param(s.param.log_mass, name="log10 m*", step=0.05),
            pn.widgets.Select.from_param(s.param.fidelity, name="fidelity"),
            pn.widgets.Select.from_param(s.param.integrator, name="integrator"),
            pn.widgets.Select.from_param(s.param.compare, name="compare with"),
            pn.Row(self.run_button, self.cancel_button),
            self.progress,
        )

    def main(self):
        tabs = pn.Tabs(
            ("Map", self.map_pane),
            ("Vertical", self.vertical_view()),
            ("Units", self.units_panel),
            dynamic=True,
        )
        return pn.Column(self.message, tabs, self.summary, self.trajectory)

    def __panel__(self):
        return pn.Row(self.controls(), self.main())


class UnitsPanel(pn.viewable.Viewer):
    """SI inputs -> (A*, m*) marker on the map, a0, c_R, drift in m/s."""

    substrate = param.Selector(default="glass", objects=sorted(units.MATERIALS))
    particle = param.Selector(default="steel", objects=sorted(units.MATERIALS))
    radius_mm = param.Number(default=0.5, bounds=(1e-4, 100.0), doc="particle radius, mm")
    frequency_khz = param.Number(default=108.0, bounds=(1e-3, 1e6), doc="wave frequency, kHz")
    amplitude_nm = param.Number(default=1.0, bounds=(0.0, 1e6), doc="vertical wave amplitude, nm")
    preload_mN = param.Number(default=0.0, bounds=(0.0, 1e6), doc="pre-load, mN")
    marker = param.Tuple(default=None, allow_None=True, length=2)

    def __init__(self, explorer, **params):
        super().__init__(**params)
        self.explorer = explorer
        self.last_drift = None
        self.info = pn.pane.Markdown(sizing_mode="stretch_width", name="units-info")
        self.param.watch(self._update, ["substrate", "particle", "radius_mm", "frequency_khz",
                                        "amplitude_nm", "preload_mN"])
        self._update()

    def normalized(self):
        return units.to_normalized(self.substrate, self.particle, self.radius_mm * 1e-3,
                                   self.frequency_khz * 1e3, self.amplitude_nm * 1e-9,
                                   preload=self.preload_mN * 1e-3)

    def _update(self, *events):
        try:
            n = self.normalized()
        except (ValueError, TypeError) as exc:
            self.info.object = f"**Invalid input:** {exc}"
            self.marker = None
            return
        la = math.log10(n.A_star) if n.A_star > 0 else -math.inf
        lm = math.log10(n.m_star)
        inside = -3 <= la <= 3 and -5 <= lm <= 5
        self.marker = (la, lm) if inside else None
        self.info.object = "\n".join([
            "| quantity | value |", "|---|---|",
            f"| A* | {n.A_star:.4g} (log10 {la:.3f}) |",
            f"| m* | {n.m_star:.4g} (log10 {lm:.3f}) |",
            f"| a0 | {n.a0:.3e} m |",
            f"| Rayleigh speed c_R | {n.c_R:.0f} m/s |",
            f"| r(nu), theta | {n.r:.3f}, {n.theta:.3f} |",
            f"| on the map | {'yes: green diamond' if inside else 'outside the map'} |",
        ])

    def si_text(self, v_star):
        try:
            n = self.normalized()
        except (ValueError, TypeError):
            return ""
        return f"{n.drift_velocity_si(v_star):.3e} m/s (with the Units tab's device)"

    def _go(self, event):
        if self.marker is not None:
            la, lm = self.marker
            self.explorer.state.param.update(log_amplitude=round(la, 3), log_mass=round(lm, 3))
            pn.state.execute(self.explorer._run)

    def __panel__(self):
        go = pn.widgets.Button(name="Run this device's scene", button_type="primary")
        go.on_click(self._go)
        labels = {"radius_mm": "particle radius (mm)", "frequency_khz": "frequency (kHz)",
                  "amplitude_nm": "vertical wave amplitude (nm)", "preload_mN": "pre-load (mN)"}
        inputs = [pn.widgets.FloatInput.from_param(self.param[k], name=v,
                                                   css_classes=[f"vt-{k}"], width=260)
                  for k, v in labels.items()]
        return pn.Column(
            pn.pane.Markdown("### Device in SI units"),
            pn.widgets.Select.from_param(self.param.substrate, name="substrate", width=260),
            pn.widgets.Select.from_param(self.param.particle, name="particle", width=260),
            *inputs, go, self.info)


def create_app():
    """One session's explorer.  A template keeps the controls in their own
    root (a plain Row of controls and plots collapsed the trajectory plots)."""
    explorer = Explorer()
    return pn.template.BootstrapTemplate(
        title="vibtrans: vibrational transport explorer",
        sidebar=[explorer.controls()], main=[explorer.main()], sidebar_width=330)


if pn.state.served:
    create_app().servable(title="vibtrans explorer")
