"""The compiled layer (numba, `jit.kernel`/`jit.helper`): records (caller-owned
buffers), the substrate's motion, the contact laws and memory diagram, the
integrators and the three models (deformable, point mass, vertical).  Plain
arrays and scalars in and out; nothing here imports Python-level code above."""
