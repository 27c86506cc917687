"""Number fields that never fail silently.

A `NumberField` edits one Number parameter of a Parameterized object as
text.  What is typed is checked by the same function as a link's value
(`urlstate.convert`: plain decimals, finite, inside the parameter's
bounds); a valid value is applied, an invalid one stays in the field with a
message under it naming the range, and the parameter keeps its value until
the text is corrected (`error` says why, and an owner with `set_invalid`,
the explorer's state, records it: a run refuses while it has one).  A change
of the parameter from elsewhere (a map click,
a paper point, a link) rewrites the text and clears the message.
"""

import panel as pn

from vibtrans_explorer.session import urlstate

ERROR_STYLE = {"color": "#b00020", "font-size": "0.85em", "margin-top": "0"}


def read_back(widget):
    """`widget` (a text field) with its model's `tags` holding the text the
    server has read (typed, or written by the server): in the browser,
    tags[0] equal to the field's value says that the server has read its
    last text (a browser test waits for it before its next action; what the
    text changed may come in a later message).  Returns it."""
    widget.tags = [widget.value]
    widget.param.watch(lambda event: setattr(widget, "tags", [event.new]), "value")
    return widget


def _text(value, digits=6):
    """The field's text for a value: `digits` significant digits (108301,
    not 108300.59370879376).  The parameter keeps its exact value: a run uses
    it, and the page's link spells it in full."""
    if value is None:  # (a size that may be absent: the tip radius)
        return ""
    if not isinstance(value, float):
        return str(value)
    return f"{value + 0.0:.{digits}g}"  # (+ 0.0: -0.0 shows as 0)


class NumberField(pn.viewable.Viewer):
    def __init__(self, owner, name, label, width=None, digits=6, **params):
        super().__init__(**params)
        self.digits = digits
        self.owner = owner
        self.name_ = name
        self.label = label
        self.error = ""
        self._width = {} if width is None else {"width": width}
        self.input = read_back(
            pn.widgets.TextInput(
                label=label,
                value=_text(getattr(owner, name), digits),
                css_classes=[f"vt-field-{name}"],
                **self._width,
            )
        )
        # the message under the field: made at the first error (a page's
        # fields are mostly never wrong, and every pane costs its server time)
        self.note = None
        self._box = None
        self._applying = False
        self._echoing = False
        self.input.param.watch(self._typed, "value")
        owner.param.watch(self._moved, name)

    def _typed(self, event):
        if self._echoing:
            return  # the text shows the value: nothing to apply
        p = self.owner.param[self.name_]
        raw = event.new or ""
        try:
            value = urlstate.convert(p, raw)
        except ValueError as exc:
            given = f"got '{urlstate.shown(raw.strip())}'" if raw.strip() else "the field is empty"
            # a value the library checks (the tip's sizes): its reason too
            why = (
                f" ({urlstate.shown(str(exc), urlstate.REASON)})"
                if urlstate.reason_given(p) and raw.strip()
                else ""
            )
            self._say(f"{self.label} must be {urlstate.valid_range(p)}; {given}{why}")
            self._record(self.error)
            return
        self._say("")
        self._record("")
        self._applying = True
        try:
            setattr(self.owner, self.name_, value)
        finally:
            self._applying = False

    def _record(self, text):
        record = getattr(self.owner, "set_invalid", None)
        if record is not None:
            record(self.name_, text)

    def _moved(self, event):
        if self._applying:
            return
        self._say("")
        self._record("")
        text = _text(event.new, self.digits)
        if self.input.value != text:
            self._echoing = True
            try:
                self.input.value = text
            finally:
                self._echoing = False

    def _say(self, text):
        self.error = text
        if self.note is None:
            if not text:
                return
            self.note = pn.pane.Markdown(
                "", visible=False, styles=ERROR_STYLE, css_classes=[f"vt-error-{self.name_}"], **self._width
            )
            if self._box is not None:
                self._box.append(self.note)
        self.note.object = text
        self.note.visible = bool(text)

    def __panel__(self):
        if self._box is None:
            self._box = pn.Column(self.input, *filter(None, [self.note]), margin=0)
        return self._box
