"""vibtrans.analysis.summary on small synthetic trajectories with known answers.

Source: closed form.  Each dataset here is written by hand (times, x*,
events), so every expected number follows from the definitions in
docs/MODEL.md section 4 and the module's docstrings by arithmetic; every
threshold (V0, SYNC_TOL, SYNC_SPREAD, LONG_FLIGHT, the chaos tolerance, the
divergence threshold, the final window, the launch fraction) is approached
from both sides.
"""

import math

import numpy as np
import pytest
import xarray as xr

from vibtrans.analysis import summary as an
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import FLIGHT, SLIDING, STICK
from vibtrans.core.params import Scene

EPS = 1e-6
# The thresholds, as stated (literal here, so that changing one in
# analysis.py fails a test): V0, the no-drift band (docs/MODEL.md section 4,
# default v0* = 0.1); synchronous take-offs 1 +- 0.05 periods apart with a
# circular phase spread < 0.02 periods; a flight > 3 periods separates bursts;
# launched: still in flight at the end, since before half of the run.
V0 = 0.1
SYNC_TOL = 0.05
SYNC_SPREAD = 0.02
LONG_FLIGHT = 3.0
LAUNCH_FRACTION = 0.5


def traj(
    t_end=100.0,
    x_end=0.0,
    x=None,
    takeoffs=(),
    landings=(),
    phases=None,
    states=(),
    tau=50.0,
    n=1001,
    y_end=None,
    vy_end=None,
    attrs=None,
):
    """A trajectory Dataset as `simulate` returns it (the variables analysis
    reads): time, x (linear from 0 to x_end unless given) and its vx, events;
    y*, y*' constant at y_end, vy_end if given (else 0); attrs added to tau,
    steps, seconds and the scene's periods (t_end), amplitude and mass."""
    t = np.linspace(0.0, t_end, n)
    xs = np.linspace(0.0, x_end, n) if x is None else np.asarray(x, dtype=float)
    takeoffs = list(takeoffs)
    if phases is None:
        phases = [tt - math.floor(tt) for tt in takeoffs]
    ev = [(tt, R.TAKEOFF, ph) for tt, ph in zip(takeoffs, phases)]
    ev += [(tt, R.LANDING, tt - math.floor(tt)) for tt in landings]
    ev += [(tt, R.STATE_CHANGE, code) for tt, code in states]
    ev.sort(key=lambda e: (e[0], e[1]))
    ev = np.array(ev, dtype=float).reshape(-1, 3)
    data = {
        "x": ("time", xs),
        "vx": ("time", np.gradient(xs, t)),
        "state": ("time", np.zeros(n, dtype=np.int8)),
        "event_time": ("event", ev[:, 0]),
        "event_kind": ("event", ev[:, 1].astype(np.int8)),
        "event_value": ("event", ev[:, 2]),
    }
    if y_end is not None:
        data["y"] = ("time", np.full(n, float(y_end)))
        data["vy"] = ("time", np.full(n, float(vy_end)))
    else:
        data["y"] = data["vy"] = ("time", np.zeros(n))
    # (the scene's attributes the drift's steadiness reads: stopping.DecidedRule's)
    return xr.Dataset(
        data,
        coords={"time": t},
        attrs={
            "tau": tau,
            "steps": 10,
            "seconds": 0.5,
            "periods": t_end,
            "amplitude": 1.0,
            "mass": 1.0,
            **(attrs or {}),
        },
    )


def spread_pair(sigma):
    """Half-distance d of two phases +-d whose circular spread is sigma:
    |mean exp(2 pi i phase)| = cos(2 pi d) = exp(-(2 pi sigma)^2 / 2)."""
    return math.acos(math.exp(-2.0 * (math.pi * sigma) ** 2)) / (2.0 * math.pi)


# ------------------------------------------------------------------ drift
def test_drift_velocity_is_distance_over_time():
    assert an.drift_velocity(traj(t_end=200.0, x_end=-52.0)) == pytest.approx(-0.26, rel=1e-15)
    assert an.drift_velocity(traj(t_end=50.0, x_end=0.0)) == 0.0


