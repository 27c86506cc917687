"""The particle on the wave, animated: a side view of the substrate's surface
and the particle over a run's last periods at full resolution, and beside
it, in step, the contact seen from above (stick core inside the slip
annulus).

Plain Bokeh, as `live.py` (few models, canvas, built once per session and
fed through ColumnDataSources).  A run's frames (every sample of its
full-resolution window, or at most `MAX_FRAMES` of them evenly in time) go
to the browser once per run; playing, pausing and scrubbing run in the
browser (a CustomJS draws a frame; a JS interval advances the frame
index), with no server round trip per frame: the browser's own changes are
made with `setv(..., {sync: false})`, so they are not even sent to the
server.  `frame(i)` is the same drawing in Python: the first frame of a run
is drawn by the server (so the page is right before any script runs) and
the tests compare the browser's frames with it.

What is to scale and what is not (the side view says so): heights, the
particle's overlap with the surface a* (the Hertz approach) and the
particle's horizontal motion relative to the surface are in a0, equal on
both axes.  Two lengths are far too large to draw: the particle's radius R
and the wavelength (both many orders of magnitude above a0).  The particle
is drawn as a circle of radius rho, a tenth of the height its motion spans
and at least three times its largest overlap a* (a real particle's radius is
some 10^5 times its overlap: the overlap must stay a small cap of the
circle; a smaller circle was drawn sunk whole under the surface), and its
contact zone as Hertz's for a sphere of that radius (half-width
c sqrt(rho) a0, c the run's contact radius over the static one, sqrt(R a0)
for the sphere; a profile's own c(a*) as its run recorded it).  A
profile's particle is drawn as its tip's outline near the contact, closed
by the drawn circle's arc above (`tip_outline`); the sphere keeps its
circle, whose bottom that outline would be (z = r^2 / (2 rho)).  The wavelength is
drawn three views wide, so that the drawn surface's slope stays below ~0.3
(at 1.5 views, ~0.6: the material point was drawn resting on a steep slope
that cut into it; the model's surface under the particle is level).  The
model drops the wave's k_R x term (MODEL.md section 1: the surface under
the particle moves as u_y*(t), u_x*(t)); the drawn wave has that motion
directly under the particle and the phase of a wave travelling to +x
elsewhere, so its crests move right while the particle sits on the surface
exactly as computed.  The view moves with the particle (x - x*(t));
marks on the surface, points of the substrate, show it sliding under it.
"""

import decimal
import functools
import math

import numpy as np
import panel as pn
import xarray as xr
from bokeh.layouts import row
from bokeh.models import (
    Circle,
    ColumnDataSource,
    CustomJS,
    Div,
    Label,
    Line,
    Patch,
    Range1d,
    Scatter,
    Segment,
    Select,
    Slider,
    Title,
    Toggle,
    VArea,
)
from bokeh.plotting import figure

from vibtrans import Scene
from vibtrans.core.errors import InputError, InputTypeError
from vibtrans.core.kernels import substrate
from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.core.profiles import parse_profile
from vibtrans.products import plots
from vibtrans_explorer.session.state import is_sphere
from vibtrans_explorer.views.presentation import INPUT_FONT

MAX_FRAMES = 3000  # frames sent to the browser per run (~0.25 MB)
SIDE_W, SIDE_H = 460, 300  # the side view's plotting area, pixels (equal scales)
CIRCLE_PX = 300  # the contact circle's plotting area, pixels (square)
PLAYER = (100, 360, 150)  # the player's widths: its button, slider and speed selector
RHO_FRACTION = 0.1  # drawn particle radius / the height the motion spans
RHO_OVER_OVERLAP = 3.0  # drawn particle radius / the largest overlap a*, at least
WAVELENGTH_VIEWS = 3.0  # drawn wavelength / the view's width
# a profile's tip: its outline drawn out to this many static
# contact radii from the axis (as app/views/profile.py draws it), at most
# this share of the drawn radius (the body's arc above it), in so many points
TIP_CONTACT_RADII = 1.6
TIP_RHO_SHARE = 0.8
TIP_POINTS = 81
TIP_HEIGHT_SPHERES = 2.0  # a steeper tip's drawing ends at twice the sphere's height
MARK_COLOUR = "#08306b"  # a rolling particle's mark: a radius that turns with it
ARC_POINTS = 121
TABLE = 720  # samples per period of the surface's vertical motion
CURVE_POINTS = 161  # points of the drawn surface
MARKS_PER_WAVELENGTH = 8  # surface marks (points of the substrate)
TICK_MS = 40  # the player's clock tick
SPEEDS = (
    ("0.05", "0.05 periods/s"),
    ("0.1", "0.1 periods/s"),
    ("0.25", "0.25 periods/s"),
    ("0.5", "0.5 periods/s"),
    ("1", "1 period/s"),
    ("5", "5 periods/s"),
    ("20", "20 periods/s"),
    ("100", "100 periods/s"),
)
# the stretch of the run the animation shows: the full-resolution window
# ("window": the run's last periods recorded sample by sample), or the last
# so many periods of the run ("0": all of it), decimated: before the window the run
# is recorded at plots.OVERVIEW_SAMPLES per period (the drift shows, a hop
# within a period does not)
WINDOWS = {
    "the last periods at full resolution": "window",
    "the last 10 periods": "10",
    "the last 100 periods": "100",
    "the last 1000 periods": "1000",
    "the whole run (decimated)": "0",
}
DEFAULT_SPEED = "0.25"
# a run's geometry, the same for all its frames (the browser's `meta`)
META = "rho wavelength zone_scale spacing width decimals deformable unit rolls mark_cy".split()
# the sources drawn per frame (`frame`: their data)
DRAWN = ("surface", "particle", "marks", "zone", "contact", "tip", "mark")
PARTICLE_FILL = "#c6dbef"
SUBSTRATE_FILL = "#bcaaa4"


