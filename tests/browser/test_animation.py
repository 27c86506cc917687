"""The particle-on-the-wave animation (app/views/animation.py): its frames
are the run's full-resolution window, each frame draws the run's state
(the particle's height, the surface under it, the contact zone and circle
by state), the point mass shows the particle only; and in chromium, play
advances the frame in the browser alone, pause stops it, a drag of the
slider shows that frame, a new run starts at its first frame, and the
browser's frames are the ones `frame(i)` draws.

The screenshots go to test-artifacts/ (look at them)."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from browserpages import settle
from budget import budget_ms

from devtools.chromium import launched
from vibtrans import paper_scene, simulate
from vibtrans.core.errors import InputError, InputTypeError
from vibtrans.core.kernels import substrate
from vibtrans.core.kernels.contact import STATE_NAMES
from vibtrans.products import plots
from vibtrans_explorer.views.animation import TICK_MS, ParticleAnimation, _fixed, frame_indices

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
T_OBS = 40.0
WINDOW = (T_OBS - 2.0, T_OBS)


def _run(point, **changes):
    scene = paper_scene(point).replace(fidelity="preview", periods=T_OBS, **changes)
    return scene, simulate(scene, window=WINDOW, samples_per_period=5)


@pytest.fixture(scope="module")
def slipping():
    """Paper point 1: stick and partial slip in its last periods."""
    return _run(1)


@pytest.fixture(scope="module")
def hopping():
    """Paper point 4: flights and total sliding."""
    return _run(4)


def _window(ds):
    t = ds["time"].values
    return ds.isel(time=(t >= WINDOW[0]) & (t <= WINDOW[1]))


@pytest.mark.parametrize("which", ["slipping", "hopping"])
def test_the_frames_are_every_sample_of_the_window(which, request):
    scene, ds = request.getfixturevalue(which)
    anim = ParticleAnimation()
    anim.show(scene, ds)
    win = _window(ds)
    f = anim.frames.data
    assert win.sizes["time"] > 30  # a window, not the 5-per-period overview
    np.testing.assert_array_equal(f["t"], win["time"].values)
    for col, var in (
        ("x", "x"),
        ("y", "y"),
        ("a", "a"),
        ("state", "state"),
        ("c", "contact_radius"),
        ("s", "stick_radius"),
    ):
        np.testing.assert_array_equal(f[col], win[var].values)
    # the overview samples before the window are not frames
    assert ds.sizes["time"] > win.sizes["time"]
    assert anim.slider.end == win.sizes["time"] - 1 and anim.slider.value == 0
    assert f"all {win.sizes['time']} samples" in anim.key.text


def _state_colour_rule(s, c):
    return plots.STATE_COLORS[1] if s >= c else plots.STATE_COLORS[2] if s > 0 else plots.STATE_COLORS[3]


@pytest.mark.parametrize("which", ["slipping", "hopping"])
def test_each_frame_draws_the_runs_state(which, request):
    scene, ds = request.getfixturevalue(which)
    anim = ParticleAnimation()
    anim.show(scene, ds)
    win = _window(ds)
    rho = anim.meta.data["rho"][0]
    L = anim.meta.data["wavelength"][0]
    seen = set()
    for i in range(win.sizes["time"]):
        f = anim.frame(i)
        t = float(win["time"][i])
        y, a, state = float(win["y"][i]), float(win["a"][i]), int(win["state"][i])
        c, s = float(win["contact_radius"][i]), float(win["stick_radius"][i])
        seen.add(state)
        # the particle's lowest point is at height -y*
        p = f["particle"]
        assert p["y"][0] - p["r"][0] == pytest.approx(-y, abs=1e-9 * (1 + abs(y)))
        assert p["x"][0] == 0.0  # the view moves with the particle
        # the surface: the wave travelling to +x, u_y(t - xi / L), scaled by the
        # ramp; under the particle it is the run's surface, y* - a*
        g = substrate.ramp(t, scene.tau)[0]
        xi = f["surface"]["xi"]
        expected = np.array(
            [-g * substrate.surface_motion(t - v / L, scene.amplitude, scene.r, 0.0)[1] for v in xi]
        )
        np.testing.assert_allclose(f["surface"]["z"], expected, rtol=0, atol=1e-4 * scene.amplitude)
        under = np.interp(0.0, xi, f["surface"]["z"])
        assert under == pytest.approx(-(y - a), abs=1e-3 * scene.amplitude + 1e-9)
        # the contact zone (half-widths c sqrt(rho), s sqrt(rho)) and circle
        z = f["zone"]
        if state == 0:
            assert np.isnan(z["x0"]).all() and np.isnan(f["contact"]["c"]).all()
            assert f["contact_title"].startswith("in flight")
        else:
            assert z["x1"][0] == pytest.approx(c * math.sqrt(rho))
            assert z["x1"][1] == pytest.approx(s * math.sqrt(rho))
            assert z["y"][0] == pytest.approx(-(y - a), abs=1e-9 * (1 + abs(y)))
            assert z["colour"][0] == f["contact"]["colour"][0] == _state_colour_rule(s, c)
            assert z["colour"][0] == plots.STATE_COLORS[state]  # the state's colour
            assert z["colour"][1] == plots.STATE_COLORS[1]  # the stick core
            assert (f["contact"]["c"][0], f["contact"]["s"][0]) == (c, s)
        shown = re.match(
            r"t\* = (\S+)   wave phase t\* mod 1 = (\S+)\n(.+?)   y\* = (\S+) a0", f["side_title"]
        ).groups()
        assert float(shown[0]) == pytest.approx(t, abs=5.1e-5)
        assert float(shown[1]) == pytest.approx(t % 1.0, abs=5.1e-4)
        assert shown[2] == STATE_NAMES[state]
        assert float(shown[3]) == pytest.approx(y, rel=1e-3, abs=1e-3)
    assert seen == ({1, 2} if which == "slipping" else {0, 3})


def test_the_marks_slide_with_the_surface_under_the_particle(hopping):
    # a mark is a point of the substrate: relative to the particle it moves
    # by u_x* - x* (the surface's motion minus the particle's)
    scene, ds = hopping
    anim = ParticleAnimation()
    anim.show(scene, ds)
    f0, f1 = anim.frame(10), anim.frame(11)
    d = anim.frames.data
    shift = (d["ux"][11] - d["x"][11]) - (d["ux"][10] - d["x"][10])
    sp = anim.meta.data["spacing"][0]
    moved = (f1["marks"]["xi"][:, None] - f0["marks"]["xi"][None, :] - shift) / sp
    assert np.isclose(moved, np.round(moved), atol=1e-9).any(axis=1).all()
    assert abs(shift) > 0


def test_decimated_frames_are_real_samples_evenly_in_time(hopping):
    scene, ds = hopping
    anim = ParticleAnimation(max_frames=20)
    anim.show(scene, ds)
    win = _window(ds)
    t = anim.frames.data["t"]
    assert 2 <= t.size <= 20 < win.sizes["time"]
    assert t[0] == win["time"].values[0] and t[-1] == win["time"].values[-1]
    assert np.isin(t, win["time"].values).all() and (np.diff(t) > 0).all()
    assert f"{t.size} of the {win.sizes['time']} samples" in anim.key.text
    assert "decimated" in anim.key.text
    np.testing.assert_array_equal(frame_indices(5, 20), np.arange(5))


def test_the_point_mass_shows_the_particle_only():
    scene, ds = _run(9, model="point-mass")
    anim = ParticleAnimation()
    anim.show(scene, ds)
    n = anim.frames.data["t"].size
    assert n == _window(ds).sizes["time"]
    for i in range(n):
        f = anim.frame(i)
        assert np.isnan(f["zone"]["x0"]).all() and np.isnan(f["contact"]["c"]).all()
        assert f["contact_title"] == "material point: rigid, no contact area"
        assert f["particle"]["r"][0] > 0
        assert "overlap" not in f["side_title"]
    assert "Material point" in anim.scale_notes[2].text
    assert "no contact zone and no contact circle" in anim.key.text


@pytest.mark.parametrize(
    "v, d, text",
    [
        (39.40625, 4, "39.4063"),
        (-0.40625, 4, "-0.4063"),
        (0.125, 2, "0.13"),
        (2.5, 0, "3"),
        (1.0, 3, "1.000"),
        (-0.0001, 3, "-0.000"),
        (123.456, 1, "123.5"),
    ],
)
def test_numbers_are_written_as_the_browser_writes_them(v, d, text):
    # the titles are written by the browser (toFixed) and by frame(); a tie
    # (a time on the material point's 1/32 grid) rounds away from zero in both
    assert _fixed(v, d) == text


def test_the_vertical_model_has_no_stick_core():
    # no tangential force: its stick radius is recorded as 0, which is not
    # total sliding; the contact is drawn in its state's colour, no core
    scene, ds = _run(1, model="vertical")
    anim = ParticleAnimation()
    anim.show(scene, ds)
    touching = 0
    for i in range(anim.frames.data["t"].size):
        f = anim.frame(i)
        state = int(anim.frames.data["state"][i])
        assert np.isnan(f["zone"]["x0"][1]) and np.isnan(f["contact"]["s"][0])
        if state > 0:
            touching += 1
            assert f["zone"]["colour"][0] == plots.STATE_COLORS[state]
            assert ", s = " not in f["contact_title"]
    assert touching > 0
    assert "no stick core" in anim.circle_note.text


def test_a_second_run_changes_data_only(slipping, hopping):
    anim = ParticleAnimation()
    anim.show(*slipping)
    models = {m.id for m in anim.references()}
    anim.show(*hopping)
    assert {m.id for m in anim.references()} == models
    assert anim.frames.data["t"].size == _window(hopping[1]).sizes["time"]
    anim.clear()
    assert anim.frames.data["t"] == [] and anim.play.disabled and not anim.play.active
    assert {m.id for m in anim.references()} == models


def test_bad_input_is_refused_with_its_name(slipping):
    scene, ds = slipping
    anim = ParticleAnimation()
    with pytest.raises(InputError, match="window"):
        anim.show(scene, simulate(scene, samples_per_period=5))
    with pytest.raises(InputError, match="amplitude"):
        anim.show(scene.replace(amplitude=2.0), ds)
    with pytest.raises(InputTypeError, match="scene"):
        anim.show("scene", ds)
    with pytest.raises(InputTypeError, match="ds"):
        anim.show(scene, {"time": []})
    for bad in (1, 2.5, True, "10"):
        with pytest.raises(InputError, match="max_frames"):
            ParticleAnimation(max_frames=bad)


# ---------------------------------------------------------------- in chromium

# the page's Bokeh models by name: the frame shown, the drawn glyph data, the titles
_PAGE_JS = """() => {
  const doc = window.Bokeh.documents[0];
  const m = (name) => doc.get_model_by_name(name);
  const cols = (name) => { const d = m(name).data, out = {};
    for (const k of Object.keys(d)) out[k] = Array.from(d[k]); return out; };
  const titles = [];
  for (const x of doc.all_models) if (x.type == "Title" || x.constructor.name == "Title")
    titles.push(x.text);
  return {value: m("anim-frame").value, surface: cols("anim-surface"),
          particle: cols("anim-particle"), zone: cols("anim-zone"), tip: cols("anim-tip"),
          contact: cols("anim-contact"), mark: cols("anim-mark"), titles: titles};
}"""


# the side view's data extent per axis and its frame's size in pixels
_SIDE_JS = """() => {
  const f = window.Bokeh.documents[0].get_model_by_name("anim-side");
  return {dx: f.x_range.end - f.x_range.start, dy: f.y_range.end - f.y_range.start,
          w: f.inner_width, h: f.inner_height};
}"""


def _messages(frames, kind):
    """How many Bokeh protocol messages of a kind (PATCH-DOC, ...) among
    websocket frames (a message: a header frame, then its parts)."""
    return sum(
        1 for m in frames if isinstance(m, str) and m.startswith("{") and json.loads(m).get("msgtype") == kind
    )


def _changes(frames):
    """The properties changed by the PATCH-DOC messages among websocket frames."""
    out = []
    for m in frames:
        if isinstance(m, str) and m.startswith('{"events"'):
            out += [e.get("attr") for e in json.loads(m)["events"]]
    return out


def _same_frame(page_state, f):
    for name in ("surface", "particle", "zone", "contact", "tip", "mark"):
        for col, want in f[name].items():
            got = page_state[name][col]
            if col == "colour":
                assert list(got) == [str(v) for v in want], (name, col)
            else:
                # NaN arrives as null
                got = np.array([np.nan if v is None else v for v in got], float)
                np.testing.assert_allclose(
                    got, np.asarray(want, float), rtol=1e-9, atol=1e-9, err_msg=f"{name}.{col}"
                )
    assert f["side_title"] in page_state["titles"]
    assert f["contact_title"] in page_state["titles"]


# the frames' data the page holds now, kept; and a test that it was replaced
# (a run's frames come as a new data object)
_KEEP_FRAMES_JS = (
    "() => { window.__vtFrames = window.Bokeh.documents[0].get_model_by_name('anim-frames').data; }"
)
_NEW_FRAMES_JS = "() => window.Bokeh.documents[0].get_model_by_name('anim-frames').data !== window.__vtFrames"
# the frame the slider shows
_VALUE_JS = "() => window.Bokeh.documents[0].get_model_by_name('anim-frame').value"
# three ticks of a timer of the player's period, started now: a player still
# running would have ticked before each of them
_TICKS_JS = """(ms) => new Promise((resolve) => {
  let n = 0;
  const id = setInterval(() => { if (++n === 3) { clearInterval(id); resolve(); } }, ms);
})"""


def _show(page, doc, anim, run):
    """The server shows `run`; wait until its frames are in the page (they
    come in the message that shows the run)."""
    page.evaluate(_KEEP_FRAMES_JS)
    doc.add_next_tick_callback(lambda: anim.show(*run))
    page.wait_for_function(_NEW_FRAMES_JS, timeout=budget_ms(30))


def _play_a_while(page):
    """Play until the page shows another frame, then pause."""
    first = page.evaluate(_VALUE_JS)
    page.get_by_role("button", name="Play").click()
    page.wait_for_function(f"(first) => ({_VALUE_JS})() !== first", arg=first, timeout=budget_ms(30))
    page.get_by_role("button", name="Pause").click()


def _show_and_play(page, doc, anim, run):
    """The server shows `run`, the page plays it until its frame moves and
    pauses: the page's state then."""
    _show(page, doc, anim, run)
    _play_a_while(page)
    return page.evaluate(_PAGE_JS)


