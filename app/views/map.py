"""The drift map: the shipped map of the selected model and mu (or both
models side by side, their zoom linked), the jumping boundary, the
resonances, the paper points, the selected scene (yellow) and the Units
tab's device (green diamond); a click runs the scene there."""

import collections
import functools
import logging
import math
import re
import threading
import uuid

import holoviews as hv
import numpy as np
import panel as pn
from bokeh.core.serialization import Deserializer
from bokeh.events import Tap
from bokeh.models import (
    AllIndices,
    CDSView,
    ColorBar,
    ColumnDataSource,
    CustomJSTicker,
    CustomJSTickFormatter,
    FixedTicker,
    GlyphRenderer,
    HoverTool,
    Legend,
    Scatter,
    Selection,
    Span,
    UnionRenderers,
)

from vibtrans import Cancelled
from vibtrans.analysis.summary import CHAOS_LYAPUNOV, V0
from vibtrans.core.params import MAP_LOG_AMPLITUDE, MAP_LOG_MASS
from vibtrans.core.profiles import linear_resonance_mass
from vibtrans.products import plots
from vibtrans_explorer.server import data
from vibtrans_explorer.session.latest import LatestJob, at_next_tick
from vibtrans_explorer.session.state import is_sphere, within
from vibtrans_explorer.views.render import rendered

log = logging.getLogger("vibtrans.explorer")

MAP_HEIGHT = 460
MIN_WIDTH = 420
# the map's data area, px: fixed, so that a key that grows below it (orbit
# curves, the Lyapunov layer) or larger fonts (presentation mode) make the
# figure taller instead of the map smaller
MAP_FRAME_HEIGHT = 330
MODELS = ("deformable", "point-mass")


LAYERS = ("drift velocity", "Lyapunov exponent")
DRIFT_LAYER, LYAPUNOV_LAYER = LAYERS
NO_ORBITS = "no orbit curves"


def _unavailable(text):
    return hv.Text(0.0, 0.0, text).opts(height=MAP_HEIGHT, xaxis=None, yaxis=None)


def tapped(event):
    """Whether a click on a figure has finite coordinates (on its data area)."""
    x, y = event.x, event.y
    return x is not None and y is not None and math.isfinite(x) and math.isfinite(y)


def in_document(source, data):
    """Set a ColumnDataSource's data from a watcher of the page's state.
    In a served session such a watcher may run where Panel applies a
    widget's change from the browser without the document's lock (its
    `unlocked`): a plain Bokeh model changed there is lost, with
    "_pending_writes should be non-None" in the server's log (then
    typed values did not move the map's marker).  So the change goes to
    the document's next tick, which holds the lock; outside a server, now."""

    def apply():
        source.data = data

    at_next_tick(source.document, apply)


def map_element(model, mu, v0, chaotic, layer=DRIFT_LAYER, orbits=NO_ORBITS):
    """The map of a model and mu (HoloViews): the shipped drift map, or the
    chaos indicator's (layer "Lyapunov exponent": the vertical motion's,
    the same for every mu), the jumping boundary, the resonances, the
    paper points, and (orbits "period-1 orbit curves", deformable) the period-1 orbit's
    period doubling and stability region."""
    try:
        ds = data.drift_map(model, mu)
    except data.MapUnavailable:  # the reason (with the file) is said at session start
        return _unavailable(f"No shipped map: {model}, mu = {mu:g}")  # (the note above says more)
    if layer == LYAPUNOV_LAYER:
        lyapunov = data.lyapunov_map(model)
        if lyapunov is None:
            return _unavailable(f"No usable Lyapunov map for {model}: show the drift velocity instead")
        el = plots.lyapunov_map(lyapunov, CHAOS_LYAPUNOV)
        title = f"Lyapunov exponent of the vertical motion\n{model} (any mu)"
    else:
        # every map of the same parts (the grey layer and the resonances
        # there, hidden where they show nothing): a change of model or of
        # the chaotic points' colour updates the shown figure in place
        el = plots.drift_map(ds, v0=v0, chaotic=chaotic, title=f"{model}, mu = {mu:g}", always_grey=True)
        # (two lines: on one, the title was wider than the map's frame at 1024
        # pixels in presentation mode)
        title = f"<v*> over 2000 periods\n{model}, mu = {mu:g}"
    vertical = data.vertical_curve()
    if vertical is not None:
        el = el * plots.jumping_boundary(vertical, model).select(log_amplitude=MAP_LOG_AMPLITUDE)
        el = el * plots.resonance_lines(vertical, shown=model == "deformable")
    chart = data.period_one_chart()
    if orbits == "period-1 orbit curves" and model == "deformable" and chart is not None:
        el = el * plots.period_one_curves(chart)
    # white on the Lyapunov layer's dark colours, black on the drift's light ones
    el = el * plots.paper_points(model, "white" if layer == LYAPUNOV_LAYER else "black")
    return el.opts(hv.opts.Image(height=MAP_HEIGHT, title=title))


