"""The explorer's memory view (app/views/memory.py), server side (no
browser): built once, empty and disabled before a deformable run, fed a real
preview run's snapshots through its sources, scrubbed by its slider, a typed
time shown or refused with a message, a new run replacing the snapshots of
the last (memory view <= 0.5 s, scrubbed through time)."""

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from asyncutil import until
from budget import budget

from vibtrans import paper_scene
from vibtrans.core.simulate import memory_snapshot, memory_snapshots
from vibtrans.products import plots
from vibtrans_explorer.session import urlstate
from vibtrans_explorer.views.memory import SNAPSHOTS, MemoryView, snapshot_times, title_lines

POOL = ThreadPoolExecutor(max_workers=2)


def _scene(point, **kw):
    return paper_scene(point).replace(**{"model": "deformable", "fidelity": "preview", **kw})


@pytest.fixture(scope="module")
def partial_slip():
    """Scene 9 (partial slip: a stick core in a slip annulus) and the
    snapshots the view should hold, computed here on their own."""
    scene = _scene(9)
    return scene, memory_snapshots(scene, snapshot_times(scene.periods))


async def _ready(view):
    view.set_run(*view._next)
    await until(lambda: not view.computing, timeout=budget(120))


def _view(scene):
    view = MemoryView(POOL)
    view._next = (scene, scene.periods)
    return view


def _holds(view, snap):
    """The view's sources hold this snapshot's arrays (and its title)."""
    assert np.array_equal(view.profile.data["h"], snap["h"])
    assert np.array_equal(view.profile.data["w"], snap["w"])
    assert np.array_equal(view.profile.data["u"], snap["u"])
    assert view.apex.data == {"h": [snap["a"]], "w": [snap["b"]]}
    spans = plots.memory_spans(snap)
    assert view.spans.data["left"] == [s["left"] for s in spans]
    assert view.spans.data["right"] == [s["right"] for s in spans]
    assert view.spans.data["label"] == [s["label"] for s in spans]
    discs = plots.contact_geometry(snap)["discs"]
    radii = [float(np.hypot(x[0], y[0])) for x, y in zip(view.discs.data["xs"], view.discs.data["ys"])]
    assert radii == pytest.approx([d["r"] for d in discs], rel=1e-12)
    assert view.w_fig.title.text == title_lines(plots.memory_title(snap))
    assert view.c_fig.title.text == title_lines(plots.contact_geometry(snap)["title"])


def test_empty_and_disabled_before_a_run():
    view = MemoryView(POOL)
    assert view.slider.disabled and view.show_button.disabled
    assert all(len(v) == 0 for src in (view.profile, view.spans, view.discs) for v in src.data.values())