def test_final_drift_velocity_is_the_last_tenth():
    # x = 0 until t = 90, then slope 3: the run mean is 30/100, the final 3.
    t = np.linspace(0.0, 100.0, 1001)
    ds = traj(x=np.where(t > 90.0, 3.0 * (t - 90.0), 0.0))
    assert an.drift_velocity(ds) == pytest.approx(0.3)
    assert an.final_drift_velocity(ds) == pytest.approx(3.0)
    # the slope starting just before the window (t = 89) counts only inside it
    ds = traj(x=np.where(t > 89.0, 3.0 * (t - 89.0), 0.0))
    assert an.final_drift_velocity(ds) == pytest.approx(3.0)
    assert an.drift_velocity(ds) == pytest.approx(0.33)
    assert an.final_drift_velocity(ds, fraction=0.5) == pytest.approx(33.0 / 50.0)


@pytest.mark.parametrize(
    "v, expected",
    [
        (V0 + EPS, "with-wave"),
        (V0, "none"),
        (V0 - EPS, "none"),
        (0.0, "none"),
        (-V0 + EPS, "none"),
        (-V0, "none"),
        (-V0 - EPS, "against-wave"),
        (1e3, "with-wave"),
        (-1e3, "against-wave"),
    ],
)
def test_drift_class_threshold_from_both_sides(v, expected):
    assert an.drift_class(v) == expected


def test_drift_class_takes_its_own_v0():
    assert an.drift_class(0.4, v0=0.5) == "none" and an.drift_class(0.6, v0=0.5) == "with-wave"


# ------------------------------------------------------------------ flights, contact
def test_jumped_means_a_takeoff():
    assert an.jumped(traj(takeoffs=[5.2], landings=[5.7])) is True
    assert an.jumped(traj(landings=[5.7], states=[(3.0, SLIDING)])) is False
    assert an.jumped(traj()) is False


def test_flights_pair_takeoffs_with_the_next_landing():
    # a rebound at t = 3 lands and leaves at once: flights (1, 2), (3, 5), (6, inf)
    ds = traj(takeoffs=[1.0, 3.0, 6.0], landings=[2.0, 3.0, 5.0])
    starts, ends = an.flights(ds)
    assert starts.tolist() == [1.0, 3.0, 6.0]
    assert ends.tolist() == [2.0, 5.0, math.inf]


def test_contact_fraction_over_the_final_window():
    # window [90, 100]: flights (91, 93.5) and (99, still flying): 3.5 in flight
    ds = traj(takeoffs=[50.0, 91.0, 99.0], landings=[51.0, 93.5])
    assert an.contact_fraction(ds) == pytest.approx(0.65)
    # a flight straddling the window start counts only inside it
    ds = traj(takeoffs=[89.0], landings=[90.5])
    assert an.contact_fraction(ds) == pytest.approx(0.95)
    # explicit window, and no flight at all
    assert an.contact_fraction(traj(takeoffs=[10.0], landings=[12.0]), 0.0, 20.0) == pytest.approx(0.9)
    assert an.contact_fraction(traj()) == 1.0


def test_contact_fraction_of_a_run_that_starts_in_flight():
    # state FLIGHT at t = 0: the first flight lasts until the first landing
    ds = traj(t_end=10.0, landings=[2.0], states=[(0.0, FLIGHT), (2.0, STICK)])
    assert an.contact_fraction(ds, 0.0, 10.0) == pytest.approx(0.8)
    ds = traj(t_end=10.0, landings=[2.0], states=[(0.0, STICK)])
    assert an.contact_fraction(ds, 0.0, 10.0) == 1.0


# ------------------------------------------------------------------ phases
def test_takeoff_phases_after_t0():
    ds = traj(takeoffs=[1.25, 2.5, 3.75], phases=[0.25, 0.5, 0.75])
    assert an.takeoff_phases(ds).tolist() == [0.25, 0.5, 0.75]
    assert an.takeoff_phases(ds, 2.5).tolist() == [0.5, 0.75]


def test_phase_spread_is_circular():
    assert math.isnan(an.phase_spread([]))
    assert an.phase_spread([0.3, 0.3, 0.3]) == pytest.approx(0.0, abs=1e-7)
    # +-d about any centre, across the wrap-around too: the closed form
    for d in (0.01, 0.05):
        expected = math.sqrt(-2.0 * math.log(math.cos(2.0 * math.pi * d))) / (2.0 * math.pi)
        for centre in (0.3, 0.0):
            assert an.phase_spread([(centre - d) % 1.0, centre + d]) == pytest.approx(expected)
    assert an.phase_spread([0.99, 0.01]) < 0.011  # 0.02 apart across 0, not 0.98
    assert an.phase_spread([0.0, 0.5]) > 1.0  # opposite phases: no mean direction
    sigma = 0.015
    d = spread_pair(sigma)
    assert an.phase_spread([-d, d]) == pytest.approx(sigma)


