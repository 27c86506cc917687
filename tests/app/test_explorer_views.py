"""The explorer's views without a server (for a lab and a class):
both models' maps side by side with one zoom, a click on them running both
models; the selected scene marked on the vertical curve; the trajectory's
time axis in seconds for a device's run; presentation mode's large fonts."""

from types import SimpleNamespace

import numpy as np
import pytest

from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import data
from vibtrans_explorer.views import runtabs
from vibtrans_explorer.views.live import time_label

pytestmark = pytest.mark.slow  # explorer sessions (maps rendered)


def _explorer(**state):
    ex = E.Explorer()
    ex.state.param.update(**{"fidelity": "preview", "compare": "none", **state})
    return ex


@pytest.mark.skipif(
    ("point-mass", 0.3) not in data.available_maps(), reason="needs the shipped point-mass map at mu = 0.3"
)
def test_both_maps_share_one_zoom_and_a_click_runs_both_models(monkeypatch):
    ex = _explorer(model="point-mass")
    assert len(ex.map_view.figures) == 1
    ex.state.maps = "both models"
    dm, pm = ex.map_view.figures
    assert "deformable" in dm.title.text and "point-mass" in pm.title.text
    assert pm.x_range is dm.x_range and pm.y_range is dm.y_range  # linked zoom
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
    # the map's axes (the vertical tab's, not swapped)
    assert ex.vertical.scene.data == {"x": [1.25], "y": [-0.5]}
    fig = ex.vertical.pane.objects[-1].object  # (under the profile note)
    assert fig.xaxis[0].axis_label == "log10 A*" and fig.yaxis[0].axis_label == "log10 m*"
    labels = [
        item.label["value"] if isinstance(item.label, dict) else getattr(item.label, "value", item.label)
        for item in fig.legend[0].items
    ]
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
    ex.state.chaotic = "colour"  # a redrawn map keeps the large fonts
    fig = ex.map_view.figures[0]
    assert fig.xaxis[0].axis_label_text_font_size == "15pt"
    ex.runs.tabs.active = runtabs.DYNAMICS_TAB  # a run tab built while large: large too
    view = ex.trajectories.view(None, 50.0)  # and a run's figures built while large
    assert view.part.children[0].title.text_font_size == "15pt"
    assert ex.runs.dynamics_view.section_fig.xaxis[0].axis_label_text_font_size == "15pt"
    ex.presentation = False
    assert fig.xaxis[0].axis_label_text_font_size == "10pt" and ex.page.styles == {}
    assert ex.runs.dynamics_view.section_fig.xaxis[0].axis_label_text_font_size == "10pt"
    assert not ex.presentation_note.visible


def test_the_run_tabs_build_their_views_when_opened():
    """The animation and the memory diagram are built (and the memory
    snapshots computed) only once their tab opens, then follow the runs."""
    import asyncio

    from asyncutil import until

    async def go():
        ex = _explorer(log_amplitude=0.3, log_mass=-2.0)
        assert ex.runs.animation is None and ex.runs.memory_view is None
        ex.start_run()
        await until(lambda: ex.controller.job is None and ex.controller.result is not None)
        assert ex.runs.animation is None and ex.runs.memory_view is None  # nothing opened yet
        ex.runs.tabs.active = runtabs.ANIMATION_TAB
        assert ex.runs.animation is not None and ex.runs.animated is ex.controller.result
        ex.runs.tabs.active = runtabs.MEMORY_TAB
        assert ex.runs.memory_view is not None and ex.runs.memory_view.scene is not None
        ex.runs.memory_view.clear()

    asyncio.run(go())


def test_changing_the_comparison_relabels_the_same_figures():
    """A new set of figures for the first run after changing "compare with"
    would cost 2.8-6 s.  Every comparison shares one set, relabelled:
    the tau twin's panel becomes the point mass's, no new figure."""
    import asyncio

    from asyncutil import until

    async def go():
        ex = _explorer(compare="tau twin", log_amplitude=0.5, log_mass=1.5)
        ex.start_run()
        await until(lambda: ex.controller.job is None and ex.controller.result is not None)
        ((key, view),) = ex.trajectories.views.items()
        assert key == "beside a comparison" and view.over.twin_figure.title.text.endswith("twin")
        first = ex.controller.result
        ex.state.compare = "point mass"
        ex.start_run()
        await until(lambda: ex.controller.job is None and ex.controller.result is not first)
        assert list(ex.trajectories.views) == [key] and view.runs == 2
        assert view.over.twin_figure.title.text == "x*(t) and the point mass run of the same scene"
        assert [i.label.value for i in view.over.twin_items][1] == "x*, point mass"  # a value, not a field

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
    return [
        " ".join(
            [
                type(m).__name__,
                *getattr(m, "css_classes", []),
                str(getattr(m, "text", "") or ""),
                str(getattr(m, "title", "") or ""),
            ]
        )
        for m in doc.models
    ]


