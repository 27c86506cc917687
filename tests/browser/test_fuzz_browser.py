"""Every URL key and every text field and selector of the explorer, fuzzed
in chromium with hypothesis over its whole type: valid values, the bounds
and just past them, 1e308, subnormals, 10**400, nan, inf, exponents like
power:1e300, empty, junk and other scripts' digits.

The only outcomes allowed: the scene with that value (the page's address,
written from its state, holds it) or the explorer's own message naming the
parameter (a link's message, the field's message under it).  Whatever the
value, the page shows no traceback, no file of the server, no JavaScript
error, and the server logs no exception.  What each value must give is the
controller's answer (app/session/urlstate.py, the same checks the page
runs, property-tested alone in tests/app/test_url_params.py): here the page
must agree with it.

One served explorer and one page for the module: a link is opened in it
per example (a page load each: URL_EXAMPLES of them); the fields are typed
and committed, options chosen, Run and Draw pressed on the page as it
stands (FIELD_EXAMPLES, DESIGN_EXAMPLES); every option of every selector is
chosen in turn.  The same examples at every run (derandomized);
VIBTRANS_FUZZ_SCALE multiplies their number for a longer search.  Waits are
on the page's answers: a field's text read back by the server
(browserpages.read_back), the address, the messages, the page's own
"busy" line."""

import math
import os
import re
from pathlib import Path
from urllib.parse import parse_qs, urlencode

import pytest
from browserpages import (
    SHOWN_TEXT_JS,
    answered,
    new_page,
    page_text,
    read_back,
    server_errors,
    settle,
    shown_text,
)
from budget import budget_ms
from hypothesis import HealthCheck, Phase, assume, event, example, given, settings
from hypothesis import strategies as st
from numbertexts import LOOKALIKE_NUMBERS
from playwright.sync_api import TimeoutError as PageTimeout
from playwright.sync_api import expect

from vibtrans.core.params import PAPER_POINTS
from vibtrans.products.design import CUSTOM_MATERIAL
from vibtrans_explorer.session import maprequest, urlstate
from vibtrans_explorer.session.pagelink import map_request_of, query_args
from vibtrans_explorer.session.state import (
    URL_ALIASES,
    URL_KEYS,
    ExplorerState,
    link_conflicts,
)
from vibtrans_explorer.texts import POINT_LABELS
from vibtrans_explorer.views.design import DesignPanel
from vibtrans_explorer.views.profile import KINDS, ROLLINGS

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
URL_EXAMPLES = 25
FIELD_EXAMPLES = 80
DESIGN_EXAMPLES = 50
# more (or fewer) examples of each: VIBTRANS_FUZZ_SCALE (1 by default)
SCALE = float(os.environ.get("VIBTRANS_FUZZ_SCALE", "1"))


def fuzz(examples):
    """Hypothesis's settings for `examples` examples (times SCALE) in a
    browser: no deadline, the same examples at every run, a failing one
    reported as found (shrinking it took minutes of page loads)."""
    return settings(
        max_examples=max(1, round(examples * SCALE)),
        deadline=None,
        derandomize=True,
        database=None,
        phases=(Phase.explicit, Phase.generate),
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )


# what no page may show: a traceback, a file of the server
LEAKS = ("Traceback", 'File "', "site-packages", str(ROOT))
KEY_NAME = {key: name for name, key in URL_KEYS.items()}
MAP_KEY = maprequest.URL_KEY
# a link that names log10 A* or m* runs its scene: these keep it short
CHEAP_RUN = {"fidelity": "preview", "compare": "none", "periods": "10"}

# ------------------------------------------------------------------ values
# texts at the edges of every number type, and what is no plain decimal
EDGE_TEXTS = [
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "5e-324",
    "-5e-324",
    "2.2250738585072014e-308",
    "1e-320",
    str(10**400),
    f"-{10**400}",
    "1" + "0" * 63,
    "1e9999",
    "1e99999",
    "1e-999",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "",
    " ",
    "0",
    "-0",
    "+0.",
    ".5",
    *LOOKALIKE_NUMBERS,
    "1e",
    "e5",
    "--1",
    "abc",
    "<b>1</b>",
    "*1* [x](y) `z`",
    "\u00a01",
]
_EDGE = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:e[-+]?\d+)?")