def _annulus_colours(stick, contact):
    """The contact circle's outer colour per frame, as plots.contact_circle
    colours it: stick everywhere (s = c), partial slip (0 < s < c), total
    sliding (s = 0)."""
    slip = np.where(stick <= 0, plots.STATE_COLORS[3], plots.STATE_COLORS[2])
    return np.where(stick < contact, slip, plots.STATE_COLORS[1])


@functools.lru_cache(maxsize=1)
def _example_device():
    """(R / a0, wavelength / a0) of the Units tab's default device, a 0.5 mm
    steel bead on glass at 108 kHz: how far from scale the side view is."""
    from vibtrans.core import units

    radius, frequency = 0.5e-3, 108e3
    n = units.to_normalized("glass", "steel", radius, frequency, 1e-9)
    return radius / n.a0, n.c_R / frequency / n.a0


def _fixed(v, decimals):
    """`v` with `decimals` decimals as JavaScript's toFixed writes it (ties
    away from zero, on the exact binary value; Python's format rounds ties
    to even: 39.40625 -> '39.4062', toFixed '39.4063')."""
    return str(
        decimal.Decimal(float(v)).quantize(
            decimal.Decimal(1).scaleb(-int(decimals)), rounding=decimal.ROUND_HALF_UP
        )
    )


def _short(v):
    """A length in 2 significant digits, powers of ten as e5 (not e+05)."""
    text = f"{v:.2g}"
    return text.replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")


def frame_indices(n, max_frames):
    """Indices of at most `max_frames` of `n` samples: all of them, or
    evenly spaced (first and last kept)."""
    if n <= max_frames:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_frames).round().astype(int))


def frame_indices_in_time(t, max_frames):
    """Indices of at most `max_frames` of the samples at times `t`
    (ascending): all of them, or those nearest to times evenly spaced over
    [t[0], t[-1]] (first and last kept): a run recorded at two rates (its
    overview and its full-resolution window) is drawn at one pace."""
    n = t.size
    if n <= max_frames:
        return np.arange(n)
    i = np.searchsorted(t, np.linspace(t[0], t[-1], max_frames)).clip(0, n - 1)
    return np.unique(i)


def _decimals(extent):
    """Decimals that show a length of this order to ~4 significant digits."""
    return int(min(8, max(0, 3 - math.floor(math.log10(max(extent, 1e-300))))))