def _has(doc, needle):
    return any(needle in s for s in _shown(doc))


def test_the_first_screen_builds_only_what_it_shows():
    """Capacity: a page costs the event loop every session shares,
    so what the first screen hides (the Units and Downloads tabs, the
    introduction's text, the point mass's controls, the animation's and
    memory diagram's texts) is built when first shown, and then works."""
    from panel.io.state import set_curdoc

    ex, doc = _page_document()
    hidden = {
        "units": "vt-substrate",
        "downloads": "vt-data-run-csv",
        "introduction": "surface acoustic",
        "point mass": "stick rule",
        "animation": "The particle on the wave",
        "memory": "Memory diagram and contact",
    }
    early = [k for k, needle in hidden.items() if _has(doc, needle)]
    assert not early, f"built with the page: {early}"
    # nor made in Python (hidden tabs have no models anyway: their widgets)
    assert not ex.exports.buttons and not ex.units_box.objects and not ex.intro.objects
    assert _has(doc, "vt-field-log_amplitude") and _has(doc, "vt-run")  # the first screen is
    with set_curdoc(doc):
        ex.map_tabs.active = E.UNITS_TAB
        assert _has(doc, "vt-substrate") and _has(doc, "vt-field-frequency")
        ex.state.frequency = 250e3  # the device moves the map's marker
        assert ex.map_view.device.data["y"] and ex.units_panel.marker is not None
        ex.runs.tabs.active = runtabs.DOWNLOADS_TAB
        assert _has(doc, "vt-data-run-csv") and _has(doc, "vt-export-map-png")
        run_csv = next(b for b in ex.exports.buttons if b.filename == "vibtrans-run.csv")
        assert run_csv.disabled  # no run yet
        ex.intro.collapsed = False
        assert _has(doc, "surface acoustic")
        ex.state.model = "point-mass"
        assert _has(doc, "stick rule") and ex.scene_controls.point_mass_controls.visible
        ex.state.model = "deformable"
        assert not ex.scene_controls.point_mass_controls.visible
        ex.runs.tabs.active = runtabs.ANIMATION_TAB
        assert _has(doc, "The particle on the wave")


# ------------------------------------------------------------------ the particle's profile
def test_the_profile_selector_is_a_view_of_the_states_profile():
    from vibtrans_explorer.views import profile as P

    ex = _explorer()
    view = ex.profile_view
    assert view.kind.value == "sphere (Hertz)" and not view.number.visible
    assert view.figure is None and not view.drawing_pane.visible  # built at first use
    view.kind.value = "cone"
    assert ex.state.profile == "cone" and ex.state.scene().profile == "cone"
    view.kind.value = "power law z ~ r^N"
    assert view.number.visible and ex.state.profile == "power:3"  # the kind's start
    view.number.value = "1.5"
    assert ex.state.profile == "power:1.5"
    # a bad number: said under the field, the profile kept, a run refused
    view.number.value = "0.5"
    assert ex.state.profile == "power:1.5"
    assert view.note.visible and "exponent n must be a real number in \\[1, inf\\)" in view.error
    assert ex.state.invalid["profile"] == view.error
    assert ex.start_run(schedule=False) is None
    assert ex.message.object.startswith("Not run:") and "exponent n" in ex.message.object
    view.number.value = "4"
    assert ex.state.profile == "power:4" and "profile" not in ex.state.invalid
    # a change from elsewhere (a link, a map on demand's click): the widgets follow
    ex.state.profile = "flat-sphere:1.5"
    assert view.kind.value == "flat-ended sphere" and view.number.value == "1.5"
    assert view.number.label.startswith("flat radius C")
    view.kind.value = "power law z ~ r^N"  # each kind keeps its own number
    assert ex.state.profile == "power:4"
    view.kind.value = "sphere (Hertz)"
    assert ex.state.profile == "sphere" and not view.drawing_pane.visible
    # the material point is rigid: said, and run all the same
    ex.state.param.update(model="point-mass", profile="cone")
    assert view.rigid.visible and "rigid point" in view.rigid.object
    assert ex.start_run(schedule=False) is not None
    assert P.KINDS[view.kind.value] == "cone"


