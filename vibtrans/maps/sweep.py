"""Parameter sweeps over the (log10 A*, log10 m*) plane, stored resumably.

A sweep is an xarray Dataset on the grid (log_amplitude, log_mass), written
to Zarr chunk by chunk (a chunk = `chunk_rows` amplitudes x every mass) as
its points finish:

* the data of a chunk is written first with a digest of its data, then its
  `done` flag (the flag commits the chunk); a sweep killed at any moment restarts with the same command,
  skips the chunks marked done, and recomputes only the chunks not marked;
* finished chunks are written together, at most every FLUSH_EVERY_S seconds
  (a Zarr region write costs ~35 ms of CPU whatever its size: written one by
  one, three writes a chunk, they were 13-30% of a decided map's CPU time),
  so a kill loses at most that much finished work;
* a store whose parameters or grid differ from the command, or whose done
  chunks do not match their digests (damaged, truncated, edited), is refused
  with a clear message, never mixed or read as data.

Points run on all local cores, in a thread pool by default (the numba kernels
release the GIL; `vibtrans bench --sweep` measured threads 40% faster than a
process pool on this 2-core machine: 59 vs 42 points/s, 89% vs 91% parallel
efficiency), or on a dask.distributed cluster given its scheduler address;
the kernels are the same either way.
"""

from __future__ import annotations

import hashlib
import math
import os
import shlex
import sys
import time
from concurrent.futures import (
    FIRST_COMPLETED,
    Executor,
    Future,
    ProcessPoolExecutor,
    ThreadPoolExecutor,
    wait,
)
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np
import xarray as xr

from vibtrans.analysis.summary import TWIN_TAU_OFFSET, jumped, rebound_pattern, summarize, twin_scene
from vibtrans.core.errors import InputError, StoreMismatch
from vibtrans.core.params import PLANE, Scene
from vibtrans.core.simulate import run_records, warmup
from vibtrans.core.stopping import REASONS, STOPS, check_stop
from vibtrans.core.trajectory import RunArrays
from vibtrans.version import __version__

if TYPE_CHECKING:
    from collections.abc import Mapping

    import numpy.typing as npt

PATTERNS = ("none", "synchronous", "multi-synchronous", "chaotic", "irregular")
DRIFTS = {"against-wave": -1, "none": 0, "with-wave": 1}
# The particle's profile: in a sweep's values and attrs only when it
# is not the sphere (stores made before profiles are the sphere's, and keep
# their keys); load_over_modulus only with a file: profile.
PROFILE_KEYS = ("profile", "load_over_modulus")
# How the particle turns (docs/MODEL.md section 11): in a sweep's values and
# attrs only for a particle that turns (a map of one that does not keeps
# the keys, stores and cache entries it had before rolling existed).
ROLLING_KEY = "rolling"
# A sweep's scene values (its store's scene_* attributes): Scene's settings
# but its point on the plane (the sweep's grid), the profile's keys and rolling
SCENE_KEYS = tuple(k for k in Scene.param if k not in ("name", *PLANE, *PROFILE_KEYS, ROLLING_KEY))
VARIABLES = {
    # name: (dtype, fill, description)
    "drift_velocity": ("f8", np.nan, "<v_x*> = x*(T)/T over the run"),
    "final_drift_velocity": ("f8", np.nan, "mean v_x* over the last 10% of the run"),
    "contact": ("i1", -1, "0 permanent contact, 1 jumping"),
    "drift": ("i1", -2, "-1 against the wave, 0 none (|v*| <= 0.1), 1 with the wave"),
    "pattern": ("i1", -1, "rebound pattern: " + ", ".join(f"{i} {p}" for i, p in enumerate(PATTERNS))),
    "chaotic": ("i1", -1, f"1 if the tau + {TWIN_TAU_OFFSET:g} twin disagrees (jumping points only), else 0"),
    "contact_fraction": ("f8", np.nan, "fraction of the final 10% spent in contact"),
    "takeoffs_per_period": ("f8", np.nan, "take-offs per period, final 10%"),
    "steps": ("i8", -1, "integration steps (run + twin)"),
    "seconds": ("f8", np.nan, "wall time of the point (run + twin), s"),
}