# ---------------------------------------------------------------- the browser's drawing
# One frame, drawn from the run's frames, its geometry (meta) and the table
# of the surface's motion; `frame()` below is the same in Python.  Changes
# are made with {sync: false}: they stay in the browser.
_DRAW_JS = """
function draw(i) {
  const F = frames.data, M = meta.data, T = table.data.uy;
  const n = F.t.length;
  if (n == 0 || M.rho.length == 0) return;
  i = Math.max(0, Math.min(n - 1, Math.round(i)));
  const t = F.t[i], x = F.x[i], y = F.y[i], a = F.a[i], st = F.state[i];
  const g = F.g[i], ux = F.ux[i], uy = F.uy[i], c = F.c[i], s = F.s[i];
  const L = M.wavelength[0], rho = M.rho[0], q = M.zone_scale[0], sp = M.spacing[0];
  const W = M.width[0], d = M.decimals[0], deformable = M.deformable[0] > 0;
  const m = T.length - 1;
  // equal scales on both axes whatever width the page gives the frame (a
  // narrow page shrinks it below SIDE_W: the particle was drawn an egg)
  const iw = side.inner_width, ih = side.inner_height;
  if (iw > 0 && ih > 0) {
    const half = Math.min(W / 2, (side.y_range.end - side.y_range.start) * iw / ih / 2);
    if (Math.abs(side.x_range.end - half) > 1e-9 * half)
      side.x_range.setv({start: -half, end: half}, {sync: false});
  }
  function height(xi) {
    let p = t - xi / L;
    p -= Math.floor(p);
    let k = Math.floor(p * m);
    if (k > m - 1) k = m - 1;
    const w = p * m - k;
    return -g * (T[k] * (1 - w) + T[k + 1] * w);
  }
  const xs = surface.data.xi, z = new Float64Array(xs.length);
  for (let j = 0; j < xs.length; j++) z[j] = height(xs[j]);
  surface.setv({data: {xi: xs, z: z}}, {sync: false});
  particle.setv({data: {x: [0.0], y: [-y + rho], r: [rho]}}, {sync: false});
  const TS = tip_shape.data, ty = new Float64Array(TS.z.length);
  for (let j = 0; j < ty.length; j++) ty[j] = TS.z[j] - y;
  tip.setv({data: {x: TS.x, y: ty}}, {sync: false});
  if (M.rolls[0] > 0) {
    const th = -Math.PI / 2 + F.roll[i] / rho, cy = M.mark_cy[0] - y;
    mark.setv({data: {x0: [0.0], y0: [cy], x1: [rho * Math.cos(th)],
                      y1: [cy + rho * Math.sin(th)]}}, {sync: false});
  } else mark.setv({data: {x0: [], y0: [], x1: [], y1: []}}, {sync: false});
  const nm = marks.data.xi.length, k0 = Math.ceil((x - ux - W / 2) / sp);
  const mx = new Float64Array(nm), mz = new Float64Array(nm);
  for (let j = 0; j < nm; j++) { mx[j] = (k0 + j) * sp + ux - x; mz[j] = height(mx[j]); }
  marks.setv({data: {xi: mx, z: mz}}, {sync: false});
  const touching = deformable && st > 0 && c > 0;
  const zs = -uy, ce = touching ? c * q : NaN, se = touching ? s * q : NaN;
  zone.setv({data: {x0: [-ce, -se], x1: [ce, se], y: [zs, zs],
                    colour: [F.outer[i], stick_colour]}}, {sync: false});
  contact.setv({data: {c: [touching ? c : NaN], s: [touching ? s : NaN],
                       colour: [F.outer[i]]}}, {sync: false});
  let phase = t - Math.floor(t);
  const gap = a < 0 ? "gap " + (-a).toFixed(d) + " a0"
            : deformable ? "overlap a* = " + a.toFixed(d) + " a0" : "on the surface";
  side_title.setv({text: "t* = " + t.toFixed(4) + "   wave phase t* mod 1 = " + phase.toFixed(3)
                   + "\\n" + names[st] + "   y* = " + y.toFixed(d) + " a0   " + gap},
                  {sync: false});
  let ct;
  if (!deformable) ct = "material point: rigid, no contact area";
  else if (!touching) ct = "in flight: no contact";
  else ct = "from above: c = " + c.toFixed(3) + "\\n"
            + (isNaN(s) ? "" : "s = " + s.toFixed(3) + " ") + M.unit[0];
            // (two lines, c on the first: one line, then "c, s" on one,
            // were cut at the figure's width at 1024 pixels)
  contact_title.setv({text: ct}, {sync: false});
}
"""

# the slider moved (the player, or a hand): draw that frame
_ON_FRAME_JS = _DRAW_JS + "draw(cb_obj.value);"

# a new run (or none): back to its first frame
_ON_RUN_JS = (
    _DRAW_JS
    + """
if (slider.value != 0) slider.setv({value: 0}, {sync: false});
draw(0);
"""
)

# play / pause: a clock in periods, advanced by the wall time elapsed times
# the speed; the frame shown is the last one at or before it (the end wraps
# to the start).  A hand on the slider moves the clock there.
_PLAY_JS = (
    """
const key = "_vibtrans_anim_" + cb_obj.id;
const st = window[key] || (window[key] = {timer: null});
if (st.timer !== null) { clearInterval(st.timer); st.timer = null; }
if (!cb_obj.active) {
  cb_obj.setv({label: "\u25b6 Play"}, {sync: false});
} else {
  cb_obj.setv({label: "\u275a\u275a Pause"}, {sync: false});
  const t = frames.data.t;
  st.shown = slider.value;
  st.clock = t.length ? t[Math.min(slider.value, t.length - 1)] : 0.0;
  st.last = performance.now();
  st.timer = setInterval(() => {
    const t = frames.data.t, n = t.length;
    const now = performance.now(), dt = (now - st.last) / 1000.0;
    st.last = now;
    if (n < 2) return;
    if (slider.value != st.shown) st.clock = t[Math.min(slider.value, n - 1)];
    st.clock += parseFloat(speed.value) * dt;
    if (st.clock > t[n - 1]) st.clock = t[0];
    let lo = 0, hi = n - 1;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (t[mid] <= st.clock) lo = mid; else hi = mid - 1;
    }
    st.shown = lo;
    if (lo != slider.value) slider.setv({value: lo}, {sync: false});
  }, %d);
}
"""
    % TICK_MS
)


def mark_angle(roll, rho):
    """The angle (radians, counter-clockwise from +x) of a rolling
    particle's mark: the radius to the material point that started at the
    contact (straight down, -pi/2), turned by the rolled arc `roll` (a0)
    over the drawn radius `rho` (a0).  Counter-clockwise: omega > 0 moves
    the contact point towards +x (docs/MODEL.md section 11)."""
    # R / a0 is not known for a normalized scene: the drawn radius turns the
    # mark, so that its rim travels the rolled arc, to scale in a0
    return -0.5 * math.pi + roll / rho


def _tip_span(shape, q, span, height):
    """The tip drawn over |x| <= span, or less where its outline rises
    above `height` first (a steep power law, nearly a flat punch): there
    the span ends where the outline reaches that height (bisection on the
    monotone outline), so the body's arc closes it at a finite height."""

    def z(x):
        return float(shape.outline(np.array([x / q]))[0])

    if z(span) <= height:
        return span
    lo, hi = 0.0, span
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if z(mid) <= height else (lo, mid)
    return lo


