"""A view's messages: to the page's alert when the explorer gave the view an
`error` callback, else in the view's own note pane (a view on its own, in
tests or another layout)."""

import panel as pn

MESSAGE_STYLE = {"color": "#b00020", "font-size": "0.85em"}


def note_pane():
    """The hidden pane a view shows its own messages in."""
    return pn.pane.Markdown("", visible=False, styles=MESSAGE_STYLE)


def say(view, text):
    """Show `text` for `view` (view.error, else view.note); '' clears the note."""
    if text and view.error is not None:
        view.error(text)
        return
    view.note.object = text
    view.note.visible = bool(text)
