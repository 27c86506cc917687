"""The expected cost of a map before it runs (maps on demand, issue 35).

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
decided_<model>_ran-to-end_fraction and decided_<model>_mean_periods_run);
`decided_profile` measures them again from any map made with the rule (a
server learns them from its own maps).  The profile depends on the region:
the lower left settles at t_min, the middle (log10 A* in [0, 1]) runs to
T_obs at a third of its points, so an estimate for a small region can be
off by more than the whole domain's.

Where a full map of the region exists (a shipped map), each point's periods
are predicted from the class of its full run there instead
(`decided_class`: regular, chaotic, not steady, long flights) by the mean
periods that class ran (CLASS_PERIODS): over nine windows of the domain this
predicted the mean periods run within 0.94-1.05x for the deformable model
and 0.63-1.15x for the material point, against 0.5-2x for the one profile.
"""
import math
import time

import numpy as np

from vibtrans.core.stopping import (DECIDED_FRACTION, MIN_WINDOW, STOP_RAN_TO_END, check_stop,
                                    settle_time)
from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import STATED_DRIFT_ERROR

# (f_end, extra periods) per model: decided_profile of the rule's maps of every
# 4th point of the shipped grid (1581 points per model; the deformable's of
# the D3 session, 2026-11-27 05:00 UTC, the rule with its settling time and
# recurrence, measured again unchanged at 13:24 UTC; the material point's at
# 13:24 UTC, its chaos decided along the run by its impact exponent):
# deformable f_end 0.142, mean periods run 601.9; material point f_end 0.020,
# mean 521.5; extra = (mean - f_end T_obs) / (1 - f_end) - t_min, t_min = 240
DECIDED_PROFILE = {"deformable": (0.142, 130.0), "point-mass": (0.020, 252.0)}
# A decided run's time per period over a full run's, per model: (decided CPU
# / mean periods run) / (full CPU / T_obs) of the same sample, both rules in
# one run (2026-11-27, two runs: 0.912 and 0.925 for the deformable model,
# whose points that run to the end cost more per period than the average
# point; 1.463 and 1.477 for the material point, whose ramp, with its
# stick-slip events, costs more per period than the flights it ends in).
DECIDED_PERIOD_COST = {"deformable": 0.92, "point-mass": 1.47}

# A full run's class for the periods the rule will run it (decided_class):
# not steady where its last tenth's drift (final_drift_velocity) differs from
# its mean by more than UNSTEADY_CHANGE of the larger of |mean| and
# UNSTEADY_FLOOR a0 per period; a long flight where it jumps at under
# LONG_FLIGHT_TAKEOFFS take-offs a period.  The values fit the deformable
# model's periods best of (0.05, 0.1, 0.2) x (1e-3, 0.1); the material
# point's hardly depends on them.
UNSTEADY_CHANGE = 0.1
UNSTEADY_FLOOR = 1e-3
LONG_FLIGHT_TAKEOFFS = 0.5
CLASSES = ("regular", "chaotic", "not steady", "long flights")
# The mean periods the rule ran per class (CLASSES order), the class read on
# the shipped map of mu = 0.3 at every 4th point of its grid (T_obs 2000,
# tau 50, standard fidelity), the periods from the decided maps of
# `vibtrans bench --sweep` (2026-11-27 13:24 UTC; 939, 182, 328, 132 and
# 528, 529, 227, 297 points).  The chaos verdict read is the one maps on
# demand judge by (the run's own exponent: app/maprequest.replay_reference;
# the shipped deformable maps' own): the material point's shipped verdict is
# its tau twin's, with which its row was (248, 718, 1010, 285); read with
# the exponent's verdict, the same points' periods (`vibtrans sweep --model
# point-mass --stop decided --chaos lyapunov --log-amplitude=-3:3:0.2
# --log-mass=-5:5:0.2`, 2026-11-27 20:16 UTC, which reproduces that row
# with the twin's verdict) are the row below (528, 393, 353, 307 points).
CLASS_PERIODS = {"deformable": (288.0, 335.0, 1780.0, 280.0),
                 "point-mass": (248.0, 484.0, 1162.0, 305.0)}