def edges(p):
    """The numbers at the edges of `p`'s range as its message states it
    (urlstate.valid_range: "a number in (0, 90)"), each with its neighbours
    just inside and past it."""
    out = set()
    for text in _EDGE.findall(urlstate.valid_range(p)):
        x = float(text)
        out.update({x, math.nextafter(x, -math.inf), math.nextafter(x, math.inf), x - 1, x + 1})
    return sorted(repr(x) for x in out if math.isfinite(x))


def numbers(p):
    """Texts over a number's whole type, its edges often."""
    edge = edges(p)
    return st.one_of(
        *([st.sampled_from(edge)] if edge else []),
        st.sampled_from(EDGE_TEXTS),
        st.floats().map(repr),  # (nan, inf, subnormals, huge ones)
        st.integers(-(10**20), 10**20).map(str),
        st.integers(-400, 400).map(lambda k: str(10**k) if k >= 0 else f"-{10**-k}"),  # (up to 10**400)
        st.integers(-400, 400).map(lambda e: f"1e{e}"),
        st.text(max_size=12),
    )


# the particle's profile: kinds with numbers over their whole type
PROFILE_NUMBERS = st.one_of(st.sampled_from(EDGE_TEXTS), st.floats().map(repr), st.just("1e300"))
PROFILES = st.one_of(
    st.sampled_from(["sphere", "cone", "power:1e300", "power:1", "flat-sphere:1e50", "file:/etc/passwd"]),
    st.tuples(st.sampled_from(["power", "flat-sphere", "cone", "sphere"]), PROFILE_NUMBERS).map(":".join),
)


_RANGE = re.compile(r"([\[(])\s*([-+.\w]+),\s*([-+.\w]+)\s*([\])])")


def valid_numbers(p):
    """Plain decimals inside `p`'s range as its message states it
    ("a number in (0, 90)"), up to 1e308 where it has no upper bound."""
    opened, lo, hi, closed = _RANGE.search(urlstate.valid_range(p)).groups()
    lo, hi = float(lo), float(hi)
    bounds = [x for x, kept in ((lo, opened == "["), (hi, closed == "]")) if kept and math.isfinite(x)]
    if not math.isfinite(hi):
        hi, closed = 1e308, "]"
    inside = st.floats(lo, hi, exclude_min=opened == "(", exclude_max=closed == ")")
    return (st.one_of(inside, st.sampled_from(bounds)) if bounds else inside).map(repr)


def url_values(name):
    """Texts for the URL key of the state's parameter `name`: valid ones
    (half of them), then anything of its type and beyond."""
    p = ExplorerState.param[name]
    junk = st.one_of(st.sampled_from(EDGE_TEXTS), st.text(max_size=20))
    if name == "profile":
        return st.one_of(PROFILES, junk)
    objects = getattr(p, "objects", None)
    if objects:
        spelled = [*objects, *URL_ALIASES.get(name, {})]
        return st.one_of(
            st.sampled_from(spelled),
            st.sampled_from(spelled).map(lambda v: f" {v} "),  # (a '+' in a query: stripped)
            st.sampled_from(spelled).map(str.upper),
            junk,
        )
    if name == "rolling":
        valid = st.one_of(
            st.sampled_from(["none", "solid", "shell"]), st.floats(0, 1, exclude_min=True).map(repr)
        )
        return st.one_of(valid, st.just("Solid"), numbers(p))
    return st.one_of(valid_numbers(p), numbers(p))


def map_values():
    """A small map on demand's `map=` text with one field drawn over its
    type (or too few, too many, junk)."""
    base = maprequest.encode(
        maprequest.MapRequest(periods=100, fidelity="preview", cells=1, levels=1, la_from=0, la_to=1)
    ).split(",")

    @st.composite
    def one_field(draw):
        k = draw(st.integers(0, len(base) - 1))
        p = maprequest.MapRequest.param[maprequest.FIELDS[k]]
        objects = getattr(p, "objects", None)
        text = draw(
            st.sampled_from([*objects, "x", ""])
            if objects
            else PROFILES
            if maprequest.FIELDS[k] == "profile"
            else numbers(p)
        )
        return ",".join([*base[:k], text.replace(",", ";"), *base[k + 1 :]])

    return st.one_of(
        one_field(),
        st.integers(0, len(base) + 2).map(lambda n: ",".join((base * 2)[:n])),
        st.sampled_from(EDGE_TEXTS),
    )


