"""`vibtrans bench --sweep`'s figures are computed from what they
claim (the numbers themselves are the benchmark's, not asserted here: a
shared machine's timings are noisy)."""

import pytest

from vibtrans.tools import bench


@pytest.mark.slow
def test_sweep_figures_are_made_of_their_parts():
    r = bench.sweep_step_ratio(quick=True)
    assert r["sweep_points"] == 121 and r["sweep_steps"] > 0 and r["cores"] >= 1
    assert r["sweep_step_ratio"] == pytest.approx(
        r["sweep_seconds"] * r["cores"] / (r["sweep_steps"] * r["vertical_ns_per_step"] * 1e-9)
    )
    # the split: the kernels' share and the rest multiply to the ratio; the
    # kernels ran inside the sweep's wall time on its cores
    assert r["sweep_kernel_step_ratio"] * r["sweep_overhead_factor"] == pytest.approx(r["sweep_step_ratio"])
    assert 0.0 < r["sweep_kernel_step_ratio"] <= r["sweep_step_ratio"]
    p = bench.preview_window_times(quick=True)
    assert 0.0 < p["preview_first_image_seconds"] <= p["preview_window_seconds"]
    assert 0.0 < p["preview_computed_fraction"] <= 1.0 and p["preview_points"] == 17 * 17


@pytest.mark.slow
def test_decided_trade_figures_are_made_of_their_parts(tmp_path):
    # the decided trade's keys, computed from the four stores the bench leaves in `keep`
    import numpy as np

    from vibtrans.analysis.summary import V0
    from vibtrans.core.fidelity import STATED_DRIFT_ERROR
    from vibtrans.maps.sweep import open_map

    r = bench.decided_trade(quick=True, keep=str(tmp_path))
    assert r["decided_speedup"] == pytest.approx(
        (r["decided_deformable_full_cpu_seconds"] + r["decided_point-mass_full_cpu_seconds"])
        / (r["decided_deformable_decided_cpu_seconds"] + r["decided_point-mass_decided_cpu_seconds"])
    )
    n = k = 0
    for model in bench.DECIDED_MODELS:
        full = open_map(str(tmp_path / f"{model}-full.zarr"))
        dec = open_map(str(tmp_path / f"{model}-decided.zarr"))
        assert dec.attrs["stop"] == "decided" and "stop" not in full.attrs
        regular = (full["chaotic"].values != 1) & (dec["chaotic"].values != 1)
        vf, vd = full["drift_velocity"].values, dec["drift_velocity"].values
        drifting = regular & (np.abs(vf) > V0)
        ok = np.abs(vd - vf) <= STATED_DRIFT_ERROR["standard"] * np.abs(vf)
        n += int(drifting.sum())
        k += int(ok[drifting].sum())
        assert r[f"decided_{model}_mean_periods_run"] == pytest.approx(float(dec["periods_run"].mean()))
        # the ceiling: ran-to-end points at T_obs, the others at the floor
        from vibtrans.core.stopping import STOP_RAN_TO_END
        from vibtrans.maps.cost import DECIDED_PERIOD_COST, expected_periods, minimum_periods

        periods, tau = r["decided_periods"], float(dec.attrs["scene_tau"])
        f_end = float((dec["stop_reason"].values == STOP_RAN_TO_END).mean())
        floor = min(periods, minimum_periods(tau))
        assert r[f"decided_{model}_speedup_ceiling"] == pytest.approx(
            periods / (f_end * periods + (1.0 - f_end) * floor)
        )
        assert r[f"decided_{model}_estimate_ratio"] == pytest.approx(
            r[f"decided_{model}_full_cpu_seconds"]
            * expected_periods(model, "decided", periods, tau)
            / periods
            * DECIDED_PERIOD_COST[model]  # a decided run's period over a full run's
            / r[f"decided_{model}_decided_cpu_seconds"]
        )
    assert n > 0 and r["decided_drift_within_error"] == pytest.approx(k / n)
    assert 0.0 <= r["decided_class_agreement"] <= 1.0
