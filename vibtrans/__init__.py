"""vibtrans: vibrational transport of a particle on a substrate carrying a
Rayleigh wave (deformable Hertz-Mindlin particle and material point).

Normalized units throughout (docs/MODEL.md): lengths in a0, time in wave periods.

The public names are imported on first use (PEP 562): `import vibtrans`
alone, and so the command line (`vibtrans.cli`), load none of the numerics
(numba, xarray, scipy: ~1.5 s), so that `vibtrans serve` decides its
re-execution on the C allocator before paying for them (paid twice before).
"""
import importlib
import sys
import types

from vibtrans.version import __version__

# public name -> the submodule defining it
_LAZY = {"Scene": "core.params", "paper_scene": "core.params", "PAPER_POINTS": "core.params",
         "Cancelled": "core.errors", "StepBudgetExceeded": "core.errors",
         "warmup": "core.simulate", "maps_dir": "maps.shipped",
         "simulate": "core.simulate", "estimate_steps": "core.simulate"}

__all__ = ["Scene", "paper_scene", "PAPER_POINTS", "simulate", "estimate_steps",
           "Cancelled", "StepBudgetExceeded", "warmup", "maps_dir", "__version__"]


class _Package(types.ModuleType):
    def __getattr__(self, name):
        where = _LAZY.get(name)
        if where is None:
            raise AttributeError(f"module 'vibtrans' has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{where}", __name__), name)
        setattr(self, name, value)
        return value

    def __dir__(self):
        return sorted({*super().__dir__(), *_LAZY})


sys.modules[__name__].__class__ = _Package