@st.composite
def links(draw):
    """{URL key: text}: map= alone (its map would move the tab), all of the
    state's keys at once, or one to three of them (most often)."""
    mode = draw(st.integers(0, 9))
    if mode == 0:
        return {MAP_KEY: draw(map_values())}
    keys = sorted(KEY_NAME)
    if mode > 3:
        keys = draw(st.lists(st.sampled_from(keys), min_size=1, max_size=3, unique=True))
    return {k: draw(url_values(KEY_NAME[k])) for k in keys}


# ------------------------------------------------------------------ the page
def _normal(text):
    """Text as compared: one space between words, straight apostrophes."""
    return " ".join(text.replace("\u2019", "'").split())


class Fuzzed:
    """The module's page (one, reused), its JavaScript errors, the served
    explorer and where each example's part of its log starts."""

    def __init__(self, browser, served):
        self.page, self.errors = new_page(browser, 1280, 800)
        self.served = served
        self.start = self.example = len(served.text())

    def begin(self):
        """An example starts: its failures are those logged from now."""
        self.example = len(self.served.text())

    def clean(self, since=None):
        """Nothing leaked: no traceback or server file in the page's text, no
        JavaScript error, no failure in the server's log (since the
        example began)."""
        text = page_text(self.page)
        leaked = [w for w in LEAKS if w in text]
        assert not leaked, (leaked, text[max(0, text.find(leaked[0]) - 300) :][:1500])
        assert not self.errors, self.errors
        failed = server_errors(self.served.text()[self.example if since is None else since :])
        assert not failed, failed


@pytest.fixture(scope="module")
def explorer(browser, served_explorer):
    fuzzed = Fuzzed(browser, served_explorer)
    yield fuzzed
    try:
        fuzzed.clean(since=fuzzed.start)  # (what the module's last answers logged too)
    finally:
        fuzzed.page.close()


def expected_link(given):
    """What the page must do with the link `given` ({key: text}), as the
    controller reads it: (the state's address it writes, {key: text}: each
    valid value as given, each other at its default; what its message
    says of each error: its key, its parameter and its range, [] if none)."""
    args = query_args("?" + urlencode(given))
    values, errors = urlstate.parse(args, ExplorerState, URL_KEYS, URL_ALIASES)
    values, conflicts = link_conflicts(values, URL_KEYS)
    request, map_errors = map_request_of(args)
    # (up to the given text: the message shows it escaped and cut)
    said = [_normal(text.split("; got ")[0]) for text in [*map_errors, *errors, *conflicts]]
    resolved = urlstate.resolved(values, ExplorerState, URL_KEYS)
    address = {URL_KEYS[n]: urlstate.written(v) for n, v in resolved.items() if v is not None}
    if request is not None:
        address[MAP_KEY] = maprequest.encode(request)
    return address, said


def _address(page):
    return {
        k: v[0]
        for k, v in parse_qs(page.evaluate("() => location.search")[1:], keep_blank_values=True).items()
    }


def _to_other_tab(page, address):
    """Click the Map or the Vertical tab (the one not shown): a change of the
    state that writes the page's whole address.  Returns the tab chosen."""
    tab, label = ("vertical", "Vertical") if address.get("tab", "map") == "map" else ("map", "Map")
    settle(page)  # (the page drawn: the click reaches its tab)
    page.locator(".bk-tab", has_text=re.compile(f"^{label}$")).first.click()
    expect(page.locator(".bk-tab.bk-active", has_text=re.compile(f"^{label}$")).first).to_be_visible(
        timeout=budget_ms(30)
    )
    return tab


