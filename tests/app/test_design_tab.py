"""The explorer's Design tab (app/views/design.py) without a browser: the
library's design chart drawn from a preset, a click on it reading the
device there, bad values refused with the library's message, the tab
built when first opened."""

import asyncio
from types import SimpleNamespace

import numpy as np
import pytest
from asyncutil import until
from bokeh.models import ColumnDataSource
from markdowntext import emphasized, shown_text

from vibtrans.products import design
from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import mapjobs
from vibtrans_explorer.views.design import DesignPanel

pytestmark = pytest.mark.slow  # charts rendered


def _numbers(value):
    """The numbers in a source's column (arrays, or lists of arrays: paths)."""
    if isinstance(value, np.ndarray):
        return [value] if value.dtype.kind in "fiu" else []
    if isinstance(value, (list, tuple)):
        out = []
        for v in value:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out.append(np.asarray([v], dtype=float))
            elif isinstance(v, (list, tuple, np.ndarray)):
                out += _numbers(np.asarray(v) if not isinstance(v, np.ndarray) else v)
        return out
    return []


def _sources(fig):
    return [m for m in fig.references() if isinstance(m, ColumnDataSource)]


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """A Design panel with the paper preset's chart drawn."""
    jobs = mapjobs.MapJobs(folder=str(tmp_path_factory.mktemp("maps")), cores=1)
    panel = DesignPanel(jobs=jobs)
    panel.__panel__()
    asyncio.run(panel.draw())
    return panel


def test_the_paper_preset_draws_a_chart_with_data(drawn):
    assert drawn.preset == "paper" and not drawn.alert.visible
    chart, fig = drawn.chart, drawn.figure
    assert chart.attrs["map"] == "shipped: deformable-mu0.3.zarr"
    assert drawn.chart_pane.objects[0].object is fig
    assert "steel on glass" in fig.title.text
    mesh = next(s for s in _sources(fig) if "C" in s.data)
    assert len(mesh.data["C"]) == chart.sizes["frequency"] * chart.sizes["amplitude"] == 41 * 41
    # no NaN reaches the plot: every number of every source is finite
    for source in _sources(fig):
        for name, column in source.data.items():
            for arr in _numbers(column):
                assert np.isfinite(arr.astype(float)).all(), name
    # the preset's device is marked and described
    dev = design.preset("paper").device
    assert drawn._marker.data["frequency"] == [dev.frequency]
    assert drawn.marked == dev
    assert "drift velocity" in drawn.info.object and not drawn.busy


def test_a_click_at_the_papers_device_gives_its_quantities(drawn):
    """The paper's worked example (point 4: drift about -2.7 cm/s), as the
    library gives it for the device clicked."""
    dev = design.preset("paper").device
    # the click as Bokeh delivers it (data coordinates of the log axes)
    drawn._on_tap(SimpleNamespace(x=None, y=None))  # nothing: no place
    asyncio.run(drawn.mark(dev.frequency * 1.0001, dev.amplitude * 0.9999))
    clicked = drawn.marked
    assert (clicked.frequency, clicked.amplitude) == (
        float(f"{dev.frequency * 1.0001:.4g}"),
        float(f"{dev.amplitude * 0.9999:.4g}"),
    )
    assert (drawn.device.frequency, drawn.device.amplitude) == (clicked.frequency, clicked.amplitude)
    reading = design.read_device(clicked, chart=drawn.chart)
    expect = design.device_quantities(clicked, reading)
    q = drawn.quantities
    assert q == expect and drawn.reading == reading
    # the device clicked reads the same map point as the paper's device itself
    paper = design.device_quantities(dev, design.read_device(dev))
    assert q.v_star == paper.v_star
    assert q.drift_velocity == pytest.approx(paper.drift_velocity, rel=1e-3)
    assert f"{q.drift_velocity:.4g} m/s" in drawn.info.object
    assert drawn.reading["regime"] in drawn.info.object
    codes = [w.code for w in design.validity_warnings(clicked, drift_velocity=q.drift_velocity)]
    assert [w.code for w in drawn.warnings] == codes
    assert all(w.message in drawn.info.object for w in drawn.warnings)
    assert drawn._marker.data["frequency"] == [clicked.frequency]
    # a click outside the chart's window moves nothing
    asyncio.run(drawn.mark(1e9, dev.amplitude))
    assert drawn.marked == clicked


