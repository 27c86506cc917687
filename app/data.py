"""Shipped maps and curves, loaded once per process (shared read-only by all
sessions; nothing per session is cached here).

A map or curve that cannot be used (not shipped, damaged, truncated, foreign)
is never read as data: `drift_map` raises MapUnavailable, whose text names
the file and the problem, `vertical_curve` returns None, and `problems()`
lists one message per unusable file (what the explorer shows; `vibtrans
serve` refuses to start on them)."""
import functools
import re

from vibtrans import maps_dir
from vibtrans.sweep import StoreMismatch, open_map, open_vertical

# the folder holding maps/: $VIBTRANS_ASSETS, else the maps installed with
# vibtrans (vibtrans.maps_dir())
ASSETS = maps_dir().parent
_NAME = re.compile(r"(deformable|point-mass)-mu([0-9.]+)\.zarr$")
DEFAULT_MAP = ("deformable", 0.3)       # the explorer opens on this one


class MapUnavailable(KeyError):
    """A drift map that cannot be shown; str() is the message for the user."""

    def __str__(self):
        return str(self.args[0])


@functools.lru_cache(maxsize=1)
def available_maps():
    """{(model, mu): path} of the shipped drift maps."""
    out = {}
    for p in sorted((ASSETS / "maps").glob("*.zarr")):
        m = _NAME.search(p.name)
        if m:
            out[(m.group(1), float(m.group(2)))] = p
    return out


def drift_map(model, mu):
    """The verified map (model, mu); MapUnavailable (a KeyError) naming the
    file and the problem if it is not shipped or cannot be used."""
    found = _load_map(model, mu)
    if isinstance(found, str):
        raise MapUnavailable(found)
    return found


@functools.lru_cache(maxsize=None)
def _load_map(model, mu):
    """The map, or the message saying why it cannot be used (cached too:
    a damaged store is not read again on every redraw)."""
    path = available_maps().get((model, mu))
    if path is None:
        return f"no drift map for model={model}, mu={mu:g} in {ASSETS / 'maps'}"
    try:
        return open_map(str(path), expect={"model": model, "mu": mu})
    except (StoreMismatch, OSError) as exc:
        return f"the drift map for model={model}, mu={mu:g} cannot be used: {exc}"


drift_map.cache_clear = _load_map.cache_clear


@functools.lru_cache(maxsize=1)
def _load_vertical():
    path = ASSETS / "maps" / "vertical.nc"
    if not path.exists():
        return None
    try:
        return open_vertical(str(path))
    except (StoreMismatch, OSError) as exc:
        return f"the jumping-threshold curve cannot be used: {exc}"


def vertical_curve():
    """The jumping-threshold curve, or None if it is not shipped or cannot
    be used (then `problems()` says why)."""
    found = _load_vertical()
    return None if isinstance(found, str) else found


vertical_curve.cache_clear = _load_vertical.cache_clear


def problems():
    """One message per shipped file that cannot be used, naming the file and
    the problem; [] when all is well.  Loads everything (once)."""
    out = []
    maps = available_maps()
    if not maps:
        out.append(f"no drift maps in {ASSETS / 'maps'} (VIBTRANS_ASSETS must name a folder "
                   f"holding maps/*.zarr)")
    elif DEFAULT_MAP not in maps:
        out.append(f"no drift map for model={DEFAULT_MAP[0]}, mu={DEFAULT_MAP[1]:g} (the "
                   f"explorer's default) in {ASSETS / 'maps'}")
    for key in maps:
        found = _load_map(*key)
        if isinstance(found, str):
            out.append(found)
    vertical = _load_vertical()
    if isinstance(vertical, str):
        out.append(vertical)
    return out


def preload():
    """Load every shipped file now; returns problems()."""
    return problems()
