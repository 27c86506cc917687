"""The explorer runs on stock Panel, Param, Bokeh and HoloViews: it replaces
none of their code (the tests at the end), and answers their known bugs
through public APIs (docs/how-to/deployment.md, section 1).  The test of each
bug runs stock code and fails on the day a version fixes it: then the
answer may be simplified (the deployment guide says how)."""

import pytest


def test_panels_text_panes_in_a_hidden_tab_fetch_the_cdn():
    """Bug 1.2: a Markdown pane updated while its tab of a `Tabs(dynamic=True)`
    is hidden comes back with its stylesheets (shared with the page's other
    models) on Panel's CDN, in a document whose stylesheets are served
    locally.  The explorer's tabs hold only the open tab's content
    (views/tabs.py `lazy_tabs`); this fails on the day Panel keeps them
    local, and a dynamic Tabs would then do."""
    import panel as pn
    from bokeh.document import Document
    from bokeh.models import ImportedStyleSheet
    from panel.io.resources import CDN_DIST, LOCAL_DIST
    from panel.io.state import set_curdoc

    doc = Document()
    doc.template_variables["dist_url"] = LOCAL_DIST  # as a served page's
    shown, hidden = pn.pane.Markdown("shown"), pn.pane.Markdown("hidden")
    tabs = pn.Tabs(("shown", shown), ("hidden", hidden), dynamic=True, active=1)
    with set_curdoc(doc):
        doc.add_root(tabs.get_root(doc))
        tabs.active = 0
        hidden.object = "changed while hidden"
        tabs.active = 1
    urls = {
        s.url for m in doc.models for s in getattr(m, "stylesheets", ()) if isinstance(s, ImportedStyleSheet)
    }
    assert any(u.startswith(CDN_DIST) for u in urls), "Panel keeps a hidden tab's stylesheets local now"


def test_panels_location_parses_the_query_it_does_not_sync():
    """Bug 1.3: a Location that syncs nothing still parses each query it is
    given (its `search` watcher reads `query_params`), and fails on '?la=²'
    (bug 2.1).  The browser sends the page's address to the template's
    Location when the page connects, so the served page has none: the
    explorer's own address component takes its place
    (explorer.serve_page).  Fails on the day Panel parses only what it
    syncs."""
    from panel.io.location import Location

    with pytest.raises(ValueError, match="²"):
        Location(pathname="/").search = "?la=²"


def test_panels_query_parsing_fails_on_a_superscript_digit():
    """Bug 2.1: Panel's `parse_query` takes '²' for an integer ('²'.isdigit()
    is True) and `int('²')` raises, so a Location Panel makes from a request
    with ?x=² fails the page (a 500).  The explorer reads its link itself
    (session/urlstate.py) and gives Panel no Location to make
    (explorer.serve_page); this fails on the day Panel parses it."""
    from panel.io.location import Location

    with pytest.raises(ValueError, match="²"):
        Location(search="?la=²").query_params  # noqa: B018


# --- the app replaces nothing of its frameworks ---------------
import ast  # noqa: E402
import importlib  # noqa: E402
import inspect  # noqa: E402
import re  # noqa: E402
from pathlib import Path  # noqa: E402

FRAMEWORKS = ("panel", "bokeh", "param", "holoviews")
APP = Path(__file__).resolve().parents[2] / "app"


def _app_sources():
    return sorted(APP.rglob("*.py"))


def _framework_names(tree):
    """Names bound by imports from the frameworks, and the offending imports
    (a private module or name)."""
    names, private = set(), []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in FRAMEWORKS:
                    names.add((a.asname or a.name).split(".")[0])
                    if any(part.startswith("_") for part in a.name.split(".")):
                        private.append(a.name)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in FRAMEWORKS:
            for a in node.names:
                names.add(a.asname or a.name)
                if a.name.startswith("_") or any(p.startswith("_") for p in node.module.split(".")):
                    private.append(f"{node.module}.{a.name}")
    return names, private


def _root(node):
    while isinstance(node, ast.Attribute):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


def test_the_app_imports_nothing_private_and_assigns_nothing_to_its_frameworks():
    """No private import from Panel, Bokeh, Param or HoloViews; no
    assignment to an attribute of one of their modules or classes (a
    process-wide replacement), by `=` or `setattr`; nothing private of
    theirs assigned anywhere (docs/how-to/deployment.md, section 1)."""
    found = []
    sources = _app_sources()
    assert len(sources) > 20
    for path in sources:
        tree = ast.parse(path.read_text(), str(path))
        framework, private = _framework_names(tree)
        found += [f"{path.name}: private import {p}" for p in private]
        for node in ast.walk(tree):
            targets = []
            if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            elif (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id == "setattr"
                and node.args
            ):
                if _root(node.args[0]) in framework:
                    found.append(f"{path.name}:{node.lineno}: setattr on {ast.unparse(node.args[0])}")
            for t in targets:
                if isinstance(t, ast.Attribute) and (
                    _root(t) in framework
                    or any(
                        isinstance(n, ast.Attribute)
                        and n.attr.startswith("_")
                        and not n.attr.startswith("__")
                        and _root(n) != "self"
                        for n in ast.walk(t)
                    )
                ):
                    found.append(f"{path.name}:{node.lineno}: assigns {ast.unparse(t)}")
    assert not found, found


ESM_DECLARED = re.compile(r"_esm|_data_model(__initialized)?")


def test_no_class_of_the_app_overrides_a_private_method_of_its_frameworks():
    """A subclass of a framework class (a Panel pane, a Parameterized) that
    redefines one of that class's private methods replaces its internals
    as surely as a patch (views.map's former FigurePane did).  `_param__*`:
    what Param's metaclass sets on every class; `_all_slots_`: what it sets
    on every Parameter class.  A `panel.custom` component (JSComponent) is
    declared by its `_esm` module, Panel's documented way to write one, and
    Panel's metaclass sets `_data_model*` on every such class (ESM_DECLARED)."""
    from panel.custom import ReactiveESM

    found = []
    for path in _app_sources():
        module = importlib.import_module(
            "vibtrans_explorer." + ".".join(path.relative_to(APP).with_suffix("").parts)
        )
        for cls in vars(module).values():
            if not (inspect.isclass(cls) and cls.__module__ == module.__name__):
                continue
            bases = [b for b in cls.__mro__[1:] if b.__module__.split(".")[0] in FRAMEWORKS]
            esm = issubclass(cls, ReactiveESM)
            for name in vars(cls):
                if (
                    name.startswith("_")
                    and not name.startswith(("__", "_param__"))
                    and name != "_all_slots_"
                    and not (esm and ESM_DECLARED.fullmatch(name))
                    and any(name in vars(b) for b in bases)
                ):
                    found.append(f"{cls.__qualname__}.{name}")
    assert not found, found
