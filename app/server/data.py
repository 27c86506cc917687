"""Shipped maps and curves, loaded once per process (shared read-only by all
sessions; nothing per session is cached here).

A map or curve that cannot be used (not shipped, damaged, truncated, foreign)
is never read as data: `drift_map` raises MapUnavailable, whose text names
the file and the problem, `vertical_curve` returns None, and `problems()`
lists one message per unusable file (what the explorer shows; `vibtrans
serve` refuses to start on them).

Verified stamps: reading and verifying the four shipped maps cost ~0.9 s of
every server start (2 cores).  Once a map has passed `open_map`'s digest
check, its stamp (each file's size, mtime, ctime and inode, with the code
version) is kept in the user's cache folder; `problems()` then counts a map
whose files still carry that stamp as checked without reading it, and the
map itself is read, digests verified again, on first use (`drift_map`).  A
changed file (written, truncated, replaced, touched: any write moves its
ctime, which no one can set back) no longer matches and is verified before
the start as before.  Every read of a map as data is a verified one.

A session loads a map it has not shown yet off the event loop (app/views/
map.py), so several threads may ask for the same file at once: one reads
it, the others wait for it and get the same copy (`_reading`)."""

import contextlib
import functools
import hashlib
import json
import os
import re
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from vibtrans import maps_dir
from vibtrans.analysis.summary import CHAOS_LYAPUNOV
from vibtrans.maps.sweep import StoreMismatch, open_map, open_vertical
from vibtrans.version import __version__

# the folder holding maps/: $VIBTRANS_ASSETS, else the maps installed with
# vibtrans (vibtrans.maps_dir())
ASSETS = maps_dir().parent
_NAME = re.compile(r"(deformable|point-mass)-mu([0-9.]+)\.zarr$")
DEFAULT_MAP = ("deformable", 0.3)  # the explorer opens on this one


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


_READING = {}  # a file's key -> the lock of its first read
_READING_LOCK = threading.Lock()


@contextlib.contextmanager
def _reading(key):
    """Held while the file of `key` is read (or found in the cache): a
    second thread asking for it meanwhile waits for that read instead of
    reading it again; the other files stay free."""
    with _READING_LOCK:
        lock = _READING.setdefault(key, threading.Lock())
    with lock:
        yield


def _map_or_reason(model, mu):
    with _reading(("map", model, mu)):
        return _load_map(model, mu)


def drift_map(model, mu):
    """The verified map (model, mu); MapUnavailable (a KeyError) naming the
    file and the problem if it is not shipped or cannot be used."""
    found = _map_or_reason(model, mu)
    if isinstance(found, str):
        raise MapUnavailable(found)
    return found


def loaded(model, mu):
    """Whether the map (model, mu) has been read in this process (or found
    unusable): `drift_map` answers it at once."""
    return (model, mu) in _LOADED


@functools.cache
def _load_map(model, mu):
    """The map, or the message saying why it cannot be used (cached too:
    a damaged store is not read again on every redraw)."""
    path = available_maps().get((model, mu))
    if path is None:
        return f"no drift map for model={model}, mu={mu:g} in {ASSETS / 'maps'}"
    tree = _tree(path)  # before the read: a write meanwhile shows
    try:
        found = open_map(str(path), expect={"model": model, "mu": mu})
    except (StoreMismatch, OSError) as exc:
        return f"the drift map for model={model}, mu={mu:g} cannot be used: {exc}"
    finally:
        _LOADED.add((model, mu))
    if tree is not None and tree == _tree(path):
        _stamp(path, (model, mu), tree)
    lyapunov = lyapunov_map(model)
    if lyapunov is not None:
        found = with_lyapunov(found, lyapunov)
    return found


# the chaos indicator's maps: the vertical motion's exponent, one per model
# (the vertical motion of every deformable map is the same, of every
# material-point map too)
LYAPUNOV_MAPS = {"deformable": "vertical-lyapunov.zarr", "point-mass": "point-mass-lyapunov.zarr"}
# the vertical motion is the same in every deformable map of these settings
_VERTICAL_KEYS = ("tau", "periods", "fidelity", "integrator")


