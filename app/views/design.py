"""The Design tab: the library's design chart (`vibtrans design`) in the
explorer.  A device's materials, pre-load and the two chart axes among
frequency, radius and amplitude (the third fixed at the device's value)
are typed here; "Draw chart" reads a shipped drift map for them
(`vibtrans.design.design_chart`, off the event loop: shipped maps only,
never a computation) and draws `vibtrans.plots.design_figure`.  A click on
the chart moves the device there and shows its quantities
(`design.device_quantities` of `design.read_device`) and validity warnings
beside it.  Below the status line: the chart-wide validity warnings
(`design.chart_warnings`) and the ranges of a0, contact radius, A* and m*
over the chart; below the chart, its downloads (figure PNG/SVG/PDF with
the device marked, `vibtrans.export.export_design`; data netCDF/CSV,
`design.write_chart_data`).  A material may be given by its three
properties ("custom (E, nu, rho)": the library's "E=70e9,nu=0.3,rho=2500").
The preset selector says "custom" once a value differs from the preset's.

No physics here: every value is checked by the library, whose refusal
(an InputError naming the parameter and its valid range) is shown as it
is; nothing is clamped.  A chart with a point the map has no value for
(NaN) is refused, not drawn."""
import asyncio
import functools
import math

import numpy as np
import panel as pn
import param
from bokeh.events import Tap
from bokeh.models import CustomJSTickFormatter, FixedTicker, GlyphRenderer, Scatter

from vibtrans import design, plots, units
from vibtrans.designconst import DEFAULT_SURFACE_ENERGY, PRESET_NAMES
from vibtrans.errors import InputError

from .. import inputs
from .exports import _read_back
from .render import rendered

MIN_WIDTH = 420
CHART_HEIGHT = 540
SHIPPED_MUS = (0.1, 0.3, 1.0)       # the shipped deformable maps' mu
MATERIAL_NAMES = tuple(sorted(m.name for m in units.MATERIALS.values()))
UNITS = {"frequency": "Hz", "radius": "m", "amplitude": "m"}
INTRO = ("**Design chart in device units** (`vibtrans design`): pick a device (or a preset), "
         "the two quantities on the chart's axes and their ranges (the third is fixed at the "
         "device's value), then *Draw chart*. The chart reads the shipped drift map "
         "(deformable model) at each point: colour, the drift velocity (red with the wave, blue "
         "against it); lines, the regimes and equal speeds. Click the chart to move the device "
         "there: its quantities and the model's validity warnings appear beside it. A device "
         "whose materials or window no shipped map covers is refused with the reason "
         "(`vibtrans design --compute` computes such a window).")
HINT = "*Press Draw chart to read the shipped map for these values.*"
CUSTOM_MATERIAL = "custom (E, nu, rho)"     # the material selectors' entry for a typed one
CUSTOM_EXAMPLE = "E=70e9,nu=0.3,rho=2500"   # units.material's custom form (glass's values)
CUSTOM_PRESET = "custom"                    # the preset selector once a value is edited
# the values a preset sets: editing one makes the preset "custom"
PRESET_VALUES = ("substrate", "particle", "preload", "frequency", "radius", "amplitude", "x",
                 "x_lo", "x_hi", "x_points", "y", "y_lo", "y_hi", "y_points")
FIGURE_FORMATS = ("png", "svg", "pdf")
DATA_FORMATS = ("nc", "csv")
DOWNLOAD_LABELS = {"png": "figure PNG", "svg": "figure SVG", "pdf": "figure PDF",
                   "nc": "data netCDF", "csv": "data CSV"}
DOWNLOAD_HINT = "*Downloads: draw a chart first.*"


def _device_marker(fig):
    """The data source of the device's marker in a design figure (its only
    Scatter glyph), or None."""
    for r in fig.renderers:
        if isinstance(r, GlyphRenderer) and isinstance(r.glyph, Scatter):
            return r.data_source
    return None


