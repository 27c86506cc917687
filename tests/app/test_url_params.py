"""Bad input through the explorer's URL and through `vibtrans simulate`,
property-based (hypothesis).

URL (app/session/urlstate.py, called by Explorer._apply_url): every invalid value
gives a message naming the URL key and the parameter and leaves the default;
valid values are applied; unknown keys are ignored; the given text is shown
escaped (the message is rendered as Markdown/HTML); the state is exactly
the parsed one; and whatever the URL, only finite,
in-range scenes reach a kernel.

CLI: over `vibtrans simulate` arguments (in-process `cli.main(argv)`), an
invalid value exits 2 with one stderr line naming the parameter; a valid
one reaches the kernel only as finite, in-domain values.  The fixed cases
are in tests/core/test_validation.py; these are random ones.
"""

import contextlib
import html
import importlib
import io
import json
import math
import re
import urllib.parse
from unittest import mock

import numpy as np
import panel as pn
import pytest
from hypothesis import HealthCheck, assume, event, example, given, settings
from hypothesis import strategies as st
from numbertexts import LOOKALIKE_NUMBERS
from tornado.httputil import parse_qs_bytes

from vibtrans.cli import main
from vibtrans.core.params import MASS_MIN, Scene
from vibtrans_explorer import explorer as E
from vibtrans_explorer.explorer import Explorer, ExplorerState
from vibtrans_explorer.server import data
from vibtrans_explorer.session import maprequest, urlstate
from vibtrans_explorer.session.state import URL_ALIASES, URL_KEYS
from vibtrans_explorer.views.browserside import BrowserAddress

# the module (the package's `simulate` attribute is the function)
S = importlib.import_module("vibtrans.core.simulate")

# texts the library checks (the particle's profile)
PROFILES = {"profile"}
# how the particle turns: none, solid, shell or j = I/(m R^2) in (0, 1]
ROLLINGS = {"rolling"}
ROLLING_TEXT = [
    "none",
    "solid",
    "shell",
    "0.4",
    "1",
    "0.5e0",
    "0",
    "1.5",
    "-0.1",
    "nan",
    "inf",
    "1_0",
    "Solid",
    " solid",
    "1e-300",
]
# the tip's sizes in SI (the Design tab's): the ranges that
# docs/MODEL.md section 10 ("In device units") and vibtrans.products.designtip
# document ((lo, hi), (lo included, hi included)); a power law's N = 1 is
# the cone (refused: the cone takes its half-angle); the tip radius may be
# absent (empty: the particle's radius)
TIPS = {
    "tip_half_angle": ((0.0, 90.0), (False, False)),
    "tip_exponent": ((1.0, math.inf), (False, False)),
    "tip_radius": ((0.0, math.inf), (False, False)),
    "tip_flat_radius": ((0.0, math.inf), (True, False)),
}
NUMERIC = {
    name: ExplorerState.param[name].bounds
    for name in URL_KEYS
    if not hasattr(ExplorerState.param[name], "objects")
    and name not in PROFILES
    and name not in TIPS
    and name not in ROLLINGS
}
OPTIONS = {
    name: ExplorerState.param[name].objects
    for name in URL_KEYS
    if name not in NUMERIC and name not in PROFILES and name not in TIPS and name not in ROLLINGS
}
# profile texts: valid ones, then ones the library or the explorer refuses
PROFILE_TEXT = [
    "sphere",
    "cone",
    "power:3",
    "power:1",
    "power:2",
    "power:1.5",
    "flat-sphere:0",
    "flat-sphere:0.5",
    " cone ",
    "power:0.5",
    "power:0",
    "power:-3",
    "power:nan",
    "power:inf",
    "power:",
    "power",
    "flat-sphere:-1",
    "flat-sphere:x",
    "Cone",
    "sphere:1",
    "file:/etc/passwd",
    "file:profile.txt",
    "file:",
    "power:3,x",
]
KEY_NAME = {key: name for name, key in URL_KEYS.items()}
MAPS = data.available_maps()

# ------------------------------------------------------------------ strategies
SPECIAL_TEXT = [
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    "1e999",
    "-1e999",
    "1e-999",
    *LOOKALIKE_NUMBERS,
    "",
    " ",
    "+",
    "-",
    ".",
    "e5",
    "1e",
    "--1",
    "1..2",
    "true",
    "null",
    "None",
    "[1, 2]",
    "{}",
    "'1'",
    "1j",
    "<img src=x onerror=alert(1)>",
    "<script>alert(1)</script>",
    "[x](javascript:alert(1))",
    "**bold**",
    "`code`",
    "a\nb",
    "\x00",
    "\u202e1",
    "9" * 400,
    "1" + "0" * 70,
    "Deformable",
    "point mass",
    "AB4",
    "rk4",
    "tau",
    "colour",
]


