"""The shipped drift maps and the vertical curve (maps/), installed as the
data package `vibtrans_assets`; `vibtrans.maps_dir()` finds them."""
