"""A particle that rolls, in chromium: a user picks a rolling solid sphere,
the page says the shipped map is of a particle that does not roll, a click
on the map runs the scene there rolling (its summary says so, the link
holds the choice), and the animation turns the particle: the mark on it
points at the angle the rolled arc gives, and that angle changes between
frames as the animation plays.

The screenshots go to test-artifacts/rolling/ (look at them)."""

import math
from pathlib import Path

import pytest
from browserpages import new_page, open_explorer, settle
from budget import budget_ms

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts" / "rolling"
SOLID = "solid sphere (j = 2/5)"
# paper point 4 (synchronous hopping, drifting against the wave: it rolls)
POINT = (2.5, 0.0)

# where a map point (log10 A*, log10 m*) is on the screen
MAP_POINT_JS = """([la, lm]) => {
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.x_range === undefined || !m.title || !String(m.title.text).startsWith("<v*>"))
      continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v) continue;
    const r = v.el.getBoundingClientRect();
    return {x: r.left + v.frame.x_scale.compute(la), y: r.top + v.frame.y_scale.compute(lm)};
  }
  return null;
}"""

# the trajectory's rotation panel drawn on the page (a figure shown)
ROTATION_SHOWN_JS = """() => {
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (!m.title || !String(m.title.text).startsWith("rotation: omega R*(t)")) continue;
    const v = window.Bokeh.index.find_one(m);
    if (m.visible && v && v.el.getClientRects().length > 0) return true;
  }
  return false;
}"""

# the animation's frame shown, the mark drawn on the particle (its angle),
# and the frame's rolled arc and the drawn radius (null before a run)
MARK_JS = """() => {
  const col = (d, k) => (d instanceof Map ? d.get(k) : d[k]);
  for (const doc of window.Bokeh.documents) {
    const mark = doc.get_model_by_name("anim-mark");
    if (!mark) continue;
    const x0 = col(mark.data, "x0"), y0 = col(mark.data, "y0");
    const x1 = col(mark.data, "x1"), y1 = col(mark.data, "y1");
    if (!x0 || x0.length === 0) return null;
    const i = doc.get_model_by_name("anim-frame").value;
    const frames = doc.get_model_by_name("anim-frames").data;
    const meta = doc.get_model_by_name("anim-meta").data;
    return {frame: i, angle: Math.atan2(y1[0] - y0[0], x1[0] - x0[0]),
            length: Math.hypot(x1[0] - x0[0], y1[0] - y0[0]),
            roll: col(frames, "roll")[i], rho: col(meta, "rho")[0]};
  }
  return null;
}"""


def _turned_to(state):
    """The angle the rolled arc gives at the frame shown (animation.mark_angle)."""
    return -0.5 * math.pi + state["roll"] / state["rho"]


def _assert_turned_by_its_arc(state):
    assert math.remainder(state["angle"] - _turned_to(state), 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


def test_a_rolling_solid_sphere_clicked_on_the_map_turns_in_the_animation(served_explorer, browser):
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page, errors = new_page(browser, 1400, 1000)
    try:
        open_explorer(page, served_explorer.url + "?fidelity=preview&compare=none")
        page.locator("select").filter(has_text=SOLID).select_option(label=SOLID)
        page.get_by_text("This map is of a particle that does not roll").first.wait_for(timeout=budget_ms(30))
        page.get_by_role("button", name="Map on demand for rolling solid").first.wait_for(
            timeout=budget_ms(30)
        )
        page.wait_for_function("() => location.search.includes('rolling=solid')", timeout=budget_ms(30))
        settle(page)
        at = page.evaluate(MAP_POINT_JS, list(POINT))
        assert at is not None
        page.mouse.click(at["x"], at["y"])
        # the run is the rolling particle's: its heading and summary say so
        page.locator("strong", has_text="rolling (a solid sphere, j = 0.4)").first.wait_for(
            timeout=budget_ms(120)
        )
        page.get_by_text("yes: solid sphere, j = 0.4; largest rolled arc").first.wait_for(
            timeout=budget_ms(30)
        )
        # the trajectory shows its rotation (omega R* and the contact's slip)
        page.wait_for_function(ROTATION_SHOWN_JS, timeout=budget_ms(30), polling=100)
        settle(page)
        page.screenshot(path=str(ARTIFACTS / "rolling-run.png"), full_page=True)
        # the animation: a mark on the particle, turned by the rolled arc
        page.get_by_text("Animation", exact=True).first.click()
        page.wait_for_function(f"() => ({MARK_JS})() !== null", timeout=budget_ms(60))
        page.get_by_text("The particle rolls (solid)").first.wait_for(timeout=budget_ms(30))
        first = page.evaluate(MARK_JS)
        assert first["length"] == pytest.approx(first["rho"], rel=1e-6)
        _assert_turned_by_its_arc(first)
        page.locator("select").filter(has_text="5 periods/s").select_option(label="5 periods/s")
        page.get_by_role("button", name="Play").click()
        # it turns as the animation plays: another frame, another angle (read
        # in the same poll, since the animation wraps back to frame 0 at its end)
        later = page.wait_for_function(
            f"""(a) => {{ const s = ({MARK_JS})();
                return s !== null && s.frame > 0 && Math.abs(s.angle - a) > 1e-4 ? s : null; }}""",
            arg=first["angle"],
            timeout=budget_ms(30),
            polling=100,
        ).json_value()
        page.get_by_role("button", name="Pause").click()
        assert later["frame"] != first["frame"] and later["roll"] != first["roll"]
        _assert_turned_by_its_arc(later)
        paused = page.evaluate(MARK_JS)
        _assert_turned_by_its_arc(paused)
        page.get_by_text("Animation", exact=True).first.evaluate("(e) => e.scrollIntoView({block: 'start'})")
        settle(page)
        page.screenshot(path=str(ARTIFACTS / "rolling-animation.png"))
        assert not errors, errors
    finally:
        page.close()
