"""A stand-in for `simulate` in explorer tests that build a session
without a server: it records each scene asked for and answers a short real
run of its model (one per model, cached)."""

import functools

from vibtrans import Scene, simulate


@functools.cache
def _real_run(model, lyapunov):
    """A short real run of `model` (the stand-in's answer)."""
    scene = Scene(model=model, amplitude=10**-0.3, mass=10.0, periods=20.0, tau=5.0, fidelity="preview")
    kw = {"lyapunov": True, "window": (18.0, 20.0)} if lyapunov else {}
    return simulate(scene, samples_per_period=5, **kw)


class StandIn:
    """simulate's stand-in: records each scene asked for, answers a short
    real run of its model."""

    def __init__(self):
        self.scenes = []

    def __call__(self, scene, **kwargs):
        self.scenes.append(scene)
        return _real_run(scene.model, bool(kwargs.get("lyapunov")))
