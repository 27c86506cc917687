"""Tabs with only the open tab's content in the page.

A hidden tab's views are not sent to the browser (a session's page costs the
event loop every session shares).  Panel's `Tabs(dynamic=True)` does that by
keeping a hidden tab's models detached from the document, and a text pane
(Markdown, HTML, Alert) updated while detached resolves its stylesheets for
no document: to Panel's CDN, and the stylesheet models it shares with the
page then point the browser at cdn.holoviz.org (docs/how-to/deployment.md,
1.2).  Here a hidden tab holds nothing: its content is taken out of the
page, so no model of it is kept, and put back, built into the session's
document, when the tab is opened."""

import panel as pn


def lazy_tabs(*tabs, **params):
    """A `pn.Tabs` of the `(title, content)` pairs `tabs` whose open tab
    alone holds its content (each tab a box, empty while hidden); `params`:
    the Tabs' own (`active`, `sizing_mode`, `stylesheets`...).  Watchers of
    `active` added later see the content already in the page."""
    boxes = [pn.Column(sizing_mode="stretch_width") for _ in tabs]
    layout = pn.Tabs(*((title, box) for (title, _), box in zip(tabs, boxes)), dynamic=False, **params)

    def show(event=None):
        with pn.io.hold():
            for i, (box, (_, content)) in enumerate(zip(boxes, tabs)):
                want = [content] if i == layout.active else []
                if [id(o) for o in box.objects] != [id(o) for o in want]:
                    box.objects = want

    layout.param.watch(show, "active")
    show()
    return layout
