"""The design chart's constants that the command line's parser shows
(vibtrans.design uses them; this module imports nothing, so building the
parser loads no numerics)."""

# Work of adhesion w of two solids in air held by van der Waals forces:
# w = A_H / (12 pi D0^2) with a Hamaker constant A_H = 1e-19 J (typical of
# inorganic solids) and the contact cut-off D0 = 0.165 nm (Israelachvili,
# Intermolecular and Surface Forces, 3rd ed. 2011, sec. 13.6) gives 0.097 J/m^2.
DEFAULT_SURFACE_ENERGY = 0.1      # J/m^2 (work of adhesion)
MAP_STEP = 0.05                   # decades, the shipped maps' grid
PRESET_NAMES = ("paper", "saw-motor", "saw-powder", "feeder")