def _server_mark(doc, socket, received, title):
    """A change the server sends after everything it sent before (the
    document's title, set on its next tick): wait until it has come; the
    index of its message's first frame among `received` (a message: a
    header, a metadata and a content frame, then its buffers)."""
    doc.add_next_tick_callback(lambda: setattr(doc, "title", title))
    socket.wait_for_event("framereceived", predicate=lambda m: title in str(m), timeout=budget_ms(30))
    return next(k for k, m in enumerate(received) if isinstance(m, str) and title in m) - 2


@pytest.mark.browser
@pytest.mark.server
def test_play_pause_and_a_new_run_in_chromium(slipping, hopping):
    point_mass = _run(9, model="point-mass")
    vertical = _run(1, model="vertical")
    cone = _run(6, profile="cone")
    rolling = _run(4, rolling="solid")
    import panel as pn
    from netutil import free_port

    sessions = []

    def app():
        anim = ParticleAnimation()
        anim.show(*slipping)
        sessions.append((anim, pn.state.curdoc))
        return anim

    port = free_port()
    server = pn.serve(
        {"/": app},
        port=port,
        address="127.0.0.1",
        threaded=True,
        show=False,
        websocket_origin=[f"127.0.0.1:{port}"],
    )
    try:
        with launched() as browser:
            page = browser.new_page(viewport={"width": 1200, "height": 700})
            errors = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            received = []  # the server's websocket messages to the page
            sent = []  # the page's to the server
            sockets = []
            page.on(
                "websocket",
                lambda ws: (
                    sockets.append(ws),
                    ws.on("framereceived", lambda m: received.append(m)),
                    ws.on("framesent", lambda m: sent.append(m)),
                ),
            )
            page.goto(f"http://127.0.0.1:{port}/")
            page.wait_for_selector("canvas", timeout=budget_ms(60))
            settle(page)  # the first run's frame drawn
            anim, doc = sessions[-1]
            state = page.evaluate(_PAGE_JS)
            assert state["value"] == 0
            _same_frame(state, anim.frame(0))  # drawn by the server
            ARTIFACTS.mkdir(exist_ok=True)

            page.locator("select").filter(has_text="1 period/s").select_option(label="1 period/s")
            play = page.get_by_role("button", name="Play")
            sent_at_play = len(sent)
            play.click()
            # play advances the frame (read in the poll that sees it: the end wraps to 0)
            page.wait_for_function(f"() => ({_VALUE_JS})() > 0", timeout=budget_ms(30))
            page.screenshot(path=str(ARTIFACTS / "animation_playing.png"))
            page.get_by_role("button", name="Pause").click()
            paused = page.evaluate(_PAGE_JS)
            page.evaluate(_TICKS_JS, TICK_MS)  # the player's ticks, had it gone on
            later = page.evaluate(_PAGE_JS)
            # the page told the server of the two clicks, of no frame
            assert _changes(sent[sent_at_play:]) == ["active", "active"]
            assert later["value"] == paused["value"]  # pause stops it
            # the browser drew the frame its slider shows, as frame() draws it
            _same_frame(later, anim.frame(later["value"]))
            # ... without telling the server: no message per frame
            assert anim.slider.value == 0
            assert anim.runs == 1
            # a hand drags the slider to a quarter of the window: that frame
            handle = page.locator(".noUi-handle").first.bounding_box()
            track = page.locator(".noUi-base").first.bounding_box()
            page.mouse.move(handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2)
            page.mouse.down()
            page.mouse.move(track["x"] + 0.25 * track["width"], handle["y"] + handle["height"] / 2, steps=8)
            page.mouse.up()
            page.wait_for_function(f"(v) => ({_VALUE_JS})() !== v", arg=later["value"], timeout=budget_ms(30))
            scrubbed = page.evaluate(_PAGE_JS)
            n = anim.frames.data["t"].size
            assert abs(scrubbed["value"] - 0.25 * (n - 1)) <= 2, (scrubbed["value"], n)
            _same_frame(scrubbed, anim.frame(scrubbed["value"]))

            # a new run from the server: back to its first frame, drawn
            before = len(received)
            sent_before = len(sent)
            _show(page, doc, anim, hopping)
            # the run came in one message (all of it before a later change of
            # the server's), and the page sent nothing about it (layout sizes aside)
            mark = _server_mark(doc, sockets[-1], received, "after the second run")
            assert _messages(received[before:mark], "PATCH-DOC") == 1
            assert not set(_changes(sent[sent_before:])) - {"outer_width", "outer_height"}
            state = page.evaluate(_PAGE_JS)
            assert state["value"] == 0
            _same_frame(state, anim.frame(0))
            _play_a_while(page)
            state = page.evaluate(_PAGE_JS)
            assert state["value"] > 0
            _same_frame(state, anim.frame(state["value"]))
            page.screenshot(path=str(ARTIFACTS / "animation_hopping.png"))

            # a material point: the particle only, and the page says so
            state = _show_and_play(page, doc, anim, point_mass)
            _same_frame(state, anim.frame(state["value"]))
            assert "material point: rigid, no contact area" in state["titles"]
            page.screenshot(path=str(ARTIFACTS / "animation_point_mass.png"))

            # the vertical model: the contact without a stick core
            state = _show_and_play(page, doc, anim, vertical)
            _same_frame(state, anim.frame(state["value"]))

            # a cone: the particle drawn with its tip, as frame() draws it,
            # on equal scales (the frame's width as the page gives it)
            state = _show_and_play(page, doc, anim, cone)
            assert len(state["tip"]["x"]) > 0
            _same_frame(state, anim.frame(state["value"]))
            side = page.evaluate(_SIDE_JS)
            assert side["w"] > 0 and side["h"] > 0, side
            assert side["dx"] / side["w"] == pytest.approx(side["dy"] / side["h"], rel=1e-6)
            page.screenshot(path=str(ARTIFACTS / "animation_cone.png"))

            # a particle that rolls: its mark turned by the rolled arc, as
            # frame() draws it
            state = _show_and_play(page, doc, anim, rolling)
            assert len(state["mark"]["x0"]) == 1
            _same_frame(state, anim.frame(state["value"]))
            assert not errors, errors
    finally:
        server.stop()