class _Renders:
    """The last `size` results of `make(*setting)` (a setting: a tuple of
    positional arguments), shared by every session and thread.  Unlike
    functools.lru_cache it says whether a setting is in (`in`: a session
    then shows it at once, else loads it off the event loop), and a
    setting asked for by two threads at once is made once: the second
    waits for the first's result."""

    def __init__(self, make, size):
        self.make, self.size = make, size
        self._done = collections.OrderedDict()
        self._making = {}  # setting -> the lock held while it is made
        self._lock = threading.Lock()
        functools.update_wrapper(self, make)

    def __contains__(self, setting):
        with self._lock:
            return setting in self._done

    def _cached(self, setting):
        with self._lock:
            if setting in self._done:
                self._done.move_to_end(setting)
                return True, self._done[setting]
            return False, self._making.setdefault(setting, threading.Lock())

    def __call__(self, *setting):
        found, value = self._cached(setting)
        if found:
            return value
        with value:  # (the setting's lock: one thread makes it)
            found, out = self._cached(setting)
            if found:
                return out
            try:
                out = self.make(*setting)
            finally:
                with self._lock:
                    self._making.pop(setting, None)
            with self._lock:
                self._done[setting] = out
                while len(self._done) > self.size:
                    self._done.popitem(last=False)
        return out

    def cache_clear(self):
        with self._lock:
            self._done.clear()


def _render_json(model, mu, v0, chaotic, layer, orbits, /):
    """`map_element` rendered by HoloViews into Bokeh models, serialized
    without the data of its sources, that data ({source id: columns}), and
    what the figure draws (`_content`: what a shown figure of the same
    shape is updated to, without building a figure of its own).
    The columns are set on each session's copy as they are: deserializing
    them cost more than the rest of the figure (Bokeh's trace log formats
    every value it sets from JSON, arrays included).  Cached by `_map_json`,
    which takes every argument positional and given: a setting is the
    tuple of them (the warm-up's calls, defaults left out, once missed
    what the pages read under functools' cache, which tells calls apart by
    how their arguments were passed)."""
    doc, fig = rendered(map_element, model, mu, v0, chaotic, layer, orbits)
    with doc.models.freeze():  # the graph recomputed once, not at every change
        _lean(fig)
        _shared_parts(fig)
        _labels_from_data(fig)
    columns = {}
    hovered = _hovered(fig)
    for m in doc.models:
        if isinstance(m, ColumnDataSource) and m.name != BAR_LABELS:  # (those: tiny)
            columns[m.id] = {k: _as_sent(k, v, hovered) for k, v in m.data.items()}
            m.data = {k: [] for k in m.data}
    # a plain dict (buffers inline) on every Bokeh: 3.4 returns one by
    # default, later versions a Serialized wrapper unless deferred=False
    js = doc.to_json(deferred=False)
    # read from a figure decoded as the sessions' are: the same values
    # (tooltips as lists, labels as value specs), so that a shown figure
    # set to them changes only where the setting differs
    return js, columns, _content(_decoded(js, columns))


_map_json = _Renders(_render_json, 16)


def _hovered(fig):
    """The names of the columns a hover of the figure shows (`@{name}` or
    `@name` in its tooltips)."""
    names = set()
    for hover in fig.select(type=HoverTool):
        for braced, bare in re.findall(r"@\{([^}]*)\}|@(\w+)", str(hover.tooltips)):
            names.add(braced or bare)
    return names


def _as_sent(name, column, hovered):
    """A map source's column as each session's page gets it: its images
    (a list of 2-D float64 arrays) as float32 where that changes no value a
    hover shows (a column no hover reads, such as the colour scale C: its
    float32 rounding, ~1e-7 of the scale's range, is far finer than the
    palette's steps; or a column float32 holds exactly, such as the chaos
    flags 0/1).  Every page's pull of the document carried four such
    images of 195 kB (a 201 x 121 map); a drift the hover shows keeps
    its float64 values.  Other columns as they are."""
    if not (
        isinstance(column, list)
        and column
        and all(isinstance(a, np.ndarray) and a.ndim == 2 and a.dtype == np.float64 for a in column)
    ):
        return column
    light = [a.astype(np.float32) for a in column]
    if name in hovered and not all(np.array_equal(x, a, equal_nan=True) for x, a in zip(light, column)):
        return column
    return light


