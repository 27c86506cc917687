"""Waiting on the explorer's state from tests that drive it in-process."""
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
