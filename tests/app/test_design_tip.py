"""The Design tab takes the particle's tip: the tip in the page's
one state (ExplorerState, a designtip.Tip, mirrored in the link), its widgets
(the kind's sizes only, each checked by designtip as typed), the chart
drawn for that tip (another profile than the sphere: a map of its own,
offered with the reason), the device's table (the tip, its normalized
profile, the edge slope, designtip's warnings), the stale mark, and the
device's run carrying the tip's profile.  The chart's numbers are checked
against `vibtrans design --profile cone --half-angle ... --json` for the
same device, on the same map."""

import asyncio
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from markdowntext import shown_text

from vibtrans.core import units
from vibtrans.maps.sweep import open_map
from vibtrans.products import design, designtip
from vibtrans.products.designtip import TIP_SIZES
from vibtrans_explorer.server import mapjobs
from vibtrans_explorer.session.state import ExplorerState
from vibtrans_explorer.views import design as D

pytestmark = pytest.mark.slow  # panels built, charts read

# the paper preset's device (steel on glass, R = 0.5 mm) with a 60-degree cone
HALF_ANGLE = 60.0


def _panel(tmp_path, state=None, **values):
    """A Design panel given `values`: the panel's, its device's and its tip's."""
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    panel = D.DesignPanel(jobs=jobs, state=state)
    panel.__panel__()
    parts = [panel.device, panel.particle_tip]
    given = [{k: values.pop(k) for k in list(values) if k in part.param} for part in parts]
    panel.param.update(**values)
    for part, part_values in zip(parts, given):
        part.param.update(**part_values)
    return panel


def test_the_tip_is_the_states_and_its_widgets_show_the_kinds_sizes(tmp_path):
    state = ExplorerState()
    panel = _panel(tmp_path, state)
    assert panel.particle_tip is state and panel.device is state  # one state
    assert state.tip == panel.particle_tip.tip == "sphere"
    # the widgets are the state's (one form): a kind chosen is the state's
    panel.tip_kind.value = "cone"
    assert state.tip == "cone" == panel.particle_tip.tip
    for kind, sizes in TIP_SIZES.items():
        state.tip = kind
        assert panel.particle_tip.tip == kind
        shown = {name for name, box in zip(D.TIP_LABELS, panel.tip_boxes) if box.visible}
        assert shown == set(sizes), kind
        assert panel.tip_boxes[-1].visible == (kind != "sphere")  # the tip's note
    # a size typed is the state's, and the panel's (its chart's) too
    state.tip = "power"
    panel.tip_fields["tip_exponent"].input.value = "2.5"
    panel.tip_fields["tip_radius"].input.value = "2e-4"
    assert (state.tip_exponent, state.tip_radius) == (2.5, 2e-4)
    assert (panel.particle_tip.tip_exponent, panel.particle_tip.tip_radius) == (2.5, 2e-4)
    assert D.tip_shape(panel.values()).name == "power:2.5 (tip radius 0.0002 m)"
    # empty: the particle's radius (None), as designtip's default
    panel.tip_fields["tip_radius"].input.value = ""
    assert state.tip_radius is None and D.tip_shape(panel.values()).tip_radius is None
    # a preset is a sphere: it sets the kind (the sizes stay as typed)
    panel.preset = "saw-motor"
    assert state.tip == "sphere" and state.tip_exponent == 2.5
    # a tip chosen afterwards makes the preset "custom"
    state.tip = "cone"
    assert panel.preset == D.CUSTOM_PRESET