# ------------------------------------------------------------------ rebound pattern
def sync_run(gap=1.0, sigma=0.0, n=8):
    """Take-offs in the final window [90, 100] every `gap` periods, phases
    alternating +-d (circular spread sigma)."""
    times = [92.0 + k * gap for k in range(n) if 92.0 + k * gap <= 100.0]
    d = spread_pair(sigma) if sigma > 0 else 0.0
    phases = [0.4 + (d if k % 2 else -d) for k in range(len(times))]
    return traj(takeoffs=times, phases=phases, tau=50.0)


def test_no_takeoff_no_pattern():
    assert an.rebound_pattern(traj()) is None


@pytest.mark.parametrize(
    "gap, expected",
    [
        (1.0, "synchronous"),
        (1.0 + SYNC_TOL - 0.01, "synchronous"),
        (1.0 - SYNC_TOL + 0.01, "synchronous"),
        (1.0 + SYNC_TOL + 0.01, "irregular"),
        (1.0 - SYNC_TOL - 0.01, "irregular"),
    ],
)
def test_synchronous_interval_threshold_from_both_sides(gap, expected):
    assert an.rebound_pattern(sync_run(gap=gap)) == expected


@pytest.mark.parametrize(
    "sigma, expected", [(SYNC_SPREAD - 0.002, "synchronous"), (SYNC_SPREAD + 0.002, "irregular")]
)
def test_synchronous_phase_spread_threshold_from_both_sides(sigma, expected):
    assert an.rebound_pattern(sync_run(sigma=sigma)) == expected


def test_synchronous_needs_three_takeoffs_in_the_final_window():
    assert an.rebound_pattern(sync_run(n=3)) == "synchronous"
    assert an.rebound_pattern(sync_run(n=2)) == "irregular"


def bursts(long_gap=10.0, burst=5, n_bursts=4, sync_gap=1.0, start=200.0, sigma=0.0, extra=None):
    """Take-offs after the ramp (t >= 3 tau = 150 of 1000 periods), in
    bursts of `burst` take-offs `sync_gap` apart, `long_gap` between bursts;
    none in the final window [900, 1000]."""
    times, t = [], start
    for _ in range(n_bursts):
        for k in range(burst):
            times.append(t + k * sync_gap)
        t = times[-1] + long_gap
    if extra is not None:
        times.append(times[-1] + extra)
    d = spread_pair(sigma) if sigma > 0 else 0.0
    phases = [0.7 + (d if k % 2 else -d) for k in range(len(times))]
    # before the ramp is over nothing counts: a stray take-off at t = 100
    return traj(t_end=1000.0, takeoffs=[100.0] + times, phases=[0.1] + phases, tau=50.0)


def test_multisynchronous_bursts():
    assert an.rebound_pattern(bursts()) == "multi-synchronous"


@pytest.mark.parametrize(
    "long_gap, expected", [(LONG_FLIGHT + 0.1, "multi-synchronous"), (LONG_FLIGHT - 0.1, "irregular")]
)
def test_long_flight_threshold_from_both_sides(long_gap, expected):
    assert an.rebound_pattern(bursts(long_gap=long_gap)) == expected


@pytest.mark.parametrize(
    "sync_gap, expected", [(1.0 + SYNC_TOL - 0.01, "multi-synchronous"), (1.0 + SYNC_TOL + 0.01, "irregular")]
)
def test_burst_interval_threshold_from_both_sides(sync_gap, expected):
    assert an.rebound_pattern(bursts(sync_gap=sync_gap)) == expected


@pytest.mark.parametrize(
    "sigma, expected", [(SYNC_SPREAD - 0.002, "multi-synchronous"), (SYNC_SPREAD + 0.002, "irregular")]
)
def test_burst_phase_spread_threshold_from_both_sides(sigma, expected):
    assert an.rebound_pattern(bursts(sigma=sigma)) == expected


