"""Waiting on the explorer's state from tests that drive it in-process."""
import asyncio
import time


async def until(cond, timeout=60.0):
    """Poll cond() every 10 ms on the running event loop; AssertionError
    after `timeout` seconds."""
    t0 = time.perf_counter()
    while not cond():
        if time.perf_counter() - t0 > timeout:
            raise AssertionError("timed out")
        await asyncio.sleep(0.01)
