"""Maps on demand (app/maprequest.py, app/mapjobs.py): the request's checks
and URL form, the server-wide queue (one map per session, sessions sharing
a computation, cancel, the cache's reuse and a damaged entry recomputed)."""
import os
import threading
import time

import numpy as np
import pytest

from vibtrans_explorer import data, maprequest, mapjobs
from vibtrans_explorer.maprequest import MapRequest
from budget import budget

# a tiny map: 5 x 5 points (2 coarse cells, K = 1), 30 periods at preview
TINY = dict(model="deformable", fidelity="preview", periods=30.0, tau=5.0,
            la_from=-0.5, la_to=0.5, lm_from=0.0, lm_to=1.0, cells=2, levels=1)


class Listener:
    """A session's updates, and an event set at the final one."""

    def __init__(self):
        self.updates = []
        self.ended = threading.Event()

    def __call__(self, update):
        self.updates.append(update)
        if update.final:
            self.ended.set()

    def wait(self, timeout=300):
        assert self.ended.wait(timeout), [u.kind for u in self.updates]
        return self.updates[-1]

    def kinds(self):
        return [u.kind for u in self.updates]


@pytest.fixture
def gate():
    return threading.Event()


@pytest.fixture
def jobs(tmp_path, gate):
    """MapJobs on a fresh cache folder whose maps start once `gate` is set."""
    def build(comp, path, on_level):
        assert gate.wait(60)
        made._run_adaptive(comp, path, on_level)
    made = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, build=build)
    return made


def test_a_map_arrives_level_by_level_then_comes_from_the_cache(jobs, gate):
    gate.set()
    first = Listener()
    jobs.submit("a", MapRequest(**TINY), first)
    done = first.wait()
    assert done.kind == "done" and not done.cached, first.kinds()
    levels = [u.level for u in first.updates if u.kind == "level"]
    assert levels == [0, 1]                 # the coarse grid, then the finest
    coarse = next(u.ds for u in first.updates if u.kind == "level")
    assert coarse["computed"].values.sum() == 9          # 3 x 3 coarse points
    assert np.isfinite(coarse["drift_velocity"].values).all()    # filled from its cells
    assert done.ds["drift_velocity"].shape == (5, 5)
    # the finest level's picture is the verified map's: a subscriber keeps it
    assert done.shown
    # another session asking for the same map reads it: nothing computed
    second = Listener()
    jobs.submit("b", MapRequest(**TINY), second)
    again = second.wait()
    assert again.kind == "done" and again.cached and jobs.computed == 1
    assert not again.shown                  # nothing drawn before: draw it
    # the next estimates learn from the map computed: its share of the grid
    # and its runs' rate (its wall time less its own work, per bounded step)
    assert jobs.fraction("deformable", 1) == done.ds["computed"].values.mean()
    assert jobs.seconds_per_work("deformable", "preview", "steps", "decided") > 0
    assert jobs.seconds_per_work("deformable", "standard", "steps", "decided") is None
    # made with the request's stopping rule (a new request's: decided), its
    # points' periods run kept; 30 periods end before the rule's first check
    assert done.ds.attrs["stop"] == "decided"
    assert (done.ds["periods_run"].values[done.ds["computed"].values] == 30.0).all()
    assert jobs.profile("deformable") == (1.0, 0.0)        # every point ran to the end
    np.testing.assert_array_equal(again.ds["drift_velocity"].values,
                                  done.ds["drift_velocity"].values)


def test_sessions_asking_for_one_map_share_its_computation(jobs, gate):
    a, b = Listener(), Listener()
    jobs.submit("a", MapRequest(**TINY), a)
    jobs.submit("b", MapRequest(**TINY), b)
    gate.set()
    assert a.wait().kind == "done" and b.wait().kind == "done"
    assert jobs.computed == 1
    assert not a.wait().cached and not b.wait().cached


def test_a_new_request_of_a_session_cancels_its_previous_one(jobs, gate):
    old, new = Listener(), Listener()
    jobs.submit("a", MapRequest(**TINY), old)
    jobs.submit("a", MapRequest(**{**TINY, "mu": 0.5}), new)
    assert old.wait(5).kind == "cancelled"
    gate.set()
    assert new.wait().kind == "done"
    assert jobs.computed == 1             # the first one never ran
    assert jobs.busy() == (0, 0)


def test_cancel_stops_the_map_and_caches_nothing_but_spares_other_sessions(jobs, gate):
    from vibtrans.maps.cache import request_key
    alone, shared_a, shared_b = Listener(), Listener(), Listener()
    request = MapRequest(**TINY)
    jobs.submit("a", request, alone)
    jobs.cancel("a")
    assert alone.wait(5).kind == "cancelled"
    other = MapRequest(**{**TINY, "mu": 0.5})
    jobs.submit("b", other, shared_a)
    jobs.submit("c", other, shared_b)
    jobs.cancel("b")                       # c still waits for it
    gate.set()
    assert shared_b.wait().kind == "done"
    assert shared_a.kinds()[-1] == "cancelled" and "done" not in shared_a.kinds()
    assert jobs.cache.get(request_key(request.cache_request())) is None
    assert jobs.computed == 1