def after_ramp(gaps):
    """Take-offs from t = 200 (after 3 tau = 150) separated by `gaps`."""
    times = list(200.0 + np.concatenate([[0.0], np.cumsum(gaps)]))
    return traj(t_end=1000.0, takeoffs=times, phases=[0.7] * len(times), tau=50.0)


def test_bursts_need_half_of_the_intervals_synchronous_and_four_intervals():
    assert an.rebound_pattern(after_ramp([1, 1, 10, 10])) == "multi-synchronous"  # 2 of 4
    assert an.rebound_pattern(after_ramp([1, 10, 10, 10])) == "irregular"  # 1 of 4
    assert an.rebound_pattern(after_ramp([1, 1, 1, 10])) == "multi-synchronous"
    assert an.rebound_pattern(after_ramp([1, 1, 10])) == "irregular"  # 3 intervals
    assert an.rebound_pattern(after_ramp([1, 1, 1, 1])) == "irregular"  # no long flight
    # one interval neither synchronous nor long (2 periods) spoils the pattern
    assert an.rebound_pattern(bursts(extra=2.0)) == "irregular"
    assert an.rebound_pattern(bursts(extra=1.0)) == "multi-synchronous"
    # take-offs during the ramp (t < 3 tau) are not looked at
    assert (
        an.rebound_pattern(traj(t_end=1000.0, takeoffs=[100, 101, 102, 140, 141], phases=[0.7] * 5, tau=50.0))
        == "irregular"
    )
    assert (
        an.rebound_pattern(traj(t_end=1000.0, takeoffs=[160, 161, 162, 170, 171], phases=[0.7] * 5, tau=50.0))
        == "multi-synchronous"
    )
    assert (
        an.rebound_pattern(traj(t_end=1000.0, takeoffs=[160, 161, 162, 170, 171], phases=[0.7] * 5, tau=60.0))
        == "irregular"
    )


# ------------------------------------------------------------------ chaos
def pair(v1, v2, t_end=100.0):
    return traj(t_end=t_end, x_end=v1 * t_end), traj(t_end=t_end, x_end=v2 * t_end)


@pytest.mark.parametrize(
    "v1, v2, expected",
    [
        # same class: chaotic iff |v1 - v2| > 0.1 max(|v1|, |v2|) + v0 = 1.1 here
        (-10.0, -10.0 + 1.1 - 0.01, False),
        (-10.0, -10.0 + 1.1 + 0.01, True),
        # away from 0 by d: chaotic iff d > 0.1 (10 + d) + 0.1, d > 1.1 / 0.9
        (-10.0, -10.0 - 1.1 / 0.9 + 0.01, False),
        (-10.0, -10.0 - 1.1 / 0.9 - 0.01, True),
        (5.0, 5.0, False),
        # different drift class: chaotic even when close
        (V0 + 0.001, V0 - 0.001, True),
        (-V0 - 0.001, -V0 + 0.001, True),
        (0.05, -0.05, False),
    ],
)  # both 'none'
def test_chaos_verdict_threshold_from_both_sides(v1, v2, expected):
    ds, twin = pair(v1, v2)
    assert an.chaos_verdict(ds, twin) is expected
    assert an.chaos_verdict(twin, ds) is expected


def test_chaos_verdict_takes_its_tolerances():
    ds, twin = pair(10.0, 8.0)
    assert an.chaos_verdict(ds, twin) is True  # 2 > 1.1
    assert an.chaos_verdict(ds, twin, rel_tol=0.2) is False  # 2 <= 2.1
    assert an.chaos_verdict(ds, twin, v0=1.5) is False  # 2 <= 2.5


def test_divergence_time_is_the_first_separation_over_threshold():
    t = np.linspace(0.0, 100.0, 1001)
    x = np.zeros_like(t)
    ds = traj(x=x)
    twin = traj(x=np.where(t >= 40.0, 0.02 * (t - 40.0) ** 2, 0.0))  # 1.0 at t = 47.07
    t_div = an.divergence_time(ds, twin)
    assert t_div == pytest.approx(40.0 + math.sqrt(1.0 / 0.02), abs=0.15)
    assert an.divergence_time(ds, twin) > 40.0 + math.sqrt(1.0 / 0.02) - 1e-9
    assert an.divergence_time(ds, twin, threshold=2.0) == pytest.approx(
        40.0 + math.sqrt(2.0 / 0.02), abs=0.15
    )
    # a separation of exactly the threshold is not divergence
    assert an.divergence_time(ds, traj(x=np.full_like(t, 1.0))) == math.inf
    assert an.divergence_time(ds, traj(x=np.full_like(t, 1.0 + 1e-9))) == 0.0
    assert an.divergence_time(ds, ds) == math.inf


