"""The explorer's live trajectory panels (app/views/live.py): a panel's second
quantity on an axis of its own, and the whole run as per-bin envelopes
(otherwise N* and T* lay flat beside b*' in the thousands, b* and x* over
the last two periods were two flat lines, the whole-run panels were solid
bands)."""

import numpy as np
import pytest

from vibtrans import paper_scene, simulate
from vibtrans.products.plots import binned
from vibtrans_explorer.views.live import LiveTrajectory, right_columns


def test_binned_is_the_naive_per_bin_min_mean_max():
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, 10.0, 500))
    v = rng.normal(size=500)
    v[[3, 77]] = np.nan
    out = binned(t, {"v": v}, 7)
    edges = np.linspace(t[0], t[-1], 8)
    k = 0
    for i in range(7):
        sel = (t >= edges[i]) & ((t < edges[i + 1]) if i < 6 else (t <= edges[i + 1]))
        if not sel.any():
            continue
        w = v[sel][np.isfinite(v[sel])]
        assert out["v_lo"][k] == w.min() and out["v_hi"][k] == w.max()
        assert out["v"][k] == pytest.approx(w.mean(), rel=1e-12)
        k += 1
    assert k == out["time"].size


@pytest.mark.parametrize(
    "columns, right",
    [
        (["a", "y"], ["y"]),
        (["b", "x"], ["x"]),
        (["N", "T", "bdot"], ["bdot"]),
        (["y"], []),
        (["x"], []),
        (["N", "T"], []),
    ],
)
def test_second_quantities_go_right(columns, right):
    assert right_columns(columns) == right


def test_forces_and_velocity_each_fill_their_axis():
    ds = simulate(paper_scene(4).replace(periods=40.0), window=(38.0, 40.0))
    view = LiveTrajectory(None, 2.0, 50.0)
    view.show(ds)
    for block, _data in ((view.over, ds), (view.last, ds.isel(time=slice(-200, None)))):
        forces = next(f for f in block.figures if f.title.text.startswith("forces"))
        n_t = np.concatenate([ds["N"].values, ds["T"].values])
        bdot = ds["bdot"].values
        assert abs(bdot).max() > 10 * abs(n_t).max()  # the scales the issue met
        left, right = forces.y_range, forces.extra_y_ranges["right"]
        # each axis spans its own quantities, not the other's
        assert right.end - right.start > 10 * (left.end - left.start)
    # the whole run: per-bin bands, not every sample
    assert len(view.over.source.data["time"]) <= 400
    assert {"N_lo", "N_hi", "bdot_lo", "bdot_hi"} <= set(view.over.source.data)


def _drawn_panels(block):
    """[(title, left label, right label or None, {column: axis} of the lines
    drawn)] of a block's line panels."""
    out = []
    for panel in block.panels:
        fig = panel.fig
        right = (
            panel.right_axis.axis_label if panel.right_axis is not None and panel.right_axis.visible else None
        )
        lines = {}
        for r in fig.renderers:
            if r.visible and type(r.glyph).__name__ == "Line":
                lines[r.glyph.y] = r.y_range_name
        out.append((fig.title.text, fig.left[0].axis_label, right, lines))
    return out


def _dashes(block):
    """{column: its line's dash} of the lines drawn in a block's panels: a
    right-axis line is dashed (plots.RIGHT_AXIS_DASH), so that it says
    which axis it is read on and is seen where it coincides with the other
    (solid, x* hid b* in a steady slide)."""
    out = {}
    for panel in block.panels:
        for r in panel.fig.renderers:
            if r.visible and type(r.glyph).__name__ == "Line":
                dash = r.glyph.line_dash
                out[r.glyph.y] = dash if isinstance(dash, str) else ("solid" if not dash else "dashed")
    return out


def test_both_models_draw_into_one_set_of_figures():
    """A second set of figures for the first point-mass run would cost
    1.9 s in chromium.  The point mass's panels are the deformable
    particle's with fewer quantities: the same figures show the model of
    the run, each quantity on its own axis, as plots.panel_spec says."""
    from vibtrans.products.plots import panel_spec

    deformable = simulate(paper_scene(4).replace(periods=40.0), window=(38.0, 40.0))
    point = simulate(paper_scene(10).replace(periods=40.0), window=(38.0, 40.0))
    view = LiveTrajectory(None, 2.0, 50.0)
    view.show(deformable)
    before = _drawn_panels(view.over)
    assert _dashes(view.over) == {
        "a": "solid",
        "y": "dashed",
        "b": "solid",
        "x": "dashed",
        "N": "solid",
        "T": "solid",
        "bdot": "dashed",
    }
    figures = list(view.over.figures)
    view.show(point, rigid=True)
    assert view.over.figures == figures  # no new figure
    for (title, ylabel, lines), drawn in zip(panel_spec(True), _drawn_panels(view.over)):
        assert drawn[0].startswith(title) and drawn[1] == ylabel and drawn[2] is None
        assert drawn[3] == {c: "default" for c, _, _ in lines}  # one axis, the left
    assert set(_dashes(view.over).values()) == {"solid"}  # one axis each: all solid
    y_panel = view.over.panels[0]
    y = point["y"].values
    assert y_panel.fig.y_range.start <= y.min() and y_panel.fig.y_range.end >= y.max()
    assert y_panel.fig.y_range.end - y_panel.fig.y_range.start < 1.2 * (y.max() - y.min()) + 1e-9
    # the fragment's panels too, x* counted from the window's start
    assert "x*(t) - x*(t0)" in view.last.panels[1].fig.title.text
    assert set(_drawn_panels(view.last)[2][3]) == {"N", "T"}
    view.show(deformable)
    assert _drawn_panels(view.over) == before  # and back
    for (title, _, lines), drawn in zip(panel_spec(False), before):
        assert drawn[0].startswith(title) and set(drawn[3]) == {c for c, _, _ in lines}


def test_relabelled_comparison_legend_is_text_not_a_column():
    """After 'both models' (the figures first built for another
    comparison, then relabelled) both x*(t) legend lines read 'Invalid
    field': a label set as a bare string is a column name to Bokeh."""
    from bokeh.core.property.vectorization import Value

    view = LiveTrajectory("tau + 0.001", 2.0, 10.0)
    view.relabel(10.0, "point mass")
    labels = [item.label for item in view.over.twin_items]
    assert all(isinstance(label, Value) for label in labels), labels
    assert [label.value for label in labels] == ["x*, tau = 10", "x*, point mass"]
