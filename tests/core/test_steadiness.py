"""A drift is called steady by one rule, the `decided` stop's own
(stopping.DecidedRule): steady when what the drift per period has left to
change moves x*(T)/T by less than DECIDED_FRACTION of the fidelity's stated
drift error, relative to |v*| (at least v0).  A run to T_obs is checked by
the rule afterwards (stopping.replay); a run the rule stopped is what it
said.  A chaotic run has no steady drift.  Paper point 4 at 2000 periods
drifts at -299 on average but at -569 over its last tenth (still
accelerating: its mean depends on the run's length); paper point 8 is
chaotic: no steady drift, whatever its last windows do."""

import contextlib
import io
import json

import numpy as np
import pytest
import xarray as xr

from vibtrans import Scene, simulate
from vibtrans.analysis import summary as analysis
from vibtrans.cli import main
from vibtrans.core.kernels.contact import STICK
from vibtrans.core.params import PAPER_POINTS
from vibtrans.core.stopping import MIN_WINDOW, settle_time

PERIODS = 2000.0
# the rule's tolerance at the standard fidelity: DECIDED_FRACTION (0.5) of
# its stated drift error (0.5%, docs/MODEL.md 8.1)
TOLERANCE = 0.0025


def _run(x_of_t, v_of_t, periods=PERIODS, samples_per_period=4, **attrs):
    """A run in contact throughout (no events) with x*(t) and v_x*(t) given
    in closed form, sampled as a run is (every 1/samples_per_period)."""
    t = np.arange(int(periods * samples_per_period) + 1) / samples_per_period
    zero = np.zeros_like(t)
    return xr.Dataset(
        {
            "x": ("time", x_of_t(t)),
            "vx": ("time", v_of_t(t)),
            "y": ("time", zero),
            "vy": ("time", zero),
            "state": ("time", np.full(t.size, STICK, dtype=np.int8)),
            "event_time": ("event", np.zeros(0)),
            "event_kind": ("event", np.zeros(0, np.int8)),
            "event_value": ("event", np.zeros(0)),
        },
        coords={"time": t},
        attrs={
            "periods": periods,
            "tau": 50.0,
            "amplitude": 1.0,
            "mass": 1.0,
            "fidelity": "standard",
            **attrs,
        },
    )


# the rule's windows at T = 2000 (tau = 50): from the settled ramp, t_s =
# settle_time(50, TOLERANCE) = 180, three thirds of (2000 - 180) // 3 = 606
# periods ending at 2000, from k0 = 182
T_SETTLE = settle_time(50.0, TOLERANCE)
THIRD = (2000 - T_SETTLE) // 3
K0 = 2000 - 3 * THIRD


def test_the_windows_of_the_rule():
    assert (T_SETTLE, THIRD, K0) == (180, 606, 182)


def test_a_uniform_drift_is_steady_from_the_rules_first_check():
    # x = v t: every drift per period is v, so the windows agree exactly and
    # the rule decides at its first check, MIN_WINDOW periods after t_s
    steady, words = analysis.steadiness(_run(lambda t: -3.0 * t, lambda t: -3.0 + 0 * t))
    assert steady is True
    assert words.startswith(f"steady: known from t* = {T_SETTLE + MIN_WINDOW} (drift per period -3)")
    # the rule, in the words: its tolerance and where it comes from
    assert f"less than {TOLERANCE:.2%} of |v*| (at least v0* = 0.1)" in words
    assert "0.5 of the standard fidelity's stated drift error" in words


def test_a_uniform_acceleration_is_not_steady():
    # x = a t^2 / 2: the drift per period from k to k + 1 is a (k + 1/2); the
    # Birkhoff weights are symmetric, so a window's average is its middle's
    # value: a (k0 + i n + n / 2) for the windows i = 0, 1, 2 of n periods.
    # The change between windows never shrinks (q = 1 >= GEOMETRIC_MAX): never decided
    a = -1e-3
    steady, words = analysis.steadiness(_run(lambda t: a * t**2 / 2, lambda t: a * t))
    assert steady is False
    assert words.startswith("not steady: still accelerating")
    middles = [a * (K0 + i * THIRD + THIRD / 2) for i in range(3)]  # -0.485, -1.091, -1.697
    assert (
        f"(drift per period {middles[0]:.4g}, {middles[1]:.4g}, then {middles[2]:.4g} "
        f"over three equal windows from t* = {K0} to 2000)"
    ) in words
    assert "the mean depends on the run's length" in words
    assert f"less than {TOLERANCE:.2%} of |v*|" in words


def test_a_slowing_drift_is_not_steady():
    # velocity -4 + 1.5e-3 t: -3.27, -2.36, -1.45 at the windows' middles
    steady, words = analysis.steadiness(
        _run(lambda t: -4.0 * t + 1.5e-3 * t**2 / 2, lambda t: -4.0 + 1.5e-3 * t)
    )
    assert steady is False and "still decelerating" in words


