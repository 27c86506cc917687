"""The design chart's constants that the command line's parser shows
and the figure shares with the chart (vibtrans.products.design and vibtrans.products.plots
use them; this module imports nothing, so building the parser loads no
numerics, and the figure does not import the chart's computing)."""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy.typing as npt

# Work of adhesion w of two solids in air held by van der Waals forces:
# w = A_H / (12 pi D0^2) with a Hamaker constant A_H = 1e-19 J (typical of
# inorganic solids) and the contact cut-off D0 = 0.165 nm (Israelachvili,
# Intermolecular and Surface Forces, 3rd ed. 2011, sec. 13.6) gives 0.097 J/m^2.
DEFAULT_SURFACE_ENERGY = 0.1      # J/m^2 (work of adhesion)
MAP_STEP = 0.05                   # decades, the shipped maps' grid
PRESET_NAMES = ("paper", "saw-motor", "saw-powder", "feeder")
AXIS_LABELS = {"frequency": "frequency f (Hz)", "radius": "particle radius R (m)",
               "amplitude": "wave amplitude A_y (m)"}
# Regimes of a chart point (outlined on the figure), from the map's flags.
REGIMES = ("no drift", "sliding with the wave", "sliding against the wave",
           "synchronous hopping", "other hopping", "chaotic")


def velocity_unit(v: npt.ArrayLike) -> tuple[str, float]:
    """(name, scale) of the unit that reads best for speeds v [m/s] (an
    array): mm/s when the largest finite |v| is at least 1 mm/s, else um/s."""
    import numpy as np  # (here: the parser imports this module)
    finite = np.abs(np.asarray(v, dtype=float))
    finite = finite[np.isfinite(finite)]
    return ("mm/s", 1e-3) if finite.size and finite.max() >= 1e-3 else ("um/s", 1e-6)