def test_a_chosen_window_shows_the_particle_travel(slipping):
    """With only the last two periods shown, a class
    could not see the particle travel at point 1.  The user chooses a
    longer stretch, up to the whole run: its frames are the run's samples,
    evenly in time (the overview's rate before the full-resolution window),
    at most max_frames of them, and the note says what is decimated."""
    from vibtrans_explorer.views.animation import WINDOWS

    scene, ds = slipping
    anim = ParticleAnimation(max_frames=100)
    anim.show(scene, ds)
    short = dict(anim.frames.data)
    assert short["t"][0] == pytest.approx(WINDOW[0])
    anim.window.value = WINDOWS["the whole run (decimated)"]  # re-shows the run
    t = np.asarray(anim.frames.data["t"])
    all_t = ds["time"].values
    assert t[0] == all_t[0] and t[-1] == all_t[-1] and 2 <= t.size <= 100
    assert np.all(np.isin(t, all_t))  # the run's own samples
    steps = np.diff(t)
    assert steps.max() < 3 * (all_t[-1] - all_t[0]) / 100  # evenly in time
    x = np.asarray(anim.frames.data["x"])
    assert np.ptp(x) > 5 * np.ptp(short["x"])  # the travel over the run shows
    assert "samples per period" in anim.key.text and "does not" in anim.key.text
    anim.window.value = WINDOWS["the last 10 periods"]
    t = np.asarray(anim.frames.data["t"])
    assert t[0] == pytest.approx(T_OBS - 10.0, abs=0.5) and t[-1] == all_t[-1]
    anim.window.value = WINDOWS["the last periods at full resolution"]
    assert np.array_equal(anim.frames.data["t"], short["t"])


