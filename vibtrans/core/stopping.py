"""The stopping rule of a run: `full` (run to T_obs, the default) or
`decided` (stop once the run's outcome is known to the fidelity's stated
drift error; issue 35).

The rule is evaluated by the drivers between kernel calls (the chunks they
already make for progress and cancellation), from what the run has already
recorded: the coarse samples (x*, v_x* every 1/samples_per_period), the
take-off and landing events, and, where the run measures it, the vertical
motion's tangent (its Lyapunov exponent).  Its extra cost is one short numpy
evaluation per check, every CHECK_EVERY periods.

Decided, after the ramp (t >= RAMP_OFF tau, where G(t) = 1 to double
precision):

* regular: the asymptotic drift rate v_inf, a weighted Birkhoff average
  (Das, Sander, Saiki and Yorke 2017, weight exp(-1/(s(1-s)))) of the drift
  per period x*(k+1) - x*(k), taken over the two halves of the periods since
  the ramp.  On a periodic or quasi-periodic orbit both halves converge
  super-polynomially to the same rate; on a chaotic one, or one that still
  accelerates, they do not.  Decided when the halves agree so closely that,
  even extrapolating the difference as a linear trend over the rest of the
  run, x*(T)/T moves by less than DECIDED_FRACTION of the stated error
  (relative, floor v0* = fidelity.V0), no flight overlapping the window is
  longer than a quarter of a half, and (where measured) the Lyapunov exponent
  so far is below lyapunov.CHAOS_LYAPUNOV.  The run reports
  x*(T)/T = (x*(k) + v_inf (T - k)) / T from the last whole period k, and
  v_inf itself (`asymptotic_drift_velocity`).
* chaotic: the Lyapunov exponent is measured (vertical motion's tangent) and
  both its value since the ramp and its value over the second half of that
  time exceed CHAOS_MARGIN x CHAOS_LYAPUNOV, after at least
  MIN_CHAOS_PERIODS, in a run that has taken off: a regular orbit's finite-time exponent decays as
  log(t)/t and over a second half alone is log(2)/(t/2)-small; a chaotic
  one's stays.  The run keeps its drift so far, flagged.
* flight: a flight in progress that, continued ballistically, cannot reach
  the substrate again before T_obs (`ballistic_reach_time`: y* above
  -A*, the highest the surface comes) ends the run exactly:
  x*(T) = x* + v_x* (T - t), v_inf = v_x* (the launched scenes of the upper
  right).
* otherwise (not steady, e.g. paper point 4's accelerating drift) the run
  goes on to T_obs (reason `ran-to-end`).
"""
import math

import numpy as np

from vibtrans.core.errors import InputError
from vibtrans.core.fidelity import STATED_DRIFT_ERROR, V0
from vibtrans.core.kernels import records as R
from vibtrans.core.kernels.substrate import RAMP_OFF
from vibtrans.core.lyapunov import CHAOS_LYAPUNOV

STOPS = ("full", "decided")
# why a run stopped (stored per map point as `stop_reason`)
REASONS = ("full", "regular", "chaotic", "ran-to-end", "flight")
FULL, REGULAR, CHAOTIC, RAN_TO_END, FLIGHT = range(5)

MIN_WINDOW = 60          # periods after the ramp before the first check (three windows of 20)
CHECK_EVERY = 8          # periods between checks, at least
CHECK_FRACTION = 1 / 8   # of the time since the ramp, between checks, at least
DECIDED_FRACTION = 0.5   # of the stated drift error, spent on the extrapolation
GEOMETRIC_MAX = 0.8      # a change between windows shrinking slower than this: not decided
MAX_PERIOD = 16          # longest recurrence (periods) looked for in the drift per period
NOISE_SIGMAS = 3.0       # standard errors of an average of irregular drifts, in the bound
NOISE_BLOCKS = 12        # batch means of the drifts for that standard error
MIN_CHAOS_PERIODS = 100  # periods of Lyapunov measurement before a chaotic stop
CHAOS_MARGIN = 2.0       # chaotic: exponent above CHAOS_MARGIN x CHAOS_LYAPUNOV
FLIGHT_FRACTION = 0.25   # longest flight allowed in the window, of one of its thirds


def ballistic_reach_time(y, vy, mass, amplitude):
    """Time (periods) until a particle at (y*, y*') in free flight (m* y*''
    = 1, y* down) first reaches y* = -A*, the highest the surface ever comes
    (0 if it is already within reach)."""
    gap = -amplitude - y                 # > 0: out of reach
    if gap <= 0.0:
        return 0.0
    # root of t^2 / (2 m*) + vy t - gap = 0, in the form without cancellation
    root = math.sqrt(vy * vy + 2.0 * gap / mass)
    return mass * (root - vy) if vy <= 0.0 else 2.0 * gap / (vy + root)


def check_stop(stop):
    """The validated stop rule name."""
    if stop not in STOPS:
        raise InputError(f"stop must be one of {', '.join(STOPS)}, got {stop!r}")
    return stop


def birkhoff_weights(n):
    """The weights exp(-1/(s(1-s))), s = (j+1)/(n+1), j < n, normalized to sum 1
    (Das, Sander, Saiki and Yorke 2017)."""
    s = np.arange(1, n + 1) / (n + 1.0)
    w = np.exp(-1.0 / (s * (1.0 - s)))
    return w / w.sum()