def with_lyapunov(ds, lyapunov):
    """A deformable map judged by the chaos indicator: `lyapunov` (the
    vertical motion's exponent, from the Lyapunov map) beside its variables,
    `chaotic` from it (analysis.CHAOS_LYAPUNOV; the twin's verdict kept as
    `twin_chaotic`, and used where the exponent is undefined).  A map the
    Lyapunov map was not made for (other tau, periods, fidelity,
    integrator, or a point off its grid), or one that stores its own
    exponent, is returned as it is."""
    if "lyapunov" in ds or any(
        ds.attrs.get(f"scene_{k}") != lyapunov.attrs.get(f"scene_{k}") for k in _VERTICAL_KEYS
    ):
        return ds
    try:
        lam = (
            lyapunov["lyapunov"]
            .sel(log_amplitude=ds["log_amplitude"], log_mass=ds["log_mass"], method="nearest", tolerance=1e-6)
            .values
        )
    except KeyError:
        return ds
    twin = ds["chaotic"].values
    # NaN: no exponent (no impacts, a flight that never ends): the twin's verdict
    chaotic = np.where(np.isnan(lam) | (twin < 0), twin, (lam > CHAOS_LYAPUNOV).astype(np.int8))
    out = ds.assign(
        twin_chaotic=ds["chaotic"],
        chaotic=(ds["chaotic"].dims, chaotic.astype(np.int8)),
        lyapunov=(ds["chaotic"].dims, lam),
    )
    out.attrs["chaos"] = "lyapunov"
    return out


@functools.cache
def _load_lyapunov(model):
    name = LYAPUNOV_MAPS[model]
    path = ASSETS / "maps" / name
    if not path.exists():
        return None
    try:
        return open_map(str(path), expect={"model": "vertical" if model == "deformable" else model})
    except (StoreMismatch, OSError) as exc:
        return f"the Lyapunov map {name} cannot be used: {exc}"


def lyapunov_map(model="deformable"):
    """The chaos indicator's map of a model's maps (the vertical motion's
    Lyapunov exponent), or None if it is not shipped or cannot be used
    (then `problems()` says why, and the maps keep their twin verdicts)."""
    found = _lyapunov_or_reason(model)
    return None if isinstance(found, str) else found


def _lyapunov_or_reason(model):
    with _reading(("lyapunov", model)):
        return _load_lyapunov(model)


_LOADED = set()  # the maps _load_map has read (or failed to read)


# ---------------------------------------------------------------- verified stamps
_STAMPS_LOCK = threading.Lock()


def _stamps_file():
    """The stamps' file in the user's cache folder ($XDG_CACHE_HOME, else
    ~/.cache), read when asked (tests point it elsewhere)."""
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(root) / "vibtrans" / "verified-maps.json"


RACY_NS = 2 * 10**9  # a file changed this recently may change again in the same tick


def _tree(path):
    """A digest of the stat of every file of a map (relative path, size,
    mtime, ctime, inode); None if it cannot be taken, holds a link (a link's
    target could change under an unchanged link) or a file changed in the
    last RACY_NS (on a file system with coarse times a second write in the
    same tick would leave the stat unchanged: git's "racily clean")."""
    recent = time.time_ns() - RACY_NS
    h = hashlib.sha256()
    try:
        for folder, dirs, files in os.walk(path):
            dirs.sort()
            for name in sorted(dirs + files):
                full = os.path.join(folder, name)
                if os.path.islink(full):
                    return None
                if name in files:
                    st = os.stat(full)
                    if max(st.st_mtime_ns, st.st_ctime_ns) > recent:
                        return None
                    h.update(
                        f"{os.path.relpath(full, path)}\0{st.st_size}\0{st.st_mtime_ns}\0"
                        f"{st.st_ctime_ns}\0{st.st_ino}\n".encode()
                    )
        if not os.path.isdir(path) or os.path.islink(path):
            return None
    except OSError:
        return None
    return h.hexdigest()


def _read_stamps():
    try:
        with open(_stamps_file()) as f:
            stamps = json.load(f)
        return stamps if isinstance(stamps, dict) else {}
    except (OSError, ValueError):
        return {}