def test_a_bad_value_names_the_parameter_and_the_chart_stays(drawn):
    fig, chart = drawn.figure, drawn.chart
    drawn.x_lo = -1e4  # a negative frequency
    asyncio.run(drawn.draw())
    assert drawn.alert.visible
    text = drawn.alert.object
    assert "x lo (frequency)" in text and "(0, inf)" in text and "-10000" in text
    assert "Traceback" not in text
    assert drawn.figure is fig and drawn.chart is chart and drawn.x_lo == -1e4  # not clamped
    assert drawn.chart_pane.objects[0].object is fig and not drawn.busy
    # text that is no number: said under its field, and the draw refuses
    drawn.fields["x_hi"].input.value = "abc"
    assert "x hi must be a number" in drawn.fields["x_hi"].error
    asyncio.run(drawn.draw())
    assert "x hi must be a number; got 'abc'" in drawn.alert.object
    drawn.fields["x_hi"].input.value = "1e6"
    drawn.x_lo = 1e4
    # a device value the library refuses
    drawn.device.radius = 0.0
    asyncio.run(drawn.draw())
    assert "radius" in drawn.alert.object and "(0, inf)" in drawn.alert.object
    assert drawn.figure is fig
    drawn.device.radius = 0.5e-3
    # materials no shipped map serves: the library's reason, and the map
    # the chart needs offered with its cost; nothing computed yet
    drawn.preset = "feeder"
    asyncio.run(drawn.draw())
    offer = drawn.offer.object
    assert drawn.offer_box.visible and not drawn.alert.visible
    assert "No shipped map serves this chart" in offer and "theta 1.424" in offer
    assert "The map it needs" in offer and "At most" in offer and "integration steps" in offer
    assert not drawn.compute_button.disabled and drawn.jobs.computed == 0
    assert drawn.figure is fig
    drawn.preset = "paper"

    async def busy_while_drawing():
        task = asyncio.create_task(drawn.draw())
        await until(lambda: drawn.busy)  # the draw has started: off the event loop now
        assert drawn.busy and drawn.spinner.visible and drawn.draw_button.disabled
        assert "Drawing the chart" in drawn.status.object
        await task
        assert not drawn.busy and not drawn.spinner.visible and not drawn.draw_button.disabled

    asyncio.run(busy_while_drawing())
    assert not drawn.alert.visible and drawn.figure is not fig


def test_a_new_axis_quantity_takes_a_range_around_the_device(tmp_path):
    panel = DesignPanel(jobs=mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1))
    dev = design.preset("paper").device
    assert (panel.x, panel.y) == ("frequency", "amplitude")  # the preset's, kept as given
    assert (panel.x_lo, panel.x_hi) == (1e4, 1e6)
    panel.x = "radius"
    assert panel.fixed_quantity() == "frequency"
    assert panel.x_lo < dev.radius < panel.x_hi and panel.x_hi / panel.x_lo == pytest.approx(10, rel=0.01)
    asyncio.run(panel.draw())  # small radii: A* beyond the shipped map's 10^3
    assert "log10 A* spans" in shown_text(panel.offer.object) and panel.chart is None  # (offered)
    panel.y_hi = 1e-7
    asyncio.run(panel.draw())
    assert not panel.alert.visible and panel.chart.attrs["fixed"] == "frequency"
    assert not panel.offer_box.visible  # a shipped map serves: the offer is gone
    assert panel.chart.attrs["fixed_value"] == dev.frequency
    panel.y = "radius"  # the same quantity twice: the library's message
    asyncio.run(panel.draw())
    assert "once each" in panel.alert.object