@fuzz(URL_EXAMPLES)
@given(given_=links())
@example(given_={"profile": "power:1e300"})
@example(given_={"tip": "power", "tipn": "1e300", "tab": "units"})
@example(given_={"la": "1e308", "lm": "5e-324"})
@example(given_={"freq": str(10**400), "amp": "-1e308", "radius": "nan", "tipn": "inf"})
@example(given_={"mu": "1.0000000000000002", "nu": "0.5", "theta": "1.0", "tab": "design"})
@example(given_={MAP_KEY: "deformable,0.3,1.2,0.3,50,1e308,preview,ab4,paper,0.5,0,1,-1,1,1,1,decided"})
def test_a_link_shows_its_scene_or_names_its_errors(explorer, given_):
    page = explorer.page
    assume(not any(w in v for v in given_.values() for w in LEAKS))
    explorer.begin()
    query = dict(given_)
    if {"la", "lm"} & set(query):  # (a link that runs: a short run)
        query.update(CHEAP_RUN)
    address, said = expected_link(query)
    event("a link with errors" if said else "a valid link")
    page.goto(explorer.served.url + "?" + urlencode(query))
    page.locator(".vt-paper-points select").first.wait_for(state="attached", timeout=budget_ms(60))
    if said:
        # the message names each wrong key and its range; nothing ran, the
        # address is the link
        line = page.get_by_text("This link has errors, so nothing was run").first
        line.wait_for(timeout=budget_ms(60))
        message = _normal(line.inner_text())
        missing = [words for words in said if words not in message]
        assert not missing, (missing, message)
        # a change writes the state's address: each invalid value left at
        # its default, each valid one as given (nothing clamped)
        address["tab"] = _to_other_tab(page, address)
    try:
        page.wait_for_function(
            "(want) => { const q = new URLSearchParams(location.search);"
            " return Object.entries(want).every(([k, v]) => q.get(k) === v); }",
            arg=address,
            timeout=budget_ms(60),
        )
    except PageTimeout:
        pass  # (what differs, said below)
    shown = _address(page)
    differ = {k: (shown.get(k), address.get(k)) for k in {*shown, *address} if shown.get(k) != address.get(k)}
    assert not differ, f"the address against the link's values (shown, expected): {differ}"
    explorer.clean()


# ------------------------------------------------------------------ the fields
SIDEBAR_NUMBERS = ("log_amplitude", "log_mass", "alpha_t")
UNITS_NUMBERS = ("radius", "frequency", "amplitude", "preload")
# the state's selectors (by their labels) and their URL keys
SELECTS = {
    "fidelity": "fidelity",
    "integrator": "integrator",
    "compare with": "compare",
    "stick rule (point mass: slide -> stick)": "rule",
    "mu (shipped maps)": "mu",
    "Paper points": None,
    "particle profile": "profile",
    "particle rolls?": "rolling",
    "substrate": "substrate",
    "particle": "particle",
}
# the radio buttons: URL key -> options (the colour of chaos is not in the link)
RADIOS = {
    "model": ["deformable", "point-mass"],
    "maps": ["selected model", "both models"],
    "layer": ["drift velocity", "Lyapunov exponent"],
    "orbits": ["no orbit curves", "period-1 orbit curves"],
    "chaotic": ["grey", "colour"],
}
J_OPTION = next(label for label, value in ROLLINGS.items() if value == "j")
# the Design tab: its own numbers (mu within the explorer's range, the
# chart's with no bounds: the library checks them when the chart is drawn),
# the tip's kinds and the field of each one's size
DESIGN_NUMBERS = ("mu", "surface_energy", "x_lo", "x_hi", "x_points", "y_lo", "y_hi", "y_points")
TIP_SIZES = {
    "tip_half_angle": "cone",
    "tip_exponent": "power",
    "tip_radius": "power",
    "tip_flat_radius": "flat-sphere",
}
DESIGN_SELECTS = ("particle tip", "preset", "x axis", "y axis")

# the shown messages of a CSS class, as the page's models hold them (their
# HTML; a message's view may be drawn a frame later)
_MESSAGES_JS = """(cls) => {
  const out = [];
  for (const d of window.Bokeh.documents) for (const m of d.all_models)
    if ((m.css_classes || []).includes(cls) && m.visible && m.text) out.push(m.text);
  return out.join(" ");
}"""


def _open_tab(page, label):
    tab = page.locator(".bk-tab", has_text=re.compile(f"^{label}$")).first
    if "bk-active" not in (tab.get_attribute("class") or ""):
        tab.click()
        expect(page.locator(".bk-tab.bk-active", has_text=re.compile(f"^{label}$")).first).to_be_visible(
            timeout=budget_ms(30)
        )