@pytest.mark.parametrize(
    "name, text, words",
    [
        ("tip_half_angle", "95", r"half\_angle must be a real number in \(0, 90\) degrees"),
        ("tip_half_angle", "0", r"half\_angle must be a real number in \(0, 90\) degrees"),
        ("tip_exponent", "0.5", r"exponent n must be a real number in \[1, inf\)"),
        ("tip_exponent", "1", r"N = 1 is the cone"),
        ("tip_radius", "-1e-4", r"tip\_radius must be a real number in \(0, inf\) m"),
        ("tip_flat_radius", "-1e-6", r"flat\_radius must be a real number in \[0, inf\) m"),
        ("tip_half_angle", "abc", "got 'abc'"),
    ],
)
def test_a_bad_tip_size_is_refused_with_the_librarys_range_never_clamped(tmp_path, name, text, words):
    state = ExplorerState()
    panel = _panel(tmp_path, state)
    state.tip = next(k for k, sizes in TIP_SIZES.items() if name in sizes)
    before = getattr(state, name)
    field = panel.tip_fields[name]
    field.input.value = text
    assert words in field.error and D.TIP_LABELS[name] in field.error, field.error
    assert field.input.value == text  # the text stays as typed
    assert getattr(state, name) == before  # the value is not changed (nor clamped)
    assert state.invalid[name] == field.error  # the state records it: a run refuses
    assert field.error in state.device_errors()
    with pytest.raises(ValueError, match="Not run|must be"):
        state.select_device()
    asyncio.run(panel.draw())
    assert panel.alert.visible and field.error in panel.alert.object and panel.chart is None
    # a hidden kind's size does not make the device: choosing another kind runs
    state.tip = "sphere" if state.tip != "sphere" else "cone"
    assert name not in TIP_SIZES[state.tip] and not panel.field_errors()
    assert not state.device_errors()


def test_a_bad_tip_in_a_link_is_named_and_nothing_is_applied():
    from vibtrans_explorer.session import urlstate
    from vibtrans_explorer.session.state import URL_KEYS

    values, errors = urlstate.parse(
        {"tip": [b"cone"], "tipa": [b"90"], "tipc": [b"-1"], "tipn": [b"1"], "tipr": [b"0"]},
        ExplorerState,
        URL_KEYS,
    )
    assert values == {"tip": "cone"}
    text = " ".join(errors)
    for key, name, words in (
        ("tipa", "tip_half_angle", r"half\_angle"),
        ("tipc", "tip_flat_radius", r"flat\_radius"),
        ("tipn", "tip_exponent", "N = 1 is the cone"),
        ("tipr", "tip_radius", r"tip\_radius"),
    ):
        assert f"URL parameter '{key}' ({name}) must be" in text and words in text
    # a measured table cannot be a link's tip (a link never names a file)
    values, errors = urlstate.parse({"tip": [b"file:/etc/passwd"]}, ExplorerState, URL_KEYS)
    assert values == {} and "URL parameter 'tip' (tip) must be one of sphere, cone" in errors[0]


def test_a_cone_chart_offers_the_cones_own_map_and_says_why(tmp_path):
    panel = _panel(tmp_path, tip="cone", tip_half_angle=HALF_ANGLE, x_points=5, y_points=5)
    asyncio.run(panel.draw())
    offer = panel.offer.object
    assert panel.chart is None and panel.offer_box.visible and not panel.alert.visible
    assert "No shipped map serves this chart" in offer
    assert "the shipped maps are the sphere's" in offer
    assert "cone (half-angle 60 deg)" in offer and "profile `cone`" in offer
    # the map offered is the cone's (a map on demand keyed by its profile)
    request, values = panel._offer
    assert request.profile == "cone" and values["tip"] == "cone"
    need = design.chart_needs(
        "glass",
        "steel",
        0.0,
        ("frequency", 1e4, 1e6, 5),
        ("amplitude", 1e-9, 5e-7, 5),
        ("radius", panel.device.radius),
        shape=designtip.tip_shape("cone", half_angle=HALF_ANGLE),
    )
    assert D.map_request(need)[0].values() == request.values()
    # the sphere's chart is the shipped map's, as before
    panel.particle_tip.tip = "sphere"
    asyncio.run(panel.draw())
    assert panel.chart is not None and panel.chart.attrs["map"].startswith("shipped")
    assert "profile" in panel.chart.attrs and panel.chart.attrs["map_profile"] == "sphere"
    # a chart whose tip changed since it was drawn is marked stale at once
    assert "Changed since" not in panel.status.object
    panel.particle_tip.tip_half_angle = 30.0  # a size the sphere does not use: no change
    assert "Changed since" not in panel.status.object
    panel.particle_tip.tip = "cone"
    assert panel.status.object.startswith("**Changed since this chart was drawn")
    # and a cone's chart when its half-angle changes
    panel.particle_tip.tip_half_angle = HALF_ANGLE
    asyncio.run(panel.draw())  # (offered its map: the chart shown stays)
    panel._drawn_values = panel.values()  # as if drawn on the cone's map
    panel.particle_tip.tip_half_angle = 45.0
    assert panel.status.object.startswith("**Changed since this chart was drawn")


