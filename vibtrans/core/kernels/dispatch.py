"""Which compiled kernel runs a scene: one table for every model.

KERNELS is keyed by (model, lyapunov, law kind, rolling):

* model: "deformable", "vertical" (the Hertz particle, deformable.py) or
  "point-mass" (point_mass.py);
* lyapunov: whether the vertical motion's tangent advances alongside (the
  Hertz models' Lyapunov exponent; the material point's comes from its
  impact map, outside its kernel, so both keys name the same kernel);
* the contact law's kind: contact.SPHERE (Hertz's own), PROFILE (a profile's
  law array) or WARM_POWER (a power law with the warm-started root).  The
  vertical model runs every profile in its PROFILE kernel (the same numbers:
  one kernel fewer to compile); the material point has no contact law;
* rolling: whether the particle turns (docs/MODEL.md section 11; its 1/j is
  a run-time parameter, HertzParams.roll_ratio): deformable only, the
  material point having no size and the vertical model no tangential
  motion.  A particle that does not turn runs the kernel it ran before
  rolling existed.

An entry is a deformable.HertzVariant (its kernel: deformable.hertz_kernel,
the call documented there) or POINT_MASS (point_mass.point_mass_kernel).
`kernel_for` turns it into the compiled kernel; each compiles on its first
call (or loads from the disk cache), so a run compiles only what it needs.
"""

from typing import Any

from vibtrans.core.kernels.contact import PROFILE, SPHERE, WARM_POWER
from vibtrans.core.kernels.deformable import HertzVariant, hertz_kernel
from vibtrans.core.kernels.point_mass import point_mass_kernel

MODELS = ("deformable", "vertical", "point-mass")
POINT_MASS = "point-mass"  # the material point's one kernel

KERNELS = {}
for _lyapunov in (False, True):
    for _kind in (SPHERE, PROFILE, WARM_POWER):
        for _rolling in (False, True):
            KERNELS["deformable", _lyapunov, _kind, _rolling] = HertzVariant(
                tangential=True, lyapunov=_lyapunov, law_kind=_kind, rolling=_rolling
            )
        KERNELS["vertical", _lyapunov, _kind, False] = HertzVariant(
            tangential=False, lyapunov=_lyapunov, law_kind=SPHERE if _kind == SPHERE else PROFILE
        )
    KERNELS["point-mass", _lyapunov, SPHERE, False] = POINT_MASS
del _lyapunov, _kind, _rolling


def kernel_for(model: str, lyapunov: bool = False, law_kind: int = SPHERE, rolling: bool = False) -> Any:
    """The compiled kernel of KERNELS[model, lyapunov, law_kind, rolling]."""
    entry = KERNELS[model, bool(lyapunov), law_kind, bool(rolling)]
    return point_mass_kernel if entry == POINT_MASS else hertz_kernel(entry)
