"""Where the shipped maps are: the data package `vibtrans_assets` (the
repository's assets/), unless VIBTRANS_ASSETS names another folder."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

ENV = "VIBTRANS_ASSETS"
PACKAGE = "vibtrans_assets"


def maps_dir() -> Path:
    """The folder of the shipped maps.

    Returns
    -------
    pathlib.Path
        $VIBTRANS_ASSETS/maps if set, else the maps installed with vibtrans.
    """
    root = os.environ.get(ENV)
    if root:
        return Path(root) / "maps"
    try:
        base = resources.files(PACKAGE)
    except ModuleNotFoundError:  # a source tree that was never installed
        return Path(__file__).resolve().parent.parent / "assets" / "maps"
    # installed wheels and editable installs are plain folders (not zips)
    return Path(str(base)) / "maps"
