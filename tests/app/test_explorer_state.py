"""One scene, one truth: a model-based test of the explorer's page
state, without a server or a browser.

A hypothesis state machine drives one session's Explorer (its controller,
state, widgets and views) through random sequences of what a user does:
clicks on the map, paper points, typed values (valid and invalid) in the
scene's and the device's fields (the particle's tip on the Design tab
too), selector changes, Design presets, Run,
the device's Run (Units and Design tabs), Cancel, and reloading the page's
own link.  After each step the invariants hold:

* the map's marker, the typed fields, the mu and paper-point selectors,
  the particle's profile selector and its tip's drawing, and the URL show
  the state's values (a field with an invalid text says so, and the state
  records it); the map says so when it is not the selected particle's;
* Run runs exactly the state's scene (the kernel receives it), or refuses
  with the field's message; the device's Run runs the device as the form
  shows it (never the chart drawn or a last valid value);
* the run shown records the state it ran; its heading gives the scene run;
  once an input changed it is marked "changed since this run" at once;
* the page's link reproduces the state (a reload gives the same values).

No error may be logged meanwhile (`no_logged_errors`: a failed callback,
Bokeh's `_pending_writes`, a failed run).  The runs are stand-ins: each
returns a short real run of the same model (the views draw real data), and
records the scene it was asked for.
"""

import asyncio
import concurrent.futures
import logging
import math

import numpy as np
import panel as pn
import pytest
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule
from standin import StandIn
from tornado.httputil import parse_qs_bytes

from vibtrans.core.params import PAPER_POINTS
from vibtrans.products.designtip import TIP_SIZES
from vibtrans_explorer import explorer as E
from vibtrans_explorer.server import data
from vibtrans_explorer.session import urlstate
from vibtrans_explorer.session.state import DEVICE_FIELDS, URL_ALIASES, URL_KEYS, is_sphere
from vibtrans_explorer.views import design as D
from vibtrans_explorer.views import inputs
from vibtrans_explorer.views import profile as P
from vibtrans_explorer.views.browserside import BrowserAddress
from vibtrans_explorer.views.summary import CANCELLED_LINE, STALE_LINE, profile_words

pytestmark = pytest.mark.slow  # explorer sessions (maps drawn), ~1 min

EXAMPLES = 12  # sequences per run (CI: two cores)
STEPS = 25  # steps per sequence


def _open(monkeypatch, query=""):
    """An Explorer as a served session opening `query` would build it."""
    monkeypatch.setattr(E, "_page_location", BrowserAddress)
    args = parse_qs_bytes(query.lstrip("?"), keep_blank_values=True)
    monkeypatch.setattr(type(pn.state), "session_args", property(lambda self: args))
    stand_in = StandIn()
    ex = E.Explorer(simulate=stand_in)
    ex.stand_in = stand_in
    ex.pending = []
    ex.controller.schedule = ex.pending.append  # finished by the `finish` rule
    # every job started (a click, a paper point, Run): `settled` waits for
    # their simulate calls, which the runner's threads make in their own time
    ex.jobs = []
    start = ex.controller.start

    def recorded(*args, **kwargs):
        job = start(*args, **kwargs)
        if job is not None:
            ex.jobs.append(job)
        return job

    ex.controller.start = recorded
    ex.main()
    ex.units_panel.__panel__()  # the device's form
    return ex


@pytest.fixture
def no_logged_errors(caplog):
    """Fail the test on any error logged meanwhile (a callback's exception,
    Bokeh's `_pending_writes`, a failed run or drawing)."""
    caplog.set_level(logging.WARNING)
    yield
    bad = [r for r in caplog.records if r.levelno >= logging.ERROR or "_pending_writes" in r.getMessage()]
    assert not bad, [f"{r.name}: {r.getMessage()}" for r in bad]


