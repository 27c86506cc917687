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
from typing import TYPE_CHECKING

from vibtrans.version import __version__

if TYPE_CHECKING:  # the same names, for type checkers and editors
    from vibtrans.analysis.dynamics import periodic_orbit, run_guess
    from vibtrans.analysis.summary import Summary, summarize
    from vibtrans.core.errors import Cancelled, StepBudgetExceeded
    from vibtrans.core.params import PAPER_POINTS, Scene, paper_scene
    from vibtrans.core.simulate import estimate_steps, simulate, warmup
    from vibtrans.core.threshold import first_takeoff, threshold_amplitude, threshold_curve
    from vibtrans.maps.shipped import maps_dir
    from vibtrans.maps.sweep import Sweep, open_map, open_vertical, run_sweep
    from vibtrans.products.design import design_chart, preset, read_device
    from vibtrans.products.export import (
        export_design,
        export_dynamics,
        export_heatmap,
        export_html,
        export_memory,
        export_paper,
        export_trajectory,
        export_vertical,
    )

# public name -> the submodule defining it
_LAZY = {
    # scenes and runs
    "Scene": "core.params",
    "paper_scene": "core.params",
    "PAPER_POINTS": "core.params",
    "simulate": "core.simulate",
    "estimate_steps": "core.simulate",
    "warmup": "core.simulate",
    "Cancelled": "core.errors",
    "StepBudgetExceeded": "core.errors",
    # take-off thresholds
    "threshold_amplitude": "core.threshold",
    "first_takeoff": "core.threshold",
    "threshold_curve": "core.threshold",
    # reading a run
    "summarize": "analysis.summary",
    "Summary": "analysis.summary",
    "periodic_orbit": "analysis.dynamics",
    "run_guess": "analysis.dynamics",
    # maps
    "Sweep": "maps.sweep",
    "run_sweep": "maps.sweep",
    "open_map": "maps.sweep",
    "open_vertical": "maps.sweep",
    "maps_dir": "maps.shipped",
    # design charts
    "design_chart": "products.design",
    "preset": "products.design",
    "read_device": "products.design",
    # figures and files
    "export_heatmap": "products.export",
    "export_trajectory": "products.export",
    "export_html": "products.export",
    "export_design": "products.export",
    "export_vertical": "products.export",
    "export_dynamics": "products.export",
    "export_memory": "products.export",
    "export_paper": "products.export",
}

__all__ = [
    "Scene",
    "paper_scene",
    "PAPER_POINTS",
    "simulate",
    "estimate_steps",
    "warmup",
    "Cancelled",
    "StepBudgetExceeded",
    "threshold_amplitude",
    "first_takeoff",
    "threshold_curve",
    "summarize",
    "Summary",
    "periodic_orbit",
    "run_guess",
    "Sweep",
    "run_sweep",
    "open_map",
    "open_vertical",
    "maps_dir",
    "design_chart",
    "preset",
    "read_device",
    "export_heatmap",
    "export_trajectory",
    "export_html",
    "export_design",
    "export_vertical",
    "export_dynamics",
    "export_memory",
    "export_paper",
    "__version__",
]


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