def _barrier(page):
    """A round trip to the server: log10 A*'s field retyped with the state's
    value (with or without a leading space: a new text, the same value).
    Once the server has read it, it has answered what the page sent before
    (in the order sent)."""
    box = page.locator(".vt-field-log_amplitude input").first
    la = _address(page)["la"]
    box.fill(la if box.input_value() != la else f" {la}")
    box.press("Enter")
    read_back(page, "vt-field-log_amplitude")


def _choose(page, label, option, barrier=True):
    """Choose the option labelled `option` of the selector `label` (if it is
    not chosen); wait for the server's answer (the page's own line where it
    says it is busy, then a round trip, unless the caller waits for the
    answer itself)."""
    select = page.get_by_label(label, exact=True).first
    if select.evaluate("(s) => s.selectedIndex >= 0 ? s.options[s.selectedIndex].text : null") != option:
        select.select_option(label=option)
        answered(page)
        if barrier:
            _barrier(page)


def _press(page, option):
    """Press the radio button `option` (if it is not pressed); the map is redrawn."""
    button = page.get_by_role("button", name=option, exact=True).first
    if "bk-active" not in (button.get_attribute("class") or ""):
        button.click()
        answered(page)


def _wait_address(page, key, value):
    """Wait until the address holds `value` at `key` (None: not there)."""
    page.wait_for_function(
        "([k, v]) => new URLSearchParams(location.search).get(k) === v",
        arg=[key, value],
        timeout=budget_ms(30),
    )


def _shown(locator):
    return locator.count() > 0 and locator.first.is_visible()


def _type(page, field, text):
    """Type `text` into the field of CSS class `field` and commit it
    (Enter); wait until the server has read it (its answer is in the page's
    models then)."""
    box = page.locator(f".{field} input").first
    box.fill(text)
    box.press("Enter")
    read_back(page, field)


def _message(page, cls, names):
    """Wait until the message of class `cls` is shown (drawn) and names one
    of `names`; its text."""
    try:
        return page.wait_for_function(
            f"""([cls, names]) => {{
              const t = ({SHOWN_TEXT_JS})(cls).replace(/\\u2019/g, "'").replace(/\\s+/g, " ");
              return names.some((n) => t.includes(n)) && t;
            }}""",
            arg=[cls, names],
            timeout=budget_ms(30),
        ).json_value()
    except PageTimeout:
        raise AssertionError(f"no message naming {names}: {shown_text(page, cls)!r}") from None


def _no_message(page, cls):
    """Wait until no message of class `cls` is shown (in the page's models)."""
    try:
        page.wait_for_function(f"(cls) => ({_MESSAGES_JS})(cls) === ''", arg=cls, timeout=budget_ms(30))
    except PageTimeout:
        raise AssertionError(f"a message for a valid value: {shown_text(page, cls)!r}") from None


def _typed_number(page, owner, name, text, key=None):
    """A NumberField typed: the value applied (in the address, when its
    parameter is in the link) with no message, or the message under the
    field naming it and its range (urlstate.convert decides which)."""
    _type(page, f"vt-field-{name}", text)
    p = owner.param[name]
    try:
        value = urlstate.convert(p, text)
    except ValueError:
        label = page.locator(f".vt-field-{name} label").first.inner_text().strip()
        _message(page, f"vt-error-{name}", [_normal(f"{label} must be {urlstate.valid_range(p)}")])
        return
    _no_message(page, f"vt-error-{name}")
    if key is not None:
        _wait_address(page, key, None if value is None else urlstate.written(value))


