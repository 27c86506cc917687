"""A map's accuracy against its cost, by fidelity preset and run length.

Measured by `python -m devtools.map_accuracy --out DIR`: the
41 x 41 window log10 A* in [-3, 3], log10 m* in [-5, 5] at mu 0.5, each
setting's uniform map against the standard, 2000-period map of the same
window (chaos judged by each point's Lyapunov exponent).  Per setting:
the share of the points regular in both maps whose drift class agrees, the
median and 90th percentile of the relative drift difference |v - v_ref| /
max(|v_ref|, 0.1) over them, and the steps relative to the reference.  The
drift of an accelerating regime depends on the observation time, so the
shorter runs' 90th percentile is large while their classes mostly agree.
The explorer's map request shows the nearest setting's figures.
"""
from __future__ import annotations

# (fidelity, periods): (class agreement, median, p90 drift difference, steps ratio)
MEASURED = {
    ("preview", 500.0): (0.9811, 3.6e-05, 0.654, 0.117),
    ("preview", 1000.0): (0.9910, 1.2e-05, 0.395, 0.232),
    ("preview", 2000.0): (0.9972, 5.7e-08, 0.0091, 0.463),
    ("standard", 500.0): (0.9816, 4.6e-05, 0.731, 0.255),
    ("standard", 1000.0): (0.9886, 1.7e-05, 0.485, 0.503),
    ("standard", 2000.0): (1.0, 0.0, 0.0, 1.0),
}
REFERENCE = ("standard", 2000.0)


def nearest(fidelity: str, periods: float) -> tuple[str, float] | None:
    """The measured setting closest to (fidelity, periods): the same preset,
    the nearest period count in log; None for "reference" (not measured:
    more accurate than the standard map the others are judged against)."""
    import math
    same = [p for f, p in MEASURED if f == fidelity]
    if not same or not (isinstance(periods, (int, float)) and periods > 0):
        return None
    return fidelity, min(same, key=lambda p: abs(math.log(p / periods)))


def note(fidelity: str, periods: float) -> str:
    """One line for a map request: what its nearest measured setting gave."""
    key = nearest(fidelity, periods)
    if key is None:
        return (f"*Accuracy: {fidelity} is more accurate than the standard, 2000-period "
                f"maps the other settings are measured against.*")
    agree, median, p90, cost = MEASURED[key]
    if key == REFERENCE:
        return ("*Accuracy: standard, 2000 periods is the setting the others are measured "
                "against (the shipped maps').*")
    return (f"*Accuracy measured for {key[0]}, {key[1]:g} periods against standard, 2000 "
            f"periods (one 41 x 41 window): drift class agrees at {100 * agree:.1f}% of the "
            f"regular points, relative drift difference median {median:.1g}, 90th percentile "
            f"{p90:.2g}; {cost:.2f}x the steps.*")
