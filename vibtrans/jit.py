"""The decorator of every compiled kernel entry point.

`kernel` = numba.njit(cache=True, nogil=True) without numba's reference-counted
runtime (NRT).  Our kernels never allocate: they work in arrays their caller
owns (and keeps alive) and return plain numbers.  With NRT on, every call of an
inlined helper that takes arrays (the memory diagram's push/pop/clamp, the
history, the records) increments and decrements the arrays' reference counts,
atomically, at every step: measured, that was ~40% of a memory-diagram update
(35 -> 21 ns; `vibtrans bench`).  Without NRT an allocation inside a kernel
fails to compile, which keeps them allocation-free.
"""
from numba import njit


def kernel(fn):
    """Compile `fn` as an allocation-free, GIL-free, disk-cached kernel."""
    return njit(cache=True, nogil=True, _nrt=False)(fn)