def test_a_damaged_cache_entry_is_recomputed_not_shown(jobs, gate):
    gate.set()
    first = Listener()
    jobs.submit("a", MapRequest(**TINY), first)
    first.wait()
    entry = jobs.cache.path(jobs.cache.entries()[0])
    chunk = next(os.path.join(root, f) for root, _, files in os.walk(entry)
                 for f in files if "drift_velocity" in root and not f.startswith("."))
    with open(chunk, "r+b") as f:          # flip a byte of the data
        f.seek(max(0, os.path.getsize(chunk) // 2))
        byte = f.read(1)
        f.seek(-1, 1)
        f.write(bytes([byte[0] ^ 0xFF]))
    again = Listener()
    jobs.submit("b", MapRequest(**TINY), again)
    done = again.wait()
    assert done.kind == "done" and not done.cached and jobs.computed == 2


def test_the_estimate_bounds_the_work_and_refuses_beyond_the_limits(tmp_path):
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=2, max_points=1000,
                           max_seconds=10.0)
    for fidelity in ("preview", "reference"):       # s per unit of work, as if measured
        jobs._rates[("deformable", fidelity, "reference", "full")] = 0.5
    request = MapRequest(**{**TINY, "stop": "full"})
    est, problems = jobs.estimate(request)
    assert problems == []
    assert est.points == 25
    # every point's steps at its own step (the contact time scale's): the bound
    la, lm = request.axes()
    from vibtrans import Scene, estimate_steps
    steps = sum(estimate_steps(Scene(amplitude=10 ** a, mass=10 ** m, **request.scene_values()))
                for a in la for m in lm)
    assert est.steps == steps
    # inside the shipped map: the refinement replayed on it, its points'
    # seconds scaled from its 2000 standard periods to these 30 preview ones
    # (full runs: a decided map counts steps, below)
    work, unit, computed = jobs.expected_work(request)
    assert unit == "reference" and computed.shape == (5, 5)
    assert (computed[::2, ::2] == 1.0).all() and est.computed == computed.sum()   # coarse grid
    shipped = data.drift_map("deformable", 0.3)
    point = shipped["seconds"].sel(log_amplitude=0.0, log_mass=0.5).item()
    ref = MapRequest(**{**TINY, "periods": 2000.0, "fidelity": "standard"})
    # (a jumping point of a map judged by its twin: the run's share of its seconds)
    assert shipped["contact"].sel(log_amplitude=0.0, log_mass=0.5).item() == 1
    assert work[2, 2] == pytest.approx(point * maprequest.TWIN_SHARE
                                       * maprequest.point_steps(request, 0.0, 0.5)
                                       / maprequest.point_steps(ref, 0.0, 0.5))
    assert est.seconds == pytest.approx(mapjobs.MAP_START_SECONDS
                                        + computed.sum() * mapjobs.POINT_PASSAGE_SECONDS
                                        + (work * computed).sum() * 0.5 / 2)
    # a decided map: each point's bounded steps, times the share it runs
    decided = MapRequest(**TINY)
    jobs._rates[("deformable", "preview", "steps", "decided")] = 1e-7
    work, unit, computed = jobs.expected_work(decided)
    assert unit == "steps"
    np.testing.assert_array_equal(work, maprequest.bound_steps(decided))
    # beyond the shipped maps: the bounded steps and the share computed
    far = MapRequest(**{**TINY, "la_from": 4.0, "la_to": 5.0})
    jobs._rates[("deformable", "preview", "steps", "decided")] = 1e-7
    est, problems = jobs.estimate(far)
    work, unit, share = jobs.expected_work(far)
    assert unit == "steps" and share == mapjobs.FRACTION_PRIOR[1] and problems == []
    assert est.seconds == pytest.approx(mapjobs.MAP_START_SECONDS
                                        + share * 25 * mapjobs.POINT_PASSAGE_SECONDS
                                        + share * work.sum() * 1e-7 / 2)
    big = MapRequest(**{**TINY, "cells": 8, "levels": 3})       # 65 x 65
    est, problems = jobs.estimate(big)
    assert est is None and "4,225 points is over this server's limit of 1,000" in problems[0]
    slow = MapRequest(**{**TINY, "periods": 10000.0, "fidelity": "reference", "stop": "full"})
    jobs._rates[("deformable", "reference", "reference", "full")] = 0.5
    est, problems = jobs.estimate(slow)
    assert est is not None and "over this server's limit of 10 s per map" in problems[0]
    empty = MapRequest(**{**TINY, "la_from": 0.5, "la_to": -0.5})
    assert "log10 A* 'from' (0.5) must be below its 'to' (-0.5)" in jobs.estimate(empty)[1][0]


def test_the_first_estimate_of_a_model_and_fidelity_probes_its_speed(tmp_path):
    """Before any map of its kind, the estimate runs PROBE_POINTS of the
    window's points (in the map workers, which it so starts for the map to
    come) and takes their seconds per bounded step expected."""
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, processes=False)
    assert jobs.seconds_per_work("deformable", "preview", "steps", "decided") is None
    est, problems = jobs.estimate(MapRequest(**TINY))
    rate = jobs.seconds_per_work("deformable", "preview", "steps", "decided")
    assert problems == [] and rate > 0 and est.seconds > 0
    assert "on this server (1 core, from its measured speed)" in est.text(1)
    # measured once: the next estimate of its kind uses it
    jobs.estimate(MapRequest(**{**TINY, "la_from": -0.4}))
    assert jobs.seconds_per_work("deformable", "preview", "steps", "decided") == rate
    assert jobs.seconds_per_work("deformable", "preview", "steps", "full") is None


def test_the_probe_measures_the_maps_own_seconds_per_step(tmp_path, monkeypatch):
    """The probe's rate is the map's: its points drawn by their expected
    work (vibtrans.maps.cost.probe_points) and timed whole
    (cost.timed_point).  Here each point costs a fixed 5 ms (its Python: a
    preview point's most) plus 1 ns per expected step: the map's seconds
    per step are their sum over its expected steps.  Nine points on a
    lattice, each weighed by its steps, made the rate of the window's
    cheap points (issue 32 item 5: the first preview map was estimated at
    3.4 s and took 1.5 s)."""
    import vibtrans.maps.cost as cost
    request = MapRequest(**{**TINY, "periods": 2000.0, "tau": 50.0, "cells": 4, "levels": 2,
                            "la_from": -1.5, "la_to": 1.5, "lm_from": -1.5, "lm_to": 1.5})
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, processes=False)
    work, unit, computed = jobs.expected_work(request)
    expected = work * jobs._share(request)
    la, lm = request.axes()
    where = {(a, m): (i, j) for i, a in enumerate(la) for j, m in enumerate(lm)}

    def fake(values, log_a, log_m, chaos, stop):
        i, j = where[(log_a, log_m)]
        whole = 5e-3 + 1e-9 * expected[i, j]
        return {"seconds": whole / 1.25}, whole      # the run's own: 80% of it
    monkeypatch.setattr(cost, "timed_point", fake)
    rate = jobs.measure_speed(request, work, unit, computed)
    truth = ((5e-3 + 1e-9 * expected) * computed).sum() / (expected * computed).sum()
    assert rate == pytest.approx(truth, rel=0.15)
    # the maps after it scale their points' run seconds by the whole's share
    assert jobs.whole_over_run(("deformable", "preview", unit, "decided")) == pytest.approx(1.25)


