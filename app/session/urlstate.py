"""The explorer's URL query, parsed and validated without Panel (a pure
function, tested alone in tests/app/test_url_params.py).

    values, errors = parse(args, state, URL_KEYS, available_maps)

`args` is the request's query as Tornado gives it ({key: [bytes, ...]}) or
as plain strings; `state` is the ExplorerState (or its class), read only
for its parameters' kinds, bounds, options and defaults; `URL_KEYS` maps
parameter name -> URL key.  Returns the values to apply (only valid ones)
and one message per invalid parameter, naming its URL key and parameter,
its valid values and what was given.  An invalid value leaves the
parameter at its default.

Rules:
* surrounding spaces are dropped (a '+' in a query string is a space);
* numbers: plain ASCII decimals only (``-0.3``, ``1e-2``, ``+2.``), at most
  64 characters, finite, inside the parameter's bounds; not ``nan``,
  ``inf``, ``1_0`` or other-script digits that Python's float() would take;
* integers (param.Integer, a map request's grid): plain ASCII digits with
  an optional sign, inside the parameter's bounds;
* options: exactly one of the selector's objects (case-sensitive);
* a text the library checks (a parameter with `check_text`, the
  particle's profile: ``cone``, ``power:3``): its check, whose reason is
  added to the message;
* a number the library checks (a parameter with `library_check`, the
  particle's tip in SI: ``tipa=30``): a plain decimal, then that check
  (its reason added); empty is None where the parameter allows None;
* a key given several times with different values is invalid (ambiguous
  link); given several times with the same value it is that value;
* unknown keys are ignored (tracking parameters, future keys);
* a value's older spellings (`URL_ALIASES`: `point_mass` for `point-mass`)
  are accepted; links are written with one spelling (`query`);
* a mu with no shipped map for the model is kept as given (the map says
  which map it shows, the mu selector offers the value);
* the given text is shown in the message escaped (no HTML, no Markdown)
  and cut to 40 characters: the message is rendered as Markdown.
"""

import html
import math
import re

import param

MAX_LENGTH = 64  # longest accepted value, characters
SHOWN = 40  # longest given text quoted in a message
REASON = 400  # longest library reason added to a message
DEFAULT_MU = 0.3
PLAIN_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]{1,4})?")
_INTEGER = re.compile(r"[+-]?[0-9]{1,9}")
# what makes emphasis, code, links, tables or strike-through inside a line
# (a link or a footnote starts with '[': a ']' alone is text)
_INLINE = re.compile(r"([\\`*_\[|~])")
# and what starts a block at a line's start, or a typed text may begin with
_BLOCK = re.compile(r"([{}()#+\-.!\]])")


def literal(text):
    """A text (a library's message, a name) as Markdown that shows it as
    it is, inside a line of a Markdown pane: HTML and the characters of
    inline Markdown escaped ("log10 A* and m*" keeps its stars)."""
    # (quotes stay: a message is Markdown text, not an attribute; escaped, the
    # Markdown escape of '#' broke the entity and '&#x27;' reached the page)
    return _INLINE.sub(r"\\\1", html.escape(str(text), quote=False))


def shown(raw, limit=SHOWN):
    """The given text, safe to put in a Markdown/HTML message (cut to
    `limit` characters): `literal`, and what would start a block escaped
    too (a typed text may be anything)."""
    text = raw if len(raw) <= limit else raw[:limit] + "…"
    text = "".join(c if c.isprintable() else "\N{REPLACEMENT CHARACTER}" for c in text)
    return _BLOCK.sub(r"\\\1", literal(text))


