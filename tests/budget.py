"""Time budgets for tests, scaled to the machine they run on.

Tests wait on events (a DOM or Bokeh-document condition, a health endpoint,
a process exit); the budget only bounds a hang so that it still ends, with a
message naming what was awaited.  A budget is `seconds` on an idle machine
with a core per busy process, scaled by `factor()`:

    factor = max(1, (1-minute load average + 1) / usable cores)
             * VIBTRANS_TEST_BUDGET_FACTOR (default 1)

so a machine whose cores are all taken by other work (the load this suite was
seen failing under: one core of two busy) gets proportionally longer.  The
factor is read at each call, since the load changes during a session.
"""

import os


def usable_cores():
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def factor():
    """How much slower than an idle machine this one is taken to be (>= 1)."""
    try:
        load = os.getloadavg()[0]
    except OSError:
        load = 0.0
    extra = os.environ.get("VIBTRANS_TEST_BUDGET_FACTOR", "1")
    try:
        extra = float(extra)
    except ValueError:
        raise ValueError(f"VIBTRANS_TEST_BUDGET_FACTOR must be a number >= 1, got {extra!r}") from None
    if not extra >= 1:
        raise ValueError(f"VIBTRANS_TEST_BUDGET_FACTOR must be >= 1, got {extra}")
    return max(1.0, (load + 1.0) / usable_cores()) * extra


def budget(seconds):
    """`seconds` (idle-machine budget) scaled to this machine, in seconds."""
    return seconds * factor()


def budget_ms(seconds):
    """`budget(seconds)` in milliseconds, as Playwright's timeouts take."""
    return budget(seconds) * 1000.0
