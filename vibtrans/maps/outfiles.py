"""Output files: checked before the work (`check_file`, `check_folder`: an
InputError naming the path and the reason), written atomically (`atomic`: a
failure leaves neither a partial file nor a damaged earlier one)."""

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
    """Create and remove a file: the writability test that holds for root and full disks too."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".vibtrans-probe-", dir=folder)
    except OSError as exc:
        raise InputError(f"{name}: cannot write in the folder {str(folder)!r} ({_reason(exc)})") from None
    os.close(fd)
    os.unlink(tmp)


def check_file(path: str | os.PathLike[str], name: str = "out") -> Path:
    """The output file's Path; InputError if it cannot be written."""
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
    """The output folder's Path (made if missing and `create`); InputError if
    it cannot be made or written."""
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
                raise InputError(f"{name}: cannot create the folder {str(p)!r} ({_reason(exc)})") from None
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
def atomic(path: str | os.PathLike[str], name: str = "out", errors: tuple = ()) -> Iterator[str]:
    """A temporary path beside `path` (same suffix), renamed to `path` when the
    block succeeds, removed otherwise; an OSError (or one of `errors`, e.g.
    netCDF4's RuntimeError on a full disk) becomes an InputError."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{name}: {str(p)!r} is a folder, not a file")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.stem[:40]}.", suffix=f".partial{p.suffix}", dir=p.parent)
    except OSError as exc:
        why = "no such folder" if exc.errno == errno.ENOENT else _reason(exc)
        raise InputError(f"{name}: cannot write {str(p)!r} ({why})") from None
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())  # as a plain open() would (mkstemp: 0600)
        os.replace(tmp, p)
    except (OSError, *errors) as exc:
        reason = _reason(exc)
        if not isinstance(exc, OSError):  # e.g. netCDF4's "NetCDF: HDF error"
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