def _cli_json(tmp_path, device, x, y, periods):
    argv = [
        sys.executable,
        "-m",
        "vibtrans.cli",
        "design",
        "--substrate",
        "glass",
        "--particle",
        "steel",
        "--radius",
        repr(device.radius),
        "--frequency",
        repr(device.frequency),
        "--amplitude",
        repr(device.amplitude),
        "--x",
        f"frequency:{x[1]!r}:{x[2]!r}:{x[3]}",
        "--y",
        f"amplitude:{y[1]!r}:{y[2]!r}:{y[3]}",
        "--profile",
        "cone",
        "--half-angle",
        repr(HALF_ANGLE),
        "--json",
        "--compute",
        "--store",
        str(tmp_path / "store"),
        "--periods",
        repr(periods),
        "--workers",
        "1",
    ]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_the_cone_chart_is_the_command_lines_for_the_same_device(tmp_path):
    """The tab's chart and device table for a cone tip against `vibtrans
    design --profile cone --half-angle 60 --json` (another process, its own
    computed map): the same A*, m*, a0 at every point and at the device,
    and the same drift read on the same map."""
    device = design.preset("paper").device
    f, a = device.frequency, device.amplitude
    x, y = ("frequency", f, f * 1.05, 2), ("amplitude", a, a * 1.05, 2)
    got = _cli_json(tmp_path, device, x, y, periods=40.0)
    assert got["profile"] == "cone (half-angle 60 deg)" and got["map_profile"] == "cone"
    store = got["chart"]["attrs"]["map"].split(": ", 1)[1]
    panel = _panel(
        tmp_path,
        preset="custom",
        substrate="glass",
        particle="steel",
        radius=device.radius,
        frequency=f,
        amplitude=a,
        preload=0.0,
        x="frequency",
        x_lo=x[1],
        x_hi=x[2],
        x_points=2,
        y="amplitude",
        y_lo=y[1],
        y_hi=y[2],
        y_points=2,
        tip="cone",
        tip_half_angle=HALF_ANGLE,
    )
    chart, _, dev, reading, q, warnings = D.build_chart(panel.values(), open_map(store), "the CLI's map")
    for name in ("A_star", "m_star", "drift_velocity", "v_star", "regime"):
        np.testing.assert_array_equal(chart[name].values, np.asarray(got["chart"][name]), err_msg=name)
    for name in ("A_star", "m_star", "a0", "contact_radius", "edge_slope", "drift_velocity"):
        assert getattr(q, name) == got["device"][name], name
    assert q.profile == got["device"]["profile"] and q.scene_profile == "cone"
    assert [w.code for w in warnings] == [w["code"] for w in got["warnings"]]
    # Sneddon's cone (docs/MODEL.md section 10): N0 = (2/pi) E* tan(alpha) a0^2,
    # an independent check of the a0 both use
    mass = units.sphere_mass(device.radius, units.material("steel").density)
    E_eff = design._e_eff(device)
    a0 = math.sqrt(mass * design.G_STANDARD * math.pi / (2 * E_eff * math.tan(math.radians(HALF_ANGLE))))
    assert q.a0 == pytest.approx(a0, rel=1e-12)
    assert q.A_star == pytest.approx(a / a0, rel=1e-12)
    # the table shows the tip, its normalized profile, its edge slope and its warnings
    text = D.device_text(dev, reading, q, warnings)
    assert "| tip | cone (half-angle 60 deg) |" in text
    assert "| normalized profile (the run's) | `cone` |" in text
    assert f"| slope at the contact edge | {q.edge_slope:.4g} |" in text
    assert q.edge_slope == pytest.approx(1 / math.tan(math.radians(HALF_ANGLE)), rel=1e-12)
    assert {w.code for w in warnings} >= {"tip-slope", "cone-apex"}
    for w in warnings:  # (as the page shows it: the message is Markdown)
        assert w.message in shown_text(text)


