"""The particle's profile: its selector and a drawing of the tip.

A view of one Parameterized's `profile` (the explorer's state, or a map
request's), never a copy: the kind (sphere, cone, power law, flat-ended
sphere) and its number (the exponent N, the flat's radius C) are written
into the owner's profile as the library spells it (`power:3`,
`flat-sphere:0.5`) and checked by the library; a change of the profile from
elsewhere (a link, a click on a map on demand) rewrites the widgets.  A
typed number that is not valid stays in its field with the message under
it, the profile keeps its last valid value, and an owner with
`set_invalid` (the state) records it: a run refuses meanwhile.

A measured profile (file:PATH) is not offered (app/state.ExplorerProfile).

The drawing: the tip's outline z(r) of the profile chosen (the library's
`outline`: z / a0 against r over the static contact radius, at rest under
the weight, so that every profile touches over r <= 1 with approach a0),
the sphere's dashed beside it.  It is built when a profile other than the
sphere is first chosen (most pages never show it: a page costs its server
less) and hidden for the sphere.
"""

import contextlib
import functools

import numpy as np
import panel as pn
from bokeh.models import ColumnDataSource, Range1d, Span, Title
from bokeh.plotting import figure

from vibtrans.core.profiles import FLAT_MAX, N_MIN, parse_profile
from vibtrans_explorer.session import urlstate
from vibtrans_explorer.session.latest import at_next_tick
from vibtrans_explorer.session.state import SPHERE, is_sphere
from vibtrans_explorer.views.inputs import ERROR_STYLE, read_back
from vibtrans_explorer.views.presentation import scale_fonts

# the selector's kinds: label -> the spec's kind
KINDS = {
    "sphere (Hertz)": "sphere",
    "cone": "cone",
    "power law z ~ r^N": "power",
    "flat-ended sphere": "flat-sphere",
}
# the number of a kind: (its label, the value it starts from)
NUMBERS = {
    "power": (f"exponent N (≥ {N_MIN:g}; 1 the cone, 2 the sphere)", "3"),
    "flat-sphere": (f"flat radius C (0 to {FLAT_MAX:g}, in sqrt(R a0))", "0.5"),
}
RIGID_NOTE = (
    "*The material point is a rigid point (the paper's comparison): it runs the same whatever the profile.*"
)
DRAWN_RHO = 1.6  # the drawing spans r in [-DRAWN_RHO, DRAWN_RHO] static contact radii
DRAWN_Z = 2.0  # and z in [0, DRAWN_Z] a0
DRAWN_POINTS = 321


def _title(spec):
    """The drawing's title (two lines: on one it was wider than the
    sidebar's figure)."""
    return f"the tip: {spec} (solid)\nthe sphere (dashed)"


def kind_of(spec):
    """(kind, its number's text or None) of a profile spec."""
    if spec in ("sphere", "cone"):
        return spec, None
    kind, _, arg = spec.partition(":")
    return kind, arg


def outline(spec, rho):
    """The tip's outline z / a0 at rho = r / (static contact radius), as
    drawn: a steep law's heights past the frame (up to +inf) are drawn at
    twice its top, so the line leaves the frame and no inf reaches the plot."""
    return np.minimum(np.asarray(parse_profile(spec).outline(rho), float), 2 * DRAWN_Z)


