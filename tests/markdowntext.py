"""What a Markdown pane shows: its text rendered as Panel renders it
(markdown-it: CommonMark with tables and strike-through), tags dropped."""

import html
import re

from markdown_it import MarkdownIt

_PARSER = MarkdownIt("commonmark").enable("table").enable("strikethrough")


def _text(fragment):
    return html.unescape(re.sub(r"<[^>]+>", "", fragment))


def shown_text(markdown):
    """The text the page shows for `markdown`."""
    return _text(_PARSER.render(markdown))


def emphasized(markdown):
    """The texts the page shows in italics or bold for `markdown`."""
    return [
        _text(m) for m in re.findall(r"<(?:em|strong)>(.*?)</(?:em|strong)>", _PARSER.render(markdown), re.S)
    ]


def table_rows(markdown):
    """The cells of each row of the tables in `markdown`, as shown."""
    out = _PARSER.render(markdown)
    return [
        [_text(c) for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", row, re.S)]
        for row in re.findall(r"<tr>(.*?)</tr>", out, re.S)
    ]