def test_twin_scene_moves_tau_only():
    scene = Scene(amplitude=2.0, mass=0.5, tau=50.0)
    twin = an.twin_scene(scene)
    assert twin.tau == 50.001  # docs/MODEL.md section 4: tau + 1e-3
    assert {k: v for k, v in twin.values().items() if k != "tau"} == {
        k: v for k, v in scene.values().items() if k != "tau"
    }


# ------------------------------------------------------------------ summary
def test_summarize_gathers_the_same_numbers():
    # synchronous hopping in the final window, drifting at -2 then -4
    t = np.linspace(0.0, 100.0, 1001)
    x = np.where(t <= 90.0, -2.0 * t, -180.0 - 4.0 * (t - 90.0))
    times = [90.5 + k for k in range(10)]
    ds = traj(x=x, takeoffs=times, landings=[tt + 0.25 for tt in times])
    s = an.summarize(ds)
    assert s.drift_velocity == pytest.approx(-2.2)
    assert s.final_drift_velocity == pytest.approx(-4.0)
    assert (s.contact, s.drift, s.pattern, s.chaotic, s.divergence_time) == (
        "jumping",
        "against-wave",
        "synchronous",
        None,
        None,
    )
    assert s.takeoffs == 10 and s.takeoffs_per_period == pytest.approx(1.0)
    assert s.takeoff_phase_spread == pytest.approx(0.0, abs=1e-7)
    assert s.contact_fraction == pytest.approx(0.75)
    assert (s.steps, s.seconds, s.twin_steps, s.twin_seconds) == (10, 0.5, 0, 0.0)
    assert s.launched is False and s.launch_time is None and s.earliest_landing is None
    # with a twin that disagrees: chaotic, and the pattern says so
    twin = traj(x=-1.0 * t, takeoffs=times, landings=[tt + 0.25 for tt in times])
    s2 = an.summarize(ds, twin)
    assert s2.chaotic is True and s2.pattern == "chaotic"
    assert s2.divergence_time == pytest.approx(1.0, abs=0.15)  # |x - x_twin| = t
    assert (s2.steps, s2.seconds, s2.twin_steps, s2.twin_seconds) == (10, 0.5, 10, 0.5)
    # permanent contact is never 'chaotic' as a pattern (no rebounds)
    calm = traj(x=-0.05 * t)
    s3 = an.summarize(calm, traj(x=+0.5 * t))
    assert s3.chaotic is True and s3.pattern is None and s3.contact == "permanent"
    assert s3.drift == "none" and s3.contact_fraction == 1.0 and s3.takeoffs == 0


# ------------------------------------------------------------------ launched runs
def test_open_flight_start():
    # ends in contact; ends in a flight from 95; a rebound at 60 opens the last flight
    assert an.open_flight_start(traj(takeoffs=[10.0], landings=[11.0])) is None
    assert an.open_flight_start(traj(takeoffs=[10.0, 95.0], landings=[11.0])) == 95.0
    assert an.open_flight_start(traj(takeoffs=[10.0, 60.0], landings=[60.0])) == 60.0
    assert an.open_flight_start(traj()) is None
    # starts in flight (state FLIGHT at t = 0): open from 0 only if it never lands
    assert an.open_flight_start(traj(states=[(0.0, FLIGHT)])) == 0.0
    assert an.open_flight_start(traj(landings=[2.0], states=[(0.0, FLIGHT), (2.0, STICK)])) is None


@pytest.mark.parametrize(
    "t_off, expected",
    [
        (LAUNCH_FRACTION * 100.0 - EPS, True),
        (LAUNCH_FRACTION * 100.0, False),
        (LAUNCH_FRACTION * 100.0 + EPS, False),
        (89.0, False),  # in flight over the whole final window [90, 100], yet not launched
        (95.0, False),
        (0.25, True),
    ],
)
def test_launch_time_threshold_from_both_sides(t_off, expected):
    ds = traj(takeoffs=[0.1, t_off], landings=[0.2])
    assert (an.launch_time(ds) == t_off) is expected
    assert (an.launch_time(ds) is None) is not expected
    # a landing after it: no flight in progress, never launched
    assert an.launch_time(traj(takeoffs=[0.1, t_off], landings=[0.2, 99.99])) is None


