"""What the kernels record: sample columns, event kinds, and the counters.

Every model kernel writes into the same preallocated buffers, so one
trajectory builder serves them all and a kernel can stop (chunk end, buffer
full) and resume later with nothing lost:

    samples  float64[capacity, NCOL]  one row per recorded instant
    events   float64[capacity, 3]     (t*, kind, value)
    ctr      int64[NCTR]              counters and cursors, below

Samples are recorded on a coarse grid (every `sample_dt` periods: the state at
the first committed step at or after each grid time, or exactly at that time
during a closed-form flight) and at every step inside the full-resolution
window [win_t0, win_t1].  Events are exact (root-found or interpolated).
"""

import numpy as np

from vibtrans.core.kernels.jit import helper

# sample columns
T_, X, VX, Y, VY, A, B, BDOT, N, TF, STATE, STICK_R, CONTACT_R = range(13)
NCOL = 13
COLUMNS = ("t", "x", "vx", "y", "vy", "a", "b", "bdot", "N", "T", "state", "stick_radius", "contact_radius")

# event kinds (column 1 of events); column 2 holds the value
TAKEOFF = 0  # value: phase t mod 1
LANDING = 1  # value: phase t mod 1
STATE_CHANGE = 2  # value: the new state code (contact.STATE_NAMES)
EVENT_NAMES = ("takeoff", "landing", "state")

# counters
C_STEPS = 0  # committed integration steps (or root-scan steps)
C_NSAMP = 1  # rows used in samples
C_NEVT = 2  # rows used in events
C_NEXT = 3  # index k of the next coarse sample time k * sample_dt
C_MODE = 4  # model-specific mode (e.g. 1 = in flight)
C_STATE = 5  # last contact state code
C_HIST = 6  # valid entries of the multistep history
C_FEVALS = 7  # force evaluations
C_WNEXT = 8  # index k of the next window sample k * h inside a flight
NCTR = 9

# kernel return codes
DONE = 0  # reached t_stop
EVENTS_FULL = 1  # grow `events` and call again
SAMPLES_FULL = 2  # grow `samples` and call again
MEMORY_FULL = 3  # grow the memory-diagram arrays and call again
EVENTS_RUNAWAY = 4  # more than a kernel's limit of events between two steps: refuse


def new_counters() -> np.ndarray:
    return np.zeros(NCTR, dtype=np.int64)


@helper
def add_event(events: np.ndarray, ctr: np.ndarray, t: float, kind: float, value: float) -> None:
    k = ctr[C_NEVT]
    events[k, 0] = t
    events[k, 1] = kind
    events[k, 2] = value
    ctr[C_NEVT] = k + 1


@helper
def want_sample(t: float, ctr: np.ndarray, sample_dt: float, win_t0: float, win_t1: float) -> bool:
    """True if the state at time t should be recorded; advances the cursor."""
    take = False
    while ctr[C_NEXT] * sample_dt <= t:
        ctr[C_NEXT] += 1
        take = True
    if win_t0 <= t <= win_t1:
        take = True
    return take


@helper
def record(
    samples: np.ndarray,
    ctr: np.ndarray,
    t: float,
    x: float,
    vx: float,
    y: float,
    vy: float,
    a: float,
    b: float,
    bdot: float,
    nf: float,
    tf: float,
    state: float,
    s: float,
    c: float,
) -> None:
    k = ctr[C_NSAMP]
    row = samples[k]
    row[T_] = t
    row[X] = x
    row[VX] = vx
    row[Y] = y
    row[VY] = vy
    row[A] = a
    row[B] = b
    row[BDOT] = bdot
    row[N] = nf
    row[TF] = tf
    row[STATE] = state
    row[STICK_R] = s
    row[CONTACT_R] = c
    ctr[C_NSAMP] = k + 1
