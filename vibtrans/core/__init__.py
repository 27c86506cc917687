"""The physics core: validated scenes and their units (`params`, `units`,
`fidelity`), the numba kernels (`kernels`: contact laws and the memory
diagram, substrate, integrators, the three models), the drivers that run
them, and the entry points `simulate` and `threshold`.  Depends on nothing
else of vibtrans."""