def _stamp(path, key, tree):
    """Record that the map at path passed verification (best effort: a
    read-only cache folder only means no stamps)."""
    with _STAMPS_LOCK:
        stamps = {p: v for p, v in _read_stamps().items() if os.path.exists(p)}
        stamps[str(Path(path).resolve())] = {"map": list(key), "version": __version__, "tree": tree}
        target = _stamps_file()
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=".verified-maps-", dir=target.parent)
        except OSError:
            return
        try:
            with os.fdopen(fd, "w") as f:
                json.dump(stamps, f)
            os.replace(tmp, target)
        except OSError:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _stamped(path, key, stamps):
    """Whether the map at path still carries the stamp of its verification."""
    entry = stamps.get(str(Path(path).resolve()))
    return (
        isinstance(entry, dict)
        and entry.get("map") == list(key)
        and entry.get("version") == __version__
        and entry.get("tree") is not None
        and entry.get("tree") == _tree(path)
    )


@functools.lru_cache(maxsize=1)
def _load_vertical():
    path = ASSETS / "maps" / "vertical.nc"
    if not path.exists():
        return None
    try:
        return open_vertical(str(path))
    except (StoreMismatch, OSError) as exc:
        return f"the jumping-threshold curve cannot be used: {exc}"


@functools.lru_cache(maxsize=1)
def _load_period_one():
    path = ASSETS / "maps" / "period-one.nc"
    if not path.exists():
        return None
    try:
        import xarray as xr

        ds = xr.load_dataset(path)
    except (OSError, ValueError) as exc:
        return f"the period-1 orbit chart period-one.nc cannot be used: {exc}"
    missing = [v for v in ("trace", "exists", "stable", "in_flight") if v not in ds]
    if missing or ds["trace"].dims != ("log_amplitude", "log_mass"):
        return (
            f"the period-1 orbit chart period-one.nc cannot be used: not a chart of "
            f"vibtrans.analysis.dynamics.period_one_chart (missing: {', '.join(missing) or 'dims'})"
        )
    return ds


def period_one_chart():
    """The period-1 orbit's chart (deformable maps' vertical motion), or None
    if it is not shipped or cannot be used (then `problems()` says why)."""
    with _reading("period-one"):
        found = _load_period_one()
    return None if isinstance(found, str) else found


def vertical_curve():
    """The jumping-threshold curve, or None if it is not shipped or cannot
    be used (then `problems()` says why)."""
    with _reading("vertical"):
        found = _load_vertical()
    return None if isinstance(found, str) else found


def forget():
    """Forget every file read, or found missing, in ASSETS (the maps, the
    Lyapunov maps, the vertical curve, the period-one chart): the next call
    reads the folder again, as a new process would (the verified stamps,
    kept in the user's cache folder, stay).  For a folder that changed
    under the process: the tests point ASSETS at copies.  The one way to
    clear these caches: clearing some of them left a Lyapunov map found
    missing in a copy cached for the shipped maps."""
    for load in (available_maps, _load_map, _load_lyapunov, _load_vertical, _load_period_one):
        load.cache_clear()
    _LOADED.clear()


def problems():
    """One message per shipped file that cannot be used, naming the file and
    the problem; [] when all is well.  Loads (once) every file but the maps
    that carry their verified stamp and were not read yet."""
    out = []
    maps = available_maps()
    if not maps:
        out.append(
            f"no drift maps in {ASSETS / 'maps'} (VIBTRANS_ASSETS must name a folder holding maps/*.zarr)"
        )
    elif DEFAULT_MAP not in maps:
        out.append(
            f"no drift map for model={DEFAULT_MAP[0]}, mu={DEFAULT_MAP[1]:g} (the "
            f"explorer's default) in {ASSETS / 'maps'}"
        )
    stamps = _read_stamps()
    for key, path in maps.items():
        if key not in _LOADED and _stamped(path, key, stamps):
            continue
        found = _map_or_reason(*key)
        if isinstance(found, str):
            out.append(found)
    with _reading("vertical"):
        vertical = _load_vertical()
    with _reading("period-one"):
        period_one = _load_period_one()
    for found in (vertical, period_one, *(_lyapunov_or_reason(m) for m in LYAPUNOV_MAPS)):
        if isinstance(found, str):
            out.append(found)
    return out


def preload():
    """Check every shipped file now (problems()), and load the ones the
    explorer's first page shows (the default map, the vertical curve);
    returns problems()."""
    if DEFAULT_MAP in available_maps():
        _map_or_reason(*DEFAULT_MAP)
    return problems()