def test_the_url_form_round_trips_and_names_a_bad_value():
    request = MapRequest(model="point-mass", mu=0.45, theta=1.1, nu=0.25, tau=20.0,
                         periods=150.0, fidelity="preview", stick_rule="classical",
                         alpha_t=0.2, la_from=-3.5, la_to=4.25, lm_from=-6.0, lm_to=7.0,
                         cells=3, levels=2)
    text = maprequest.encode(request)
    back, errors = maprequest.decode(text)
    assert errors == [] and back.values() == request.values()
    assert maprequest.encode(back) == text
    parts = text.split(",")
    bad = ",".join([*parts[:1], "2", *parts[2:]])           # mu = 2
    none, errors = maprequest.decode(bad)
    assert none is None and errors == [
        "URL parameter 'map': mu must be a number in [0.01, 1.0]; got '2'"]
    bad = ",".join([*parts[:-3], "2.5", *parts[-2:]])       # levels not an integer
    assert "levels must be an integer in [1, 6]; got '2\\.5'" in maprequest.decode(bad)[1][0]
    assert "must hold 18 comma-separated values" in maprequest.decode("deformable,0.3")[1][0]
    assert "must hold 18" in maprequest.decode(text + ",full")[1][0]
    bad = ",".join([*parts[:-2], "fast", parts[-1]])
    assert "URL parameter 'map': stop must be one of decided, full; got 'fast'" in \
        maprequest.decode(bad)[1][0]
    swapped = ",".join([*parts[:10], parts[11], parts[10], *parts[12:]])
    assert "'from' (4.25) must be below its 'to' (-3.5)" in maprequest.decode(swapped)[1][0]


def test_a_new_request_stops_each_point_once_decided_and_an_old_link_meant_full_runs():
    """A link written before the stopping rule was part of the request (its
    16 values) meant full runs and still does; a new request is decided."""
    assert MapRequest().stop == "decided"
    for stop in ("decided", "full"):
        request = MapRequest(**{**TINY, "stop": stop})
        text = maprequest.encode(request)
        assert text.endswith(f",{stop},sphere")
        back, errors = maprequest.decode(text)
        assert errors == [] and back.values() == request.values()
    old = maprequest.encode(MapRequest(**TINY)).rsplit(",", 2)[0]      # the 16 older values
    back, errors = maprequest.decode(old)
    assert errors == [] and back.stop == "full"
    assert back.values() == MapRequest(**{**TINY, "stop": "full"}).values()
    assert maprequest.encode(back) == old + ",full,sphere"   # written again with its rule
    # the sweep it runs, and the title over its map, carry the rule
    assert MapRequest(**TINY).sweep().stop == "decided" and back.sweep().stop == "full"
    assert "stop: decided" in MapRequest(**TINY).title() and "stop: full" in back.title()


def test_the_cache_key_holds_the_stopping_rule_and_a_full_map_keeps_its_old_key():
    from vibtrans.maps.cache import request_key
    full = MapRequest(**{**TINY, "stop": "full"})
    decided = MapRequest(**{**TINY, "stop": "decided"})
    assert request_key(full.cache_request()) != request_key(decided.cache_request())
    assert decided.cache_request()["stop"] == "decided"
    # a full map's key is the one it had before the rule existed (its store's
    # attributes name no rule either: vibtrans.maps.sweep.Sweep.attrs)
    assert "stop" not in full.cache_request()
    assert "stop" not in full.sweep().attrs() and decided.sweep().attrs()["stop"] == "decided"


def test_the_estimate_scales_each_point_s_work_by_the_periods_it_is_expected_to_run(tmp_path):
    """Under the decided rule a point runs a share of its T_obs: inside a
    shipped map the share its class there runs (maprequest.reference_share:
    vibtrans.maps.cost.decided_class, class_periods), beyond it the
    model's profile (vibtrans.maps.cost.expected_periods), or one measured
    on this server's last map; the runs' part of the estimate scales by the
    work-weighted share; the bound on the steps stays that of full runs."""
    from vibtrans.maps.cost import (CLASS_PERIODS, DECIDED_PROFILE, class_periods,
                                    decided_class, expected_periods)
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=2)
    long = {**TINY, "periods": 2000.0, "tau": 50.0}
    seconds = {}
    rates = {"full": 0.5, "decided": 1e-7}    # s per shipped second, per step
    for stop, unit in (("full", "reference"), ("decided", "steps")):
        jobs._rates[("deformable", "preview", unit, stop)] = rates[stop]
        request = MapRequest(**{**long, "stop": stop})
        est, problems = jobs.estimate(request)
        assert problems == [] and est.stop == stop
        seconds[stop] = est.seconds - mapjobs.MAP_START_SECONDS \
            - est.computed * mapjobs.POINT_PASSAGE_SECONDS
        steps = est.steps
    request = MapRequest(**long)
    work, unit, computed = jobs.expected_work(request)
    assert unit == "steps"
    # each point's share: its class on the shipped map, nearest point
    shipped = data.drift_map("deformable", 0.3)
    la, lm = request.axes()
    near = shipped.sel(log_amplitude=la, log_mass=lm, method="nearest")
    classes = decided_class(near["drift_velocity"].values, near["final_drift_velocity"].values,
                            near["chaotic"].values, near["contact"].values,
                            near["takeoffs_per_period"].values)
    per_point = class_periods("deformable", classes, 2000.0, 50.0, "preview") / 2000.0
    np.testing.assert_array_equal(maprequest.reference_share(request, shipped), per_point)
    share = float((work * computed * per_point).sum() / (work * computed).sum())
    assert 0.1 < share < 1.0 and est.share == pytest.approx(share)
    # the runs' seconds: the share of the expected points' steps, at the rate
    assert seconds["decided"] == pytest.approx(share * (work * computed).sum() * 1e-7 / 2)
    full_work, full_unit, full_computed = jobs.expected_work(MapRequest(**{**long,
                                                                          "stop": "full"}))
    assert full_unit == "reference"
    assert seconds["full"] == pytest.approx((full_work * full_computed).sum() * 0.5 / 2)
    assert steps == maprequest.bound_steps(request).sum()
    assert f"about {share:.0%} of its periods expected" in est.text(2)
    assert maprequest.reference_share(MapRequest(**{**long, "stop": "full"}), shipped) is None
    # the class table's settings: a class's periods move with the rule's minimum
    assert CLASS_PERIODS["point-mass"] != CLASS_PERIODS["deformable"]
    # beyond the shipped maps: the model's profile, or this server's own
    far = {**long, "la_from": 4.0, "la_to": 5.0}
    jobs._rates[("deformable", "preview", "steps", "decided")] = 1e-7
    est, _ = jobs.estimate(MapRequest(**far))
    assert est.share == pytest.approx(
        expected_periods("deformable", "decided", 2000.0, 50.0, None, "preview") / 2000.0)
    assert DECIDED_PROFILE["point-mass"] != DECIDED_PROFILE["deformable"]
    np.testing.assert_allclose(maprequest.expected_steps(MapRequest(**far)),
                               est.share * maprequest.bound_steps(MapRequest(**far)))
    jobs._profiles["deformable"] = (0.5, 100.0)
    est, _ = jobs.estimate(MapRequest(**far))
    own = expected_periods("deformable", "decided", 2000.0, 50.0, (0.5, 100.0), "preview") / 2000.0
    assert est.share == pytest.approx(own)


