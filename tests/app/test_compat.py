"""app/server/compat.py: each workaround answers a bug the installed framework
versions show.  The test of each bug runs stock code and fails on the day
a version fixes it: then delete the workaround (docs/how-to/deployment.md)."""

import subprocess
import sys

from vibtrans_explorer.server import compat

_STOCK_PROBE = (
    "from vibtrans_explorer.server import compat; print(compat.validation_switch_is_process_wide())"
)


def test_bokeh_validation_switch_is_one_flag_for_the_process():
    """Bug 1.1 (docs/how-to/deployment.md): Bokeh's `validate(False)` in one thread
    turns validation off in every thread.  Probed in a fresh process:
    stock Bokeh, nothing applied."""
    out = subprocess.run(
        [sys.executable, "-c", _STOCK_PROBE], capture_output=True, text=True, timeout=120, check=True
    ).stdout.split()
    assert out[-1] == "True", (
        "Bokeh's validation switch no longer leaks across threads: "
        "delete workaround 1 of app/server/compat.py"
    )


def test_panels_text_panes_in_a_hidden_tab_fetch_the_cdn():
    """Bug 1.2 (docs/how-to/deployment.md): a Markdown pane updated while its tab of
    a dynamic Tabs is hidden comes back with its stylesheets (shared with
    the page's other models) on Panel's CDN.  Probed in a fresh process:
    stock Panel, nothing applied."""
    probe = "from vibtrans_explorer.server import compat; print(compat.hidden_tab_update_fetches_the_cdn())"
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, check=True
    ).stdout.split()
    assert out[-1] == "True", (
        "Panel's hidden-tab text updates keep the page's stylesheets: "
        "delete workaround 2 of app/server/compat.py"
    )


def test_apply_applies_what_is_shown_and_undo_restores_bokeh():
    was = compat.applied()
    compat.undo()
    names = [name for name, *_ in compat.WORKAROUNDS]
    try:
        assert compat.validation_switch_is_process_wide()  # stock: the bug
        assert compat.hidden_tab_update_fetches_the_cdn()
        lines = compat.apply()
        assert compat.applied() == names
        assert all("applied" in line for line in lines)
        assert not compat.validation_switch_is_process_wide()  # answered
        assert not compat.hidden_tab_update_fetches_the_cdn()
        assert compat.apply() == [f"{name}: applied" for name in names]  # idempotent
        compat.undo()
        assert compat.applied() == []
        assert compat.validation_switch_is_process_wide()  # Bokeh's own again
        assert compat.hidden_tab_update_fetches_the_cdn()  # Panel's own again
    finally:
        if was:
            compat.apply()


def test_nothing_is_applied_at_import():
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            "import vibtrans_explorer.explorer, vibtrans_explorer.server.compat as c; print(c.applied())",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    ).stdout.split()
    assert out[-1] == "[]"


def test_panels_query_parsing_fails_on_a_superscript_digit():
    """Bug 2.1 (docs/how-to/deployment.md): Panel's `parse_query` takes '²' for an
    integer ('²'.isdigit() is True) and `int('²')` raises, so a Location
    Panel makes from a request with ?x=² fails the page (a 500).  The
    explorer gives Panel a Location of its own through the public
    `server_doc(location=...)` (explorer.serve_page); this fails on the day
    Panel parses it, and the explorer may then leave the Location to Panel."""
    import pytest
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
    return [p for p in sorted(APP.rglob("*.py")) if p.name != "compat.py"]


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
    theirs assigned anywhere.  app/server/compat.py alone may (docs/how-to/deployment.md)."""
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