@st.composite
def sidebar_actions(draw):
    """One action on the sidebar or the Units tab: a number typed, the
    profile's number or j typed, a custom material typed, an option chosen,
    a radio button pressed."""
    kind = draw(
        st.sampled_from(["number", "number", "profile", "rolling", "custom", "select", "radio", "run"])
    )
    if kind == "number":
        name = draw(st.sampled_from([*SIDEBAR_NUMBERS, *UNITS_NUMBERS]))
        return kind, name, draw(numbers(ExplorerState.param[name]))
    if kind == "profile":
        return kind, draw(st.sampled_from(["power law z ~ r^N", "flat-ended sphere"])), draw(PROFILE_NUMBERS)
    if kind == "rolling":
        return kind, None, draw(numbers(ExplorerState.param["rolling"]))
    if kind == "custom":
        part = st.one_of(st.sampled_from(EDGE_TEXTS), st.floats().map(repr))
        text = st.one_of(
            st.tuples(part, part, part).map(lambda t: f"E={t[0]},nu={t[1]},rho={t[2]}"),
            st.sampled_from(["E=70e9,nu=0.3,rho=2500", "E=1e308,nu=0.49,rho=1e308", "nu=0.3", "E=,nu=,rho="]),
            st.text(max_size=30),
        )
        return kind, draw(st.sampled_from(["substrate", "particle"])), draw(text)
    if kind == "select":
        return kind, draw(st.sampled_from(sorted(SELECTS))), draw(st.integers(0, 20))  # (an option, modulo)
    if kind == "run":  # (the sidebar's scene, or the Units tab's device)
        return kind, draw(st.sampled_from(["Run selected scene", "Run this device's scene"])), None
    key = draw(st.sampled_from(sorted(RADIOS)))
    return kind, key, draw(st.sampled_from(RADIOS[key]))


@pytest.fixture
def sidebar_page(explorer):
    """The module's page on a link with the material point's controls
    (compare with the point mass) and the Units tab; runs kept short."""
    page = explorer.page
    page.goto(explorer.served.url + "?" + urlencode({**CHEAP_RUN, "compare": "point mass", "tab": "units"}))
    page.locator(".vt-field-radius input").first.wait_for(timeout=budget_ms(60))
    return explorer


def _profile_of(kind, text):
    """The profile a kind with its number's text makes (the sidebar's
    reading, app/views/profile.py), or None where it is refused."""
    if kind in ("sphere", "cone"):
        return kind
    text = (text or "").strip()
    spec = f"{kind}:{text}"
    if not (0 < len(text) <= urlstate.MAX_LENGTH and urlstate.PLAIN_NUMBER.fullmatch(text)):
        return None
    try:
        return ExplorerState.param["profile"].check_text(spec)
    except ValueError:
        return None


def _rolling_of(text):
    """j's text as the particle's rolling (its link's spelling), or None."""
    text = (text or "").strip()
    if not 0 < len(text) <= urlstate.MAX_LENGTH:
        return None
    try:
        return urlstate.written(ExplorerState.param["rolling"].check_text(text))
    except ValueError:
        return None


def _applied_or_said(page, key, want, cls, names):
    """The server has answered: the address holds `want` at `key`, or (want
    None) the message of class `cls` is shown and names one of `names`."""
    if want is not None:
        _wait_address(page, key, want)
        _no_message(page, cls)
    else:
        _message(page, cls, names)


def _profile_number(page, option, text):
    """The profile's number typed (a power law's N, a flat's C): the
    profile applied, or the message naming it (the library decides)."""
    _press(page, "deformable")
    _choose(page, "particle profile", option)
    _type(page, "vt-profile-number", text)
    label = page.locator(".vt-profile-number label").first.inner_text().strip()
    want = _profile_of(KINDS[option], text)
    _applied_or_said(page, "profile", want, "vt-error-profile", [_normal(label), "profile"])


def _rolling_number(page, text):
    """j typed: the particle rolls with it, or the message naming j."""
    _press(page, "deformable")  # (the material point does not roll)
    _choose(page, "particle rolls?", J_OPTION)
    _type(page, "vt-rolling-j", text)
    _applied_or_said(page, "rolling", _rolling_of(text), "vt-error-rolling", ["j = I/(m R^2)", "rolling"])


def _custom(page, which, text):
    """A custom material typed: the device's numbers, or the library's
    message saying what is wrong in it."""
    _choose(page, which, CUSTOM_MATERIAL)
    _type(page, f"vt-{which}-custom", text)
    info = page.locator(":is(p, td)", has_text=re.compile(r"^(Invalid input:|A\*$)")).first
    info.wait_for(timeout=budget_ms(30))
    said = info.inner_text()
    if said.startswith("Invalid input:"):
        assert re.search(r"must|unknown material", said), said


