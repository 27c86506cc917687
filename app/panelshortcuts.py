"""Work Panel, Param and Bokeh repeat for every page the server builds,
done more cheaply here with the same results.  The pages are built
on the event loop that every session shares (`python -m devtools.pagecost`
measures a page with and without them, and with and without
app/propertycache.py, in one run).

- Bokeh checks the signature of every callback registered with
  `on_change` or `on_event` (`inspect.signature`): a page's widgets
  register ~6 each, all Panel's own.  Skipped where this thread sets
  properties without validating them, as Panel skips it when validation is
  off (`panel.util.set_bokeh_validation`): the explorer builds its pages
  so (`explorer.create_app`), and the tests build them validated, checks
  included.  ~8% of a page.
- Panel's `Syncable._init_params` rebuilds the list of synced parameters
  for every parameter it looks at (~30 lists of ~30 names per widget or
  layout); built once per call here, the same dict.  ~5%.
- A template attaches each of its parts inside `config.set(design=...)`,
  which reads and restores all ~100 of Panel's settings, each through the
  settings' own `__getattribute__`.  While this thread attaches a page
  (`attaching()`), only the design is saved and restored: the only setting
  changed there (tests/test_panelshortcuts.py compares every setting
  after a page attached both ways).  ~7%.
- The template then applies its design to every part of the page twice:
  `Design.apply`, and at once the preprocessing hook it installed
  (`Design._apply_hooks`), which does the same.  While attaching, `apply`
  only sets the document's Bokeh theme (its other half).  ~3%.
- Param's Path parameters (a design theme's CSS files, read for every
  part) resolve their value at every read through `resolve_path`, a
  ParameterizedFunction instantiated per call.  An absolute path that
  exists is resolved here as `resolve_path` resolves it (normalized), at
  the cost of one `stat`; anything else goes to `resolve_path`.  ~3%.

Process-wide; `server.py` installs it (and the page-cost bench, to measure
the page as served).  Nothing here imports the rest of the app.
"""
import contextlib
import os
import threading

from bokeh.core.property import bases
from bokeh.util import callback_manager
from panel.config import _config
from panel.reactive import Syncable
from panel.theme.base import Design
from param import parameters

# Param's path parameters and what resolve_path requires of an absolute path
_PATHS = {parameters.Path: os.path.exists, parameters.Filename: os.path.isfile,
          parameters.Foldername: os.path.isdir}
_OWN = {"check_callback": callback_manager._check_callback,
        "init_params": Syncable.__dict__["_init_params"],
        "config_set": _config.__dict__["set"],
        "design_apply": Design.__dict__["apply"],
        **{cls: cls.__dict__["_resolve"] for cls in _PATHS}}
_ATTACHING = threading.local()      # .on: this thread attaches a page


def _check_callback(callback, fargs, what="Callback functions"):
    """Bokeh's check of a callback's signature, where this thread validates
    properties (`bases.validation_on`, per thread in the server:
    views/render.py)."""
    if bases.validation_on():
        _OWN["check_callback"](callback, fargs, what)


def _init_params(self):
    """Panel's Syncable._init_params: the synced parameters' values that
    are not None, in the parameters' order; the synced list built once."""
    synced = frozenset(self._synced_params)
    params = {}
    for p in self.param:
        if p in synced:
            v = getattr(self, p)
            if v is not None:
                params[p] = v
    return params


@contextlib.contextmanager
def _config_set(self, **kwargs):
    """Panel's `config.set`; while this thread attaches a page, a design
    alone is set and restored without the snapshot of every setting."""
    if not (getattr(_ATTACHING, "on", False) and kwargs.keys() == {"design"}):
        with _OWN["config_set"](self, **kwargs):
            yield
        return
    old = self.design
    self.design = kwargs["design"]
    try:
        yield
    finally:
        if self.design is not old:
            self.design = old


def _design_apply(self, viewable, root, isolated=True):
    """Panel's Design.apply; while this thread attaches a page, only the
    document's Bokeh theme: the template's `_apply_hooks` applies the rest,
    the same, right after."""
    doc = root.document
    if not (getattr(_ATTACHING, "on", False) and doc is not None):
        return _OWN["design_apply"](self, viewable, root, isolated)
    if self.theme and self.theme.bokeh_theme:
        doc.theme = self.theme.bokeh_theme


def _absolute_first(cls):
    """cls._resolve, with resolve_path's answer for an absolute path that
    exists (the path normalized) given without calling it."""
    own = _OWN[cls]
    exists = _PATHS[cls]

    def _resolve(self, path):
        normal = os.path.normpath(path)
        if os.path.isabs(normal) and exists(normal):
            return normal
        return own(self, path)
    return _resolve


_RESOLVE = {cls: _absolute_first(cls) for cls in _PATHS}


@contextlib.contextmanager
def attaching():
    """The context in which this thread attaches a page's parts to its
    document (explorer._attached_in_one_pass)."""
    was = getattr(_ATTACHING, "on", False)
    _ATTACHING.on = True
    try:
        yield
    finally:
        _ATTACHING.on = was


# (owner, attribute, the shortcut, the code it stands in for)
_SWAPS = [(callback_manager, "_check_callback", _check_callback, _OWN["check_callback"]),
          (Syncable, "_init_params", _init_params, _OWN["init_params"]),
          (_config, "set", _config_set, _OWN["config_set"]),
          (Design, "apply", _design_apply, _OWN["design_apply"]),
          *((cls, "_resolve", _RESOLVE[cls], _OWN[cls]) for cls in _PATHS)]


def install():
    """The shortcuts, from now on (idempotent)."""
    for owner, name, shortcut, _ in _SWAPS:
        setattr(owner, name, shortcut)


def uninstall():
    """Panel's, Param's and Bokeh's own code back (for tests and the bench
    that compare)."""
    for owner, name, _, own in _SWAPS:
        setattr(owner, name, own)


def installed():
    return Syncable._init_params is _init_params
