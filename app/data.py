"""Shipped maps and curves, loaded once per process (shared read-only by all
sessions; nothing per session is cached here)."""
import functools
import os
import re
from pathlib import Path

import xarray as xr

from vibtrans.sweep import open_map

ASSETS = Path(os.environ.get("VIBTRANS_ASSETS",
                             Path(__file__).resolve().parent.parent / "assets"))
_NAME = re.compile(r"(deformable|point-mass)-mu([0-9.]+)\.zarr$")


@functools.lru_cache(maxsize=1)
def available_maps():
    """{(model, mu): path} of the shipped drift maps."""
    out = {}
    for p in sorted((ASSETS / "maps").glob("*.zarr")):
        m = _NAME.search(p.name)
        if m:
            out[(m.group(1), float(m.group(2)))] = p
    return out


@functools.lru_cache(maxsize=None)
def drift_map(model, mu):
    """The verified map (model, mu); raises KeyError if not shipped."""
    return open_map(str(available_maps()[(model, mu)]))


@functools.lru_cache(maxsize=1)
def vertical_curve():
    path = ASSETS / "maps" / "vertical.nc"
    return xr.load_dataset(path) if path.exists() else None


def preload():
    for key in available_maps():
        drift_map(*key)
    vertical_curve()
