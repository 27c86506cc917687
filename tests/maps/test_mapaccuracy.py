"""The map request's accuracy line (vibtrans/maps/accuracy.py): the nearest
measured setting, and the measured table against a fresh measurement of
every setting on a small window (the table's own computation, `study`)."""

import os

import numpy as np
import pytest

from vibtrans.maps import accuracy as A

WINDOW = ((-3.0, 3.0), (-5.0, 5.0))
MU = 0.5


def _map(folder, points, fidelity, periods):
    from vibtrans.maps.sweep import Sweep, open_map, run_sweep

    (a0, a1), (m0, m1) = WINDOW
    grid = np.linspace(a0, a1, points), np.linspace(m0, m1, points)
    sweep = Sweep(*grid, chunk_rows=1, mu=MU, fidelity=fidelity, periods=periods)
    path = os.path.join(folder, f"{fidelity}-{periods:g}-{points}.zarr")
    run_sweep(sweep, path, progress=False)
    return open_map(path)


def study(folder, points=41):
    """Each setting of A.MEASURED's map against the reference one on a
    points x points window (the table's is 41 x 41): class agreement of the
    regular points, median and 90th percentile of |v - v_ref| / max(|v_ref|,
    v0), steps over the reference's."""
    from vibtrans.maps.difference import map_difference

    reference = _map(folder, points, *A.REFERENCE)
    ref_steps = float(reference["steps"].values.sum())
    rows = []
    for fidelity, periods in A.MEASURED:
        ds = reference if (fidelity, periods) == A.REFERENCE else _map(folder, points, fidelity, periods)
        diff = map_difference(reference, ds)
        regular = diff["compared"].values & ~diff["chaotic_either"].values
        v1 = diff["drift_velocity_first"].values[regular]
        v2 = diff["drift_velocity_second"].values[regular]
        relative = np.abs(v2 - v1) / np.maximum(np.abs(v1), diff.attrs["v0"])
        rows.append(
            {
                "fidelity": fidelity,
                "periods": periods,
                "class_agreement": diff.attrs["class_agreement"],
                "median_drift_difference": float(np.median(relative)),
                "p90_drift_difference": float(np.percentile(relative, 90)),
                "regular_points": int(regular.sum()),
                "steps_over_reference": float(ds["steps"].values.sum()) / ref_steps,
            }
        )
    return rows


def test_the_nearest_measured_setting_is_named():
    assert A.nearest("preview", 600.0) == ("preview", 500.0)
    assert A.nearest("preview", 800.0) == ("preview", 1000.0)  # nearer in log
    assert A.nearest("standard", 5000.0) == ("standard", 2000.0)
    assert A.nearest("reference", 2000.0) is None
    line = A.note("preview", 600.0)
    assert "preview, 500 periods" in line and "98.1%" in line
    assert "more accurate" in A.note("reference", 2000.0)
    assert "the others are measured against" in A.note("standard", 1900.0)


@pytest.mark.slow
def test_the_table_is_the_study_of_its_command(tmp_path):
    """The study on a 9 x 9 window (the table's is 41 x 41): its reference
    row is exact and every figure lies in its range; the shorter preview run
    costs fewer steps, as in the table."""
    rows = {(r["fidelity"], r["periods"]): r for r in study(str(tmp_path), points=9)}
    assert rows[A.REFERENCE]["class_agreement"] == 1.0
    assert rows[A.REFERENCE]["steps_over_reference"] == 1.0
    assert set(rows) == set(A.MEASURED)
    for key, r in rows.items():
        assert 0.0 <= r["class_agreement"] <= 1.0
        assert (r["steps_over_reference"] < 1.0) == (key != A.REFERENCE)