def test_launch_time_takes_its_fraction():
    ds = traj(takeoffs=[70.0])
    assert an.launch_time(ds) is None and an.launch_time(ds, fraction=0.8) == 70.0


def test_earliest_landing_is_the_ballistic_return_within_reach():
    # m* = 8, A* = 2: y*(t_end + s) = y + vy s + s^2 / 16 reaches -2.
    A, m = 2.0, 8.0
    attrs = {"amplitude": A, "mass": m}
    # y = -102, vy = -3 (rising): s^2/16 - 3 s - 100 = 0 -> s = 8 (3 + sqrt(9 + 25))
    ds = traj(takeoffs=[10.0], y_end=-102.0, vy_end=-3.0, attrs=attrs)
    s = an.earliest_landing(ds) - 100.0
    assert s == pytest.approx(8.0 * (3.0 + math.sqrt(34.0)), rel=1e-14)
    assert -102.0 - 3.0 * s + s * s / 16.0 == pytest.approx(-A, rel=1e-13)
    # y = -10, vy = +2 (falling): s^2/16 + 2 s - 8 = 0 -> s = 8 (-2 + sqrt(4 + 2))
    ds = traj(takeoffs=[10.0], y_end=-10.0, vy_end=2.0, attrs=attrs)
    s = an.earliest_landing(ds) - 100.0
    assert s == pytest.approx(8.0 * (math.sqrt(6.0) - 2.0), rel=1e-14)
    assert -10.0 + 2.0 * s + s * s / 16.0 == pytest.approx(-A, rel=1e-14)
    # a huge fall velocity (no cancellation): s = gap / vy to first order
    ds = traj(takeoffs=[10.0], y_end=-3.0, vy_end=1e8, attrs=attrs)
    assert an.earliest_landing(ds) - 100.0 == pytest.approx(1e-8, rel=1e-9)
    # within reach of the surface (y >= -A*): it can land at once
    for y in (-A, -1.0, 0.5):
        ds = traj(takeoffs=[10.0], y_end=y, vy_end=-1.0, attrs=attrs)
        assert an.earliest_landing(ds) == 100.0


# ------------------------------------------------------------------ the verdict
def test_summary_costs_list_the_twin_apart():
    t = np.linspace(0.0, 100.0, 1001)
    ds = traj(x=-2.0 * t, takeoffs=[95.0], landings=[95.5])
    twin = traj(x=-2.0 * t, takeoffs=[95.0], landings=[95.5], attrs={"steps": 7, "seconds": 0.25})
    s = an.summarize(ds, twin)
    assert (s.steps, s.seconds, s.twin_steps, s.twin_seconds) == (10, 0.5, 7, 0.25)
    s = an.summarize(ds)
    assert (s.steps, s.seconds, s.twin_steps, s.twin_seconds) == (10, 0.5, 0, 0.0)


def test_summary_names_its_model_and_refuses_another_models_twin():
    ds = traj(attrs={"model": "deformable"})
    assert an.summarize(ds).model == "deformable"
    assert an.summarize(ds, traj(attrs={"model": "deformable"})).model == "deformable"
    with pytest.raises(ValueError, match="point-mass"):
        an.summarize(ds, traj(attrs={"model": "point-mass"}))
    assert an.summarize(traj()).model is None  # a hand-made Dataset names none


DIRECTION_WORDS = ("with the wave", "against the wave", "no drift")


def test_regime_of_regular_runs_names_contact_pattern_and_drift():
    t = np.linspace(0.0, 100.0, 1001)
    calm = traj(x=-0.05 * t)
    assert an.summarize(calm, calm).regime == f"permanent contact, no drift (|v*| <= {V0:g})"
    assert an.summarize(traj(x=(V0 + EPS) * t)).regime == "permanent contact, drift with the wave (+x)"
    times = [90.5 + k for k in range(10)]
    hop = traj(x=-2.0 * t, takeoffs=times, landings=[tt + 0.25 for tt in times])
    assert an.summarize(hop, hop).regime == "jumping, synchronous, drift against the wave (-x)"
    # no twin: the verdict says the drift was not checked for chaos
    assert (
        an.summarize(hop).regime
        == "jumping, synchronous, drift against the wave (-x); chaos not checked (no twin run)"
    )


