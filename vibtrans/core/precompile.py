"""Compile the kernels ahead of the first run (`vibtrans.warmup`).

A kernel compiles on its first call (or loads from the on-disk cache,
vibtrans.core.kernels.jit); `warmup` makes that call on a tiny scene, so that no
user-facing run pays for compilation, and says how far it got.
"""
from vibtrans.core.errors import InputError

# Compiled variants by model, in the order warmup compiles them.
MODELS = ("deformable", "vertical", "point-mass")


def _warm(model):
    from vibtrans.core.params import Scene
    from vibtrans.core.simulate import simulate
    for integrator in ("ab4", "verlet"):
        # one compiled kernel per model: the integrator is a run-time argument
        simulate(Scene(model=model, integrator=integrator, amplitude=100.0, mass=1.0,
                       periods=2.0, tau=0.5), window=(1.0, 1.5))
    # the chaos indicator's variant (the explorer's and the CLI's runs
    # measure it): the Hertz models advance the tangent map in a kernel of
    # their own, the material point's exponent comes from its impact map
    simulate(Scene(model=model, amplitude=100.0, mass=1.0, periods=2.0, tau=0.5),
             window=(1.0, 1.5), lyapunov=True)
    if model == "vertical":
        from vibtrans.core.threshold import first_takeoff
        first_takeoff(1.0, 1.0, periods=1.0)


def warmup(models=MODELS, progress=None):
    """Compile (or load from the on-disk cache) the kernels of `models`.

    models: any of "deformable", "vertical" (also the jumping threshold) and
        "point-mass"; each is one compiled variant.
    progress: callable(done, total, label), called after each variant is
        ready (done = 1 .. total, label such as "deformable kernel").
    Cheap once the cache holds them (about 0.1 s per variant).
    """
    models = (models,) if isinstance(models, str) else tuple(models)
    for model in models:
        if model not in MODELS:
            raise InputError(f"models must be among {', '.join(MODELS)}, got {model!r}")
    models = tuple(dict.fromkeys(models))
    for done, model in enumerate(models, start=1):
        _warm(model)
        if progress is not None:
            progress(done, len(models), f"{model} kernel")
