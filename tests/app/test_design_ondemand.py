"""A design chart no shipped map serves: the map it needs (design.chart_needs),
read from a given map (design_chart's map_ds), and in the explorer's Design
tab offered with its cost, computed as a map on demand (app/server/mapjobs.py),
drawn, shared through the server's cache, cancelled, and its device run."""

import asyncio
import math

import numpy as np
import pytest
from asyncutil import until

from vibtrans.core.errors import InputError
from vibtrans.maps.sweep import open_map
from vibtrans.products import design
from vibtrans_explorer.server import mapjobs
from vibtrans_explorer.views import design as D

PAPER = dict(
    substrate="glass",
    particle="steel",
    preload=0.0,
    x=("frequency", 1e4, 1e6, 21),
    y=("amplitude", 1e-9, 5e-7, 21),
    fixed=("radius", 0.5e-3),
)
# a small chart at mu 0.5 (no shipped map): a 0.2-decade window of the map
SMALL = dict(mu=0.5, x_lo=1e5, x_hi=1.2e5, x_points=3, y_lo=1e-8, y_hi=1.2e-8, y_points=3)


def test_a_chart_on_the_shipped_map_needs_nothing_else():
    need = design.chart_needs(**PAPER, mu=0.3)
    assert need.shipped_problems == ()
    assert need.theta == pytest.approx(1.2143, abs=1e-4) and need.nu == 0.3
    chart = design.design_chart(**PAPER, mu=0.3)
    lo, hi = need.log_amplitude
    assert lo == pytest.approx(np.log10(chart["A_star"].values).min(), abs=1e-12)
    assert hi == pytest.approx(np.log10(chart["A_star"].values).max(), abs=1e-12)


@pytest.mark.parametrize(
    "change, reason",
    [
        (dict(mu=0.5), "no shipped map for mu = 0.5"),
        (dict(particle="PTFE"), "theta"),
        (dict(x=("frequency", 1e4, 1e6, 21), y=("amplitude", 1e-9, 1e-3, 21)), "log10 A* spans"),
    ],
)
def test_the_need_says_why_the_shipped_map_cannot_serve(change, reason):
    values = {**PAPER, "mu": 0.3, **change}
    need = design.chart_needs(**values)
    assert any(reason in p for p in need.shipped_problems), need.shipped_problems
    with pytest.raises(InputError, match="no shipped map covers this chart") as refused:
        design.design_chart(**values)
    assert isinstance(refused.value, design.NoMapCovers) and refused.value.need == need


def test_a_given_map_is_read_as_the_shipped_one_bit_for_bit():
    ds = open_map(str(design.shipped_map_path(0.3)))
    shipped = design.design_chart(**PAPER, mu=0.3)
    given = design.design_chart(**PAPER, mu=0.3, map_ds=ds, map_name="the same map")
    assert given.attrs["map"] == "the same map"
    for name in shipped.data_vars:
        np.testing.assert_array_equal(given[name].values, shipped[name].values, err_msg=name)


def test_a_given_map_that_does_not_serve_the_chart_is_refused():
    ds = open_map(str(design.shipped_map_path(0.3)))
    with pytest.raises(InputError, match="the my map does not serve this chart: mu 0.5"):
        design.design_chart(**PAPER, mu=0.5, map_ds=ds, map_name="my map")
    device = design.preset("paper").device
    assert design.read_device(device, mu=0.5, map_ds=ds) is None
    got = design.read_device(device, mu=0.3, map_ds=ds, map_name="my map")
    assert got["map"] == "my map"
    assert got["v_star"] == design.read_device(device, mu=0.3)["v_star"]


