"""The map and the state strips explain themselves:
the colour bar is labelled in drift velocities v* at the colours that stand
for them and follows v0*; a key outside the plot names grey, white, the
jumping boundary and the resonances, in the explorer (bokeh) and in every
export (matplotlib, HTML); the contact-state colours are named beside the
strips, and the exported HTML strip shows them (it was solid black).

All on hand-made data: a 4 x 3 map whose drift velocities give round
ticks, a threshold curve with two resonances, and a short run."""

import holoviews as hv
import numpy as np
import pytest
import xarray as xr
from bokeh.models import ColorBar, FixedTicker, GlyphRenderer, Legend, Patch

from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.core.params import paper_scene
from vibtrans.core.simulate import simulate
from vibtrans.products import export, plots

LA = np.array([-1.0, 0.0, 1.0, 2.0])
LM = np.array([-2.0, 0.0, 2.0])
# with-wave drift up to 1000, against-wave down to -100, one chaotic cell
V = np.array([[0.0, 0.05, -0.05], [1000.0, 3.0, -100.0], [20.0, -7.0, 0.5], [-30.0, 400.0, 0.0]])
CHAOTIC_CELL = (3, 2)

# Source: the paper's colour scale (docs/MODEL.md section 4) by hand.  The
# colour value of a drift v > v0 is C = log10(v/v0) / log10(v_max/v0) (and
# the mirror for v < -v0, with its own maximum), so the bar's ticks at
# C = 1/3, 2/3, 1 stand for v = v0 * (v_max/v0)^C, two significant digits:
#   v0 = 0.1: v_max/v0 = 1e4 -> 2.154 ("2.2"), 46.4 ("46"), 1000;
#             |v_min|/v0 = 1e3 -> -1, -10, -100;
#   v0 = 1:   1e3 -> 10, 100, 1000;  1e2 -> -4.64 ("-4.6"), -21.5 ("-22"), -100.
EXPECTED_TICKS = {
    0.1: {-1: "-100", -2 / 3: "-10", -1 / 3: "-1", 0: "\u00b10.1", 1 / 3: "2.2", 2 / 3: "46", 1: "1000"},
    1.0: {-1: "-100", -2 / 3: "-22", -1 / 3: "-4.6", 0: "\u00b11", 1 / 3: "10", 2 / 3: "100", 1: "1000"},
}


def _hand_map(model="deformable"):
    chaotic = np.zeros(V.shape, np.int8)
    chaotic[CHAOTIC_CELL] = 1
    return xr.Dataset(
        {
            "drift_velocity": (("log_amplitude", "log_mass"), V),
            "chaotic": (("log_amplitude", "log_mass"), chaotic),
        },
        coords={"log_amplitude": LA, "log_mass": LM},
        attrs={"scene_model": model, "scene_mu": 0.3, "scene_periods": 2000.0},
    )


def _hand_vertical():
    lm = np.linspace(-2.5, 2.5, 11)
    return xr.Dataset(
        {
            "threshold_amplitude": ("log_mass", 10.0 ** (-lm - 1)),
            "point_mass_threshold_amplitude": ("log_mass", 10.0 ** (-lm - 1.5)),
        },
        coords={"log_mass": lm},
        attrs={"resonance_fundamental_log_mass": -0.8, "resonance_subharmonic_log_mass": -1.4},
    )


def _key(v0, chaotic=True, boundary=True, resonances=True):
    """The key the map must carry, in drawing order."""
    return (
        [plots.white_label(v0)]
        + [plots.CHAOTIC_LABEL] * chaotic
        + [plots.BOUNDARY_LABEL] * boundary
        + [plots.RESONANCE_LABEL] * resonances
    )


@pytest.fixture(autouse=True, scope="module")
def backends():
    export.ensure_backends()


def _colour_bar(fig):
    bars = fig.select({"type": ColorBar})
    assert len(bars) == 1
    return bars[0]


@pytest.mark.parametrize("v0", sorted(EXPECTED_TICKS))
def test_bokeh_colour_bar_is_labelled_in_drift_velocities(v0):
    want = EXPECTED_TICKS[v0]
    bar = _colour_bar(hv.render(plots.drift_map(_hand_map(), v0=v0), backend="bokeh"))
    # ticks at the colour values C, labelled with the velocities they stand for
    assert isinstance(bar.ticker, FixedTicker)
    np.testing.assert_allclose(bar.ticker.ticks, sorted(want), atol=1e-12)
    got = {float(c): label for c, label in bar.major_label_overrides.items()}
    assert set(got) == set(bar.ticker.ticks)  # every tick has its label
    assert [got[c] for c in sorted(got)] == [want[c] for c in sorted(want)]
    # ... and a tick's colour is the colour of its velocity: C(v) = tick
    for c, label in want.items():
        if c:
            v = float(label)
            np.testing.assert_allclose(
                plots.colour_scale(np.r_[V.ravel(), v], v0)[-1], c, atol=0.02, err_msg=label
            )  # v rounded to 2 digits
    # the title names the drift velocity and this v0*, not "C"
    assert "<v*>" in bar.title and f"v0* = {v0:g}" in bar.title and "signed log" in bar.title


