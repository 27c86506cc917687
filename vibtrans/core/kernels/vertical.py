"""Vertical-only Hertz particle: m* y'' = 1 - N*(a*), a* = y* - u_y*(t).

The same stepping as the deformable particle, called with tangential=False:
a constant, which LLVM folds once it inlines the loop into this kernel, so
the vertical step has no memory diagram, no sin and no x (it costs about
half the deformable step, `vibtrans bench`).
"""
from vibtrans.core.kernels.jit import kernel
from vibtrans.core.kernels.deformable import _hertz_particle


@kernel
def vertical_kernel(params, integrator, stop_at_takeoff, state, hist, dummy,
                    samples, events, ctr, t_stop):
    """Vertical motion from state[S_T] to t_stop (or the first take-off).

    `dummy` is any float64 array standing in for the memory diagram's slots,
    which this compiled variant never reads or writes.
    Returns a records.* status code.
    """
    # `hist` stands in for the (2-D) vertex array: never touched either.
    return _hertz_particle(params, integrator, stop_at_takeoff, state, hist, dummy,
                           hist, dummy, dummy, ctr, dummy, samples, events,
                           ctr, t_stop, False, False, dummy, False)


@kernel
def vertical_profile_kernel(params, integrator, stop_at_takeoff, state, hist, dummy,
                            samples, events, ctr, t_stop, law):
    """vertical_kernel for a profile's `law` (N* = law, docs/MODEL.md section 10)."""
    return _hertz_particle(params, integrator, stop_at_takeoff, state, hist, dummy,
                           hist, dummy, dummy, ctr, dummy, samples, events,
                           ctr, t_stop, False, False, law, True)


@kernel
def vertical_lyapunov_kernel(params, integrator, state, hist, tangent, dummy, samples,
                             events, ctr, t_stop):
    """vertical_kernel (no stop at take-off) with the tangent advanced
    alongside (`tangent`, float64[deformable.NTANGENT])."""
    return _hertz_particle(params, integrator, False, state, hist, tangent,
                           hist, dummy, dummy, ctr, dummy, samples, events,
                           ctr, t_stop, False, True, dummy, False)


@kernel
def vertical_profile_lyapunov_kernel(params, integrator, state, hist, tangent, dummy,
                                     samples, events, ctr, t_stop, law):
    """vertical_lyapunov_kernel for a profile's `law`."""
    return _hertz_particle(params, integrator, False, state, hist, tangent,
                           hist, dummy, dummy, ctr, dummy, samples, events,
                           ctr, t_stop, False, True, law, True)