NUMBER_TEXT = st.one_of(
    st.floats(-7, 7, allow_nan=False).map(lambda v: f"{v:.3f}"),
    st.sampled_from(["", "abc", "nan", "1e999", "2,5", " 0.5 ", "-9", "0.25", "1.5", "-0.3"]),
)
# the profile selector's kinds and the numbers typed for them (valid and not)
PROFILE_KIND = st.sampled_from(list(P.KINDS))
PROFILE_NUMBER = st.sampled_from(["3", "1", "2", "1.5", "0.5", "0", "-1", "abc", "", "nan", "0.25", "4"])
DEVICE_TEXT = {
    "radius": st.sampled_from(["5e-6", "0.0005", "1e-3", "-1", "0", "abc", "2e-4"]),
    "frequency": st.sampled_from(["2e7", "108000", "1e5", "-5", "x", "5e4"]),
    "amplitude": st.sampled_from(["1e-9", "1e-8", "2.6e-7", "0", "-1e-9", "1e-10"]),
    "preload": st.sampled_from(["0", "1e-3", "-1", "0.01"]),
}
# the particle's tip (the Design tab's): sizes typed, valid and not
TIP_TEXT = {
    "tip_half_angle": st.sampled_from(["60", "30", "85", "90", "0", "-5", "abc"]),
    "tip_exponent": st.sampled_from(["3", "1.5", "2", "1", "0.5", "x"]),
    "tip_radius": st.sampled_from(["", "1e-4", "5e-3", "0", "-1e-4"]),
    "tip_flat_radius": st.sampled_from(["1e-6", "0", "5e-7", "-1e-6", "y"]),
}


