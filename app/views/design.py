"""The Design tab: the library's design chart (`vibtrans design`) in the
explorer.  A device's materials, pre-load and the two chart axes among
frequency, radius and amplitude (the third fixed at the device's value)
are typed here; "Draw chart" reads a shipped drift map for them
(`vibtrans.products.design.design_chart`, off the event loop) and draws
`vibtrans.products.plots.design_figure`.  When no shipped map serves the chart
(another mu, theta or nu of the materials, a window outside the shipped
maps), the tab offers the map it needs as a map on demand (app/server/mapjobs.py:
the server's queue, cache and fair share of cores), with its estimated cost
shown before anything runs; the chart is drawn level by level as the map is
refined.  A click on the chart moves the device there and shows its
quantities (`design.device_quantities` of `design.read_device`) and validity
warnings beside it; "Run this device's scene" runs it in the explorer.
Below the status line: the chart-wide validity warnings
(`design.chart_warnings`) and the ranges of a0, contact radius, A* and m*
over the chart; below the chart, its downloads (figure PNG/SVG/PDF with
the device marked, `vibtrans.products.export.export_design`; data netCDF/CSV,
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
import time

import numpy as np
import panel as pn
import param
from bokeh.events import Tap
from bokeh.models import CustomJSTickFormatter, FixedTicker, GlyphRenderer, Scatter

from vibtrans import Scene
from vibtrans.core import units
from vibtrans.core.errors import Cancelled, InputError
from vibtrans.core.params import ROLLING_NONE
from vibtrans.maps import accuracy as mapaccuracy
from vibtrans.products import design, designtip, plots
from vibtrans.products.design import CUSTOM_EXAMPLE, CUSTOM_MATERIAL, Device
from vibtrans.products.designconst import DEFAULT_SURFACE_ENERGY, PRESET_NAMES
from vibtrans.products.designtip import TIP_SIZES, Tip
from vibtrans_explorer.server import mapjobs
from vibtrans_explorer.session.latest import LatestJob
from vibtrans_explorer.session.maprequest import MapRequest
from vibtrans_explorer.session.state import SCENE_LIMITS, TIP_FIELDS, limited
from vibtrans_explorer.session.urlstate import literal
from vibtrans_explorer.views import inputs
from vibtrans_explorer.views.exports import read_back
from vibtrans_explorer.views.map import tapped
from vibtrans_explorer.views.mapondemand import progress_text, rolling_name
from vibtrans_explorer.views.presentation import scale_fonts
from vibtrans_explorer.views.profile import RollingView
from vibtrans_explorer.views.render import exclusively, rendered
from vibtrans_explorer.views.units import DEVICE_LABELS, device_form, refusal_alert

MIN_WIDTH = 420
CHART_HEIGHT = 540
# a computed map's refinement levels (its coarse grid is 1/8 of its finest)
DESIGN_LEVELS = 3
UNITS = {"frequency": "Hz", "radius": "m", "amplitude": "m"}
INTRO = (
    "**Design chart in device units** (`vibtrans design`): pick a device (or a preset) "
    "and its particle's tip (the sphere, a cone, a power law, a flat), "
    "the two quantities on the chart's axes and their ranges (the third is fixed at the "
    "device's value), then *Draw chart*. The chart reads a drift map "
    "(deformable model) at each point: colour, the drift velocity (red with the wave, blue "
    "against it); lines, the regimes and equal speeds. Click the chart to move the device "
    "there: its quantities and the model's validity warnings appear beside it, and its "
    "scene runs in the explorer (the trajectory's time also in seconds). When no "
    "shipped map serves the chart (another mu, the materials' theta or nu, a window "
    "outside the shipped maps), the map it needs is offered, its cost shown first, and "
    "computed on this server like a map on demand."
)
HINT = "*Press Draw chart to read the drift map for these values.*"
# over a chart drawn for other values than the form's
STALE = "**Changed since this chart was drawn: press Draw chart.**"
STALE_OFFERED = (
    "**Changed since this chart was drawn:** no shipped map serves the chart of "
    "these values (below: the map it needs)."
)
CUSTOM_PRESET = "custom"  # the preset selector once a value is edited
# the device's values a preset sets (Device's but a custom material's
# text), with the tip's kind (a preset's particle is a sphere; the sizes
# stay as typed) and the chart's axes (AXIS_VALUES): editing one makes the
# preset "custom"
PRESET_DEVICE = tuple(k for k in Device.param if k != "name" and not k.endswith("_custom"))
# the tip's fields: label of each size (TIP_SIZES says which kind takes it)
TIP_LABELS = {
    "tip_half_angle": "cone half-angle (degrees)",
    "tip_exponent": "exponent N (z ~ r^N)",
    "tip_radius": "tip radius R_t (m; empty: R)",
    "tip_flat_radius": "flat radius (m)",
}
TIP_NOTE = (
    "*The body stays a sphere of the radius above (its mass); it touches the substrate "
    "with this tip. Its chart reads a map of the tip's normalized profile (not the "
    "sphere's shipped maps); \"Run this device's scene\" sets the explorer's particle "
    "profile to it.*"
)
# the particle's body: whether it rolls, a solid or a hollow (thin-shell)
# sphere (docs/MODEL.md section 11; the state's `rolling`, the sidebar's too)
DESIGN_ROLLINGS = {
    "does not roll (the paper's)": "none",
    "solid sphere, rolls (j = 2/5)": "solid",
    "hollow (thin shell), rolls (j = 2/3)": "shell",
    "another j = I/(m R^2), rolls": "j",
}
HOLLOW_NOTE = (
    "*A hollow particle: its mass is taken as a solid sphere's of the particle's "
    "density (m\\* follows it), so give it as a custom particle whose density is the "
    "shell's mean density (its mass over 4/3 pi R^3); its contact is Hertz's while "
    "its wall is much thicker than the contact radius.*"
)
ROLLING_CHART_NOTE = (
    "the shipped maps are of a particle that does not roll; this particle "
    "rolls ({rolling}), so its chart reads a map of its own, computed on "
    "this server (`vibtrans design --rolling {rolling}` needs --compute)"
)
FIGURE_FORMATS = ("png", "svg", "pdf")
DATA_FORMATS = ("nc", "csv")
DOWNLOAD_LABELS = {
    **{f: f"figure {f.upper()}" for f in FIGURE_FORMATS},
    "nc": "data netCDF",
    "csv": "data CSV",
}
DOWNLOAD_HINT = "*Downloads: draw a chart first.*"


# the values a map on demand bounds, named as the chart's refusal says them
_NAMED = {"theta": "theta of the materials", "nu": "nu of the substrate", "periods": "the map's periods"}


def _button(label, color, css, act, **params):
    """A button (CSS classes `css`, space-separated) calling act() when clicked."""
    button = pn.widgets.Button(label=label, color=color, css_classes=css.split(), **params)
    button.on_click(lambda event: act())
    return button


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
        ticks = [m * 10.0**e for e in range(e0, e1 + 1) for m in mantissas]
        ticks = [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]
        if 2 <= len(ticks) <= most:
            return ticks
    k = max(1, math.ceil((e1 - e0 + 1) / most))
    ticks = [10.0**e for e in range(e0, e1 + 1, k) if lo <= 10.0**e <= hi]
    return ticks if len(ticks) >= 2 else [lo, hi]


def _tick_axes(fig, chart):
    """The chart's log axes with readable ticks (labels such as 2e5)."""
    for axis, q in ((fig.xaxis, chart.attrs["x"]), (fig.yaxis, chart.attrs["y"])):
        values = chart[q].values
        axis.ticker = FixedTicker(ticks=log_ticks(float(values[0]), float(values[-1])))
        # three significant digits at most, trailing zeros dropped: 1e5,
        # 1.2e5, 2e-8, 0.5 (a narrow axis's ends differ in the 2nd digit)
        axis.formatter = CustomJSTickFormatter(
            code="const a = Math.abs(tick); "
            "if (a !== 0 && (a >= 1e4 || a < 1e-3)) { "
            "  const [m, e] = tick.toExponential(2).split('e'); "
            "  return String(Number(m)) + 'e' + String(Number(e)); } "
            "return String(Number(tick.toPrecision(3)));"
        )


