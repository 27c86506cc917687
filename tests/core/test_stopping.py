"""The `decided` stopping rule (vibtrans.core.drivers) against full runs.

The reference of every check is the same scene run to T_obs (stop="full"):
a regular stop must report x*(T)/T within the standard preset's stated drift
error, STATED_DRIFT_ERROR["standard"] = 5e-3, relative with the floor
V0 = 0.1 (fidelity.py: how the preset's error is defined and measured), of
the full run's; a scene that does not settle must run to T_obs.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibtrans import paper_scene
from vibtrans.analysis.summary import CHAOS_LYAPUNOV, V0, summarize
from vibtrans.core.errors import InputError, StoreMismatch
from vibtrans.core.fidelity import STATED_DRIFT_ERROR
from vibtrans.core.kernels.substrate import RAMP_OFF
from vibtrans.core.params import Scene
from vibtrans.core.simulate import run_records
from vibtrans.core.stopping import MIN_WINDOW, REASONS, remaining_rate, weighted_birkhoff
from vibtrans.core.trajectory import RunArrays

ERR = STATED_DRIFT_ERROR["standard"]


def both(scene, lyapunov=True):
    """(full, decided) summaries and the decided run's attributes (the
    material point's exponent from its impact map)."""
    full = RunArrays(*run_records(scene, lyapunov=lyapunov))
    dec = RunArrays(*run_records(scene, lyapunov=lyapunov, stop="decided"))
    return summarize(full), summarize(dec), dec.attrs


def within_error(v, v_ref):
    return abs(v - v_ref) <= ERR * max(abs(v_ref), V0)


def ramp_end(scene):
    return math.ceil(RAMP_OFF * scene.tau)


# ---------------------------------------------------------------- the averages


def test_weighted_birkhoff_converges_super_polynomially_on_a_rotation():
    # Das, Sander, Saiki, Yorke (2017): for a smooth function on an
    # irrational rotation the weighted average converges faster than any
    # power of N; the plain average only as 1/N.  cos(2 pi k alpha) has
    # mean 0 (alpha the golden mean).
    alpha = (math.sqrt(5) - 1) / 2
    f = np.cos(2 * math.pi * alpha * np.arange(200))
    assert abs(weighted_birkhoff(f)) < 1e-10
    assert abs(f.mean()) > 1e-4


def test_remaining_rate_extrapolates_a_geometric_transient():
    # drift per period v + c q^k: windows of n periods differ by a factor
    # q^n, and the rate they tend to is v.
    v, c, q, n = -0.3, 0.05, 0.99, 30
    d = v + c * q ** np.arange(3 * n)
    v3, v_inf, bound = remaining_rate(d, n)
    assert abs(v_inf - v) < 0.05 * abs(v3 - v)
    assert bound >= abs(v_inf - v3)
    # a change that does not shrink (accelerating) is not decided
    assert remaining_rate(v + 1e-3 * np.arange(3 * n), n) is None


# ---------------------------------------------------------------- the recurrence


def _flight_records(vx_of, t_now, spp=10, p=3):
    """Samples (records.py columns) of a motion in flight at every whole
    period, x* the integral of vx_of(t) (closed form below), y* and v_y*
    periodic with period p; events: a take-off before the first sample."""
    from vibtrans.core.kernels import records as R
    from vibtrans.core.kernels.contact import FLIGHT

    t = np.arange(0, int(t_now * spp) + 1) / spp
    samples = np.zeros((t.size, R.NCOL))
    samples[:, R.T_] = t
    vx, x = vx_of(t)
    samples[:, R.X], samples[:, R.VX] = x, vx
    samples[:, R.Y] = -2.0 - np.cos(2 * np.pi * t / p)
    samples[:, R.VY] = 2 * np.pi / p * np.sin(2 * np.pi * t / p)
    samples[:, R.STATE] = FLIGHT
    # a take-off and landing every half period (a flight over each whole one)
    times = np.arange(0.75, t_now, 0.5)
    kinds = np.where(np.arange(times.size) % 2 == 0, R.LANDING, R.TAKEOFF)
    events = np.column_stack([times, kinds, times % 1])
    return samples, events


def test_a_recurrent_flight_state_gives_x_at_t_obs_exactly():
    # v_x* = 1 + 0.5 sin(2 pi t / 3): period 3, x* = t - (0.75 / pi) cos(2 pi t / 3)
    # + 0.75 / pi; x*(T)/T at T = 2000 from the whole cycles since the last
    # recurrence, not from a rate times the rest (the cycle's phase matters)
    from vibtrans.core.stopping import DecidedRule

    def motion(t):
        c = 0.75 / np.pi
        return 1 + 0.5 * np.sin(2 * np.pi * t / 3), t - c * np.cos(2 * np.pi * t / 3) + c

    rule = DecidedRule(2000.0, 50.0, 1.0, 1.0)
    samples, events = _flight_records(motion, 400.0)
    assert rule._recurs(samples, events, 400)
    assert REASONS[rule.reason] == "recurrent" and rule.rate == pytest.approx(1.0, rel=1e-12)
    assert rule.drift_velocity() == pytest.approx(motion(np.array([2000.0]))[1][0] / 2000.0, rel=1e-12)
    assert (400 - 3) < rule.t_strobe <= 400 and (2000.0 - rule.t_strobe) % 3 == 0