def test_a_run_fills_the_sources_and_the_slider_scrubs(partial_slip):
    scene, snaps = partial_slip

    async def go():
        view = _view(scene)
        view.set_run(scene, scene.periods)
        assert view.busy.visible and view.slider.disabled  # computing, said so
        await until(lambda: not view.computing, timeout=budget(120))
        assert not view.busy.visible and not view.slider.disabled
        assert len(view.snapshots) == SNAPSHOTS
        _holds(view, snaps[-1])  # the run's end first
        assert len(view.spans.data["left"]) == 2  # stick core, slip annulus
        # every position of the slider shows its snapshot
        for i in (0, 7, SNAPSHOTS // 2, SNAPSHOTS - 2):
            view.slider.value = float(view.times[i])
            _holds(view, snaps[i])
        # the depth axis and the circle keep one scale while scrubbing
        a_max = max(s["a"] for s in snaps)
        assert view.w_fig.x_range.end == pytest.approx(1.02 * a_max)
        assert view.c_fig.x_range.end == pytest.approx(1.1 * max(np.sqrt(a_max), 1.0))

    asyncio.run(go())


def test_a_typed_time_is_shown_and_bad_ones_are_messages(partial_slip):
    scene, _ = partial_slip

    async def go():
        view = _view(scene)
        await _ready(view)
        view.time_field.input.value = "1500.25"
        await view.show_at()
        _holds(view, memory_snapshot(scene, 1500.25))
        assert not view.note.visible
        before = view.shown
        for text in ("2500", "-5", "abc", ""):
            says = f"got '{urlstate.shown(text)}'" if text else "the field is empty"
            view.time_field.input.value = text
            await view.show_at()
            assert view.note.visible and view.shown is before
            msg = view.note.object
            assert msg.startswith("Not shown: time t* (periods) must be") and says in msg
            assert "[0.0, 2000.0]" in msg
        # with the explorer's alert: the message goes there
        said = []
        view.error = said.append
        view.time_field.input.value = "2001"
        await view.show_at()
        assert len(said) == 1 and "'2001'" in said[0]

    asyncio.run(go())


def test_in_flight_there_is_no_memory():
    """Scene 4 hops: a time in flight draws the message, no diagram."""
    scene = _scene(4, periods=60.0)
    snaps = memory_snapshots(scene, snapshot_times(60.0))
    k = next(i for i, s in enumerate(snaps) if s["h"].size == 0)

    async def go():
        view = _view(scene)
        await _ready(view)
        view.slider.value = float(view.times[k])
        assert view.notes.data["text"] == [plots.FLIGHT_TEXT]
        assert len(view.profile.data["h"]) == 0 and len(view.discs.data["xs"]) == 0
        assert view.circle_notes.data["text"] == ["in flight: no contact"]
        j = next(i for i, s in enumerate(snaps) if s["h"].size > 0)
        view.slider.value = float(view.times[j])
        _holds(view, snaps[j])
        assert view.notes.data["text"] == []

    asyncio.run(go())


def test_a_new_run_cancels_and_replaces_the_snapshots():
    first = _scene(9, fidelity="standard")  # ~0.5 s of snapshots
    second = _scene(7, periods=100.0)

    async def go():
        view = MemoryView(POOL)
        view.set_run(first, first.periods)
        first_job = view.work.job
        cancel = first_job.event
        view.set_run(second, second.periods)
        assert cancel.is_set()  # the first run stops
        await until(lambda: not view.computing, timeout=budget(120))
        assert view.scene is second and view.times[-1] == 100.0
        expected = memory_snapshots(second, snapshot_times(100.0))[-1]
        _holds(view, expected)
        # the first's end (its thread done, then every task the view started
        # for it) changes nothing
        await until(lambda: all(f.done() for f in first_job.futures), timeout=budget(120))
        await asyncio.gather(*(asyncio.all_tasks() - {asyncio.current_task()}))
        assert view.scene is second
        _holds(view, expected)
        view.set_run(second.replace(model="point-mass"), 100.0)  # no memory diagram
        assert view.scene is None and view.slider.disabled and view.show_button.disabled
        assert len(view.profile.data["h"]) == 0

    asyncio.run(go())


def test_clear_empties_and_disables(partial_slip):
    scene, _ = partial_slip

    async def go():
        view = _view(scene)
        await _ready(view)
        view.clear()
        assert view.slider.disabled and view.show_button.disabled and view.shown is None
        assert all(len(v) == 0 for v in view.profile.data.values())
        await view.show_at()  # nothing to show: nothing happens
        assert view.shown is None and not view.note.visible

    asyncio.run(go())


def test_snapshot_times_cover_the_last_period():
    t = snapshot_times(2000.0)
    assert t.size == SNAPSHOTS and t[0] == 1999.0 and t[-1] == 2000.0
    assert np.all(np.diff(t) > 0)
    short = snapshot_times(0.5)
    assert short[0] == 0.0 and short[-1] == 0.5


def test_the_slider_and_the_time_field_show_the_time_drawn(partial_slip):
    """The slider must not stand at the run's end while the time field
    says the last period's start, each not following the other.  Both
    show the time of the diagram drawn: after the snapshots, a slide and a
    typed time inside the slider's range; the titles name that time."""
    scene, snaps = partial_slip

    async def go():
        view = _view(scene)
        assert view.w_fig.toolbar_location != "above"  # the title has the whole row
        await _ready(view)
        # (the field holds times within the run: its end's snapshot may lie a
        # step past the run's end)
        end = view.at.param.t.bounds[1]
        assert view.at.t == min(round(snaps[-1]["t"], 4), end)
        assert view.slider.value == pytest.approx(snaps[-1]["t"])
        view.slider.value = float(view.times[5])
        _holds(view, snaps[5])
        # (a snapshot's time is the step nearest to the one asked for)
        assert view.at.t == round(snaps[5]["t"], 4)
        assert view.slider.value == pytest.approx(snaps[5]["t"])
        assert float(view.time_field.input.value) == view.at.t  # the field's text
        t = round(float((view.times[10] + view.times[11]) / 2), 4)  # between two snapshots
        view.time_field.input.value = str(t)
        await view.show_at()
        assert view.shown["t"] == pytest.approx(t) and view.slider.value == pytest.approx(t)
        _holds(view, view.shown)  # (not replaced by the nearest snapshot)
        assert f"t* = {view.shown['t']:.6g}" in view.w_fig.title.text

    asyncio.run(go())


def test_after_a_cancel_the_diagram_is_marked_as_the_previous_runs(partial_slip):
    """After Cancel the old plots are not shown as if current."""
    scene, _ = partial_slip

    async def go():
        view = _view(scene)
        await _ready(view)
        view.mark_previous()
        assert "previous run" in view.status.object

    asyncio.run(go())


class _HeldSnapshots:
    """An executor whose last-period snapshots start only once released
    (the order of the race, made certain); everything else runs at once."""

    def __init__(self):
        self.release = threading.Event()

    def submit(self, fn, *args, **kwargs):
        if fn.__name__ == "memory_snapshots":

            def held():
                self.release.wait(budget(120))
                return fn(*args, **kwargs)

            return POOL.submit(held)
        return POOL.submit(fn, *args, **kwargs)


def test_a_time_shown_while_the_snapshots_compute_stays_shown():
    """Show pressed before the last period's snapshots are ready: when they
    come, the diagram of the typed time stays (before, the last period's
    replaced it and the field went back to the run's end), and the slider
    is enabled at that time."""
    scene = _scene(9)
    executor = _HeldSnapshots()

    async def go():
        view = MemoryView(executor)
        view.set_run(scene, scene.periods)
        view.time_field.input.value = "1999.5"
        await view.show_at()
        assert view.computing  # the snapshots still to come
        _holds(view, memory_snapshot(scene, 1999.5))
        executor.release.set()
        await until(lambda: not view.computing, timeout=budget(120))
        _holds(view, memory_snapshot(scene, 1999.5))
        t = float(view.shown["t"])  # the time drawn (a sample's)
        assert abs(t - 1999.5) < 1e-3
        assert view.at.t == round(t, 4) and not view.slider.disabled
        assert view.slider.value == t

    asyncio.run(go())


async def _served_view(scene):
    """(a ready memory view of `scene`, the document it is in): a Bokeh
    Document as a served page's, with a session, whose next-tick callbacks
    are kept in `ticks` for the test to run."""
    from types import SimpleNamespace

    import panel as pn
    from bokeh.document import Document

    class Served(Document):
        session_context = SimpleNamespace()

        def __init__(self):
            super().__init__()
            self.ticks = []

        def add_next_tick_callback(self, callback):
            self.ticks.append(callback)

    view = _view(scene)
    await _ready(view)
    doc = Served()
    doc.add_root(pn.Column(view).get_root(doc))
    return view, doc


def test_a_typed_times_diagram_is_drawn_at_the_documents_next_tick(partial_slip):
    """After its await,
    `show_at` runs without the document's lock, where a change of a plain
    Bokeh model can be lost ("_pending_writes should be non-None"); seen:
    the click taken, the button disabled, the diagram never drawn and the
    button never enabled again.  In a served page the answer is made at the
    document's next tick (which holds the lock), as a whole."""
    from panel.io.state import set_curdoc

    scene, _ = partial_slip

    async def go():
        view, doc = await _served_view(scene)
        before = view.w_fig.title.text
        view.time_field.input.value = "1500.25"
        with set_curdoc(doc):
            await view.show_at()
        # computed, not yet drawn: the button waits disabled with the figures
        assert view.show_button.disabled and view.w_fig.title.text == before
        assert doc.ticks
        with set_curdoc(doc):
            while doc.ticks:
                doc.ticks.pop(0)()
        _holds(view, memory_snapshot(scene, 1500.25))
        assert not view.show_button.disabled

    asyncio.run(go())


def test_a_typed_time_lays_out_no_figure_of_the_page_again(partial_slip):
    """The memory view within 0.5 s (browserbench): a loading overlay on
    the figures as the click's busy state (Panel's
    `loading`: the figures' row's css_classes), on and off, costs more (0.51-0.56 s), as BokehJS lays
    out every figure of the page again at each change of a layout's
    css_classes, visible, size or children (tests/relayout.py
    names them; Chrome traces, docs/how-to/deployment.md 2.2).  The busy state is the
    disabled button: in a served page, while the diagram computes and once
    it is drawn, no such property of a model of the page has changed."""
    from bokeh.models import LayoutDOM, Plot
    from panel.io.state import set_curdoc
    from relayout import LAYOUT_PROPERTIES, PLOT_LAYOUT_PROPERTIES

    def layout(doc):
        """What BokehJS lays the page out by: {(model id, property): value}."""
        out = {}
        for m in doc.models:
            names = (LAYOUT_PROPERTIES if isinstance(m, LayoutDOM) else set()) | (
                PLOT_LAYOUT_PROPERTIES if isinstance(m, Plot) else set()
            )
            for name in names & set(m.properties()):
                value = getattr(m, name)
                out[(m.id, name)] = (
                    [x.id for x in value]
                    if isinstance(value, list) and value and hasattr(value[0], "id")
                    else repr(value)
                )
        return out

    scene, _ = partial_slip

    async def go():
        view, doc = await _served_view(scene)
        before = layout(doc)
        view.time_field.input.value = "1500.25"
        with set_curdoc(doc):
            await view.show_at()
            assert view.show_button.disabled  # busy
            busy = layout(doc)
            while doc.ticks:
                doc.ticks.pop(0)()
        _holds(view, memory_snapshot(scene, 1500.25))
        assert not view.show_button.disabled
        assert {k: v for k, v in busy.items() if before.get(k) != v} == {}
        assert {k: v for k, v in layout(doc).items() if before.get(k) != v} == {}

    asyncio.run(go())