@pytest.mark.parametrize("preset", design.PRESET_NAMES)
def test_the_map_requested_covers_the_chart_at_the_shipped_step_or_finer(preset):
    p = design.preset(preset)
    d = p.device
    fq = next(q for q in design.AXES if q not in (p.x[0], p.y[0]))
    need = design.chart_needs(d.substrate, d.particle, d.preload, p.x, p.y, (fq, getattr(d, fq)), mu=0.5)
    request, why = D.map_request(need)
    assert why is None
    la, lm = request.axes()
    assert la[0] <= need.log_amplitude[0] and la[-1] >= need.log_amplitude[1]
    assert lm[0] <= need.log_mass[0] and lm[-1] >= need.log_mass[1]
    assert np.diff(la).max() <= design.MAP_STEP + 1e-12
    assert np.diff(lm).max() <= design.MAP_STEP + 1e-12
    # snapped to the grid of the step: a window asked twice is one cache entry
    assert math.isclose(request.la_from / design.MAP_STEP, round(request.la_from / 0.05))
    assert (request.model, request.mu, request.fidelity) == ("deformable", 0.5, "preview")
    assert request.theta == pytest.approx(need.theta) and request.nu == need.nu


def test_the_map_s_fidelity_and_periods_are_the_user_s_and_checked():
    need = design.MapNeed(0.3, 1.2, 0.3, (0.0, 1.0), (0.0, 1.0), ("outside",))
    request, why = D.map_request(need, fidelity="standard", periods=500.0)
    assert why is None and (request.fidelity, request.periods) == ("standard", 500.0)
    request, why = D.map_request(need, periods=5.0)
    assert request is None and why == (
        "the map's periods is 5; a map on demand accepts periods in [10, 10000]"
    )
    request, why = D.map_request(need, fidelity="fast")
    assert request is None and "fidelity must be one of preview, standard" in why


def test_a_window_beyond_what_a_map_on_demand_accepts_is_said():
    need = design.MapNeed(0.3, 1.2, 0.3, (5.0, 7.5), (0.0, 1.0), ("outside",))
    request, why = D.map_request(need)
    assert request is None and "log10 A* [5, 7.5]" in why and "[-6, 6]" in why
    request, why = D.map_request(design.MapNeed(3.0, 1.2, 0.3, (0, 1), (0, 1), ()))
    assert request is None and why == "mu is 3; a map on demand accepts mu in [0.01, 1]"
    # a window snapped across the accepted range's edge is moved inside it
    request, why = D.map_request(design.MapNeed(0.3, 1.2, 0.3, (5.02, 5.99), (0, 1), ()))
    assert why is None and request.la_to == 6.0 and request.la_from <= 5.02


@pytest.mark.slow  # a small map computed (preview, 2000 periods)
def test_the_tab_computes_the_map_draws_the_chart_and_shares_it(tmp_path, monkeypatch):
    monkeypatch.setattr(D, "DESIGN_LEVELS", 1)  # 3 x 3 coarse, 5 x 5 finest
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    runs = []
    panel = D.DesignPanel(jobs=jobs, on_run=lambda *args: runs.append(args))
    panel.__panel__()
    panel.param.update(**SMALL)
    asyncio.run(panel.draw())
    assert panel.chart is None and "no shipped map for mu = 0.5" in panel.offer.object
    assert "5 x 5 points" in panel.offer.object and jobs.computed == 0
    assert "2000 periods, preview" in panel.offer.object and "Accuracy" in panel.offer.object
    asyncio.run(panel.compute())
    assert "finished" in panel.progress.object and not panel.alert.visible
    assert jobs.computed == 1 and not panel.cancel_button.visible
    chart = panel.chart
    assert chart.attrs["map"] == "computed on this server: preview, 2000 periods"
    # the chart is the library's reading of the map computed
    ds = panel._map[0]
    direct = design.design_chart(
        panel.device.substrate,
        panel.device.particle,
        0.0,
        ("frequency", 1e5, 1.2e5, 3),
        ("amplitude", 1e-8, 1.2e-8, 3),
        ("radius", panel.device.radius),
        mu=0.5,
        map_ds=ds,
        map_name=chart.attrs["map"],
    )
    for name in ("drift_velocity", "v_star", "regime"):
        np.testing.assert_array_equal(chart[name].values, direct[name].values)
    assert np.isfinite(chart["drift_velocity"].values).all()
    # a click on the chart reads the device on the map computed
    x, y = 1.1e5, 1.1e-8
    asyncio.run(panel.mark(x, y))
    assert panel.reading is not None and panel.reading["map"] == chart.attrs["map"]
    assert (panel.device.frequency, panel.device.amplitude) == (x, y)
    # its scene runs in the explorer at the chart's mu and periods (the
    # click ran it; the button runs it again)
    assert not panel.run_button.disabled and len(runs) == 1
    panel.run_device()
    # the explorer runs the form's device (the state's when shared) at these
    assert len(runs) == 2 and runs[0] == runs[1] == (0.5, 2000.0)
    # another session asking the same chart gets it from the cache
    other = D.DesignPanel(jobs=jobs)
    other.__panel__()
    other.param.update(**SMALL)
    asyncio.run(other.draw())
    asyncio.run(other.compute())
    assert "from this server's cache" in other.progress.object and jobs.computed == 1
    np.testing.assert_array_equal(other.chart["v_star"].values, chart["v_star"].values)
    # a chart the map computed serves is drawn on it at once, without an offer
    panel.param.update(x_hi=1.15e5)
    asyncio.run(panel.draw())
    assert not panel.offer_box.visible and panel.offer.object == ""
    assert panel.chart.attrs["map"] == chart.attrs["map"] and panel.chart is not chart


