"""A particle that rolls in the explorer (docs/MODEL.md section 11): the
rolling selector and its link, the material point's refusal, the map's note
and its map on demand, the rotation's panel in the figures, the
animation's turning mark, the summary's words, the Design tab's solid and
hollow particles, the fixed contact patch's warning (Units and Design
tabs), and the rolling kernels compiled off the warm-up."""

import asyncio
import math
import threading
from urllib.parse import parse_qs

import numpy as np
import panel as pn
import pytest
from asyncutil import until

from vibtrans import paper_scene, simulate
from vibtrans.analysis import dynamics
from vibtrans.core.errors import InputError
from vibtrans.products import design, plots
from vibtrans_explorer.server import warmup
from vibtrans_explorer.session import maprequest, urlstate
from vibtrans_explorer.session.controller import RunResult, comparison, interpret
from vibtrans_explorer.session.maprequest import MapRequest
from vibtrans_explorer.session.state import URL_KEYS, ExplorerState
from vibtrans_explorer.views import design as D
from vibtrans_explorer.views.animation import ParticleAnimation, mark_angle
from vibtrans_explorer.views.live import LiveTrajectory
from vibtrans_explorer.views.profile import ROLLINGS, RollingView
from vibtrans_explorer.views.summary import rolls_words, summary_table
from vibtrans_explorer.views.units import UnitsPanel

T_OBS = 40.0
WINDOW = (T_OBS - 2.0, T_OBS)
LABEL = {v: k for k, v in ROLLINGS.items()}


def _run(point, rolling, **changes):
    scene = paper_scene(point).replace(fidelity="preview", periods=T_OBS, rolling=rolling, **changes)
    return scene, simulate(scene, window=WINDOW, samples_per_period=5)


@pytest.fixture(scope="module")
def rolling_run():
    """Paper point 4 (synchronous hopping) with a solid sphere that rolls."""
    return _run(4, "solid")


@pytest.fixture(scope="module")
def plain_run():
    return _run(4, "none")


def _explorer(monkeypatch, query):
    """An explorer opened on a link (its Location and the session's args)."""
    from panel.io.location import Location

    from vibtrans_explorer import explorer as E

    monkeypatch.setattr(E, "_page_location", lambda: Location(search="?" + query))
    args = {k: [v.encode() for v in vs] for k, vs in parse_qs(query).items()}
    monkeypatch.setattr(type(pn.state), "session_args", property(lambda self: args))
    return E.Explorer()


# ---------------------------------------------------------------- state and link
@pytest.mark.parametrize(
    "label, value", [(LABEL["solid"], "solid"), (LABEL["shell"], "shell"), (LABEL["none"], "none")]
)
def test_the_selector_sets_the_state_and_the_link_reproduces_it(label, value):
    state = ExplorerState()
    view = RollingView(state)
    view.kind.value = label
    assert state.rolling == value and state.scene().rolling == value
    query = urlstate.query(state, URL_KEYS)
    assert f"rolling={value}" in query
    values, errors = urlstate.parse(parse_qs(query[1:]), ExplorerState, URL_KEYS)
    assert not errors and values["rolling"] == value


def test_a_typed_j_is_checked_and_its_link_is_exact():
    state = ExplorerState()
    view = RollingView(state)
    view.kind.value = LABEL["j"]
    assert view.number.visible and state.rolling == 0.5  # the field's starting j
    view.number.value = "0.3"
    assert state.rolling == 0.3 and not view.error
    values, _ = urlstate.parse({"rolling": "0.3"}, ExplorerState, URL_KEYS)
    assert values["rolling"] == 0.3 and "rolling=0.3" in urlstate.query(state, URL_KEYS)
    # out of range: said under the field (the parameter and its range), the
    # state keeps its value and records the error: a run refuses meanwhile
    view.number.value = "1.5"
    assert state.rolling == 0.3
    said = view.error.replace("\\", "")  # (escaped for Markdown)
    assert "rolling must be none, solid" in said and "(0, 1]" in said and "1.5" in said
    assert view.note.visible and "rolling" in state.invalid
    view.number.value = "0.25"
    assert state.rolling == 0.25 and not state.invalid
    # the state moved from elsewhere (a link, a map on demand): the widgets follow
    state.rolling = "shell"
    assert view.kind.value == LABEL["shell"] and not view.number.visible