# The chaos indicator's map: the vertical motion's largest Lyapunov exponent.
# The vertical motion does not feel the tangential one, so one such map
# (model "vertical"; "point-mass" for the material point's maps) serves every
# deformable map of the same tau, fidelity,
# integrator and periods, whatever mu and theta (the same steps; equal to
# rounding, as kernel calls differ: tests/core/test_lyapunov.py).
LYAPUNOV_VARIABLES = {
    "lyapunov": (
        "f8",
        np.nan,
        "largest Lyapunov exponent of the vertical motion, per period, from the end of the ramp",
    ),
    "contact": ("i1", -1, "0 permanent contact, 1 jumping"),
    "steps": ("i8", -1, "integration steps"),
    "seconds": ("f8", np.nan, "wall time of the point, s"),
}


# How a transport sweep judges chaos: "lyapunov" (the run's own exponent,
# analysis.CHAOS_LYAPUNOV; no twin run; the material point's from its impact
# map, lyapunov.impact_lyapunov, as its shipped Lyapunov map has it) or
# "twin" (the tau + 1e-3 twin: the shipped maps, made before the exponent
# existed, whose stores carry no `chaos` attribute).
CHAOS_SOURCES = ("lyapunov", "twin")
LYAPUNOV_CHAOS_VARIABLES = {
    **VARIABLES,
    "chaotic": (
        "i1",
        -1,
        "1 if the Lyapunov exponent exceeds analysis.CHAOS_LYAPUNOV (the "
        "material point's: of its impact map), else 0",
    ),
    "lyapunov": LYAPUNOV_VARIABLES["lyapunov"],
}


# A transport sweep under the `decided` stopping rule (core.stopping.DecidedRule) stores
# per point how long its run was and why it stopped; its drift_velocity is
# x*(T)/T extrapolated from a regular stop (analysis.drift_velocity).
DECIDED_VARIABLES = {
    "periods_run": ("f8", np.nan, "periods the run actually ran (its twin's not counted)"),
    "stop_reason": ("i1", -1, "why the run stopped: " + ", ".join(f"{i} {r}" for i, r in enumerate(REASONS))),
    "asymptotic_drift_velocity": (
        "f8",
        np.nan,
        "the asymptotic drift rate v_inf of a regular stop (NaN otherwise)",
    ),
}


def variables_of(kind: str, chaos: str, stop: str = "full") -> dict[str, Any]:
    """The stored variables of a sweep of this kind, chaos source and stop rule."""
    if kind == "lyapunov":
        return LYAPUNOV_VARIABLES
    variables = LYAPUNOV_CHAOS_VARIABLES if chaos == "lyapunov" else VARIABLES
    return {**variables, **DECIDED_VARIABLES} if stop == "decided" else variables


