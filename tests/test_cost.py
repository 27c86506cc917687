"""The map cost model (vibtrans.maps.cost, issue 35): expected periods per
point under each stopping rule, and its profile measured from a map."""
import numpy as np
import pytest
import xarray as xr

from vibtrans.core.drivers import (DECIDED_FRACTION, MIN_WINDOW, RAMP_SHARE, REASONS,
                                   STOP_RAN_TO_END)
from vibtrans.core.fidelity import STATED_DRIFT_ERROR
from vibtrans.core.errors import InputError
from vibtrans.core.kernels.substrate import RAMP_OFF
from vibtrans.maps.cost import (DECIDED_PERIOD_COST, DECIDED_PROFILE, decided_profile,
                                expected_periods, expected_seconds, minimum_periods)


def test_full_runs_every_period():
    for model in DECIDED_PROFILE:
        assert expected_periods(model, "full", 2000.0, 50.0) == 2000.0


@pytest.mark.parametrize("fidelity", sorted(STATED_DRIFT_ERROR))
def test_minimum_periods_is_the_ramp_s_settling_and_the_first_window(fidelity):
    # the windows start at the first whole period where the ramp's residual
    # 1 - G = exp(-t^2/tau^2) (substrate.py) is below RAMP_SHARE of the rule's
    # tolerance (DECIDED_FRACTION of the stated error), at the latest where
    # G = 1 to double precision (RAMP_OFF tau); the first check MIN_WINDOW later
    tau = 50.0
    bar = RAMP_SHARE * DECIDED_FRACTION * STATED_DRIFT_ERROR[fidelity]
    t_s = minimum_periods(tau, fidelity) - MIN_WINDOW
    assert np.exp(-(t_s / tau) ** 2) <= bar < np.exp(-((t_s - 1) / tau) ** 2)
    assert t_s <= np.ceil(RAMP_OFF * tau)
    assert minimum_periods(tau) == minimum_periods(tau, "standard")
    with pytest.raises(InputError, match="fidelity must be one of"):
        minimum_periods(tau, "best")


@pytest.mark.parametrize("model", sorted(DECIDED_PROFILE))
def test_decided_lies_between_the_floor_and_the_full_run(model):
    t_min = minimum_periods(50.0)
    e = expected_periods(model, "decided", 2000.0, 50.0)
    assert t_min < e < 2000.0
    # a run no longer than the floor runs to its end
    assert expected_periods(model, "decided", 0.5 * t_min, 50.0) == 0.5 * t_min


def test_seconds_scale_with_the_expected_periods():
    full = expected_seconds(1e9, 100.0, "deformable", "full", 2000.0, 50.0, workers=2)
    assert full == pytest.approx(1e9 * 100e-9 / 2)
    for model in DECIDED_PROFILE:
        full = expected_seconds(1e9, 100.0, model, "full", 2000.0, 50.0, workers=2)
        dec = expected_seconds(1e9, 100.0, model, "decided", 2000.0, 50.0, workers=2)
        # the expected periods, each at the model's measured cost of a decided
        # run's period over a full run's
        assert dec / full == pytest.approx(
            expected_periods(model, "decided", 2000.0, 50.0) / 2000.0
            * DECIDED_PERIOD_COST[model])


def _decided_map(run, reason, periods=2000.0, tau=50.0):
    shape = (2, run.size // 2)
    return xr.Dataset({"periods_run": (("a", "m"), run.reshape(shape)),
                       "stop_reason": (("a", "m"), reason.reshape(shape))},
                      attrs={"stop": "decided", "scene_periods": periods, "scene_tau": tau})


def test_profile_reproduces_the_maps_mean_periods():
    rng = np.random.default_rng(3)
    t_min = minimum_periods(50.0)
    run = rng.uniform(t_min, 1200.0, 40)
    reason = np.full(40, REASONS.index("regular"))
    reason[:7] = STOP_RAN_TO_END
    run[:7] = 2000.0
    profile = decided_profile(_decided_map(run, reason))
    assert profile[0] == pytest.approx(7 / 40)
    assert expected_periods("deformable", "decided", 2000.0, 50.0, profile) == pytest.approx(
        run.mean())


def test_profile_needs_a_decided_map():
    ds = _decided_map(np.full(4, 2000.0), np.zeros(4, dtype=int))
    ds.attrs["stop"] = "full"
    with pytest.raises(InputError, match="stop='decided'"):
        decided_profile(ds)


def test_bad_input_names_the_parameter():
    with pytest.raises(InputError, match="stop"):
        expected_periods("deformable", "soon", 2000.0, 50.0)
    with pytest.raises(InputError, match="model"):
        expected_periods("rigid", "full", 2000.0, 50.0)
    with pytest.raises(InputError, match="periods"):
        expected_periods("deformable", "full", -1.0, 50.0)
    with pytest.raises(InputError, match="workers"):
        expected_seconds(1.0, 1.0, "deformable", "full", 2000.0, 50.0, workers=0)


@pytest.mark.slow
def test_profile_of_a_computed_map_predicts_its_periods(tmp_path):
    """A small decided map's own profile predicts its mean periods run (the
    model's form holds), and the shipped-grid profile predicts it within
    1.5x (the issue's estimate goal; a region's profile differs from the
    whole domain's)."""
    from vibtrans.maps.sweep import Sweep, open_map, parse_range, run_sweep
    sweep = Sweep(parse_range("-2.5:2.5:1.25", "log_amplitude"),
                  parse_range("-4:4:2", "log_mass"), model="deformable", mu=0.3,
                  periods=2000.0, stop="decided")
    run_sweep(sweep, str(tmp_path / "m.zarr"), progress=False)
    ds = open_map(str(tmp_path / "m.zarr"))
    mean = float(ds["periods_run"].values.mean())
    own = expected_periods("deformable", "decided", 2000.0, 50.0, decided_profile(ds))
    assert own == pytest.approx(mean)
    shipped = expected_periods("deformable", "decided", 2000.0, 50.0)
    assert 1 / 1.5 <= shipped / mean <= 1.5