def tip_shape(values):
    """The checked tip (designtip.TipShape) of the panel's values (the
    library's InputError names a refused size)."""
    return designtip.tip_shape(**designtip.tip_arguments(values))


def preset_device(p):
    """The device's values (PRESET_DEVICE) a preset `p` sets, as the form
    holds them (its materials by name)."""
    values = {k: getattr(p.device, k) for k in PRESET_DEVICE}
    return {
        k: units.material(v).name if k in ("substrate", "particle") else float(v) for k, v in values.items()
    }


def _chart_args(values):
    """design_chart's positional arguments and mu of the panel's values."""
    v = values
    xq, yq = v["x"], v["y"]
    fq = next((q for q in design.AXES if q not in (xq, yq)), xq)  # (x == y: the library says so)
    return (
        v["substrate"],
        v["particle"],
        v["preload"],
        (xq, v["x_lo"], v["x_hi"], v["x_points"]),
        (yq, v["y_lo"], v["y_hi"], v["y_points"]),
        (fq, v[fq]),
    )


def map_request(need, step=design.MAP_STEP, levels=None, fidelity=design.COMPUTE_FIDELITY, periods=2000.0):
    """(MapRequest, None) computing the map `need` asks for: the deformable
    particle at `fidelity` and `periods` (by default the library's computed
    map's: preview, 2000 periods) with the shipped maps' tau, mu, theta and
    nu of the chart, its particle's normalized profile (the tip's) and
    its rolling, its window snapped outward to `step` decades, the
    finest step at most `step`; or (None, why) when a value or the window
    is outside what a map on demand accepts.  levels: DESIGN_LEVELS if None."""
    levels = DESIGN_LEVELS if levels is None else levels
    if fidelity not in MapRequest.param.fidelity.objects:
        return None, (
            f"the map's fidelity must be one of "
            f"{', '.join(MapRequest.param.fidelity.objects)}; got {fidelity!r}"
        )
    for name, value in (("mu", need.mu), ("theta", need.theta), ("nu", need.nu), ("periods", periods)):
        p = MapRequest.param[name]
        (lo, hi), (lo_in, hi_in) = p.bounds, p.inclusive_bounds
        if not ((lo <= value if lo_in else lo < value) and (value <= hi if hi_in else value < hi)):
            what = _NAMED.get(name, name)
            return None, (
                f"{what} is {value:.4g}; a map on demand accepts {name} in "
                f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"
            )
    spans = {"la": need.log_amplitude, "lm": need.log_mass}
    bounds = {k: MapRequest.param[f"{k}_from"].bounds for k in spans}
    for k, label in (("la", "log10 A*"), ("lm", "log10 m*")):
        (lo, hi), (blo, bhi) = spans[k], bounds[k]
        if lo < blo or hi > bhi:
            return None, (
                f"the chart spans {label} [{lo:.3g}, {hi:.3g}], beyond what a map "
                f"on demand accepts ({label} in [{blo:g}, {bhi:g}]): narrow the axes"
            )
    start = {k: math.floor(spans[k][0] / step) * step for k in spans}
    fine = max(max(math.ceil((spans[k][1] - start[k]) / step - 1e-9) for k in spans), 1)
    cells = math.ceil(fine / 2**levels)
    width = cells * 2**levels * step
    if cells > MapRequest.param.cells.bounds[1] or any(width > b[1] - b[0] for b in bounds.values()):
        return None, (
            f"the chart spans {fine * step:.3g} decades, more than a map on demand "
            f"of this tab covers: narrow the axes"
        )
    # snapped to the step's grid (a chart asked again is the same map), moved
    # inside the accepted range where the snapping crossed its edge
    start = {k: min(start[k], bounds[k][1] - width) for k in spans}
    start = {k: max(v, bounds[k][0]) for k, v in start.items()}
    if need.load_over_modulus is not None:  # (a measured table: not offered here)
        return None, (
            "a measured profile's map needs its load over modulus, which a map on "
            "demand does not take: use `vibtrans design --compute`"
        )
    request = MapRequest(
        model="deformable",
        mu=need.mu,
        theta=need.theta,
        nu=need.nu,
        profile=need.profile,
        rolling=need.rolling,
        fidelity=fidelity,
        periods=float(periods),
        levels=levels,
        cells=cells,
        la_from=round(start["la"], 10),
        la_to=round(start["la"] + width, 10),
        lm_from=round(start["lm"], 10),
        lm_to=round(start["lm"] + width, 10),
    )
    return request, None