def test_a_decided_map_teaches_the_server_its_profile_and_its_rate_per_period_run(tmp_path):
    """A map long enough for the rule to stop points: its computed points
    carry periods_run below T_obs; the server keeps its profile (what
    vibtrans.maps.cost.decided_profile measures on those points) for the next
    estimate, and its rate under the decided rule only."""
    from vibtrans.maps.cost import decided_profile, expected_periods, minimum_periods
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, processes=False)
    request = MapRequest(**{**TINY, "periods": 300.0})        # t_min 93 at tau 5
    got = Listener()
    jobs.submit("a", request, got)
    done = got.wait()
    assert done.kind == "done", got.kinds()
    computed = done.ds["computed"].values
    run = done.ds["periods_run"].values[computed]
    assert run.min() >= minimum_periods(5.0, "preview") and (run < 300.0).any()
    f_end, extra = jobs.profile("deformable")
    mine = done.ds[["periods_run", "stop_reason"]].where(done.ds["computed"])
    mine.attrs = dict(done.ds.attrs)
    assert (f_end, extra) == decided_profile(mine)
    # its own mean periods run, reproduced by the profile (f_end, extra)
    assert expected_periods("deformable", "decided", 300.0, 5.0, (f_end, extra), "preview") == \
        pytest.approx(run.mean())
    # its rate is the decided rule's, never the full runs': its points' own
    # seconds per bounded step run (no probe before it: their run's seconds
    # alone), not its wall time less its fixed costs, which grow with the
    # host's load and a small map's runs do not outweigh
    rate = jobs.seconds_per_work("deformable", "preview", "steps", "decided")
    work = jobs.expected_work(request)[0][computed]
    assert rate == pytest.approx(np.nansum(done.ds["seconds"].values[computed])
                                 / (work * run / 300.0).sum())
    assert jobs.seconds_per_work("deformable", "preview", "steps", "full") is None
    # and the periods each class (read on the shipped map) ran, for the next
    # estimates at these settings (vibtrans.maps.cost.learn_class_periods)
    from vibtrans.maps.cost import LEARN_MIN_POINTS, class_periods
    classes = maprequest.reference_classes(request, data.drift_map("deformable", 0.3))[computed]
    learned = jobs._class_periods[mapjobs._class_key(request)]
    for c in range(len(learned)):
        seen = classes == c
        if seen.sum() >= LEARN_MIN_POINTS:
            assert learned[c] == pytest.approx(run[seen].mean())
        else:
            assert np.isnan(learned[c])
    assert np.isfinite(learned).any()
    jobs._rates.setdefault(("deformable", "preview", "steps", "decided"), 1e-3)
    again = MapRequest(**{**TINY, "periods": 300.0, "mu": 0.5})
    est, _ = jobs.estimate(again)
    work, _, expected = jobs.expected_work(again)
    per_point = class_periods("deformable", maprequest.reference_classes(
        again, data.drift_map("deformable", 0.3)), 300.0, 5.0, "preview", learned) / 300.0
    assert est.share == pytest.approx(
        float((work * expected * per_point).sum() / (work * expected).sum()))


def test_the_cache_key_ignores_what_changes_no_number():
    base = MapRequest(**TINY)
    # the material point's rules do not enter a deformable map
    same = MapRequest(**{**TINY, "stick_rule": "classical", "alpha_t": 0.1})
    assert base.cache_request() == same.cache_request()
    for change in ({"mu": 0.31}, {"periods": 31.0}, {"la_to": 0.6}, {"levels": 2},
                   {"fidelity": "standard"}, {"stop": "full"}):
        assert MapRequest(**{**TINY, **change}).cache_request() != base.cache_request()


# ------------------------------------------------------------------ the explorer's side
def _explorer(monkeypatch, query):
    import panel as pn
    from panel.io.location import Location
    from urllib.parse import parse_qs
    from vibtrans_explorer import explorer as E
    monkeypatch.setattr(E, "_page_location", lambda: Location(search="?" + query))
    args = {k: [v.encode() for v in vs] for k, vs in parse_qs(query).items()}
    monkeypatch.setattr(type(pn.state), "session_args", property(lambda self: args))
    return E.Explorer()


def test_a_link_with_a_map_request_shows_it_and_a_bad_one_says_why(monkeypatch):
    request = MapRequest(**{**TINY, "mu": 0.45})
    text = maprequest.encode(request)
    e = _explorer(monkeypatch, f"map={text}&mu=0.45&la=0.1&lm=0.5")
    assert e.state.map_request == text and e._url_map.values() == request.values()
    assert e.state.mu == 0.45 and not e.message.visible      # the map's own mu: no reset
    assert f"map={text.replace(',', '%2C')}" in e.location.search
    e._back_to_shipped()                                      # the request leaves the link
    assert e.state.map_request is None and "map=" not in e.location.search
    assert e.state.mu == 0.3                                  # a shipped map's, and said so
    bad = _explorer(monkeypatch, "map=" + text.replace("deformable", "rigid"))
    assert bad.state.map_request is None
    assert "URL parameter 'map': model must be one of deformable, point-mass; got 'rigid'" \
        in bad.message.object