def _number_text(lo, hi):
    """Texts of numbers, mostly near [lo, hi], as a person or a bug writes them."""
    finite = st.one_of(
        st.floats(lo - 1, hi + 1),
        st.floats(allow_nan=False, allow_infinity=False),
        st.sampled_from([lo, hi, 0.0, -0.0, lo - 1e-9, hi + 1e-9]),
    )
    return st.one_of(
        finite.map(repr),
        finite.map(lambda v: f"{v:g}"),
        finite.map(lambda v: f"{v:.3e}"),
        st.integers(-(10**30), 10**30).map(str),
    )


def _profile_text():
    """Profile texts: the fixed ones, and a power law's or a flat's number
    over every float, huge integers and exponents (power:1e300)."""
    number = st.one_of(
        _number_text(0.0, 1e3),
        st.floats().map(repr),
        st.integers(0, 10**400).map(str),
        st.integers(-400, 400).map(lambda e: f"1e{e}"),
    )
    return st.one_of(
        st.sampled_from(PROFILE_TEXT),
        st.tuples(st.sampled_from(["power", "flat-sphere"]), number).map(lambda kv: f"{kv[0]}:{kv[1]}"),
    )


def _value_text(name):
    own = (
        _number_text(*NUMERIC[name])
        if name in NUMERIC
        else _number_text(TIPS[name][0][0], min(TIPS[name][0][1], 1e3))
        if name in TIPS
        else _profile_text()
        if name in PROFILES
        else st.one_of(st.sampled_from(ROLLING_TEXT), st.floats().map(repr))
        if name in ROLLINGS
        else st.sampled_from(list(OPTIONS[name]))
    )
    return st.one_of(own, st.sampled_from(SPECIAL_TEXT), st.text(max_size=30))


@st.composite
def queries(draw):
    """A list of (key, value) pairs: known keys with good or bad values,
    unknown keys, repeated keys, raw bytes that are not UTF-8."""
    pairs = []
    for _ in range(draw(st.integers(0, 8))):
        kind = draw(st.sampled_from(["known", "known", "known", "unknown", "repeat", "bytes"]))
        if kind == "unknown":
            key = draw(
                st.one_of(
                    st.sampled_from(
                        ["chaotic", "LA", "la ", "utm_source", "x", "mu[]", "la.1", "log_amplitude"]
                    ),
                    st.text(min_size=1, max_size=8),
                )
            )
            # unknown to the explorer: not a state key, nor the map request's
            # (`map=`, read and checked by the map on demand, not by this oracle)
            assume(key not in KEY_NAME and key != maprequest.URL_KEY)
            pairs.append((key, draw(st.text(max_size=10))))
        elif kind == "bytes":
            key = draw(st.sampled_from(sorted(KEY_NAME)))
            pairs.append((key, draw(st.binary(max_size=12))))
        else:
            key = draw(st.sampled_from(sorted(KEY_NAME)))
            value = draw(_value_text(KEY_NAME[key]))
            pairs.append((key, value))
            if kind == "repeat":
                pairs.append((key, draw(st.one_of(st.just(value), _value_text(KEY_NAME[key])))))
    return pairs


def _args(pairs):
    """The query as Tornado hands it to the session: {key: [bytes, ...]}."""
    return parse_qs_bytes(_query(pairs), keep_blank_values=True)


def _query(pairs):
    return urllib.parse.urlencode(pairs)


def _profile_valid(text):
    """The library's profile check (parse_profile), a measured table refused."""
    from vibtrans.core.profiles import parse_profile

    if not isinstance(text, str) or text.startswith("file:"):
        return False
    try:
        parse_profile(text)
    except ValueError:
        return False
    return True


def _tip_valid(name, value):
    """The documented range of a tip's size (TIPS); None only for the tip radius."""
    if value is None:
        return name == "tip_radius"
    (lo, hi), (lo_in, hi_in) = TIPS[name]
    return (
        isinstance(value, float)
        and math.isfinite(value)
        and (lo <= value if lo_in else lo < value)
        and (value <= hi if hi_in else value < hi)
    )


