"""The explorer's views without a server (issue 14, for a lab and a class):
both models' maps side by side with one zoom, a click on them running both
models; the selected scene marked on the vertical curve; the trajectory's
time axis in seconds for a device's run; presentation mode's large fonts."""
from types import SimpleNamespace

import pytest

from vibtrans_explorer import data
from vibtrans_explorer import explorer as E
from vibtrans_explorer.views import runtabs
from vibtrans_explorer.live import time_label

pytestmark = pytest.mark.slow       # explorer sessions (maps rendered)


def _explorer(**state):
    ex = E.Explorer()
    ex.state.param.update(**{"fidelity": "preview", "compare": "none", **state})
    return ex


@pytest.mark.skipif(("point-mass", 0.3) not in data.available_maps(),
                    reason="needs the shipped point-mass map at mu = 0.3")
def test_both_maps_share_one_zoom_and_a_click_runs_both_models(monkeypatch):
    ex = _explorer(model="point-mass")
    assert len(ex.map_view.figures) == 1
    ex.state.maps = "both models"
    dm, pm = ex.map_view.figures
    assert "deformable" in dm.title.text and "point-mass" in pm.title.text
    assert pm.x_range is dm.x_range and pm.y_range is dm.y_range     # linked zoom
    runs = []
    monkeypatch.setattr(ex, "start_run", lambda: runs.append(ex.state.scene()))
    ex.map_view._on_tap(True, SimpleNamespace(x=0.4, y=1.2))
    # the deformable scene with the point mass beside it: one run, two models
    assert len(runs) == 1 and runs[0].model == "deformable"
    assert ex.state.compare == "point mass"
    ex.state.maps = "selected model"
    assert len(ex.map_view.figures) == 1


def test_the_vertical_curve_marks_the_selected_scene():
    ex = _explorer()
    ex.vertical.build()
    ex.state.param.update(log_amplitude=1.25, log_mass=-0.5)
    # the map's axes (issue 32: the vertical tab had them swapped)
    assert ex.vertical.scene.data == {"x": [1.25], "y": [-0.5]}
    fig = ex.vertical.pane.objects[0].object
    assert fig.xaxis[0].axis_label == "log10 A*" and fig.yaxis[0].axis_label == "log10 m*"
    labels = [item.label["value"] if isinstance(item.label, dict) else
              getattr(item.label, "value", item.label) for item in fig.legend[0].items]
    assert "the selected scene" in labels


def test_time_reads_in_seconds_for_a_device():
    assert time_label() == "t* (periods)"
    assert time_label(1998.0) == "t* - t0 (periods; t0 = 1998)"
    # 108 kHz: a period lasts 9.259 us
    assert time_label(None, 1 / 108e3) == "t* (periods); 1 period = 9.259 us"


def test_presentation_mode_enlarges_and_restores_the_figures_fonts():
    ex = _explorer()
    ex.main()
    fig = ex.map_view.figures[0]
    ex.presentation = True
    assert fig.xaxis[0].axis_label_text_font_size == "15pt"
    large = {"--bokeh-font-size": f"{1.5 * E.BOKEH_FONT_PX:g}px"}
    assert ex.page.styles == large and ex.intro.collapsed
    assert ex.presentation_note.visible
    ex.state.chaotic = "colour"         # a redrawn map keeps the large fonts
    fig = ex.map_view.figures[0]
    assert fig.xaxis[0].axis_label_text_font_size == "15pt"
    ex.run_tabs.active = runtabs.DYNAMICS_TAB     # a run tab built while large: large too
    view = ex.trajectories.view(None, 50.0)       # and a run's figures built while large
    assert view.part.children[0].title.text_font_size == "15pt"
    assert ex.dynamics_view.section_fig.xaxis[0].axis_label_text_font_size == "15pt"
    ex.presentation = False
    assert fig.xaxis[0].axis_label_text_font_size == "10pt" and ex.page.styles == {}
    assert ex.dynamics_view.section_fig.xaxis[0].axis_label_text_font_size == "10pt"
    assert not ex.presentation_note.visible