class ExplorerMachine(RuleBasedStateMachine):
    monkeypatch = None  # set by the test

    def __init__(self):
        super().__init__()
        self.ex = _open(self.monkeypatch)
        self.last_run = None  # (the scene the state had at Run, job or None)
        self.addresses = []  # the page's addresses so far (its browser's history)

    # ------------------------------------------------------------ helpers
    def settled(self):
        """The scenes asked for so far, once every job started has called
        simulate (a run started by an earlier step must not count as this
        step's)."""
        for job in self.ex.jobs:
            concurrent.futures.wait(job.futures, timeout=120)
        return len(self.ex.stand_in.scenes)

    def field(self, name):
        for f in [*self.ex.scene_controls.fields, *self.ex.units_panel.form]:
            if isinstance(f, inputs.NumberField) and f.name_ == name:
                return f
        raise KeyError(name)

    def _run(self, start):
        """Run (by `start`) and check what it did: the state's scene, or a
        refusal naming the invalid field."""
        ex = self.ex
        before = self.settled()
        job = start()
        if job is None:
            assert ex.message.visible and ex.message.object, "a refused run says why"
            assert len(ex.stand_in.scenes) == before  # nothing ran
            errors = ex.state.errors(ex.state.invalid)
            if errors:
                assert any(e in ex.message.object for e in errors)
        else:
            # exactly what the forms show: the state's scene
            assert job.scene.values() == ex.state.scene().values()
            concurrent.futures.wait(job.futures, timeout=120)
            assert any(sc is job.scene for sc in ex.stand_in.scenes[before:])
            assert not ex.state.errors(("log_amplitude", "log_mass", "alpha_t", "profile"))
        return job

    # ------------------------------------------------------------ rules
    @rule(la=st.floats(-1.0, 3.0), lm=st.floats(-3.0, 3.0))
    def click_map(self, la, lm):
        self.ex._on_map_click(round(la, 3), round(lm, 3), False)

    @rule(k=st.sampled_from(sorted(PAPER_POINTS)))
    def paper_point(self, k):
        self.ex.scene_controls.point_select.value = k

    @rule(name=st.sampled_from(["log_amplitude", "log_mass"]), text=NUMBER_TEXT)
    def type_scene(self, name, text):
        self.field(name).input.value = text

    @rule(name=st.sampled_from(sorted(DEVICE_TEXT)), data=st.data())
    def type_device(self, name, data):
        self.field(name).input.value = data.draw(DEVICE_TEXT[name])

    @rule(which=st.sampled_from(["substrate", "particle"]), data=st.data())
    def material(self, which, data):
        setattr(self.ex.state, which, data.draw(st.sampled_from(self.ex.state.param[which].objects[:-1])))

    @rule(data=st.data())
    def mu(self, data):
        mu_select = self.ex.scene_controls.mu_select
        mu_select.value = data.draw(st.sampled_from(list(mu_select.options)))

    @rule(name=st.sampled_from(["model", "fidelity", "compare", "integrator"]), data=st.data())
    def selector(self, name, data):
        setattr(self.ex.state, name, data.draw(st.sampled_from(self.ex.state.param[name].objects)))

    @rule(kind=PROFILE_KIND, number=PROFILE_NUMBER)
    def profile(self, kind, number):
        """The particle's profile chosen in its selector (and its number typed)."""
        view = self.ex.profile_view
        view.kind.value = kind
        if view.number.visible:
            view.number.value = number

    @rule(spec=st.sampled_from(["sphere", "cone", "power:3", "flat-sphere:0.5"]))
    def profile_elsewhere(self, spec):
        """The profile set from elsewhere (a map on demand's click): the
        selector follows."""
        self.ex.state.profile = spec

    @rule(kind=st.sampled_from(list(TIP_SIZES)))
    def tip_kind(self, kind):
        """The particle's tip chosen on the Design tab."""
        self.ex.map_tabs.active = E.DESIGN_TAB
        self.ex.design_panel.tip_kind.value = kind

    @rule(name=st.sampled_from(sorted(TIP_TEXT)), data=st.data())
    def type_tip(self, name, data):
        """A tip's size typed on the Design tab (shown or not)."""
        self.ex.map_tabs.active = E.DESIGN_TAB
        self.ex.design_panel.tip_fields[name].input.value = data.draw(TIP_TEXT[name])

    @rule(preset=st.sampled_from(D.PRESET_NAMES))
    def design_preset(self, preset):
        self.ex.map_tabs.active = E.DESIGN_TAB
        self.ex.design_panel.preset = preset

    @rule()
    def run(self):
        self._run(self.ex.start_run)

    @rule()
    def run_device(self):
        ex = self.ex
        before = self.settled()
        job = ex._run_device()
        if job is not None:
            la, lm, theta, nu = ex.state.device_scene_values()
            assert (job.scene.theta, job.scene.nu) == (theta, nu)
            assert math.isclose(math.log10(job.scene.amplitude), la, abs_tol=1e-12)
            assert math.isclose(math.log10(job.scene.mass), lm, abs_tol=1e-12)
            # the tip's normalized profile runs (the sphere's device: the sphere)
            assert job.scene.profile == ex.state.device_tip()[3] == ex.state.profile
            assert not ex.state.device_errors()
        elif ex.state.device_errors():
            assert len(ex.stand_in.scenes) == before
            assert any(e in ex.message.object for e in ex.state.device_errors())

    @rule()
    def run_design_device(self):
        ex = self.ex
        ex.map_tabs.active = E.DESIGN_TAB
        panel = ex.design_panel
        job = None

        def on_run(mu, periods):
            nonlocal job
            job = ex._run_design_device(mu, periods)

        panel.on_run = on_run
        panel.run_device()
        if job is not None:  # the form's device, not the chart drawn or a preset's
            la, lm, theta, nu = ex.state.device_scene_values()
            assert math.isclose(math.log10(job.scene.amplitude), la, abs_tol=1e-12)
            assert job.scene.profile == ex.state.device_tip()[3]
            assert job.scene.model == "deformable" and job.scene.mu == panel.mu

    @rule()
    def finish(self):
        """The runs scheduled finish (as the server's loop would)."""
        pending, self.ex.pending[:] = list(self.ex.pending), []
        for start in pending:
            asyncio.run(start())

    @rule()
    def cancel(self):
        self.ex.run_buttons.cancel_button.clicks += 1

    @precondition(lambda self: self.addresses)
    @rule(data=st.data())
    def back_or_forward(self, data):
        """The browser's Back or Forward reaches an earlier address of the
        page (its report of the address): the state is that link's, and its
        scene runs; the address stays as it is."""
        ex = self.ex
        address = data.draw(st.sampled_from(self.addresses))
        before, jobs = ex.location.search, len(ex.jobs)
        ex.location.search = address
        assert ex.location.search == address
        values, errors = urlstate.parse(parse_qs_bytes(address.lstrip("?")), ex.state, URL_KEYS, URL_ALIASES)
        assert not errors and urlstate.resolved(values, ex.state, URL_KEYS) == {
            n: getattr(ex.state, n) for n in URL_KEYS
        }
        if address == before:
            assert len(ex.jobs) == jobs  # the address shown: nothing to do
        elif len(ex.jobs) == jobs:  # refused: the message says why
            assert ex.message.visible and ex.message.object
        else:
            assert len(ex.jobs) == jobs + 1
            assert ex.jobs[-1].scene.values() == ex.state.scene().values()

    @rule()
    def reload(self):
        """Open the page's own link: the same state."""
        old = self.ex
        query = old.url_query()
        new = _open(self.monkeypatch, query)
        for name in URL_KEYS:
            assert getattr(new.state, name) == getattr(old.state, name), name
        assert not new.message.visible, new.message.object
        old.controller.discard()
        self.ex = new

    # ------------------------------------------------------------ invariants
    @invariant()
    def views_show_the_state(self):
        ex, s = self.ex, self.ex.state
        assert ex.map_view.selected.data == {"x": [s.log_amplitude], "y": [s.log_mass]}
        assert ex.scene_controls.mu_select.value == s.mu and s.mu in ex.scene_controls.mu_select.options
        assert ex.scene_controls.point_select.value == ex.scene_controls.paper_point()
        for f in [
            *ex.scene_controls.fields,
            *(f for f in ex.units_panel.form if isinstance(f, inputs.NumberField)),
        ]:
            if f.name_ in s.invalid:
                assert f.error == s.invalid[f.name_] and f.error
            else:
                assert not f.error
                # the text is the value (as typed, or to 6 digits as
                # written by a move: the state keeps it exactly)
                shown, value = urlstate.convert(s.param[f.name_], f.input.value), getattr(s, f.name_)
                assert shown == value or math.isclose(shown, value, rel_tol=5e-6), f.name_
        # the profile selector and its drawing: a view of the state's profile
        view = ex.profile_view
        if "profile" in s.invalid:  # a bad number typed: said, the profile kept
            assert view.error == s.invalid["profile"] and view.note.visible
            assert view.number.visible and P.KINDS[view.kind.value] in P.NUMBERS
        else:
            kind, arg = P.kind_of(s.profile)
            assert P.KINDS[view.kind.value] == kind
            assert view.number.visible == (kind in P.NUMBERS)
            assert not view.error and not view.note.visible
            assert view.value() == s.profile
        assert view.drawing_pane.visible == (not is_sphere(s.profile))
        if view.drawing_pane.visible:
            np.testing.assert_array_equal(view.source.data["z"], P.outline(s.profile, view.source.data["r"]))
            assert s.profile in view.figure.title.text
        assert view.rigid.visible == (s.model == "point-mass")
        # the map shown (the shipped, the sphere's that does not roll) says
        # when it is not the particle's (the material point is rigid), or
        # when no shipped map has the selected mu
        other_particle = s.model != "point-mass" and (not is_sphere(s.profile) or s.rolling != "none")
        no_map = (s.model, s.mu) not in data.available_maps()
        assert ex.ondemand.profile_box.visible == (other_particle or no_map)
        if ex.design_panel is not None:
            # the Design tab's device and tip are the state's (one form, no copy)
            assert ex.design_panel.device is s and ex.design_panel.particle_tip is s
            # the tip's widgets: its kind, the sizes of that kind shown, each
            # field's text its value or its message (the state records it)
            panel = ex.design_panel
            assert panel.tip_kind.value == s.tip
            for name, box in zip(D.TIP_LABELS, panel.tip_boxes):
                assert box.visible == (name in TIP_SIZES[s.tip]), name
                f = panel.tip_fields[name]
                if name in s.invalid:
                    assert f.error == s.invalid[name] and f.error
                else:
                    assert not f.error
                    assert urlstate.convert(s.param[name], f.input.value) == getattr(s, name)

    @invariant()
    def the_link_is_the_state(self):
        """(and records the address, an entry of the browser's history)"""
        ex = self.ex
        assert ex.location.search == ex.url_query()
        if ex.location.search not in self.addresses:
            self.addresses.append(ex.location.search)
        values, errors = urlstate.parse(
            parse_qs_bytes(ex.location.search.lstrip("?")), ex.state, URL_KEYS, URL_ALIASES
        )
        assert not errors
        # (a None, the tip radius that is the particle's, is left out: the default)
        assert set(URL_KEYS) - set(values) <= {n for n in URL_KEYS if getattr(ex.state, n) is None}
        assert urlstate.resolved(values, ex.state, URL_KEYS) == {n: getattr(ex.state, n) for n in URL_KEYS}

    @invariant()
    def the_run_shown_is_what_ran_and_stale_at_once(self):
        ex = self.ex
        result = ex.controller.result
        if result is None:
            return
        ran = result.ran
        scene = result.scene
        # the heading: the scene run
        assert f"A\\* = {scene.amplitude:.4g}, m\\* = {scene.mass:.4g}" in ex.summary_view._table
        assert scene.amplitude == 10 ** ran["log_amplitude"]
        assert (scene.model, scene.mu) == (ran["model"], ran["mu"])
        # the particle's profile run, and named where it is not the sphere
        assert scene.profile == ran["profile"]
        words = profile_words(scene)
        assert (words == "") == (scene.profile == "sphere")
        assert words in ex.summary_view._table
        changed = [k for k in E.SCENE_STATE if getattr(ex.state, k) != ran[k]]
        if changed:
            assert ex.stale_shown()
            # said over the table; under the cancel's note when a later run
            # was cancelled (a run on a busy machine was cancelled in time)
            assert ex.summary_view.pane.object.startswith((STALE_LINE, f"{CANCELLED_LINE}\n\n{STALE_LINE}"))
        elif not ex.state.invalid and not (
            ex.summary_view.device_run and any(getattr(ex.state, k) != ran[k] for k in DEVICE_FIELDS)
        ):
            assert not ex.stale_shown()


