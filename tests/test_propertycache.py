"""app/propertycache.py: Bokeh's answers, remembered or read directly, are
Bokeh's own answers (source: Bokeh itself, computed uncached beside them), and a
page built with the cache is the page built without it."""
import pytest
from bokeh.core.has_props import HasProps
from bokeh.core.property.descriptors import PropertyDescriptor

import bokeh.models
import panel.models
from vibtrans_explorer import propertycache

MODELS = (bokeh.models, panel.models)          # imported: every model class of both defined


def _model_classes():
    seen, todo = set(), [HasProps]
    while todo:
        cls = todo.pop()
        for sub in cls.__subclasses__():
            if sub not in seen:
                seen.add(sub)
                todo.append(sub)
    return sorted(seen, key=lambda c: f"{c.__module__}.{c.__qualname__}")


@pytest.fixture
def cache():
    was = propertycache.installed()
    propertycache.install()
    yield
    if not was:
        propertycache.uninstall()


def test_every_model_class_gets_bokehs_own_answers(cache):
    classes = _model_classes()
    assert len(classes) > 300                   # Bokeh's and Panel's models
    bokeh_overridden = propertycache._BOKEH["overridden_defaults"].__func__
    bokeh_unstable = propertycache._BOKEH["has_unstable_default"]
    pairs = 0
    for cls in classes:
        for _ in range(2):                          # computed, then remembered
            assert cls._overridden_defaults() == bokeh_overridden(cls), cls
        instance = cls.__new__(cls)                 # its class is all either reads
        for name in cls.properties(_with_props=True):
            descriptor = cls.lookup(name)
            if type(descriptor).has_unstable_default is not propertycache._has_unstable_default:
                continue                            # (an alias answers for itself)
            for _ in range(2):
                assert (descriptor.has_unstable_default(instance)
                        == bokeh_unstable(descriptor, instance)), (cls, name)
            pairs += 1
    assert pairs > 10000


@pytest.mark.parametrize("validate", [True, False])
def test_every_unthemed_default_is_bokehs_own(cache, validate):
    """Every property's default of every model class, read twice (computed,
    then remembered where it is an immutable scalar), equals Bokeh's
    uncached answer, with property validation on and off (validation may
    convert a default: remembered apart); an unstable default (a container,
    a model) is never remembered, nor a stable one that is not a scalar."""
    from bokeh.core.property.validation import validate as validating

    classes = _model_classes()
    bokeh_default = propertycache._BOKEH["instance_default"]
    remembered = 0
    with validating(validate):
        for cls in classes:
            try:
                model = cls()
            except Exception:
                continue                            # abstract, or needs arguments
            for name in cls.properties(_with_props=True):
                descriptor = cls.lookup(name)
                if not isinstance(descriptor, PropertyDescriptor):
                    continue                        # an alias
                first = descriptor.instance_default(model)
                again = descriptor.instance_default(model)
                key = (descriptor, cls, validate)
                if descriptor.has_unstable_default(model):
                    assert key not in propertycache._default_by_property_and_class
                    continue                        # made afresh per model, as by Bokeh
                own = bokeh_default(descriptor, model)
                assert (first == own and again == own) or own != own, (cls, name)   # NaN
                kept = propertycache._default_by_property_and_class[key]
                if type(own) in (type(None), bool, int, float, str):
                    remembered += 1
                else:
                    assert kept is propertycache._COMPUTED, (cls, name)
    assert remembered > 5000


def test_a_remembered_default_is_per_class_and_not_for_themed_models(cache):
    """A subclass overriding a scalar default is answered for itself; a
    model with theme values gets the theme's value."""
    from bokeh.core.properties import Override
    from bokeh.document import Document
    from bokeh.models import Div
    from bokeh.themes import Theme

    class Narrow(Div):
        width = Override(default=99)

    assert Div().width is None and Narrow().width == 99 and Div().width is None
    div = Div()
    doc = Document()
    doc.add_root(div)
    doc.theme = Theme(json={"attrs": {"Div": {"width": 222}}})
    assert div.width == 222 and Div().width is None


def test_a_class_with_its_own_overrides_is_answered_for_itself(cache):
    """Remembered per class, not per property: a subclass that overrides a
    list's default with a plain value is answered apart from its parent."""
    from bokeh.core.properties import Override
    from bokeh.models import Div

    class Styled(Div):
        css_classes = Override(default=lambda: ["a"])
        width = Override(default=321)
        height = Override(default=lambda: 123)      # stable in Div, not here

    div, styled = Div(), Styled()
    assert styled.width == 321 and div.width is None
    assert styled.height == 123 and div.height is None
    assert not Div.lookup("height").has_unstable_default(div)      # asked first
    assert Styled.lookup("height").has_unstable_default(styled)
    assert not Div.lookup("height").has_unstable_default(div)
    assert styled.css_classes == ["a"] and div.css_classes == []
    styled.css_classes.append("b")                  # a fresh list per model
    assert Styled().css_classes == ["a"]
    assert Styled._overridden_defaults()["width"] == 321
    assert "width" not in Div._overridden_defaults()


def test_theme_values_are_bokehs_with_and_without_a_theme(cache):
    """A model's theme values, read from its dict, are what Bokeh's own
    lookup reads: none without a theme, the theme's once one applies, none
    again once it is taken off; and the themed default is what a read of
    the property gives."""
    from bokeh.document import Document
    from bokeh.models import Div
    from bokeh.themes import Theme

    bokeh_themed = propertycache._BOKEH["themed_values"]
    div = Div()
    assert div.themed_values() is None and bokeh_themed(div) is None
    doc = Document()
    doc.add_root(div)
    doc.theme = Theme(json={"attrs": {"Div": {"width": 222}}})
    assert div.themed_values() == {"width": 222} == bokeh_themed(div)
    assert div.themed_values() is bokeh_themed(div)
    assert div.width == 222
    doc.theme = Theme(json={})
    assert div.themed_values() is None and bokeh_themed(div) is None
    assert div.width is None


def test_install_and_uninstall_swap_bokehs_lookups():
    was = propertycache.installed()
    try:
        propertycache.install()
        propertycache.install()                     # idempotent
        assert propertycache.installed()
        assert PropertyDescriptor.has_unstable_default is propertycache._has_unstable_default
        propertycache.uninstall()
        assert not propertycache.installed()
        assert (PropertyDescriptor.has_unstable_default
                is propertycache._BOKEH["has_unstable_default"])
        assert HasProps.__dict__["_overridden_defaults"] is propertycache._BOKEH["overridden_defaults"]
        assert HasProps.themed_values is propertycache._BOKEH["themed_values"]
        assert PropertyDescriptor.instance_default is propertycache._BOKEH["instance_default"]
    finally:
        (propertycache.install if was else propertycache.uninstall)()


@pytest.mark.slow
def test_a_page_built_with_the_cache_is_the_page_built_without():
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    from test_app_runs import _serialized
    from vibtrans_explorer import explorer as E
    from vibtrans_explorer.views import map as map_view

    was = propertycache.installed()
    texts = []
    try:
        for cached in (False, True):
            (propertycache.install if cached else propertycache.uninstall)()
            map_view._map_json.cache_clear()    # the map rendered inside each build too
            doc = Document()
            with set_curdoc(doc):
                E.create_app().server_doc(doc)
            texts.append(_serialized(doc))
    finally:
        (propertycache.install if was else propertycache.uninstall)()
    assert len(texts[0]) > 10000
    assert texts[0] == texts[1]