def test_zooming_the_shipped_map_beyond_its_resolution_offers_a_refinement(monkeypatch):
    e = _explorer(monkeypatch, "")
    e.main()
    fig = e.map_view.figures[0]
    fig.x_range.start, fig.x_range.end = -1.0, 1.0        # 40 cells of 0.05: no offer
    fig.y_range.start, fig.y_range.end = 0.0, 2.0
    assert e.refine_button is None and not e.refine_box.visible
    fig.x_range.start, fig.x_range.end = 0.1, 0.3         # 4 x 4 cells
    fig.y_range.start, fig.y_range.end = 0.5, 0.7
    assert e.refine_box.visible and e.refine_button.visible
    e._refine_window()
    r = e.map_request_panel.request
    shipped = e._shipped_request()        # the shipped map's stored scene
    assert (r.la_from, r.la_to, r.lm_from, r.lm_to) == (0.1, 0.3, 0.5, 0.7)
    assert (r.tau, r.periods, r.fidelity, r.model, r.mu) == (
        shipped.tau, shipped.periods, shipped.fidelity, "deformable", 0.3)
    assert e.map_tabs.active == 3


@pytest.mark.slow
def test_a_cluster_computes_the_same_map_and_can_cancel_it(tmp_path):
    """`vibtrans serve --scheduler`: the points run on a dask.distributed
    cluster (here a LocalCluster) and the map equals the local one; a cancel
    drops the cluster's queued points."""
    from dask.distributed import LocalCluster
    local = mapjobs.MapJobs(folder=str(tmp_path / "local"), cores=1)
    mine = Listener()
    local.submit("a", MapRequest(**TINY), mine)
    expected = mine.wait()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:
        remote = mapjobs.MapJobs(folder=str(tmp_path / "remote"), cores=1,
                                 scheduler=cluster.scheduler_address)
        theirs = Listener()
        remote.submit("a", MapRequest(**TINY), theirs)
        got = theirs.wait()
        assert got.kind == "done" and not got.cached, theirs.kinds()
        for v in ("drift_velocity", "drift", "chaotic", "computed"):
            np.testing.assert_array_equal(got.ds[v].values, expected.ds[v].values)
        bigger = MapRequest(**{**TINY, "cells": 4, "levels": 2})      # 17 x 17
        cancelled = Listener()

        def cancel_at_first_level(update):
            cancelled(update)
            if update.kind == "level":
                remote.cancel("b")
        remote.submit("b", bigger, cancel_at_first_level)
        assert cancelled.wait().kind == "cancelled", cancelled.kinds()
        # the computation ends (its queued points dropped), leaving no map
        deadline = time.monotonic() + budget(120)
        while remote._running and time.monotonic() < deadline:
            time.sleep(0.1)
        from vibtrans.maps.cache import request_key
        assert not remote._running
        assert remote.cache.get(request_key(bigger.cache_request())) is None


def test_worker_processes_compute_the_threads_map_and_stop_after_it(tmp_path, monkeypatch):
    """The points run in worker processes by default (their Python off the
    server's GIL), with the same results as in threads of the server; the
    processes are gone WORKERS_LINGER after no map computes (their memory
    with them), or at `stop_workers`."""
    monkeypatch.setattr(mapjobs, "WORKERS_LINGER", 0.5)
    threads = mapjobs.MapJobs(folder=str(tmp_path / "threads"), cores=1, processes=False)
    mine = Listener()
    threads.submit("a", MapRequest(**TINY), mine)
    expected = mine.wait()
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "processes"), cores=1)
    assert jobs.processes
    theirs = Listener()
    jobs.submit("a", MapRequest(**TINY), theirs)
    got = theirs.wait()
    assert got.kind == "done" and not got.cached, theirs.kinds()
    for v in ("drift_velocity", "drift", "chaotic", "computed", "lyapunov", "steps"):
        np.testing.assert_array_equal(got.ds[v].values, expected.ds[v].values)
    assert jobs._workers.processes and threads._workers is not None
    assert not threads._workers.processes
    deadline = time.monotonic() + budget(60)
    while jobs._workers.processes_up() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not jobs._workers.processes_up()
    monkeypatch.setattr(mapjobs, "WORKERS_LINGER", 600.0)
    again = mapjobs.MapJobs(folder=str(tmp_path / "again"), cores=1)
    mine = Listener()
    again.submit("a", MapRequest(**TINY), mine)
    assert mine.wait().kind == "done"
    time.sleep(0.5)
    assert again._workers.processes_up()            # lingering for the next map
    again.stop_workers()
    assert not again._workers.processes_up()


def test_the_environment_switches_the_map_workers_to_threads(monkeypatch):
    monkeypatch.setattr(mapjobs, "_JOBS", {"jobs": None, "settings": {}})
    monkeypatch.setenv("VIBTRANS_MAP_PROCESSES", "0")
    assert mapjobs.jobs().processes is False
    monkeypatch.setattr(mapjobs, "_JOBS", {"jobs": None, "settings": {}})
    monkeypatch.setenv("VIBTRANS_MAP_PROCESSES", "2")
    with pytest.raises(mapjobs.InputError, match=r"VIBTRANS_MAP_PROCESSES must be a number "
                                                 r"in \[0, 1\], got '2'"):
        mapjobs.jobs()


@pytest.mark.parametrize("argv, message", [
    (["--scheduler", "localhost:8786"], "scheduler must be an address such as tcp://HOST:PORT"),
    (["--map-cores", "0"], "map-cores must be in [1, 256]"),
    (["--map-cache-mb", "0"], "map-cache-mb must be in [1, 10000000]"),
])
def test_serve_refuses_bad_map_settings_before_starting(capsys, argv, message):
    from vibtrans.cli import main
    try:
        code = main(["serve", "--port", "5999", *argv])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err, err


def test_a_closing_page_cancels_its_map(monkeypatch, tmp_path, gate):
    """A session that closes while its map waits cancels it (unless another
    session waits for it too): the explorer's session-destroyed callback."""
    made = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1,
                           build=lambda comp, path, on_level: gate.wait(60))
    monkeypatch.setattr(mapjobs, "jobs", lambda: made)
    e = _explorer(monkeypatch, "")
    mine = Listener()
    made.submit(e._map_session, MapRequest(**TINY), mine)
    assert made.busy() == (1, 1)
    e._on_session_destroyed(None)
    assert mine.wait(5).kind == "cancelled" and made.busy() == (0, 0)
    gate.set()