def test_the_page_is_one_state_whatever_the_order(monkeypatch, no_logged_errors):
    ExplorerMachine.monkeypatch = monkeypatch
    from hypothesis.stateful import run_state_machine_as_test

    run_state_machine_as_test(
        ExplorerMachine,
        settings=settings(
            max_examples=EXAMPLES,
            stateful_step_count=STEPS,
            deadline=None,
            # (no shrinking: a failing sequence is printed as found; shrinking
            # one rebuilds a page per try, minutes)
            phases=[Phase.explicit, Phase.reuse, Phase.generate],
            suppress_health_check=list(HealthCheck),
        ),
    )


# ------------------------------------------------------------ cases met on the page
def test_the_design_tabs_run_runs_the_device_the_form_shows(monkeypatch, no_logged_errors):
    # lithium niobate / glass, 2e7 Hz, R = 5e-6 m, 1e-9 m, then
    # "Run this device's scene" must not run the paper preset (A* = 316.2, m* = 1)
    ex = _open(monkeypatch)
    ex.map_tabs.active = E.DESIGN_TAB
    panel = ex.design_panel
    assert panel.run_button.disabled is False
    panel.preset = "paper"
    ex.state.param.update(
        substrate="lithium niobate", particle="glass", frequency=2e7, radius=5e-6, amplitude=1e-9
    )
    assert (panel.device.substrate, panel.device.frequency, panel.device.radius) == (
        "lithium niobate",
        2e7,
        5e-6,
    )
    assert panel.preset == "custom"
    panel.run_device()
    job = ex.controller.job
    la, lm, theta, nu = ex.state.device_scene_values()
    assert job is not None and job.scene.model == "deformable"
    assert math.log10(job.scene.amplitude) == pytest.approx(la, abs=1e-12)
    assert math.log10(job.scene.mass) == pytest.approx(lm, abs=1e-12)
    assert (job.scene.theta, job.scene.nu) == (theta, nu) != (1.2, 0.3)
    # the Units tab shows the same device (one form)
    assert f"{10**la:.4g}" in ex.units_panel.info.object