def build_chart(values, map_ds=None, map_name="given map"):
    """(chart, figure, device, reading, quantities, warnings) for the
    panel's `values` (DesignPanel.values()), read on `map_ds` (a map on
    demand named `map_name`) or the shipped map; the library's InputError
    (a ValueError) when a value is refused.  Runs off the event loop."""
    v = values
    xq, yq = v["x"], v["y"]
    chart = design.design_chart(
        *_chart_args(v),
        mu=v["mu"],
        surface_energy=v["surface_energy"],
        map_ds=map_ds,
        map_name=map_name,
        shape=tip_shape(v),
        rolling=v["rolling"],
    )
    # every chart point with a value: no NaN reaches the plot
    if not all(bool(np.isfinite(chart[v].values).all()) for v in ("drift_velocity", "A_star", "m_star")):
        bad = int((~np.isfinite(chart["drift_velocity"].values)).sum())
        raise InputError(
            f"the map has no value at {bad} of {chart['drift_velocity'].size} chart points "
            f"(not computed there): narrow the axes"
        )
    device, reading, q, warnings = device_reading(v, chart, map_ds, map_name)
    _, fig = rendered(plots.design_figure, chart, device=(getattr(device, xq), getattr(device, yq)))
    fig.document.remove_root(fig)
    _tick_axes(fig, chart)
    fig.update(sizing_mode="stretch_width", min_width=MIN_WIDTH, width=None, height=CHART_HEIGHT)
    return chart, fig, device, reading, q, warnings


def device_spec(values):
    """The checked units.DeviceSpec of the panel's values (InputError names
    a value refused)."""
    v = values
    device = units.DeviceSpec(
        v["substrate"], v["particle"], v["radius"], v["frequency"], v["amplitude"], preload=v["preload"]
    )
    device.normalized()  # checks every value
    return device


def device_reading(values, chart, map_ds=None, map_name="given map"):
    """(device, reading, quantities, warnings) of the panel's device, read
    on `chart`'s map (`map_ds` when it is a map on demand); InputError for
    a value the library refuses."""
    v = values
    device = device_spec(v)
    shape = tip_shape(v)
    reading = design.read_device(
        device, mu=v["mu"], chart=chart, map_ds=map_ds, map_name=map_name, shape=shape, rolling=v["rolling"]
    )
    q = design.device_quantities(device, reading, v["surface_energy"], shape=shape)
    warnings = design.validity_warnings(device, v["surface_energy"], q.drift_velocity, shape=shape)
    return device, reading, q, warnings


def _range(values, unit=""):
    """min – max of values (3 digits), or the one value where they agree."""
    lo, hi = f"{float(np.nanmin(values)):.3g}", f"{float(np.nanmax(values)):.3g}"
    return f"{lo if lo == hi else f'{lo} – {hi}'}{(' ' + unit) if unit else ''}"


def chart_text(chart):
    """The chart-wide validity warnings (`design.chart_warnings`) and the
    ranges of a0, contact radius, A* and m* over the chart, as Markdown."""
    lines = design.chart_warnings(chart)
    warned = [f"* **chart warning:** {literal(line)}" for line in lines] or [
        "*No validity warnings over the chart.*"
    ]
    ranges = (
        f"**Over the chart:** a0 {_range(chart['a0'].values, 'm')}; contact radius "
        f"{_range(chart['contact_radius'].values, 'm')}; A* "
        f"{_range(chart['A_star'].values)}; m* {_range(chart['m_star'].values)}"
    )
    return "\n".join([ranges, "", *warned])


def _g(value, unit=""):
    return "n/a" if value is None else f"{value:.4g}{(' ' + unit) if unit else ''}"


UNREAD = "not read: the device is off the chart's map (or its map does not serve it)"
# the device of a chart that needs a map on demand, before it is computed
UNREAD_OFFERED = "not read: no map serves this device's chart yet (the map offered above)"


def device_text(device, reading, q, warnings, rolling=ROLLING_NONE, unread=UNREAD):
    """The device's quantities and warnings as Markdown (`rolling`: how its
    particle turns, the Design tab's choice; `unread`: the drift's row when
    there is no reading)."""
    rows = [
        ("A*, m*", f"{q.A_star:.4g}, {q.m_star:.4g}"),
        ("theta, nu, r", f"{q.theta:.4g}, {q.nu:g}, {q.r:.4g}"),
        ("mass, load m g + P", f"{q.mass:.4g} kg, {q.load:.4g} N"),
        ("a0 (static compression)", _g(q.a0, "m")),
        ("contact radius", _g(q.contact_radius, "m")),
        ("mean contact pressure", _g(q.mean_contact_pressure, "Pa")),
        ("peak surface acceleration", _g(q.peak_acceleration_g, "g")),
        ("peak surface velocity", _g(q.peak_velocity, "m/s")),
        ("Rayleigh speed, wavelength", f"{q.rayleigh_speed:.4g} m/s, {q.rayleigh_wavelength:.4g} m"),
        ("pull-off JKR, DMT", f"{q.pull_off_jkr:.4g} N, {q.pull_off_dmt:.4g} N"),
        ("tip", literal(q.profile)),
        ("normalized profile (the run's)", f"`{q.scene_profile}`"),
        ("slope at the contact edge", _g(q.edge_slope)),
    ]
    if reading is None:
        rows.append(("drift", unread))
    else:
        rows += [
            ("drift velocity", f"**{q.drift_velocity:.4g} m/s** ({q.drift_velocity * 100:.3g} cm/s)"),
            ("v*", f"{q.v_star:.4g} ({literal(reading['map'])}, nearest grid point)"),
            ("regime", literal(reading["regime"])),
            ("contact time per period", _g(q.contact_time, "s")),
            (
                "travel per period",
                f"{_g(q.travel_per_period, 'm')} = {_g(q.travel_over_wavelength)} wavelengths",
            ),
        ]
    tip = "sphere" if q.profile == "sphere" else f"particle with a {q.profile} tip"
    if rolling != ROLLING_NONE:
        body = {v: k for k, v in DESIGN_ROLLINGS.items()}.get(rolling)
        tip += f", {body}" if body else f", rolling with j = {rolling:g}"
    head = (
        f"**Device**: {literal(units.material(device.particle).name)} {literal(tip)}, R = "
        f"{device.radius:.4g} m, on {literal(units.material(device.substrate).name)}; f = "
        f"{device.frequency:.4g} Hz, A_y = {device.amplitude:.4g} m, pre-load "
        f"{device.preload:g} N"
    )
    table = ["| quantity | value |", "|---|---|", *(f"| {k} | {v} |" for k, v in rows)]
    notes = [f"* **warning:** {literal(w.message)}" for w in warnings] or ["*No validity warnings.*"]
    return "\n".join([head, "", *table, "", *notes])