def test_the_design_tab_is_built_when_first_opened():
    """Most pages never open it: nothing of it is made (nor sent to the
    browser) before; opened, its widgets are in the page."""
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    doc = Document()
    with set_curdoc(doc):
        ex = E.Explorer()
        E.explorer_template(ex).server_doc(doc)
    assert not [m for m in doc.models if "vt-design-draw" in getattr(m, "css_classes", [])]
    assert ex.design_panel is None and not ex.design_box.objects
    assert E.DESIGN_TAB == len(ex.map_tabs) - 1
    assert ex.map_tabs._names[E.DESIGN_TAB] == "Design"
    with set_curdoc(doc):
        ex.map_tabs.active = E.UNITS_TAB
        assert ex.design_panel is None and not ex.design_box.objects
        ex.map_tabs.active = E.DESIGN_TAB
        assert [m for m in doc.models if "vt-design-draw" in getattr(m, "css_classes", [])]
        panel = ex.design_panel
        assert isinstance(panel, DesignPanel) and panel.chart is None
        (shown,) = ex.design_box.objects
        assert panel.draw_button in shown.select(type(panel.draw_button))
        ex.map_tabs.active = 0
        ex.map_tabs.active = E.DESIGN_TAB
        assert ex.design_panel is panel and ex.design_box.objects == [shown]  # built once


# ---------------------------------------------------------------- custom materials
from vibtrans.core import units  # noqa: E402
from vibtrans_explorer.views import design as D  # noqa: E402

# the chart's numbers (every variable but the names in attrs)
CHART_VARS = (
    "drift_velocity",
    "v_star",
    "drift",
    "contact",
    "pattern",
    "chaotic",
    "regime",
    "contact_fraction",
    "A_star",
    "m_star",
    "a0",
    "contact_radius",
    "adhesion_ratio",
    "travel_over_wavelength",
)


def _small(panel):
    """A small window of the paper preset's chart (cheap to draw and export)."""
    panel.param.update(x_lo=3e4, x_hi=3e5, x_points=6, y_lo=1e-8, y_hi=3e-7, y_points=5)
    return panel


def _custom(m):
    return f"E={m.youngs_modulus!r},nu={m.poisson_ratio!r},rho={m.density!r}"


def test_a_custom_material_equal_to_glass_draws_the_same_chart():
    named = _small(DesignPanel())
    asyncio.run(named.draw())
    assert not named.alert.visible
    panel = _small(DesignPanel())
    panel.__panel__()
    assert not panel.custom_row.visible
    panel.device.substrate = D.CUSTOM_MATERIAL
    assert panel.custom_row.visible and panel.custom_inputs["substrate"].visible
    assert not panel.custom_inputs["particle"].visible
    glass, example = units.material("glass"), units.material(D.CUSTOM_EXAMPLE)
    assert panel.device.substrate_custom == D.CUSTOM_EXAMPLE  # glass's E, nu, rho
    assert (example.youngs_modulus, example.poisson_ratio, example.density) == (
        glass.youngs_modulus,
        glass.poisson_ratio,
        glass.density,
    )
    panel.device.particle = D.CUSTOM_MATERIAL
    panel.device.particle_custom = _custom(units.material("steel"))
    assert panel.values()["substrate"] == D.CUSTOM_EXAMPLE
    assert panel.values()["particle"] == _custom(units.material("steel"))
    asyncio.run(panel.draw())
    assert not panel.alert.visible, panel.alert.object
    assert panel.chart.attrs["substrate"] == f"custom ({D.CUSTOM_EXAMPLE})"
    for name in CHART_VARS:
        np.testing.assert_array_equal(panel.chart[name].values, named.chart[name].values, err_msg=name)
    assert panel.quantities == named.quantities
    assert "custom (E=70e9" in panel.info.object
    # back to a named material: its field hidden
    panel.device.particle = "steel"
    assert not panel.custom_inputs["particle"].visible and panel.custom_row.visible


@pytest.mark.parametrize(
    "text",
    [
        "E=70e9,nu=0.3",
        "E=70e9,nu=0.7,rho=2500",
        "E=abc,nu=0.3,rho=2500",
        "E=70e9,nu=0.3,rho=2500,k=1",
        "unobtainium",
        "",
    ],
)
def test_a_bad_custom_material_gets_the_librarys_message(text):
    panel = _small(DesignPanel())
    asyncio.run(panel.draw())
    chart = panel.chart
    panel.device.substrate = D.CUSTOM_MATERIAL
    panel.device.substrate_custom = text
    asyncio.run(panel.draw())
    with pytest.raises(ValueError) as refused:
        units.material(text)
    assert panel.alert.visible
    # (as the page shows it: the message is Markdown)
    assert shown_text(panel.alert.object).strip() == f"Cannot draw the chart: {refused.value}"
    assert panel.device.substrate_custom == text and panel.chart is chart  # nothing clamped