def test_an_invalid_device_field_refuses_the_run_with_its_message(monkeypatch, no_logged_errors):
    # with radius "-1" flagged invalid, Run must not run the last valid device
    ex = _open(monkeypatch)
    field = next(f for f in ex.units_panel.form if isinstance(f, inputs.NumberField) and f.name_ == "radius")
    field.input.value = "-1"
    assert "radius" in ex.state.invalid
    before = len(ex.stand_in.scenes)
    assert ex._run_device() is None
    assert ex.message.object.startswith("Not run: particle radius (m) must be a number in")
    assert ex.controller.job is None and len(ex.stand_in.scenes) == before
    # the Design tab's Run refuses it too
    ex.map_tabs.active = E.DESIGN_TAB
    ex.message.object = ""
    ex.design_panel.run_device()
    assert ex.message.object.startswith("Not run: particle radius (m)")


def test_a_device_run_is_stale_once_the_device_changes_and_its_link_holds_it(monkeypatch, no_logged_errors):
    # amplitude 1 -> 10 nm without a run: the summary must not give the
    # old device's m/s; a device run's link must not reopen with nu = 0.3, no device
    ex = _open(monkeypatch)
    ex.state.param.update(
        substrate="lithium niobate",
        particle="glass",
        frequency=1e7,
        radius=1e-5,
        amplitude=1e-9,
        fidelity="preview",
        compare="none",
    )
    ex._run_device()
    asyncio.run(ex.pending.pop()())
    assert ex.summary_view.device_run and not ex.stale_shown()
    heading = ex.summary_view.pane.object.splitlines()[0]
    n = ex.state.device()
    # the heading's A*, m* are the Units table's (unrounded logs)
    assert f"A\\* = {n.A_star:.4g}, m\\* = {n.m_star:.4g}" in heading
    assert f"| A* | {n.A_star:.4g}" in ex.units_panel.info.object
    ex.state.amplitude = 1e-8
    assert ex.stale_shown() and "Changed since this run" in ex.summary_view.pane.object
    ex.state.amplitude = 1e-9
    assert not ex.stale_shown()
    again = _open(monkeypatch, ex.url_query())
    for k in (*DEVICE_FIELDS, "theta", "nu", "log_amplitude", "log_mass"):
        assert getattr(again.state, k) == getattr(ex.state, k), k
    assert again.runs_on_load