def test_colour_bar_follows_v0_in_both_backends():
    # the same map at two v0*: the explorer re-renders it per v0 (its cache
    # key), so the labels must come from v0, in bokeh and matplotlib alike
    labels = {}
    for v0 in EXPECTED_TICKS:
        el = export.heatmap_figure(_hand_map(), v0=v0, vertical=_hand_vertical())
        bar = _colour_bar(hv.render(el, backend="bokeh"))
        bk = [bar.major_label_overrides[t] for t in bar.ticker.ticks]
        fig = export.render(el)
        try:
            cax = next(a for a in fig.axes if not a.images and a.get_ylabel().startswith("<v*>"))
            mp = [t.get_text() for t in cax.get_yticklabels()]
            np.testing.assert_allclose(cax.get_yticks(), sorted(EXPECTED_TICKS[v0]), atol=1e-12)
            assert f"v0* = {v0:g}" in cax.get_ylabel()
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
        assert bk == mp == [EXPECTED_TICKS[v0][c] for c in sorted(EXPECTED_TICKS[v0])]
        labels[v0] = bk
    assert labels[0.1] != labels[1.0]


@pytest.mark.parametrize(
    "model, chaotic", [("deformable", "grey"), ("deformable", "colour"), ("point-mass", "grey")]
)
def test_map_key_names_every_layer_outside_the_map(model, chaotic):
    # grey only where chaotic points are drawn grey; resonances only on the
    # deformable map (the exporter and the explorer draw them only there)
    el = export.heatmap_figure(_hand_map(model), v0=0.1, vertical=_hand_vertical(), chaotic=chaotic)
    want = _key(0.1, chaotic=chaotic == "grey", resonances=model == "deformable")
    # bokeh: one legend, below the plot (not over the map, where it took
    # the clicks in its corner)
    fig = hv.render(el, backend="bokeh")
    legends = fig.select({"type": Legend})
    assert len(legends) == 1 and legends[0] in fig.below
    assert [item.label.value for item in legends[0].items] == want
    # matplotlib: the key below the axes, inside the figure
    import matplotlib.pyplot as plt

    f = export.render(el)
    try:
        ax = next(a for a in f.axes if a.images)
        keys = [a for a in ax.artists if a.get_gid() == plots.KEY_NAME]
        assert len(keys) == 1 and ax.get_legend() is None
        assert [t.get_text() for t in keys[0].texts] == want
        r = f.canvas.get_renderer()
        box, frame = keys[0].get_window_extent(r), ax.get_window_extent(r)
        assert box.y1 <= ax.xaxis.label.get_window_extent(r).y0 + 1 and box.y1 < frame.y0
        assert box.y0 >= 0 and box.x0 >= 0 and box.x1 <= f.bbox.x1
    finally:
        plt.close(f)


@pytest.mark.slow
def test_paper_map_pair_keeps_colour_bar_titles_clear_of_the_next_map():
    # Fig. 3 (export_paper): two maps side by side; the first map's
    # two-line colour-bar title overlapped the second map's y label at the
    # layout's usual column gap
    import matplotlib.pyplot as plt

    pair = hv.Layout(
        [export.heatmap_figure(_hand_map(m), vertical=_hand_vertical()) for m in ("deformable", "point-mass")]
    ).cols(2)
    f = export.render(pair, 13.0, 5.2, hspace=export.MAPS_HSPACE)
    try:
        r = f.canvas.get_renderer()
        maps = sorted((a for a in f.axes if a.images), key=lambda a: a.get_position().x0)
        bars = sorted(
            (a for a in f.axes if a.get_ylabel().startswith("<v*>")), key=lambda a: a.get_position().x0
        )
        assert len(maps) == len(bars) == 2
        title = bars[0].yaxis.label.get_window_extent(r)
        assert title.x1 < maps[1].yaxis.label.get_window_extent(r).x0
        assert title.x1 < maps[1].get_tightbbox(r).x0 + 1
    finally:
        plt.close(f)


# ---------------------------------------------------------------- contact states
@pytest.fixture(scope="module")
def run4():
    """Paper point 4 (hopping: flight and total sliding every period), short."""
    return simulate(paper_scene(4, periods=50), window=(48, 50), samples_per_period=5)


@pytest.mark.slow
def test_html_export_state_strip_shows_the_state_colours(tmp_path, run4):
    # Source: the report (the whole-run strip of the HTML export was
    # solid black).  Bokeh outlines each band in black by default; over a
    # run's hundreds of bands a pixel or less wide the outlines were all one
    # saw.  The strip must draw its bands in the state colours, unoutlined,
    # and name the colours in a legend.
    obj = export.export_trajectory(run4, tmp_path / "t.html")
    fig = export.trajectory_bokeh(obj)
    strips = [r for r in fig.select({"type": GlyphRenderer}) if isinstance(r.glyph, Patch)]
    # the whole run's strip: a polygon per state over many bins
    assert any(len(r.data_source.data["x"]) > 40 for r in strips)
    colours = set(plots.STATE_COLORS.values())
    for r in strips:
        assert r.glyph.fill_color in colours
        assert r.glyph.line_alpha == 0 or r.glyph.line_width == 0 or r.glyph.line_color == r.glyph.fill_color
    names = {item.label.value for lg in fig.select({"type": Legend}) for item in lg.items}
    assert {"flight", "total sliding"} <= names  # the states point 4 visits


def test_live_strips_name_the_state_colours(run4):
    # the explorer's strips (app/views/live.py): a legend grouped by the bands'
    # state names, fed with each run; the colours are the plots' ones
    from bokeh.core.property.vectorization import Field

    from vibtrans_explorer.views import live

    view = live.LiveTrajectory(label=None, fragment=2.0, tau=50.0)
    view.show(run4)
    for block in (view.over, view.last):
        legends = [m for m in block.timeline.above if isinstance(m, Legend)]
        assert len(legends) == 1
        (item,) = legends[0].items
        assert isinstance(item.label, Field) and item.label.field == "state"
        data = block.bands.data
        assert set(data["state"]) >= {"flight", "total sliding"}
        for name, colour in zip(data["state"], data["color"]):
            assert colour == plots.STATE_COLORS[STATE_NAMES.index(name)]