class _ChoiceView(pn.viewable.Viewer):
    """What the profile and rolling selectors share: a view of the owner's
    `setting` (a kind in a selector, a number typed for some kinds); its
    parts (the number's field, the message under it, the notes) are made
    at their first use, in PARTS' order.  A typed value the library refuses
    stays in its field with the message, and the owner keeps its last valid
    value (an owner with `set_invalid`, the state, records the message: a
    run refuses meanwhile)."""

    setting = ""
    PARTS: tuple[str, ...] = ()

    def _start(self, owner, width, label, options, value, css):
        """The selector (`label`, its `options` and `value`), watched both
        ways: widgets -> owner, owner -> widgets."""
        self.owner = owner
        self.error = ""
        self._width = {} if width is None else {"width": width}
        self._applying = self._echoing = False
        self.kind = pn.widgets.Select(
            label=label, options=options, value=value, css_classes=[css], **self._width
        )
        self._parts = {}
        self._layout = pn.Column(self.kind, margin=0, sizing_mode="stretch_width", name=self.setting)
        self.kind.param.watch(self._chosen, "value")
        owner.param.watch(self._moved, self.setting)
        if "model" in owner.param:
            owner.param.watch(self._on_model, "model")

    def _made(self, name):
        return name in self._parts

    def _part(self, name):
        if name not in self._parts:
            self._parts[name] = getattr(self, f"_make_{name}")()
            self._layout.objects = [self.kind, *(self._parts[n] for n in self.PARTS if n in self._parts)]
        return self._parts[name]

    note = property(lambda self: self._part("note"), doc="the message under the selector")

    def _number_field(self, label, value, visible, css):
        """The field of a kind's number, watched as the selector is."""
        number = read_back(
            pn.widgets.TextInput(label=label, value=value, visible=visible, css_classes=[css], **self._width)
        )
        number.param.watch(self._chosen, "value")
        return number

    def _make_note(self):
        return pn.pane.Markdown(
            "",
            visible=False,
            styles=ERROR_STYLE,
            css_classes=[f"vt-error-{self.setting}"],
            margin=(0, 10),
            **self._width,
        )

    def _note(self, text, css):
        """A note in italics under the selector (hidden until needed)."""
        return pn.pane.Markdown(text, visible=False, margin=(0, 10), css_classes=[css], **self._width)

    @contextlib.contextmanager
    def _echo(self):
        """Widgets set from the owner: not a user's choice."""
        self._echoing = True
        try:
            yield
        finally:
            self._echoing = False

    def _chosen(self, event):
        if self._echoing:
            return
        self._typed(event.obj is self.kind)
        try:
            value = self.value()
        except ValueError as exc:
            self._say(urlstate.shown(str(exc), urlstate.REASON))
            return
        self._say("")
        self._applying = True
        try:
            setattr(self.owner, self.setting, value)
        finally:
            self._applying = False
        self._applied()

    def _say(self, text):
        self.error = text
        if text or self._made("note"):
            self.note.param.update(object=text, visible=bool(text))
        record = getattr(self.owner, "set_invalid", None)
        if record is not None:
            record(self.setting, text)

    def _applied(self):
        """After the owner took a value from the widgets."""

    def __panel__(self):
        return self._layout