def log_ticks(lo, hi, most=8):
    """Ticks of a log axis from lo to hi: 1..9, 1-2-5 or 1-3 times the
    decades, the densest with at most `most`, else every k-th decade.
    (Bokeh's LogTicker falls back to linear ticks over a few decades,
    whose labels overlap on a chart as narrow as half the page.)"""
    e0, e1 = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    for mantissas in ((1, 2, 3, 4, 5, 6, 7, 8, 9), (1, 2, 5), (1, 3), (1,)):
        ticks = [m * 10.0 ** e for e in range(e0, e1 + 1) for m in mantissas]
        ticks = [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
        if 2 <= len(ticks) <= most:
            return ticks
    k = max(1, math.ceil((e1 - e0 + 1) / most))
    ticks = [10.0 ** e for e in range(e0, e1 + 1, k) if lo <= 10.0 ** e <= hi]
    return ticks if len(ticks) >= 2 else [lo, hi]


def _tick_axes(fig, chart):
    """The chart's log axes with readable ticks (labels such as 2e5)."""
    for axis, q in ((fig.xaxis, chart.attrs["x"]), (fig.yaxis, chart.attrs["y"])):
        values = chart[q].values
        axis.ticker = FixedTicker(ticks=log_ticks(float(values[0]), float(values[-1])))
        axis.formatter = CustomJSTickFormatter(
            code="return tick.toPrecision(1).includes('e') ? "
                 "tick.toExponential(0).replace('e+', 'e') : String(tick)")


def _all_finite(chart):
    """True when every chart point has a value (no NaN would reach the plot)."""
    return all(bool(np.isfinite(chart[v].values).all())
               for v in ("drift_velocity", "A_star", "m_star"))


def build_chart(values):
    """(chart, figure, device, reading, quantities, warnings) for the
    panel's `values` (DesignPanel.values()); the library's InputError
    (a ValueError) when a value is refused.  Runs off the event loop."""
    v = values
    xq, yq = v["x"], v["y"]
    fq = next(q for q in design.AXES if q not in (xq, yq))     # (x == y: the library says so)
    fixed = (fq, v[fq])
    chart = design.design_chart(v["substrate"], v["particle"], v["preload"],
                                (xq, v["x_lo"], v["x_hi"], v["x_points"]),
                                (yq, v["y_lo"], v["y_hi"], v["y_points"]),
                                fixed, mu=v["mu"], surface_energy=v["surface_energy"])
    if not _all_finite(chart):
        bad = int((~np.isfinite(chart["drift_velocity"].values)).sum())
        raise InputError(
            f"the map has no value at {bad} of {chart['drift_velocity'].size} chart points "
            f"(not computed there): narrow the axes")
    device, reading, q, warnings = device_reading(v, chart)
    _, fig = rendered(plots.design_figure, chart,
                      device=(getattr(device, xq), getattr(device, yq)))
    fig.document.remove_root(fig)
    _tick_axes(fig, chart)
    fig.update(sizing_mode="stretch_width", min_width=MIN_WIDTH, width=None,
               height=CHART_HEIGHT)
    return chart, fig, device, reading, q, warnings


def device_reading(values, chart):
    """(device, reading, quantities, warnings) of the panel's device, read
    on `chart`'s map; InputError for a value the library refuses."""
    v = values
    device = units.DeviceSpec(v["substrate"], v["particle"], v["radius"], v["frequency"],
                              v["amplitude"], preload=v["preload"])
    device.normalized()             # checks every value (InputError names it)
    reading = design.read_device(device, mu=v["mu"], chart=chart)
    q = design.device_quantities(device, reading, v["surface_energy"])
    warnings = design.validity_warnings(device, v["surface_energy"], q.drift_velocity)
    return device, reading, q, warnings


def _range(values, unit=""):
    """min – max of values (3 digits), or the one value where they agree."""
    lo, hi = f"{float(np.nanmin(values)):.3g}", f"{float(np.nanmax(values)):.3g}"
    return f"{lo if lo == hi else f'{lo} – {hi}'}{(' ' + unit) if unit else ''}"


def chart_text(chart):
    """The chart-wide validity warnings (`design.chart_warnings`) and the
    ranges of a0, contact radius, A* and m* over the chart, as Markdown."""
    lines = design.chart_warnings(chart)
    warned = ([f"* **chart warning:** {line}" for line in lines]
              or ["*No validity warnings over the chart.*"])
    ranges = (f"**Over the chart:** a0 {_range(chart['a0'].values, 'm')}; contact radius "
              f"{_range(chart['contact_radius'].values, 'm')}; A* "
              f"{_range(chart['A_star'].values)}; m* {_range(chart['m_star'].values)}")
    return "\n".join([ranges, "", *warned])


def _g(value, unit=""):
    return "n/a" if value is None else f"{value:.4g}{(' ' + unit) if unit else ''}"


def device_text(device, reading, q, warnings):
    """The device's quantities and warnings as Markdown."""
    rows = [("A*, m*", f"{q.A_star:.4g}, {q.m_star:.4g}"),
            ("theta, nu, r", f"{q.theta:.4g}, {q.nu:g}, {q.r:.4g}"),
            ("mass, load m g + P", f"{q.mass:.4g} kg, {q.load:.4g} N"),
            ("a0 (static compression)", _g(q.a0, "m")),
            ("contact radius", _g(q.contact_radius, "m")),
            ("mean contact pressure", _g(q.mean_contact_pressure, "Pa")),
            ("peak surface acceleration", _g(q.peak_acceleration_g, "g")),
            ("peak surface velocity", _g(q.peak_velocity, "m/s")),
            ("Rayleigh speed, wavelength", f"{q.rayleigh_speed:.4g} m/s, "
                                           f"{q.rayleigh_wavelength:.4g} m"),
            ("pull-off JKR, DMT", f"{q.pull_off_jkr:.4g} N, {q.pull_off_dmt:.4g} N")]
    if reading is None:
        rows.append(("drift", "not read: the device is off the map (or no shipped map "
                              "serves it)"))
    else:
        rows += [("drift velocity", f"**{q.drift_velocity:.4g} m/s** "
                                    f"({q.drift_velocity * 100:.3g} cm/s)"),
                 ("v*", f"{q.v_star:.4g} ({reading['map']}, nearest grid point)"),
                 ("regime", reading["regime"]),
                 ("contact time per period", _g(q.contact_time, "s")),
                 ("travel per period", f"{_g(q.travel_per_period, 'm')} = "
                                       f"{_g(q.travel_over_wavelength)} wavelengths")]
    head = (f"**Device**: {units.material(device.particle).name} sphere, R = "
            f"{device.radius:.4g} m, on {units.material(device.substrate).name}; f = "
            f"{device.frequency:.4g} Hz, A_y = {device.amplitude:.4g} m, pre-load "
            f"{device.preload:g} N")
    table = ["| quantity | value |", "|---|---|", *(f"| {k} | {v} |" for k, v in rows)]
    notes = ([f"* **warning:** {w.message}" for w in warnings]
             or ["*No validity warnings.*"])
    return "\n".join([head, "", *table, "", *notes])


class DesignPanel(pn.viewable.Viewer):
    """The Design tab: its values (SI units), its widgets, the chart.

    Every number is stored as typed; the library checks them when the
    chart is drawn (`draw`) and its refusal is shown in `alert`."""

    preset = param.Selector(default="paper", objects=[*PRESET_NAMES, CUSTOM_PRESET])
    substrate = param.Selector(default="glass", objects=[*MATERIAL_NAMES, CUSTOM_MATERIAL])
    particle = param.Selector(default="steel", objects=[*MATERIAL_NAMES, CUSTOM_MATERIAL])
    substrate_custom = param.String(default=CUSTOM_EXAMPLE, doc="E=<Pa>,nu=<->,rho=<kg/m^3>")
    particle_custom = param.String(default=CUSTOM_EXAMPLE, doc="E=<Pa>,nu=<->,rho=<kg/m^3>")
    preload = param.Number(default=0.0, doc="pre-load P, N")
    mu = param.Selector(default=0.3, objects=list(SHIPPED_MUS))
    surface_energy = param.Number(default=DEFAULT_SURFACE_ENERGY, doc="work of adhesion, J/m^2")
    frequency = param.Number(default=1e5, doc="the device's wave frequency, Hz")
    radius = param.Number(default=0.5e-3, doc="the device's particle radius, m")
    amplitude = param.Number(default=1e-8, doc="the device's vertical wave amplitude, m")
    x = param.Selector(default="frequency", objects=list(design.AXES))
    x_lo = param.Number(default=1e4)
    x_hi = param.Number(default=1e6)
    x_points = param.Integer(default=41)
    y = param.Selector(default="amplitude", objects=list(design.AXES))
    y_lo = param.Number(default=1e-9)
    y_hi = param.Number(default=5e-7)
    y_points = param.Integer(default=41)
    busy = param.Boolean(default=False)

    def __init__(self, **params):
        super().__init__(**params)
        self.chart = None           # the chart drawn (design_chart's Dataset)
        self.figure = None          # its Bokeh figure
        self.device = None          # the device marked (units.DeviceSpec)
        self.quantities = self.reading = None
        self.warnings = []
        self._marker = None         # the figure's device marker's source
        self._drawn_values = None   # the values the chart drawn was made with
        self._draws = 0             # the latest draw's number (older ones dropped)
        self._marks = 0
        self.alert = pn.pane.Alert("", alert_type="danger", visible=False,
                                   sizing_mode="stretch_width", css_classes=["vt-design-alert"])
        self.status = pn.pane.Markdown(HINT, sizing_mode="stretch_width",
                                       css_classes=["vt-design-status"])
        self.spinner = pn.indicators.LoadingSpinner(value=False, visible=False, width=24,
                                                    height=24)
        self.chart_pane = pn.Column(sizing_mode="stretch_width", min_width=MIN_WIDTH,
                                    css_classes=["vt-design-chart"])
        self.info = pn.pane.Markdown("", sizing_mode="stretch_width",
                                     css_classes=["vt-design-device"])
        self.note = pn.pane.Markdown("", sizing_mode="stretch_width")
        self.draw_button = pn.widgets.Button(name="Draw chart", button_type="primary",
                                             css_classes=["vt-design-draw"])
        self.draw_button.on_click(lambda event: pn.state.execute(self.draw))
        labels = {"preload": "preload (N)", "surface_energy": "surface energy (J/m^2)",
                  "frequency": "frequency (Hz)", "radius": "radius (m)",
                  "amplitude": "amplitude (m)", "x_lo": "x lo", "x_hi": "x hi",
                  "x_points": "x points", "y_lo": "y lo", "y_hi": "y hi",
                  "y_points": "y points"}
        # (the parameters have no bounds: a typed number is applied, the
        # library checks its range when the chart is drawn)
        self.fields = {k: inputs.NumberField(self, k, v, width=150) for k, v in labels.items()}
        self._presetting = False
        self.param.watch(self._on_preset, "preset")
        self.param.watch(self._on_axis, ["x", "y"])
        self._on_preset()
        self._init_extras()
        self._layout = None

    # ---------- values ----------
    def _on_preset(self, *events):
        if self.preset == CUSTOM_PRESET:        # nothing applied: the values stay as typed
            self.note.object = "*Custom values (no preset applied).*"
            return
        p = design.preset(self.preset)
        d = p.device
        self._presetting = True
        try:
            self._apply_preset(p, d)
        finally:
            self._presetting = False
        self.note.object = f"*{p.note}*"

    def _apply_preset(self, p, d):
        self.param.update(
            substrate=units.material(d.substrate).name, particle=units.material(d.particle).name,
            preload=float(d.preload), frequency=float(d.frequency), radius=float(d.radius),
            amplitude=float(d.amplitude), x=p.x[0], x_lo=float(p.x[1]), x_hi=float(p.x[2]),
            x_points=int(p.x[3]), y=p.y[0], y_lo=float(p.y[1]), y_hi=float(p.y[2]),
            y_points=int(p.y[3]))

    def _on_axis(self, *events):
        """A new quantity on an axis: its range becomes a decade around the
        device's value of it (the old range was in another unit).  A
        device value the library would refuse leaves the range as it is."""
        if self._presetting:
            return
        for e in events:
            value = getattr(self, e.new)
            if isinstance(value, (int, float)) and math.isfinite(value) and value > 0:
                lo, hi = float(f"{value / 10 ** 0.5:.3g}"), float(f"{value * 10 ** 0.5:.3g}")
                self.param.update(**{f"{e.name}_lo": lo, f"{e.name}_hi": hi})

    def fixed_quantity(self):
        third = [q for q in design.AXES if q not in (self.x, self.y)]
        return third[0] if len(third) == 1 else None

    def _fixed_text(self):
        q = self.fixed_quantity()
        return ("x and y must be two different quantities" if q is None else
                f"fixed: {q} = the device's {q} ({UNITS[q]})")

    def values(self):
        """The values as typed (SI), for the library to check."""
        names = ("substrate", "particle", "preload", "mu", "surface_energy", "frequency",
                 "radius", "amplitude", "x", "x_lo", "x_hi", "x_points", "y", "y_lo", "y_hi",
                 "y_points")
        return self._with_custom_materials({k: getattr(self, k) for k in names})

    def field_errors(self):
        return [f.error for f in self.fields.values() if f.error]

    # ---------- drawing ----------
    def _say(self, text):
        self.alert.object = text
        self.alert.visible = bool(text)

    async def draw(self):
        """Draw the chart for the values (off the event loop).  A refused
        value: the message in `alert`, the chart drawn before stays."""
        errors = self.field_errors()
        if errors:
            self._say("**Cannot draw the chart:** " + "; ".join(errors))
            return
        self._draws += 1
        token = self._draws
        values = self.values()
        self._busy(True, "Drawing the chart ...")
        try:
            result = await asyncio.get_running_loop().run_in_executor(
                None, build_chart, values)
        except ValueError as exc:        # the library's InputError (TypeError kind too)
            if token == self._draws:
                self._say(f"**Cannot draw the chart:** {exc}")
                self._busy(False, self._shown_status())
            return
        if token != self._draws:
            return              # a newer draw was asked for meanwhile
        chart, fig, device, reading, q, warnings = result
        self._say("")
        with pn.io.hold():
            self.chart, self.figure, self._drawn_values = chart, fig, values
            self._marker = _device_marker(fig)
            fig.on_event(Tap, self._on_tap)
            self.chart_pane.objects = [pn.pane.Bokeh(fig, sizing_mode="stretch_width",
                                                     min_width=MIN_WIDTH)]
            self._show_device(device, reading, q, warnings)
            self._show_chart_extras()
            self._busy(False, self._shown_status())

    def _shown_status(self):
        c = self.chart
        if c is None:
            return HINT
        return (f"*{c.attrs['particle']} on {c.attrs['substrate']}, {c.sizes[c.attrs['y']]} x "
                f"{c.sizes[c.attrs['x']]} points, {c.attrs['fixed']} = "
                f"{c.attrs['fixed_value']:.4g} {c.attrs['fixed_units']}; map "
                f"{c.attrs['map']} ({c.attrs['reading']}). Click the chart to move the "
                f"device.*")

    def _busy(self, on, text):
        self.busy = on
        self.spinner.value = self.spinner.visible = on
        self.draw_button.disabled = on
        self.status.object = text

    def _show_device(self, device, reading, q, warnings):
        self.device, self.reading, self.quantities, self.warnings = device, reading, q, warnings
        self.info.object = device_text(device, reading, q, warnings)
        if self._marker is not None and self.chart is not None:
            xq, yq = self.chart.attrs["x"], self.chart.attrs["y"]
            keys = list(self._marker.data)
            if xq in keys and yq in keys:
                self._marker.data = {**{k: [] for k in keys}, xq: [getattr(device, xq)],
                                     yq: [getattr(device, yq)]}

    # ---------- custom materials, the preset's label, the chart's notes and files ----------
    def _init_extras(self):
        """The widgets of the custom materials, the chart-wide notes and the
        downloads (made with the panel; shown by __panel__)."""
        self.custom_inputs = {
            k: pn.widgets.TextInput.from_param(
                self.param[f"{k}_custom"], name=f"{k}: E (Pa), nu, rho (kg/m^3)", width=230,
                placeholder=CUSTOM_EXAMPLE, visible=getattr(self, k) == CUSTOM_MATERIAL,
                css_classes=[f"vt-design-{k}-custom"])
            for k in ("substrate", "particle")}
        self.custom_row = pn.Row(*self.custom_inputs.values(), visible=self._any_custom(),
                                 margin=(0, 0, 10, 0))
        self.param.watch(self._on_material, ["substrate", "particle"])
        self.param.watch(self._on_edit, [*PRESET_VALUES, "substrate_custom", "particle_custom"])
        self.chart_notes = pn.pane.Markdown("", visible=False, sizing_mode="stretch_width",
                                            css_classes=["vt-design-chart-notes"])
        self.download_buttons = {
            fmt: pn.widgets.FileDownload(
                callback=functools.partial(self.chart_file, fmt),
                filename=f"vibtrans-design.{fmt}",
                label=DOWNLOAD_LABELS[fmt], button_type="light", width=95, disabled=True,
                css_classes=[f"vt-design-download-{fmt}"])
            for fmt in (*FIGURE_FORMATS, *DATA_FORMATS)}
        self.download_note = pn.pane.Markdown(DOWNLOAD_HINT, margin=(5, 10))
        self.downloads = pn.FlexBox(self.download_note, *self.download_buttons.values(),
                                    flex_wrap="wrap", align_items="center",
                                    sizing_mode="stretch_width",
                                    css_classes=["vt-design-downloads"])

    def _any_custom(self):
        return CUSTOM_MATERIAL in (self.substrate, self.particle)

    def _on_material(self, *events):
        for k, w in self.custom_inputs.items():
            w.visible = getattr(self, k) == CUSTOM_MATERIAL
        self.custom_row.visible = self._any_custom()

    def _with_custom_materials(self, values):
        """values with a custom material's text in place of its selector's
        entry (the library parses it and names what is wrong)."""
        for k in ("substrate", "particle"):
            if values[k] == CUSTOM_MATERIAL:
                values[k] = getattr(self, f"{k}_custom")
        return values

    def _on_edit(self, *events):
        """A value of the preset's edited: the preset shown becomes "custom"
        (nothing re-applied).  A custom material's text counts only when
        that material is custom."""
        if self._presetting or self.preset == CUSTOM_PRESET:
            return
        if all(e.name.endswith("_custom") and getattr(self, e.name[:-7]) != CUSTOM_MATERIAL
               for e in events):
            return
        self.preset = CUSTOM_PRESET

    def _show_chart_extras(self):
        """The chart drawn's notes, and its downloads enabled."""
        self.chart_notes.object = chart_text(self.chart)
        self.chart_notes.visible = True
        self.download_note.object = "*Download the chart shown (device marked):*"
        for b in self.download_buttons.values():
            b.disabled = False

    def device_mark(self):
        """(x, y) of the device marked on the chart shown, or None."""
        c, d = self.chart, self.device
        if c is None or d is None:
            return None
        return (getattr(d, c.attrs["x"]), getattr(d, c.attrs["y"]))

    def chart_file(self, fmt):
        """The bytes (BytesIO) of a download of the chart shown: its figure
        (png, svg, pdf; the device marked) or its data (nc, csv)."""
        chart = self.chart
        if chart is None:
            raise ValueError("draw a chart first")
        if fmt in DATA_FORMATS:
            return _read_back(functools.partial(design.write_chart_data, chart),
                              f"design.{fmt}")
        if fmt not in FIGURE_FORMATS:
            raise ValueError(f"no such download: {fmt!r}")
        from vibtrans.export import export_design
        return _read_back(functools.partial(export_design, chart, device=self.device_mark()),
                          f"design.{fmt}")

    # ---------- a click on the chart ----------
    def _on_tap(self, event):
        x, y = event.x, event.y
        if self.chart is None or x is None or y is None:
            return
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        pn.state.execute(functools.partial(self.mark, x, y))

    async def mark(self, x, y):
        """Move the device to (x, y) of the chart drawn (its axes' units;
        4 significant digits) and show its quantities.  A click outside
        the chart's window moves nothing."""
        c = self.chart
        if c is None:
            return
        xq, yq = c.attrs["x"], c.attrs["y"]
        xs, ys = c[xq].values, c[yq].values
        if not (xs[0] <= x <= xs[-1] and ys[0] <= y <= ys[-1]):
            return
        x, y = float(f"{x:.4g}"), float(f"{y:.4g}")
        values = {**self._drawn_values, xq: x, yq: y}
        self._marks += 1
        token = self._marks
        try:
            got = await asyncio.get_running_loop().run_in_executor(
                None, device_reading, values, c)
        except ValueError as exc:
            self._say(f"**Cannot read the device:** {exc}")
            return
        if token != self._marks or c is not self.chart:
            return
        self._say("")
        with pn.io.hold():
            self.param.update(**{xq: x, yq: y})
            self._show_device(*got)

    def __panel__(self):
        if self._layout is None:
            f = self.fields
            select = functools.partial(pn.widgets.Select.from_param, width=150)
            fixed = pn.pane.Markdown(pn.bind(lambda x, y: f"*{self._fixed_text()}*",
                                             self.param.x, self.param.y),
                                     sizing_mode="stretch_width")
            controls = pn.Column(
                pn.pane.Markdown(INTRO, sizing_mode="stretch_width"),
                pn.Row(select(self.param.preset, name="preset", css_classes=["vt-design-preset"]),
                       self.note, sizing_mode="stretch_width"),
                pn.Row(select(self.param.substrate, name="substrate"),
                       select(self.param.particle, name="particle"), f["preload"],
                       select(self.param.mu, name="mu (shipped maps)"), f["surface_energy"]),
                self.custom_row,
                pn.pane.Markdown("**The device** (marked on the chart; a click moves it)",
                                 margin=(0, 10)),
                pn.Row(f["frequency"], f["radius"], f["amplitude"]),
                pn.Row(select(self.param.x, name="x axis"), f["x_lo"], f["x_hi"], f["x_points"]),
                pn.Row(select(self.param.y, name="y axis"), f["y_lo"], f["y_hi"], f["y_points"]),
                fixed,
                pn.Row(self.draw_button, self.spinner),
                sizing_mode="stretch_width")
            self._layout = pn.Column(
                controls, self.alert, self.status, self.chart_notes,
                pn.FlexBox(pn.Column(self.chart_pane, styles={"flex": "2 1 420px",
                                                              "min-width": "0"}),
                           pn.Column(self.info, styles={"flex": "1 1 260px", "min-width": "0"}),
                           flex_wrap="wrap", align_items="flex-start",
                           sizing_mode="stretch_width"),
                self.downloads,
                sizing_mode="stretch_width", name="design")
        return self._layout