@pytest.mark.parametrize("profile, n", [("cone", 1.0), ("power:3", 3.0)])
def test_a_profiles_contact_circle_is_its_own_contact_radius(profile, n):
    """The contact circle of a power-law tip z = C r^n is its own
    c(a*), not the sphere's sqrt(a*).  Closed form (MDR; Popov & Hess, the
    power-law indenter): the approach d = kappa_n C a_c^n, so a_c grows as
    d^(1/n) and, over the static contact radius (d = a0), c = a*^(1/n); the
    cone (n = 1: a_c = 2 d tan(beta) / pi, beta the half-angle from the
    axis, linear in d) gives c = a*.  Paper point 6's landings sweep a*
    over a wide range."""
    scene, ds = _run(6, profile=profile)
    anim = ParticleAnimation()
    anim.show(scene, ds)
    f = anim.frames.data
    touching = f["state"] > 0
    a = np.asarray(f["a"])[touching]
    assert touching.sum() > 20 and a.max() > 10.0 * a.min() > 0  # a real range of a*
    closed = a ** (1.0 / n)
    np.testing.assert_allclose(np.asarray(f["c"])[touching], closed, rtol=1e-9)
    assert not np.allclose(closed, np.sqrt(a), rtol=1e-3)  # not the sphere's
    i = int(np.flatnonzero(touching)[0])
    frame = anim.frame(i)
    assert frame["contact"]["c"][0] == pytest.approx(a[0] ** (1.0 / n), rel=1e-9)
    assert frame["contact_title"].endswith("(static contact radii)")
    assert anim.circle.xaxis.axis_label == "x  (static contact radii)"
    assert f"c(a*) the {profile} profile's" in anim.circle_note.text
    assert f"the particle drawn with its {profile} tip" in anim.key.text
    # the sphere keeps its own units
    sphere, ds = _run(6)
    anim.show(sphere, ds)
    assert anim.circle.xaxis.axis_label == "x  (sqrt(R a0))"
    assert "the particle drawn with its" not in anim.key.text


