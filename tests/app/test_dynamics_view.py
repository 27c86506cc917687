"""The explorer's dynamics view (app/views/dynamics.py), server side: a run's
section and period-1 orbit, a click on the section seeding a new orbit in a
new colour (back and clear), the orbit diagram recomputed in a zoomed window
(back and reset), the material point explained.
The numbers are vibtrans.analysis.dynamics' own, computed here beside the view."""

import asyncio
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from asyncutil import until
from bokeh.events import RangesUpdate, Tap
from budget import budget

from vibtrans import paper_scene, simulate
from vibtrans.analysis import dynamics
from vibtrans.products import plots
from vibtrans_explorer.views.dynamics import DIAGRAM_RUNS, POINT_MASS_TEXT, SECTION_PERIODS, DynamicsView

POOL = ThreadPoolExecutor(max_workers=2)


def _idle(view):
    return not view.computing


def _run():
    scene = paper_scene(6).replace(periods=400.0)  # synchronous hopping: an island
    return scene, simulate(scene)


def test_a_run_draws_its_section_and_period_one_orbit():
    scene, ds = _run()
    view = DynamicsView(POOL)

    async def go():
        view.set_run(scene, ds)
        await until(lambda: _idle(view), timeout=budget(120))

    asyncio.run(go())
    y, vy = float(ds["y"].values[-1]), float(ds["vy"].values[-1])
    want = dynamics.section(scene.amplitude, scene.mass, y, vy, SECTION_PERIODS)
    assert np.array_equal(view.points.data["y"], want[:, 0])
    assert np.array_equal(view.points.data["vy"], want[:, 1])
    orbit = dynamics.periodic_orbit(scene.amplitude, scene.mass, (y, vy))
    assert view.fixed.data == {"y": [orbit.y], "vy": [orbit.vy]}
    assert "elliptic (linearly stable)" in view.orbit_status.object
    # the diagram: DIAGRAM_RUNS runs over +-0.5 decades of A*, one phase each (synchronous)
    la = math.log10(scene.amplitude)
    assert view.diagram_window == ("amplitude", la - 0.5, la + 0.5)
    assert len(set(np.round(view.phases.data["x"], 9))) <= DIAGRAM_RUNS


def test_a_click_seeds_an_orbit_and_back_and_clear_remove_it():
    scene, ds = _run()
    view = DynamicsView(POOL)

    async def go():
        view.set_run(scene, ds)
        await until(lambda: _idle(view), timeout=budget(120))
        y0, vy0 = view.orbits[0][0]
        view._on_tap(Tap(model=view.section_fig, x=y0 + 0.002, y=vy0))
        assert view.back_button.disabled  # busy while it iterates
        await until(lambda: _idle(view), timeout=budget(120))
        assert len(view.orbits) == 2
        colours = set(view.points.data["color"])
        assert colours == set(plots.ORBIT_COLORS[:2])
        want = dynamics.section(
            scene.amplitude, scene.mass, y0 + 0.002, vy0, SECTION_PERIODS, phase=view.phase
        )
        assert np.array_equal(view.orbits[1], want)
        assert not view.back_button.disabled
        view.back_button.clicks += 1
        assert len(view.orbits) == 1 and set(view.points.data["color"]) == {plots.ORBIT_COLORS[0]}
        assert view.clear_button.disabled

    asyncio.run(go())


def test_a_zoom_recomputes_the_diagram_in_its_window():
    scene, ds = _run()
    view = DynamicsView(POOL)

    async def go():
        view.set_run(scene, ds)
        await until(lambda: _idle(view), timeout=budget(120))
        first = view.diagram_window
        view._on_ranges(RangesUpdate(model=view.diagram_fig, x0=0.2, x1=0.3, y0=0, y1=1))
        await until(lambda: _idle(view), timeout=budget(120))
        assert view.diagram_window == ("amplitude", 0.2, 0.3)
        x = np.asarray(view.phases.data["x"])
        assert x.min() >= 0.2 - 1e-12 and x.max() <= 0.3 + 1e-12
        assert len(np.unique(x)) == DIAGRAM_RUNS  # finer: all runs in the window
        assert not view.diagram_back.disabled
        view.diagram_back.clicks += 1
        await until(lambda: _idle(view), timeout=budget(120))
        assert view.diagram_window == first
        view.along.value = "mass"  # another line: a reset
        await until(lambda: _idle(view), timeout=budget(120))
        lm = math.log10(scene.mass)
        assert view.diagram_window == ("mass", lm - 0.5, lm + 0.5)

    asyncio.run(go())


def test_a_point_mass_run_is_explained():
    scene = paper_scene(10).replace(periods=50.0)
    view = DynamicsView(POOL)
    view.set_run(scene, simulate(scene))
    assert view.note.object == POINT_MASS_TEXT and view.note.visible
    assert view.points.data["y"] == [] and view.diagram_reset.disabled