# The colour bar's ticks and labels read from a source of their own (its
# columns "tick": C, "label": the drift velocity there), not set on the bar:
# a change of a ColorBar's labels or ticks makes BokehJS lay out every
# figure of the page's main column again (its ColorBarView marks its layout
# dirty whatever the size: docs/how-to/deployment.md 2.2), and every map has its own
# labels (each side of the paper's scale runs to that map's largest drift).
# A new source's data only repaints the figure, which draws the bar again
# with the new labels, in the place laid out for the first map's: the
# labels have two significant digits (plots.colour_ticks), at most five
# characters for every shipped map, so that place holds any of them (a new
# v0* changes the bar's title, and the bar is laid out again).
BAR_LABELS = "vibtrans-colour-bar-labels"
_BAR_TICKS_JS = "return Array.from(source.data.tick);"
# (the formatter's code is a function of `tick`, `index` and `ticks`)
_BAR_LABEL_JS = """const at = source.data.tick, labels = source.data.label;
for (let i = 0; i < at.length; i++)
  if (Math.abs(at[i] - tick) < 1e-9) return String(labels[i]);
return "";"""


def _labels_from_data(fig):
    """The figure's colour bars' ticks and labels (HoloViews': a FixedTicker
    and major_label_overrides) moved into a source of their own (BAR_LABELS),
    read by a CustomJSTicker and a CustomJSTickFormatter."""
    for bar in _annotations(fig, ColorBar):
        if not isinstance(bar.ticker, FixedTicker):
            continue  # (the Lyapunov layer's: Bokeh's own ticks, fixed)
        labels = {float(k): v for k, v in bar.major_label_overrides.items()}
        ticks = sorted(float(t) for t in bar.ticker.ticks)
        source = ColumnDataSource(
            {"tick": ticks, "label": [labels.get(t, f"{t:g}") for t in ticks]}, name=BAR_LABELS
        )
        bar.update(
            ticker=CustomJSTicker(args=dict(source=source), major_code=_BAR_TICKS_JS),
            formatter=CustomJSTickFormatter(args=dict(source=source), code=_BAR_LABEL_JS),
            major_label_overrides={},
        )


def _labels_source(bar):
    """The source of a colour bar's ticks and labels (`_labels_from_data`),
    or None."""
    return bar.ticker.args["source"] if isinstance(bar.ticker, CustomJSTicker) else None


def bar_labels(bar):
    """A map's colour bar's {tick C: label} (`_labels_from_data`)."""
    data_ = _labels_source(bar).data
    return dict(zip(data_["tick"], data_["label"]))


def _setting(model, mu, v0, chaotic, layer, orbits):
    """The arguments of `_map_json` for a setting (all positional: see there)."""
    if layer == LYAPUNOV_LAYER:  # the drift's settings change nothing there
        v0, chaotic = V0, "grey"
    return model, mu, v0, chaotic, layer, orbits


def map_content(model, mu, v0, chaotic, layer=DRIFT_LAYER, orbits=NO_ORBITS):
    """What the map of a setting draws (`_content`), from the rendering
    cache: no figure is built (decoding a figure from its JSON cost a
    model change 0.1-0.25 s of the server's event loop, only to copy its
    values into the shown one)."""
    return _map_json(*_setting(model, mu, v0, chaotic, layer, orbits))[2]


def _content(fig):
    """What a map figure draws, as plain values (the data's arrays are the
    shared columns: no one writes into them): its shape (`_shape`), per
    renderer (data or None, the image placement, visible, a span's
    location), the colour bars' (their labels' data, title), the legends'
    [(label, visible)], the hovers' tooltips and the title."""
    renderers = []
    for r in fig.renderers:
        source, glyph = getattr(r, "data_source", None), getattr(r, "glyph", None)
        placement = {
            attr: getattr(glyph, attr)
            for attr in ("x", "y", "dw", "dh")
            if glyph is not None and hasattr(glyph, attr)
        }
        data_ = None if source is None else dict(source.data)
        renderers.append((data_, placement, r.visible, r.location if isinstance(r, Span) else None))
    return {
        "shape": _shape(fig),
        "renderers": renderers,
        "bars": [
            (None if _labels_source(b) is None else dict(_labels_source(b).data), b.title)
            for b in _annotations(fig, ColorBar)
        ],
        "keys": [
            [(item.label, item.visible) for item in legend.items] for legend in _annotations(fig, Legend)
        ],
        "tooltips": [t.tooltips for t in fig.toolbar.tools if isinstance(t, HoverTool)],
        "title": fig.title.text,
    }