def weighted_birkhoff(values):
    """The weighted Birkhoff average of a sequence (float)."""
    values = np.asarray(values, dtype=float)
    return float(birkhoff_weights(values.size) @ values)


def recurrence_period(values, tol, longest=MAX_PERIOD):
    """The smallest p <= longest with |values[k + p] - values[k]| <= tol for
    every k (the stroboscopic state's recurrence, seen in its drift per
    period), or None."""
    values = np.asarray(values)
    for p in range(1, min(longest, values.size // 3) + 1):
        if np.max(np.abs(values[p:] - values[:-p])) <= tol:
            return p
    return None


def remaining_rate(drift_per_period, n, recur_tol=0.0):
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
    d = np.asarray(drift_per_period)[-3 * n:]
    v1, v2, v3 = (float(w @ d[i * n:(i + 1) * n]) for i in range(3))
    if not all(math.isfinite(v) for v in (v1, v2, v3)):
        return None
    noise = 0.0
    if recurrence_period(d[-n:], recur_tol) is None:
        blocks = d[:d.size - d.size % NOISE_BLOCKS].reshape(NOISE_BLOCKS, -1).mean(axis=1)
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


def stroboscope(samples, times):
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

    def __init__(self, periods, tau, amplitude, mass, fidelity="standard", v0=V0):
        self.periods = float(periods)
        self.amplitude = float(amplitude)
        self.mass = float(mass)
        self.t_ramp = math.ceil(RAMP_OFF * tau)
        self.tolerance = DECIDED_FRACTION * STATED_DRIFT_ERROR[fidelity]
        self.v0 = v0
        self.reason = RAN_TO_END
        self.t_stop = self.periods
        self.rate = math.nan
        self.t_strobe = math.nan
        self.x_strobe = math.nan
        self._growth = []              # (t, log growth since the start) of the tangent

    def next_check(self, t):
        """The time of the next check after t (a chunk end)."""
        first = self.t_ramp + MIN_WINDOW
        if t < first:
            return float(first)
        # every CHECK_EVERY periods, or every CHECK_FRACTION of the time since
        # the ramp where that is longer (a bounded cost per run)
        return float(math.floor(t + max(CHECK_EVERY, CHECK_FRACTION * (t - self.t_ramp))))

    def __call__(self, t_now, samples, events, in_flight_since=None, lyapunov=None,
                 flight=None):
        """Decide at a chunk end t_now: True to stop (reason set).
        samples, events: the run's records so far; in_flight_since: the
        start of a flight in progress (None in contact); lyapunov: (t0, log
        growth since t0) of the tangent so far, or None if not measured;
        flight: a point (t, x, vx, y, vy) of the flight in progress."""
        if t_now >= self.periods:
            return False
        if flight is not None and self._flies_to_end(*flight):
            return True
        # chaotic hopping: a run that never left the surface is not called
        # chaotic early (its tangent can grow for a while near a resonance
        # of the contact oscillation and decay later)
        if (lyapunov is not None and self._chaotic(t_now, *lyapunov)
                and (events[:, 1] == R.TAKEOFF).any()):
            self.reason = CHAOTIC
            self.t_stop = float(samples[-1, R.T_])
            return True
        k_end = int(math.floor(t_now + 1e-9))
        if samples[-1, R.T_] < k_end:   # the sample at k_end is not yet recorded
            k_end -= 1
        third = (k_end - self.t_ramp) // 3
        if third < MIN_WINDOW // 3:
            return False
        k0 = k_end - 3 * third
        if self._long_flight(events, k0, t_now, in_flight_since, third):
            return False
        if lyapunov is not None:
            t0, growth = lyapunov
            if not (t_now - t0 >= 1.0 and growth / (t_now - t0) < CHAOS_LYAPUNOV):
                return False
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
        self.reason = REGULAR
        self.rate = v_inf
        self.t_stop = float(samples[-1, R.T_])
        self.t_strobe = float(k_end)
        self.x_strobe = float(x[-1])
        return True

    def _flies_to_end(self, t, x, vx, y, vy):
        """True (reason FLIGHT, the rest known) if a flight through (t, x,
        vx, y, vy) cannot land again before T_obs."""
        if t >= self.periods or not all(math.isfinite(v) for v in (x, vx, y, vy)):
            return False
        if t + ballistic_reach_time(y, vy, self.mass, self.amplitude) <= self.periods:
            return False
        self.reason = FLIGHT
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
        events = events[before[-1] if before.size else j:]
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

    def drift_velocity(self):
        """x*(T)/T: for a regular stop, the run to the last whole period plus
        v_inf for the rest (a flight: to its point, plus its v_x*); else None
        (the run's own x*(t)/t)."""
        if self.reason not in (REGULAR, FLIGHT):
            return None
        return (self.x_strobe + self.rate * (self.periods - self.t_strobe)) / self.periods

    def attrs(self):
        """The run's attributes of the rule."""
        return {"stop": "decided", "stop_reason": REASONS[self.reason],
                "periods_run": self.t_stop,
                "asymptotic_drift_velocity": None if math.isnan(self.rate) else self.rate,
                "decided_drift_velocity": self.drift_velocity()}