def as_text(value):
    """A URL value as text (bytes decoded as UTF-8)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    return str(value)


def _bounds(p):
    """(lo, hi) of a Number parameter; no bounds (a value the library checks
    where it is used, e.g. the Design tab's): (-inf, inf)."""
    lo, hi = p.bounds if p.bounds is not None else (None, None)
    return (-math.inf if lo is None else lo), (math.inf if hi is None else hi)


def _inclusive(p):
    return getattr(p, "inclusive_bounds", (True, True)) or (True, True)


def _inside(p, value):
    lo, hi = _bounds(p)
    lo_in, hi_in = _inclusive(p)
    return (lo <= value if lo_in else lo < value) and (value <= hi if hi_in else value < hi)


def valid_range(p):
    """What a parameter accepts, in words ("a number in [-6.0, 6.0]",
    "(0.0, 0.01]" where a bound is excluded)."""
    if isinstance(p, param.Selector):
        return f"one of {', '.join(map(str, p.objects))}"
    if getattr(p, "valid_values", None):
        return f"one of {p.valid_values}"
    if getattr(p, "range_text", None):  # a size the library checks (the particle's tip)
        return p.range_text
    what = "an integer" if isinstance(p, param.Integer) else "a number"
    lo, hi = _bounds(p)
    lo_in, hi_in = _inclusive(p)
    return (
        what
        if (lo, hi) == (-math.inf, math.inf)
        else (f"{what} in {'[' if lo_in else '('}{lo}, {hi}{']' if hi_in else ')'}")
    )


def convert(p, raw):
    """The parameter's value for the text `raw`, or ValueError.  The one
    check of a typed or linked value: the explorer's number fields use it
    too (app/views/inputs.py)."""
    if len(raw) > MAX_LENGTH:
        raise ValueError("too long")
    raw = raw.strip(" \t")  # a '+' in a query is a space
    if callable(getattr(p, "check_text", None)):
        return p.check_text(raw)
    if isinstance(p, param.Selector):
        if raw not in p.objects:
            raise ValueError("not an option")
        return raw
    if isinstance(p, param.Integer):
        if not _INTEGER.fullmatch(raw):
            raise ValueError("not an integer")
        value = int(raw)
        if not _inside(p, value):
            raise ValueError("out of range")
        return value
    checked = _library_checked(p)
    if checked and raw == "" and p.allow_None:
        return None  # (a size that may be absent: the library's default)
    if not PLAIN_NUMBER.fullmatch(raw):
        raise ValueError("not a number")
    value = float(raw)
    if not (math.isfinite(value) and _inside(p, value)):
        raise ValueError("out of range")
    return p.library_check(value) if checked else value


def _library_checked(p):
    """Is the parameter's value checked by the library (`library_check`:
    the tip's sizes), whose reason a message adds?"""
    return callable(getattr(p, "library_check", None))


def reason_given(p):
    """Does a refusal of `p`'s text carry the library's reason (a text or
    a number the library checks)?"""
    return callable(getattr(p, "check_text", None)) or _library_checked(p)


def parse(args, state, url_keys, aliases=None):
    """(values, errors): see the module docstring."""
    aliases = aliases or {}
    args = args or {}
    values, errors = {}, []
    for name, key in url_keys.items():
        if key not in args:
            continue
        given = args[key]
        if isinstance(given, (str, bytes)):
            given = [given]
        texts = [as_text(v) for v in given]
        p = state.param[name]
        if not texts:
            continue
        if len(set(texts)) > 1:
            errors.append(
                f"URL parameter '{key}' ({name}) is given {len(texts)} times with "
                f"different values; it must be {valid_range(p)}"
            )
            continue
        raw = texts[0]
        raw = aliases.get(name, {}).get(raw.strip(" \t"), raw)
        try:
            values[name] = convert(p, raw)
        except ValueError as exc:
            why = f" ({shown(str(exc), REASON)})" if reason_given(p) and len(raw) <= MAX_LENGTH else ""
            errors.append(f"URL parameter '{key}' ({name}) must be {valid_range(p)}; got '{shown(raw)}'{why}")
    return values, errors


def written(value):
    """A value as a link writes it: numbers exactly (repr: the run a link
    reproduces is the run shown), options as they are."""
    if isinstance(value, float):
        return repr(value + 0.0)  # (-0.0 is 0.0: equal, no change seen)
    return str(value)


def query(state, url_keys, extra=()):
    """The link's query ("?la=...&lm=...") of the state: every key of
    `url_keys`, then `extra` ((key, text) pairs); None values left out."""
    from urllib.parse import urlencode

    pairs = [
        (key, written(getattr(state, name)))
        for name, key in url_keys.items()
        if getattr(state, name) is not None
    ]
    return "?" + urlencode([*pairs, *extra])


def resolved(values, state, url_keys):
    """Every URL parameter's value: the parsed one, else its default."""
    return {name: values.get(name, state.param[name].default) for name in url_keys}


def message(errors):
    """The one line the explorer shows for a link's errors (empty if none):
    nothing of such a link is run."""
    return (
        "This link has errors, so nothing was run: "
        + " · ".join(errors)
        + ". Correct the link, or choose a scene and press Run."
        if errors
        else ""
    )
