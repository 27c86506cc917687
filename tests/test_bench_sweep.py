"""`vibtrans bench --sweep`'s issue-16 figures are computed from what they
claim (the numbers themselves are the benchmark's, not asserted here: a
shared machine's timings are noisy)."""
import pytest

from vibtrans.tools import bench


@pytest.mark.slow
def test_sweep_figures_are_made_of_their_parts():
    r = bench.sweep_step_ratio(quick=True)
    assert r["sweep_points"] == 121 and r["sweep_steps"] > 0 and r["cores"] >= 1
    assert r["sweep_step_ratio"] == pytest.approx(
        r["sweep_seconds"] * r["cores"] / (r["sweep_steps"] * r["vertical_ns_per_step"] * 1e-9))
    # the split: the kernels' share and the rest multiply to the ratio; the
    # kernels ran inside the sweep's wall time on its cores
    assert r["sweep_kernel_step_ratio"] * r["sweep_overhead_factor"] == pytest.approx(
        r["sweep_step_ratio"])
    assert 0.0 < r["sweep_kernel_step_ratio"] <= r["sweep_step_ratio"]
    p = bench.preview_window_times(quick=True)
    assert 0.0 < p["preview_first_image_seconds"] <= p["preview_window_seconds"]
    assert 0.0 < p["preview_computed_fraction"] <= 1.0 and p["preview_points"] == 17 * 17
