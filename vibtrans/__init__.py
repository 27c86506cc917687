"""vibtrans: vibrational transport of a particle on a substrate carrying a
Rayleigh wave (deformable Hertz-Mindlin particle and material point).

Normalized units throughout (docs/MODEL.md): lengths in a0, time in wave periods.
"""
from .version import __version__
from .params import PAPER_POINTS, Scene, paper_scene  # noqa: E402
from .errors import Cancelled, StepBudgetExceeded  # noqa: E402
from .precompile import warmup  # noqa: E402
from .shipped import maps_dir  # noqa: E402
from .simulate import estimate_steps, simulate  # noqa: E402

__all__ = ["Scene", "paper_scene", "PAPER_POINTS", "simulate", "estimate_steps",
           "Cancelled", "StepBudgetExceeded", "warmup", "maps_dir", "__version__"]
