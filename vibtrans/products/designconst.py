"""The design chart's constants shared by the command line's parser, the
chart and its figure; importing nothing, the parser loads no numerics."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy.typing as npt

# van der Waals adhesion in air: w = A_H / (12 pi D0^2), A_H = 1e-19 J, D0 =
# 0.165 nm (Israelachvili, Intermolecular and Surface Forces, 3rd ed., 13.6): 0.097 J/m^2
DEFAULT_SURFACE_ENERGY = 0.1  # J/m^2 (work of adhesion)
MAP_STEP = 0.05  # decades, the shipped maps' grid
PRESET_NAMES = ("paper", "saw-motor", "saw-powder", "feeder")
AXIS_LABELS = {
    "frequency": "frequency f (Hz)",
    "radius": "particle radius R (m)",
    "amplitude": "wave amplitude A_y (m)",
}
# Regimes of a chart point (outlined on the figure), from the map's flags.
REGIMES = (
    "no drift",
    "sliding with the wave",
    "sliding against the wave",
    "synchronous hopping",
    "other hopping",
    "chaotic",
)


def velocity_unit(v: npt.ArrayLike) -> tuple[str, float]:
    """(name, scale) of speeds v [m/s]: mm/s from a largest finite |v| of 1 mm/s, else um/s."""
    import numpy as np  # (here: the parser imports this module)

    finite = np.abs(np.asarray(v, dtype=float))
    finite = finite[np.isfinite(finite)]
    return ("mm/s", 1e-3) if finite.size and finite.max() >= 1e-3 else ("um/s", 1e-6)
