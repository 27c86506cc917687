"""The explorer's number fields (app/views/inputs.py): a typed value is checked
like a link's (urlstate.convert), applied only when valid, and an invalid
one is a message beside the field, never a silent revert or clamp; the
explorer refuses to run while a field holds one (log10 A* = 99, -10 or
1e400 left in the field must not run the previous value; clearing it
must not raise in the server log)."""

import panel as pn
import param
import pytest

from vibtrans_explorer.explorer import Explorer
from vibtrans_explorer.views.inputs import NumberField


class _Owner(param.Parameterized):
    x = param.Number(default=1.0, bounds=(-6.0, 6.0))


@pytest.mark.parametrize(
    "typed, says",
    [
        ("99", "got '99'"),
        ("-10", "got '\\-10'"),
        ("1e400", "got '1e400'"),
        ("nan", "got 'nan'"),
        ("abc", "got 'abc'"),
        ("", "the field is empty"),
        ("   ", "the field is empty"),
        # (the message is Markdown: the given text is escaped, shown as typed)
        ("²", "got '²'"),
        ("1_0", "got '1\\_0'"),
    ],
)
def test_an_invalid_text_is_a_message_and_the_value_stays(typed, says):
    owner = _Owner()
    field = NumberField(owner, "x", "log10 A*")
    field.input.value = typed
    assert owner.x == 1.0
    assert field.error == f"log10 A* must be a number in [-6.0, 6.0]; {says}"
    assert field.note.visible and field.note.object == field.error
    assert field.input.value == typed  # what was typed stays, to correct it


def test_a_valid_text_is_applied_and_clears_the_message():
    owner = _Owner()
    field = NumberField(owner, "x", "log10 A*")
    field.input.value = "99"
    field.input.value = " 2.5 "
    assert owner.x == 2.5 and field.error == "" and not field.note.visible


def test_a_change_from_elsewhere_rewrites_the_field():
    owner = _Owner()
    field = NumberField(owner, "x", "log10 A*")
    field.input.value = "abc"
    owner.x = 0.1 + 0.2  # e.g. a map click
    # the field shows the value to 6 digits; the state keeps it exactly
    assert field.input.value == "0.3" and field.error == ""
    assert owner.x == 0.1 + 0.2


def test_the_explorer_refuses_to_run_while_a_field_is_invalid():
    explorer = Explorer()
    la = explorer.scene_controls.fields[0]
    la.input.value = "1e400"
    assert explorer.start_run(schedule=False) is None
    assert explorer.message.visible
    assert explorer.message.object.startswith("Not run: log10 A* must be a number in [-6.0, 6.0]")
    la.input.value = "0.5"  # corrected: the refusal goes
    assert not explorer.message.visible and explorer.state.log_amplitude == 0.5


def test_showing_a_value_does_not_round_it():
    # the field shows 6 significant digits; the value set elsewhere keeps all
    owner = _Owner()
    field = NumberField(owner, "x", "log10 A*")
    owner.x = 1.171875
    assert owner.x == 1.171875
    assert field.input.value == "1.17188"


def test_a_device_value_is_shown_short_and_kept_exact():
    # a frequency made by the Design tab's chart, or a device's radius
    class Device(param.Parameterized):
        x = param.Number(default=1.0, bounds=(0.0, None))

    owner = Device()
    field = NumberField(owner, "x", "frequency (Hz)")
    owner.x = 108300.59370879376
    assert field.input.value == "108301" and owner.x == 108300.59370879376
    owner.x = 2.6448882818205527e-07
    assert field.input.value == "2.64489e-07"


@pytest.mark.parametrize("typed", ["abc", "it's", "<b>1</b>", "1.5#2", "*x*", "a & b", "\\(1\\)"])
def test_a_message_shows_the_typed_text_as_typed(typed):
    # the message is Markdown: rendered, it reads exactly what was typed
    # (no '&#x27;' or doubled backslashes on the page)
    import html
    import re

    from markdown_it import MarkdownIt

    owner = _Owner()
    field = NumberField(owner, "x", "log10 A*")
    field.input.value = typed
    rendered = MarkdownIt("commonmark").render(field.note.object)
    text = html.unescape(re.sub(r"<[^>]+>", "", rendered)).strip()
    assert text == f"log10 A* must be a number in [-6.0, 6.0]; got '{typed}'"


def test_a_profile_message_shows_the_typed_text_as_typed():
    import html
    import re

    from markdown_it import MarkdownIt

    from vibtrans_explorer.session.state import ExplorerState
    from vibtrans_explorer.views.profile import ProfileView

    view = ProfileView(ExplorerState())
    view.kind.value = next(k for k in view.kind.options if "power" in k.lower())
    view.number.value = "a'1.5"
    notes = [o.object for o in view.__panel__().select(pn.pane.Markdown) if "got" in o.object]
    text = html.unescape(re.sub(r"<[^>]+>", "", MarkdownIt("commonmark").render(notes[0])))
    assert text.strip().endswith("must be a plain number; got 'a'1.5'")
