"""A folder of computed maps, shared by every session of a server.

A map on demand is a sweep store (vibtrans.maps.sweep: Zarr, its chunks' digests
checked on every open).  The cache keeps finished ones under a folder:

* an entry is `<folder>/<key>.zarr`, the key a digest of the map's request
  (its scene values, grid and refinement settings: anything that changes a
  number) and of the code version, so a new release never reads an old
  release's numbers as its own;
* an entry appears only when finished: it is computed under a temporary
  name and renamed into place (a folder's rename is atomic on one file
  system), so no reader ever sees half a map;
* opening verifies it (sweep.open_map): a damaged or unfinished entry is
  deleted and reported missing, so it is recomputed, never shown;
* least recently used entries go once the folder exceeds its size cap (a
  use touches the entry's time stamp);
* two callers asking for the same key while it is computed share one
  computation (`MapCache.compute` returns the same Future).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import threading
import time
import uuid
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any

from vibtrans.core.errors import InputError, StoreMismatch
from vibtrans.version import __version__

if TYPE_CHECKING:
    import xarray as xr

log = logging.getLogger("vibtrans.maps.cache")

SUFFIX = ".zarr"
TEMPORARY = ".computing-"  # <key>.computing-<id>: an entry being written
DEFAULT_MAX_BYTES = 2 * 2**30  # 2 GiB: ~500 shipped-size maps (~4 MB each)
STALE_SECONDS = 24 * 3600  # a temporary this old was left by a killed server


def request_key(request: Any) -> str:
    """The cache key of a map request: a dict of JSON-able values (scene
    values, grid bounds and steps, refinement settings), with the code
    version.  Key order does not matter; 0.3 and 0.30 are one value."""
    if not isinstance(request, dict):
        raise InputError(f"a map request is a dict of its values, got {type(request).__name__}")
    try:
        text = json.dumps(
            {"request": request, "code_version": __version__},
            sort_keys=True,
            allow_nan=False,
            separators=(",", ":"),
        )
    except (TypeError, ValueError) as exc:
        raise InputError(f"a map request holds only numbers, strings and lists ({exc})") from None
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _folder_bytes(path):
    total = 0
    for root, _, files in os.walk(path):
        for name in files:
            try:
                total += os.path.getsize(os.path.join(root, name))
            except OSError:  # removed meanwhile
                pass
    return total


class MapCache:
    """Finished maps under `folder` (created if missing), at most
    `max_bytes` in all (the least recently used go first)."""

    def __init__(self, folder: str | os.PathLike[str], max_bytes: int = DEFAULT_MAX_BYTES) -> None:
        if not isinstance(max_bytes, int) or isinstance(max_bytes, bool) or max_bytes < 1:
            raise InputError(f"max_bytes must be a positive integer (bytes), got {max_bytes!r}")
        self.folder = os.fspath(folder)
        self.max_bytes = max_bytes
        try:
            os.makedirs(self.folder, exist_ok=True)
        except OSError as exc:
            raise InputError(
                f"map cache folder {self.folder!r} cannot be made ({exc.strerror or exc})"
            ) from None
        self._lock = threading.Lock()
        self._computing: dict = {}  # key -> Future of the dataset
        self._remove_stale_temporaries()

    def _remove_stale_temporaries(self):
        # (not younger ones: another server process may be writing them)
        now = time.time()
        for name in os.listdir(self.folder):
            path = os.path.join(self.folder, name)
            try:
                if TEMPORARY in name and now - os.stat(path).st_mtime > STALE_SECONDS:
                    shutil.rmtree(path, ignore_errors=True)
            except OSError:
                pass

    def path(self, key: Any) -> str:
        return os.path.join(self.folder, key + SUFFIX)

    def entries(self) -> list[Any]:
        """Finished entries' keys, least recently used first."""
        found = []
        for name in os.listdir(self.folder):
            if name.endswith(SUFFIX) and TEMPORARY not in name:
                try:
                    found.append((os.stat(os.path.join(self.folder, name)).st_mtime_ns, name[: -len(SUFFIX)]))
                except OSError:
                    pass
        return [key for _, key in sorted(found)]

    def get(self, key: Any) -> xr.Dataset | None:
        """The entry's dataset, verified (sweep.open_map), or None if there
        is none; a damaged or unfinished one is deleted (and None)."""
        from vibtrans.maps.sweep import open_map

        path = self.path(key)
        if not os.path.exists(path):
            return None
        try:
            ds = open_map(path)
            if not bool(ds["done"].values.all()):
                raise StoreMismatch(f"{path} is not finished")
        except (StoreMismatch, OSError) as exc:
            log.warning("map cache: %s removed (%s); it will be recomputed", path, exc)
            shutil.rmtree(path, ignore_errors=True)
            return None
        try:
            os.utime(path)  # a use: the most recently used now
        except OSError:
            pass
        return ds

    def temporary_path(self, key: Any) -> str:
        """Where a computation writes the entry before `publish` renames it."""
        return os.path.join(self.folder, f"{key}{TEMPORARY}{uuid.uuid4().hex}")

    def publish(self, key: Any, temporary: Any) -> str:
        """Move a finished store from `temporary` into place, then evict."""
        path = self.path(key)
        if os.path.exists(path):  # another process finished first: keep one
            shutil.rmtree(temporary, ignore_errors=True)
        else:
            os.replace(temporary, path)
        self.evict(keep=key)
        return path

    def evict(self, keep: Any = None) -> list[Any]:
        """Remove least recently used entries (never `keep`) until the
        folder's maps take at most max_bytes; returns the removed keys."""
        keys = self.entries()
        sizes = {key: _folder_bytes(self.path(key)) for key in keys}
        total = sum(sizes.values())
        removed = []
        for key in keys:
            if total <= self.max_bytes:
                break
            if key == keep:
                continue
            shutil.rmtree(self.path(key), ignore_errors=True)
            total -= sizes[key]
            removed.append(key)
        return removed

    def compute(self, key: Any, build: Any, submit: Any) -> Any:
        """The entry `key`: from the cache when finished there, else computed
        once by `build(temporary_path)` (which writes a sweep store there),
        through `submit(fn)` (an executor's submit: where the work runs).
        Returns a Future of the verified dataset; callers asking for a key
        that is being computed get the same Future."""
        with self._lock:
            running = self._computing.get(key)
            if running is not None:
                return running
            ds = self.get(key)
            if ds is not None:
                done: Future = Future()
                done.set_result(ds)
                return done
            future: Future = Future()
            self._computing[key] = future

        def job():
            temporary = self.temporary_path(key)
            try:
                build(temporary)
                self.publish(key, temporary)
                ds = self.get(key)
                if ds is None:
                    raise StoreMismatch(f"the map computed for {key} could not be read back")
                future.set_result(ds)
            except BaseException as exc:  # cancelled, failed: nothing left behind
                shutil.rmtree(temporary, ignore_errors=True)
                future.set_exception(exc)
            finally:
                with self._lock:
                    self._computing.pop(key, None)

        try:
            submit(job)
        except BaseException as exc:
            with self._lock:
                self._computing.pop(key, None)
            future.set_exception(exc)
        return future