def test_the_device_run_carries_the_tips_profile(monkeypatch):
    from vibtrans_explorer import explorer as E
    from vibtrans_explorer.views.summary import profile_words

    ex = E.Explorer()
    runs = []
    monkeypatch.setattr(ex, "start_run", lambda: runs.append(ex.state.scene()))
    device = design.preset("paper").device
    ex.state.param.update(
        substrate=device.substrate,
        particle=device.particle,
        radius=device.radius,
        frequency=device.frequency,
        amplitude=device.amplitude,
        tip="power",
        tip_exponent=3.0,
        tip_radius=1e-4,
    )
    ex._run_design_device(0.3, 2000.0)
    scene = runs[-1]
    shape = designtip.tip_shape("power:3", tip_radius=1e-4)
    q = design.device_quantities(device, shape=shape)
    assert scene.profile == "power:3" == q.scene_profile == ex.state.profile
    # (the scene holds 10^log10: equal to rounding)
    assert math.isclose(math.log10(scene.amplitude), math.log10(q.A_star), abs_tol=1e-12)
    assert math.isclose(math.log10(scene.mass), math.log10(q.m_star), abs_tol=1e-12)
    assert profile_words(scene) == ", profile power:3"
    assert "profile=power%3A3" in ex.url_query() and "tip=power" in ex.url_query()
    # its drift in SI: a0 f v* with the tip's a0 (not the sphere's)
    text = ex.units_panel.si_text(-10.0, scene)
    assert f"{q.a0 * device.frequency * -10.0:.3e} m/s" in text
    assert "(the device of the Units and Design tabs)" in text
    # the sphere's device runs the sphere (whatever the profile was)
    ex.state.tip = "sphere"
    ex._run_design_device(0.3, 2000.0)
    assert runs[-1].profile == "sphere"
    n = device.normalized()
    assert math.isclose(math.log10(runs[-1].amplitude), math.log10(n.A_star), abs_tol=1e-12)


def test_the_units_tab_gives_the_tips_numbers_and_warnings(monkeypatch):
    from vibtrans_explorer import explorer as E
    from vibtrans_explorer.views.units import device_warnings

    ex = E.Explorer()
    ex.units_panel.__panel__()
    ex.state.param.update(tip="cone", tip_half_angle=HALF_ANGLE)
    device = ex.state.device_spec()
    shape = designtip.tip_shape("cone", half_angle=HALF_ANGLE)
    q = design.device_quantities(device, shape=shape)
    info = ex.units_panel.info.object
    assert f"| A* | {q.A_star:.4g}" in info and f"| a0 | {q.a0:.3e} m |" in info
    assert "| tip (the Design tab's) | cone (half-angle 60 deg): profile `cone` |" in info
    expected = design.validity_warnings(device, shape=shape)
    assert [w.code for w in device_warnings(ex.state)] == [w.code for w in expected]
    assert "cone-apex" in [w.code for w in expected]
    for w in expected:
        assert w.message in shown_text(ex.units_panel.warnings.object)
