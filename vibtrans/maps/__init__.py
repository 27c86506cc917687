"""Maps over (log10 A*, log10 m*): sweeps and their stores (`sweep`), adaptive
maps, the shared cache, map differences, the shipped maps, the accuracy
table and atomic output files."""
