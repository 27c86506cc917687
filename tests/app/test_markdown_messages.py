"""The library's words in the explorer's Markdown panes are shown as
written (urlstate.literal): a star of A*, v* or t*, a '|v*|', an '_' or an
'E=<Pa>' is neither emphasis, a table's cell edge nor an HTML tag.  The
Design tab's status line is in italics: unescaped, the star of "log10 A*"
in its chart's reading would close them ("... in log10 A and in log10 m*").

Each test renders a pane as the page does (markdown-it, tests/markdowntext.py)
and finds the library's message in it, stars included."""

import asyncio

import pytest
from markdowntext import emphasized, shown_text, table_rows

from vibtrans import Scene
from vibtrans.analysis import summary as analysis
from vibtrans.core import units
from vibtrans.products import design
from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import mapjobs
from vibtrans_explorer.session.urlstate import literal
from vibtrans_explorer.views.design import DesignPanel, device_text
from vibtrans_explorer.views.summary import summary_table

# texts of the library's kinds: stars, bars, underscores, angle brackets, backquotes
LIBRARY_TEXTS = [
    "the map point read is at most 0.025 decades from the device in log10 A* and in log10 m*",
    "launched: leaves the substrate at t* = 12 and is still in flight at the end (t* = 2000)",
    "moves <v*> by less than 0.25% of |v*| (at least v0* = 0.1)",
    "a cone's contact pressure (E* cot(alpha)/2) arccosh(a/r) is infinite",
    "write E=<Pa>,nu=<0..0.5>,rho=<kg/m^3>; names: 304_stainless_steel, _x_, *y*",
    "a `code` [link](x) ~~struck~~ & \\ backslash",
]


@pytest.mark.parametrize("text", LIBRARY_TEXTS)
def test_a_literal_text_shows_as_written_even_inside_emphasis(text):
    assert shown_text(literal(text)).strip() == text
    assert emphasized(f"*{literal(text)}*") == [text]
    assert emphasized(f"**Why:** {literal(text)}") == ["Why:"]
    # in a table's cell, a bar is the text's
    rows = table_rows(f"| a | b |\n|---|---|\n| x | {literal(text)} |")
    assert rows[1] == ["x", text]


@pytest.mark.slow
def test_the_design_tabs_status_note_and_alert_show_the_librarys_words(tmp_path):
    panel = DesignPanel(jobs=mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1))
    panel.__panel__()
    # the preset's note (v* of the paper and of this model), whole in italics
    assert emphasized(panel.note.object) == [design.preset("paper").note]
    panel.param.update(x_lo=3e4, x_hi=3e5, x_points=6, y_lo=1e-8, y_hi=3e-7, y_points=5)
    asyncio.run(panel.draw())
    reading = panel.chart.attrs["reading"]
    assert "log10 A* and in log10 m*" in reading
    # the status line is one italic text, the chart's reading in it whole
    (status,) = emphasized(panel.status.object)
    assert reading in status
    # the table's warnings and tip
    shown = shown_text(panel.info.object)
    assert all(w.message in shown for w in panel.warnings)
    # a refused custom material: the library's message with its <Pa>
    panel.device.substrate = "custom (E, nu, rho)"
    panel.device.substrate_custom = "E=70e9"
    asyncio.run(panel.draw())
    with pytest.raises(ValueError) as refused:
        units.material("E=70e9")
    assert "<Pa>" in str(refused.value)
    assert shown_text(panel.alert.object).strip() == f"Cannot draw the chart: {refused.value}"


def test_a_cone_tips_warnings_keep_their_stars():
    from vibtrans.products import designtip

    device = design.preset("paper").device
    shape = designtip.tip_shape("cone", half_angle=60.0)
    q = design.device_quantities(device, shape=shape)
    warnings = design.validity_warnings(device, shape=shape)
    apex = next(w for w in warnings if w.code == "cone-apex")
    assert "E* cot(alpha)/2" in apex.message
    text = shown_text(device_text(device, None, q, warnings))
    assert apex.message in text and q.profile in text


def test_the_units_tab_shows_the_librarys_refusal_and_warnings():
    ex = E.Explorer()
    ex.units_panel.__panel__()
    ex.state.param.update(tip="cone", tip_half_angle=60.0)
    shown = shown_text(ex.units_panel.warnings.object)
    assert all(
        w.message in shown
        for w in design.validity_warnings(ex.state.device_spec(), shape=ex.state.tip_shape())
    )
    ex.state.param.update(substrate="custom (E, nu, rho)", substrate_custom="E=70e9")
    with pytest.raises(ValueError) as refused:
        ex.state.device()
    assert "<Pa>" in str(refused.value)
    assert f"Invalid input: {refused.value}" in shown_text(ex.units_panel.info.object)


def test_a_device_outside_the_range_is_said_with_its_stars():
    ex = E.Explorer()
    ex.state.param.update(amplitude=1e-3)  # A* far beyond the explorer's range
    assert ex._run_device() is None
    shown = shown_text(ex.message.object)
    assert "Not run: the device (log10 A* = " in shown and ", log10 m* = " in shown
    assert "explorer's range: log10 A* in [" in shown


def test_the_summary_shows_the_librarys_words_in_its_cells():
    # a launched run's regime (two t*) and a steadiness (<v*>, |v*|): each
    # cell shows the library's words whole
    s = analysis.Summary(*[None] * len(analysis.Summary._fields))._replace(
        drift_velocity=-12.5,
        final_drift_velocity=-12.5,
        takeoffs=1,
        takeoffs_per_period=0.0,
        contact_fraction=0.0,
        steps=10,
        seconds=0.1,
        model="deformable",
        twin_steps=0,
        regime=LIBRARY_TEXTS[1],
        steadiness=f"not steady: {LIBRARY_TEXTS[2]}",
        steady=False,
    )
    table = summary_table(Scene(profile="power:3"), s, "not checked", None, None, None)
    rows = {r[0]: r[1:] for r in table_rows(table)}
    assert rows["regime"] == [LIBRARY_TEXTS[1]]
    assert rows["steady?"] == [f"not steady: {LIBRARY_TEXTS[2]}"]
