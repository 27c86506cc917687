"""The profile part of `vibtrans bench`: what its ratios rest on.

`same_motion_*` compares the profile code with Hertz's on the sphere's own
motion; that holds only if every path runs the same steps (to rounding: the
power law p = 3/2 and the tabulated sphere are the sphere's law)."""

import math

from vibtrans.tools import bench


def test_same_motion_paths_run_the_sphere_steps():
    ns, steps = bench._profile_same_motion_ns(1)
    assert len(ns) == len(steps) == 4
    assert len(set(steps)) == 1 and steps[0] > 0
    assert all(math.isfinite(v) and v > 0 for v in ns)


def test_profile_cost_reports_every_ratio():
    c = bench._profile_cost(1)
    for key in (
        "power_over_sphere",
        "tabulated_over_sphere",
        "same_motion_power_over_sphere",
        "same_motion_tabulated_over_sphere",
        "same_motion_power_pow_over_sphere",
    ):
        assert math.isfinite(c[key]) and c[key] > 0, key
    assert c["power_profile"] == bench.PROFILE_BENCH["power"]
    assert c["tabulated_profile"] == bench.PROFILE_BENCH["tabulated"]