class ProfileView(_ChoiceView):
    """The profile selector of `owner.profile` (and its drawing where
    `drawing`).  `owner.model`, where it has one, says when the profile is
    not used (the material point)."""

    setting = "profile"
    PARTS = ("number", "note", "rigid", "drawing_pane")

    def __init__(self, owner, drawing=True, width=None, **params):
        super().__init__(**params)
        self._texts = {kind: start for kind, (_, start) in NUMBERS.items()}
        kind, arg = kind_of(owner.profile)
        if arg is not None:
            self._texts[kind] = arg
        labels = {v: k for k, v in KINDS.items()}
        self.figure = None  # the drawing, built at its first use
        self.font_scale = 1.0  # presentation mode's (`scale_fonts`)
        self._drawing = drawing
        # (the parts made at their first use: most pages show the sphere,
        # and a page costs its server less)
        self._start(owner, width, "particle profile", list(KINDS), labels[kind], "vt-profile-kind")
        if kind in NUMBERS:
            self._part("number")
        self._on_model()
        self._draw()

    # ---------- its parts, made when first needed ----------
    number = property(lambda self: self._part("number"), doc="the kind's number (a TextInput)")
    rigid = property(lambda self: self._part("rigid"), doc="the material point's note")
    drawing_pane = property(lambda self: self._part("drawing_pane"), doc="the tip's drawing")

    def _make_number(self):
        kind = KINDS[self.kind.value]
        label = NUMBERS.get(kind, NUMBERS["power"])[0]
        return self._number_field(label, self._texts.get(kind, ""), kind in NUMBERS, "vt-profile-number")

    def _make_rigid(self):
        note = self._note(RIGID_NOTE, "vt-profile-rigid")
        note.visible = self._rigid()
        return note

    def _make_drawing_pane(self):
        return pn.Column(visible=False, margin=0, sizing_mode="stretch_width")

    def _rigid(self):
        return getattr(self.owner, "model", None) == "point-mass"

    # ---------- widgets -> owner ----------
    def value(self):
        """The spec the widgets say, or ValueError naming what is wrong."""
        kind = KINDS[self.kind.value]
        if kind not in NUMBERS:
            return kind
        text = (self.number.value or "").strip()
        label = NUMBERS[kind][0]
        if not text:
            raise ValueError(f"{label}: the field is empty")
        if len(text) > urlstate.MAX_LENGTH or not urlstate.PLAIN_NUMBER.fullmatch(text):
            raise ValueError(f"{label} must be a plain number; got '{text}'")  # shown by _say
        spec = f"{kind}:{text}"
        self.owner.param["profile"].check_text(spec)  # the library's range check
        return spec

    def _typed(self, kind_chosen):
        kind = KINDS[self.kind.value]
        if kind_chosen:
            self._echo_number(kind)
        else:
            self._texts[kind] = self.number.value

    def _applied(self):
        self._draw()

    def _echo_number(self, kind):
        with self._echo():
            if kind in NUMBERS:
                self.number.param.update(label=NUMBERS[kind][0], value=self._texts[kind], visible=True)
            elif self._made("number"):
                self.number.visible = False

    # ---------- owner -> widgets ----------
    def _moved(self, event):
        if self._applying:
            return
        kind, arg = kind_of(event.new)
        if arg is not None:
            self._texts[kind] = arg
        with self._echo():
            self.kind.value = {v: k for k, v in KINDS.items()}[kind]
        self._echo_number(kind)
        self._say("")
        self._draw()

    def _on_model(self, *events):
        if self._rigid() or self._made("rigid"):
            self.rigid.visible = self._rigid()

    # ---------- the drawing ----------
    def _draw(self):
        spec = self.owner.profile
        shown = self._drawing and not is_sphere(spec)
        if shown and self.figure is None:
            self._build(spec)
        elif self.figure is not None:
            rho = self.source.data["r"]
            data = {"r": rho, "z": outline(spec, rho), "sphere": self.source.data["sphere"]}
            # plain Bokeh models, changed at the document's next tick (its
            # lock: a typed number is applied without it, and the change
            # raised "_pending_writes should be non-None")
            at_next_tick(self.figure.document, functools.partial(self._drawn, data, _title(spec)))
        if shown or self._made("drawing_pane"):
            self.drawing_pane.visible = shown

    def _drawn(self, data, title):
        self.source.data = data
        self.figure.title.text = title

    def _build(self, spec):
        """The drawing of `spec`, made whole before it joins the page."""
        rho = np.linspace(-DRAWN_RHO, DRAWN_RHO, DRAWN_POINTS)
        self.source = ColumnDataSource({"r": rho, "z": outline(spec, rho), "sphere": outline(SPHERE, rho)})
        fig = figure(
            height=190,
            sizing_mode="stretch_width",
            toolbar_location=None,
            x_range=Range1d(-DRAWN_RHO, DRAWN_RHO),
            y_range=Range1d(0.0, DRAWN_Z),
            title=Title(text=_title(spec)),
            name="profile-drawing",
        )
        fig.line("r", "sphere", source=self.source, line_dash="dashed", color="grey", line_width=1.5)
        fig.line("r", "z", source=self.source, color="#1f77b4", line_width=2.5)
        for x in (-1.0, 1.0):  # the static contact's edge
            fig.add_layout(Span(location=x, dimension="height", line_dash="dotted", line_color="#999"))
        fig.xaxis.axis_label = "r / static contact radius"
        fig.yaxis.axis_label = "z / a0"
        fig.title.text_font_size = "9pt"
        if self.font_scale != 1.0:
            scale_fonts(fig, self.font_scale)
        self.figure = fig
        self.drawing_pane.objects = [
            pn.pane.Bokeh(fig, sizing_mode="stretch_width"),
            pn.pane.Markdown(
                "*At rest under the weight: every tip touches over r <= 1 (dotted) with approach a0.*",
                margin=(0, 10),
                sizing_mode="stretch_width",
            ),
        ]

    def scale_fonts(self, factor):
        """The drawing's text at `factor` times Bokeh's sizes (presentation
        mode), and when it is built later."""
        self.font_scale = factor
        if self.figure is not None:
            scale_fonts(self.figure, factor)


