"""The particle's profile in chromium: a link with a cone opens
the page with the cone selected, its tip drawn in the sidebar (readable:
inside the sidebar, not cut, as wide as its controls), the map saying it is
the sphere's with the button for the cone's map on demand, and the run's
heading naming the cone; at 1024 x 768, 1280 x 800 and 1920 x 1080.

The screenshots go to test-artifacts/profile/ (look at them)."""

from pathlib import Path

import pytest
from browserpages import steady

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts" / "profile"
SIZES = ["1024x768", "1280x800", "1920x1080"]
# paper point 6 (landings: the contact circle's own c(a*) moves)
LINK = "?profile=cone&la=0.25&lm=0.8&fidelity=preview&compare=none"

# the tip's drawing: its box on the screen, the sidebar's, and its title
DRAWING_JS = """() => {
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models) {
    if (m.name !== "profile-drawing") continue;
    const v = window.Bokeh.index.find_one(m);
    if (!v) return {found: false};
    const r = v.el.getBoundingClientRect();
    const side = document.querySelector("#sidebar");
    const s = side ? side.getBoundingClientRect() : null;
    return {found: true, left: r.left, right: r.right, width: r.width, height: r.height,
            sidebar_left: s && s.left, sidebar_right: s && s.right,
            title: String(m.title.text), shown: v.el.getClientRects().length > 0};
  }
  return {found: false};
}"""


@pytest.mark.parametrize("size", SIZES)
def test_a_cone_link_shows_its_tip_the_maps_note_and_runs_the_cone(served_explorer, browser, size):
    width, height = (int(v) for v in size.split("x"))
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page = browser.new_page(viewport={"width": width, "height": height})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(served_explorer.url + LINK)
        page.wait_for_selector("canvas", timeout=120000)
        # the link runs its scene: its heading names the cone
        page.locator("strong", has_text="profile cone").first.wait_for(timeout=120000)
        steady(page, timeout_s=120)  # the run's figures drawn and laid out
        page.screenshot(path=str(ARTIFACTS / f"cone-{size}.png"), full_page=True)
        box = page.evaluate(DRAWING_JS)
        assert box["found"] and box["shown"], box
        assert box["title"] == "the tip: cone (solid)\nthe sphere (dashed)"
        # readable: inside the sidebar, as wide as its controls, not cut
        assert box["sidebar_left"] is not None, box
        assert box["sidebar_left"] - 1 <= box["left"] and box["right"] <= box["sidebar_right"] + 1
        assert box["width"] >= 250 and box["height"] >= 150, box
        # (Markdown writes the apostrophe typographically)
        assert page.get_by_text("This map is the sphere").first.is_visible()
        assert page.get_by_role("button", name="Map on demand for cone").first.is_visible()
        assert "profile=cone" in page.url
        # the sidebar scrolled to the drawing (on a short screen it is below)
        page.evaluate("""() => { for (const doc of window.Bokeh.documents)
            for (const m of doc.all_models) if (m.name === "profile-drawing") {
              window.Bokeh.index.find_one(m).el.scrollIntoView({block: "center"}); } }""")
        steady(page)  # scrolled
        page.screenshot(path=str(ARTIFACTS / f"cone-{size}-drawing.png"))
        # the animation: its contact circle is the profile's (its key says how it is drawn)
        page.get_by_text("Animation", exact=True).first.click()
        page.get_by_text("the particle drawn with its cone tip").first.wait_for(timeout=60000)
        steady(page, timeout_s=120)  # the tab's figures drawn and laid out
        page.get_by_text("Animation", exact=True).first.evaluate("(e) => e.scrollIntoView({block: 'start'})")
        steady(page)  # scrolled
        page.screenshot(path=str(ARTIFACTS / f"cone-{size}-animation.png"))
        assert not errors, errors
    finally:
        page.close()


# a small map on demand of the cone (5 x 5 points, 100 periods: seconds)
CONE_MAP = "deformable,0.3,1.2,0.3,50,100,preview,ab4,paper,0.5,-1,1,-2,0,2,1,decided,cone"
TITLES_JS = """() => {
  const out = [];
  for (const doc of window.Bokeh.documents) for (const m of doc.all_models)
    if (m.title != null && m.title.text !== undefined) out.push(String(m.title.text));
  return out;
}"""


def test_a_cone_map_on_demand_draws_its_linear_resonance_and_says_why(served_explorer, browser):
    """At 1024 x 768: a link to a cone's map on demand; its lines are not
    the sphere's shipped ones (its title's second line says so, its key
    names the closed form's line)."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page = browser.new_page(viewport={"width": 1024, "height": 768})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(served_explorer.url + f"?profile=cone&map={CONE_MAP}")
        page.wait_for_selector("canvas", timeout=120000)
        page.get_by_text("click it to run a scene there", exact=False).first.wait_for(timeout=180000)
        steady(page, timeout_s=120)
        titles = page.evaluate(TITLES_JS)
        note = [t for t in titles if "no jumping boundary: the one shipped is the sphere's" in t]
        assert note and "cone's linear resonance m* = 0.0507" in note[0], titles
        page.screenshot(path=str(ARTIFACTS / "cone-map-on-demand-1024x768.png"))
        assert not errors, errors
    finally:
        page.close()


def test_a_steep_power_law_link_opens_its_page_and_runs(served_explorer, browser):
    """power:1e300 (valid: n >= 1) overflowed the tip's outline: the page
    was Panel's traceback with the server's paths.  Now the page opens, its
    tip is drawn, the linked scene runs (its animation draws the tip too),
    and the server logs no exception."""
    logged = len(served_explorer.text())
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(served_explorer.url + "?profile=power:1e300&la=0.25&lm=0.8&fidelity=preview&compare=none")
        page.locator("strong", has_text="profile power:1e300").first.wait_for(timeout=120000)
        page.get_by_text("Animation", exact=True).first.click()
        steady(page, timeout_s=120)
        box = page.evaluate(DRAWING_JS)
        assert box["found"] and box["title"] == "the tip: power:1e300 (solid)\nthe sphere (dashed)"
        body = page.inner_text("body")
        assert "Traceback" not in body and "Error" not in body
    finally:
        page.close()
    log = served_explorer.text()[logged:]
    assert "Traceback" not in log and "Error" not in log, log
    assert not errors, errors