def _lean(fig):
    """Drop the glyph copies HoloViews gives every renderer for selected,
    unselected and muted data: the map has no selection or muting tool, so
    they are never drawn, but every session's browser built a view for
    each (a third of the map's glyph models)."""
    for r in fig.renderers:
        if isinstance(r, GlyphRenderer):
            r.update(selection_glyph=None, nonselection_glyph=None, muted_glyph=None)


def _same_rows(a, b):
    """Whether two sources' columns can be one source's: as many rows, and
    equal values in the columns they share (no columns: only with none)."""
    if not a or not b:
        return not a and not b
    lengths = {len(v) for v in (*a.values(), *b.values())}
    return len(lengths) == 1 and all(
        np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in a.keys() & b.keys()
    )


def _shared_parts(fig):
    """Let the map's renderers share what they can, so that every session's
    copy has fewer models to build (server) and to view (browser): 101 ->
    71 for a shipped map.  One selection, selection policy and filter for
    all sources (the map has no selection tool: they never change); one
    source, and one view of it, for renderers that draw the same rows (the
    key's swatches, which draw none; the paper points' labels are offset
    from the points, so they keep their own).  Called once per rendered
    setting, before it is serialized."""
    selection, policy, everything = Selection(), UnionRenderers(), AllIndices()
    merged = []  # [(source, its view)]
    for r in fig.renderers:
        if not isinstance(r, GlyphRenderer):
            continue
        source = r.data_source
        for shared, view in merged:
            if _same_rows(shared.data, source.data):
                shared.data.update({k: v for k, v in source.data.items() if k not in shared.data})
                r.update(data_source=shared, view=view)
                break
        else:
            source.set_from_json("selected", selection)
            source.selection_policy = policy
            r.view = CDSView(filter=everything)
            merged.append((source, r.view))


def map_figure(model, mu, v0, chaotic, layer=DRIFT_LAYER, orbits=NO_ORBITS):
    """A new Bokeh figure of the map for one session, as wide as its place
    on the page: rendered once per setting by HoloViews, then rebuilt from
    its serialized models and the shared columns of its sources (a
    fraction of the server time of rendering it for every page).  The
    columns' arrays are shared by the sessions: no one writes into them."""
    fig = _decoded(*_map_json(*_setting(model, mu, v0, chaotic, layer, orbits))[:2])
    _fit(fig)
    return fig


def _decoded(js, columns):
    """The figure of `_map_json`'s JSON, its sources given the columns.
    Decoded without a Document of its own (adding the figure to one and
    removing it walked its model graph twice), its sources found through
    its renderers (a walk of the graph costs ~10 ms: ~120 models)."""
    (fig,) = Deserializer().decode(js["roots"])
    sources = {s.id: s for s in (getattr(r, "data_source", None) for r in fig.renderers) if s is not None}
    if not columns.keys() <= sources.keys():  # a source elsewhere: walk the graph
        sources = {m.id: m for m in fig.references()}
    for id_, data_ in columns.items():
        sources[id_].data = dict(data_)
    return fig


def _fit(fig):
    """The map as wide as its place on the page, its data area
    MAP_FRAME_HEIGHT high (the figure's height follows what is around it)."""
    fig.update(
        sizing_mode=None,
        width_policy="max",
        height_policy="fit",
        width=None,
        height=None,
        frame_height=MAP_FRAME_HEIGHT,
        min_width=MIN_WIDTH,
    )


_SIDES = ("center", "below", "right", "left", "above")


def _annotations(fig, kind):
    """A figure's annotations of a type, from its layout lists (a
    `fig.select` walks the whole model graph: ~10 ms a call)."""
    return [m for side in _SIDES for m in getattr(fig, side) if isinstance(m, kind)]


def _shape(fig):
    """What a map figure is made of: its renderers' glyph types in order,
    its legends' item counts and its colour bars' count.  Two figures of the
    same shape differ only in their data, labels and ticks."""
    return (
        [(type(r).__name__, type(getattr(r, "glyph", None)).__name__) for r in fig.renderers],
        [len(legend.items) for legend in _annotations(fig, Legend)],
        len(_annotations(fig, ColorBar)),
    )


def _same_columns(a, b):
    """Whether two sources' data are equal (the same arrays, mostly: the
    shared columns of the rendering cache)."""
    if a.keys() != b.keys():
        return False
    for k, v in b.items():
        w = a[k]
        if w is v:
            continue
        x, y = np.asarray(w), np.asarray(v)
        if x.shape != y.shape or not np.array_equal(
            x, y, equal_nan=x.dtype.kind == "f" and y.dtype.kind == "f"
        ):
            return False
    return True


