"""The page's link as a view of its state (a link reproduces the
page).  A link is read once, when the page opens, and every value checked
(app/session/urlstate.py: messages naming the key and the valid range); from then
on the URL is written from the state (`PageLink.query`: every URL key, one
spelling, numbers exact), one way.  Panel's Location.sync is not used: it
applies the browser's raw query of its own when the page connects (a
`?mu=0.5` reached the run unchecked while the page said 0.3)."""
import panel as pn

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
        return None, [f"URL parameter '{maprequest.URL_KEY}' is given {len(given)} times "
                      f"with different values"]
    return maprequest.decode(texts.pop())


class PageLink:
    """The URL of one session's page (its panel Location) bound to its state."""

    def __init__(self, state, location):
        self.state = state
        self.location = location
        self.written = None       # the query last written

    def read(self, args):
        """Apply a link's query (Tornado's {key: [bytes]}) to the state:
        (the values it gave, its errors, its map request or None).  The
        valid values are applied; then the URL follows the state."""
        request, map_errors = map_request_of(args)
        values, errors = urlstate.parse(args, self.state, URL_KEYS, URL_ALIASES)
        values, conflicts = link_conflicts(values, URL_KEYS)
        errors += conflicts
        self.state.param.update(**urlstate.resolved(values, self.state, URL_KEYS))
        if request is not None:
            self.state.map_request = maprequest.encode(request)
        self.write()
        self.state.param.watch(self.write, [*URL_KEYS, "map_request"])
        self.location.param.watch(self._on_location, "search")
        return values, [*map_errors, *errors], request

    def query(self):
        """The page's link query: the state's values, one spelling each."""
        extra = ([] if self.state.map_request is None
                 else [(maprequest.URL_KEY, self.state.map_request)])
        return urlstate.query(self.state, URL_KEYS, extra)

    def write(self, *events):
        self.written = self.query()
        if self.location.search != self.written:
            self.location.search = self.written

    def _on_location(self, event):
        """The browser reports its own query (the raw link) when the page
        connects: the page's one replaces it, on the next tick (Panel sends
        no change back to the browser while it applies the browser's own
        change of that property)."""
        if event.new == self.written:
            return
        at_next_tick(pn.state.curdoc, self._rewrite)

    def _rewrite(self):
        self.written = self.query()
        self.location.search = self.written