@pytest.mark.parametrize("profile", ["cone", "power:3", "flat-sphere:1"])
def test_a_profiles_particle_is_drawn_with_its_tip(profile):
    """The side view draws a profile's particle with its tip's
    outline near the contact (the library's outline, as the tip's drawing
    beside the profile selector), its apex at the particle's lowest point
    (height -y*, the overlap a* to scale), not the sphere's circle."""
    from vibtrans.core.profiles import parse_profile
    from vibtrans_explorer.views import animation as A

    scene, ds = _run(6, profile=profile)
    anim = ParticleAnimation()
    anim.show(scene, ds)
    assert anim.tip_glyph.visible and not anim.particle_glyph.visible
    rho = anim.meta.data["rho"][0]
    q = math.sqrt(rho)
    X = min(A.TIP_CONTACT_RADII * q, A.TIP_RHO_SHARE * rho)
    shape = parse_profile(profile)
    for i in (0, len(anim.frames.data["t"]) // 2):
        f = anim.frame(i)
        y = anim.frames.data["y"][i]
        x, z = np.asarray(f["tip"]["x"]), np.asarray(f["tip"]["y"])
        # its lowest point is the particle's, -y*; the tip's outline near the axis
        assert z.min() == pytest.approx(-y, abs=1e-12)
        near = np.arange(A.TIP_POINTS)
        np.testing.assert_allclose(z[near], -y + shape.outline(x[near] / q), rtol=0, atol=1e-12)
        assert x[near][0] == pytest.approx(-X) and x[near][-1] == pytest.approx(X)
        # closed by the drawn circle's arc (radius rho) through the outline's ends
        arc = np.arange(A.TIP_POINTS, x.size)
        centre = z[A.TIP_POINTS - 1] + math.sqrt(rho * rho - X * X)
        np.testing.assert_allclose(np.hypot(x[arc], z[arc] - centre), rho, rtol=1e-12)
    # the sphere: its circle, no tip
    sphere, ds = _run(6)
    anim.show(sphere, ds)
    assert anim.particle_glyph.visible and not anim.tip_glyph.visible
    assert len(anim.frame(0)["tip"]["x"]) == 0
