"""Tools around the model: the benchmark, the work-precision study and the
peers (independent implementations such as LAMMPS)."""