def tip_form(owner, width=150):
    """The tip's widgets, bound to the designtip.Tip `owner` (the state, or
    the panel's own alone): (its kind's selector, {name: NumberField}, the
    fields' boxes, each shown for the kind that takes it).  Each size is checked
    by the library as typed (app/inputs.NumberField: its message)."""
    kind = pn.widgets.Select.from_param(
        owner.param.tip, label="particle tip", width=width, css_classes=["vt-design-tip"]
    )
    fields = {name: inputs.NumberField(owner, name, label, width=width) for name, label in TIP_LABELS.items()}
    boxes = [
        pn.Column(
            field,
            margin=0,
            css_classes=[f"vt-design-{name.replace('_', '-')}"],
            visible=pn.bind(lambda k, name=name: name in TIP_SIZES[k], owner.param.tip),
        )
        for name, field in fields.items()
    ]
    note = pn.pane.Markdown(
        TIP_NOTE,
        visible=pn.bind(lambda k: k != "sphere", owner.param.tip),
        sizing_mode="stretch_width",
        margin=(0, 10),
        css_classes=["vt-design-tip-note"],
    )
    return kind, fields, [*boxes, note]


class DesignPanel(pn.viewable.Viewer, limited(Scene, SCENE_LIMITS, ("mu",), name="DesignScene")):
    """The Design tab: its values (SI units), its widgets, the chart.

    The device and its particle's tip are `device` (a design.Device) and
    `particle_tip` (a designtip.Tip): the explorer's state, whose device
    the Units tab shows too (one form), or the panel's own alone.  Its mu
    (the chart's map's and the device's run's) is Scene's within the
    explorer's limits.  The chart's numbers are stored as typed; the
    library checks them when the chart is drawn (`draw`) and its refusal
    is shown in `alert`.  on_run(mu, periods): run the device's scene (the
    explorer's); jobs: the server's maps on demand (mapjobs.jobs() if None)."""

    device = param.ClassSelector(class_=Device, instantiate=False, doc="the device edited (SI units)")
    particle_tip = param.ClassSelector(class_=Tip, instantiate=False, doc="the particle's tip edited")
    font_scale = 1.0  # the chart's text (presentation mode's; set by the page)
    preset = param.Selector(default="paper", objects=[*PRESET_NAMES, CUSTOM_PRESET])
    surface_energy = param.Number(default=DEFAULT_SURFACE_ENERGY, doc="work of adhesion, J/m^2")
    x = param.Selector(default="frequency", objects=list(design.AXES))
    x_lo = param.Number(default=1e4)
    x_hi = param.Number(default=1e6)
    x_points = param.Integer(default=41)
    y = param.Selector(default="amplitude", objects=list(design.AXES))
    y_lo = param.Number(default=1e-9)
    y_hi = param.Number(default=5e-7)
    y_points = param.Integer(default=41)
    # the map computed for a chart no shipped map serves
    map_fidelity = param.Selector(default=design.COMPUTE_FIDELITY, objects=["preview", "standard"])
    map_periods = param.Number(default=2000.0, doc="the computed map's run length, periods")
    busy = param.Boolean(default=False)

    def __init__(self, on_run=None, jobs=None, state=None, **params):
        super().__init__(
            device=Device() if state is None else state,
            particle_tip=Tip() if state is None else state,
            **params,
        )
        self.on_run = on_run
        self.state = state
        self._jobs = jobs
        self._session = f"design-{id(self)}"  # its key in the server's map queue
        self._offer = None  # (MapRequest, values) of the map offered, not computing
        # the map computing (its Ticket in the server's queue, mapjobs):
        # cancelling its job cancels the session's request there
        self.map_work = LatestJob()
        self._map = None  # (ds, name) of the map on demand the chart reads
        self.chart = None  # the chart drawn (design_chart's Dataset)
        self.figure = None  # its Bokeh figure
        self.marked = None  # the device marked (units.DeviceSpec)
        self.quantities = self.reading = None
        self.warnings = []
        self._chart_map = None  # (ds, name) of the map on demand the chart read, or None
        self._marker = None  # the figure's device marker's source
        self._drawn_values = None  # the values the chart drawn was made with
        self._offered_values = None  # the values a draw offered a map for
        # the chart's drawing and a click's reading, off the event loop: the
        # latest of each wins (an older one's result is dropped)
        self.draws = LatestJob()
        self.marks = LatestJob()
        self.alert = refusal_alert("vt-design-alert")
        self.status = pn.pane.Markdown(HINT, sizing_mode="stretch_width", css_classes=["vt-design-status"])
        self.spinner = pn.indicators.LoadingSpinner(value=False, visible=False, width=24, height=24)
        self.chart_pane = pn.Column(
            sizing_mode="stretch_width", min_width=MIN_WIDTH, css_classes=["vt-design-chart"]
        )
        self.info = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-design-device"])
        self.note = pn.pane.Markdown("", sizing_mode="stretch_width")
        draw, compute = (lambda: pn.state.execute(self.draw)), (lambda: pn.state.execute(self.compute))
        self.draw_button = _button("Draw chart", "primary", "vt-design-draw", draw)
        self.offer = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-design-offer"])
        self.compute_button = _button("Compute this map", "success", "vt-design-compute", compute)
        self.cancel_button = _button("Cancel map", "warning", "vt-design-cancel", self.cancel)
        # what the map computing is doing (apart from the offer: a chart
        # drawn meanwhile may offer another map)
        self.progress = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-design-progress"])
        self.map_fields = pn.Row(
            pn.widgets.Select.from_param(
                self.param.map_fidelity,
                label="map fidelity",
                width=150,
                css_classes=["vt-design-map-fidelity"],
            ),
            inputs.NumberField(self, "map_periods", "map periods", width=150),
        )
        # a new fidelity or run length: the offer (and its estimate) anew
        self.param.watch(self._on_map_settings, ["map_fidelity", "map_periods"])
        self.offer_box = pn.Column(
            self.offer,
            self.map_fields,
            pn.Row(self.compute_button, self.cancel_button),
            self.progress,
            visible=False,
            sizing_mode="stretch_width",
        )
        run = ("Run this device's scene", "primary", "vt-design-run vt-ack-run", self.run_device)
        self.run_button = _button(*run, disabled=on_run is None)
        self._buttons()
        labels = {"mu": "mu (friction)", "surface_energy": "surface energy (J/m^2)"}
        labels.update({k: k.replace("_", " ") for k in AXIS_VALUES if "_" in k})  # "x lo", ...
        # (the chart's numbers have no bounds: a typed number is applied, the
        # library checks its range when the chart is drawn)
        self.fields = {k: inputs.NumberField(self, k, v, width=150) for k, v in labels.items()}
        if state is None:  # (shared, the Units tab's form is the device's)
            self.fields.update(
                {k: inputs.NumberField(self.device, k, v, width=150) for k, v in DEVICE_LABELS.items()}
            )
        self._presetting = False
        self.param.watch(self._on_preset, "preset")
        self.param.watch(self._on_axis, ["x", "y"])
        # alone, the preset applied; shared, the state's device stays (the
        # preset's axes only, and its label "custom" if the device is not its)
        self._on_preset(device=state is None)
        self._init_extras()
        self._layout = None
        self.tip_kind, self.tip_fields, self.tip_boxes = tip_form(self.particle_tip)
        # whether the particle rolls: the state's (the sidebar's selector
        # too), or the panel's own alone
        self.rolling_owner = state if state is not None else DesignRolling()
        self.rolling_view = RollingView(
            self.rolling_owner, width=320, options=DESIGN_ROLLINGS, label="particle body"
        )
        self.hollow_note = pn.pane.Markdown(
            HOLLOW_NOTE,
            sizing_mode="stretch_width",
            margin=(0, 10),
            css_classes=["vt-design-hollow"],
            visible=self.rolling_owner.rolling == "shell",
        )
        self.rolling_owner.param.watch(self._on_rolling, "rolling")
        # the last run of the device, if it rolled: its contact patch's check
        self.run_note = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["vt-design-rolling"])
        self.param.watch(
            self._on_changed, [*AXIS_VALUES, "mu", "surface_energy", "map_fidelity", "map_periods"]
        )
        self.device.param.watch(self._on_changed, [k for k in Device.param if k != "name"])
        self.particle_tip.param.watch(self._on_changed, list(TIP_FIELDS))

    def _on_rolling(self, event):
        self.hollow_note.visible = event.new == "shell"
        self._on_changed(event)

    def show_run_note(self, text):
        """The explorer's note on the last run of the device, if it rolled
        (UnitsPanel.rolling_note: its contact patch against the contact
        radius, a warning where it moved)."""
        self.run_note.object = text

    def _set_device(self, **values):
        """Set the device's values (a preset's, a click's); a value the
        device refuses (the state's limits) is said and nothing is set."""
        try:
            type(self.device)(**values)  # (each checked before any is set)
        except ValueError as exc:
            self._say(f"**The device cannot take these values:** {literal(exc)}")
            return False
        self.device.param.update(**values)
        return True

    def _on_changed(self, *events):
        """A value changed: the chart shown is marked stale if it was drawn
        for other values (and no longer once they are its own again)."""
        if not self.busy:
            self.status.object = self._shown_status()

    # ---------- values ----------
    def _on_preset(self, *events, device=True):
        """A preset chosen: its device (a sphere) and its chart's axes
        applied.  device=False (the state's device, opening the tab): its
        axes only, and the label "custom" if the device is not the preset's."""
        if self.preset == CUSTOM_PRESET:  # nothing applied: the values stay as typed
            self.note.object = "*Custom values (no preset applied).*"
            return
        p = design.preset(self.preset)
        values = preset_device(p)
        self._presetting = True
        try:
            if device and self._set_device(**values):
                self.particle_tip.tip = "sphere"
            axes = {}
            for a, (q, lo, hi, points) in (("x", p.x), ("y", p.y)):
                axes.update({a: q, f"{a}_lo": float(lo), f"{a}_hi": float(hi), f"{a}_points": int(points)})
            self.param.update(**axes)
        finally:
            self._presetting = False
        if not device and (
            self.particle_tip.tip != "sphere" or any(getattr(self.device, k) != v for k, v in values.items())
        ):
            self.preset = CUSTOM_PRESET
            return
        self.note.object = f"*{literal(p.note)}*"

    def _on_axis(self, *events):
        """A new quantity on an axis: its range becomes a decade around the
        device's value of it (the old range was in another unit).  A
        device value the library would refuse leaves the range as it is."""
        if self._presetting:
            return
        for e in events:
            value = getattr(self.device, e.new)
            if isinstance(value, (int, float)) and math.isfinite(value) and value > 0:
                lo, hi = float(f"{value / 10**0.5:.3g}"), float(f"{value * 10**0.5:.3g}")
                self.param.update(**{f"{e.name}_lo": lo, f"{e.name}_hi": hi})

    def fixed_quantity(self):
        third = [q for q in design.AXES if q not in (self.x, self.y)]
        return third[0] if len(third) == 1 else None

    def _fixed_text(self, *axes):
        q = self.fixed_quantity()
        return (
            "*x and y must be two different quantities*"
            if q is None
            else f"*fixed: {q} = the device's {q} ({UNITS[q]})*"
        )

    def values(self):
        """The values as typed (SI), for the library to check: the chart's,
        the device's (a material: its name, or a custom one's properties),
        whether its particle rolls, and its tip's (its kind and that kind's sizes; another kind's do
        not make the chart)."""
        tip = self.particle_tip
        names = ("mu", "surface_energy", *AXIS_VALUES, "map_fidelity", "map_periods")
        return {
            **{k: getattr(self, k) for k in names},
            "rolling": self.rolling_owner.rolling,
            **{k: getattr(self.device, k) for k in PRESET_DEVICE},
            **{k: self.device.material(k) for k in ("substrate", "particle")},
            **{k: getattr(tip, k) for k in ("tip", *tip.sizes())},
        }

    def field_errors(self):
        """The typed fields' messages: the panel's, and its tip's of the
        kind chosen (a hidden kind's size does not make the device)."""
        tips = [f for f in self.tip_fields.values() if f.name_ in self.particle_tip.sizes()]
        return [f.error for f in [*self.fields.values(), *tips, self.rolling_view] if f.error]

    # ---------- drawing ----------
    def _say(self, text):
        self.alert.param.update(object=text, visible=bool(text))

    @property
    def jobs(self):
        return self._jobs or mapjobs.jobs()

    async def draw(self):
        """Draw the chart for the values (off the event loop).  A refused
        value: the message in `alert`, the chart drawn before stays.  No
        shipped map serving them: the map they need is offered (`offer`),
        its estimate first; the map on demand read last is used if it
        serves them."""
        errors = self.field_errors()
        if errors:
            self._say("**Cannot draw the chart:** " + "; ".join(errors))
            return
        job = self.draws.start()
        values = self.values()
        self._busy(True, "Drawing the chart ...")
        try:
            chart_map = None
            try:
                result = await job.run(build_chart, values)
            except design.NoMapCovers as exc:
                result = None
                if self._map is not None:
                    try:
                        result = await job.run(build_chart, values, *self._map)
                        chart_map = self._map
                    except ValueError:  # (the values passed: the map does not serve them)
                        pass
                if result is None:
                    if self.draws.is_latest(job):
                        await self._offer_map(exc.need, values, job)
                    return
        except ValueError as exc:  # the library's InputError (TypeError kind too)
            if self.draws.is_latest(job):
                self._say(f"**Cannot draw the chart:** {literal(exc)}")
                self._busy(False, self._shown_status())
            return
        except Cancelled:
            return  # a newer draw was asked for meanwhile
        if not self.draws.is_latest(job):
            return
        self._offer = None  # served: nothing to offer
        self.offer.object = ""
        self.offer_box.visible = self.map_work.running  # (a map computing goes on)
        self._buttons()
        self._show_chart(values, result, chart_map)

    def _show_chart(self, values, result, chart_map):
        chart, fig, device, reading, q, warnings = result
        self._say("")
        with pn.io.hold():
            self.chart, self.figure, self._drawn_values = chart, fig, values
            self._offered_values = None
            self._chart_map = chart_map
            self._marker = _device_marker(fig)
            fig.on_event(Tap, self._on_tap)
            scale_fonts(fig, self.font_scale)
            self.chart_pane.objects = [pn.pane.Bokeh(fig, sizing_mode="stretch_width", min_width=MIN_WIDTH)]
            self._show_device(device, reading, q, warnings)
            self._show_chart_extras()
            self._busy(False, self._shown_status())

    # ---------- a map on demand for the chart ----------
    async def _offer_map(self, need, values, job):
        """Say why no shipped map serves the chart and offer the one it
        needs, with its estimated cost (or why it cannot be computed)."""
        reasons = literal("; ".join(need.shipped_problems))
        if need.profile != "sphere":  # (say why, in the tip's words)
            reasons = (
                f"the shipped maps are the sphere's (Hertz's contact law); this "
                f"particle's tip, {literal(tip_shape(values).name)}, runs the normalized "
                f"profile `{need.profile}` (another contact law N\\*(a\\*), "
                f"docs/MODEL.md section 10), so its chart reads a map of that profile"
            )
        if need.rolling != ROLLING_NONE:  # (and why a rolling particle's needs its own)
            rolling = ROLLING_CHART_NOTE.format(rolling=rolling_name(need.rolling))
            reasons = rolling if need.profile == "sphere" else f"{reasons}; {rolling}"
        head = f"**No shipped map serves this chart:** {reasons}."
        request, why = map_request(need, fidelity=values["map_fidelity"], periods=values["map_periods"])
        self._say("")
        self._offered_values = values
        self._show_unread_device(values)
        self.offer_box.visible = True
        self._offer = None
        if not self.map_work.running:
            self.progress.object = ""  # (a finished map's words)
        if request is None:
            self.offer.object = f"{head}\n\n**It cannot be computed here:** {literal(why)}."
            self._buttons()
            self._busy(False, self._shown_status())
            return
        n = request.points_per_axis()
        step = min(request.la_to - request.la_from, request.lm_to - request.lm_from) / (n - 1)
        what = (
            f"**The map it needs:** {request.title()}; log10 A* [{request.la_from:g}, "
            f"{request.la_to:g}], log10 m* [{request.lm_from:g}, {request.lm_to:g}], "
            f"{n} x {n} points at the finest level (a step of {step:.3g} decades or less)."
        )
        self.offer.object = f"{head}\n\n{what}\n\n*Estimating its cost ...*"
        self._buttons()
        jobs = self.jobs
        try:
            est, problems = await job.run(jobs.estimate, request)
        except Cancelled:
            return  # a newer draw was asked for meanwhile
        except Exception as exc:  # a bug: said, and logged by the caller's loop
            est, problems = None, [f"{type(exc).__name__}: {literal(exc)}"]
        if not self.draws.is_latest(job):
            return
        cost = "" if est is None else est.text(jobs.cores)
        refused = "".join(f"\n\n**Refused:** {literal(p)}." for p in problems)
        accuracy = mapaccuracy.note(request.fidelity, request.periods)
        self.offer.object = f"{head}\n\n{what} {cost}\n\n{accuracy}{refused}"
        self._offer = None if problems else (request, values)
        self._buttons()
        self._busy(False, self._shown_status())

    def _on_map_settings(self, *events):
        if self.offer_box.visible and not self.map_work.running and not self.busy:
            pn.state.execute(self.draw)

    def _buttons(self):
        computing = self.map_work.running
        self.compute_button.visible = self._offer is not None or computing
        self.compute_button.disabled = computing or self._offer is None
        self.cancel_button.visible = computing

    async def compute(self):
        """Compute the map offered (the server's queue; shared with every
        session asking for it) and draw the chart on it level by level."""
        if self._offer is None or self.map_work.running:
            return
        request, values = self._offer
        loop = asyncio.get_running_loop()
        updates = asyncio.Queue()

        def deliver(update):  # a worker thread: hand it to this loop
            loop.call_soon_threadsafe(updates.put_nowait, update)

        jobs = self.jobs
        job = self.map_work.start()
        try:
            jobs.submit(self._session, request, deliver)
        except mapjobs.MapRefused as exc:
            self.map_work.finish(job)
            self.progress.object = f"**Not computed:** {literal(exc)}."
            return
        job.when_cancelled(functools.partial(jobs.cancel, self._session))
        self._offer = None
        self._buttons()
        drawn = self.draws.job  # the chart asked for when the map was
        started = time.monotonic()
        n = request.points_per_axis()
        # (short: the chart's title names it; the offer says the rest)
        name = f"computed on this server: {request.fidelity}, {request.periods:g} periods"
        self.progress.object = f"Computing the chart's {n} x {n} map ({request.title()}) ..."
        while True:
            update = await updates.get()
            if not self.map_work.is_latest(job):
                return  # cancelled: its updates are no one's
            if update.kind == "chunk" and not updates.empty():
                continue  # a newer picture (or the level's) is waiting: draw that
            if update.kind == "queued":
                self.progress.object = f"{update.text.capitalize()} ..."
            elif update.kind in ("level", "chunk", "done"):
                drawn_from = self._map
                self._map = (update.ds, name)
                if update.shown:
                    # the finest level's chart stands: the verified map has its values
                    if self._chart_map is drawn_from:
                        self._chart_map = self._map
                elif self.draws.is_latest(drawn):  # the chart asked for is still the one shown
                    try:
                        result = await loop.run_in_executor(None, build_chart, values, update.ds, name)
                    except ValueError as exc:
                        result = None
                        self._say(f"**The chart could not be read on the map:** {literal(exc)}")
                    if result is not None and self.draws.is_latest(drawn):
                        self._show_chart(values, result, self._map)
                self.progress.object = progress_text(
                    update,
                    n,
                    time.monotonic() - started,
                    "The chart's map, from this server's cache ({done:,} of {total:,} points computed).",
                    "The chart's map is finished: {done:,} of {total:,} points computed in {seconds:.0f} s.",
                )
            elif update.kind == "failed":
                self.progress.object = f"**The map failed:** {update.text}"
            elif update.kind == "cancelled":
                self.progress.object = "Map cancelled."
            if update.final:
                self.map_work.finish(job)
                self._buttons()
                return

    def cancel(self):
        """Cancel the map computing (unless another session waits for it)."""
        if not self.map_work.running:
            return
        self.map_work.cancel()
        self.progress.object = (
            "Map cancelled: its finished points are kept on this "
            "server; computing it again resumes from them."
        )
        self._buttons()

    def close(self):
        """The session closed: its map stops unless another session waits."""
        self.map_work.cancel()

    # ---------- the device's scene ----------
    def run_device(self):
        """Run the device as the form shows it (the state's; not the chart
        drawn, which may be older) in the explorer, at the form's mu and map
        periods: its drift and time then also in SI units."""
        if self.on_run is None:
            return
        errors = self.field_errors()
        if errors:
            self._say("**Not run:** " + "; ".join(errors))
            return
        self.on_run(self.mu, self.map_periods)

    def stale(self):
        """Whether the chart shown was drawn for other values than the form's."""
        return self.chart is not None and self.values() != self._drawn_values

    def _shown_status(self):
        """The status line of the chart shown: what it is, under a banner
        while the form's values are not its own."""
        c = self.chart
        if c is None:
            return HINT
        text = literal(
            f"{c.attrs['particle']} on {c.attrs['substrate']}, "
            f"{c.sizes[c.attrs['y']]} x {c.sizes[c.attrs['x']]} points, "
            f"{c.attrs['fixed']} = {c.attrs['fixed_value']:.4g} "
            f"{c.attrs['fixed_units']}; map {c.attrs['map']} "
            f"({c.attrs['reading']}). Click the chart to move the device there "
            f"and run its scene."
        )
        if not self.stale():
            return f"*{text}*"
        banner = STALE_OFFERED if self._offered_values == self.values() else STALE
        return f"{banner} *The chart shown: {text}*"

    def _busy(self, on, text):
        self.busy = on
        self.spinner.value = self.spinner.visible = on
        self.draw_button.disabled = on
        self.status.object = text

    def _show_unread_device(self, values):
        """The table shows the device of `values`, its drift not read (its
        chart needs a map on demand): the table follows the device, not
        the chart shown."""
        try:
            device, shape = device_spec(values), tip_shape(values)
            q = design.device_quantities(device, None, values["surface_energy"], shape=shape)
            warnings = design.validity_warnings(device, values["surface_energy"], shape=shape)
        except ValueError:  # (the chart's check said it first)
            return
        self.info.object = device_text(
            device, None, q, warnings, values.get("rolling", ROLLING_NONE), UNREAD_OFFERED
        )

    def _show_device(self, device, reading, q, warnings):
        self.marked, self.reading, self.quantities, self.warnings = device, reading, q, warnings
        self.info.object = device_text(
            device, reading, q, warnings, (self._drawn_values or {}).get("rolling", ROLLING_NONE)
        )
        if self._marker is not None and self.chart is not None:
            xq, yq = self.chart.attrs["x"], self.chart.attrs["y"]
            keys = list(self._marker.data)
            if xq in keys and yq in keys:
                self._marker.data = {
                    **{k: [] for k in keys},
                    xq: [getattr(device, xq)],
                    yq: [getattr(device, yq)],
                }

    # ---------- custom materials, the preset's label, the chart's notes and files ----------
    def _init_extras(self):
        """The widgets of the custom materials, the chart-wide notes and the
        downloads (made with the panel; shown by __panel__)."""
        device = self.device
        self.custom_inputs = {
            k: pn.widgets.TextInput.from_param(
                device.param[f"{k}_custom"],
                label=f"{k}: E (Pa), nu, rho (kg/m^3)",
                width=230,
                placeholder=CUSTOM_EXAMPLE,
                visible=pn.bind(lambda v: v == CUSTOM_MATERIAL, device.param[k]),
                css_classes=[f"vt-design-{k}-custom"],
            )
            for k in ("substrate", "particle")
        }
        any_custom = pn.bind(lambda *m: CUSTOM_MATERIAL in m, device.param.substrate, device.param.particle)
        self.custom_row = pn.Row(*self.custom_inputs.values(), visible=any_custom, margin=(0, 0, 10, 0))
        self.param.watch(self._on_edit, list(AXIS_VALUES))
        device.param.watch(self._on_edit, [*PRESET_DEVICE, "substrate_custom", "particle_custom"])
        self.particle_tip.param.watch(self._on_edit, "tip")
        self.chart_notes = pn.pane.Markdown(
            "", visible=False, sizing_mode="stretch_width", css_classes=["vt-design-chart-notes"]
        )
        self.download_buttons = {
            fmt: pn.widgets.FileDownload(
                callback=functools.partial(self.chart_file, fmt),
                filename=f"vibtrans-design.{fmt}",
                label=DOWNLOAD_LABELS[fmt],
                color="light",
                width=95,
                disabled=True,
                css_classes=[f"vt-design-download-{fmt}"],
            )
            for fmt in (*FIGURE_FORMATS, *DATA_FORMATS)
        }
        self.download_note = pn.pane.Markdown(DOWNLOAD_HINT, margin=(5, 10))
        self.downloads = pn.FlexBox(
            self.download_note,
            *self.download_buttons.values(),
            flex_wrap="wrap",
            align_items="center",
            sizing_mode="stretch_width",
            css_classes=["vt-design-downloads"],
        )

    def _on_edit(self, *events):
        """A value of the preset's edited: the preset shown becomes "custom"
        (nothing re-applied).  A custom material's text counts only when
        that material is custom."""
        if self._presetting or self.preset == CUSTOM_PRESET:
            return
        if all(
            e.name.endswith("_custom") and getattr(self.device, e.name[:-7]) != CUSTOM_MATERIAL
            for e in events
        ):
            return
        self.preset = CUSTOM_PRESET

    def _show_chart_extras(self):
        """The chart drawn's notes, and its downloads enabled."""
        self.chart_notes.object = chart_text(self.chart)
        self.chart_notes.visible = True
        self.download_note.object = "*Download the chart shown (device marked):*"
        for b in self.download_buttons.values():
            b.disabled = False

    def chart_file(self, fmt):
        """The bytes (BytesIO) of a download of the chart shown: its figure
        (png, svg, pdf; the device marked) or its data (nc, csv)."""
        chart = self.chart
        if chart is None:
            raise ValueError("draw a chart first")
        if fmt in DATA_FORMATS:
            return read_back(functools.partial(design.write_chart_data, chart), f"design.{fmt}")
        if fmt not in FIGURE_FORMATS:
            raise ValueError(f"no such download: {fmt!r}")
        from vibtrans.products.export import export_design

        d = self.marked  # the device marked on the chart shown
        mark = None if d is None else (getattr(d, chart.attrs["x"]), getattr(d, chart.attrs["y"]))
        return exclusively(read_back, functools.partial(export_design, chart, device=mark), f"design.{fmt}")

    # ---------- a click on the chart ----------
    def _on_tap(self, event):
        if self.chart is not None and tapped(event):
            pn.state.execute(functools.partial(self.mark, event.x, event.y))

    async def mark(self, x, y):
        """Move the device to (x, y) of the chart drawn (its axes' units;
        4 significant digits), show its quantities and run its scene.  A
        click outside the chart's window moves nothing."""
        c = self.chart
        if c is None:
            return
        xq, yq = c.attrs["x"], c.attrs["y"]
        xs, ys = c[xq].values, c[yq].values
        if not (xs[0] <= x <= xs[-1] and ys[0] <= y <= ys[-1]):
            return
        x, y = float(f"{x:.4g}"), float(f"{y:.4g}")
        values = {**self._drawn_values, xq: x, yq: y}
        job = self.marks.start()
        try:
            got = await job.run(device_reading, values, c, *(self._chart_map or ()))
        except Cancelled:
            return  # a newer click was made meanwhile
        except ValueError as exc:
            self._say(f"**Cannot read the device:** {literal(exc)}")
            return
        if not self.marks.is_latest(job) or c is not self.chart:
            return
        self._say("")
        with pn.io.hold():
            if not self._set_device(**{xq: x, yq: y}):
                return
            self._show_device(*got)
        # a click runs the device's scene, as on the map: on the next tick,
        # holding the document's lock (the explorer sets Bokeh models)
        pn.state.execute(self.run_device, schedule=True)

    def _device_rows(self, row, f, select):
        """The device's form: the Units tab's (one form) when the device is
        the state's."""
        head = pn.pane.Markdown(
            "**The device** (the Units tab's too; marked on the chart; a click moves it and runs its scene)",
            margin=(0, 10),
        )
        tip = row(self.tip_kind, *self.tip_boxes)
        body = pn.Column(self.rolling_view, self.hollow_note, margin=0, sizing_mode="stretch_width")
        if self.state is not None:
            return [
                head,
                row(*device_form(self.device, width=180)),
                tip,
                body,
                row(f["mu"], f["surface_energy"]),
            ]
        return [
            row(
                select(self.device.param.substrate, label="substrate"),
                select(self.device.param.particle, label="particle"),
                f["preload"],
                f["mu"],
                f["surface_energy"],
            ),
            self.custom_row,
            head,
            row(f["frequency"], f["radius"], f["amplitude"]),
            tip,
            body,
        ]

    def __panel__(self):
        if self._layout is None:
            f = self.fields
            select = functools.partial(pn.widgets.Select.from_param, width=150)
            fixed = pn.pane.Markdown(
                pn.bind(self._fixed_text, self.param.x, self.param.y),
                sizing_mode="stretch_width",
            )
            # (rows that wrap: in half of a wide screen the tab is ~600 px wide)
            row = functools.partial(
                pn.FlexBox, flex_wrap="wrap", align_items="flex-start", sizing_mode="stretch_width"
            )
            controls = pn.Column(
                pn.pane.Markdown(INTRO, sizing_mode="stretch_width"),
                pn.Row(
                    select(self.param.preset, label="preset", css_classes=["vt-design-preset"]),
                    self.note,
                    sizing_mode="stretch_width",
                ),
                *self._device_rows(row, f, select),
                row(select(self.param.x, label="x axis"), f["x_lo"], f["x_hi"], f["x_points"]),
                row(select(self.param.y, label="y axis"), f["y_lo"], f["y_hi"], f["y_points"]),
                fixed,
                pn.Row(self.draw_button, self.spinner, self.run_button),
                sizing_mode="stretch_width",
                css_classes=["vt-design-fields"],
            )
            self._layout = pn.Column(
                controls,
                self.alert,
                self.status,
                self.chart_notes,
                self.offer_box,
                # the device's table beside the chart where both fit, else below it
                pn.FlexBox(
                    pn.Column(self.chart_pane, styles={"flex": "2 1 560px", "min-width": "0"}),
                    pn.Column(self.info, self.run_note, styles={"flex": "1 1 260px", "min-width": "0"}),
                    flex_wrap="wrap",
                    align_items="flex-start",
                    sizing_mode="stretch_width",
                ),
                self.downloads,
                sizing_mode="stretch_width",
                name="design",
            )
        return self._layout


# whether the particle rolls, for a Design tab alone (the explorer's is its state)
DesignRolling = limited(Scene, SCENE_LIMITS, ("rolling",), name="DesignRolling")
# the chart's axes: each one's quantity and range (a preset sets them)
AXIS_VALUES = tuple(k for k in DesignPanel.param if k.split("_")[0] in ("x", "y"))