@pytest.mark.slow
def test_a_map_can_be_cancelled_and_a_closed_session_cancels_it(tmp_path):
    started = []

    def build(comp, path, on_level):  # a map that never finishes until cancelled
        started.append(comp)
        comp.cancel.wait(30)
        raise mapjobs.Cancelled("map cancelled")

    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, build=build)
    for close in (False, True):
        panel = D.DesignPanel(jobs=jobs)
        panel.__panel__()
        panel.param.update(**SMALL)

        async def run():
            await panel.draw()
            task = asyncio.create_task(panel.compute())
            await until(lambda: started and not started[-1].cancel.is_set())
            assert panel.cancel_button.visible and panel.compute_button.disabled
            # another chart drawn meanwhile offers its own map; the first goes on
            panel.mu = 0.6
            await panel.draw()
            assert "mu = 0.6" in panel.offer.object and "Computing" in panel.progress.object
            assert panel.compute_button.disabled and panel.cancel_button.visible
            panel.mu = 0.5
            panel.close() if close else panel.cancel()
            await asyncio.wait_for(task, 10)

        asyncio.run(run())
        assert started[-1].cancel.is_set() and jobs.busy() == (0, 0)
        if not close:
            assert "Map cancelled" in panel.progress.object and not panel.cancel_button.visible


@pytest.mark.slow  # an explorer session (maps rendered)
def test_the_explorer_runs_the_design_tabs_device_and_gives_it_in_si_units(monkeypatch):
    from vibtrans import Scene
    from vibtrans_explorer import explorer as E

    ex = E.Explorer()
    runs = []
    monkeypatch.setattr(ex, "start_run", lambda: runs.append(ex.state.scene()))
    device = design.preset("paper").device  # steel on glass: theta 1.214
    ex.state.param.update(
        substrate=device.substrate,
        particle=device.particle,
        radius=device.radius,
        frequency=device.frequency,
        amplitude=device.amplitude,
        preload=device.preload,
    )
    ex._run_design_device(0.3, 2000.0)
    scene = runs[-1]
    n = device.normalized()
    assert scene.model == "deformable" and scene.mu == 0.3 and scene.periods == 2000.0
    assert scene.theta == n.theta and scene.nu == n.nu
    assert round(np.log10(scene.amplitude), 3) == round(np.log10(n.A_star), 3)
    text = ex.units_panel.si_text(-299.0, scene)
    assert "(the device of the Units and Design tabs)" in text
    assert f"{n.drift_velocity_si(-299.0):.3e} m/s" in text
    assert ex.units_panel.period_seconds(scene) == pytest.approx(1 / device.frequency)
    # another scene is no device: the hint, as before
    assert "run a device from the Units or Design tab" in ex.units_panel.si_text(
        1.0, Scene(amplitude=10.0, mass=1.0)
    )
    # a device beyond the explorer's range is refused with a message, nothing runs
    ex.state.param.update(
        substrate="lithium niobate", particle="fused silica", radius=1e-6, frequency=1e7, amplitude=1e-3
    )
    ex._run_design_device(0.3, 2000.0)
    assert len(runs) == 1 and "outside the explorer's range" in ex.message.object