def test_a_small_map_asked_for_later_is_not_starved_by_a_big_one(tmp_path):
    """Maps share the server's workers in turn (app/fairshare.py): on one
    core, a 5 x 5 map asked for while a 33 x 33 map computes finishes
    first, and both maps equal the ones computed alone."""
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    big_request = MapRequest(**{**TINY, "cells": 8, "levels": 2})       # 33 x 33
    small_request = MapRequest(**{**TINY, "mu": 0.5})
    ended = []
    big, small = Listener(), Listener()

    def on_big(update):
        big(update)
        if update.final:
            ended.append("big")
        elif update.kind == "level" and update.level == 0:
            # the big map's coarse level is drawn: now a small map is asked for
            jobs.submit("small", small_request, on_small)

    def on_small(update):
        small(update)
        if update.final:
            ended.append("small")
    jobs.submit("big", big_request, on_big)
    assert small.wait().kind == "done" and big.wait().kind == "done", (big.kinds(),
                                                                       small.kinds())
    assert ended == ["small", "big"]
    assert "queued" not in small.kinds()
    alone = mapjobs.MapJobs(folder=str(tmp_path / "alone"), cores=1)
    for request, shared in ((small_request, small), (big_request, big)):
        solo = Listener()
        alone.submit("a", request, solo)
        got = solo.wait()
        for v in ("drift_velocity", "drift", "chaotic", "computed"):
            np.testing.assert_array_equal(got.ds[v].values, shared.updates[-1].ds[v].values)


@pytest.mark.parametrize("slow_cache_read", ["first", "second"])
def test_beyond_the_running_maps_a_request_waits_its_turn(tmp_path, gate, slow_cache_read):
    """With max_running maps computing, the next one says it waits, whichever
    of two requests reaches the queue first (a slow cache read lets the
    second overtake the first, as a busy machine can)."""
    def build(comp, path, on_level):
        assert gate.wait(60)
        made._run_adaptive(comp, path, on_level)
    made = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, build=build,
                           max_running=1)
    read = made.cache.get
    slow_key = mapjobs.request_key(MapRequest(**(TINY if slow_cache_read == "first" else
                                                 {**TINY, "mu": 0.5})).cache_request())

    def get(key):
        if key == slow_key:
            time.sleep(0.5)
        return read(key)
    made.cache.get = get
    first, second = Listener(), Listener()
    made.submit("a", MapRequest(**TINY), first)
    made.submit("b", MapRequest(**{**TINY, "mu": 0.5}), second)
    # the two requests open the cache on two threads: either may reach the
    # queue first, and the other is the one that waits
    deadline = time.monotonic() + budget(60)
    while ("queued" not in first.kinds() + second.kinds()
           and time.monotonic() < deadline):
        time.sleep(0.05)
    gate.set()
    assert first.wait().kind == "done" and second.wait().kind == "done"
    queued = [u for listener in (first, second) for u in listener.updates
              if u.kind == "queued"]
    assert len(queued) == 1 and "1 map(s) computing and 0 waiting" in queued[0].text


def test_a_map_is_pictured_within_its_levels(tmp_path, monkeypatch):
    """Every CHUNK_SECONDS within a refinement level, the map so far: chunk
    updates between the levels, each a complete picture (no NaN), their
    computed points growing, the last update the map."""
    from vibtrans.maps import adaptive
    monkeypatch.setattr(mapjobs, "CHUNK_SECONDS", 0.0)
    monkeypatch.setattr(adaptive, "POINTS_PER_TASK", 1)
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    got = Listener()
    jobs.submit("a", MapRequest(**{**TINY, "levels": 2}), got)       # 9 x 9
    assert got.wait().kind == "done", got.kinds()
    kinds = got.kinds()
    assert kinds[0] == "level" and kinds.count("level") == 3 and "chunk" in kinds
    assert kinds.index("chunk") > 0                     # not within the coarse grid
    pictures = [u for u in got.updates if u.kind in ("level", "chunk", "done")]
    counts = [int(u.ds["computed"].values.sum()) for u in pictures]
    assert counts == sorted(counts)
    for u in pictures:
        assert np.isfinite(u.ds["drift_velocity"].values).all(), u.kind
        assert u.kind != "chunk" or 1 <= u.level <= 2


def test_the_finished_map_is_not_drawn_again_when_its_last_level_showed_it():
    """`same_values`: the verified map equals the finest level's map value
    for value (then the "done" update says `shown`, and the explorer and the
    Design tab keep their picture: no second render, no redraw in every
    browser); any difference draws it."""
    import xarray as xr
    grid = np.arange(6.0).reshape(2, 3)
    drawn = xr.Dataset({"drift_velocity": (("a", "m"), grid),
                        "chaotic": (("a", "m"), grid > 2),
                        "lyapunov": (("a", "m"), np.where(grid > 4, np.nan, grid))})
    stored = drawn.assign(digest=("a", np.zeros(2)))      # the store holds more
    assert mapjobs.same_values(drawn, stored)
    changed = stored.copy(deep=True)
    changed["drift_velocity"].values[1, 2] += 1e-12
    assert not mapjobs.same_values(drawn, changed)
    assert not mapjobs.same_values(drawn, stored.drop_vars("chaotic"))


# ------------------------------------------------------------------ the particle's profile (issue 34)
def test_a_profile_is_the_requests_18th_value_and_an_older_link_meant_the_sphere():
    cone = MapRequest(**{**TINY, "profile": "cone"})
    text = maprequest.encode(cone)
    assert text.endswith(",decided,cone")
    back, errors = maprequest.decode(text)
    assert errors == [] and back.values() == cone.values()
    # a link of the 17 values (written before profiles): the sphere
    old = text.rsplit(",", 1)[0]
    back, errors = maprequest.decode(old)
    assert errors == [] and back.profile == "sphere" and back.stop == "decided"
    # a bad profile named with the explorer's kinds; a measured table refused
    for bad in ("power:0.5", "file:/etc/passwd", "ellipsoid"):
        none, errors = maprequest.decode(text.rsplit(",", 1)[0] + "," + bad)
        assert none is None and len(errors) == 1
        assert errors[0].startswith("URL parameter 'map': profile must be one of sphere, cone, "
                                    "power:N (N ≥ 1), flat-sphere:C"), errors
    with pytest.raises(ValueError, match=r"exponent n must be a real number in \[1, inf\)"):
        MapRequest(profile="power:0.9")


