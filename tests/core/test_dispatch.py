"""The one table of kernels (vibtrans.core.kernels.dispatch) and the copies
it compiles: every scene's kernel found by (model, Lyapunov tangent, law
kind, rolling), each variant's flags global constants of its own copy."""

import pytest

from vibtrans.core.kernels import deformable as D
from vibtrans.core.kernels.contact import (
    LAW_KINDS,
    PROFILE,
    SPHERE,
    WARM_POWER,
    kernel_law,
    kind_of_law,
    memory_steps,
    power_kernel_law,
)
from vibtrans.core.kernels.dispatch import KERNELS, MODELS, kernel_for
from vibtrans.core.kernels.point_mass import point_mass_kernel
from vibtrans.core.profiles import FlatSphereProfile


@pytest.mark.parametrize("model, rolling", [("deformable", False), ("deformable", True), ("vertical", False)])
@pytest.mark.parametrize("lyapunov", [False, True])
@pytest.mark.parametrize("kind", [SPHERE, PROFILE, WARM_POWER])
def test_every_hertz_scene_has_its_kernel(model, rolling, lyapunov, kind):
    variant = KERNELS[model, lyapunov, kind, rolling]
    assert variant.tangential == (model == "deformable") and variant.lyapunov == lyapunov
    assert variant.rolling == rolling
    # the vertical model runs every profile in its PROFILE kernel
    assert variant.law_kind == (kind if model == "deformable" or kind == SPHERE else PROFILE)
    kernel = kernel_for(model, lyapunov, kind, rolling)
    assert kernel is D.hertz_kernel(variant)  # built once, on first use
    # the copy's flags are its globals (numba folds them: jit.specialize)
    names = kernel.py_func.__globals__
    assert (names["tangential"], names["lyapunov"], names["law_kind"], names["rolling"]) == tuple(variant)
    assert names["memory_commit"] is memory_steps(variant.law_kind).commit
    assert LAW_KINDS[variant.law_kind].replace("-", "_") in kernel.py_func.__qualname__
    assert ("_rolling" in kernel.py_func.__qualname__) == rolling


def test_only_the_deformable_particle_rolls():
    # the material point has no size, the vertical model no tangential motion
    assert {key[0] for key in KERNELS if key[3]} == {"deformable"}
    with pytest.raises(KeyError):
        kernel_for("vertical", False, SPHERE, True)
    # a particle that does not turn runs the kernel it ran before rolling existed
    assert kernel_for("deformable") is kernel_for("deformable", False, SPHERE, False)


def test_the_material_point_has_one_kernel():
    assert set(MODELS) == {key[0] for key in KERNELS}
    assert kernel_for("point-mass") is kernel_for("point-mass", True) is point_mass_kernel
    with pytest.raises(KeyError):
        kernel_for("point-mass", False, SPHERE, True)
    with pytest.raises(KeyError):
        kernel_for("point-mass", False, PROFILE)


def test_a_law_names_its_kind():
    assert kind_of_law(None) == SPHERE
    assert kind_of_law(power_kernel_law(3.0)) == WARM_POWER  # the warm-started root
    assert kind_of_law(power_kernel_law(2.5)) == PROFILE  # pow() every time
    assert kind_of_law(kernel_law(FlatSphereProfile(1.0))) == PROFILE


def test_each_kind_has_its_own_memory_copies():
    copies = [memory_steps(kind) for kind in (SPHERE, PROFILE, WARM_POWER)]
    assert len({id(c.commit) for c in copies}) == 3
    for kind, steps in zip((SPHERE, PROFILE, WARM_POWER), copies):
        assert steps.commit.py_func.__globals__["law_kind"] == kind
        assert steps is memory_steps(kind)
