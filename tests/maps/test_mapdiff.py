"""Two maps compared (vibtrans/maps/difference.py): hand-made maps
whose differences are known, the signed log scale's closed form, and the
command line on the shipped maps."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from budget import budget

from vibtrans.core.errors import InputError
from vibtrans.maps.difference import describe, map_difference, signed_log

GRID = ("log_amplitude", "log_mass")


def _map(la, lm, v, chaotic=None, **attrs):
    v = np.asarray(v, dtype=float)
    drift = np.where(v > 0.1, 1, np.where(v < -0.1, -1, 0)).astype("i1")
    chaotic = np.zeros(v.shape, dtype="i1") if chaotic is None else np.asarray(chaotic, "i1")
    return xr.Dataset(
        {"drift_velocity": (GRID, v), "drift": (GRID, drift), "chaotic": (GRID, chaotic)},
        coords={"log_amplitude": la, "log_mass": lm},
        attrs={"scene_model": "deformable", "scene_mu": 0.3, **attrs},
    )


LA, LM = np.array([0.0, 0.5, 1.0]), np.array([-1.0, 0.0])
V = np.array([[0.0, 2.0], [-3.0, 50.0], [0.05, -0.5]])


def test_signed_log_closed_form():
    # s(v) = sign(v) log10(1 + |v|/v0): 0 at 0, odd, 1 decade at 9 v0, 2 at 99 v0
    assert signed_log(0.0) == 0.0
    np.testing.assert_allclose(signed_log([0.9, -0.9, 9.9]), [1.0, -1.0, 2.0])
    np.testing.assert_allclose(signed_log(9.0, v0=1.0), 1.0)


def test_a_map_against_itself_agrees_everywhere():
    m = _map(LA, LM, V)
    d = map_difference(m, m)
    assert d["compared"].values.all() and not d["class_changed"].values.any()
    assert np.all(d["log_difference"].values == 0.0)
    assert d.attrs["class_agreement"] == 1.0 and d.attrs["median_relative_difference"] == 0.0


def test_known_changes_are_found():
    other = V.copy()
    other[1, 1] = 500.0  # ten times the drift: one decade more (about)
    other[2, 1] = 0.5  # against the wave -> with the wave
    chaotic = np.zeros(V.shape)
    chaotic[0, 1] = 1  # chaotic in the second map: not judged
    d = map_difference(_map(LA, LM, V), _map(LA, LM, other, chaotic, scene_mu=0.1))
    assert d["class_changed"].values.sum() == 1 and d["class_changed"].values[2, 1]
    assert d["log_difference"].values[1, 1] == pytest.approx(np.log10(1 + 5000) - np.log10(1 + 500))
    assert d["chaotic_either"].values.sum() == 1
    assert d.attrs["regular_points"] == 5
    assert d.attrs["class_agreement"] == pytest.approx(4 / 5)
    # |v2 - v1| / max(|v1|, 0.1) over the regular points: 0, 0, 0, 9, 2
    assert d.attrs["median_relative_difference"] == pytest.approx(0.0)
    assert d.attrs["second"] == "deformable mu 0.1"


def test_the_second_map_is_read_at_its_nearest_point_within_half_a_step():
    # a finer second map (step 0.25 in log A*), shifted by 0.01: its nearest
    # points are the first's; a coarser one missing a row leaves it uncompared
    fine_la = np.arange(-0.24, 1.3, 0.25)
    fine = _map(fine_la, LM + 0.01, np.repeat([[1.0, 1.0]], fine_la.size, axis=0))
    d = map_difference(_map(LA, LM, V), fine)
    assert d["compared"].values.all()
    np.testing.assert_array_equal(d["drift_velocity_second"].values, 1.0)
    part = _map(LA[:2], LM, V[:2])
    d = map_difference(_map(LA, LM, V), part)
    assert d["compared"].values[:2].all() and not d["compared"].values[2].any()
    assert np.isnan(d["log_difference"].values[2]).all()


def test_maps_that_share_no_point_are_a_message():
    far = _map(LA + 10.0, LM, V)
    with pytest.raises(InputError, match="share no point"):
        map_difference(_map(LA, LM, V), far)
    with pytest.raises(InputError, match="missing chaotic"):
        map_difference(_map(LA, LM, V), _map(LA, LM, V).drop_vars("chaotic"))
    with pytest.raises(InputError, match="v0 must be a positive number"):
        map_difference(_map(LA, LM, V), _map(LA, LM, V), v0=0.0)


def test_a_name_says_what_differs_from_the_shipped_maps():
    assert describe(_map(LA, LM, V, scene_periods=2000.0, scene_fidelity="standard")) == "deformable mu 0.3"
    assert (
        describe(_map(LA, LM, V, scene_periods=500.0, scene_fidelity="preview"))
        == "deformable mu 0.3 preview 500 periods"
    )
    # a profile's map names its profile
    assert describe(_map(LA, LM, V, scene_profile="cone")) == "deformable mu 0.3 cone"
    # a map made under the `decided` stopping rule says so (its store's `stop`)
    assert describe(_map(LA, LM, V, stop="decided")) == "deformable mu 0.3 stop decided"
    assert describe(_map(LA, LM, V, stop="full")) == "deformable mu 0.3"


def _export(tmp_path, *args):
    return subprocess.run(
        [sys.executable, "-m", "vibtrans.cli", "export", "map-difference", *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=budget(600),
    )


def test_cli_compares_two_shipped_maps(tmp_path):
    out = tmp_path / "diff.png"
    r = _export(tmp_path, "--map", "deformable-mu0.3", "--other", "point-mass-mu0.3", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 10000 and out.read_bytes()[:4] == b"\x89PNG"
    assert "point-mass mu 0.3 against deformable mu 0.3" in r.stdout
    assert "drift class agrees at" in r.stdout
    r = _export(tmp_path, "--map", "deformable-mu0.7", "--other", "point-mass-mu0.3", "--out", str(out))
    assert r.returncode == 2 and "map: no store 'deformable-mu0.7'" in r.stderr
    assert "deformable-mu0.3" in r.stderr and "Traceback" not in r.stderr
    r = _export(tmp_path, "--map", "deformable-mu0.3", "--out", str(out))
    assert r.returncode == 2 and "needs --map A and --other B" in r.stderr