def test_a_slowly_accelerating_flight_state_does_not_recur():
    # v_x* grows by 1e-3 per period (paper point 4's kind of drift): its states
    # never recur within RECUR_TOL, whatever the period looked for
    from vibtrans.core.stopping import DecidedRule

    rule = DecidedRule(2000.0, 50.0, 1.0, 1.0)
    samples, events = _flight_records(lambda t: (1 + 1e-3 * t, t + 5e-4 * t * t), 400.0)
    assert not rule._recurs(samples, events, 400)
    assert REASONS[rule.reason] == "ran-to-end" and rule.drift_velocity() is None


# ---------------------------------------------------------------- known scenes


def test_full_is_the_default_and_adds_nothing():
    scene = paper_scene(1, periods=400.0)
    s0, e0, a0 = run_records(scene)
    s1, e1, a1 = run_records(scene, stop="full")
    assert np.array_equal(s0, s1) and np.array_equal(e0, e1)
    assert "stop_reason" not in a1 and "periods_run" not in a1


def test_permanent_contact_stops_soon_after_the_ramp():
    # paper point 1: permanent contact, drift against the wave
    scene = paper_scene(1)
    full, dec, attrs = both(scene)
    assert full.contact == dec.contact == "permanent"
    assert attrs["stop_reason"] == "regular"
    assert attrs["periods_run"] < ramp_end(scene) + MIN_WINDOW + 100
    assert within_error(dec.drift_velocity, full.drift_velocity)
    assert within_error(attrs["asymptotic_drift_velocity"], full.final_drift_velocity)
    assert dec.drift == full.drift and not dec.chaotic


def test_synchronous_hopping_stops_regular():
    # paper point 6: one jump per period, uniform drift against the wave
    scene = paper_scene(6)
    full, dec, attrs = both(scene)
    assert attrs["stop_reason"] == "regular"
    assert attrs["periods_run"] < 0.5 * scene.periods
    assert dec.pattern == full.pattern == "synchronous"
    assert within_error(dec.drift_velocity, full.drift_velocity)


def test_chaotic_hopping_stops_with_its_verdict():
    # paper point 8: chaotic hopping (its Lyapunov exponent is 0.04 per period)
    scene = paper_scene(8)
    full, dec, attrs = both(scene)
    assert full.chaotic and dec.chaotic
    assert attrs["stop_reason"] == "chaotic"
    assert attrs["periods_run"] < scene.periods
    assert dec.lyapunov > CHAOS_LYAPUNOV
    assert "asymptotic_drift_velocity" not in attrs  # the drift so far, flagged


def test_point_mass_chaotic_hopping_stops_with_its_impact_verdict():
    # paper point 10: the material point's irregular hopping (the paper: its
    # tau twin parts after ~30 periods); its impact map's exponent, measured
    # along the run, calls it chaotic long before T_obs, as the full run's
    # exponent over the whole run does
    scene = paper_scene(10)
    full, dec, attrs = both(scene)
    assert full.lyapunov > CHAOS_LYAPUNOV and full.chaotic
    assert attrs["stop_reason"] == "chaotic" and dec.chaotic
    assert attrs["periods_run"] < 0.5 * scene.periods
    assert dec.lyapunov > CHAOS_LYAPUNOV
    # measured from where the rule's windows start, not from the ramp's end
    assert attrs["lyapunov_from"] < RAMP_OFF * scene.tau


def test_point_mass_that_rides_the_surface_is_not_held_back_by_its_exponent():
    # paper point 9: the material point slides without a take-off: no impact,
    # no exponent; its regular stop is the same as without the measurement
    scene = paper_scene(9)
    _, dec, attrs = both(scene)
    _, dec0, attrs0 = both(scene, lyapunov=False)
    assert dec.lyapunov is None
    assert attrs["stop_reason"] == attrs0["stop_reason"]
    assert attrs["periods_run"] == attrs0["periods_run"]
    assert dec.drift_velocity == dec0.drift_velocity


def test_accelerating_drift_runs_to_the_end():
    # paper point 4: synchronous hovering whose drift accelerates through the
    # 2000 periods (tests/core/test_paper_points.py): never stopped early
    scene = paper_scene(4)
    full, dec, attrs = both(scene)
    assert attrs["stop_reason"] == "ran-to-end"
    assert attrs["periods_run"] == scene.periods
    # the same steps, in more kernel calls (exact to rounding: drivers.py)
    assert dec.drift_velocity == pytest.approx(full.drift_velocity, rel=1e-12)