def _select(page, label, index):
    """An option of a selector (its index modulo their number): the
    address holds it (or the profile's or j's message shows)."""
    if label in ("particle rolls?", "particle profile"):
        _press(page, "deformable")
    if label.startswith("stick rule"):  # (shown with the point mass)
        _choose(page, "compare with", "point mass")
    if label == "Paper points":  # (it runs the point: a short run)
        _choose(page, "fidelity", "preview")
        _choose(page, "compare with", "none")
    select = page.get_by_label(label, exact=True).first
    options = select.evaluate("(s) => [...s.options].map((o) => o.text)")
    option = options[index % len(options)]
    key = SELECTS[label]
    _choose(page, label, option, barrier=key in ("profile", "rolling"))  # (else: the address waited for)
    if label == "Paper points":
        number = index % len(options)
        if number:
            la, lm, model = PAPER_POINTS[number]
            assert option == f"{number}: {POINT_LABELS[number]}"
            _wait_address(page, "la", urlstate.written(la))
            _wait_address(page, "lm", urlstate.written(lm))
            _wait_address(page, "model", model)
    elif key == "profile":  # (a kind with a number: the text it had)
        number = page.locator(".vt-profile-number input").first
        text = number.input_value() if _shown(number) else ""
        want = _profile_of(KINDS[option], text)
        _applied_or_said(
            page, "profile", want, "vt-error-profile", ["exponent N", "flat radius C", "profile"]
        )
    elif key == "rolling":
        value = ROLLINGS[option]
        number = page.locator(".vt-rolling-j input").first
        want = _rolling_of(number.input_value()) if value == "j" else value
        _applied_or_said(page, "rolling", want, "vt-error-rolling", ["j = I/(m R^2)"])
    else:
        _wait_address(page, key, urlstate.written(float(option)) if key == "mu" else option)


def _run(page, button):
    """Run the scene as it stands (the sidebar's, or the Units tab's
    device): its run shown, or the message saying why not (an invalid field
    named, a refused scene)."""
    _choose(page, "fidelity", "preview")  # (a short run)
    page.get_by_role("button", name=button).first.click()
    answered(page, timeout_s=60)  # (the page's "Running ..." cleared: shown or refused)
    said = page.get_by_text(re.compile(r"^(Not run|The run failed)")).first
    heading = page.locator("strong", has_text=re.compile(r": A\* = ")).first
    refused = page.locator(".vt-units-refusal").first
    expect(said.or_(heading).or_(refused).first).to_be_visible(timeout=budget_ms(30))


@fuzz(FIELD_EXAMPLES)
@given(action=sidebar_actions())
@example(action=("number", "log_amplitude", "1e308"))
@example(action=("number", "log_mass", "5e-324"))
@example(action=("number", "frequency", str(10**400)))
@example(action=("profile", "power law z ~ r^N", "1e300"))
def test_every_sidebar_and_units_control_gives_the_scene_or_its_message(sidebar_page, action):
    page = sidebar_page.page
    kind, what, value = action
    assume(not any(w in str(value) for w in LEAKS))
    sidebar_page.begin()
    event(f"{kind} {what}")
    _open_tab(page, "Units")
    if kind == "number":
        if what == "alpha_t":  # (shown with the point mass)
            _choose(page, "compare with", "point mass")
        _typed_number(page, ExplorerState, what, value, key=URL_KEYS[what])
    elif kind == "profile":
        _profile_number(page, what, value)
    elif kind == "rolling":
        _rolling_number(page, value)
    elif kind == "custom":
        _custom(page, what, value)
    elif kind == "select":
        _select(page, what, value)
    elif kind == "run":
        _run(page, what)
    else:
        _press(page, value)
        if what in URL_KEYS:
            _wait_address(page, what, value)
    sidebar_page.clean()


def test_every_option_of_every_selector_gives_its_scene_or_its_message(sidebar_page):
    """Every option of the sidebar's, the Units tab's and the Design tab's
    selectors, and every radio button, in turn (the fuzzed actions above
    draw some; these are all of them)."""
    page = sidebar_page.page
    _open_tab(page, "Units")
    for label in SELECTS:
        if label.startswith("stick rule"):
            _choose(page, "compare with", "point mass")
        count = page.get_by_label(label, exact=True).first.evaluate("(s) => s.options.length")
        for index in range(count):
            sidebar_page.begin()
            _select(page, label, index)
            sidebar_page.clean()
    for key, options in RADIOS.items():
        for option in [*options[1:], options[0]]:
            sidebar_page.begin()
            _press(page, option)
            if key in URL_KEYS:
                _wait_address(page, key, option)
            sidebar_page.clean()
    _open_tab(page, "Design")
    page.get_by_role("button", name="Draw chart").first.wait_for(timeout=budget_ms(60))
    for label in DESIGN_SELECTS:
        select = page.get_by_label(label, exact=True).first
        for option in select.evaluate("(s) => [...s.options].map((o) => o.text)"):
            sidebar_page.begin()
            _choose(page, label, option)
            if label == "particle tip":
                _wait_address(page, "tip", option)
            sidebar_page.clean()


