"""The chaos line says plainly what the tau twin did
("the twin's trajectory parted from this run after N periods") rather than
"agrees" / "disagrees"."""

import math
from types import SimpleNamespace

from markdowntext import table_rows

from vibtrans_explorer.views.summary import chaos_verdict


def _result(**summary):
    s = {"lyapunov": None, "chaotic": None, "twin_chaotic": None, "divergence_time": None, **summary}
    return SimpleNamespace(summary=SimpleNamespace(**s), twin_unneeded=False)


def test_the_chaos_line_says_where_the_twin_parted():
    text = chaos_verdict(_result(lyapunov=0.2, chaotic=True, twin_chaotic=True, divergence_time=312.0))
    assert text.startswith("chaotic: Lyapunov exponent 0.2 per period")
    assert "the tau + 0.001 twin's trajectory parted from this run after 312 periods" in text
    assert "its drift differs" in text
    assert "agrees" not in text and "disagrees" not in text


def test_a_twin_that_stayed_says_so():
    text = chaos_verdict(_result(lyapunov=-0.5, chaotic=False, twin_chaotic=False, divergence_time=math.inf))
    assert "stayed within 1 a0 of this run's" in text and "its drift is the same" in text
    # a twin that parted, but whose drift is the same: both said
    text = chaos_verdict(_result(chaotic=False, twin_chaotic=False, divergence_time=1500.0))
    assert text == (
        "robust; the tau + 0.001 twin's trajectory parted from this run after "
        "1500 periods, and its drift is the same"
    )


def test_a_relabelled_comparison_legend_shows_its_text_not_a_field():
    # "both models", a click: neither line of the x*(t) legend may read
    # "Invalid field" (a string set on a LegendItem after its creation is
    # taken by Bokeh as a column name)
    from bokeh.core.property.vectorization import Value

    from vibtrans_explorer.views.live import LiveTrajectory

    view = LiveTrajectory("tau + 0.001", 2.0, 50.0)
    view.relabel(50.0, "point mass")
    labels = [item.label for item in view.over.twin_items]
    assert all(isinstance(label, Value) for label in labels), labels
    assert [label.value for label in labels] == ["x*, tau = 50", "x*, point mass"]


def test_the_map_has_a_key_for_its_markers_and_the_introduction_a_glossary():
    # the page says what the yellow circle, the green diamond and
    # the numbered dots on the map are, nor what a*, b*, N*, T* mean
    from vibtrans_explorer import explorer as E

    ex = E.Explorer()
    assert ex.map_key in ex.map_pane.objects
    for words in (
        "yellow circle: the selected scene",
        "green diamond",
        "the device of the Units and Design tabs",
        "paper's points",
    ):
        assert words in ex.map_key.object
    for symbol in ("**a\\***", "**b\\***", "**b\\*'**", "**N\\***", "**T\\***", "**x\\***", "**y\\***"):
        assert symbol in E.INTRODUCTION, symbol


def test_the_introduction_defines_each_contact_state():
    # the contact strip and the animation colour these states: the
    # introduction says what each one is
    from vibtrans.core.kernels.contact import STATE_NAMES
    from vibtrans_explorer import texts

    for name in STATE_NAMES:
        if name != "flight":
            assert f"**{name}**" in texts.INTRODUCTION, name


# ---------------------------------------------------------------- steady, in the table and in SI
SI = "-2.708e-02 m/s; the run, 2000 periods, lasts 18.47 ms (the device of the Units and Design tabs)"


def _summary(x_of_t, v_of_t, **attrs):
    """The library's summary (analysis.summarize) of a closed-form run in
    contact (tests/core/test_steadiness.py's)."""
    import numpy as np
    import xarray as xr

    from vibtrans.analysis.summary import summarize
    from vibtrans.core.kernels.contact import STICK

    t = np.arange(8001) / 4.0
    zero = np.zeros_like(t)
    ds = xr.Dataset(
        {
            "x": ("time", x_of_t(t)),
            "vx": ("time", v_of_t(t)),
            "y": ("time", zero),
            "vy": ("time", zero),
            "state": ("time", np.full(t.size, STICK, dtype=np.int8)),
            "event_time": ("event", np.zeros(0)),
            "event_kind": ("event", np.zeros(0, np.int8)),
            "event_value": ("event", np.zeros(0)),
        },
        coords={"time": t},
        attrs={
            "periods": 2000.0,
            "tau": 50.0,
            "amplitude": 1.0,
            "mass": 1.0,
            "fidelity": "standard",
            "model": "deformable",
            **attrs,
        },
    )
    return summarize(ds)


def _shown_table(s):
    """The summary pane of a device run whose library summary is `s`."""
    from vibtrans import Scene
    from vibtrans_explorer.views.summary import SummaryView

    view = SummaryView(lambda v_star, scene: SI)
    view.show(SimpleNamespace(summary=s, scene=Scene(), other=None, twin=None, twin_unneeded=False))
    return view.pane.object


def _row(table, name):
    """The cells of the table's row `name`, as the page shows them."""
    return next(r for r in table_rows(table) if r[0] == name)


def test_an_unsteady_drift_is_said_so_in_the_si_row_too():
    # the SI row converts the run's mean: where the drift is not steady it
    # says so, as the "steady?" row does
    s = _summary(lambda t: -1e-3 * t**2 / 2, lambda t: -1e-3 * t)
    assert s.steady is False
    table = _shown_table(s)
    assert _row(table, "steady?") == ["steady?", s.steadiness]
    assert s.steadiness.startswith("not steady: still accelerating")
    assert _row(table, "in SI units") == [
        "in SI units",
        f"not steady (see steady?): {SI}; this run's mean, which depends on its length",
    ]
    # a chaotic run's mean is no drift of the scene either
    s = _summary(lambda t: -3.0 * t, lambda t: -3.0 + 0 * t, lyapunov=0.2)
    assert _row(_shown_table(s), "in SI units")[1].startswith(f"chaotic (see steady?): {SI}")


def test_a_steady_drift_is_converted_as_it_is():
    s = _summary(lambda t: -3.0 * t, lambda t: -3.0 + 0 * t)
    assert s.steady is True
    table = _shown_table(s)
    assert _row(table, "in SI units") == ["in SI units", SI]
    # the rule, in the table's words, shown as written (its |v*| and <v*>)
    assert _row(table, "steady?") == ["steady?", s.steadiness]
    assert "moves <v*> by less than 0.25% of |v*| (at least v0* = 0.1)" in s.steadiness