def update_in_place(old, content):
    """Make the shown figure `old` draw what a figure of `content`
    (`map_content`, of the same shape) draws: the sources' data, the image
    glyphs' placement, which renderers are shown and where lines lie, the
    colour bars' ticks, labels and title, the legends' labels and entries
    shown, the hover's tooltips and the title.  The browser then repaints
    one plot instead of building a new one (a new figure costs it about
    half a second); the zoom is kept.  Only what differs is set: a source's
    data set again is sent again, and redrawn.  False (nothing changed) when
    the shapes differ.  (The session's markers, added after the map's own
    renderers, are not in `content` and stay.)"""
    shape = _shape(old)
    if (shape[0][: len(content["shape"][0])], *shape[1:]) != content["shape"]:
        return False
    for ro, (data_, placement, visible, location) in zip(old.renderers, content["renderers"]):
        so = getattr(ro, "data_source", None)
        if so is not None and data_ is not None and not _same_columns(so.data, data_):
            so.data = dict(data_)
        if placement:
            ro.glyph.update(**placement)
        ro.visible = visible
        if location is not None:
            ro.location = location
    for bo, (labels, title) in zip(_annotations(old, ColorBar), content["bars"]):
        source = _labels_source(bo)
        if source is not None and labels is not None and not _same_columns(source.data, labels):
            source.data = dict(labels)
        bo.title = title
    for lo, items in zip(_annotations(old, Legend), content["keys"]):
        for io, (label, visible) in zip(lo.items, items):
            io.update(label=label, visible=visible)
    hovers = [t for t in old.toolbar.tools if isinstance(t, HoverTool)]
    for ho, tooltips in zip(hovers, content["tooltips"]):
        ho.tooltips = tooltips
    old.title.text = content["title"]
    return True


def map_profile(ds, model):
    """The particle's profile a map was made for (its store's
    scene_profile; the sphere's where absent, and for the material point,
    which is rigid)."""
    return "sphere" if model == "point-mass" else str(ds.attrs.get("scene_profile", "sphere"))


def profile_lines_note(profile):
    """The map's words on its lines for a profile other than the sphere:
    its linear resonance drawn (a closed form), the jumping boundary not
    (the threshold curve shipped is the sphere's; the profile's own costs
    about half of a map on demand's points, docs/DYNAMICS.md section 5)."""
    m_res = linear_resonance_mass(profile)
    return (
        f"dotted: {profile}'s linear resonance m* = {m_res:.3g} (closed form)\n"
        f"no jumping boundary: the one shipped is the sphere's"
    )


def computed_element(ds, title, model, window, v0, chaotic):
    """A map on demand (HoloViews): its drift map over its window, with the
    jumping boundary and the resonances (the vertical motion's: they hold
    for any mu, theta, nu) where they cross it.  window: ((log10 A* from,
    to), (log10 m* from, to)).  A map of another profile than the sphere
    (the deformable particle's, its store's scene_profile): the shipped
    curve is the sphere's, so neither is drawn; its linear contact
    resonance m*_res = N*'(1)/(4 pi^2) (a closed form) is, and the title's
    second line says so (`profile_lines_note`)."""
    (a0, a1), (m0, m1) = window
    el = plots.drift_map(ds, v0=v0, chaotic=chaotic, title=title)
    profile = map_profile(ds, model)
    vertical = data.vertical_curve()
    if not is_sphere(profile):
        # the shipped threshold curve is the sphere's: not this particle's
        # lines.  Its own linear resonance, a closed form, and a note.
        el = el * plots.linear_resonance_line(math.log10(linear_resonance_mass(profile)))
        title = f"{title}\n{profile_lines_note(profile)}"
    elif vertical is not None:
        el = el * plots.jumping_boundary(vertical, model)
        if model == "deformable":
            el = el * plots.resonance_lines(vertical)
    # half a cell beyond the outer points: the image's own extent
    da = (a1 - a0) / max(1, ds.sizes["log_amplitude"] - 1) / 2
    dm = (m1 - m0) / max(1, ds.sizes["log_mass"] - 1) / 2
    return el.opts(
        hv.opts.Image(height=MAP_HEIGHT, title=title),
        hv.opts.Overlay(xlim=(a0 - da, a1 + da), ylim=(m0 - dm, m1 + dm)),
    )


