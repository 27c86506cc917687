"""The Hertz kernels' shortcuts change results only at the rounding level.

Source: each shortcut is exact in real arithmetic (models.deformable.SHORT_*):
* ramp: G(t) = 1 - exp(-t^2/tau^2) equals 1 in double precision once
  t > 6.5 tau (exp < 2^-60), so skipping exp() there changes nothing;
* rotation: (cos, sin)(2 pi (t + h)) is the rotation of (cos, sin)(2 pi t) by
  2 pi h; rounding accumulates over at most ROTATION_STEPS = 64 steps before
  a fresh evaluation, ~64 ulp ~ 1e-14 relative.
So on scenes that are not chaotic the drift must agree to ~1e-12 relative,
far inside every preset's stated error (preview 5%, standard 0.5%).  The bound
1e-9 leaves room for the growth of 1e-14 perturbations over 2000 periods of a
stable (non-chaotic) orbit, seen at <= 3e-14 (`vibtrans bench`).
"""

import math

import numpy as np
import pytest

from vibtrans import paper_scene, simulate
from vibtrans.analysis.summary import V0, drift_velocity
from vibtrans.core.kernels import deformable as D

NON_CHAOTIC = (1, 2, 3, 4, 6, 7)


@pytest.mark.parametrize("point", NON_CHAOTIC)
@pytest.mark.parametrize("off", [D.SHORT_RAMP, D.SHORT_ROTATION, D.SHORTCUTS_ALL])
def test_shortcut_changes_drift_only_by_rounding(point, off):
    scene = paper_scene(point)
    on = simulate(scene)
    ref = simulate(scene, shortcuts=D.SHORTCUTS_ALL & ~off)
    v_on, v_ref = drift_velocity(on), drift_velocity(ref)
    assert abs(v_on - v_ref) <= 1e-9 * max(abs(v_ref), V0)
    # the whole sampled trajectory, not only its end
    scale = max(1.0, float(np.abs(ref["x"].values).max()))
    assert np.abs(on["x"].values - ref["x"].values).max() <= 1e-9 * scale
    assert np.allclose(on["y"].values, ref["y"].values, rtol=1e-9, atol=1e-9)


def test_vertical_model_rotation_matches_exact_trig():
    scene = paper_scene(6).replace(model="vertical")
    on = simulate(scene)
    ref = simulate(scene, shortcuts=0)
    assert np.allclose(on["y"].values, ref["y"].values, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("bad", [-1, 4, 1.5, True, "3", math.nan])
def test_bad_shortcuts_named(bad):
    with pytest.raises(ValueError, match="shortcuts must be an integer in \\[0, 3\\]"):
        simulate(paper_scene(1).replace(periods=1.0), shortcuts=bad)


def test_steps_override_equals_the_preset():
    scene = paper_scene(1).replace(periods=50.0)
    a = simulate(scene)
    b = simulate(scene, steps=(256, 40))
    assert a.attrs["steps"] == b.attrs["steps"]
    assert np.array_equal(a["x"].values, b["x"].values)


@pytest.mark.parametrize("bad", [(0, 40), (256,), (256, math.inf), "fast", (256, -1)])
def test_bad_steps_named(bad):
    with pytest.raises(ValueError, match="steps must be a pair"):
        simulate(paper_scene(1).replace(periods=1.0), steps=bad)


def test_steps_refused_for_the_point_mass():
    with pytest.raises(ValueError, match="steps applies to the deformable and vertical"):
        simulate(paper_scene(1).replace(model="point-mass", periods=1.0), steps=(64, 24))