def test_a_profiles_map_runs_keys_and_says_its_profile_and_the_material_point_has_none():
    from vibtrans.maps.cache import request_key
    sphere = MapRequest(**TINY)
    cone = MapRequest(**{**TINY, "profile": "cone"})
    flat = MapRequest(**{**TINY, "profile": "flat-sphere:0.5"})
    keys = {request_key(r.cache_request()) for r in (sphere, cone, flat)}
    assert len(keys) == 3
    # the sphere's key is the one it had before profiles (its scene's default)
    assert sphere.cache_request()["scene"]["profile"] == "sphere"
    assert "profile" not in sphere.scene_values() and "profile" not in sphere.sweep().attrs()
    assert cone.sweep().values["profile"] == "cone"
    assert cone.sweep().attrs()["scene_profile"] == "cone"
    assert "profile cone" in cone.title() and "profile" not in sphere.title()
    # the material point is rigid: one map whatever the profile says
    pm = MapRequest(**{**TINY, "model": "point-mass"})
    pm_cone = MapRequest(**{**TINY, "model": "point-mass", "profile": "cone"})
    assert pm.cache_request() == pm_cone.cache_request() and not pm_cone.profiled()
    assert "profile" not in pm_cone.title()


def test_a_profiles_estimate_takes_its_own_steps_and_its_kernels_cost():
    """Each point's steps are the profile's (the library's estimate_steps:
    its own contact time scale), and its work per step is the profile's
    kernel cost over the sphere's (PROFILE_STEP_COST); the reference map
    (the sphere's) is scaled by the sphere's steps."""
    from vibtrans import Scene, estimate_steps
    for profile in ("cone", "power:3", "flat-sphere:0.5"):
        request = MapRequest(**{**TINY, "profile": profile, "la_from": 2.0, "la_to": 3.0})
        la, lm = request.axes()
        for a, m in ((la[0], lm[0]), (la[-1], lm[-1])):
            assert maprequest.point_steps(request, a, m) == estimate_steps(
                Scene(amplitude=10 ** a, mass=10 ** m, **request.scene_values()))
    # where the impacts set the step, a cone's differ from the sphere's
    cone = MapRequest(**{**TINY, "profile": "cone", "la_from": 2.0, "la_to": 3.0})
    sphere = MapRequest(**{**TINY, "la_from": 2.0, "la_to": 3.0})
    assert maprequest.point_steps(cone, 3.0, 0.0) != maprequest.point_steps(sphere, 3.0, 0.0)
    assert maprequest.step_cost(sphere) == 1.0
    # each contact-law path at its measured cost (the cone's N*' is linear:
    # no root to take, the sphere's cost)
    assert maprequest.step_cost(cone) == maprequest.PROFILE_STEP_COST["cone"]
    power = MapRequest(**{**TINY, "profile": "power:3"})
    assert maprequest.step_cost(power) == maprequest.PROFILE_STEP_COST["power"] > 1.0
    fractional = MapRequest(**{**TINY, "profile": "power:2.5"})
    assert (maprequest.step_cost(fractional) == maprequest.PROFILE_STEP_COST["power-pow"]
            > maprequest.step_cost(power))
    flat = MapRequest(**{**TINY, "profile": "flat-sphere:0.5"})
    assert maprequest.step_cost(flat) == maprequest.PROFILE_STEP_COST["table"] > 1.0
    assert maprequest.step_cost(MapRequest(**{**TINY, "model": "point-mass",
                                              "profile": "cone"})) == 1.0
    # the estimate: the sphere's reference seconds, the profile's steps over
    # the sphere's, times its cost per step
    jobs = mapjobs.MapJobs(folder=None, cores=2)
    shipped = data.drift_map("deformable", 0.3)
    for request in (MapRequest(**{**TINY, "profile": "cone"}), power, flat):
        # a decided map: the profile's bounded steps times its cost per step
        work, unit, computed = jobs.expected_work(request)
        assert unit == "steps"
        np.testing.assert_allclose(work, maprequest.bound_steps(request)
                                   * maprequest.step_cost(request))
        request = MapRequest(**{**request.values(), "stop": "full"})
        work, unit, computed = jobs.expected_work(request)
        assert unit == "reference"
        point = shipped["seconds"].sel(log_amplitude=0.0, log_mass=0.5).item()
        ref = MapRequest(**{**TINY, "periods": 2000.0, "fidelity": "standard"})
        assert work[2, 2] == pytest.approx(point * maprequest.TWIN_SHARE
                                           * maprequest.step_cost(request)
                                           * maprequest.point_steps(request, 0.0, 0.5)
                                           / maprequest.point_steps(ref, 0.0, 0.5))


def test_a_cone_map_on_demand_is_the_cones(jobs, gate):
    """Computed end to end: its store names the cone, and its points are
    the cone's runs (the library's compute_point with the request's values)."""
    from vibtrans.maps.sweep import compute_point
    gate.set()
    got = Listener()
    request = MapRequest(**{**TINY, "profile": "cone"})
    jobs.submit("a", request, got)
    done = got.wait()
    assert done.kind == "done", got.kinds()
    assert done.ds.attrs["scene_profile"] == "cone"
    la, lm = request.axes()
    own = compute_point(request.scene_values(), la[0], lm[0], maprequest.CHAOS, request.stop)
    assert done.ds["drift_velocity"].values[0, 0] == own["drift_velocity"]


def test_the_page_says_when_the_map_shown_is_not_the_particles(monkeypatch):
    """The shipped maps are the sphere's: with a cone selected the page says
    so over the map and offers the cone's map on demand; a click on a map
    on demand runs its own particle."""
    e = _explorer(monkeypatch, "profile=cone&la=0.1&lm=0.5")
    o = e.ondemand
    assert o.profile_box.visible and o.profile_note.visible
    assert "This map is the sphere's" in o.profile_note.object
    assert "not the selected cone's" in o.profile_note.object
    assert o.profile_button.name == "Map on demand for cone"
    o.request_for_profile()
    panel = o.map_request_panel
    assert panel.request.profile == "cone" and panel.profile.kind.value == "cone"
    assert panel.request.la_from == pytest.approx(-0.4)      # the scene's neighbourhood
    # the material point is rigid: no warning
    e.state.model = "point-mass"
    assert not o.profile_box.visible
    e.state.model = "deformable"
    assert o.profile_box.visible
    e.state.profile = "power:2"                 # the sphere's own law
    assert not o.profile_box.visible
    # a click on a sphere's map on demand runs the sphere, on a cone's the cone
    runs = []
    monkeypatch.setattr(o, "run", lambda: runs.append(e.state.scene().profile))
    e.state.profile = "cone"
    o._on_computed_click(MapRequest(**TINY), 0.0, 0.5)
    o._on_computed_click(MapRequest(**{**TINY, "profile": "flat-sphere:0.5"}), 0.0, 0.5)
    assert runs == ["sphere", "flat-sphere:0.5"]


