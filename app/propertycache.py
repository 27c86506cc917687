"""Four answers Bokeh recomputes at every model's construction and at
every read of a property left at its default: cheaper here.  The server's
pages and figures are built from Bokeh models on the event loop that
every session shares.

- A model's `__init__` asks each of its properties (~40 for a widget or a
  layout) whether its default is "unstable" (a fresh list or dict per
  model); remembered per (property, class).
- Every read of a property left at its default merges the class's
  overridden defaults along its whole MRO; remembered per class.
  Both answers depend only on the class: its properties and overrides are
  fixed when the class is made.  Bokeh recomputes them every time (~7,500
  times per explorer page).
- The same read asks for the model's theme values with `getattr(self,
  "__themed_values__", None)`: for the many models without a theme the
  lookup misses, goes through HasProps.__getattr__ and raises and catches
  an AttributeError (~8,000 times a page).  Read here from the model's own
  dict, where Bokeh's `apply_theme` puts them.
- That read then computes the default afresh (~3,000 times a page): copies
  the class's default and prepares it (`Property.prepare_value`).  For a
  model without theme values, a stable default (Bokeh's own word: not made
  by a function, not a container or a model) that comes out as an
  immutable scalar (None, a bool, a number, a string) is remembered per
  (property, class, whether this thread validates: validation may convert
  a value).  Anything else is computed as before.

With the first three a page cost ~20% less, the fourth ~4% more
(`python -m devtools.pagecost` builds pages with and without them and
app/panelshortcuts.py in one run: `own_over_served`).  The values are
Bokeh's own (tests/test_propertycache.py compares them for every model
class of Bokeh and Panel, and for themed and unthemed models, and a page
built with and without them serializes alike).

Process-wide; `server.py` installs it (and the page-cost bench, to measure
the page as served).  Nothing here imports the rest of the app.
"""
from bokeh.core.has_props import HasProps
from bokeh.core.property import bases
from bokeh.core.property.descriptors import PropertyDescriptor

_BOKEH = {"overridden_defaults": HasProps.__dict__["_overridden_defaults"],
          "has_unstable_default": PropertyDescriptor.has_unstable_default,
          "themed_values": HasProps.themed_values,
          "instance_default": PropertyDescriptor.instance_default}
_overridden_by_class = {}
_unstable_by_property_and_class = {}
_default_by_property_and_class = {}
_IMMUTABLE = frozenset((type(None), bool, int, float, str))
_COMPUTED = object()     # a default computed at every read (not an immutable scalar)
_UNSEEN = object()       # a (property, class, validation) not read yet


def _overridden_defaults(cls):
    """Bokeh's HasProps._overridden_defaults, once per class.  Callers read
    the dict (Property.themed_default), never change it."""
    try:
        return _overridden_by_class[cls]
    except KeyError:
        merged = _overridden_by_class[cls] = _BOKEH["overridden_defaults"].__func__(cls)
        return merged


def _has_unstable_default(descriptor, obj):
    """Bokeh's PropertyDescriptor.has_unstable_default, once per (property,
    class): the property's default and the class's overrides decide it."""
    key = (descriptor, type(obj))
    try:
        return _unstable_by_property_and_class[key]
    except KeyError:
        unstable = _unstable_by_property_and_class[key] = _BOKEH["has_unstable_default"](
            descriptor, obj)
        return unstable


def _themed_values(model):
    """Bokeh's HasProps.themed_values: the dict `apply_theme` set on the
    model, or None."""
    return model.__dict__.get("__themed_values__")


def _instance_default(descriptor, obj):
    """Bokeh's PropertyDescriptor.instance_default: an unthemed model's
    stable default that is an immutable scalar, once per (property, class,
    validation on)."""
    if obj.themed_values() is not None or descriptor.has_unstable_default(obj):
        return _BOKEH["instance_default"](descriptor, obj)
    key = (descriptor, type(obj), bases.validation_on())
    value = _default_by_property_and_class.get(key, _UNSEEN)
    if value is _UNSEEN:
        value = _BOKEH["instance_default"](descriptor, obj)
        _default_by_property_and_class[key] = value if type(value) in _IMMUTABLE else _COMPUTED
    elif value is _COMPUTED:
        value = _BOKEH["instance_default"](descriptor, obj)
    return value


def install():
    """The four lookups, from now on (idempotent)."""
    HasProps._overridden_defaults = classmethod(_overridden_defaults)
    PropertyDescriptor.has_unstable_default = _has_unstable_default
    HasProps.themed_values = _themed_values
    PropertyDescriptor.instance_default = _instance_default


def uninstall():
    """Bokeh's own lookups back (for tests that compare)."""
    HasProps._overridden_defaults = _BOKEH["overridden_defaults"]
    PropertyDescriptor.has_unstable_default = _BOKEH["has_unstable_default"]
    HasProps.themed_values = _BOKEH["themed_values"]
    PropertyDescriptor.instance_default = _BOKEH["instance_default"]


def installed():
    return PropertyDescriptor.has_unstable_default is _has_unstable_default
