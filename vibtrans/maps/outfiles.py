"""Output files: checked before the work, written atomically.

`check_file` refuses, with one line naming the path and the reason (an
InputError), an output whose folder is missing or not writable, or which is
an existing folder, before any simulation runs.  `atomic` writes through a
temporary file beside the target and renames it over the target at the end
(os.replace: atomic within a folder), so a failure (disk full, permissions
changed, an exception in the writer) leaves neither a partial file nor a
damaged earlier one; the failure is an InputError naming the path."""
from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from vibtrans.core.errors import InputError


def _reason(exc):
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror[0].lower() + exc.strerror[1:]
    return str(exc) or type(exc).__name__


def _probe(folder, name):
    """Create and remove a file in folder: the only test of writability that
    holds for root and for read-only or full file systems too."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".vibtrans-probe-", dir=folder)
    except OSError as exc:
        raise InputError(f"{name}: cannot write in the folder {str(folder)!r} "
                         f"({_reason(exc)})") from None
    os.close(fd)
    os.unlink(tmp)


def check_file(path: str | os.PathLike[str], name: str = "out") -> Path:
    """Refuse (InputError) an output file path that cannot be written: its
    folder missing or not a folder, not writable, or the path an existing
    folder.  Returns the path as a Path."""
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InputError(f"{name} must be a file path, got {path!r}")
    p = Path(path)
    folder = p.parent
    if p.is_dir():
        raise InputError(f"{name}: {str(p)!r} is a folder, not a file")
    if not folder.exists():
        raise InputError(f"{name}: no such folder {str(folder)!r} (for {str(p)!r})")
    if not folder.is_dir():
        raise InputError(f"{name}: {str(folder)!r} is not a folder (for {str(p)!r})")
    _probe(folder, name)
    return p


def check_folder(path: str | os.PathLike[str], name: str = "out", create: bool = True) -> Path:
    """Refuse an output folder that cannot be made or written: its parent
    missing or not writable, or the path an existing file.  The folder itself
    is created if missing (create=True).  Returns it as a Path."""
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InputError(f"{name} must be a folder path, got {path!r}")
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{name}: {str(p)!r} exists and is not a folder")
    if not p.exists():
        if not p.parent.is_dir():
            raise InputError(f"{name}: no such folder {str(p.parent)!r} (for {str(p)!r})")
        _probe(p.parent, name)
        if create:
            try:
                p.mkdir()
            except OSError as exc:
                raise InputError(f"{name}: cannot create the folder {str(p)!r} "
                                 f"({_reason(exc)})") from None
            return p
        return p
    _probe(p, name)
    return p


def _umask():
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    return 0o022


@contextlib.contextmanager
def atomic(path: str | os.PathLike[str], name: str = "out",
           errors: tuple = ()) -> Iterator[str]:
    """Yield a temporary path beside `path` (same suffix, so writers that
    choose a format from the name choose the same); when the block ends
    without an exception, rename it to `path`.  On any exception the
    temporary file is removed; an OSError (or one of `errors`, e.g. the
    RuntimeError netCDF4 raises on a full disk) becomes an InputError naming
    the path and the reason."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{name}: {str(p)!r} is a folder, not a file")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.stem[:40]}.", suffix=f".partial{p.suffix}",
                                   dir=p.parent)
    except OSError as exc:
        why = ("no such folder" if exc.errno == errno.ENOENT else _reason(exc))
        raise InputError(f"{name}: cannot write {str(p)!r} ({why})") from None
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())     # as a plain open() would (mkstemp: 0600)
        os.replace(tmp, p)
    except (OSError, *errors) as exc:
        reason = _reason(exc)
        if not isinstance(exc, OSError):       # e.g. netCDF4's "NetCDF: HDF error"
            try:
                free = shutil.disk_usage(p.parent).free
            except OSError:
                free = None
            if free is not None and free < 2**20:
                reason = f"no space left on its file system: {free} bytes free; {reason}"
            elif free is not None:
                reason += f"; {free} bytes free on its file system"
        raise InputError(f"{name}: cannot write {str(p)!r} ({reason})") from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
