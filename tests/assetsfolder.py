"""The explorer's assets folder pointed at copies, and back: every test that
does so goes through `point_assets` (or `assets_folder`, the fixture in
conftest.py), so nothing read from the copies, or found missing there,
outlives the test in its process (once a Lyapunov map found missing in a
copy stayed cached, and every later test of that pytest worker saw maps
without a chaos indicator)."""

from vibtrans_explorer.server import data
from vibtrans_explorer.views import map as map_views
from vibtrans_explorer.views import vertical as vertical_views


def forget_maps():
    """What a new process would know of the assets folder: nothing read yet
    (data.forget()), no map figure rendered from it."""
    data.forget()
    map_views._map_json.cache_clear()
    vertical_views._vertical_json.cache_clear()


def point_assets(folder):
    """The explorer reads its maps from folder/maps from now on."""
    data.ASSETS = folder
    forget_maps()