def test_inside_the_no_drift_band_an_accelerating_drift_is_not_steady():
    # the rule's floor v0 scales its tolerance, but its windows' change must
    # still shrink (as the `decided` stop runs such a run to T_obs)
    steady, _ = analysis.steadiness(_run(lambda t: 1e-6 * t**2, lambda t: 2e-6 * t))
    assert steady is False


def test_a_relaxing_drift_is_steady_once_the_rule_decides():
    # v = -3 (1 - exp(-t / 100)): a geometric transient, which the rule
    # extrapolates away; decided after its first check (the transient is
    # still e^-2.4 = 9% of v there)
    x = lambda t: -3.0 * (t - 100.0 * (1.0 - np.exp(-t / 100.0)))  # noqa: E731
    v = lambda t: -3.0 * (1.0 - np.exp(-t / 100.0))  # noqa: E731
    steady, words = analysis.steadiness(_run(x, v))
    assert steady is True and words.startswith("steady: known from t* = ")
    assert int(words.split("t* = ")[1].split(" ")[0]) > T_SETTLE + MIN_WINDOW


def test_a_run_too_short_for_the_rule_is_not_judged():
    # T = 200: after the ramp (t_s = 180) the rule needs MIN_WINDOW = 60 periods
    steady, words = analysis.steadiness(_run(lambda t: -3.0 * t, lambda t: -3.0 + 0 * t, periods=200.0))
    assert steady is None and words.startswith("not judged: the run is too short")


def test_a_chaotic_run_has_no_steady_drift():
    # whatever its drift does: its Lyapunov exponent, or its twin, says chaotic
    run = _run(lambda t: -3.0 * t, lambda t: -3.0 + 0 * t, lyapunov=0.2)
    steady, words = analysis.steadiness(run)
    assert steady is False
    assert words == (
        "chaotic: no steady drift (the vertical motion's Lyapunov exponent is 0.2 per period (> 0.01))"
    )
    steady, words = analysis.steadiness(_run(lambda t: -3.0 * t, lambda t: -3.0 + 0 * t), chaotic=True)
    assert (steady, words) == (False, "chaotic: no steady drift (the tau + 0.001 twin ends elsewhere)")


def test_a_run_the_rule_stopped_is_what_it_said():
    run = _run(
        lambda t: -3.0 * t,
        lambda t: -3.0 + 0 * t,
        stop="decided",
        stop_reason="regular",
        periods_run=300.0,
        asymptotic_drift_velocity=-3.0,
    )
    assert analysis.steadiness(run)[1].startswith("steady: known from t* = 300 (drift per period -3)")
    run.attrs.update(stop_reason="ran-to-end", periods_run=PERIODS)
    del run.attrs["asymptotic_drift_velocity"]
    assert analysis.steadiness(run)[0] is False


@pytest.mark.slow
@pytest.mark.parametrize("k", [2, 4, 6])
def test_the_full_run_is_steady_where_the_decided_stop_decides(k):
    # the same rule: a run to T_obs is steady exactly where the `decided`
    # stop (with its Lyapunov exponent) stops it as regular, from the same time
    la, lm, model = PAPER_POINTS[k]
    scene = Scene(amplitude=10**la, mass=10**lm, model=model)
    decided = simulate(scene, stop="decided", lyapunov=True)
    full = simulate(scene)
    steady, words = analysis.steadiness(full)
    assert steady is (decided.attrs["stop_reason"] == "regular")
    assert steady is analysis.steadiness(decided)[0]
    if steady:
        # (the whole period of its check; its last sample may come just before it)
        assert words.startswith(f"steady: known from t* = {int(decided.attrs['periods_run'])} ")


@pytest.mark.slow
def test_point_4_says_it_is_still_accelerating():
    la, lm, model = PAPER_POINTS[4]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        main(["simulate", "--amplitude", str(10**la), "--mass", str(10**lm), "--model", model, "--json"])
    got = json.loads(out.getvalue())
    assert got["steady"] is False, got
    assert got["steadiness"].startswith("not steady: still accelerating"), got["steadiness"]
    # paper point 4's figures: the mean and the last tenth far apart
    assert abs(got["final_drift_velocity"]) > 1.5 * abs(got["drift_velocity"])


@pytest.mark.slow
def test_point_8_chaotic_has_no_steady_drift():
    # paper point 8 is chaotic (its tau twin parts after about 20 periods,
    # docs/MODEL.md 6): its drift is called chaotic, not "still accelerating"
    la, lm, model = PAPER_POINTS[8]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        main(
            [
                "simulate",
                "--amplitude",
                str(10**la),
                "--mass",
                str(10**lm),
                "--model",
                model,
                "--json",
                "--twin",
                "always",
            ]
        )
    got = json.loads(out.getvalue())
    assert got["chaotic"] is True, got
    assert got["steady"] is False
    assert got["steadiness"].startswith("chaotic: no steady drift"), got["steadiness"]