CLASS_REFERENCE = (2000.0, 50.0, "standard")        # (T_obs, tau, fidelity) they ran at


def decided_class(drift_velocity, final_drift_velocity, chaotic, contact,
                  takeoffs_per_period):
    """Each point's class (an index of CLASSES) from a full map's fields."""
    v = np.asarray(drift_velocity, dtype=float)
    change = np.abs(np.asarray(final_drift_velocity, dtype=float) - v)
    chaotic = np.asarray(chaotic) == 1
    unsteady = ~chaotic & ~(change <= UNSTEADY_CHANGE * np.maximum(np.abs(v), UNSTEADY_FLOOR))
    flights = (~chaotic & ~unsteady & (np.asarray(contact) == 1)
               & (np.asarray(takeoffs_per_period, dtype=float) < LONG_FLIGHT_TAKEOFFS))
    return np.select([chaotic, unsteady, flights], [1, 2, 3], 0)


def class_periods(model, classes, periods, tau, fidelity="standard", learned=None):
    """The expected periods a point of each class (decided_class) runs
    under the `decided` rule at (T_obs = periods, tau, fidelity):
    CLASS_PERIODS moved by the change of the rule's minimum
    (minimum_periods), a not-steady point's as the same share of T_obs (at
    least that minimum), all at most T_obs; `learned`: the periods per class measured at these
    settings (learn_class_periods; NaN where a class was not seen), which
    replace those."""
    if model not in CLASS_PERIODS:
        raise InputError(f"model must be one of {', '.join(CLASS_PERIODS)}, got {model!r}")
    t_ref, tau_ref, fid_ref = CLASS_REFERENCE
    t_min = minimum_periods(tau, fidelity)
    table = np.array([p + t_min - minimum_periods(tau_ref, fid_ref)
                      for p in CLASS_PERIODS[model]])
    # (no point stops before the rule's first check)
    table[2] = max(CLASS_PERIODS[model][2] / t_ref * float(periods), t_min)
    if learned is not None:
        learned = np.asarray(learned, dtype=float)
        table = np.where(np.isfinite(learned), learned, table)
    return np.minimum(np.maximum(table, 0.0), float(periods))[np.asarray(classes)]


LEARN_MIN_POINTS = 5      # points of a class a map must have run to learn its periods


def learn_class_periods(classes, periods_run, previous=None):
    """The mean periods run per class (CLASSES order) by the points of a map
    made with the `decided` rule (their classes, decided_class, read on a
    full map of the same model); a class with fewer than LEARN_MIN_POINTS
    points keeps its `previous` value (NaN if none)."""
    classes = np.asarray(classes).ravel()
    run = np.asarray(periods_run, dtype=float).ravel()
    out = (np.full(len(CLASSES), np.nan) if previous is None
           else np.array(previous, dtype=float))
    for c in range(len(CLASSES)):
        seen = (classes == c) & np.isfinite(run)
        if seen.sum() >= LEARN_MIN_POINTS:
            out[c] = float(run[seen].mean())
    return out


def minimum_periods(tau, fidelity="standard"):
    """The periods every point runs under the `decided` rule: the ramp's
    settling (stopping.settle_time: its residual below 1e-3 of the rule's
    tolerance at this fidelity) and the rule's first window."""
    if fidelity not in STATED_DRIFT_ERROR:
        raise InputError(f"fidelity must be one of {', '.join(STATED_DRIFT_ERROR)}, "
                         f"got {fidelity!r}")
    return settle_time(tau, DECIDED_FRACTION * STATED_DRIFT_ERROR[fidelity]) + MIN_WINDOW