def test_a_mu_without_a_shipped_map_is_shown_as_it_is(monkeypatch, no_logged_errors):
    # ?la=2.5&lm=0&mu=0.5: the banner, the selector and the run all take 0.5
    # (the banner must not say 0.3, nor the selector 0.1)
    ex = _open(monkeypatch, "?la=2.5&lm=0&mu=0.5")
    mu_select = ex.scene_controls.mu_select
    assert ex.state.mu == 0.5 and mu_select.value == 0.5 and 0.5 in mu_select.options
    assert not ex.message.visible
    # the page says no shipped map has it, and offers its map on demand
    assert ex.ondemand.profile_box.visible
    assert "No shipped map has mu = 0.5" in ex.ondemand.profile_note.object
    assert ex.ondemand.profile_button.label == "Map on demand for mu 0.5"
    job = ex.start_run()
    assert job.scene.mu == 0.5
    ex.scene_controls.mu_select.value = 0.1
    assert ex.state.mu == 0.1


def test_an_invalid_link_runs_nothing_and_claims_no_defaults(monkeypatch, no_logged_errors):
    ex = _open(monkeypatch, "?la=abc&lm=1")
    assert not ex.runs_on_load
    assert ex.message.object.startswith("This link has errors, so nothing was run:")
    assert "default" not in ex.message.object


def test_a_link_with_an_error_stays_in_the_address_until_a_change(monkeypatch, no_logged_errors):
    """Opened, or reached by the browser's Back, a link with an error stays
    in the address (the browser's) while its message shows: nothing is
    written until the state changes, then the state's address."""
    ex = _open(monkeypatch, "?la=abc&lm=1")
    assert ex.location.search == ""  # nothing written: the link as given
    ex.state.mu = 0.1
    assert ex.location.search == ex.url_query() and "la=-0.3" in ex.location.search
    jobs = len(ex.jobs)
    ex.location.search = "?la=abc&lm=1"  # the browser's Back to it
    assert ex.message.object.startswith("This link has errors, so nothing was run:")
    assert "URL parameter 'la' (log_amplitude)" in ex.message.object
    assert ex.location.search == "?la=abc&lm=1" and len(ex.jobs) == jobs
    assert (ex.state.mu, ex.state.log_mass) == (0.3, 1.0)
    ex.state.log_mass = 0.5
    assert ex.location.search == ex.url_query()


def test_a_link_on_a_paper_point_shows_it_in_the_list(monkeypatch, no_logged_errors):
    la, lm, model = PAPER_POINTS[4]
    ex = _open(monkeypatch, f"?la={la}&lm={lm}&model={model}")
    assert ex.scene_controls.point_select.value == 4
    ex._on_map_click(*PAPER_POINTS[6][:2], False)
    assert ex.scene_controls.point_select.value == 6
    ex._on_map_click(0.123, 0.456, False)
    assert ex.scene_controls.point_select.value == 0