def computed_figure(ds, title, model, window, v0, chaotic):
    """`computed_element` as a Bokeh figure of a Document of its own (made
    off the event loop: it belongs to no session until shown)."""
    _, fig = rendered(computed_element, ds, title, model, window, v0, chaotic)
    fig.document.remove_root(fig)
    _lean(fig)
    _shared_parts(fig)
    _fit(fig)
    return fig


def prerender_steps():
    """The renders of every shipped map at the default v0*, both ways of
    drawing chaotic points, so that a change of model, mu or that setting
    only copies a rendered figure (~0.1 s) instead of rendering it
    (0.3-1.8 s): an iterator of calls, one render each.  The server runs
    them on its event loop one at a time after its warm-up."""
    for model, mu in sorted(data.available_maps()):
        for chaotic in ("grey", "colour"):
            yield functools.partial(_map_json, model, mu, V0, chaotic, DRIFT_LAYER, NO_ORBITS)
    for model, mu in sorted(data.available_maps()):  # the chaos indicator's layer
        yield functools.partial(_map_json, model, mu, V0, "grey", LYAPUNOV_LAYER, NO_ORBITS)


def prerender():
    """All of `prerender_steps` at once."""
    for step in prerender_steps():
        step()


def _map_pane(fig):
    """A map's pane in the map view's wrapping row: it takes the row's
    width, shared with the other map where each gets MIN_WIDTH (the
    figure's own style: a Bokeh pane's element has none of its own in the
    page, `display: contents`)."""
    fig.styles = {**fig.styles, "flex": f"1 1 {MIN_WIDTH}px"}
    return pn.pane.Bokeh(fig, sizing_mode="stretch_width")


# A map not shown before in this process (not in the rendering cache) is
# read, verified and rendered off the event loop: 0.3-0.4 s on an idle
# machine, seconds on a busy one, when every session waited.  Meanwhile
# the maps shown are dimmed and a line over them says what loads, both by
# style (a change of `visible` lays out every figure of the page's main
# column again).
READING = "reading and checking its file"
DRAWING = "drawing it"
_LINE_HIDDEN, _LINE_SHOWN = {"display": "none"}, {"display": None}
_DIMMED, _UNDIMMED = {"opacity": "0.35"}, {"opacity": None}


def loading_text(settings, stage):
    """The line over the map while the maps of `settings` (`_setting`'s
    tuples) load, at `stage` (READING, DRAWING)."""
    maps = " and ".join(f"{model}, mu = {mu:g}" for model, mu, *_ in settings)
    what = "map" if len(settings) == 1 else "maps"
    layer = " (Lyapunov exponent)" if settings[0][4] == LYAPUNOV_LAYER else ""
    return (
        f"**Loading the {what} for {maps}**{layer}: {stage} ... "
        f"*(the map below, dimmed, is the one shown before)*"
    )


def _read(model, mu):
    """The map read and verified (cached for every session); a map that is
    not shipped or cannot be used is said on the figure (`map_element`)."""
    try:
        data.drift_map(model, mu)
    except data.MapUnavailable:
        pass