def test_the_run_tabs_build_their_views_when_opened():
    """The animation and the memory diagram are built (and the memory
    snapshots computed) only once their tab opens, then follow the runs."""
    import asyncio

    from asyncutil import until

    async def go():
        ex = _explorer(log_amplitude=0.3, log_mass=-2.0)
        assert ex.animation is None and ex.memory_view is None
        ex.start_run()
        await until(lambda: ex.controller.job is None and ex.controller.result is not None)
        assert ex.animation is None and ex.memory_view is None       # nothing opened yet
        ex.run_tabs.active = runtabs.ANIMATION_TAB
        assert ex.animation is not None and ex._animated is ex.controller.result
        ex.run_tabs.active = runtabs.MEMORY_TAB
        assert ex.memory_view is not None and ex.memory_view.scene is not None
        ex.memory_view.clear()
    asyncio.run(go())


def test_changing_the_comparison_relabels_the_same_figures():
    """Issue 14: the first run after changing "compare with" built a new
    set of figures (2.8-6 s).  Every comparison shares one set, relabelled:
    the tau twin's panel becomes the point mass's, no new figure."""
    import asyncio

    from asyncutil import until

    async def go():
        ex = _explorer(compare="tau twin", log_amplitude=0.5, log_mass=1.5)
        ex.start_run()
        await until(lambda: ex.controller.job is None and ex.controller.result is not None)
        (key, view), = ex.trajectories.views.items()
        assert key == "beside a comparison" and view.over.twin_figure.title.text.endswith("twin")
        first = ex.controller.result
        ex.state.compare = "point mass"
        ex.start_run()
        await until(lambda: ex.controller.job is None and ex.controller.result is not first)
        assert list(ex.trajectories.views) == [key] and view.runs == 2
        assert view.over.twin_figure.title.text == "x*(t) and the point mass run of the same scene"
        assert [i.label.value for i in view.over.twin_items][1] == "x*, point mass"   # a value, not a field
    asyncio.run(go())


def _page_document():
    """A session's page attached to its own document, as the server builds
    it (devtools/pagecost.py)."""
    from bokeh.document import Document
    from panel.io.state import set_curdoc
    doc = Document()
    with set_curdoc(doc):
        ex = E.Explorer()
        E.explorer_template(ex).server_doc(doc)
    return ex, doc


def _shown(doc):
    """What the browser has of the page: each model's type, CSS classes and
    text, one string per model."""
    return [" ".join([type(m).__name__, *getattr(m, "css_classes", []),
                      str(getattr(m, "text", "") or ""), str(getattr(m, "title", "") or "")])
            for m in doc.models]


def _has(doc, needle):
    return any(needle in s for s in _shown(doc))


def test_the_first_screen_builds_only_what_it_shows():
    """Issue 14 (capacity): a page costs the event loop every session shares,
    so what the first screen hides (the Units and Downloads tabs, the
    introduction's text, the point mass's controls, the animation's and
    memory diagram's texts) is built when first shown, and then works."""
    from panel.io.state import set_curdoc
    ex, doc = _page_document()
    hidden = {"units": "vt-substrate", "downloads": "vt-data-run-csv",
              "introduction": "surface acoustic", "point mass": "stick rule",
              "animation": "The particle on the wave", "memory": "Memory diagram and contact"}
    early = [k for k, needle in hidden.items() if _has(doc, needle)]
    assert not early, f"built with the page: {early}"
    # nor made in Python (hidden tabs have no models anyway: their widgets)
    assert not ex.exports.buttons and not ex.units_box.objects and not ex.intro.objects
    assert _has(doc, "vt-field-log_amplitude") and _has(doc, "vt-run")    # the first screen is
    with set_curdoc(doc):
        ex.map_tabs.active = E.UNITS_TAB
        assert _has(doc, "vt-substrate") and _has(doc, "vt-field-frequency")
        ex.state.frequency = 250e3                # the device moves the map's marker
        assert ex.map_view.device.data["y"] and ex.units_panel.marker is not None
        ex.run_tabs.active = runtabs.DOWNLOADS_TAB
        assert _has(doc, "vt-data-run-csv") and _has(doc, "vt-export-map-png")
        run_csv = next(b for b in ex.exports.buttons if b.filename == "vibtrans-run.csv")
        assert run_csv.disabled                   # no run yet
        ex.intro.collapsed = False
        assert _has(doc, "surface acoustic")
        ex.state.model = "point-mass"
        assert _has(doc, "stick rule") and ex.point_mass_controls.visible
        ex.state.model = "deformable"
        assert not ex.point_mass_controls.visible
        ex.run_tabs.active = runtabs.ANIMATION_TAB
        assert _has(doc, "The particle on the wave")
