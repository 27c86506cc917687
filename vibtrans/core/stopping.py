"""The stopping rule of a run: `full` (run to T_obs, the default) or
`decided` (stop once the run's outcome is known to the fidelity's stated
drift error).

The rule is evaluated by the drivers between kernel calls (the chunks they
already make for progress and cancellation), from what the run has already
recorded: the coarse samples (x*, v_x* every 1/samples_per_period), the
take-off and landing events, and, where the run measures it, the vertical
motion's tangent (its Lyapunov exponent).  Its extra cost is one short numpy
evaluation per check, every CHECK_EVERY periods.

Decided, once the ramp has settled: from t_s = settle_time(tau), where
the ramp's residual 1 - G(t) = exp(-t^2/tau^2) is below RAMP_SHARE of
the tolerance (3.6 tau = 180 periods at tau = 50 for the standard preset;
G = 1 to double precision only at RAMP_OFF tau = 325).  The residual is a
relative change of the wave's amplitude: the motion it perturbs drifts
differently by at most S x residual (S = dlog v*/dlog A*, the drift's
sensitivity to the amplitude), under 1e-3 of the tolerance wherever S <
1000, and it decays faster than any geometric transient, which the
windows below extrapolate away.  A run that measures its Lyapunov
exponent starts it at t_s under this rule (simulate.lyapunov_start), so
that no regular stop comes before the exponent is measured:

* regular: the drift per period x*(k+1) - x*(k) (`stroboscope`) in three
  windows since the ramp, each a weighted Birkhoff average (Das, Sander,
  Saiki and Yorke 2017, weight exp(-1/(s(1-s)))): on a periodic or
  quasi-periodic orbit they converge super-polynomially; their change from
  window to window is taken as geometric (a relaxing transient) and must
  shrink (`remaining_rate`); unless the drifts recur with a period <=
  MAX_PERIOD, NOISE_SIGMAS batch-means standard errors join the bound
  (irregular drifts agree by chance).  Decided when the bound, over the
  rest of the run, moves x*(T)/T by less than DECIDED_FRACTION of the
  stated error (relative, floor v0* = fidelity.V0), no flight overlapping
  the windows is longer than FLIGHT_FRACTION of one, and (where measured)
  the Lyapunov exponent so far is below fidelity.CHAOS_LYAPUNOV.  The run
  reports x*(T)/T = (x*(k) + v_inf (T - k)) / T from the last whole period
  k, and v_inf itself (`asymptotic_drift_velocity`).
* chaotic: the Lyapunov exponent is measured (vertical motion's tangent) and
  both its value since the ramp and its value over the second half of that
  time exceed CHAOS_MARGIN x CHAOS_LYAPUNOV, after at least
  MIN_CHAOS_PERIODS, in a run that has taken off: a regular orbit's
  finite-time exponent decays as log(t)/t and over a second half alone is
  log(2)/(t/2)-small; a chaotic one's stays.  The run keeps its drift so far, flagged.
* flight: a flight in progress that, continued ballistically, cannot reach
  the substrate again before T_obs (`ballistic_reach_time`: y* above
  -A*, the highest the surface comes) ends the run exactly:
  x*(T) = x* + v_x* (T - t), v_inf = v_x* (the launched scenes of the upper
  right).
* recurrent (the long flights the regular test leaves out; tried only
  there: on the shipped grid's sample it decided no other point and cost
  ~20% of a chaotic material point's run): the state at the last whole period k spent in
  flight, (v_x*, y*, v_y*) on its closed form, a complete state of the run
  (a landing restarts the contact from the flight alone: the springs'
  memory and the integrator's history are the flight's, and the motion is
  invariant under a shift in x and of one period), recurs at k - p, k -
  2p, ..., k - RECUR_CYCLES p, all in flight, within RECUR_TOL of the
  motion's scale (2 pi A* for the velocities, A* for y*, plus the state's
  own size), for the smallest period p <= RECUR_LONGEST (Attractors.jl's
  recurrence idea, on the stroboscope).  The orbit then repeats its
  cycle's advance Dx: x*(T) = x*(T - n p) + n Dx (n whole cycles, T - n p
  within the last cycle), exact for a periodic orbit; the advances'
  change from cycle to cycle must not grow, and even continued at its
  largest as an acceleration (n + n(n+1)/2 times it) must move x*(T)/T by
  less than DECIDED_FRACTION of the stated error.  v_inf = Dx / p.
* otherwise (not steady, e.g. paper point 4's accelerating drift) the run
  goes on to T_obs (reason `ran-to-end`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import CHAOS_LYAPUNOV, STATED_DRIFT_ERROR, V0
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.contact import FLIGHT
from vibtrans.core.kernels.substrate import RAMP_OFF

STOPS = ("full", "decided")
# why a run stopped (stored per map point as `stop_reason`)
REASONS = ("full", "regular", "chaotic", "ran-to-end", "flight", "recurrent")
STOP_FULL, STOP_REGULAR, STOP_CHAOTIC, STOP_RAN_TO_END, STOP_FLIGHT, STOP_RECURRENT = range(6)

MIN_WINDOW = 60  # periods after the ramp before the first check (three windows of 20)
CHECK_EVERY = 8  # periods between checks, at least
CHECK_FRACTION = 1 / 8  # of the time since the ramp, between checks, at least
DECIDED_FRACTION = 0.5  # of the stated drift error, spent on the extrapolation
GEOMETRIC_MAX = 0.8  # a change between windows shrinking slower than this: not decided
MAX_PERIOD = 16  # longest recurrence (periods) looked for in the drift per period
NOISE_SIGMAS = 3.0  # standard errors of an average of irregular drifts, in the bound
NOISE_BLOCKS = 12  # batch means of the drifts for that standard error
MIN_CHAOS_PERIODS = 100  # periods of Lyapunov measurement before a chaotic stop
CHAOS_MARGIN = 2.0  # chaotic: exponent above CHAOS_MARGIN x CHAOS_LYAPUNOV
FLIGHT_FRACTION = 0.25  # longest flight allowed in the window, of one of its thirds
RAMP_SHARE = 1e-3  # the ramp's residual where the windows start, of the tolerance
RECUR_CYCLES = 3  # cycles over which the in-flight stroboscope must recur
RECUR_TOL = 1e-6  # its states' mismatch, relative to the motion's scale
RECUR_LONGEST = 250  # longest recurrence period looked for (periods)


def ballistic_reach_time(y: Any, vy: Any, mass: float, amplitude: float) -> Any:
    """Time (periods) until a particle at (y*, y*') in free flight (m* y*''
    = 1, y* down) first reaches y* = -A*, the highest the surface ever comes
    (0 if it is already within reach)."""
    gap = -amplitude - y  # > 0: out of reach
    if gap <= 0.0:
        return 0.0
    # root of t^2 / (2 m*) + vy t - gap = 0, in the form without cancellation
    root = math.sqrt(vy * vy + 2.0 * gap / mass)
    return mass * (root - vy) if vy <= 0.0 else 2.0 * gap / (vy + root)


def settle_time(tau: float, tolerance: float) -> int:
    """The whole period from which the `decided` rule's windows start: the
    ramp's residual 1 - G(t) = exp(-t^2 / tau^2) below RAMP_SHARE x
    `tolerance` (the rule's share of the stated drift error), at the latest
    RAMP_OFF tau (G = 1 to double precision).  tau = 0: 0."""
    if tau <= 0.0:
        return 0
    return min(
        math.ceil(tau * math.sqrt(math.log(1.0 / (RAMP_SHARE * tolerance)))), math.ceil(RAMP_OFF * tau)
    )


def check_stop(stop: str) -> str:
    """The validated stop rule name."""
    if stop not in STOPS:
        raise InputError(f"stop must be one of {', '.join(STOPS)}, got {stop!r}")
    return stop


def birkhoff_weights(n: int) -> Any:
    """The weights exp(-1/(s(1-s))), s = (j+1)/(n+1), j < n, normalized to sum 1
    (Das, Sander, Saiki and Yorke 2017)."""
    s = np.arange(1, n + 1) / (n + 1.0)
    w = np.exp(-1.0 / (s * (1.0 - s)))
    return w / w.sum()


def weighted_birkhoff(values: Any) -> float:
    """The weighted Birkhoff average of a sequence (float)."""
    values = np.asarray(values, dtype=float)
    return float(birkhoff_weights(values.size) @ values)


def recurrence_period(values: Any, tol: float, longest: Any = MAX_PERIOD) -> int | None:
    """The smallest p <= longest with |values[k + p] - values[k]| <= tol for
    every k (the stroboscopic state's recurrence, seen in its drift per
    period), or None."""
    values = np.asarray(values)
    for p in range(1, min(longest, values.size // 3) + 1):
        if np.max(np.abs(values[p:] - values[:-p])) <= tol:
            return p
    return None


def remaining_rate(
    drift_per_period: np.ndarray, n: int, recur_tol: float = 0.0
) -> tuple[float, float, float] | None:
    """The asymptotic drift rate from the last 3 n drifts per period: the
    weighted Birkhoff averages v1, v2, v3 of three windows of n periods, and
    (v3, v_inf, bound): v_inf the rate they tend to, with the change from
    window to window taken as geometric, d2 = v3 - v2 = q (v2 - v1), and
    bound >= |v_inf - v3| + |d2|, the rate's uncertainty.  None if the
    windows do not converge (growing or slowly shrinking changes: q >=
    GEOMETRIC_MAX), or are not finite.

    Unless the last window's drifts recur with a period <= MAX_PERIOD
    (within recur_tol: `recurrence_period`), the motion may be irregular,
    where averages agree by chance: the bound then also holds NOISE_SIGMAS
    standard errors of a window's mean, by batch means (the 3 n drifts in
    NOISE_BLOCKS blocks; a window holds NOISE_BLOCKS / 3 of them), which
    holds for drifts correlated over up to a block (long flights).  On a
    quasi-periodic orbit the averages converge far faster than that, so this
    only makes it run longer."""
    w = birkhoff_weights(n)
    d = np.asarray(drift_per_period)[-3 * n :]
    v1, v2, v3 = (float(w @ d[i * n : (i + 1) * n]) for i in range(3))
    if not all(math.isfinite(v) for v in (v1, v2, v3)):
        return None
    noise = 0.0
    if recurrence_period(d[-n:], recur_tol) is None:
        blocks = d[: d.size - d.size % NOISE_BLOCKS].reshape(NOISE_BLOCKS, -1).mean(axis=1)
        noise = NOISE_SIGMAS * float(np.std(blocks, ddof=1)) / math.sqrt(NOISE_BLOCKS / 3)
    d1, d2 = v2 - v1, v3 - v2
    if d1 == 0.0 or d2 == 0.0 or d2 / d1 < 0.0:
        # no common direction: the averages' own scatter, not a trend
        return v3, v3, 2.0 * max(abs(d1), abs(d2)) + noise
    q = d2 / d1
    if q >= GEOMETRIC_MAX:
        return None
    tail = d2 * q / (1.0 - q)
    return v3, v3 + tail, abs(tail) + abs(d2) + noise


def stroboscope(samples: Any, times: Any) -> np.ndarray:
    """x* at the integer times `times` from coarse samples (t, x, vx): the
    first sample at or after each time, moved back to it along its velocity
    (a sample lies within one step of its grid time)."""
    t = samples[:, R.T_]
    i = np.searchsorted(t, times - 1e-12)
    i = np.minimum(i, t.size - 1)
    return samples[i, R.X] - samples[i, R.VX] * (t[i] - times)


class DecidedRule:
    """The `decided` rule's state through one run (see the module docstring).

    periods: T_obs; tau: the ramp time; fidelity: its stated drift error
    sets the tolerance.  After the run: `reason` (REASONS index),
    `t_stop` (periods actually run), `rate` (v_inf, NaN unless regular),
    `t_strobe`, `x_strobe` (the whole period the extrapolation starts from).
    """

    def __init__(
        self,
        periods: float,
        tau: float,
        amplitude: float,
        mass: float,
        fidelity: str = "standard",
        v0: float = V0,
    ) -> None:
        self.periods = float(periods)
        self.amplitude = float(amplitude)
        self.mass = float(mass)
        self.tolerance = DECIDED_FRACTION * STATED_DRIFT_ERROR[fidelity]
        self.t_settle = settle_time(tau, self.tolerance)
        self.v0 = v0
        self.reason = STOP_RAN_TO_END
        self.t_stop = self.periods
        self.rate = math.nan
        self.t_strobe = math.nan
        self.x_strobe = math.nan
        self._growth: list = []  # (t, log growth since the start) of the tangent
        self._quiet_until = -math.inf  # no decision can come before (a long flight's landing)

    def next_check(self, t: float) -> float:
        """The time of the next check after t (a chunk end)."""
        first = self.t_settle + MIN_WINDOW
        if t < first:
            return float(first)
        # every CHECK_EVERY periods, or every CHECK_FRACTION of the time since
        # the ramp where that is longer (a bounded cost per run)
        t_next = math.floor(t + max(CHECK_EVERY, CHECK_FRACTION * (t - self.t_settle)))
        # in a flight that already blocks the windows: nothing new until it
        # can land again (its earliest landing, `__call__`)
        return float(max(t_next, self._quiet_until // 1.0))

    def __call__(self, t_now, samples, events, in_flight_since=None, lyapunov=None, flight=None):
        """Decide at a chunk end t_now: True to stop (reason set).
        samples, events: the run's records so far; in_flight_since: the
        start of a flight in progress (None in contact); lyapunov: (t0, log
        growth since t0) of the tangent so far, or None if not measured;
        flight: a point (t, x, vx, y, vy) of the flight in progress."""
        if t_now >= self.periods:
            return False
        if flight is not None and self._flies_to_end(*flight):
            return True
        if flight is not None and in_flight_since is not None:
            # a flight longer than the windows allow stays longer (the windows
            # grow a quarter as fast as it): no check before its earliest
            # landing, where it first reaches -A* (constant along the flight;
            # before T_obs, or it would have flown to the end).  Skipped
            # checks only delay a decision.
            t, _, _, y, vy = flight
            if t_now - in_flight_since > FLIGHT_FRACTION * (t_now - self.t_settle) / 3.0:
                self._quiet_until = t + ballistic_reach_time(y, vy, self.mass, self.amplitude)
        # chaotic hopping: a run that never left the surface is not called
        # chaotic early (its tangent can grow for a while near a resonance
        # of the contact oscillation and decay later)
        if lyapunov is not None and self._chaotic(t_now, *lyapunov) and (events[:, 1] == R.TAKEOFF).any():
            self.reason = STOP_CHAOTIC
            self.t_stop = float(samples[-1, R.T_])
            return True
        k_end = int(math.floor(t_now + 1e-9))
        if samples[-1, R.T_] < k_end:  # the sample at k_end is not yet recorded
            k_end -= 1
        third = (k_end - self.t_settle) // 3
        if third < MIN_WINDOW // 3:
            return False
        k0 = k_end - 3 * third
        if lyapunov is not None:
            t0, growth = lyapunov
            if not (t_now - t0 >= 1.0 and growth / (t_now - t0) < CHAOS_LYAPUNOV):
                return False
        if self._long_flight(events, k0, t_now, in_flight_since, third):
            return self._recurs(samples, events, k_end)
        i0 = max(int(np.searchsorted(samples[:, R.T_], k0 - 1.0)), 0)
        x = stroboscope(samples[i0:], np.arange(k0, k_end + 1, dtype=float))
        d = np.diff(x)
        scale = max(abs(float(np.mean(d[-third:]))), self.v0)
        rate = remaining_rate(d, third, self.tolerance * scale)
        if rate is None:
            return False
        v3, v_inf, bound = rate
        rest = self.periods - k_end
        if bound * rest / self.periods > self.tolerance * max(abs(v_inf), self.v0):
            return False
        self.reason = STOP_REGULAR
        self.rate = v_inf
        self.t_stop = float(samples[-1, R.T_])
        self.t_strobe = float(k_end)
        self.x_strobe = float(x[-1])
        return True

    def _recurs(self, samples, events, k_end):
        """True (reason STOP_RECURRENT, the rest known) if the in-flight
        stroboscope recurs with a period p (module comment: recurrent) and
        its cycles' advance is decided to the tolerance."""
        # a recurrence needs a flight in each of its cycles (a cheap test first)
        j = int(np.searchsorted(events[:, 0], self.t_settle))
        if np.count_nonzero(events[j:, 1] == R.TAKEOFF) < RECUR_CYCLES + 1:
            return False
        t = samples[:, R.T_]

        def in_flight_at(times):
            """The rows of the samples exactly at `times` in flight (-1 where none)."""
            rows = np.minimum(np.searchsorted(t, times - 1e-9), t.size - 1)
            ok = (np.abs(t[rows] - times) <= 1e-9) & (samples[rows, R.STATE] == FLIGHT)
            return np.where(ok, rows, -1)

        # the last whole period in flight, within reach of a recurrence
        latest = in_flight_at(
            np.arange(k_end, max(self.t_settle, k_end - RECUR_LONGEST) - 1, -1, dtype=float)
        )
        found = np.flatnonzero(latest >= 0)
        if found.size == 0:
            return False
        row = int(latest[found[0]])
        k = k_end - int(found[0])
        longest = min(RECUR_LONGEST, (k - self.t_settle) // RECUR_CYCLES)
        if longest < 1:
            return False
        state = [R.VX, R.Y, R.VY]
        now = samples[row, state]
        v_scale = 2.0 * math.pi * self.amplitude
        tol = RECUR_TOL * (np.array([v_scale, self.amplitude, v_scale]) + np.abs(now))
        periods = np.arange(1, longest + 1)
        back = in_flight_at(k - np.outer(periods, np.arange(1, RECUR_CYCLES + 1)).astype(float))
        same = (back >= 0) & np.all(np.abs(samples[back][:, :, state] - now) <= tol, axis=2)
        hits = np.flatnonzero(same.all(axis=1))
        if hits.size == 0:
            return False
        p = int(periods[hits[0]])
        back = back[hits[0]]
        x = samples[[row, *back], R.X]  # at k, k - p, ..., k - RECUR_CYCLES p
        advance = x[:-1] - x[1:]  # the cycles', latest first
        change = np.abs(np.diff(advance))
        rounding = 64.0 * np.finfo(float).eps * float(np.max(np.abs(x)) + 1.0)
        if change[0] > max(float(change[1:].max()), rounding):
            return False  # the advance changes faster: not settled
        n = math.ceil((self.periods - k) / p)
        rate = float(advance[0]) / p
        worst = float(change.max()) * (n + 0.5 * n * (n + 1))
        if worst / self.periods > self.tolerance * max(abs(rate), self.v0):
            return False
        self.reason = STOP_RECURRENT
        self.rate = rate
        self.t_stop = float(samples[-1, R.T_])
        self.t_strobe = self.periods - n * p  # in (k - p, k]
        self.x_strobe = float(stroboscope(samples, np.array([self.t_strobe]))[0])
        return True

    def _flies_to_end(self, t, x, vx, y, vy):
        """True (reason STOP_FLIGHT, the rest known) if a flight through (t, x,
        vx, y, vy) cannot land again before T_obs."""
        if t >= self.periods or not all(math.isfinite(v) for v in (x, vx, y, vy)):
            return False
        if t + ballistic_reach_time(y, vy, self.mass, self.amplitude) <= self.periods:
            return False
        self.reason = STOP_FLIGHT
        self.rate = vx
        self.t_stop = t
        self.t_strobe = t
        self.x_strobe = x
        return True

    def _chaotic(self, t_now, t0, growth):
        if t0 < 0.0 or not math.isfinite(growth):
            return False
        self._growth.append((t_now, growth))
        span = t_now - t0
        if span < MIN_CHAOS_PERIODS:
            return False
        bar = CHAOS_MARGIN * CHAOS_LYAPUNOV
        if growth / span <= bar:
            return False
        # the growth over the second half of the measurement alone
        t_half = t0 + 0.5 * span
        times = np.array([g[0] for g in self._growth])
        j = int(np.searchsorted(times, t_half))
        if j >= len(self._growth) - 1:
            return False
        t_mid, g_mid = self._growth[j]
        return (growth - g_mid) / (t_now - t_mid) > bar

    @staticmethod
    def _long_flight(events, k0, t_now, in_flight_since, window):
        """True if a flight overlapping [k0, t_now] lasts longer than
        FLIGHT_FRACTION of a window (its drift is a flight's, not a regime's)."""
        limit = FLIGHT_FRACTION * window
        if in_flight_since is not None and t_now - in_flight_since > limit:
            return True
        # the flights ending in the window: their take-offs lie after k0 - limit
        # or belong to a flight longer than limit, which ends after the last
        # take-off before k0 - limit
        j = int(np.searchsorted(events[:, 0], k0 - limit))
        kinds = events[:, 1]
        before = np.flatnonzero(kinds[:j] == R.TAKEOFF)
        events = events[before[-1] if before.size else j :]
        kinds = events[:, 1]
        t_to = events[kinds == R.TAKEOFF, 0]
        t_la = events[kinds == R.LANDING, 0]
        if t_to.size == 0 or t_la.size == 0:
            return False
        j = np.searchsorted(t_la, t_to, side="right")
        ok = j < t_la.size
        dur = t_la[j[ok]] - t_to[ok]
        overlap = t_la[j[ok]] >= k0
        return bool(np.any(dur[overlap] > limit))

    def drift_velocity(self) -> Any:
        """x*(T)/T: for a regular stop, the run to the last whole period plus
        v_inf for the rest (a flight: to its point, plus its v_x*); else None
        (the run's own x*(t)/t)."""
        if self.reason not in (STOP_REGULAR, STOP_FLIGHT, STOP_RECURRENT):
            return None
        return (self.x_strobe + self.rate * (self.periods - self.t_strobe)) / self.periods

    def attrs(self) -> dict[str, Any]:
        """The run's attributes of the rule."""
        return {
            "stop": "decided",
            "stop_reason": REASONS[self.reason],
            "periods_run": self.t_stop,
            "asymptotic_drift_velocity": None if math.isnan(self.rate) else self.rate,
            "decided_drift_velocity": self.drift_velocity(),
        }


def replay(rule: DecidedRule, samples: Any, events: Any) -> DecidedRule:
    """The `decided` rule checked on a finished run's records.

    Checked at the times its checks come in a run (`DecidedRule.next_check`
    from t = 0), each given the records up to its time and the flight then
    in progress.  Left out: the Lyapunov exponent (the caller judges chaos)
    and a flight's continuation to T_obs (a flight stop is a launch).

    Parameters
    ----------
    rule : DecidedRule
        A new rule for the run's scene (its T_obs, tau, A*, m*, fidelity).
    samples : numpy.ndarray
        float[n, records.NCOL], the run's samples (columns t, x, vx, y, vy
        and state read).
    events : numpy.ndarray
        float[k, 3], the run's events (t, kind, value).

    Returns
    -------
    DecidedRule
        `rule`, saying where it stops the run (`reason` STOP_REGULAR or
        STOP_RECURRENT, `t_strobe`, `rate`), else left at STOP_RAN_TO_END.
    """
    t = samples[:, R.T_]
    t_events, kinds = events[:, 0], events[:, 1]
    check = rule.next_check(0.0)
    while check < rule.periods and check <= t[-1]:
        n = int(np.searchsorted(t, check + 1e-9, side="right"))
        k = int(np.searchsorted(t_events, check, side="right"))
        took_off = np.flatnonzero(kinds[:k] == R.TAKEOFF)
        landed = np.flatnonzero(kinds[:k] == R.LANDING)
        flying = took_off.size and (landed.size == 0 or took_off[-1] > landed[-1])
        since = float(t_events[took_off[-1]]) if flying else None
        if rule(check, samples[:n], events[:k], since):
            break
        check = rule.next_check(check)
    return rule
