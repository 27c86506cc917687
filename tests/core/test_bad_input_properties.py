"""Property tests: any float in any scene value ends in bounded work.

Every entry point finishes or refuses for any float (1e308,
5e-324, -0.0, inf, nan, huge integers).  The cost estimate is overflow-safe:
it is a finite step count or a refusal (StepBudgetExceeded, the estimate in
its message), never an OverflowError, a ZeroDivisionError or a count that
passes the budget while the run would not end.

Bounded work is checked without a clock: a run under a small step budget must
return (a hang fails the suite), its records must stay in [0, T_obs], and the steps it
took must stay within the estimate (plus one restart per landing for the
Hertz kernels, one partial scan step per event for the material point).  A
material point caught in events at rounding level (e.g. mu* = 5e-324) is
stopped by the kernel's limit of events per scan step, and refused.
"""

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibtrans import Scene, estimate_steps, simulate
from vibtrans.core.errors import InputError, StepBudgetExceeded
from vibtrans.core.fidelity import FIDELITY, contact_time_scale, step_count, time_step
from vibtrans.core.params import MASS_MIN
from vibtrans.core.threshold import _first_takeoff, first_takeoff

MAX = 1.7976931348623157e308
EXTREMES = [
    0.0,
    -0.0,
    5e-324,
    -5e-324,
    2.2250738585072014e-308,
    1e-300,
    1e-100,
    1.0,
    1e100,
    1e300,
    1e308,
    MAX,
    -1.0,
    -1e308,
    math.inf,
    -math.inf,
    math.nan,
]
# every float (subnormals, -0.0, inf, nan), the extremes above, huge integers
ANY_VALUE = st.one_of(
    st.sampled_from(EXTREMES),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**400), max_value=10**400),
)
FIELDS = ("amplitude", "mass", "mu", "theta", "nu", "tau", "periods", "alpha_t")


def _in(lo, hi, exclude_min=False, exclude_max=False):
    """Floats of a valid range, its edges and extremes favoured."""
    edges = [
        v
        for v in EXTREMES + [lo, hi]
        if isinstance(v, float)
        and math.isfinite(v)
        and (lo < v or (v == lo and not exclude_min))
        and (v < hi or (v == hi and not exclude_max))
    ]
    return st.one_of(
        st.sampled_from(edges), st.floats(lo, hi, exclude_min=exclude_min, exclude_max=exclude_max)
    )


# valid Scene values over their whole (float) domain
VALID = st.fixed_dictionaries(
    {
        "amplitude": _in(0.0, MAX),
        "mass": _in(MASS_MIN, MAX),
        "mu": _in(0.0, MAX, exclude_min=True),
        "theta": _in(1.0, 1.5),
        "nu": _in(0.0, 0.5, exclude_min=True, exclude_max=True),
        "tau": _in(0.0, MAX),
        "periods": _in(0.0, MAX, exclude_min=True),
        "alpha_t": _in(0.0, 1.0),
        "fidelity": st.sampled_from(["preview", "standard", "reference"]),
        "integrator": st.sampled_from(["ab4", "verlet"]),
    }
)
SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])
BUDGET = 3000  # steps: every run the budget lets through is small


def _scene_or_refusal(values):
    try:
        return Scene(**values)
    except InputError:
        return None


@settings(max_examples=300, **SETTINGS)
@given(
    amplitude=_in(0.0, MAX),
    mass=_in(0.0, MAX, exclude_min=True),
    fidelity=st.sampled_from(sorted(FIDELITY)),
    impacts=st.booleans(),
    refine=st.sampled_from([1.0, 3.0, 1024.0]),
)
def test_time_step_is_a_number_for_any_valid_float(amplitude, mass, fidelity, impacts, refine):
    t = contact_time_scale(amplitude, mass, impacts)
    assert t > 0.0 or (impacts and amplitude > 0.0 and t == 0.0)  # 0: v = 4 pi A* overflows
    assert not math.isnan(t)
    h = time_step(amplitude, mass, fidelity, refine, impacts)
    assert 0.0 <= h <= 1.0 / FIDELITY[fidelity][0] and not math.isnan(h)
    n = step_count(2000.0, h)
    assert n == math.inf or (isinstance(n, int) and n >= 1)


@settings(max_examples=300, **SETTINGS)
@given(
    field=st.sampled_from(FIELDS),
    value=ANY_VALUE,
    model=st.sampled_from(["deformable", "vertical", "point-mass"]),
)
def test_any_value_of_one_field_is_estimated_or_refused(field, value, model):
    scene = _scene_or_refusal({field: value, "model": model})
    if scene is None:
        return
    try:
        n = estimate_steps(scene)
    except StepBudgetExceeded as e:
        assert "inf steps" in str(e), str(e)  # the estimate, in the message
        return
    assert isinstance(n, int) and 1 <= n < math.inf