def test_the_refinement_is_replayed_on_the_verdicts_maps_on_demand_judge_by(tmp_path):
    """The replay of the refinement on the shipped map (its prediction of
    the points a map computes) reads the chaos verdict that maps on demand
    judge by (the run's own exponent: maprequest.CHAOS).  The shipped
    deformable maps' verdict is that one; the material point's shipped map
    judged chaos by the tau twin and calls the plane's middle a chaotic sea
    that the replay left whole, where the runs' exponents draw boundaries
    (mapestimate's 33 x 33 material-point map computed 446 points where 270
    were predicted).  Its not-steady points' refinement is added by
    cost.NOT_STEADY_REFINED's share of the replay with their drifts unknown."""
    from vibtrans.analysis.summary import CHAOS_LYAPUNOV
    from vibtrans.maps.adaptive import predict_refinement
    from vibtrans.maps.cost import NOT_STEADY, NOT_STEADY_REFINED, decided_class
    for model, mu in data.available_maps():
        shipped = data.drift_map(model, mu)
        replay = maprequest.replay_reference(shipped)
        lam = shipped["lyapunov"].values
        np.testing.assert_array_equal(replay["chaotic"].values,
                                      np.isfinite(lam) & (lam > CHAOS_LYAPUNOV))
        if model == "deformable":
            np.testing.assert_array_equal(replay["chaotic"].values, shipped["chaotic"].values)
    shipped = data.drift_map("point-mass", 0.3)
    assert (maprequest.replay_reference(shipped)["chaotic"].values
            != shipped["chaotic"].values).mean() > 0.05
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1)
    request = MapRequest(model="point-mass", cells=4, levels=3, la_from=-1.0, la_to=2.0,
                         lm_from=-1.0, lm_to=1.0)
    _, _, computed = jobs.expected_work(request)
    twin = predict_refinement(request.sweep(), request.levels, shipped)
    assert computed.sum() > 1.5 * twin.sum()
    # each point's class (the periods it is expected to run) with that verdict
    # too: cost.CLASS_PERIODS's material-point row was measured so
    near = np.ix_(*maprequest.nearest_points(request, shipped))
    fields = ("drift_velocity", "final_drift_velocity", "chaotic", "contact",
              "takeoffs_per_period")
    classes = maprequest.reference_classes(request, shipped)
    replayed_classes = decided_class(*(maprequest.replay_reference(shipped)[n].values[near]
                                       for n in fields))
    np.testing.assert_array_equal(classes, replayed_classes)
    assert (classes != decided_class(*(shipped[n].values[near] for n in fields))).any()
    # the not-steady points' drifts unknown: NaN there, nothing else changed
    deformable = maprequest.replay_reference(data.drift_map("deformable", 0.3))
    unknown = maprequest.unknown_drift_reference(deformable)
    classes = decided_class(*(deformable[n].values for n in (
        "drift_velocity", "final_drift_velocity", "chaotic", "contact", "takeoffs_per_period")))
    v, u = deformable["drift_velocity"].values, unknown["drift_velocity"].values
    assert np.isnan(u[classes == NOT_STEADY]).all() and (classes == NOT_STEADY).any()
    np.testing.assert_array_equal(u[classes != NOT_STEADY], v[classes != NOT_STEADY])
    preview = MapRequest(fidelity="preview", cells=4, levels=3, la_from=-2.0, la_to=2.0,
                         lm_from=-2.0, lm_to=2.0)
    replayed, full = jobs._predicted(preview)[2]
    _, _, computed = jobs.expected_work(preview)
    q = NOT_STEADY_REFINED[("deformable", "preview")]
    assert full.sum() > replayed.sum()
    assert computed.sum() == pytest.approx(replayed.sum() + q * (full.sum() - replayed.sum()))


def test_a_map_computed_alone_teaches_the_server_its_own_work(tmp_path, gate):
    """A map's own work (its start, its points' passage: MAP_START_SECONDS,
    POINT_PASSAGE_SECONDS) is this server's: the constants, measured on one
    host, made every estimate 1.3-2x the time on a faster one
    (devtools/mapestimate.py).  Before any map the factor is 1 (no probe
    here); a map computed alone sets it to its wall time less its runs over
    the constants' (a second's wait in its build counted as its own work);
    two maps computed side by side teach nothing (their wall times share
    the workers); and the estimate scales both constants by it."""
    def build(comp, path, on_level):
        assert gate.wait(60)
        time.sleep(1.0)
        jobs._run_adaptive(comp, path, on_level)
    jobs = mapjobs.MapJobs(folder=str(tmp_path / "maps"), cores=1, processes=False,
                           build=build)
    assert jobs.own_factor() == 1.0
    # side by side: nothing learned
    pair = [Listener(), Listener()]
    jobs.submit("a", MapRequest(**TINY), pair[0])
    jobs.submit("b", MapRequest(**{**TINY, "la_to": 0.6}), pair[1])
    until = time.perf_counter() + budget(30)
    while len(jobs._running) < 2:
        assert time.perf_counter() < until
        time.sleep(0.01)
    gate.set()
    assert [p.wait().kind for p in pair] == ["done", "done"]
    assert jobs.own_factor() == 1.0 and jobs._own_sums is None
    # alone: its own work, the wait included
    alone = Listener()
    jobs.submit("c", MapRequest(**{**TINY, "la_to": 0.7}), alone)
    done = alone.wait()
    assert done.kind == "done"
    n = int(done.ds["computed"].values.sum())
    constants = mapjobs.MAP_START_SECONDS + n * mapjobs.POINT_PASSAGE_SECONDS
    assert jobs.own_factor() * constants >= 1.0
    # the estimate's own work is the constants scaled by it
    request = MapRequest(**{**TINY, "la_to": 0.8})
    jobs._rates[("deformable", "preview", "steps", "decided")] = 1e-9
    est, problems = jobs.estimate(request)
    assert not problems
    work, unit, computed = jobs.expected_work(request)
    own = jobs.own_factor()
    assert est.seconds == pytest.approx(maprequest.estimate(
        request, 1e-9, work, computed, jobs.cores, own * mapjobs.MAP_START_SECONDS,
        own * mapjobs.POINT_PASSAGE_SECONDS, jobs.profile("deformable"),
        jobs._share(request)).seconds)
    assert est.seconds > 1.0