def expected_periods(model, stop, periods, tau, profile=None, fidelity="standard"):
    """The expected periods one point of a map runs (see the module
    docstring): T_obs under stop="full"; under "decided" the model above,
    with `profile` (f_end, extra) or the model's DECIDED_PROFILE."""
    check_stop(stop)
    if model not in DECIDED_PROFILE:
        raise InputError(f"model must be one of {', '.join(DECIDED_PROFILE)}, got {model!r}")
    periods = float(periods)
    if not (math.isfinite(periods) and periods > 0.0):
        raise InputError(f"periods must be a positive number, got {periods!r}")
    if stop == "full":
        return periods
    f_end, extra = DECIDED_PROFILE[model] if profile is None else profile
    if not (0.0 <= f_end <= 1.0 and extra >= 0.0):
        raise InputError(f"profile must be (f_end in [0, 1], extra >= 0), got {profile!r}")
    early = min(periods, minimum_periods(tau, fidelity) + extra)
    return f_end * periods + (1.0 - f_end) * early


def expected_seconds(full_steps, ns_per_step, model, stop, periods, tau, workers=1,
                     profile=None, fidelity="standard"):
    """Expected seconds of a map whose points would take `full_steps` steps in
    all when run to T_obs (stop="full"), at ns_per_step per step on
    `workers` cores: full_steps x E[periods] / T_obs x ns_per_step / workers,
    under the `decided` rule times the model's DECIDED_PERIOD_COST (its
    periods are not the average period of a full run: the ramp's and the
    checks' cost more, the steady flights less)."""
    if workers < 1:
        raise InputError(f"workers must be >= 1, got {workers!r}")
    return float(full_steps) * expected_time_share(model, stop, periods, tau, profile,
                                                   fidelity) * float(ns_per_step) * 1e-9 / workers


def expected_time_share(model, stop, periods, tau, profile=None, fidelity="standard"):
    """A map's expected time under `stop` over its time under stop="full":
    E[periods] / T_obs, times DECIDED_PERIOD_COST under the `decided` rule."""
    share = expected_periods(model, stop, periods, tau, profile, fidelity) / float(periods)
    return share if stop == "full" else share * DECIDED_PERIOD_COST[model]


def decided_profile(ds):
    """(f_end, extra) measured from a finished map made with stop="decided"
    (its per-point periods_run and stop_reason; attribute scene_tau): the profile `expected_periods` reproduces its mean periods
    run with."""
    if ds.attrs.get("stop", "full") != "decided" or "periods_run" not in ds:
        raise InputError("decided_profile needs a map made with stop='decided'")
    run = np.asarray(ds["periods_run"].values, dtype=float).ravel()
    reason = np.asarray(ds["stop_reason"].values).ravel()
    done = np.isfinite(run) & (reason >= 0)
    if not done.any():
        raise InputError("the map has no finished point")
    run, reason = run[done], reason[done]
    t_min = minimum_periods(float(ds.attrs["scene_tau"]),
                            ds.attrs.get("scene_fidelity", "standard"))
    end = reason == STOP_RAN_TO_END
    f_end = float(end.mean())
    if end.all():
        return f_end, 0.0
    # E = f_end T + (1 - f_end) min(T, t_min + extra): the others' mean periods
    # past t_min (points stopped before t_min: none, the rule's first check)
    return f_end, max(float(run[~end].mean()) - t_min, 0.0)


# ---------------------------------------------------------------- a map's probe
# A decided run's seconds follow the periods it runs (its steps) far more
# closely than the seconds its point took in a full map: over the seven maps
# of `python -m devtools.mapestimate` (2026-11-27 19:55 UTC) the per-point
# seconds over steps run varied by a coefficient of variation of 0.3-0.6,
# over the shipped map's seconds (scaled by the periods run) by 0.4-1.3, and
# the maps' sums of the latter disagreed by up to 2x between maps of one
# model and fidelity (a decided run spends most of its time in the ramp and
# the rule's checks, alike everywhere; a full run's cost is that of its
# regime).  So the estimate of a decided map counts steps.

