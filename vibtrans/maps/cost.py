"""The expected share of its periods a map's point runs, before the map runs.

Under `stop="full"` a point runs T_obs.  Under `stop="decided"` it runs at
least t_min = settle_time(tau) + MIN_WINDOW (240 periods at tau = 50), then
stops or runs to T_obs (a drift still accelerating):

    E[periods] = f_end T_obs + (1 - f_end) min(T_obs, t_min + extra)

f_end (the share run to T_obs) and extra (the others' mean periods past
t_min) are measured on every 4th point of the shipped grid by `vibtrans bench
--sweep` (keys decided_<model>_ran-to-end_fraction, _mean_periods_run).  They
vary by region, so a small region's estimate can be off by more.
"""

from __future__ import annotations

import math

from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import STATED_DRIFT_ERROR
from vibtrans.core.stopping import DECIDED_FRACTION, MIN_WINDOW, check_stop, settle_time

# (f_end, extra) per model, 1581 points each: mean periods run 601.9 (deformable),
# 521.5 (point mass); extra = (mean - f_end T_obs) / (1 - f_end) - t_min
DECIDED_PROFILE = {"deformable": (0.142, 130.0), "point-mass": (0.020, 252.0)}
# A decided run's CPU per period over a full run's (same sample, `vibtrans bench
# --sweep`): the deformable's late runners cost more, the point mass's ramp too
DECIDED_PERIOD_COST = {"deformable": 0.92, "point-mass": 1.47}


def minimum_periods(tau: float, fidelity: str = "standard") -> int:
    """t_min: the ramp's settling at this fidelity and the rule's first window."""
    if fidelity not in STATED_DRIFT_ERROR:
        raise InputError(f"fidelity must be one of {', '.join(STATED_DRIFT_ERROR)}, got {fidelity!r}")
    return settle_time(tau, DECIDED_FRACTION * STATED_DRIFT_ERROR[fidelity]) + MIN_WINDOW


def expected_periods(model: str, stop: str, periods: float, tau: float, fidelity: str = "standard") -> float:
    """E[periods] of one point of a map (the module docstring's model)."""
    check_stop(stop)
    if model not in DECIDED_PROFILE:
        raise InputError(f"model must be one of {', '.join(DECIDED_PROFILE)}, got {model!r}")
    periods = float(periods)
    if not (math.isfinite(periods) and periods > 0.0):
        raise InputError(f"periods must be a positive number, got {periods!r}")
    if stop == "full":
        return periods
    f_end, extra = DECIDED_PROFILE[model]
    early = min(periods, minimum_periods(tau, fidelity) + extra)
    return f_end * periods + (1.0 - f_end) * early


def expected_time_share(
    model: str, stop: str, periods: float, tau: float, fidelity: str = "standard"
) -> float:
    """A map's expected time over its stop="full" time (E[periods] / T_obs,
    times DECIDED_PERIOD_COST under the `decided` rule)."""
    share = expected_periods(model, stop, periods, tau, fidelity) / float(periods)
    return share if stop == "full" else share * DECIDED_PERIOD_COST[model]
