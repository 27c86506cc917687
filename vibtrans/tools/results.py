"""Benchmark results as data: one JSON file per run.

A record holds what was measured with what it was measured on: the bench's
name and command, its start and end (UTC), the machine (CPU model, cores,
memory, the load average at the start and at the end, Python and the key
packages' versions), the git commit of the source (and whether the tree
had uncommitted changes; None outside a checkout) and the bench's own
results.  `write_result` writes it atomically (a temporary file renamed
over the target), so a reader never finds a partial file; in a folder the
file is named by the bench and its UTC start, e.g.
``bench-20261128T213005Z.json``.  `vibtrans bench --results-dir DIR`,
devtools/browserbench.py and devtools/loadtest.py write these; the
documentation renders the latest of each (docs/reference/benchmarks.md).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import subprocess
import sys
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

from vibtrans.maps.outfiles import atomic, check_file, check_folder

# the packages whose versions decide the figures (missing ones are left out)
KEY_PACKAGES = tuple(
    "vibtrans numpy numba llvmlite scipy xarray zarr matplotlib panel bokeh holoviews playwright".split()
)
SCHEMA = 1
_STAMP = "%Y%m%dT%H%M%SZ"


def _utc_now() -> _dt.datetime:
    return _dt.datetime.now(_dt.UTC).replace(microsecond=0)


def _iso(when: _dt.datetime) -> str:
    return when.strftime("%Y-%m-%dT%H:%M:%SZ")


def _load() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _memory_gb() -> float | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    return round(int(line.split()[1]) / 2**20, 1)
    except (OSError, ValueError, IndexError):
        pass
    return None


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def package_versions(names: Iterable[str] = KEY_PACKAGES) -> dict[str, str]:
    """{name: installed version} of those of `names` that are installed."""
    out = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def machine_description(packages: Iterable[str] = KEY_PACKAGES) -> dict[str, Any]:
    """The machine a bench runs on, as a dict.

    Parameters
    ----------
    packages : iterable of str
        Distribution names whose installed versions are recorded.

    Returns
    -------
    dict
        cpu_model, cores (os.cpu_count), usable_cores (this process's
        affinity; `result_record` takes it from `begin`), memory_gb,
        platform, python, python_implementation and packages
        ({name: version}).
    """
    return {
        "cpu_model": _cpu_model(),
        "cores": os.cpu_count(),
        "usable_cores": _usable_cores(),
        "memory_gb": _memory_gb(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "python_implementation": platform.python_implementation(),
        "packages": package_versions(packages),
    }


def git_state(root: str | os.PathLike[str] | None = None) -> dict[str, Any] | None:
    """The git commit of the checkout at `root` (default: the one holding
    this package, i.e. a development install) and whether its tree has
    uncommitted changes: {"commit": sha, "dirty": bool}; None where `root`
    is not the top of a git checkout (an installed package inside some
    other repository is not its checkout) or git is missing.

    Parameters
    ----------
    root : path, optional
        The checkout's top folder.

    Returns
    -------
    dict or None
    """
    top = Path(root) if root is not None else Path(__file__).resolve().parents[2]

    def git(*args):
        return subprocess.run(
            ["git", "-C", str(top), *args], capture_output=True, text=True, timeout=30, check=True
        ).stdout.strip()

    try:
        if Path(git("rev-parse", "--show-toplevel")).resolve() != top.resolve():
            return None
        commit = git("rev-parse", "HEAD")
        dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": commit, "dirty": dirty}


def begin(git_root: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """What a record needs from the start of a run: the UTC time, the load
    average, the cores this process may use (a bench may pin itself to one
    later) and the source's git state (`git_state(git_root)`: the code that
    runs is the code at the start); pass it to `result_record` at the end."""
    return {
        "started": _utc_now(),
        "load_average_start": _load(),
        "usable_cores": _usable_cores(),
        "git": git_state(git_root),
    }


def _plain(value: Any) -> Any:
    """`value` as plain JSON: NaN and infinities as null (strict JSON has
    neither), numpy scalars and arrays as numbers and lists, tuples and sets
    as lists, keys as strings."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        items = sorted(value) if isinstance(value, (set, frozenset)) else value
        return [_plain(v) for v in items]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # numpy
        return _plain(value.tolist())
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return str(value)


def result_record(
    bench: str,
    results: Mapping[str, Any],
    begun: Mapping[str, Any],
    command: str | None = None,
    packages: Iterable[str] = KEY_PACKAGES,
    note: str | None = None,
) -> dict[str, Any]:
    """One run's record, ready for `write_result`.

    Parameters
    ----------
    bench : str
        The bench's name (the file name's first part): letters, digits and
        dashes.
    results : mapping
        What the bench measured.
    begun : mapping
        `begin()`'s dict, taken as the run started.
    command : str, optional
        The command line (default: this process's).
    packages : iterable of str
        Distribution names whose versions are recorded.
    note : str, optional
        A line on the conditions of the run.

    Returns
    -------
    dict
        bench, schema, command, started_utc, finished_utc, machine (with
        load_average_start and load_average_end), git, note and results.
    """
    if not bench or not all(c.isalnum() or c == "-" for c in bench):
        raise ValueError(f"bench must be letters, digits and dashes, got {bench!r}")
    machine = machine_description(packages)
    machine["usable_cores"] = begun.get("usable_cores", machine["usable_cores"])
    machine["load_average_start"] = begun.get("load_average_start")
    machine["load_average_end"] = _load()
    return _plain(
        {
            "bench": bench,
            "schema": SCHEMA,
            "command": command if command is not None else " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
            "started_utc": _iso(begun["started"]),
            "finished_utc": _iso(_utc_now()),
            "machine": machine,
            "git": begun.get("git"),
            "note": note,
            "results": results,
        }
    )


def result_name(record: Mapping[str, Any]) -> str:
    """The file name of a record in a results folder: its bench and start,
    e.g. bench-20261128T213005Z.json."""
    started = _dt.datetime.strptime(record["started_utc"], "%Y-%m-%dT%H:%M:%SZ")
    return f"{record['bench']}-{started.strftime(_STAMP)}.json"


def write_result(
    record: Mapping[str, Any],
    folder: str | os.PathLike[str] | None = None,
    output: str | os.PathLike[str] | None = None,
) -> Path:
    """Write `record` as JSON into `folder` (named by `result_name`; a second
    file of the same bench and second gets -2, -3, ...) or to the file
    `output`, atomically: a temporary file beside it renamed over it.

    Parameters
    ----------
    record : mapping
        `result_record`'s dict.
    folder : path, optional
        A results folder (created if missing, its parent must exist).
    output : path, optional
        The file to write instead.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    if (folder is None) == (output is None):
        raise ValueError("write_result: give either folder or output")
    text = json.dumps(_plain(record), indent=1, allow_nan=False) + "\n"
    if output is not None:
        path = check_file(output, "output")
    else:
        base = check_folder(folder, "results-dir")  # type: ignore[arg-type]
        name = result_name(record)
        path = base / name
        k = 1
        while path.exists():
            k += 1
            path = base / name.replace(".json", f"-{k}.json")
    with atomic(path, "results") as tmp:
        Path(tmp).write_text(text)
    return path