def tip_outline(profile, rho):
    """(x, z) of a profile's particle as the side view draws it, in a0,
    z from its lowest point (the apex, at x = 0): the tip's outline
    (the library's `outline`, z / a0 at r over the static contact radius;
    that radius drawn sqrt(rho) a0, the contact zone's scale) for
    |x| <= X = min(TIP_CONTACT_RADII sqrt(rho), TIP_RHO_SHARE rho) (less for
    a tip steeper than twice the sphere's height there: _tip_span), closed
    by the arc of the drawn circle (radius rho, the body) through its ends."""
    q = math.sqrt(rho)
    X = min(TIP_CONTACT_RADII * q, TIP_RHO_SHARE * rho)
    shape = parse_profile(profile)
    # at most TIP_HEIGHT_SPHERES times the sphere's height at that span
    X = _tip_span(shape, q, X, TIP_HEIGHT_SPHERES * 0.5 * (X / q) ** 2)
    xs = np.linspace(-X, X, TIP_POINTS)
    zs = np.asarray(shape.outline(xs / q), float)
    z_end = float(shape.outline(np.array([X / q]))[0])
    centre = z_end + math.sqrt(rho * rho - X * X)
    start = math.atan2(z_end - centre, X)  # below the horizontal
    angles = np.linspace(start, math.pi - start, ARC_POINTS)[1:-1]
    return (np.concatenate([xs, rho * np.cos(angles)]), np.concatenate([zs, centre + rho * np.sin(angles)]))


def _view(width, height, limit, name):
    """A figure of the animation: its frame's size in pixels, both ranges
    [-limit, limit] until a run sets them, no tools."""
    fig = figure(
        frame_width=width,
        frame_height=height,
        x_range=Range1d(-limit, limit),
        y_range=Range1d(-limit, limit),
        tools="",
        toolbar_location=None,
        output_backend="canvas",
        title=Title(text="(no run)"),
        name=name,
    )
    fig.title.text_font_size = "9.5pt"
    fig.toolbar.logo = None
    return fig