# ---------------------------------------------------------------- rolling
# How the particle turns (docs/MODEL.md section 11): the selector's labels
# -> the owner's `rolling`; "j" takes the number typed in its field
ROLLINGS = {
    "no: it slides (the paper's)": "none",
    "solid sphere (j = 2/5)": "solid",
    "thin shell (j = 2/3)": "shell",
    "another j = I/(m R^2)": "j",
}
J_LABEL = "j = I/(m R^2), in (0, 1]"
J_START = "0.5"
ROLLING_POINT_NOTE = (
    "*A material point has no size, so it does not roll: the selector applies to the deformable particle.*"
)


def rolling_label(value, options=ROLLINGS):
    """The selector's label of a rolling value among `options` (a number:
    "another j")."""
    labels = {v: k for k, v in options.items()}
    return labels.get(value, labels["j"])


def rolling_text(value):
    """A rolling value as its field shows it (a number j), or None for a name."""
    return None if isinstance(value, str) else f"{value:g}"


class RollingView(_ChoiceView):
    """The rolling selector of `owner.rolling` (the explorer's state, or a
    map request's): does not roll, a solid sphere, a thin shell, or a typed
    j.  A view, never a copy: a change of the owner's rolling from
    elsewhere (a link, a click on a map on demand) rewrites it.  A typed j
    that is not valid stays in its field with the library's message under
    it (the owner keeps its last valid value; an owner with `set_invalid`,
    the state, records it: a run refuses meanwhile).  With the material
    point (`owner.model`) the selector is disabled, with a note: the owner
    then does not roll (ExplorerScene), and the deformable particle's
    choice comes back with it.  options: {label: value} ("j": the typed
    number), ROLLINGS by default."""

    setting = "rolling"
    PARTS = ("number", "note", "point")

    def __init__(self, owner, width=None, options=ROLLINGS, label="particle rolls?", **params):
        super().__init__(**params)
        self.options = dict(options)
        self._text = rolling_text(owner.rolling) or J_START
        self._remembered = None  # the deformable particle's choice, the point mass shown
        self._start(owner, width, label, list(self.options), self._label(owner.rolling), "vt-rolling")
        if self._kind() == "j":
            self._part("number")
        self._on_model()

    def _kind(self):
        return self.options[self.kind.value]

    def _label(self, value):
        return rolling_label(value, self.options)

    number = property(lambda self: self._part("number"), doc="j's field (a TextInput)")
    point = property(lambda self: self._part("point"), doc="the material point's note")

    def _make_number(self):
        return self._number_field(J_LABEL, self._text, self._kind() == "j", "vt-rolling-j")

    def _make_point(self):
        return self._note(ROLLING_POINT_NOTE, "vt-rolling-point")

    def _point_mass(self):
        return getattr(self.owner, "model", "deformable") != "deformable"

    # ---------- widgets -> owner ----------
    def value(self):
        """The rolling value the widgets say, or ValueError naming what is
        wrong (the library's message: the parameter and its range)."""
        kind = self._kind()
        if kind != "j":
            return kind
        text = (self.number.value or "").strip()
        if not text:
            raise ValueError(f"{J_LABEL}: the field is empty")
        if len(text) > urlstate.MAX_LENGTH:
            raise ValueError(f"{J_LABEL}: too long")
        return self.owner.param["rolling"].check_text(text)

    def _typed(self, kind_chosen):
        if kind_chosen:
            self._show_number()
        else:
            self._text = self.number.value

    def _show_number(self):
        shown = self._kind() == "j"
        if shown or "number" in self._parts:
            with self._echo():
                self.number.param.update(visible=shown, value=self._text)

    # ---------- owner -> widgets ----------
    def _moved(self, event):
        if self._point_mass() and event.new == "none" and event.old != "none":
            self._remembered = event.old  # (the point mass's: ExplorerScene)
        if self._applying:
            return
        if rolling_text(event.new) is not None:
            self._text = rolling_text(event.new)
        with self._echo():
            self.kind.value = self._label(event.new)
        self._show_number()
        self._say("")

    def _on_model(self, *events):
        point = self._point_mass()
        self.kind.disabled = point
        if point or "point" in self._parts:
            self.point.visible = point
        if point and self.error:  # (a typed j: not the point's)
            with self._echo():
                self.kind.value = self._label(self.owner.rolling)
            self._show_number()
            self._say("")
        if not point and self._remembered is not None:
            remembered, self._remembered = self._remembered, None
            if self.owner.rolling == "none":
                self.owner.rolling = remembered
