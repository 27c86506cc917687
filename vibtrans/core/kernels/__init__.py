"""The compiled layer (numba, `jit.kernel`/`jit.helper`): records (caller-owned
buffers), the substrate's motion, the contact laws and memory diagram, the
integrators, the models (the Hertz particle, deformable or vertical, and the
material point) and the one table that says which kernel runs a scene
(dispatch.KERNELS).  Plain arrays and scalars in and out; nothing here
imports Python-level code above."""
