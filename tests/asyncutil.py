"""Waiting on a condition: the explorer's state from tests that drive it
in-process (`until`, on the running event loop), or a server, a process or
a file from a test's own thread (`wait_until`).  The only polling loops of
the tests: each names what it waited for when it times out."""

import asyncio
import time

from budget import budget


async def until(cond, timeout=None):
    """Poll cond() every 10 ms on the running event loop until it holds;
    AssertionError (naming cond) after `timeout` seconds (default:
    budget(60), scaled to the machine)."""
    timeout = budget(60) if timeout is None else timeout
    t0 = time.perf_counter()
    while not cond():
        if time.perf_counter() - t0 > timeout:
            what = getattr(cond, "__qualname__", repr(cond))
            raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")
        await asyncio.sleep(0.01)


def wait_until(cond, timeout=None, what=None, every=0.05):
    """Poll cond() every `every` seconds until it returns a true value, and
    return that value; AssertionError naming `what` (default: cond's name)
    after `timeout` seconds (default: budget(60), scaled to the machine)."""
    timeout = budget(60) if timeout is None else timeout
    t0 = time.perf_counter()
    while not (got := cond()):
        if time.perf_counter() - t0 > timeout:
            what = what or getattr(cond, "__qualname__", repr(cond))
            raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(every)
    return got
