"""app/panelshortcuts.py: each shortcut gives Panel's, Param's or Bokeh's
own result (source: their own code, run beside it), and a page built with
them (and app/propertycache.py) is the page built without."""
import os
import re

import panel as pn
import pytest
from bokeh.document import Document
from bokeh.models import Div
from panel.io.state import set_curdoc
from panel.reactive import Syncable
from param import parameters

from vibtrans_explorer import panelshortcuts, propertycache
from vibtrans_explorer.views.render import unvalidated


@pytest.fixture
def shortcuts():
    was = panelshortcuts.installed()
    panelshortcuts.install()
    yield
    if not was:
        panelshortcuts.uninstall()


def _init_params():
    return Syncable.__dict__["_init_params"]


def _syncables():
    """One instance of every Panel component class that builds with no
    arguments and uses Syncable's _init_params (widgets, layouts,
    indicators)."""
    seen, todo, out = set(), [Syncable], []
    while todo:
        cls = todo.pop()
        for sub in cls.__subclasses__():
            if sub in seen:
                continue
            seen.add(sub)
            todo.append(sub)
            if sub.__module__.startswith("panel.") and sub._init_params is _init_params():
                try:
                    out.append(sub())
                except Exception:
                    pass                    # abstract, or needs arguments
    return out


def test_init_params_are_panels_own(shortcuts):
    """The synced parameters' values, in order, as Panel's _init_params
    gives them, for every component class that uses it."""
    own = panelshortcuts._OWN["init_params"]
    objects = _syncables()
    assert len(objects) > 50
    for obj in objects:
        assert list(obj._init_params().items()) == list(own(obj).items()), type(obj)


def test_a_callback_signature_is_checked_where_this_thread_validates(shortcuts):
    """Bokeh refuses a callback of the wrong signature; on a thread that
    builds a page unvalidated the check is skipped, as Panel skips it."""
    def wrong(attr):
        return None
    with pytest.raises(ValueError, match="signature"):
        Div().on_change("text", wrong)
    with unvalidated():
        Div().on_change("text", wrong)
    with pytest.raises(ValueError, match="signature"):
        Div().on_change("text", wrong)


def _settings():
    return {p: getattr(pn.config, p) for p in pn.config.param if p != "name"}


def test_config_set_keeps_every_setting_as_panels_does(shortcuts):
    """config.set(design=...) while attaching sets the design and restores
    it (the fast path); any other use is Panel's own (restores all)."""
    from panel.theme import Bootstrap
    doc = Document()
    with set_curdoc(doc):
        before = _settings()
        with panelshortcuts.attaching():
            with pn.config.set(design=Bootstrap):
                assert pn.config.design is Bootstrap
            assert _settings() == before
            with pn.config.set(sizing_mode="stretch_both"):     # not the fast path
                assert pn.config.sizing_mode == "stretch_both"
                pn.config.loading_spinner = "bar"               # restored by Panel's
            assert _settings() == before
        with pn.config.set(design=Bootstrap):
            pn.config.loading_spinner = "bar"
        assert _settings() == before


def test_design_apply_sets_only_the_theme_while_attaching(shortcuts, monkeypatch):
    """While attaching, Design.apply leaves the parts to the template's
    hook (spied: not reapplied) and sets the document's Bokeh theme;
    elsewhere it is Panel's own."""
    from panel.theme import Design
    from panel.theme.bootstrap import Bootstrap
    calls = []
    monkeypatch.setattr(Design, "_reapply", lambda self, *a, **k: calls.append(a))
    design = Bootstrap(theme="dark")
    col = pn.Column()
    doc = Document()
    root = col.get_root(doc)
    doc.add_root(root)
    with panelshortcuts.attaching():
        design.apply(col, root, isolated=False)
    assert calls == [] and doc.theme is not None
    design.apply(col, root, isolated=False)
    assert len(calls) == 1


@pytest.mark.parametrize("cls", [parameters.Path, parameters.Filename, parameters.Foldername])
def test_paths_resolve_as_param_resolves_them(shortcuts, cls, tmp_path, monkeypatch):
    """Absolute, relative, missing, the wrong kind, with '..': the same
    value, or the same error, as Param's own resolution."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.css").write_text("x")
    monkeypatch.chdir(tmp_path)
    own = panelshortcuts._OWN[cls]
    p = cls()
    cases = [str(tmp_path / "a.css"), str(tmp_path / "sub"), tmp_path / "a.css",
             str(tmp_path / "sub" / ".." / "a.css"), "a.css", "sub", str(tmp_path / "gone.css")]
    for case in cases:
        try:
            expected = own(p, case)
        except OSError as exc:
            with pytest.raises(OSError, match=re.escape(str(exc))):
                p._resolve(case)
        else:
            assert p._resolve(case) == expected, case
            assert os.path.isabs(expected) or case in ("a.css", "sub")


def test_install_and_uninstall_swap_the_shortcuts():
    from bokeh.util import callback_manager
    from panel.config import _config
    from panel.theme import Design
    was = panelshortcuts.installed()
    try:
        panelshortcuts.install()
        panelshortcuts.install()                    # idempotent
        assert panelshortcuts.installed() and Design.apply is panelshortcuts._design_apply
        panelshortcuts.uninstall()
        assert not panelshortcuts.installed()
        own = panelshortcuts._OWN
        assert callback_manager._check_callback is own["check_callback"]
        assert Syncable._init_params is own["init_params"]
        assert _config.__dict__["set"] is own["config_set"]
        assert Design.apply is own["design_apply"]
        assert all(cls._resolve is own[cls] for cls in panelshortcuts._PATHS)
    finally:
        (panelshortcuts.install if was else panelshortcuts.uninstall)()


@pytest.mark.slow
@pytest.mark.parametrize("settings", [{}, {"maps": "both models"}, {"model": "point-mass"},
                                      {"presentation": True}])
def test_a_page_built_with_the_shortcuts_is_the_page_built_without(settings):
    """The explorer's page with these settings, built as the server builds
    it (unvalidated, attached in one pass), with both modules installed and
    with neither, serializes alike, and leaves Panel's settings as Panel's
    own code leaves them."""
    from test_app_runs import _serialized
    from vibtrans_explorer import explorer as E
    from vibtrans_explorer.views import map as map_view

    def build():
        with unvalidated():
            ex = E.Explorer()
            ex.state.param.update(**{k: v for k, v in settings.items() if k != "presentation"})
            ex.presentation = settings.get("presentation", False)
            return E._attached_in_one_pass(E.explorer_template(ex), ex.location)

    was = propertycache.installed(), panelshortcuts.installed()
    texts, after = [], []
    try:
        for on in (False, True):
            for module in (propertycache, panelshortcuts):
                (module.install if on else module.uninstall)()
            map_view._map_json.cache_clear()    # the map rendered inside each build too
            doc = Document()
            with set_curdoc(doc):
                build().server_doc(doc)
                after.append(_settings())
            texts.append(_serialized(doc))
    finally:
        for module, on in zip((propertycache, panelshortcuts), was):
            (module.install if on else module.uninstall)()
    assert len(texts[0]) > 10000
    assert texts[0] == texts[1]
    assert after[0] == after[1]