def test_the_units_tab_warns_as_the_design_tab_does(monkeypatch, no_logged_errors):
    # one device form; the Units tab gives the model's validity
    # warnings (design.validity_warnings) as the Design tab does
    from vibtrans.core import units
    from vibtrans.products import design

    ex = _open(monkeypatch)
    bead = design.validity_warnings(
        units.DeviceSpec(substrate="glass", particle="steel", radius=5e-4, frequency=108e3, amplitude=1e-9)
    )
    assert [w.code for w in bead] == ["adhesion"]  # the default bead: adhesion only
    assert bead[0].message in ex.units_panel.warnings.object
    ex.state.param.update(radius=1e-8, particle="PTFE", amplitude=1e-12)
    expected = design.validity_warnings(
        units.DeviceSpec(substrate="glass", particle="PTFE", radius=1e-8, frequency=108e3, amplitude=1e-12)
    )
    assert len(expected) > 1
    assert all(w.message in ex.units_panel.warnings.object for w in expected)
    # the same list of materials in both tabs
    ex.map_tabs.active = E.DESIGN_TAB
    assert ex.design_panel.device.param.substrate.objects == ex.state.param.substrate.objects


@pytest.mark.parametrize("order", ["cancel, then a change", "a change, then cancel"])
def test_the_summary_says_cancelled_and_changed_in_one_order(order):
    """Over the previous run's table, the cancel's note and then the stale
    mark, whatever the order of the events (the stale mark once came first
    or second by the order, and a change after a cancel dropped its note)."""
    from vibtrans_explorer.views.summary import SummaryView

    view = SummaryView(lambda *a: "")
    view._table = "| table |"  # a run shown
    steps = [view.cancelled, lambda: view.mark_stale(True)]
    for step in steps if order.startswith("cancel") else steps[::-1]:
        step()
    assert view.pane.object == f"{CANCELLED_LINE}\n\n{STALE_LINE}\n\n| table |"
    view.mark_stale(False)  # the state back to the run's
    assert view.pane.object == f"{CANCELLED_LINE}\n\n| table |"


def test_a_fresh_page_names_no_paper_point_and_picking_1_runs_it(monkeypatch, no_logged_errors):
    # a fresh page's scene is point 1's, not run: its selector names no point
    # (had it named 1, picking "1" would change nothing and run nothing)
    from vibtrans_explorer.views.scene import CHOOSE_POINT

    ex = _open(monkeypatch)
    select = ex.scene_controls.point_select
    assert select.value == 0 and select.options[CHOOSE_POINT] == 0
    assert (ex.state.log_amplitude, ex.state.log_mass, ex.state.model) == PAPER_POINTS[1]
    select.value = 1
    assert len(ex.jobs) == 1
    # the job runs point 1 (the state's scene, which is point 1's)
    assert ex.jobs[0].scene.values() == ex.state.scene().values()
    assert (ex.state.log_amplitude, ex.state.log_mass, ex.state.model) == PAPER_POINTS[1]
    assert select.value == 1
    # Run on a fresh page runs point 1: the selector names it then
    ex = _open(monkeypatch)
    ex.start_run()
    assert ex.scene_controls.point_select.value == 1


def test_an_invalid_device_field_withholds_the_units_tabs_values_and_says_so_by_run(
    monkeypatch, no_logged_errors
):
    # with an invalid amplitude the state keeps the last valid device: the
    # Units tab shows none of its values (A* 316.2), and its Run's "Not run"
    # is said beside the button, not only at the top of the page
    ex = _open(monkeypatch)
    panel = ex.units_panel
    assert "| A* | 316.2" in panel.info.object and panel.marker is not None
    field = next(f for f in panel.form if isinstance(f, inputs.NumberField) and f.name_ == "amplitude")
    field.input.value = "-1e-9"
    assert "amplitude" in ex.state.invalid
    assert "| A* |" not in panel.info.object and "316.2" not in panel.info.object
    assert panel.info.object.startswith("**Invalid input:** vertical wave amplitude (m) must be")
    assert panel.marker is None and not panel.warnings.object
    # the tab's Run: refused, and said beside its button
    before = len(ex.stand_in.scenes)
    panel.run()
    assert ex.controller.job is None and len(ex.stand_in.scenes) == before
    assert panel.refusal.visible
    assert panel.refusal.object.startswith("Not run: vertical wave amplitude (m) must be")
    layout = panel.__panel__()
    go = next(o for o in layout.objects if isinstance(o, pn.widgets.Button))
    assert layout.objects.index(panel.refusal) == layout.objects.index(go) + 1
    # corrected: the values again, and the refusal gone
    field.input.value = "2.6e-7"
    assert "| A* |" in panel.info.object and panel.marker is not None
    assert not panel.refusal.visible
