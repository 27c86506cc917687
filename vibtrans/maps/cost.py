"""The expected share of its periods a map's point runs, before the map
runs (the a-priori figure of a map on demand's time).

A map point's cost is its integration steps times the machine's time per
step.  Under `stop="full"` every point runs T_obs periods, so its steps are
known in advance (core.simulate.estimate_steps, the upper bound the explorer
adds up).  Under `stop="decided"` (core.stopping.DecidedRule) a point runs
at least to the ramp's end plus the rule's first window,

    t_min = settle_time(tau) + MIN_WINDOW      (240 periods at tau = 50, standard),

and then either stops (regular, chaotic, a flight that lasts past T_obs) or
runs to T_obs (a drift that is not steady: most of them accelerate through
T_obs, as paper point 4 does).  The expected periods
of a point are modelled as

    E[periods] = f_end T_obs + (1 - f_end) min(T_obs, t_min + extra)

with f_end the share of points that run to T_obs and extra the mean periods
the others run past t_min.  DECIDED_PROFILE holds them as measured on every
4th point of the shipped grid (121 x 201 over log10 A* in [-3, 3], log10 m*
in [-5, 5]; standard fidelity, T_obs = 2000, tau = 50, mu = 0.3) by
`vibtrans bench --sweep` (tools.bench.decided_trade; its keys
decided_<model>_ran-to-end_fraction and decided_<model>_mean_periods_run).
The profile depends on the region:
the lower left settles at t_min, the middle (log10 A* in [0, 1]) runs to
T_obs at a third of its points, so an estimate for a small region can be
off by more than the whole domain's.
"""
from __future__ import annotations

import math

from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import STATED_DRIFT_ERROR
from vibtrans.core.stopping import DECIDED_FRACTION, MIN_WINDOW, check_stop, settle_time

# (f_end, extra periods) per model, measured on the rule's maps of every
# 4th point of the shipped grid (1581 points per model; the deformable's of
# the rule with its settling time and recurrence, the same when measured again;
# the material point's with its chaos decided along the run by its impact
# exponent; `vibtrans bench --sweep --json` measures both):
# deformable f_end 0.142, mean periods run 601.9; material point f_end 0.020,
# mean 521.5; extra = (mean - f_end T_obs) / (1 - f_end) - t_min, t_min = 240
DECIDED_PROFILE = {"deformable": (0.142, 130.0), "point-mass": (0.020, 252.0)}
# A decided run's time per period over a full run's, per model: (decided CPU
# / mean periods run) / (full CPU / T_obs) of the same sample, both rules in
# one run (two runs: 0.912 and 0.925 for the deformable model,
# whose points that run to the end cost more per period than the average
# point; 1.463 and 1.477 for the material point, whose ramp, with its
# stick-slip events, costs more per period than the flights it ends in).
DECIDED_PERIOD_COST = {"deformable": 0.92, "point-mass": 1.47}


def minimum_periods(tau: float, fidelity: str = "standard") -> int:
    """The periods every point runs under the `decided` rule: the ramp's
    settling (stopping.settle_time: its residual below 1e-3 of the rule's
    tolerance at this fidelity) and the rule's first window."""
    if fidelity not in STATED_DRIFT_ERROR:
        raise InputError(f"fidelity must be one of {', '.join(STATED_DRIFT_ERROR)}, "
                         f"got {fidelity!r}")
    return settle_time(tau, DECIDED_FRACTION * STATED_DRIFT_ERROR[fidelity]) + MIN_WINDOW


def expected_periods(model: str, stop: str, periods: float, tau: float,
                     fidelity: str = "standard") -> float:
    """The expected periods one point of a map runs (see the module
    docstring): T_obs under stop="full"; under "decided" the model above,
    with the model's DECIDED_PROFILE."""
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


def expected_time_share(model: str, stop: str, periods: float, tau: float,
                        fidelity: str = "standard") -> float:
    """A map's expected time under `stop` over its time under stop="full":
    E[periods] / T_obs, times DECIDED_PERIOD_COST under the `decided` rule."""
    share = expected_periods(model, stop, periods, tau, fidelity) / float(periods)
    return share if stop == "full" else share * DECIDED_PERIOD_COST[model]