def test_long_flight_of_the_upper_right_stops_in_flight():
    # A* = 100, m* = 1000: launched during the ramp, it cannot land again
    # before T_obs; the rest of the run is its flight, x* + v_x* (T - t)
    scene = Scene(amplitude=100.0, mass=1000.0, mu=0.3)
    full, dec, attrs = both(scene)
    assert attrs["stop_reason"] == "flight"
    assert attrs["periods_run"] < scene.periods
    assert full.launched and dec.launched
    assert dec.drift_velocity == pytest.approx(full.drift_velocity, rel=1e-9)


def test_point_mass_stops_regular():
    # paper point 9: the material point slides symmetrically, no drift
    scene = paper_scene(9)
    full, dec, attrs = both(scene, lyapunov=False)
    assert attrs["stop_reason"] in ("regular", "flight")
    assert attrs["periods_run"] < scene.periods
    assert within_error(dec.drift_velocity, full.drift_velocity)


# ---------------------------------------------------------------- entry points


def test_bad_stop_is_refused_by_name():
    with pytest.raises(InputError, match="stop must be one of full, decided"):
        run_records(paper_scene(1, periods=10.0), stop="early")


def test_sweep_store_records_the_rule(tmp_path):
    from vibtrans.maps.sweep import Sweep, open_map, run_sweep

    grid = (np.array([-1.0, 0.0]), np.array([0.0]))
    values = dict(model="deformable", mu=0.3, periods=500.0)
    path = str(tmp_path / "d.zarr")
    run_sweep(Sweep(*grid, chunk_rows=1, stop="decided", **values), path, progress=False)
    ds = open_map(path)
    assert ds.attrs["stop"] == "decided"
    reasons = ds["stop_reason"].values
    assert set(reasons.ravel()) <= set(range(1, len(REASONS)))
    assert (ds["periods_run"].values <= 500.0).all()
    # the same store is not resumed under the other rule
    with pytest.raises(StoreMismatch, match="stop: store decided, command full"):
        run_sweep(Sweep(*grid, chunk_rows=1, **values), path, progress=False)
    with pytest.raises(InputError, match="stop must be full for a lyapunov sweep"):
        Sweep(*grid, kind="lyapunov", stop="decided", model="vertical")


def test_cli_simulate_stop(capsys):
    import json

    from vibtrans.cli import main

    assert main(["simulate", "--amplitude", "0.1", "--mass", "1", "--stop", "decided", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["stop_reason"] == "regular" and out["periods_run"] < 2000
    with pytest.raises(SystemExit):
        main(["simulate", "--stop", "soon"])
    assert "--stop" in capsys.readouterr().err


# ---------------------------------------------------------------- property


@pytest.mark.slow
@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    log_a=st.floats(-3.0, 3.0),
    log_m=st.floats(-5.0, 5.0),
    model=st.sampled_from(["deformable", "point-mass"]),
)
def test_decided_never_reports_a_regular_drift_outside_the_stated_error(log_a, log_m, model):
    scene = Scene(amplitude=10.0**log_a, mass=10.0**log_m, model=model, mu=0.3)
    full, dec, attrs = both(scene)
    if attrs["stop_reason"] in ("regular", "flight", "recurrent") and not full.chaotic:
        assert within_error(dec.drift_velocity, full.drift_velocity), (
            attrs,
            full.drift_velocity,
            dec.drift_velocity,
        )


def test_plateau_then_acceleration_is_not_stopped_early():
    # A* = 10^0.6, m* = 10^3: synchronous hopping, drift -0.111 per period
    # from 400 to 460 (three windows from the ramp's end, 325, agree to 3e-4
    # there), -0.49 by 1500-2000.  Windows from the ramp's settling (180)
    # see the approach to the plateau and do not call it converged: the run
    # goes on.  This is the windows' reach, not a test of plateaus in
    # general: that a plateau is never taken for the steady drift is not
    # established (docs/DYNAMICS.md section 4; the bench's difference map)
    scene = Scene(amplitude=10.0**0.6, mass=10.0**3.0, mu=0.3)
    full, dec, attrs = both(scene)
    assert within_error(dec.drift_velocity, full.drift_velocity)


@pytest.mark.xfail(
    strict=True,
    reason="known (docs/DYNAMICS.md section 4, known "
    "inaccuracy at small drifts): the drift relaxes to a plateau that the windows accept at "
    "240 periods; hundreds of periods later the hopping changes and the "
    "full run's x*(T)/T is -0.069, the decided one -0.019",
)
def test_a_small_drift_whose_hopping_changes_late_is_not_stopped_early():
    # A* = 10^0.6, m* = 10^3.6, found by the bench's difference map (decided
    # against full, every 4th point of the shipped grid): one of 7 points,
    # all with |v*| < v0* (the metric over drifting points does not
    # count them), where the stated error with its floor does not hold
    scene = Scene(amplitude=10.0**0.6, mass=10.0**3.6, mu=0.3)
    full, dec, attrs = both(scene)
    assert within_error(dec.drift_velocity, full.drift_velocity), (
        attrs["stop_reason"],
        attrs["periods_run"],
        full.drift_velocity,
        dec.drift_velocity,
    )