def timed_point(values, log_a, log_m, chaos="twin", stop="full"):
    """(maps.sweep.compute_point's dict, its wall seconds in all): the run
    and the Python around it (the scene's checks, the run's summary), which
    a map point costs but the run's own `seconds` leaves out."""
    from vibtrans.maps.sweep import compute_point
    start = time.perf_counter()
    point = compute_point(values, log_a, log_m, chaos, stop)
    return point, time.perf_counter() - start


def probe_points(weights, count):
    """`count` flat indices of `weights` (>= 0, any shape) drawn with
    probability proportional to size, systematically (the points where the
    cumulative weight crosses (k + 1/2) / count of the total, k = 0 ..
    count - 1): a point may come more than once.  With these picks the mean
    of seconds / weight over the picks estimates the map's seconds per unit
    of weight without bias whatever the seconds' spread over the points
    (Horvitz-Thompson), which nine points on a lattice do not."""
    w = np.asarray(weights, dtype=float).ravel()
    if not (count >= 1 and np.all(np.isfinite(w)) and np.all(w >= 0.0) and w.sum() > 0.0):
        raise InputError("probe_points needs finite weights >= 0, not all 0, and count >= 1")
    edges = np.cumsum(w)
    targets = (np.arange(count) + 0.5) / count * edges[-1]
    return np.minimum(np.searchsorted(edges, targets, side="right"), w.size - 1)


# The share of a window's not-steady points (decided_class 2 on the shipped
# map) whose refinement a map on demand adds to the replay's
# (maps.adaptive.predict_refinement on the shipped map): q in
#     expected computed = replay + q (replay with those drifts unknown - replay),
# per (model, fidelity).  A not-steady run's x*(T)/T is its acceleration's,
# sensitive to the run: the shipped full runs at standard fidelity draw it
# smoothly, a preview run's scatters from point to point beyond the
# refinement's drift tolerance, so the refinement follows it down into
# not-steady regions the replay leaves whole (mapestimate's 97 x 97 preview
# map, 2026-11-27: 2293 points computed, 1824 replayed, 3688 with every
# not-steady drift unknown).  Measured on two 33 x 33 maps (3 levels) per
# model and fidelity in windows none of mapestimate's ((-2.5..0.5,
# -3..-1) and (0..2.5, 1..3) of log10 A*, log10 m*; 2026-11-27 20:00 UTC,
# the window with not-steady points): deformable preview 0.36 (474
# computed, 156 replayed, 1035 unknown), standard 0.04 (189, 156, 1035);
# material point 0.11 (676, 663, 782).  A server learns it per model and
# fidelity from its own maps (app/mapjobs.py); where neither, 0.
NOT_STEADY_REFINED = {("deformable", "preview"): 0.36, ("deformable", "standard"): 0.04,
                      ("point-mass", "standard"): 0.11}
NOT_STEADY = CLASSES.index("not steady")


def expected_refinement(replayed, unknown, share):
    """Each finest-grid point's expected count in a map's refinement (in
    [0, 1]): the replay on the shipped map (`replayed`, boolean), moved by
    `share` (NOT_STEADY_REFINED) towards the replay with the not-steady
    points' drift unknown (`unknown`, boolean)."""
    replayed = np.asarray(replayed, dtype=float)
    return np.clip(replayed + float(share) * (np.asarray(unknown, dtype=float) - replayed),
                   0.0, 1.0)


def learn_not_steady_share(computed, replayed, unknown, min_points=10):
    """The share q of expected_refinement a finished map shows (its
    computed points against the two replays), in [0, 1]; None where the
    unknown drifts change the replay by fewer than `min_points` points."""
    base, full = float(np.sum(replayed)), float(np.sum(unknown))
    if full - base < min_points:
        return None
    return float(np.clip((float(np.sum(computed)) - base) / (full - base), 0.0, 1.0))