def test_the_material_point_does_not_roll_and_says_why():
    state = ExplorerState()
    view = RollingView(state)
    view.kind.value = LABEL["solid"]
    state.model = "point-mass"
    assert state.rolling == "none" and state.scene().model == "point-mass"
    assert view.kind.disabled and view.point.visible
    assert "has no size" in view.point.object
    state.model = "deformable"  # the deformable particle's choice again
    assert state.rolling == "solid" and not view.kind.disabled and not view.point.visible


def test_a_link_rolling_a_material_point_is_refused_with_its_range(monkeypatch):
    e = _explorer(monkeypatch, "model=point-mass&rolling=solid&la=0.1&lm=0.5")
    text = e.message.object
    assert e.message.visible and text.startswith("This link has errors, so nothing was run")
    assert "URL parameter 'rolling' (rolling): rolling must be none with model point-mass" in text
    assert "none, solid, shell, or a number j in (0, 1]" in text and "got 'solid'" in text
    assert "Traceback" not in text
    assert not e.runs_on_load and e.state.rolling == "none"
    # with the deformable particle the same link's rolling is taken
    ok = _explorer(monkeypatch, "rolling=solid&la=0.1&lm=0.5")
    assert not ok.message.visible and ok.state.rolling == "solid" and ok.runs_on_load
    assert ok.rolling_view.kind.value == LABEL["solid"]
    assert "rolling=solid" in ok.location.search


def test_a_map_request_that_rolls_names_it_and_refuses_the_point_mass():
    request = MapRequest(model="deformable", rolling="shell", fidelity="preview")
    assert request.rolls() and "rolling shell" in request.title()
    back, errors = maprequest.decode(maprequest.encode(request))
    assert not errors and back.rolling == "shell"
    point = MapRequest(model="point-mass", rolling="solid")
    assert any("rolling must be none with model point-mass" in p for p in point.problems())
    point.model = "deformable"
    point.model = "point-mass"  # a request switched to the point mass drops it
    assert point.rolling == "none" and not point.problems()


# ---------------------------------------------------------------- the map
def test_the_map_says_it_is_of_a_particle_that_does_not_roll(monkeypatch):
    e = _explorer(monkeypatch, "rolling=solid&la=0.1&lm=0.5")
    o = e.ondemand
    assert o.profile_box.visible
    assert "This map is of a particle that does not roll" in o.profile_note.object
    assert "not of the selected solid sphere that rolls (j = 2/5)" in o.profile_note.object
    assert "the shipped maps are" in o.profile_note.object
    assert o.profile_button.label == "Map on demand for rolling solid"
    o.request_for_profile()
    panel = o.map_request_panel
    assert panel.request.rolling == "solid" and panel.rolling.kind.value == LABEL["solid"]
    # the material point has no size: any map of it is its own
    e.state.model = "point-mass"
    assert not o.profile_box.visible
    e.state.model = "deformable"
    assert o.profile_box.visible
    # a cone that rolls: both said, one button
    e.state.profile = "cone"
    assert "sphere's" in o.profile_note.object and "does not roll" in o.profile_note.object
    assert o.profile_button.label == "Map on demand for cone, rolling solid"
    e.state.param.update(profile="sphere", rolling="none")
    assert not o.profile_box.visible
    # a click on a map on demand runs its own particle: rolling or not
    runs = []
    monkeypatch.setattr(o, "run", lambda: runs.append(e.state.scene().rolling))
    tiny = dict(
        fidelity="preview", periods=30.0, la_from=-0.5, la_to=0.5, lm_from=0.0, lm_to=1.0, cells=2, levels=1
    )
    o._on_computed_click(MapRequest(**tiny, rolling="shell"), 0.0, 0.5)
    o._on_computed_click(MapRequest(**tiny), 0.0, 0.5)
    assert runs == ["shell", "none"]