@settings(max_examples=300, **SETTINGS)
@given(values=VALID, model=st.sampled_from(["deformable", "vertical", "point-mass"]))
def test_extreme_valid_scenes_are_estimated_or_refused(values, model):
    scene = Scene(model=model, **values)
    try:
        n = estimate_steps(scene)
    except StepBudgetExceeded as e:
        assert "inf steps" in str(e), str(e)
        return
    assert isinstance(n, int) and n >= 1


def _run_or_refusal(scene):
    try:
        n = estimate_steps(scene)
    except StepBudgetExceeded:
        n = math.inf
    try:
        ds = simulate(scene, max_steps=BUDGET, samples_per_period=2)
    except StepBudgetExceeded as e:
        if "events within one scan step" in str(e):  # a Zeno-like run, stopped
            assert scene.model == "point-mass"
            return
        assert n > BUDGET
        assert (f"{n:.3g}" if n < math.inf else "inf steps") in str(e), str(e)
        return
    assert n <= BUDGET
    # (a Hertz run that ends in flight records no sample at T_obs itself)
    assert 0.0 <= float(ds.time[-1]) <= scene.periods
    events = ds.sizes.get("event", 0)
    assert ds.attrs["steps"] <= n + events + 1


@pytest.mark.parametrize("model", ["deformable", "vertical", "point-mass"])
@settings(max_examples=120, **SETTINGS)
@given(values=VALID)
def test_extreme_valid_scenes_run_or_are_refused_in_bounded_work(model, values):
    _run_or_refusal(Scene(model=model, **values))


@pytest.mark.parametrize("model", ["deformable", "vertical", "point-mass"])
@settings(max_examples=60, **SETTINGS)
@given(
    amplitude=st.sampled_from([1e10, 1e100, 1e200, 1e300, 1e307, 1e308, MAX]),
    mass=st.sampled_from([MASS_MIN, 1e-300, 1e-5, 1.0, 1e5, 1e300, MAX]),
    periods=st.sampled_from([5e-324, 1e-3, 2.0, 1e308]),
)
def test_overflowing_forces_run_or_are_refused_in_bounded_work(model, amplitude, mass, periods):
    # the corners where the forces, speeds or the step overflow or underflow
    _run_or_refusal(Scene(model=model, amplitude=amplitude, mass=mass, periods=periods))


def test_issue_examples_are_refused_with_the_estimate():
    for values in (
        {"amplitude": 1e308, "mass": 1.0},
        {"periods": 1e308},
        {"periods": 1e308, "model": "point-mass"},
    ):
        with pytest.raises(StepBudgetExceeded, match="inf steps"):
            simulate(Scene(**values))


@settings(max_examples=200, **SETTINGS)
@given(field=st.sampled_from(["amplitude", "mass", "tau", "periods"]), value=ANY_VALUE)
def test_first_takeoff_refuses_any_bad_float(field, value):
    args = {"amplitude": 1.0, "mass": 1.0, "tau": 5.0, "periods": 2.0, field: value}
    try:
        scene = Scene(model="vertical", **{k: v for k, v in args.items()})
    except InputError:
        with pytest.raises(InputError):
            first_takeoff(**args)
        return
    try:
        t = _first_takeoff(scene, max_steps=BUDGET)
    except StepBudgetExceeded as e:
        assert "steps" in str(e)
        return
    # (the kernel's last step may end past T_obs: a take-off inside it counts)
    h = time_step(scene.amplitude, scene.mass, scene.fidelity, impacts=False)
    assert t == math.inf or 0.0 <= t <= scene.periods + h


@settings(max_examples=150, **SETTINGS)
@given(
    amplitude=_in(0.0, MAX),
    mass=_in(MASS_MIN, MAX),
    tau=_in(0.0, MAX),
    periods=_in(0.0, MAX, exclude_min=True),
)
def test_first_takeoff_finishes_or_refuses_for_extreme_valid_floats(amplitude, mass, tau, periods):
    scene = Scene(model="vertical", amplitude=amplitude, mass=mass, tau=tau, periods=periods)
    try:
        t = _first_takeoff(scene, max_steps=BUDGET)
    except StepBudgetExceeded as e:
        assert "steps" in str(e)
        return
    # (the kernel's last step may end past T_obs: a take-off inside it counts)
    h = time_step(scene.amplitude, scene.mass, scene.fidelity, impacts=False)
    assert t == math.inf or 0.0 <= t <= scene.periods + h


def test_a_subnormal_mass_is_refused_with_its_range():
    """Found here: m* = 5e-324 (subnormal: 1/m* overflows), A* = 0, tau = 0
    and T_obs = 4.8e-160 periods (within the step budget) gave a NaN
    take-off time (the particle at rest: acceleration 0 * inf).  The
    valid range of m* starts at the smallest normal float."""
    for mass in (5e-324, 1e-310):
        with pytest.raises(InputError, match=r"mass must be in \[2\.22507e-308, inf\)"):
            Scene(model="vertical", amplitude=0.0, mass=mass, tau=0.0, periods=4.8e-160)
    scene = Scene(model="vertical", amplitude=0.0, mass=MASS_MIN, tau=0.0, periods=4.8e-160)
    assert _first_takeoff(scene, max_steps=BUDGET) == math.inf  # at rest, never leaves