def test_regime_says_when_the_final_drift_differs_from_the_mean():
    # mean +0.3 (with), final 10% -1 (against): both are stated, neither hidden
    t = np.linspace(0.0, 100.0, 1001)
    x = np.where(t <= 90.0, 40.0 / 90.0 * t, 40.0 - (t - 90.0))
    s = an.summarize(traj(x=x), traj(x=x))
    assert (s.drift, an.drift_class(s.final_drift_velocity)) == ("with-wave", "against-wave")
    assert s.regime == (
        "permanent contact, drift with the wave (+x) over the run, "
        "drift against the wave (-x) over its final 10%"
    )


def test_a_chaotic_regime_claims_no_drift_direction():
    # the case: the run's mean drifts with the wave, the twin's against
    t = np.linspace(0.0, 100.0, 1001)
    times = [5.0 + 3.7 * k for k in range(25)]
    ds = traj(x=0.5 * t, takeoffs=times, landings=[tt + 0.5 for tt in times])
    twin = traj(x=-2.17 * t, takeoffs=times, landings=[tt + 0.5 for tt in times])
    s = an.summarize(ds, twin)
    assert (s.chaotic, s.pattern, s.drift) == (True, "chaotic", "with-wave")  # drift: own <v*>
    assert s.regime == (
        f"jumping, chaotic: the tau + {an.TWIN_TAU_OFFSET:g} twin ends "
        "elsewhere, the drift is not a property of the scene"
    )
    assert not any(w in s.regime for w in DIRECTION_WORDS)
    # the same run with an agreeing twin: the drift is stated
    s = an.summarize(ds, ds)
    assert s.chaotic is False and "drift with the wave" in s.regime


def launched_run(t_off=17.0, x_slope=-70.0, **kw):
    """Hops until t = 10, then one flight from t_off to the end, at x*' = x_slope."""
    t = np.linspace(0.0, 100.0, 1001)
    return traj(
        x=np.where(t > t_off, x_slope * (t - t_off), 0.0),
        takeoffs=[5.0, 6.0, 7.0, t_off],
        landings=[5.5, 6.5, 7.5],
        y_end=-1e4,
        vy_end=-10.0,
        attrs={"amplitude": 300.0, "mass": 1000.0},
        **kw,
    )


def test_a_launched_run_is_labelled_as_such_and_gets_no_regime():
    ds = launched_run()
    s = an.summarize(ds, ds)
    landing = 100.0 + 1000.0 * (10.0 + math.sqrt(100.0 + 2.0 * 9700.0 / 1000.0))
    assert (s.launched, s.launch_time, s.pattern, s.contact) == (True, 17.0, "launched", "jumping")
    assert s.earliest_landing == pytest.approx(landing, rel=1e-14)
    assert s.drift == "against-wave"  # the class of its own <v*>, as sweeps store
    assert s.regime.startswith(
        "launched: leaves the substrate at t* = 17 and is still in flight at the end (t* = 100)"
    )
    assert f"cannot land again before t* = {landing:.3g}" in s.regime
    assert not any(w in s.regime for w in DIRECTION_WORDS + ("irregular",))
    # launched outranks chaotic as the pattern; the chaos verdict is still said
    twin = launched_run(x_slope=-20.0)
    s = an.summarize(ds, twin)
    assert (s.chaotic, s.pattern, s.launched) == (True, "launched", True)
    assert s.regime.endswith(f"the tau + {an.TWIN_TAU_OFFSET:g} twin ends elsewhere")
    # the same flight begun after half the run is not a launch
    s = an.summarize(launched_run(t_off=60.0), launched_run(t_off=60.0))
    assert (s.launched, s.launch_time, s.earliest_landing) == (False, None, None)
    assert s.pattern == "irregular" and s.regime.startswith("jumping, irregular, drift against")


def test_a_run_that_starts_in_flight_and_never_lands_is_launched():
    ds = traj(states=[(0.0, FLIGHT)], y_end=-50.0, vy_end=-1.0, attrs={"amplitude": 1.0, "mass": 1.0})
    s = an.summarize(ds)
    assert (s.launched, s.launch_time, s.contact, s.takeoffs) == (True, 0.0, "jumping", 0)