def test_a_click_on_the_shipped_map_runs_the_particle_rolling(monkeypatch):
    e = _explorer(monkeypatch, "rolling=shell")
    runs = []
    monkeypatch.setattr(e, "start_run", lambda *a, **k: runs.append(e.state.scene()))
    e._on_map_click(0.25, 0.8, False)
    assert runs[0].rolling == "shell" and runs[0].amplitude == 10**0.25


def test_the_point_mass_comparison_of_a_rolling_run_does_not_roll():
    scene = paper_scene(4).replace(rolling="solid")
    other, label = comparison(scene, "point mass")
    assert label == "point mass" and other.model == "point-mass" and other.rolling == "none"
    twin, _ = comparison(scene, "tau twin")
    assert twin.rolling == "solid"


# ---------------------------------------------------------------- figures
def test_the_figures_show_the_rotation_of_a_run_that_rolls(rolling_run, plain_run):
    _, ds = rolling_run
    fig = plots.trajectory_figure(ds)
    for column in fig.columns:
        rows = [{t.var for t in p.traces} for p in column]
        assert {"roll_velocity", "slip_velocity"} in rows
        panel = next(p for p in column if {t.var for t in p.traces} == {"roll_velocity", "slip_velocity"})
        assert panel.title.startswith("rotation: omega R*(t), contact slip")
        assert panel.axis_labels[0].startswith("omega R*, slip")
    # omega R* = x*'/j (the library's column, drawn as it is)
    np.testing.assert_allclose(ds["roll_velocity"].values, ds["vx"].values / 0.4, rtol=1e-12)
    _, plain = plain_run
    assert not plots.rolls(plain)
    for column in plots.trajectory_figure(plain).columns:
        assert all("roll_velocity" not in {t.var for t in p.traces} for p in column)
    # the point mass has none (its panels are the rigid ones)
    assert plots.ROLLING_PANEL not in plots.panel_spec(True, rolling=False)


def test_the_live_figures_show_the_rotation_only_for_a_run_that_rolls(rolling_run, plain_run):
    _, ds = rolling_run
    view = LiveTrajectory(None, 2.0, 50.0)
    view.show(plain_run[1])
    assert view.over.rolling_figure is None  # built at the first run that rolls
    view.show(ds)
    for block in (view.over, view.last):
        fig = block.rolling_figure
        assert fig.visible and fig in block.layout.children
        assert fig.title.text.startswith("rotation: omega R*(t)")
        data = block.rolling_source.data
        assert {"roll_velocity", "slip_velocity"} <= set(data)
        assert np.isfinite(data["roll_velocity"]).all() and len(data["time"]) > 0
    assert {"roll_velocity_lo", "slip_velocity_hi"} <= set(view.over.rolling_source.data)
    lo, hi = ds["roll_velocity"].values.min(), ds["roll_velocity"].values.max()
    r = view.last.rolling_figure.y_range
    assert r.start <= lo and r.end >= hi
    view.show(plain_run[1])
    assert not view.over.rolling_figure.visible and not view.last.rolling_figure.visible