# ------------------------------------------------------------------ the Design tab
# the draw button's `disabled`, as the server sets it (busy while drawing)
_DRAWING_JS = """() => {
  if (!window.__vtDrawWatched) {
    window.__vtDrawWatched = true;
    for (const d of window.Bokeh.documents) d.on_change((e) => {
      if (e.kind === "ModelChanged" && e.attr === "disabled"
          && (e.model.css_classes || []).includes("vt-design-draw"))
        window.__vtDrawing.push(e.model.disabled);
    });
  }
  window.__vtDrawing = [];
}"""
_DRAWN_JS = (
    "() => window.__vtDrawing.includes(true) && window.__vtDrawing[window.__vtDrawing.length - 1] === false"
)


@st.composite
def design_actions(draw):
    """One action on the Design tab (its own numbers, the tip's sizes, a
    selector's option), then Draw or not."""
    kind = draw(st.sampled_from(["number", "number", "tip", "select"]))
    if kind == "number":
        name = draw(st.sampled_from(DESIGN_NUMBERS))
        action = kind, name, draw(numbers(DesignPanel.param[name]))
    elif kind == "tip":
        name = draw(st.sampled_from(sorted(TIP_SIZES)))
        action = kind, name, draw(numbers(ExplorerState.param[name]))
    else:
        action = kind, draw(st.sampled_from(DESIGN_SELECTS)), draw(st.integers(0, 20))
    return (*action, draw(st.booleans()))


def _draw_chart(page):
    """Press Draw: refused at once while a field is invalid (the alert says
    so); else drawn, offered a map, or refused by the library, the button
    busy meanwhile (the server's changes of its `disabled`)."""
    invalid = any(page.evaluate(_MESSAGES_JS, f"vt-error-{n}") for n in (*DESIGN_NUMBERS, *TIP_SIZES))
    page.evaluate(_DRAWING_JS)
    page.get_by_role("button", name="Draw chart").first.click()
    if invalid:
        page.locator(".vt-design-alert").get_by_text("Cannot draw the chart").first.wait_for(
            timeout=budget_ms(30)
        )
    else:
        page.wait_for_function(_DRAWN_JS, timeout=budget_ms(120))


@pytest.fixture
def design_page(explorer):
    """The module's page on the Design tab (runs kept short)."""
    page = explorer.page
    page.goto(explorer.served.url + "?" + urlencode({**CHEAP_RUN, "tab": "design"}))
    page.get_by_role("button", name="Draw chart").first.wait_for(timeout=budget_ms(60))
    page.evaluate(_DRAWING_JS)
    return explorer


@fuzz(DESIGN_EXAMPLES)
@given(action=design_actions())
@example(action=("number", "x_points", str(10**400), True))
@example(action=("number", "y_hi", "1e308", True))
@example(action=("tip", "tip_exponent", "1e300", True))
def test_every_design_control_gives_the_chart_or_its_message(design_page, action):
    page = design_page.page
    kind, what, value, then_draw = action
    assume(not any(w in str(value) for w in LEAKS))
    design_page.begin()
    event(f"{kind} {what}")
    if kind == "number":
        _typed_number(page, DesignPanel, what, value)
    elif kind == "tip":
        _choose(page, "particle tip", TIP_SIZES[what])
        _typed_number(page, ExplorerState, what, value, key=URL_KEYS[what])
    else:
        select = page.get_by_label(what, exact=True).first
        options = select.evaluate("(s) => [...s.options].map((o) => o.text)")
        option = options[value % len(options)]
        _choose(page, what, option)
        if what == "particle tip":
            _wait_address(page, "tip", option)
    if then_draw:
        _draw_chart(page)
    design_page.clean()