class ParticleAnimation(pn.viewable.Viewer):
    """The particle on the wave over a run's full-resolution window: side
    view and contact circle in step, with play / pause, a frame slider and
    a speed choice, all in the browser.

        anim = ParticleAnimation()
        anim.show(scene, ds)   # ds = simulate(scene, window=(T - 2, T), ...)
        anim.clear()

    `max_frames`: at most this many frames per run go to the browser."""

    def __init__(self, max_frames=MAX_FRAMES, **params):
        super().__init__(**params)
        if isinstance(max_frames, bool) or not isinstance(max_frames, (int, np.integer)) or max_frames < 2:
            raise InputError(f"max_frames must be an integer >= 2, got {max_frames!r}")
        self.max_frames = int(max_frames)
        self.frames = ColumnDataSource(self._no_frames(), name="anim-frames")
        self.meta = ColumnDataSource({k: [] for k in META}, name="anim-meta")
        self.table = ColumnDataSource({"uy": []}, name="anim-table")
        self.surface = ColumnDataSource({"xi": [], "z": []}, name="anim-surface")
        self.particle = ColumnDataSource({"x": [], "y": [], "r": []}, name="anim-particle")
        # a profile's particle: its outline relative to its lowest point
        # (per run), and drawn (per frame; empty for the sphere)
        self.tip_shape = ColumnDataSource({"x": [], "z": []}, name="anim-tip-shape")
        self.tip = ColumnDataSource({"x": [], "y": []}, name="anim-tip")
        # a rolling particle's mark (per frame; empty for one that does not roll)
        self.mark = ColumnDataSource({"x0": [], "y0": [], "x1": [], "y1": []}, name="anim-mark")
        self.marks = ColumnDataSource({"xi": [], "z": []}, name="anim-marks")
        self.zone = ColumnDataSource({"x0": [], "x1": [], "y": [], "colour": []}, name="anim-zone")
        self.contact = ColumnDataSource({"c": [], "s": [], "colour": []}, name="anim-contact")
        self._build()
        self.runs = 0
        self._run = None  # (scene, ds) shown, for a new window
        # the contact circle beside the side view where both fit, else below
        # it (one Bokeh row squeezed it beside the side view at 1024 pixels,
        # its frame narrower than its title's lines): each figure a pane of
        # its own in a wrapping row
        self._pane = pn.Column(
            pn.pane.Bokeh(self.player),
            pn.FlexBox(
                pn.pane.Bokeh(self.side),
                pn.pane.Bokeh(self.circle),
                flex_wrap="wrap",
                align_items="flex-start",
            ),
            pn.pane.Bokeh(self.key),
            name="particle-animation",
            margin=0,
            sizing_mode="stretch_width",
        )
        self.window = pn.widgets.Select(
            label="show", options=WINDOWS, value="window", width=300, css_classes=["vt-anim-window"]
        )
        self.window.param.watch(self._on_window, "value")
        self._panel = pn.Column(self.window, self._pane, margin=0)

    @staticmethod
    def _no_frames():
        return {k: [] for k in ("t", "x", "y", "a", "state", "c", "s", "g", "ux", "uy", "outer", "roll")}

    # ------------------------------------------------------------ figures
    def _build(self):
        side = _view(SIDE_W, SIDE_H, 1.0, "anim-side")
        side.xaxis.axis_label = "x - x*(t)  (a0; the view moves with the particle)"
        side.yaxis.axis_label = "height -y  (a0, up)"
        self.ground = VArea(x="xi", y1="z", y2=-1.0, fill_color=SUBSTRATE_FILL, fill_alpha=1.0)
        side.add_glyph(self.surface, self.ground)
        # the particle over the substrate and under its surface line: its
        # overlap with the surface (the Hertz approach a*) shows below the line
        body = dict(fill_color=PARTICLE_FILL, fill_alpha=0.85, line_color="black", line_width=1.5)
        self.particle_glyph = side.add_glyph(self.particle, Circle(x="x", y="y", radius="r", **body))
        self.tip_glyph = side.add_glyph(self.tip, Patch(x="x", y="y", **body))
        side.add_glyph(
            self.mark, Segment(x0="x0", y0="y0", x1="x1", y1="y1", line_color=MARK_COLOUR, line_width=2.5)
        )
        side.add_glyph(
            self.mark,
            Scatter(x="x1", y="y1", marker="circle", size=7, fill_color=MARK_COLOUR, line_color=MARK_COLOUR),
        )
        side.add_glyph(self.surface, Line(x="xi", y="z", line_color="#4e342e", line_width=2))
        side.add_glyph(
            self.marks,
            Scatter(x="xi", y="z", marker="triangle", size=8, fill_color="#4e342e", line_color="#4e342e"),
        )
        side.add_glyph(
            self.zone,
            Segment(x0="x0", y0="y", x1="x1", y1="y", line_color="colour", line_width=7, line_cap="round"),
        )
        side.add_layout(
            Label(
                x=8,
                y=SIDE_H - 40,
                x_units="screen",
                y_units="screen",
                text="wave travels to +x \u2192\nphase 0.5: crest under the particle",
                text_font_size="9pt",
                background_fill_color="white",
                background_fill_alpha=0.7,
            )
        )
        # short lines: a long one was cut at the figure's edge at 1024 pixels
        self.scale_notes = [
            Title(text="", text_font_size="8.5pt", text_font_style="italic") for _ in range(4)
        ]
        for note in self.scale_notes:
            side.add_layout(note, "below")
        self.side = side

        circ = _view(CIRCLE_PX, CIRCLE_PX, 1.1, "anim-circle")
        circ.xaxis.axis_label = "x  (sqrt(R a0))"
        circ.yaxis.axis_label = "z  (sqrt(R a0))"
        # the static contact under the weight alone: c = 1 (a* = 1)
        self.static_contact = circ.add_glyph(
            ColumnDataSource({"r": [1.0]}),
            Circle(x=0.0, y=0.0, radius="r", fill_alpha=0.0, line_color="grey", line_dash="dotted"),
        )
        # the contact, and its stick core over it
        at_centre = dict(x=0.0, y=0.0, line_color="black")
        circ.add_glyph(self.contact, Circle(radius="c", fill_color="colour", fill_alpha=0.9, **at_centre))
        core = Circle(radius="s", fill_color=plots.STATE_COLORS[1], line_dash="dashed", **at_centre)
        circ.add_glyph(self.contact, core)
        self.circle_note = Title(text="", text_font_size="8.5pt", text_font_style="italic")
        circ.add_layout(self.circle_note, "below")
        self.circle = circ

        self.slider = Slider(
            start=0, end=1, value=0, step=1, title="frame", width=PLAYER[1], disabled=True, name="anim-frame"
        )
        self.play = Toggle(
            label="\u25b6 Play", width=PLAYER[0], disabled=True, button_type="success", name="anim-play"
        )
        # (its text follows the page's root size, as the Panel widgets' do)
        self.speed = Select(
            title="speed",
            value=DEFAULT_SPEED,
            options=list(SPEEDS),
            width=PLAYER[2],
            name="anim-speed",
            stylesheets=[INPUT_FONT],
        )
        args = {k: getattr(self, k) for k in ("frames", "meta", "table", "tip_shape", "slider", *DRAWN)}
        args.update(side=side, side_title=side.title, contact_title=circ.title, names=list(STATE_NAMES))
        args.update(stick_colour=plots.STATE_COLORS[1])
        self.slider.js_on_change("value", CustomJS(args=args, code=_ON_FRAME_JS))
        # the frame's size known (or changed) in the browser: its scales made equal
        side.js_on_change("inner_width", CustomJS(args=args, code=_DRAW_JS + "draw(slider.value);"))
        on_run = CustomJS(args=args, code=_ON_RUN_JS)
        for source in (self.frames, self.meta, self.table, self.tip_shape):
            source.js_on_change("data", on_run)
        self.play.js_on_change(
            "active",
            CustomJS(args=dict(frames=self.frames, slider=self.slider, speed=self.speed), code=_PLAY_JS),
        )
        swatch = (
            '<span style="display:inline-block;width:11px;height:11px;'
            'background:{};border:1px solid #555;margin:0 3px 0 10px"></span>{}'
        )
        self.key = Div(text="", sizing_mode="stretch_width")
        self._key_head = (
            "<b>contact state</b>"
            + "".join(swatch.format(plots.STATE_COLORS[k], STATE_NAMES[k]) for k in (1, 2, 3))
            + " &nbsp; (flight: no contact zone). Side view: the contact zone on the "
            "surface, its stick core green; right: the contact seen from above, the stick "
            "core (radius s) inside the slip annulus (out to the contact radius c). "
            "Triangles: points of the substrate's surface (they show it sliding under "
            "the particle).<br>"
        )
        # the player above the figures: at 1024 pixels, below them its speed
        # selector was off the page's right edge
        self.player = row(self.play, self.slider, self.speed)

    # ------------------------------------------------------------ data
    def show(self, scene, ds):
        """Show a run: `scene` (a vibtrans Scene) and its Dataset from
        `simulate(scene, window=(t0, t1), ...)`; the frames are the samples
        of the window [t0, t1] (all of them, or `max_frames` evenly in
        time).  One message to the browser (data and ranges only)."""
        chosen = self.window.value
        frames, note = self._frames(scene, ds, None if chosen == "window" else float(chosen))
        self._run = (scene, ds)
        with pn.io.hold():
            self.play.active = False
            self._set_run(scene, frames, note)
        self.runs += 1

    def _on_window(self, event):
        if self._run is not None:
            self.show(*self._run)

    def clear(self):
        """No run: empty figures, the player stopped."""
        with pn.io.hold():
            self.play.active = False
            self.play.disabled = self.slider.disabled = True
            self.frames.data = self._no_frames()
            self.meta.data = {k: [] for k in self.meta.data}
            self.table.data = {"uy": []}
            for source in (self.tip_shape, *(getattr(self, name) for name in DRAWN)):
                source.data = {k: [] for k in source.data}
            self.side.title.text = self.circle.title.text = "(no run)"
            for note in (*self.scale_notes, self.circle_note):
                note.text = ""
            self.key.text = ""

    def _frames(self, scene, ds, periods=None):
        """The frames (dict of arrays) of a run's window and a note on them.
        periods: None, the run's full-resolution window; else the run's
        last `periods` (0: the whole run), at most `max_frames` frames evenly
        in time."""
        if not isinstance(scene, Scene):
            raise InputTypeError(f"scene must be a vibtrans Scene, got {type(scene).__name__}")
        if not isinstance(ds, xr.Dataset) or "time" not in ds.dims:
            raise InputTypeError(
                f"ds must be the Dataset of simulate(scene, window=...), got {type(ds).__name__}"
            )
        w0, w1 = ds.attrs.get("window_start"), ds.attrs.get("window_end")
        if w0 is None or w1 is None:
            raise InputError(
                "ds has no full-resolution window: run it with simulate(scene, window=(T - 2, T))"
            )
        for key in ("amplitude", "mass", "model", "tau", "nu"):
            if ds.attrs.get(key) != getattr(scene, key):
                raise InputError(
                    f"ds is not a run of this scene: its {key} is "
                    f"{ds.attrs.get(key)!r}, the scene's {getattr(scene, key)!r}"
                )
        t_all = ds["time"].values
        full = (w0, w1)  # the run's full-resolution window
        if periods is not None:
            if not (isinstance(periods, (int, float)) and periods >= 0):
                raise InputError(f"periods must be a number >= 0 (0: the whole run), got {periods!r}")
            w1 = float(t_all[-1])
            w0 = float(t_all[0]) if periods == 0 else max(float(t_all[0]), w1 - periods)
        start = int(np.searchsorted(t_all, w0, side="left"))
        stop = int(np.searchsorted(t_all, w1, side="right"))
        n = stop - start
        if n < 1:
            raise InputError(f"ds has no samples in its window [{w0:g}, {w1:g}]")
        # isel: a label-based sel builds a pandas index of the times first
        if periods is None:
            pick = start + frame_indices(n, self.max_frames)
        else:  # sampled at two rates: evenly in time
            pick = start + frame_indices_in_time(t_all[start:stop], self.max_frames)
        win = ds.isel(time=pick)
        t = win["time"].values
        A, r, tau = float(scene.amplitude), float(scene.r), float(scene.tau)
        g = np.array([substrate.ramp(ti, tau)[0] for ti in t])
        u = np.array([substrate.surface_motion(ti, A, r, tau)[:2] for ti in t]).reshape(-1, 2)
        c = win["contact_radius"].values
        s = win["stick_radius"].values
        state = win["state"].values.astype(np.int8)
        outer = _annulus_colours(s, c)
        if scene.model == "vertical":
            # no tangential force: no stick core or slip annulus, the contact
            # in its state's colour (its stick radius is recorded as 0, which
            # the rule above would colour as total sliding)
            s = np.full_like(c, np.nan)
            outer = np.array([plots.STATE_COLORS[k] for k in state])
        # a rolling particle's rolled arc q* (a0; plots.rolls), else none
        roll = win["roll"].values if plots.rolls(win) else np.zeros(t.size)
        frames = dict(t=t, x=win["x"].values, y=win["y"].values, a=win["a"].values, state=state, c=c, s=s)
        frames.update(g=g, ux=u[:, 0], uy=u[:, 1], outer=outer, roll=roll)
        span = f"the last {w1 - w0:g} periods (t* = {w0:g} to {w1:g})"
        if periods is not None and w0 < full[0]:
            return frames, (
                f"Frames: {pick.size} of the {n} samples of {span}, evenly spaced in time. "
                f"Before t* = {full[0]:g} the run is recorded at {plots.OVERVIEW_SAMPLES} "
                f"samples per period: the particle's travel shows, its motion within a "
                f"period does not (choose the last periods at full resolution for that)."
            )
        if pick.size == n:
            note = f"Frames: all {n} samples of {span}, the run's full resolution."
        else:
            note = (
                f"Frames: {pick.size} of the {n} samples of {span}, evenly spaced in "
                f"time (one in about {n / pick.size:.1f}: decimated for the browser)."
            )
        return frames, note

    def _set_run(self, scene, frames, note):
        A, r = float(scene.amplitude), float(scene.r)
        deformable = scene.model != "point-mass"
        neg_y = -frames["y"]
        surf = float(frames["g"].max()) * A
        low, high = min(neg_y.min(), -surf), max(neg_y.max(), surf)
        extent = max(high - low, 1.0)  # 1 a0: the static compression's scale
        overlap = float(frames["a"].max()) if deformable else 0.0
        rho = max(RHO_FRACTION * extent, RHO_OVER_OVERLAP * overlap)
        # the particle's drawing: the circle, or a profile's tip and the arc above
        drawn_tip = deformable and not is_sphere(scene.profile)
        tip_x, tip_z = tip_outline(scene.profile, rho) if drawn_tip else (np.zeros(0),) * 2
        height = float(tip_z.max()) if drawn_tip else 2.0 * rho
        top = max(neg_y.max() + height, surf)
        z0 = low - 0.2 * (top - low)  # some substrate below the lowest point
        z1 = top + 0.15 * (top - low)  # room for the label above the highest
        width = (z1 - z0) * SIDE_W / SIDE_H
        wavelength = WAVELENGTH_VIEWS * width
        spacing = wavelength / MARKS_PER_WAVELENGTH
        phase = np.linspace(0.0, 1.0, TABLE + 1)
        # the surface's vertical motion over one period (per unit ramp G):
        # the library's formula, sampled; the browser interpolates it
        table = substrate.wave_motion.py_func(
            np.cos(substrate.TWO_PI * phase), np.sin(substrate.TWO_PI * phase), 1.0, 0.0, A, r
        )[1]
        self.side.x_range.update(start=-width / 2, end=width / 2)
        self.side.y_range.update(start=z0, end=z1)
        self.ground.y2 = z0
        # the contact radii: the run's own (its records' c: the profile's
        # c(a*), over the static contact radius, sqrt(R a0) for the sphere)
        sphere = is_sphere(scene.profile)
        unit = "(sqrt(R a0))" if sphere else "(static contact radii)"
        self.circle.xaxis.axis_label = f"x  {unit}"
        self.circle.yaxis.axis_label = f"z  {unit}"
        cmax = float(np.nanmax(frames["c"])) if deformable and frames["c"].size else 0.0
        R = 1.1 * max(cmax, 1.0)
        self.circle.x_range.update(start=-R, end=R)
        self.circle.y_range.update(start=-R, end=R)
        rolls = scene.rolling != "none"
        # the mark turns about the body's centre: the circle's, over its lowest point
        mark_cy = float(tip_z.max()) - rho if drawn_tip else rho
        self.meta.data = {
            "rho": [rho],
            "wavelength": [wavelength],
            "zone_scale": [math.sqrt(rho)],
            "spacing": [spacing],
            "width": [width],
            "decimals": [_decimals(extent)],
            "deformable": [int(deformable)],
            "unit": [unit],
            "rolls": [int(rolls)],
            "mark_cy": [mark_cy],
        }
        self.table.data = {"uy": table}
        self.tip_shape.data = {"x": tip_x, "z": tip_z}
        self.particle_glyph.visible = not drawn_tip
        self.tip_glyph.visible = drawn_tip
        self.frames.data = frames
        n = frames["t"].size
        self.surface.data = {
            "xi": np.linspace(-0.51 * width, 0.51 * width, CURVE_POINTS),
            "z": np.zeros(CURVE_POINTS),
        }
        nm = int(math.ceil(width / spacing)) + 2
        self.marks.data = {"xi": np.zeros(nm), "z": np.zeros(nm)}
        self.slider.update(end=max(n - 1, 1), value=0, disabled=n < 2)
        self.play.disabled = n < 2
        self._draw(0)
        self.static_contact.visible = deformable
        self.circle_note.text = (
            "a rigid point has no contact area"
            if not deformable
            else "dotted: the static contact, c = 1"
            + ("\nvertical model: no tangential force, no stick core" if scene.model == "vertical" else "")
            + ("" if sphere else f"\nc(a*) the {scene.profile} profile's")
        )
        R_a0, wave_a0 = _example_device()
        notes, scaled = (
            self.scale_notes,
            ", the overlap a*." if deformable else ". Material point: the particle only.",
        )
        notes[0].text = f"Not to scale: particle radius drawn {_short(rho)} a0 (real R ~ {_short(R_a0)} a0*),"
        notes[1].text = f"wavelength {_short(wavelength)} a0 (real ~ {_short(wave_a0)} a0*)"
        notes[2].text = f"To scale (a0): heights, the motion along x{scaled}"
        notes[3].text = "*a 0.5 mm steel bead on glass at 108 kHz"
        zone = (
            (f"the contact zone drawn as Hertz's for the drawn radius: half-width c sqrt({rho:.3g}) a0. ")
            if deformable and sphere
            else (
                f"the particle drawn with its {scene.profile} tip: the tip's outline near "
                f"the contact (z to scale in a0; r in static contact radii, each drawn "
                f"sqrt({rho:.3g}) a0), its apex at the particle's lowest point, on a body "
                f"drawn as a circle; its contact zone's half-width c sqrt({rho:.3g}) a0 with "
                f"c the profile's own contact radius over the static one. "
            )
            if deformable
            else "Material point: no contact zone and no contact circle (rigid contact). "
        )
        turning = (
            f"The particle rolls ({scene.rolling}): the dark radius marks its material "
            f"point that started at the contact and turns by the rolled arc q* over the "
            f"drawn radius ({_short(rho)} a0: the real R/a0 is not known for a "
            f"normalized scene), so that its rim travels q*, to scale in a0. "
            if rolls
            else ""
        )
        self.key.text = self._key_head + zone + turning + note

    def frame(self, i):
        """Frame i drawn (what the browser draws for it): the data of each
        glyph source and the two titles."""
        F, M = self.frames.data, self.meta.data
        i = int(max(0, min(len(F["t"]) - 1, round(i))))
        t, x, y, a, st = F["t"][i], F["x"][i], F["y"][i], F["a"][i], int(F["state"][i])
        g, ux, uy, c, s = F["g"][i], F["ux"][i], F["uy"][i], F["c"][i], F["s"][i]
        L, rho, q, sp = M["wavelength"][0], M["rho"][0], M["zone_scale"][0], M["spacing"][0]
        W, d, deformable = M["width"][0], M["decimals"][0], bool(M["deformable"][0])
        T = np.asarray(self.table.data["uy"])
        m = T.size - 1

        def height(xi):
            p = t - xi / L
            p = p - np.floor(p)
            k = np.minimum(np.floor(p * m), m - 1).astype(int)
            w = p * m - k
            return -g * (T[k] * (1 - w) + T[k + 1] * w)

        xs = np.asarray(self.surface.data["xi"])
        nm = len(self.marks.data["xi"])
        k0 = math.ceil((x - ux - W / 2) / sp)
        mx = (k0 + np.arange(nm)) * sp + ux - x
        touching = deformable and st > 0 and c > 0
        ce, se = (c * q, s * q) if touching else (np.nan, np.nan)
        zs = -uy
        gap = (
            f"gap {_fixed(-a, d)} a0"
            if a < 0
            else f"overlap a* = {_fixed(a, d)} a0"
            if deformable
            else "on the surface"
        )
        if not deformable:
            ct = "material point: rigid, no contact area"
        elif not touching:
            ct = "in flight: no contact"
        else:
            ct = (
                f"from above: c = {_fixed(c, 3)}\n"
                + ("" if np.isnan(s) else f"s = {_fixed(s, 3)} ")
                + M["unit"][0]
            )
        TS = self.tip_shape.data
        # a rolling particle's mark: from the body's centre to its rim (else none)
        th, cy = mark_angle(F["roll"][i], rho), M["mark_cy"][0] - y
        ends = (0.0, cy, rho * math.cos(th), cy + rho * math.sin(th))
        mark = {k: np.array([v] if M["rolls"][0] else []) for k, v in zip(("x0", "y0", "x1", "y1"), ends)}
        return {
            "surface": {"xi": xs, "z": height(xs)},
            "particle": {"x": np.array([0.0]), "y": np.array([-y + rho]), "r": np.array([rho])},
            "tip": {"x": np.asarray(TS["x"], float), "y": np.asarray(TS["z"], float) - y},
            "mark": mark,
            "marks": {"xi": mx, "z": height(mx)},
            "zone": {
                "x0": np.array([-ce, -se]),
                "x1": np.array([ce, se]),
                "y": np.array([zs, zs]),
                "colour": [F["outer"][i], plots.STATE_COLORS[1]],
            },
            "contact": {
                "c": np.array([c if touching else np.nan]),
                "s": np.array([s if touching else np.nan]),
                "colour": [F["outer"][i]],
            },
            "side_title": (
                f"t* = {_fixed(t, 4)}   wave phase t* mod 1 = "
                f"{_fixed(t - math.floor(t), 3)}\n{STATE_NAMES[st]}   "
                f"y* = {_fixed(y, d)} a0   {gap}"
            ),
            "contact_title": ct,
        }

    def _draw(self, i):
        f = self.frame(i)
        for name in DRAWN:
            getattr(self, name).data = f[name]
        self.side.title.text = f["side_title"]
        self.circle.title.text = f["contact_title"]

    def references(self):
        """Every Bokeh model of the animation's figures and player."""
        return {m for part in (self.player, self.side, self.circle, self.key) for m in part.references()}

    def scale_sizes(self, factor):
        """The player's button and speed selector at `factor` times their
        width (presentation mode: their text grows), its slider shorter by
        as much, so that the player keeps its width."""
        play, slider, speed = PLAYER
        self.play.width, self.speed.width = round(play * factor), round(speed * factor)
        self.slider.width = round(slider - (factor - 1.0) * (play + speed))

    def __panel__(self):
        return self._panel
