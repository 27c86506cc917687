"""The map request's accuracy line (vibtrans/maps/accuracy.py): the nearest
measured setting, and the measured table against a fresh measurement of
one setting on a small window (devtools.map_accuracy's own computation)."""

import pytest

from vibtrans.maps import accuracy as A


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
    from devtools.map_accuracy import study

    rows = {(r["fidelity"], r["periods"]): r for r in study(str(tmp_path), points=9)}
    assert rows[A.REFERENCE]["class_agreement"] == 1.0
    assert rows[A.REFERENCE]["steps_over_reference"] == 1.0
    assert set(rows) == set(A.MEASURED)
    for key, r in rows.items():
        assert 0.0 <= r["class_agreement"] <= 1.0
        assert (r["steps_over_reference"] < 1.0) == (key != A.REFERENCE)