# ---------------------------------------------------------------- the animation
def test_the_animation_turns_a_mark_by_the_rolled_arc(rolling_run, plain_run):
    scene, ds = rolling_run
    anim = ParticleAnimation()
    anim.show(scene, ds)
    rho = anim.meta.data["rho"][0]
    rolls = anim.frames.data["roll"]
    n = len(rolls)
    angles = []
    for i in (0, n // 3, 2 * n // 3, n - 1):
        m = anim.frame(i)["mark"]
        dx, dy = m["x1"][0] - m["x0"][0], m["y1"][0] - m["y0"][0]
        assert math.hypot(dx, dy) == pytest.approx(rho, rel=1e-9)  # a radius
        angle = math.atan2(dy, dx)
        want = mark_angle(rolls[i], rho)
        assert math.remainder(angle - want, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        # about the drawn circle's centre
        p = anim.frame(i)["particle"]
        assert (m["x0"][0], m["y0"][0]) == pytest.approx((p["x"][0], p["y"][0]))
        angles.append(angle)
    assert len({round(a, 6) for a in angles}) > 1  # it turns between frames
    # theta = roll / rho: the rim travels the rolled arc; counter-clockwise
    # for a positive arc (the contact point moves towards +x)
    assert mark_angle(0.0, 2.0) == -math.pi / 2
    assert mark_angle(math.pi, 2.0) == pytest.approx(0.0)
    np.testing.assert_allclose(rolls, ds["roll"].values[-n:], rtol=0, atol=0)
    assert "The particle rolls (solid)" in anim.key.text
    # a particle that does not roll has no mark
    anim.show(*plain_run)
    assert len(anim.frame(0)["mark"]["x0"]) == 0 and anim.meta.data["rolls"] == [0]


# ---------------------------------------------------------------- the summary
def test_the_summary_says_whether_the_particle_rolls(rolling_run, plain_run):
    scene, ds = rolling_run
    result = interpret(scene, ds, None, None)
    s = result.summary
    assert rolls_words(s).startswith("yes: solid sphere, j = 0.4; largest rolled arc within one contact ")
    assert f"{s.max_episode_roll:.3g} a0" in rolls_words(s)
    table = summary_table(scene, s, "-", None, None, None)
    assert "| rolls? | yes: solid sphere, j = 0.4" in table
    assert "rolling (a solid sphere, j = 0.4)**" in table.splitlines()[0]
    plain = interpret(*plain_run, None, None).summary
    assert rolls_words(plain) == "no: it slides without turning (the paper's particle)"
    assert "rolling" not in summary_table(plain_run[0], plain, "-", None, None, None).splitlines()[0]
    assert rolls_words(plain._replace(model="point-mass")) == "no: a material point has no size"


# ---------------------------------------------------------------- the Design tab
class _NoEstimate:
    cores = 1

    def estimate(self, request):
        return None, []


@pytest.mark.parametrize("value", ["solid", "shell"])
def test_the_design_tab_offers_solid_and_hollow_particles_and_their_maps(value):
    state = ExplorerState()
    panel = D.DesignPanel(state=state, jobs=_NoEstimate())
    panel.__panel__()
    label = {v: k for k, v in D.DESIGN_ROLLINGS.items()}[value]
    panel.rolling_view.kind.value = label
    assert state.rolling == value and panel.values()["rolling"] == value
    assert panel.hollow_note.visible == (value == "shell")
    # the shipped maps are of a particle that does not roll: the map it
    # needs is offered (the CLI refuses without --compute)
    asyncio.run(panel.draw())
    assert panel.chart is None
    assert "No shipped map serves this chart" in panel.offer.object
    assert f"this particle rolls ({value})" in panel.offer.object
    assert f"--rolling {value}` needs --compute" in panel.offer.object
    request, values = panel._offer
    assert request.rolling == value and request.model == "deformable"
    assert values["rolling"] == value
    # the chart the library draws for it: on a map of its own only
    with pytest.raises(design.NoMapCovers, match="rolling"):
        D.build_chart(values)


def test_the_design_tabs_device_names_its_body():
    q = design.device_quantities(design.preset("paper").device)
    text = D.device_text(design.preset("paper").device, None, q, [], "shell")
    assert "hollow (thin shell), rolls (j = 2/3)" in text.splitlines()[0]
    assert "rolls" not in D.device_text(design.preset("paper").device, None, q, [])


# ---------------------------------------------------------------- validity
def test_the_rolling_warning_is_at_a_tenth_of_the_contact_radius():
    assert design.ROLL_CONTACT_FRACTION == 0.1
    a0, radius = 1e-9, 2e-6  # contact radius sqrt(R a0): 2000 a0
    at = design.ROLL_CONTACT_FRACTION * radius / a0  # 200 a0
    w = design.rolling_warning(at, a0, radius)
    assert w.code == "rolling-patch" and w.value == pytest.approx(0.1)
    assert w.threshold == 0.1 and "within one contact" in w.message
    assert design.rolling_warning(0.99 * at, a0, radius) is None
    assert design.rolling_warning(None, a0, radius) is None  # it does not roll
    for bad in (-1.0, math.nan, "1"):
        with pytest.raises(InputError, match="max_episode_roll"):
            design.rolling_warning(bad, a0, radius)
    with pytest.raises(InputError, match="contact_radius"):
        design.rolling_warning(1.0, a0, 0.0)


def test_the_units_and_design_tabs_warn_when_a_device_run_rolled_far(rolling_run):
    state = ExplorerState()
    state.rolling = "solid"
    state.select_device(model="deformable")
    units = UnitsPanel(state, on_run=lambda: None)
    scene = state.scene().replace(fidelity="preview", periods=T_OBS)
    s = interpret(*rolling_run, None, None).summary
    a0 = state.device_tip()[2]
    radius = math.sqrt(state.radius * a0)  # the sphere's contact radius
    far = RunResult(scene, None, None, None, None, s._replace(max_episode_roll=0.5 * radius / a0), False)
    note = units.show_run(far)
    assert note.startswith("**Warning (the run):** the particle rolled")
    assert "0.5 of the contact radius" in note and units.run_note.object == note
    near = RunResult(scene, None, None, None, None, s._replace(max_episode_roll=0.01 * radius / a0), False)
    assert "its contact patch stayed put" in units.rolling_note(near)
    # a run that is no device's, or does not roll: nothing to say
    other = far._replace(scene=scene.replace(mass=scene.mass * 2))
    assert units.rolling_note(other) == ""
    assert units.rolling_note(far._replace(summary=s._replace(max_episode_roll=None))) == ""
    panel = D.DesignPanel(state=state, jobs=_NoEstimate())
    panel.show_run_note(note)
    assert panel.run_note.object == note


# ---------------------------------------------------------------- dynamics
def test_the_dynamics_of_a_rolling_run_are_its_vertical_motion():
    scene = paper_scene(4).replace(fidelity="preview", periods=20.0)
    assert dynamics.run_guess(scene.replace(rolling="solid")) == dynamics.run_guess(scene)


# ---------------------------------------------------------------- the kernels
@pytest.fixture
def rolling_compiling(monkeypatch):
    """A served explorer whose warm-up is done, the rolling kernels compiling."""
    monkeypatch.setattr(warmup, "READY", threading.Event())
    warmup.READY.set()
    monkeypatch.setattr(warmup, "_thread", object())
    monkeypatch.setattr(warmup, "ROLLING_READY", threading.Event())
    monkeypatch.setattr(warmup, "_rolling_thread", object())  # (under way)
    return warmup.ROLLING_READY


def test_a_rolling_run_waits_for_its_kernels_saying_compiling(rolling_compiling):
    from vibtrans_explorer import explorer as E

    async def go():
        ex = E.Explorer()
        ex.state.param.update(fidelity="preview", compare="none", periods=20.0, rolling="solid")
        plain = ex.state.scene().replace(rolling="none")
        assert warmup.ready(plain) and warmup.status(plain) is None  # others do not wait
        ex.start_run()
        await until(lambda: "Compiling the kernels of a particle that rolls" in ex.summary_view.pane.object)
        assert not ex.controller.job.futures[0].done()
        rolling_compiling.set()
        await until(
            lambda: (
                ex.controller.job is None and "| rolls? | yes: solid sphere" in ex.summary_view.pane.object
            )
        )

    asyncio.run(go())


def test_the_warm_up_leaves_the_rolling_kernels_to_their_first_need(monkeypatch):
    import vibtrans

    seen = []
    monkeypatch.setattr(vibtrans, "warmup", lambda models=None, progress=None: seen.append(models))
    monkeypatch.setattr(warmup, "READY", threading.Event())
    warmup.compile_all()
    assert seen == [warmup.MODELS] and not warmup.ROLLING_READY.is_set()
    # outside `vibtrans serve` (no warm-up) nothing starts: runs compile what they need
    assert warmup._thread is None
    warmup.prepare_rolling()
    assert warmup._rolling_thread is None
    assert warmup.ready(paper_scene(4).replace(rolling="solid"))