def _rolling_valid(value):
    """none, solid, shell, or a number j in (0, 1] (the text of a plain decimal)."""
    if value in ("none", "solid", "shell"):
        return True
    return isinstance(value, float) and 0.0 < value <= 1.0


def _rolling_value(text):
    """A rolling text as the oracle reads it: a name, or a plain decimal's value."""
    text = text.strip()
    if text in ("none", "solid", "shell"):
        return text
    return float(text) if re.fullmatch(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", text) else None


def _valid(name, value):
    if name in PROFILES:
        return _profile_valid(value)
    if name in ROLLINGS:
        return _rolling_valid(value)
    if name in TIPS:
        return _tip_valid(name, value)
    if name in OPTIONS:
        return value in OPTIONS[name]
    return isinstance(value, float) and math.isfinite(value) and _inside(name, value)


def _inside(name, value):
    """Inside the parameter's bounds, each bound included or not as the
    parameter says (nu's are open, the device's radius excludes 0)."""
    (lo, hi), (lo_in, hi_in) = NUMERIC[name], ExplorerState.param[name].inclusive_bounds
    return (lo <= value if lo_in else lo < value) and (value <= hi if hi_in else value < hi)


# ------------------------------------------------------------------ the pure parser
@settings(max_examples=400, deadline=None)
@given(pairs=queries())
@example(pairs=[("la", "abc"), ("mu", "7"), ("model", "rigid")])
@example(pairs=[("la", "2"), ("la", "3")])
@example(pairs=[("la", "<img src=x onerror=alert(1)>")])
@example(pairs=[("mu", "0.5")])
@example(pairs=[("model", "point-mass"), ("mu", "1")])
def test_parse_applies_valid_values_and_names_invalid_ones(pairs):
    args = _args(pairs)
    values, errors = urlstate.parse(args, ExplorerState, URL_KEYS, URL_ALIASES)
    # only known parameters, only valid values (a mu without a shipped map
    # is kept: the page shows it as it is)
    assert set(values) <= set(URL_KEYS)
    for name, value in values.items():
        assert _valid(name, value), (name, value)
    ExplorerState(**urlstate.resolved(values, ExplorerState, URL_KEYS))
    text = " ".join(errors)
    for key, raw in args.items():
        if key not in KEY_NAME:
            assert f"URL parameter '{key}'" not in text  # unknown keys: ignored
            continue
        name = KEY_NAME[key]
        named = f"URL parameter '{key}' ({name})" in text
        if name in values:
            assert not named, (key, raw, errors)
            texts = {r.decode("utf-8", "replace").strip(" \t") for r in raw}
            assert len(texts) == 1
            given_ = texts.pop()
            given_ = URL_ALIASES.get(name, {}).get(given_, given_)
            expected = (
                given_
                if name in OPTIONS
                or name in PROFILES
                or (name in ROLLINGS and given_ in ("none", "solid", "shell"))
                else None
                if name in TIPS and given_ == ""
                else float(given_)
            )
            assert values[name] == expected  # a valid value is applied as given
        else:
            assert named, (key, raw, errors)
    for e in errors:
        assert len(e) < 500, e
        # nothing of the given text can become markup: no tag, no entity, no emphasis
        assert "<" not in e and ">" not in e and "\n" not in e, e


@settings(max_examples=300, deadline=None)
@given(name=st.sampled_from(sorted(NUMERIC)), data_=st.data())
def test_parse_numbers_exactly_the_documented_ones(name, data_):
    raw = data_.draw(
        st.one_of(_number_text(*NUMERIC[name]), st.sampled_from(SPECIAL_TEXT), st.text(max_size=20))
    )
    values, errors = urlstate.parse({URL_KEYS[name]: [raw.encode()]}, ExplorerState, URL_KEYS)
    plain = re.fullmatch(r"[ \t]*[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d{1,4})?[ \t]*", raw, re.ASCII)
    lo, hi = NUMERIC[name]
    ok = (
        plain is not None
        and len(raw) <= urlstate.MAX_LENGTH
        and math.isfinite(float(raw))
        and _inside(name, float(raw))
    )
    if ok:
        assert values == {name: float(raw)} and errors == []
    else:
        assert values == {} and len(errors) == 1
        lo_in, hi_in = ExplorerState.param[name].inclusive_bounds
        assert (
            f"'{URL_KEYS[name]}' ({name}) must be a number in {'[' if lo_in else '('}{lo}, "
            f"{hi}{']' if hi_in else ')'}"
        ) in errors[0]


@settings(max_examples=300, deadline=None)
@given(name=st.sampled_from(sorted(TIPS)), data_=st.data())
@example(name="tip_exponent", data_=None)
def test_tip_sizes_parse_exactly_the_documented_ones(name, data_):
    # the Design tab's tip in a link; designtip checks each size
    # (its message added), nothing clamped
    lo, hi = TIPS[name][0]
    raw = (
        "1"
        if data_ is None
        else data_.draw(
            st.one_of(_number_text(lo, min(hi, 1e3)), st.sampled_from(SPECIAL_TEXT), st.text(max_size=20))
        )
    )
    values, errors = urlstate.parse({URL_KEYS[name]: [raw.encode()]}, ExplorerState, URL_KEYS)
    plain = re.fullmatch(r"[ \t]*[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d{1,4})?[ \t]*", raw, re.ASCII)
    if name == "tip_radius" and len(raw) <= urlstate.MAX_LENGTH and raw.strip(" \t") == "":
        assert values == {name: None} and errors == []  # the particle's radius
    elif plain is not None and len(raw) <= urlstate.MAX_LENGTH and _tip_valid(name, float(raw)):
        assert values == {name: float(raw)} and errors == []
    else:
        assert values == {} and len(errors) == 1
        assert errors[0].startswith(
            f"URL parameter '{URL_KEYS[name]}' ({name}) must be {ExplorerState.param[name].range_text}"
        )
        if plain is not None and len(raw) <= urlstate.MAX_LENGTH and math.isfinite(float(raw)):
            # the library's reason, naming the parameter
            word = {
                "tip_half_angle": "half\\_angle",
                "tip_exponent": "exponent",
                "tip_radius": "tip\\_radius",
                "tip_flat_radius": "flat\\_radius",
            }[name]
            assert word in errors[0], errors[0]


def test_older_links_without_a_tip_mean_the_sphere_and_links_round_trip():
    values, errors = urlstate.parse({"la": [b"1"]}, ExplorerState, URL_KEYS)
    state = ExplorerState(**urlstate.resolved(values, ExplorerState, URL_KEYS))
    assert errors == [] and state.tip == "sphere" and state.tip_radius is None
    state.param.update(
        tip="power", tip_exponent=2.5, tip_radius=2e-4, tip_half_angle=30.0, tip_flat_radius=0.0
    )
    query = urlstate.query(state, URL_KEYS)
    assert "tip=power" in query and "tipn=2.5" in query and "tipr=0.0002" in query
    again, errors = urlstate.parse(parse_qs_bytes(query.lstrip("?")), ExplorerState, URL_KEYS)
    assert errors == []
    assert {
        k: again[k] for k in ("tip", "tip_exponent", "tip_radius", "tip_half_angle", "tip_flat_radius")
    } == {
        "tip": "power",
        "tip_exponent": 2.5,
        "tip_radius": 2e-4,
        "tip_half_angle": 30.0,
        "tip_flat_radius": 0.0,
    }
    # the particle's own radius (None) is left out of the link, and read back so
    state.tip_radius = None
    assert "tipr" not in urlstate.query(state, URL_KEYS)


def test_a_tip_size_set_in_code_is_refused_with_the_librarys_message():
    state = ExplorerState()
    with pytest.raises(ValueError, match=r"half_angle must be a real number in \(0, 90\)"):
        state.tip_half_angle = 90.0
    with pytest.raises(ValueError, match=r"exponent N must be a real number in \(1, inf\)"):
        state.tip_exponent = 1.0
    with pytest.raises(ValueError, match=r"flat_radius must be a real number in \[0, inf\)"):
        state.tip_flat_radius = -1e-9
    assert (state.tip_half_angle, state.tip_exponent, state.tip_flat_radius) == (
        ExplorerState.param.tip_half_angle.default,
        ExplorerState.param.tip_exponent.default,
        ExplorerState.param.tip_flat_radius.default,
    )


def test_message_is_shown_as_text_not_markup():
    # What the browser receives for the Alert (its innerHTML): the given
    # text is inert.  Before app/session/urlstate.py the raw value went into the
    # Markdown as is: `?la=<img src=x onerror=alert(1)>` made an <img> tag.
    _, errors = urlstate.parse(
        {"la": [b"<img src=x onerror=alert(1)>"], "lm": [b"**[x](javascript:alert(2))**"]},
        ExplorerState,
        URL_KEYS,
    )
    alert = pn.pane.Alert(urlstate.message(errors), alert_type="danger")
    inner = html.unescape(alert._transform_object(alert.object)["object"])
    assert "<img" not in inner and "<a" not in inner and "<strong" not in inner, inner
    assert "&lt;img src=x onerror=alert(1)&gt;" in inner


def test_mu_without_a_shipped_map_is_kept_as_given():
    # `?mu=0.5` must not say "showing mu = 0.3" with its selector at 0.1
    # while the run uses 0.5: the value is the link's, everywhere
    values, errors = urlstate.parse(
        {"model": [b"point-mass"], "mu": [b"0.1"]}, ExplorerState, URL_KEYS, URL_ALIASES
    )
    assert values == {"model": "point-mass", "mu": 0.1} and errors == []


def test_old_spellings_are_accepted_and_links_use_one():
    values, errors = urlstate.parse(
        {"model": [b"point_mass"], "compare": [b"point-mass"]}, ExplorerState, URL_KEYS, URL_ALIASES
    )
    assert values == {"model": "point-mass", "compare": "point mass"} and errors == []
    state = ExplorerState(model="point-mass")
    assert "model=point-mass" in urlstate.query(state, URL_KEYS)


# ------------------------------------------------------------------ the Explorer object
@pytest.fixture
def url_session(monkeypatch):
    """Make Explorer() see `pairs` as its page's query, as a served session
    does: pn.state.session_args (Tornado's parse) and the page's address
    (nothing written in it yet: the browser shows the link as given)."""

    def open_(pairs):
        monkeypatch.setattr(E, "_page_location", BrowserAddress)
        monkeypatch.setattr(type(pn.state), "session_args", property(lambda self: _args(pairs)))
        return Explorer()

    return open_


class _Reached(Exception):
    """Raised by the fake kernel drivers: the scene got to a kernel."""


def _fake_driver(seen):
    """Stands in for simulate._run_hertz/_run_point_mass: records and checks
    what would reach the numba kernel, then stops."""

    def driver(scene, w0, w1, samples_per_period, refine, *args, **kwargs):
        v = scene.values()
        for k in ("amplitude", "mass", "mu", "theta", "nu", "tau", "periods", "alpha_t"):
            assert isinstance(v[k], float) and math.isfinite(v[k]), (k, v[k])
        assert 0 <= v["amplitude"] and 0 < v["mass"] and 0 < v["mu"] and 0 < v["periods"]
        assert 1 <= v["theta"] <= 1.5 and 0 < v["nu"] < 0.5 and 0 <= v["tau"]
        assert 0 <= v["alpha_t"] <= 1
        assert v["model"] in ("deformable", "point-mass", "vertical")
        assert v["fidelity"] in ("preview", "standard", "reference")
        assert v["integrator"] in ("ab4", "verlet") and v["stick_rule"] in ("paper", "classical")
        assert _profile_valid(v["profile"]), v["profile"]
        assert (w0, w1) == (math.inf, -math.inf) or (
            math.isfinite(w0) and math.isfinite(w1) and 0 <= w0 <= w1 <= v["periods"]
        )
        assert isinstance(samples_per_period, (int, np.integer))
        assert 1 <= samples_per_period <= 10000
        assert math.isfinite(refine) and 1 <= refine <= 1024
        seen.append(v)
        raise _Reached()

    return driver


@pytest.fixture
def kernel_calls(monkeypatch):
    seen = []
    monkeypatch.setattr(S, "_run_hertz", _fake_driver(seen))
    monkeypatch.setattr(S, "_run_point_mass", _fake_driver(seen))
    return seen


def _run_now(explorer):
    """The explorer's controller.run without a server: its pool runs the (faked) kernels."""
    import asyncio

    asyncio.run(explorer.controller.run())


@pytest.mark.slow
@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(pairs=queries())
@example(pairs=[("la", "2"), ("la", "3")])
@example(pairs=[("la", "NaN"), ("lm", "Infinity"), ("fidelity", "reference")])
@example(pairs=[("la", "١"), ("lm", "[1, 2]")])
@example(pairs=[("compare", "²"), ("x", "²")])  # Panel's parse_query: int('²') raised
@example(pairs=[("model", "rigid"), ("la", "2")])
@example(pairs=[("la", "3"), ("lm", "-5"), ("fidelity", "reference"), ("compare", "point mass")])
# every scene key away from its default, with each comparison (the run must
# carry each one: a key the explorer dropped would arrive as its default)
@example(
    pairs=[("la", "0.5"), ("lm", "0.25"), ("mu", "0.1"), ("integrator", "verlet"), ("fidelity", "preview")]
)
@example(
    pairs=[
        ("la", "1"),
        ("lm", "-1"),
        ("mu", "1"),
        ("compare", "point mass"),
        ("fidelity", "reference"),
        ("integrator", "verlet"),
    ]
)
@example(
    pairs=[("model", "point-mass"), ("la", "1.5"), ("lm", "-2"), ("compare", "none"), ("fidelity", "preview")]
)
@example(pairs=[("nu", "0.25"), ("theta", "1.1")])  # the material's values run too
@example(pairs=[("la", "0.5"), ("profile", "cone"), ("compare", "point mass")])  # a profile
@example(pairs=[("la", "0.5"), ("profile", "file:/etc/passwd")])
# a steep power law: its tip's outline overflowed (a traceback page)
@example(pairs=[("profile", "power:400")])
@example(pairs=[("profile", "power:1e300"), ("la", "0.5")])
@example(pairs=[("profile", "flat-sphere:1e300")])
def test_explorer_state_is_the_validated_one(url_session, kernel_calls, pairs):
    explorer = url_session(pairs)
    values, errors = urlstate.parse(_args(pairs), ExplorerState, URL_KEYS, URL_ALIASES)
    expected = urlstate.resolved(values, ExplorerState, URL_KEYS)
    got = {name: getattr(explorer.state, name) for name in URL_KEYS}
    assert got == expected
    assert explorer.message.visible == bool(errors)
    assert explorer.message.object == urlstate.message(errors)
    # a link naming a scene (log10 A* or m*) runs it when the page has
    # loaded, unless the link has an error (then the message is the news)
    assert explorer.runs_on_load == (not errors and ("la" in dict(pairs) or "lm" in dict(pairs)))
    if errors:
        # a link with an error stays in the address while its message
        # shows (nothing written); the first change writes the state's
        assert explorer.location.search == ""
        v0 = explorer.state.v0
        explorer.state.v0 = 0.5 if v0 != 0.5 else 0.2
        explorer.state.v0 = v0
    # the URL now shows the state in use
    query = {
        k: v[0]
        for k, v in urllib.parse.parse_qs(
            explorer.location.search.lstrip("?"), keep_blank_values=True
        ).items()
    }
    for name, key in URL_KEYS.items():
        if got[name] is None:  # (the tip radius: the particle's own)
            assert key not in query
            continue
        assert query[key] == got[name] or float(query[key]) == got[name]
    kernel_calls.clear()
    _run_now(explorer)
    # a run either reached the kernel with checked values, or was refused by
    # the server's step cap with a message
    assert kernel_calls or "over this server's limit" in explorer.message.object
    if kernel_calls:
        # every scene key arrives as the URL set it, the rest at the Scene
        # defaults; the comparison run is the same scene with tau + 1e-3
        # (docs/MODEL.md section 4) or the material point, or absent
        main = {
            **Scene().values(),
            "amplitude": 10 ** got["log_amplitude"],
            "mass": 10 ** got["log_mass"],
            "mu": got["mu"],
            "model": got["model"],
            "fidelity": got["fidelity"],
            "integrator": got["integrator"],
            "stick_rule": got["stick_rule"],
            "alpha_t": got["alpha_t"],
            "tau": got["tau"],
            "periods": got["periods"],
            "theta": got["theta"],
            "nu": got["nu"],
            "profile": got["profile"],
        }
        if got["rolling"] != "none":  # (a scene's values name rolling only then)
            main["rolling"] = got["rolling"]
        expected = [main]
        if got["compare"] == "tau twin":
            expected.append({**main, "tau": main["tau"] + 1e-3})
        elif got["compare"] == "point mass" and got["model"] == "deformable":
            # the material point has no size: its comparison run does not roll
            point = {k: v for k, v in main.items() if k != "rolling"}
            expected.append({**point, "model": "point-mass"})
        assert sorted(kernel_calls, key=repr) == sorted(expected, key=repr)


def test_bad_url_message_and_defaults(url_session):
    explorer = url_session(
        [("la", "abc"), ("mu", "7"), ("model", "rigid"), ("lm", "0.5"), ("utm_source", "x")]
    )
    msg = explorer.message.object
    assert "URL parameter 'la' (log_amplitude) must be a number in [-6.0, 6.0]; got 'abc'" in msg
    assert "URL parameter 'model' (model) must be one of deformable, point-mass" in msg
    assert "URL parameter 'mu' (mu) must be a number in [0.01, 1.0]; got '7'" in msg
    assert "utm_source" not in msg
    s = explorer.state
    assert (s.log_amplitude, s.log_mass, s.model, s.mu) == (-0.3, 0.5, "deformable", 0.3)


def test_valid_url_is_applied_without_message(url_session):
    explorer = url_session(
        [
            ("la", "2.5"),
            ("lm", "0"),
            ("model", "point-mass"),
            ("fidelity", "preview"),
            ("integrator", "verlet"),
            ("v0", "0.5"),
            ("compare", "none"),
        ]
    )
    s = explorer.state
    assert (s.log_amplitude, s.log_mass, s.model, s.fidelity, s.integrator, s.v0, s.compare) == (
        2.5,
        0.0,
        "point-mass",
        "preview",
        "verlet",
        0.5,
        "none",
    )
    assert not explorer.message.visible


# ------------------------------------------------------------------ vibtrans simulate
DOMAIN = {  # CLI option -> membership test of its valid values (vibtrans/core/params.py)
    "--amplitude": lambda v: 0 <= v < math.inf,
    "--mass": lambda v: MASS_MIN <= v < math.inf,
    "--mu": lambda v: 0 < v < math.inf,
    "--theta": lambda v: 1 <= v <= 1.5,
    "--nu": lambda v: 0 < v < 0.5,
    "--tau": lambda v: 0 <= v < math.inf,
    "--periods": lambda v: 0 < v < math.inf,
    "--alpha-t": lambda v: 0 <= v <= 1,
    "--log-amplitude": lambda v: abs(v) <= 300,
    "--log-mass": lambda v: abs(v) <= 300,
}
CHOICES = {
    "--model": ("deformable", "point-mass", "vertical"),
    "--fidelity": ("preview", "standard", "reference"),
    "--integrator": ("ab4", "verlet"),
    "--stick-rule": ("paper", "classical"),
}
OTHER = ("--samples-per-period", "--max-steps", "--window", "--rolling")
BASE = {"--amplitude": "0.5", "--mass": "10", "--periods": "5"}


def _cli_text(option):
    near = {
        "--samples-per-period": st.integers(-2, 20000).map(str),
        "--max-steps": st.floats(-10, 1e9).map(repr),
        "--window": st.floats(-1, 6).map(lambda v: f"{v:.3g}"),
        "--rolling": st.sampled_from(ROLLING_TEXT),
    }
    own = (
        st.sampled_from(CHOICES[option])
        if option in CHOICES
        else near.get(
            option,
            st.floats(-0.5, 2.5).map(lambda v: f"{v:.3g}")
            if option not in ("--theta", "--nu")
            else st.floats(0.9, 1.6).map(str)
            if option == "--theta"
            else st.floats(-0.1, 0.6).map(str),
        )
    )
    return st.one_of(
        own,
        own,
        own,
        own,
        st.floats().map(repr),
        st.integers(-(10**400), 10**400).map(str),
        st.sampled_from(SPECIAL_TEXT),
        st.text(max_size=12),
        st.sampled_from([c for cs in CHOICES.values() for c in cs]),
    )


def _spellings(option):
    return (option, option.lstrip("-"), option.lstrip("-").replace("-", "_"))


@pytest.mark.slow
@settings(max_examples=500, deadline=None)
@given(option=st.sampled_from(sorted([*DOMAIN, *CHOICES, *OTHER])), data_=st.data())
def test_cli_simulate_value_is_refused_in_one_line_or_reaches_the_kernel_checked(option, data_):
    values = [data_.draw(_cli_text(option))] + (
        [data_.draw(_cli_text(option))] if option == "--window" else []
    )
    argv = dict(BASE)
    if option == "--log-amplitude":
        argv.pop("--amplitude")
    if option == "--log-mass":
        argv.pop("--mass")
    args = ["simulate", "--twin", "never"]
    for k, v in argv.items():
        args += [k, v]
    args += [option, *values]
    seen, err = [], io.StringIO()
    with (
        mock.patch.object(S, "_run_hertz", _fake_driver(seen)),
        mock.patch.object(S, "_run_point_mass", _fake_driver(seen)),
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(io.StringIO()),
    ):
        try:
            code = main(args)
        except SystemExit as exc:  # argparse's own errors
            code = exc.code
        except _Reached:
            code = "reached"
    err = err.getvalue()
    event(f"{option}: {'reached the kernel' if code == 'reached' else 'refused'}")
    if code == "reached":
        assert len(seen) == 1
        if option in DOMAIN:  # reached: the value was in the domain
            v = float(values[0])
            assert math.isfinite(v) and DOMAIN[option](v), (option, values)
        elif option in CHOICES:
            assert values[0] in CHOICES[option]
        elif option == "--rolling":
            assert _rolling_valid(_rolling_value(values[0])), values
        return
    assert code == 2, (args, code, err)
    lines = err.splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    line = lines[0]
    # the line names the option, or (a valid scene too costly to run) the step budget
    assert any(s in line for s in _spellings(option)) or "budget" in line, (args, line)
    costly = "budget" in line
    if option in DOMAIN and not costly:
        try:
            v = float(values[0])
        except ValueError:
            return
        assert not (math.isfinite(v) and DOMAIN[option](v)), (option, values, line)
    if option in CHOICES:
        assert values[0] not in CHOICES[option], line
    if option == "--rolling":
        assert not _rolling_valid(_rolling_value(values[0])), (values, line)


@pytest.mark.parametrize("argv", [["--amplitude", "1.48e-289"], ["--log-amplitude=-300"]])
def test_cli_tiny_amplitude_runs(capsys, argv):
    # Found by the property above: (4 pi A*)^2 underflowed to 0, the time
    # step was 0 and estimate_steps raised ZeroDivisionError (a traceback).
    # The impact time scale is now computed without v^2: a valid scene runs.
    code = main(["simulate", "--mass", "1", "--periods", "5", "--json", *argv])
    out = capsys.readouterr().out
    assert code == 0, out
    assert json.loads(out)["contact"] == "permanent"


# ------------------------------------------------------------------ the particle's profile
@pytest.mark.parametrize("text", PROFILE_TEXT)
def test_profile_links_are_the_librarys_check(text):
    """A profile in a link is applied exactly when the library accepts it
    (a measured table refused: a link must not name a server's file); a
    refusal names the key, the explorer's kinds and the library's reason."""
    values, errors = urlstate.parse({"profile": [text.encode()]}, ExplorerState, URL_KEYS)
    if _profile_valid(text.strip()):
        assert values == {"profile": text.strip()} and errors == []
        assert ExplorerState(**values).scene().profile == text.strip()
        return
    assert values == {} and len(errors) == 1
    e = errors[0]
    assert e.startswith(
        "URL parameter 'profile' (profile) must be one of sphere, cone, "
        "power:N (N ≥ 1), flat-sphere:C (0 ≤ C ≤ 1e+50"
    )
    if text.startswith("power:") and re.fullmatch(r"-?[0-9.]+|nan|inf", text[6:]):
        assert "power\\-law exponent n must be a real number in \\[1, inf\\)" in e, e
    if text.startswith("file:"):
        assert "measured table \\(file:PATH\\) is not offered by the explorer" in e, e


def test_the_state_refuses_a_bad_profile_with_the_librarys_message():
    """Not clamped, not replaced: the value stays and the message names the
    parameter and its range."""
    s = ExplorerState(profile="cone")
    with pytest.raises(ValueError, match=r"exponent n must be a real number in \[1, inf\)"):
        s.profile = "power:0.5"
    with pytest.raises(ValueError, match="file:PATH"):
        s.profile = "file:/etc/passwd"
    assert s.profile == "cone" and s.scene().profile == "cone"


def test_a_profile_link_round_trips_and_no_profile_means_the_sphere():
    s = ExplorerState(profile="flat-sphere:0.5")
    query = urlstate.query(s, URL_KEYS)
    assert "profile=flat-sphere%3A0.5" in query
    args = parse_qs_bytes(query[1:], keep_blank_values=True)
    values, errors = urlstate.parse(args, ExplorerState, URL_KEYS, URL_ALIASES)
    assert errors == [] and values["profile"] == "flat-sphere:0.5"
    # an older link, without the key: the sphere (the shipped maps' particle)
    values, errors = urlstate.parse({"la": [b"0.5"]}, ExplorerState, URL_KEYS)
    assert urlstate.resolved(values, ExplorerState, URL_KEYS)["profile"] == "sphere"


def test_a_bad_profile_link_is_named_in_the_banner_and_runs_nothing(url_session):
    explorer = url_session([("la", "0.5"), ("profile", "power:0.5")])
    msg = explorer.message.object
    assert "URL parameter 'profile' (profile) must be one of sphere, cone" in msg
    assert "got 'power:0\\.5'" in msg
    assert explorer.state.profile == "sphere" and not explorer.runs_on_load
