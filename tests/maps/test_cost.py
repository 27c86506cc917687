"""The expected periods per point of a map under each stopping rule
(vibtrans.maps.cost), which the a-priori time of a map on demand counts."""

import numpy as np
import pytest

from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import STATED_DRIFT_ERROR
from vibtrans.core.kernels.substrate import RAMP_OFF
from vibtrans.core.stopping import DECIDED_FRACTION, MIN_WINDOW, RAMP_SHARE
from vibtrans.maps.cost import (
    DECIDED_PERIOD_COST,
    DECIDED_PROFILE,
    expected_periods,
    expected_time_share,
    minimum_periods,
)


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
    assert np.exp(-((t_s / tau) ** 2)) <= bar < np.exp(-(((t_s - 1) / tau) ** 2))
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


def test_the_time_share_is_the_expected_periods_at_a_decided_period_s_cost():
    for model in DECIDED_PROFILE:
        assert expected_time_share(model, "full", 2000.0, 50.0) == 1.0
        # the expected periods, each at the model's measured cost of a decided
        # run's period over a full run's
        assert expected_time_share(model, "decided", 2000.0, 50.0) == pytest.approx(
            expected_periods(model, "decided", 2000.0, 50.0) / 2000.0 * DECIDED_PERIOD_COST[model]
        )


def test_bad_input_names_the_parameter():
    with pytest.raises(InputError, match="stop"):
        expected_periods("deformable", "soon", 2000.0, 50.0)
    with pytest.raises(InputError, match="model"):
        expected_periods("rigid", "full", 2000.0, 50.0)
    with pytest.raises(InputError, match="periods"):
        expected_periods("deformable", "full", -1.0, 50.0)


@pytest.mark.slow
def test_the_profile_predicts_a_computed_map_s_periods(tmp_path):
    """The shipped-grid profile predicts a small decided map's mean periods
    run within 1.5x (a region's profile differs from the whole domain's)."""
    from vibtrans.maps.sweep import Sweep, open_map, parse_range, run_sweep

    sweep = Sweep(
        parse_range("-2.5:2.5:1.25", "log_amplitude"),
        parse_range("-4:4:2", "log_mass"),
        model="deformable",
        mu=0.3,
        periods=2000.0,
        stop="decided",
    )
    run_sweep(sweep, str(tmp_path / "m.zarr"), progress=False)
    mean = float(open_map(str(tmp_path / "m.zarr"))["periods_run"].values.mean())
    shipped = expected_periods("deformable", "decided", 2000.0, 50.0)
    assert 1 / 1.5 <= shipped / mean <= 1.5