def short_reason(exc: BaseException, limit: int = 240) -> str:
    """An underlying error as one short line (for StoreMismatch messages)."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= limit else text[:limit] + "..."


def parse_range(text: str, name: str) -> np.ndarray:
    """'start:stop:step' (inclusive stop) -> 1-D array, validated."""
    try:
        start, stop, step = (float(v) for v in str(text).split(":"))
    except ValueError:
        raise InputError(f"{name} must be 'start:stop:step', got {text!r}") from None
    if not all(math.isfinite(v) for v in (start, stop, step)) or step <= 0 or stop < start:
        raise InputError(
            f"{name} must be 'start:stop:step' with finite start <= stop and step > 0, got {text!r}"
        )
    n = int(round((stop - start) / step)) + 1
    if n > 100_000:
        raise InputError(f"{name} has {n} points, more than 100000")
    return np.round(start + step * np.arange(n), 10)


def compute_point(
    values: Any, log_a: Any, log_m: Any, chaos: str = "twin", stop: str = "full"
) -> dict[str, Any]:
    """One grid point: the run with its Lyapunov exponent (chaos
    "lyapunov"; the material point's from its impact map), or the run and,
    if it jumps, its chaos twin (analysis.twin_scene; chaos "twin").
    stop: the runs' stopping rule (core.stopping.STOPS; the twin's too).

    Returns a dict of the stored quantities.
    """
    scene = Scene(amplitude=10.0**log_a, mass=10.0**log_m, **values)
    measure = chaos == "lyapunov"
    # the runs' arrays, summarized as a Dataset of them would be (no Dataset)
    ds = RunArrays(*run_records(scene, lyapunov=measure, stop=stop))
    jumping = jumped(ds)
    twin = RunArrays(*run_records(twin_scene(scene), stop=stop)) if jumping and not measure else None
    s = summarize(ds, twin)
    pattern = s.pattern
    if pattern == "launched":
        # the maps store the pattern of the take-offs (PATTERNS), as shipped
        pattern = "chaotic" if s.chaotic else rebound_pattern(ds)
    decided = (
        {}
        if stop == "full"
        else {
            "periods_run": float(ds.attrs["periods_run"]),
            "stop_reason": REASONS.index(ds.attrs["stop_reason"]),
            "asymptotic_drift_velocity": ds.attrs.get("asymptotic_drift_velocity", np.nan),
        }
    )
    return {
        **decided,
        "drift_velocity": s.drift_velocity,
        "final_drift_velocity": s.final_drift_velocity,
        "contact": int(jumping),
        "drift": DRIFTS[s.drift],
        "pattern": PATTERNS.index(pattern or "none"),
        "chaotic": int(bool(s.chaotic)),
        "contact_fraction": s.contact_fraction,
        "takeoffs_per_period": s.takeoffs_per_period,
        "steps": s.steps + s.twin_steps,  # VARIABLES: run + twin
        "seconds": s.seconds + s.twin_seconds,
        "lyapunov": np.nan if s.lyapunov is None else s.lyapunov,
    }


def lyapunov_point(values: Any, log_a: Any, log_m: Any) -> dict[str, Any]:
    """One point of a Lyapunov map (kind "lyapunov", model vertical)."""
    scene = Scene(amplitude=10.0**log_a, mass=10.0**log_m, **values)
    ds = RunArrays(*run_records(scene, lyapunov=True))
    value = ds.attrs.get("lyapunov")
    return {
        "lyapunov": np.nan if value is None else value,
        "contact": int(jumped(ds)),
        "steps": int(ds.attrs["steps"]),
        "seconds": float(ds.attrs["seconds"]),
    }


KINDS = ("transport", "lyapunov")  # drift maps; the vertical motion's exponent


def _compute_row_block(values, log_as, log_ms, kind="transport", chaos="twin", stop="full"):
    """All points of a chunk (a worker task)."""
    if kind == "lyapunov":
        return [[lyapunov_point(values, la, lm) for lm in log_ms] for la in log_as]
    return [[compute_point(values, la, lm, chaos, stop) for lm in log_ms] for la in log_as]


def block_digest(block: Any, variables: Any = VARIABLES) -> np.unsignedinteger:
    h = hashlib.sha256()
    for name in variables:
        h.update(np.ascontiguousarray(block[name].values).tobytes())
    return np.uint64(int(h.hexdigest()[:16], 16))


class Sweep:
    """A sweep's definition: the scene values (everything but A*, m*) and the grid.

    Parameters
    ----------
    log_amplitude, log_mass : array_like
        The grid's log10 A* and log10 m*.
    chunk_rows : int
        Rows of log_amplitude per chunk (the unit of work and of resuming).
    command : str, optional
        The command that made the store, recorded in its attributes.
    kind : str
        "transport" (drift maps) or "lyapunov" (the vertical motion's
        exponent).
    chaos : str
        Where a transport map's chaos flag comes from: "lyapunov" or "twin".
    stop : str
        "full" or "decided" (stop each point once its drift is decided).
    **values
        Scene values (`Scene`'s parameters but amplitude and mass).

    Raises
    ------
    InputError
        If a value is outside its range, or the combination is not a sweep.
    """

    def __init__(
        self,
        log_amplitude: npt.ArrayLike,
        log_mass: npt.ArrayLike,
        chunk_rows: int = 4,
        command: str | None = None,
        kind: str = "transport",
        chaos: str = "lyapunov",
        stop: str = "full",
        **values: Any,
    ) -> None:
        if kind not in KINDS:
            raise InputError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        if chaos not in CHAOS_SOURCES:
            raise InputError(f"chaos must be one of {', '.join(CHAOS_SOURCES)}, got {chaos!r}")
        if kind == "lyapunov" and values.get("model") not in ("vertical", "point-mass"):
            raise InputError(
                "a lyapunov sweep runs the vertical model (model='vertical') or "
                "the material point (model='point-mass'): the indicator is the "
                "vertical motion's"
            )
        check_stop(stop)
        if kind == "lyapunov" and stop != "full":
            raise InputError(
                f"stop must be full for a lyapunov sweep (its exponent is "
                f"measured over the whole run), got {stop!r}"
            )
        self.kind = kind
        self.chaos = chaos
        self.stop = stop
        self.variables = variables_of(kind, chaos, stop)
        scene = Scene(**values)  # validates every value
        self.values = {k: getattr(scene, k) for k in SCENE_KEYS}
        if scene.profile != "sphere":
            self.values["profile"] = scene.profile
            if scene.load_over_modulus is not None:
                self.values["load_over_modulus"] = scene.load_over_modulus
        if ROLLING_KEY in scene.values():
            self.values[ROLLING_KEY] = scene.rolling
        self.log_amplitude = np.asarray(log_amplitude, dtype=float)
        self.log_mass = np.asarray(log_mass, dtype=float)
        if not (isinstance(chunk_rows, int) and chunk_rows >= 1):
            raise InputError(f"chunk_rows must be an integer >= 1, got {chunk_rows!r}")
        self.chunk_rows = chunk_rows
        self.command = command or "python API"

    @property
    def n_chunks(self) -> int:
        return -(-self.log_amplitude.size // self.chunk_rows)

    def rows(self, k: int) -> slice:
        return slice(k * self.chunk_rows, min((k + 1) * self.chunk_rows, self.log_amplitude.size))

    def attrs(self) -> dict[str, Any]:
        return {
            **{f"scene_{k}": v for k, v in self.values.items()},
            "chunk_rows": self.chunk_rows,
            "code_version": __version__,
            "command": self.command,
            **({"kind": self.kind} if self.kind != "transport" else {}),
            **({"chaos": self.chaos} if self.kind == "transport" else {}),
            **({"stop": self.stop} if self.stop != "full" else {}),
        }

    def empty_dataset(self) -> xr.Dataset:
        shape = (self.log_amplitude.size, self.log_mass.size)
        data: dict[str, tuple] = {
            name: (("log_amplitude", "log_mass"), np.full(shape, fill, dtype=dt), {"description": desc})
            for name, (dt, fill, desc) in self.variables.items()
        }
        data["done"] = (("chunk",), np.zeros(self.n_chunks, dtype=bool))
        data["digest"] = (("chunk",), np.zeros(self.n_chunks, dtype=np.uint64))
        return xr.Dataset(
            data,
            coords={
                "log_amplitude": self.log_amplitude,
                "log_mass": self.log_mass,
                "chunk": np.arange(self.n_chunks),
            },
            attrs=self.attrs(),
        )


def check_store(ds: xr.Dataset, sweep: Sweep, path: str | os.PathLike[str]) -> None:
    problems = []
    for k, v in sweep.values.items():
        got = ds.attrs.get(f"scene_{k}")
        if got != v:
            problems.append(f"{k}: store {got!r}, command {v!r}")
    for k in PROFILE_KEYS:
        if k not in sweep.values and f"scene_{k}" in ds.attrs:
            problems.append(
                f"{k}: store {ds.attrs[f'scene_{k}']!r}, command {'sphere' if k == 'profile' else None!r}"
            )
    if ROLLING_KEY not in sweep.values and f"scene_{ROLLING_KEY}" in ds.attrs:
        problems.append(f"{ROLLING_KEY}: store {ds.attrs[f'scene_{ROLLING_KEY}']!r}, command 'none'")
    for name in ("log_amplitude", "log_mass"):
        grid = getattr(sweep, name)
        if ds[name].size != grid.size or not np.allclose(ds[name].values, grid, atol=1e-9):
            problems.append(f"{name} grid differs")
    if ds.attrs.get("kind", "transport") != sweep.kind:
        problems.append(f"kind: store {ds.attrs.get('kind', 'transport')}, command {sweep.kind}")
    elif sweep.kind == "transport" and ds.attrs.get("chaos", "twin") != sweep.chaos:
        problems.append(f"chaos: store {ds.attrs.get('chaos', 'twin')}, command {sweep.chaos}")
    if ds.attrs.get("stop", "full") != sweep.stop:
        problems.append(f"stop: store {ds.attrs.get('stop', 'full')}, command {sweep.stop}")
    if ds.attrs.get("chunk_rows") != sweep.chunk_rows:
        problems.append(f"chunk_rows: store {ds.attrs.get('chunk_rows')}, command {sweep.chunk_rows}")
    if problems:
        raise StoreMismatch(
            f"{path} was made with other parameters ({'; '.join(problems)}); use another --out or delete it"
        )


def verify(ds: xr.Dataset, path: Any = "store") -> None:
    """Raise StoreMismatch unless every done chunk matches its digest."""
    rows = ds.attrs.get("chunk_rows", 0)
    if (
        not isinstance(rows, int)
        or isinstance(rows, bool)
        or rows < 1
        or "done" not in ds
        or "digest" not in ds
    ):
        raise StoreMismatch(f"{path} is not a vibtrans sweep store")
    kind = ds.attrs.get("kind", "transport")  # (stores before kinds: transport,
    chaos = ds.attrs.get("chaos", "twin")  #  judged by the twin)
    if kind not in KINDS or chaos not in CHAOS_SOURCES:
        raise StoreMismatch(f"{path} is a sweep store of unknown kind {kind!r} or chaos source {chaos!r}")
    stop = ds.attrs.get("stop", "full")
    if stop not in STOPS:
        raise StoreMismatch(f"{path} is a sweep store of unknown stop rule {stop!r}")
    variables = variables_of(kind, chaos, stop)
    if "computed" in ds or "adaptive_max_level" in ds.attrs:
        # an adaptive map (vibtrans.maps.adaptive): which points were simulated is
        # data too, digested with the rest
        variables = {**variables, "computed": ("bool", False, "simulated, not filled")}
    missing = [name for name in variables if name not in ds]
    if missing:
        raise StoreMismatch(f"{path} is not a complete vibtrans sweep store (missing: {', '.join(missing)})")
    try:
        done, digests = ds["done"].values, ds["digest"].values
    except Exception as exc:  # undecodable flags: damaged or truncated
        raise StoreMismatch(
            f"{path}: the done flags or digests cannot be read ({short_reason(exc)})"
        ) from None
    n_chunks = -(-ds.sizes.get("log_amplitude", 0) // rows)
    if done.shape != digests.shape or done.ndim != 1 or done.size != n_chunks or not n_chunks:
        raise StoreMismatch(f"{path}: the done flags do not fit its grid (damaged or edited)")
    try:  # one read of each variable (a read per chunk cost ~1.5 ms each)
        whole = ds[list(variables)].load()
    except Exception:  # a damaged chunk: read chunk by chunk, to name it
        whole = None
    for k in np.flatnonzero(done):
        sl = slice(int(k) * rows, (int(k) + 1) * rows)
        try:
            block = (
                ds[list(variables)].isel(log_amplitude=sl).load()
                if whole is None
                else whole.isel(log_amplitude=sl)
            )
        except Exception as exc:  # undecodable chunk: damaged or truncated
            raise StoreMismatch(f"{path}: chunk {k} cannot be read ({short_reason(exc)})") from None
        if block_digest(block, variables) != digests[k]:
            raise StoreMismatch(
                f"{path}: chunk {k} does not match its digest (damaged or edited); delete the store and rerun"
            )


def open_map(path: str | os.PathLike[str], expect: Mapping[str, Any] | None = None) -> xr.Dataset:
    """Open a finished or partial sweep, verified; undone points are masked.

    Parameters
    ----------
    path : str or os.PathLike
        The Zarr store (or a netCDF file) of a sweep.
    expect : dict, optional
        Scene values the store must have been made with (e.g.
        `{"model": "deformable", "mu": 0.3}`, from a map's file name).

    Returns
    -------
    xarray.Dataset
        The map over (log_amplitude, log_mass).

    Raises
    ------
    StoreMismatch
        If the store is unreadable, damaged, or made with other values than
        `expect`.
    """
    if not os.path.exists(path):
        raise FileNotFoundError(f"no sweep store at {path}")
    try:
        # chunks=None: numpy, not dask (the maps are small; dask's per-read
        # overhead made opening the shipped maps take seconds)
        ds = xr.open_zarr(path, consolidated=False, chunks=None)
    except Exception as exc:
        raise StoreMismatch(f"{path} is not a readable Zarr store ({short_reason(exc)})") from None
    made = {k: ds.attrs.get(f"scene_{k}") for k in (expect or {})}
    if made != dict(expect or {}) and "chunk_rows" in ds.attrs:  # (foreign: verify says)
        have = ", ".join(f"{k}={v}" for k, v in made.items())
        want = ", ".join(f"{k}={v}" for k, v in (expect or {}).items())
        raise StoreMismatch(
            f"{path} was made for {have}, not {want} (a sweep store under another map's name?)"
        )
    verify(ds, path)
    try:
        ds = ds.load()
    except Exception as exc:  # e.g. an unfinished chunk that is damaged
        raise StoreMismatch(f"{path} cannot be read ({short_reason(exc)})") from None
    rows = int(ds.attrs["chunk_rows"])
    done_rows = np.repeat(ds["done"].values, rows)[: ds.sizes["log_amplitude"]]
    return ds.assign(point_done=("log_amplitude", done_rows))


VERTICAL_VARIABLES = ("threshold_amplitude", "point_mass_threshold_amplitude")


def open_vertical(path: str | os.PathLike[str]) -> xr.Dataset:
    """The jumping-threshold curve A_J*(m*), checked.

    Parameters
    ----------
    path : str or os.PathLike
        The netCDF file written by `vibtrans threshold --sweep`.

    Returns
    -------
    xarray.Dataset
        The curve along `log_mass`.

    Raises
    ------
    StoreMismatch
        Naming the path and the problem, if the file is unreadable (damaged,
        truncated) or not such a curve.
    """
    if not os.path.exists(path):
        raise FileNotFoundError(f"no vertical curve at {path}")
    try:
        ds = xr.load_dataset(path)
    except Exception as exc:
        raise StoreMismatch(f"{path} is not a readable netCDF file ({short_reason(exc)})") from None
    missing = [v for v in ("log_mass", *VERTICAL_VARIABLES) if v not in ds.variables]
    if missing:
        raise StoreMismatch(f"{path} is not a vibtrans vertical curve (missing: {', '.join(missing)})")
    lm = ds["log_mass"].values
    if (
        ds["log_mass"].dims != ("log_mass",)
        or lm.size < 2
        or lm.dtype.kind != "f"
        or not np.isfinite(lm).all()
        or not (np.diff(lm) > 0).all()
    ):
        raise StoreMismatch(f"{path}: log_mass is not an increasing grid of finite numbers")
    for v in VERTICAL_VARIABLES:
        a = ds[v].values
        if ds[v].dims != ("log_mass",) or a.dtype.kind != "f" or (a <= 0).any():
            raise StoreMismatch(f"{path}: {v} is not a positive curve over log_mass")
    return ds


def run_sweep(
    sweep: Sweep,
    path: str | os.PathLike[str],
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    executor: str = "threads",
    flush_every: float | None = None,
) -> str | os.PathLike[str]:
    """Compute every unfinished chunk of `sweep` into the Zarr store `path`.

    A store left by an interrupted run resumes where it stopped.

    Parameters
    ----------
    sweep : Sweep
        The map's definition: scene values and grid.
    path : str or os.PathLike
        The Zarr store, created if missing.
    workers : int, optional
        Parallel workers; None: one per core.
    scheduler : str, optional
        A Dask scheduler address (tcp://HOST:PORT) to send the chunks to.
    progress : bool
        Show a progress bar on stderr.
    executor : str
        "threads" (default, measured faster: the numba kernels release the
        GIL) or "processes".
    flush_every : float, optional
        Seconds finished chunks may wait before they are written (default
        FLUSH_EVERY_S; 0: each as it finishes).

    Returns
    -------
    str or os.PathLike
        `path`.

    Raises
    ------
    InputError
        If a parameter is outside its range.
    StoreMismatch
        If `path` holds a store of another sweep, or an unreadable one.
    """
    if executor not in ("processes", "threads"):
        raise InputError(f"executor must be processes or threads, got {executor!r}")
    flush_every = check_flush_every(FLUSH_EVERY_S if flush_every is None else flush_every)
    if os.path.exists(path):
        try:
            existing = xr.open_zarr(path, consolidated=False)
        except Exception as exc:
            raise StoreMismatch(
                f"{path} exists but is not a readable sweep store ({short_reason(exc)})"
            ) from None
        check_store(existing, sweep, path)
        verify(existing, path)
        done = existing["done"].values.copy()
    else:
        sweep.empty_dataset().to_zarr(
            path,
            mode="w",
            encoding={name: {"chunks": (sweep.chunk_rows, sweep.log_mass.size)} for name in sweep.variables},
            consolidated=False,
        )
        done = np.zeros(sweep.n_chunks, dtype=bool)
    todo = [k for k in range(sweep.n_chunks) if not done[k]]
    if not todo:
        return path
    warmup()  # fill the numba cache once, before any worker starts
    total = sum(sweep.rows(k).stop - sweep.rows(k).start for k in todo) * sweep.log_mass.size
    bar = progress_bar(total, progress)
    writer = _ChunkWriter(path, sweep, bar, flush_every)
    try:
        _run_chunks(sweep, todo, writer, workers, scheduler, executor)
    finally:
        writer.flush()  # what finished is kept, whatever stopped the sweep
    bar.close()
    return path


def _run_chunks(sweep, todo, writer, workers, scheduler, executor):
    """Compute the chunks `todo` on the local pool or the dask cluster, handing
    each finished chunk to `writer`."""

    def job(k):  # _compute_row_block's arguments for chunk k
        s = sweep
        return s.values, s.log_amplitude[s.rows(k)], s.log_mass, s.kind, s.chaos, s.stop

    if scheduler:
        from dask.distributed import Client

        with Client(scheduler) as client:
            client.run(warmup)
            futures = {client.submit(_compute_row_block, *job(k), pure=False): k for k in todo}
            from dask.distributed import as_completed

            for fut in as_completed(futures):
                writer.add(futures[fut], fut.result())
    else:
        workers = workers or os.cpu_count() or 1
        import multiprocessing as mp

        if executor == "threads":
            pool_cm: Executor = ThreadPoolExecutor(max_workers=workers)
        else:
            pool_cm = ProcessPoolExecutor(
                max_workers=workers, initializer=warmup, mp_context=mp.get_context("spawn")
            )
        with pool_cm as pool:
            pending: dict[Future, int] = {}
            queue = list(todo)
            while queue or pending:
                while queue and len(pending) < 2 * workers:
                    k = queue.pop(0)
                    pending[pool.submit(_compute_row_block, *job(k))] = k
                finished, _ = wait(pending, return_when=FIRST_COMPLETED)
                failed = None
                for fut in finished:  # every chunk that finished is kept
                    k = pending.pop(fut)
                    if fut.exception() is None:
                        writer.add(k, fut.result())
                    else:
                        failed = failed or fut
                if failed is not None:
                    failed.result()  # raises the chunk's error


def progress_bar(total: Any, enabled: bool) -> Any[NoReturn]:
    from tqdm import tqdm

    return tqdm(total=total, unit="pt", file=sys.stderr, disable=not enabled, desc="sweep", smoothing=0.05)


FLUSH_EVERY_S = 2.0  # finished chunks wait in memory at most this long


def check_flush_every(seconds: float) -> float:
    """The validated flush interval (seconds, a number in [0, 3600])."""
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not 0.0 <= seconds <= 3600.0:
        raise InputError(f"flush_every must be a number of seconds in [0, 3600], got {seconds!r}")
    return float(seconds)


class _ChunkWriter:
    """Writes finished chunks to the store: each contiguous run of them in
    one region write of their data and digests, then one of their done
    flags, at most every `flush_every` seconds (and at `flush`).  A kill
    loses at most that much finished work, besides the chunks in flight."""

    def __init__(self, path, sweep, bar, flush_every):
        self.path = path
        self.sweep = sweep
        self.bar = bar
        self.flush_every = flush_every
        self.finished = {}
        self.last = time.monotonic()

    def add(self, k, rows):
        self.finished[k] = rows
        self.bar.update(sum(len(row) for row in rows))
        if time.monotonic() - self.last >= self.flush_every:
            self.flush()

    def flush(self):
        ks = sorted(self.finished)
        start = 0
        for i in range(1, len(ks) + 1):
            if i == len(ks) or ks[i] != ks[i - 1] + 1:
                run = ks[start:i]
                _write_chunks(self.path, self.sweep, run, [self.finished[k] for k in run])
                start = i
        self.finished.clear()
        self.last = time.monotonic()


def _write_chunks(path, sweep, ks, blocks):
    """Write the consecutive chunks `ks` (their points' dicts, `blocks`):
    their data and digests, then their done flags, each one write."""
    sl = slice(sweep.rows(ks[0]).start, sweep.rows(ks[-1]).stop)
    rows = [row for block in blocks for row in block]
    data = {}
    for name, (dt, _, _) in sweep.variables.items():
        data[name] = (
            ("log_amplitude", "log_mass"),
            np.array([[p[name] for p in row] for row in rows], dtype=dt),
        )
    block = xr.Dataset(data)
    digests = [
        block_digest(
            block.isel(log_amplitude=slice(sweep.rows(k).start - sl.start, sweep.rows(k).stop - sl.start)),
            sweep.variables,
        )
        for k in ks
    ]
    chunks = slice(ks[0], ks[-1] + 1)
    block["digest"] = (("chunk",), np.array(digests, dtype=np.uint64))
    # the flags last, a write of their own: they commit the chunks, so a kill
    # at any point before them redoes these chunks
    block.to_zarr(
        path, region={"log_amplitude": sl, "log_mass": slice(None), "chunk": chunks}, consolidated=False
    )
    xr.Dataset({"done": (("chunk",), np.ones(len(ks), dtype=bool))}).to_zarr(
        path, region={"chunk": chunks}, consolidated=False
    )


def command_line() -> str:
    return "vibtrans " + " ".join(shlex.quote(a) for a in sys.argv[1:])
