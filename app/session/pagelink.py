"""The page's link as a view of its state (a link reproduces the page).  A
link is read when the page opens, and every value checked
(app/session/urlstate.py: messages naming the key and the valid range);
from then on the address is written from the state (`PageLink.query`:
every URL key, one spelling, numbers exact), each change a new entry of
the browser's history.  The browser's Back and Forward report the entry
they reach: its query is read as a link is (`navigate`), and the page
follows it.  A link with an error stays in the address while its message
shows, until the state changes.  Panel's Location is not used: it pushes
a history entry at every change, answers no Back, and applies the
browser's raw query of its own when the page connects (a `?mu=0.5`
reached the run unchecked while the page said 0.3)."""

import panel as pn
from tornado.httputil import parse_qs_bytes

from vibtrans_explorer.session import maprequest, urlstate
from vibtrans_explorer.session.latest import at_next_tick
from vibtrans_explorer.session.state import URL_ALIASES, URL_KEYS, link_conflicts


def map_request_of(args):
    """(MapRequest or None, errors) of a link's `map=`."""
    given = args.get(maprequest.URL_KEY)
    if not given:
        return None, []
    if isinstance(given, (str, bytes)):
        given = [given]
    texts = {urlstate.as_text(v) for v in given}
    if len(texts) > 1:
        return None, [
            f"URL parameter '{maprequest.URL_KEY}' is given {len(given)} times with different values"
        ]
    return maprequest.decode(texts.pop())


def query_args(search):
    """A query ('?la=0.5&...') as the server's request gives it: {key: [bytes]}
    (Tornado's parse: blank values kept, '+' a space, escapes decoded)."""
    return parse_qs_bytes(search[1:] if search.startswith("?") else search, keep_blank_values=True)


class PageLink:
    """The address of one session's page (a views.browserside.BrowserAddress,
    or anything with a `search` parameter) bound to its state.
    navigated(args): called when the browser's Back or Forward reached
    another address of the page, with that address's query as a link's
    (`query_args`); it applies it (`apply`) and does what a link does."""

    def __init__(self, state, location, navigated=None):
        self.state = state
        self.location = location
        self.navigated = navigated
        self.written = None  # the address the browser shows, as the server knows it
        self._following = False  # the state follows the browser's address: nothing written

    def apply(self, args):
        """Apply a link's query (Tornado's {key: [bytes]}) to the state:
        (the values it gave, its errors, its map request or None).  The
        valid values are applied, every other URL value set to its default."""
        request, map_errors = map_request_of(args)
        values, errors = urlstate.parse(args, self.state, URL_KEYS, URL_ALIASES)
        values, conflicts = link_conflicts(values, URL_KEYS)
        errors += conflicts
        self.state.param.update(**urlstate.resolved(values, self.state, URL_KEYS))
        if request is not None:
            self.state.map_request = maprequest.encode(request)
        return values, [*map_errors, *errors], request

    def read(self, args):
        """Read the link the page was opened with (`apply`); from then on the
        address follows the state.  A link with an error stays as given
        (its message names what is wrong in it) until the state changes."""
        values, errors, request = self.apply(args)
        if not errors:
            self.write()
        self.state.param.watch(self.write, [*URL_KEYS, "map_request"])
        self.location.param.watch(self._on_location, "search")
        return values, errors, request

    def query(self):
        """The page's link query: the state's values, one spelling each."""
        extra = [] if self.state.map_request is None else [(maprequest.URL_KEY, self.state.map_request)]
        return urlstate.query(self.state, URL_KEYS, extra)

    def write(self, *events):
        if self._following:
            return
        self.written = self.query()
        if self.location.search != self.written:
            self.location.search = self.written

    def _on_location(self, event):
        """The browser reports the address its Back or Forward reached: the
        page follows it at the document's next tick (with its lock, after
        Panel has applied the browser's change)."""
        if event.new == self.written:
            return
        at_next_tick(pn.state.curdoc, lambda: self.navigate(event.new))

    def navigate(self, search):
        """The browser shows `search` (its Back or Forward): the state
        follows it, as a link (`navigated`); the address stays as it is."""
        if search != self.location.search:
            return  # the browser went on meanwhile: its latest address is next
        self._following = True
        try:
            if self.navigated is not None:
                self.navigated(query_args(search))
            else:
                self.apply(query_args(search))
        finally:
            self._following = False
        self.written = search
