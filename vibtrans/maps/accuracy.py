"""A map's accuracy against its cost, by fidelity preset and run length, for
the explorer's map request, as measured: each setting's 41 x 41 map (log10
A* in [-3, 3], log10 m* in [-5, 5], mu 0.5) against the standard 2000-period
one (tests/maps/test_mapaccuracy.py's `study`); the share of regular points
whose drift class agrees, the median and 90th percentile of |v - v_ref| /
max(|v_ref|, 0.1) (large for short runs: accelerating drifts), the steps.
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
    """The measured setting of the same preset nearest in log periods (None: not measured)."""
    import math

    same = [p for f, p in MEASURED if f == fidelity]
    if not same or not (isinstance(periods, (int, float)) and periods > 0):
        return None
    return fidelity, min(same, key=lambda p: abs(math.log(p / periods)))


def note(fidelity: str, periods: float) -> str:
    """A map request's line: what its nearest measured setting gave."""
    key = nearest(fidelity, periods)
    if key is None:
        return (
            f"*Accuracy: {fidelity} is more accurate than the standard, 2000-period "
            f"maps the other settings are measured against.*"
        )
    agree, median, p90, cost = MEASURED[key]
    if key == REFERENCE:
        return (
            "*Accuracy: standard, 2000 periods is the setting the others are measured "
            "against (the shipped maps').*"
        )
    return (
        f"*Accuracy measured for {key[0]}, {key[1]:g} periods against standard, 2000 "
        f"periods (one 41 x 41 window): drift class agrees at {100 * agree:.1f}% of the "
        f"regular points, relative drift difference median {median:.1g}, 90th percentile "
        f"{p90:.2g}; {cost:.2f}x the steps.*"
    )