def test_the_tips_drawing_is_the_librarys_outline_beside_the_spheres():
    """Closed forms (MDR, Popov & Hess; at rest under the weight: approach
    d = a0, contact radius a_c = 1): the sphere z = r^2 / (2R) has g(x) =
    x^2 / R, so d = a_c^2 / R and its edge lies at z = d / 2; the cone
    z = C r has g(x) = (pi/2) C |x|, so d = (pi/2) C a_c and z = (2/pi) r
    in these units; a flat-ended sphere is flat out to its flat's radius."""
    ex = _explorer()
    view = ex.profile_view
    ex.state.profile = "cone"
    assert view.drawing_pane.visible
    src = view.source.data
    r = np.asarray(src["r"])
    edge = int(np.argmin(np.abs(r - 1.0)))
    assert r[edge] == pytest.approx(1.0)
    assert src["sphere"][edge] == pytest.approx(0.5, rel=1e-12)
    assert src["z"][edge] == pytest.approx(2.0 / np.pi, rel=1e-12)
    np.testing.assert_allclose(src["z"], 2.0 / np.pi * np.abs(r), rtol=1e-12)  # a cone
    np.testing.assert_allclose(src["sphere"], r * r / 2.0, rtol=1e-12)
    assert "cone" in view.figure.title.text
    dashed = [g for g in view.figure.renderers if list(g.glyph.line_dash)]
    assert len(dashed) == 1 and dashed[0].glyph.y == "sphere"
    ex.state.profile = "flat-sphere:2"
    z = np.asarray(view.source.data["z"])
    from vibtrans.core.profiles import FlatSphereProfile

    flat = FlatSphereProfile(2.0)
    c_over_edge = 2.0 / float(np.sqrt(4.0 + flat._sigma(1.0) ** 2))  # the flat's edge
    assert (z[np.abs(r) < c_over_edge - 1e-9] == 0.0).all()
    assert (z[np.abs(r) > c_over_edge + 1e-9] > 0.0).all()
    assert "flat-sphere:2" in view.figure.title.text
    ex.state.profile = "power:2"  # the sphere's own law: nothing to compare
    assert not view.drawing_pane.visible


def test_the_map_requests_selector_is_a_view_of_its_request():
    from vibtrans_explorer.session.maprequest import MapRequest
    from vibtrans_explorer.views.ondemand import MapRequestPanel

    panel = MapRequestPanel(MapRequest())
    panel.profile.kind.value = "cone"
    assert panel.request.profile == "cone" and panel.errors() == []
    panel.profile.kind.value = "flat-ended sphere"
    assert panel.request.profile == "flat-sphere:0.5"  # the kind's start
    panel.profile.number.value = "-1"
    assert panel.request.profile == "flat-sphere:0.5"  # kept
    assert len(panel.errors()) == 1 and "flat radius" in panel.errors()[0]
    panel.set_values(profile="power:3")
    assert panel.profile.kind.value == "power law z ~ r^N" and panel.errors() == []


def test_the_vertical_tab_says_its_curve_is_the_spheres():
    ex = _explorer()
    ex.vertical.build()
    note = ex.vertical.profile_note
    assert not note.visible
    ex.state.profile = "cone"
    assert note.visible and "curve is the sphere's" in note.object
    assert "vibtrans threshold --profile cone" in note.object
    ex.state.profile = "sphere"
    assert not note.visible


def test_the_explorers_design_adds_the_input_font_to_bootstraps_own_stylesheets():
    """ExplorerDesign (app/views/presentation.py) gives every widget INPUT_FONT
    (text inputs and selects sized in rem, so that presentation mode grows
    them) and WRAPPING_LABELS (a label wraps, not cut) on top of Bootstrap's
    own stylesheets: a modifier without
    `Inherit` replaced them, and the widgets lost Bootstrap's look."""
    import panel as pn
    from bokeh.document import Document

    from vibtrans_explorer.views.presentation import INPUT_FONT, WRAPPING_LABELS, ExplorerDesign

    def stylesheets(design):
        field = pn.widgets.TextInput(label="log10 A*")
        doc = Document()
        pn.template.BootstrapTemplate(sidebar=[field], design=design).server_doc(doc)
        (model,) = [m for m in doc.models if type(m).__name__ == "TextInput"]
        return [getattr(s, "url", None) or getattr(s, "css", None) or s for s in model.stylesheets]

    bootstrap, ours = stylesheets(pn.theme.Bootstrap), stylesheets(ExplorerDesign)
    assert any("bootstrap" in str(s) for s in bootstrap), bootstrap
    assert ours == bootstrap + [INPUT_FONT, WRAPPING_LABELS], (bootstrap, ours)
