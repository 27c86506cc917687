"""The explorer's Design tab (app/views/design.py) without a browser: the
library's design chart drawn from a preset, a click on it reading the
device there, bad values refused with the library's message, the tab
built when first opened."""
import asyncio
from types import SimpleNamespace

import numpy as np
import pytest
from bokeh.models import ColumnDataSource

from vibtrans import design
from vibtrans_explorer import explorer as E
from vibtrans_explorer import mapjobs
from vibtrans_explorer.views.design import DesignPanel

pytestmark = pytest.mark.slow       # charts rendered


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
    assert drawn.device == dev
    assert "drift velocity" in drawn.info.object and not drawn.busy


def test_a_click_at_the_papers_device_gives_its_quantities(drawn):
    """The paper's worked example (point 4: drift about -2.7 cm/s), as the
    library gives it for the device clicked."""
    dev = design.preset("paper").device
    # the click as Bokeh delivers it (data coordinates of the log axes)
    drawn._on_tap(SimpleNamespace(x=None, y=None))          # nothing: no place
    asyncio.run(drawn.mark(dev.frequency * 1.0001, dev.amplitude * 0.9999))
    clicked = drawn.device
    assert (clicked.frequency, clicked.amplitude) == (float(f"{dev.frequency * 1.0001:.4g}"),
                                                      float(f"{dev.amplitude * 0.9999:.4g}"))
    assert (drawn.frequency, drawn.amplitude) == (clicked.frequency, clicked.amplitude)
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
    assert drawn.device == clicked


def test_a_bad_value_names_the_parameter_and_the_chart_stays(drawn):
    fig, chart = drawn.figure, drawn.chart
    drawn.x_lo = -1e4                          # a negative frequency
    asyncio.run(drawn.draw())
    assert drawn.alert.visible
    text = drawn.alert.object
    assert "x lo (frequency)" in text and "(0, inf)" in text and "-10000" in text
    assert "Traceback" not in text
    assert drawn.figure is fig and drawn.chart is chart and drawn.x_lo == -1e4   # not clamped
    assert drawn.chart_pane.objects[0].object is fig and not drawn.busy
    # text that is no number: said under its field, and the draw refuses
    drawn.fields["x_hi"].input.value = "abc"
    assert "x hi must be a number" in drawn.fields["x_hi"].error
    asyncio.run(drawn.draw())
    assert "x hi must be a number; got 'abc'" in drawn.alert.object
    drawn.fields["x_hi"].input.value = "1e6"
    drawn.x_lo = 1e4
    # a device value the library refuses
    drawn.radius = 0.0
    asyncio.run(drawn.draw())
    assert "radius" in drawn.alert.object and "(0, inf)" in drawn.alert.object
    assert drawn.figure is fig
    drawn.radius = 0.5e-3
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
        await asyncio.sleep(0)          # the draw has started: off the event loop now
        assert drawn.busy and drawn.spinner.visible and drawn.draw_button.disabled
        assert "Drawing the chart" in drawn.status.object
        await task
        assert not drawn.busy and not drawn.spinner.visible and not drawn.draw_button.disabled
    asyncio.run(busy_while_drawing())
    assert not drawn.alert.visible and drawn.figure is not fig


def test_a_new_axis_quantity_takes_a_range_around_the_device(tmp_path):
    panel = DesignPanel(jobs=mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1))
    dev = design.preset("paper").device
    assert (panel.x, panel.y) == ("frequency", "amplitude")    # the preset's, kept as given
    assert (panel.x_lo, panel.x_hi) == (1e4, 1e6)
    panel.x = "radius"
    assert panel.fixed_quantity() == "frequency"
    assert panel.x_lo < dev.radius < panel.x_hi and panel.x_hi / panel.x_lo == pytest.approx(
        10, rel=0.01)
    asyncio.run(panel.draw())           # small radii: A* beyond the shipped map's 10^3
    assert "log10 A* spans" in panel.offer.object and panel.chart is None       # (offered)
    panel.y_hi = 1e-7
    asyncio.run(panel.draw())
    assert not panel.alert.visible and panel.chart.attrs["fixed"] == "frequency"
    assert not panel.offer_box.visible          # a shipped map serves: the offer is gone
    assert panel.chart.attrs["fixed_value"] == dev.frequency
    panel.y = "radius"                  # the same quantity twice: the library's message
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
        E._attached_in_one_pass(E.explorer_template(ex)).server_doc(doc)
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
        shown, = ex.design_box.objects
        assert panel.draw_button in shown.select(type(panel.draw_button))
        ex.map_tabs.active = 0
        ex.map_tabs.active = E.DESIGN_TAB
        assert ex.design_panel is panel and ex.design_box.objects == [shown]     # built once