# ---------------------------------------------------------------- the chart's notes
def test_the_chart_wide_warnings_and_ranges_are_shown_below_the_status(drawn):
    chart = drawn.chart
    notes = drawn.chart_notes
    assert notes.visible
    layout = drawn.__panel__()
    assert layout.objects.index(notes) == layout.objects.index(drawn.status) + 1
    lines = design.chart_warnings(chart)
    assert lines and all(f"**chart warning:** {line}" in notes.object for line in lines)
    assert "No validity warnings" not in notes.object
    for var, label in (
        ("a0", "a0"),
        ("contact_radius", "contact radius"),
        ("A_star", "A*"),
        ("m_star", "m*"),
    ):
        lo, hi = f"{chart[var].values.min():.3g}", f"{chart[var].values.max():.3g}"
        assert f"{label} {lo if lo == hi else f'{lo} – {hi}'}" in notes.object, var
    # (a0 and the contact radius depend on the radius only: fixed on this chart)
    assert f"a0 {chart['a0'].values[0, 0]:.3g} m;" in notes.object
    assert f"A* {chart['A_star'].values.min():.3g} – " in notes.object
    assert "A* " in notes.object and "m* " in notes.object
    # a chart crossing no threshold says so
    quiet = chart.copy(deep=True)
    quiet["adhesion_ratio"].values[...] = 0.0
    quiet["a0"].values[...] = 1e-6
    quiet["contact_radius"].values[...] = 1e-4
    quiet["travel_over_wavelength"].values[...] = 0.0
    assert design.chart_warnings(quiet) == []
    assert "*No validity warnings over the chart.*" in D.chart_text(quiet)
    # nothing before a chart is drawn
    assert not DesignPanel().chart_notes.visible


# ---------------------------------------------------------------- downloads
def test_the_downloads_are_of_the_chart_shown(monkeypatch, tmp_path):
    import io
    import xml.etree.ElementTree as ET

    import pandas as pd
    import xarray as xr

    panel = _small(DesignPanel())
    buttons = panel.download_buttons
    assert set(buttons) == {"png", "svg", "pdf", "nc", "csv"}
    assert all(b.disabled for b in buttons.values())
    assert "draw a chart first" in panel.download_note.object
    with pytest.raises(ValueError, match="draw a chart first"):
        panel.chart_file("png")
    asyncio.run(panel.draw())
    chart = panel.chart
    assert not any(b.disabled for b in buttons.values())
    assert panel.downloads in panel.__panel__().objects
    got = {fmt: b.callback().getvalue() for fmt, b in buttons.items()}
    assert got["png"][:8] == b"\x89PNG\r\n\x1a\n"
    assert ET.fromstring(got["svg"]).tag.endswith("svg")
    assert got["pdf"][:5] == b"%PDF-"
    (tmp_path / "chart.nc").write_bytes(got["nc"])
    with xr.open_dataset(tmp_path / "chart.nc") as back:
        assert back.attrs["map"] == chart.attrs["map"]
        assert back.load().equals(chart)  # every variable and coordinate
        for name in CHART_VARS:
            np.testing.assert_array_equal(back[name].values, chart[name].values, err_msg=name)
        for q in (chart.attrs["x"], chart.attrs["y"]):
            np.testing.assert_array_equal(back[q].values, chart[q].values)
    table = pd.read_csv(io.BytesIO(got["csv"]))
    assert len(table) == chart["a0"].size == 6 * 5
    np.testing.assert_allclose(
        np.sort(table["drift_velocity"].values), np.sort(chart["drift_velocity"].values.ravel())
    )
    # the figure marks the device shown (moved by a click)
    asyncio.run(panel.mark(1e5, 5e-8))
    seen = {}

    def fake_export(chart_, out, device=None):
        seen.update(chart=chart_, device=device)
        open(out, "wb").write(b"x")

    monkeypatch.setattr("vibtrans.products.export.export_design", fake_export)
    assert buttons["svg"].callback().getvalue() == b"x"
    assert seen == {"chart": chart, "device": (1e5, 5e-8)}