class MapView:
    """The session's map pane.  `on_click(la, lm, both)` is called for a
    click inside a drawn map (`both`: the two models were shown side by
    side); `on_tap_js`, a CustomJS, runs in the browser at every click on a
    drawn map.  The markers' sources outlive the figures (redrawn when the
    settings change).

    A map not rendered yet in this process loads off the event loop
    (`background`: True, or None for a served session's page; else it is
    made at once, as outside a server): `loading_line` says so meanwhile,
    the latest setting wins, and `answered()` is called once its map is
    shown (a change shown at once answers itself: the explorer's watcher)."""

    def __init__(self, state, on_click, on_tap_js=None, on_zoom=None, answered=None, background=None):
        self.state = state
        self.answered = answered
        self.background = background
        self.loads = LatestJob()  # the map loading (`_load`)
        self.loading_line = pn.pane.Markdown(
            "",
            sizing_mode="stretch_width",
            css_classes=["vt-map-loading"],
            margin=(0, 10),
            styles=dict(_LINE_HIDDEN),
        )
        self.on_zoom = on_zoom  # f(view_ranges()): the shipped map zoomed or panned
        self.on_click = on_click
        self.on_tap_js = on_tap_js  # a CustomJS run in the browser at a click
        self.selected = ColumnDataSource({"x": [state.log_amplitude], "y": [state.log_mass]})
        self.device = ColumnDataSource({"x": [], "y": []})
        # both models' maps side by side where each gets MIN_WIDTH, else
        # one under the other: side by side at 1024 x 768 (a 680-pixel
        # column) the second was cut off at the page's right edge
        self.pane = pn.FlexBox(
            sizing_mode="stretch_width", name="map", css_classes=["vt-map"], flex_wrap="wrap"
        )
        self.figures = []
        # a map on demand shown instead of the shipped ones: (figure, window,
        # on_click(la, lm)); None: the shipped maps
        self.computed = None
        self.scale_fonts = None  # f(fig): presentation mode's fonts, applied to new figures
        self._drawn = None  # what the shipped figures shown draw (redraw)
        self._shapes = []  # their shapes (`_shape`, before the markers)
        # the page's first map, with the page (the default one is rendered
        # at the server's start, a link's other mu in the page's build)
        self._draw()
        state.param.watch(
            self.redraw, ["model", "mu", "v0", "chaotic", "maps", "layer", "orbits"], precedence=1
        )

    def shown(self):
        """The (model, mu) of each map drawn."""
        s = self.state
        if s.maps == "both models":
            return [(m, s.mu) for m in MODELS]
        return [(s.model, s.mu)]

    def _figure(self, model, mu):
        s = self.state
        fig = map_figure(model, mu, s.v0, s.chaotic, s.layer, s.orbits)
        drawn = (model, mu) in data.available_maps()
        fig.on_event(Tap, functools.partial(self._on_tap, drawn))
        if drawn and self.on_tap_js is not None:
            fig.js_on_event(Tap, self.on_tap_js)
        if drawn and self.on_zoom is not None:
            for r in (fig.x_range, fig.y_range):
                r.on_change("end", self._zoomed)
        self._decorate(fig, len(self.shown()))
        return fig

    def _zoomed(self, attr, old, new):
        if self.computed is None and self.figures:
            self.on_zoom(self.view_ranges())

    def show_computed(self, fig, window, on_click):
        """Show `fig` (computed_figure) with the markers; a click inside
        `window` calls on_click(la, lm)."""
        self.loads.cancel()  # (a shipped map loading: no longer wanted)
        self._loading(None)
        self._decorate(fig)
        fig.on_event(Tap, functools.partial(self._on_computed_tap, window, on_click))
        if self.on_tap_js is not None:
            fig.js_on_event(Tap, self.on_tap_js)
        self.computed = fig
        self._drawn = None
        self.figures = [fig]
        self.pane.objects = [_map_pane(fig)]

    def show_shipped(self):
        self.computed = None
        self.redraw()

    def _on_computed_tap(self, window, on_click, event):
        if tapped(event) and within(event.x, event.y, *window):
            on_click(round(event.x, 4), round(event.y, 4))

    def _decorate(self, fig, maps=1):
        """The selected scene's and the device's markers on `fig`, its
        fonts in presentation mode.  The markers are drawn by bare
        renderers: no glyph copies for selected or muted data (neither
        happens on a map), four models fewer per page."""
        for source, marker, colour in ((self.selected, "circle", "yellow"), (self.device, "diamond", "lime")):
            fig.add_glyph(
                source,
                Scatter(x="x", y="y", size=14, marker=marker, fill_color=colour, line_color="black"),
                nonselection_glyph=None,
                muted_glyph=None,
            )
        if self.scale_fonts is not None:
            self.scale_fonts(fig)
        self._fit_key(fig, maps)

    def _fit_key(self, fig, maps):
        """The key below the map in one column where two columns would be
        wider than the map (large fonts, `maps` maps side by side), else two."""
        narrow = self.scale_fonts is not None or maps > 1
        for key in fig.below:
            if getattr(key, "name", None) == plots.KEY_NAME:
                key.ncols = 1 if narrow else 2

    def fit_keys(self):
        for fig in self.figures:
            self._fit_key(fig, len(self.figures))

    @property
    def loading(self):
        """Whether a map is loading off the event loop (`loading_line`)."""
        return self.loads.running

    def _in_background(self):
        if self.background is not None:
            return self.background
        doc = pn.state.curdoc
        return doc is not None and doc.session_context is not None

    def _loading(self, text):
        """Say `text` over the dimmed maps; None: the maps shown are the
        state's again (line hidden, maps not dimmed)."""
        if text is None:
            if self.loading_line.styles != _LINE_HIDDEN:
                self.loading_line.styles = dict(_LINE_HIDDEN)
                self.pane.styles = {**self.pane.styles, **_UNDIMMED}
            return
        self.loading_line.object = text
        if self.loading_line.styles == _LINE_HIDDEN:
            self.loading_line.styles = dict(_LINE_SHOWN)
            self.pane.styles = {**self.pane.styles, **_DIMMED}

    def redraw(self, *events):
        if self.computed is not None:
            return  # a map on demand is shown: the shipped settings wait
        s = self.state
        settings = [_setting(m, mu, s.v0, s.chaotic, s.layer, s.orbits) for m, mu in self.shown()]
        missing = [x for x in settings if x not in _map_json]
        if missing and self._in_background():
            self._load(missing)
            return
        self.loads.cancel()  # a newer setting, shown at once: an older load's map is not shown
        self._loading(None)
        self._draw()

    def _load(self, settings):
        """Load the maps of `settings` off the event loop, then show the
        state's (the latest request wins: a newer one cancels this)."""
        job = self.loads.start()
        read = all(data.loaded(model, mu) for model, mu, *_ in settings)
        self._loading(loading_text(settings, DRAWING if read else READING))
        self.loads.schedule(functools.partial(self._load_steps, job, settings))

    async def _load_steps(self, job, settings):
        doc = pn.state.curdoc  # (the session's: its next tick shows the result)
        try:
            for setting in settings:
                model, mu = setting[:2]
                if not data.loaded(model, mu):
                    await job.run(_read, model, mu)
                    if not self.loads.is_latest(job):
                        return
                    at_next_tick(doc, functools.partial(self._stage, job, settings, DRAWING))
                await job.run(_map_json, *setting)
                if not self.loads.is_latest(job):
                    return
        except Cancelled:
            return  # a newer setting: it is shown, or loading
        except Exception:
            # (a bug: a map that cannot be used is drawn as a note) the
            # page gets a reference to the log, not the server's words
            reference = uuid.uuid4().hex[:8]
            log.exception("loading the map failed (reference %s): %s", reference, settings)
            at_next_tick(doc, functools.partial(self._loaded, job, reference))
            return
        at_next_tick(doc, functools.partial(self._loaded, job))

    def _stage(self, job, settings, stage):
        if self.loads.is_latest(job) and not job.finished:
            self._loading(loading_text(settings, stage))

    def _loaded(self, job, reference=None):
        """The load ended: the state's maps shown, or (`reference` of the
        server's log) why not."""
        if not self.loads.is_latest(job) or job.finished:
            return
        self.loads.finish(job)
        with pn.io.hold():
            if reference is None:
                self._loading(None)
                self._draw()  # (from the rendering cache now)
            else:
                self._loading(
                    f"**The map could not be drawn** (reference {reference}: the server's log names "
                    f"the cause); the map below, dimmed, is the one shown before."
                )
            if self.answered is not None:
                self.answered()

    def _draw(self):
        """Show the state's maps (rendered now if not in the cache)."""
        s = self.state
        # as many maps, each drawn or not as before (that decides what a
        # click on it does), the same layer and curves, each of the same
        # shape (a new model, mu, v0* or colour of the chaotic points): the
        # shown figures are updated to what the new setting draws, from the
        # rendering cache, without building figures
        contents = [map_content(m, mu, s.v0, s.chaotic, s.layer, s.orbits) for m, mu in self.shown()]
        shown = ([(m, mu) in data.available_maps() for m, mu in self.shown()], s.layer, s.orbits)
        if (
            self.figures
            and self._drawn == shown
            and len(contents) == len(self.figures)
            and all(c["shape"] == k for c, k in zip(contents, self._shapes))
        ):
            for old, content in zip(self.figures, contents):
                update_in_place(old, content)
            return
        figures = [self._figure(m, mu) for m, mu in self.shown()]
        self._shapes = [c["shape"] for c in contents]
        self._drawn = shown
        if len(figures) > 1:  # linked zoom and pan
            for fig in figures[1:]:
                fig.x_range, fig.y_range = figures[0].x_range, figures[0].y_range
        self.figures = figures
        self.pane.objects = [_map_pane(f) for f in figures]

    def view_ranges(self):
        """((log10 A* from, to), (log10 m* from, to)) of the zoomed view."""
        fig = self.figures[0]
        return (fig.x_range.start, fig.x_range.end), (fig.y_range.start, fig.y_range.end)

    def select(self, la, lm):
        in_document(self.selected, {"x": [la], "y": [lm]})

    def mark_device(self, marker):
        in_document(
            self.device,
            {"x": [] if marker is None else [marker[0]], "y": [] if marker is None else [marker[1]]},
        )

    def _on_tap(self, drawn, event):
        # (no map drawn: a click has no meaning; outside the map's domain,
        # on its padding, it is not a scene)
        if drawn and tapped(event) and within(event.x, event.y, MAP_LOG_AMPLITUDE, MAP_LOG_MASS):
            self.on_click(round(event.x, 3), round(event.y, 3), len(self.figures) > 1)