# ---------------------------------------------------------------- the preset's label
def test_editing_a_value_labels_the_preset_custom():
    panel = DesignPanel()
    paper = design.preset("paper")
    assert panel.param.preset.objects[-1] == D.CUSTOM_PRESET
    panel.device.radius = 1e-3
    assert panel.preset == D.CUSTOM_PRESET and panel.device.radius == 1e-3  # nothing re-applied
    assert "Custom values" in panel.note.object
    assert (panel.x_lo, panel.device.frequency) == (paper.x[1], paper.device.frequency)
    panel.preset = "paper"  # a real preset: applied as before
    assert panel.device.radius == paper.device.radius and panel.preset == "paper"
    assert emphasized(panel.note.object) == [paper.note]  # shown whole, in italics
    # a value typed in its field, an axis, a material: each makes it custom
    for edit in (
        lambda: setattr(panel.fields["x_lo"].input, "value", "2e4"),
        lambda: setattr(panel, "y", "radius"),
        lambda: setattr(panel, "x_points", 11),
        lambda: setattr(panel.device, "particle", "glass"),
        lambda: setattr(panel.device, "substrate", D.CUSTOM_MATERIAL),
    ):
        panel.preset = "paper"
        assert panel.preset == "paper"
        edit()
        assert panel.preset == D.CUSTOM_PRESET
    # back to a preset: its named materials, the custom field hidden
    panel.preset = "saw-motor"
    assert panel.device.substrate == "lithium niobate" and not panel.custom_row.visible
    # a custom material's text counts only while that material is custom
    panel.device.substrate_custom = "E=1e9,nu=0.3,rho=1000"
    assert panel.preset == "saw-motor"
    panel.device.substrate = D.CUSTOM_MATERIAL
    panel.preset = "paper"
    panel.device.substrate = D.CUSTOM_MATERIAL
    assert panel.preset == D.CUSTOM_PRESET
    # choosing "custom" by hand applies nothing
    values = panel.values()
    panel.preset = "paper"
    before = panel.values()
    panel.preset = D.CUSTOM_PRESET
    assert panel.values() == before and values != before
    # mu and the surface energy are not a preset's: they leave its label
    panel.preset = "paper"
    panel.surface_energy = 0.01
    assert panel.preset == "paper"


def test_a_chart_of_other_values_is_marked_and_the_table_follows_the_device(tmp_path):
    # paper preset, Draw chart (sphere), then frequency 200000 and a cone
    # tip, Draw chart: the cone's chart needs its own map (offered); the
    # sphere's chart stays under the banner "Changed since this chart was
    # drawn", and the table shows the cone's device, not the sphere's m/s
    from vibtrans_explorer.session.state import ExplorerState
    from vibtrans_explorer.views import design as D

    state = ExplorerState()
    panel = DesignPanel(jobs=mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1), state=state)
    panel.__panel__()
    asyncio.run(panel.draw())
    chart = panel.chart
    assert chart.attrs["map"] == "shipped: deformable-mu0.3.zarr"
    assert panel.status.object.startswith("*steel on glass") and "m/s" in panel.info.object
    state.param.update(frequency=200000.0, tip="cone")
    assert panel.status.object.startswith(D.STALE)
    asyncio.run(panel.draw())
    # the cone's chart needs its own map: offered, the reason said
    assert panel.offer_box.visible and "the shipped maps are the sphere's" in panel.offer.object
    # the chart shown stays, under a banner that says why it is not redrawn
    assert panel.chart is chart
    assert panel.status.object.startswith(D.STALE_OFFERED)
    assert "*The chart shown: steel on glass" in panel.status.object
    # the table is the form's device: the cone at 2e5 Hz, its drift not read
    info = panel.info.object
    assert "f = 2e+05 Hz" in info and "cone" in info and D.UNREAD_OFFERED in info
    assert "m/s**" not in info
    # the values of the chart again: no banner
    state.param.update(frequency=design.preset("paper").device.frequency, tip="sphere")
    assert not panel.stale() and panel.status.object.startswith("*steel on glass")
