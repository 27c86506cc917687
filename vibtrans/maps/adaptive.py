"""Adaptive drift maps: points are computed only where the map changes.

The finest grid is a sweep's; level 0 is every 2^K-th point (K the finest
level), level l's cells are 2^(K-l) finest steps wide.  A cell is refined
(its edge midpoints and centre computed) when its known corners and edge
midpoints differ in drift class, contact mode or chaos verdict, or in drift
velocity by more than tol * max(V0, max|v|); an all-chaotic cell is not
refined on drift (its drift is noise).  Cells are re-examined until none
changes.  Points come from sweep.compute_point, bit-identical to a uniform
sweep's.  Points not computed are filled from their smallest unrefined cell:
categories from the nearest corner, continuous values bilinearly; `computed`
marks the simulated ones.

Resumable from digested .npz batches in `<out>.partial/` (a damaged one:
StoreMismatch naming it); the result is a regular sweep store.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from typing import TYPE_CHECKING, Any

import numpy as np

from vibtrans.analysis.summary import V0
from vibtrans.core.errors import Cancelled, InputError, StoreMismatch
from vibtrans.core.simulate import warmup
from vibtrans.maps.sweep import block_digest, check_store, compute_point, progress_bar, short_reason, verify

if TYPE_CHECKING:
    import xarray as xr

    from vibtrans.maps.sweep import Sweep

MAX_LEVELS = (1, 8)
DEFAULT_DRIFT_TOLERANCE = 0.5
CATEGORICAL = ("drift", "contact", "chaotic", "pattern")
CONTINUOUS = ("drift_velocity", "final_drift_velocity", "contact_fraction", "takeoffs_per_period", "lyapunov")
COMPUTED = {
    "computed": (
        "bool",
        False,
        "True where the point was simulated, False where it was filled from its cell (adaptive maps)",
    )
}
BATCH_POINTS = 64  # points per batch file (a kill loses at most these)
POINTS_PER_TASK = 4  # points per worker task (amortizes the pool's overhead)


def check_levels(sweep: Sweep, max_level: int) -> None:
    """Refuse a finest level outside 1..8 or a grid it cannot refine ((n - 1) % 2^K)."""
    lo, hi = MAX_LEVELS
    if (
        isinstance(max_level, bool)
        or not isinstance(max_level, (int, np.integer))
        or not lo <= max_level <= hi
    ):
        raise InputError(f"max_level must be an integer in {lo}..{hi}, got {max_level!r}")
    stride = 2 ** int(max_level)
    for name in ("log_amplitude", "log_mass"):
        n = getattr(sweep, name).size
        if (n - 1) % stride or n < stride + 1:
            sizes = ", ".join(str(stride * k + 1) for k in (1, 2, 4, 8, 16))
            raise InputError(
                f"{name} has {n} points, which max_level {max_level} cannot "
                f"refine: (points - 1) must be a multiple of 2^{max_level} = "
                f"{stride} (e.g. {sizes} points)"
            )


def check_tolerance(tol: float) -> float:
    """Refuse a drift tolerance outside (0, 100]."""
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating)) or not 0 < tol <= 100:
        raise InputError(f"drift_tolerance must be a number in (0, 100], got {tol!r}")
    return float(tol)


class _Grid:
    """The finest grid's arrays, filled as points are computed."""

    def __init__(self, sweep):
        self.shape = (sweep.log_amplitude.size, sweep.log_mass.size)
        self.variables = sweep.variables
        self.data = {
            name: np.full(self.shape, fill, dtype=dt) for name, (dt, fill, _) in sweep.variables.items()
        }
        self.computed = np.zeros(self.shape, dtype=bool)

    def put(self, i, j, point):
        for name, (dt, _, _) in self.variables.items():
            self.data[name][i, j] = np.asarray(point[name], dtype=dt)
        self.computed[i, j] = True

    def copy(self):
        other = _Grid.__new__(_Grid)
        other.shape, other.variables = self.shape, self.variables
        other.data = {name: a.copy() for name, a in self.data.items()}
        other.computed = self.computed.copy()
        return other


def _cell_points(i0, j0, s):
    """A cell's corners and edge midpoints: the points its level can know."""
    return [(i0 + a, j0 + b) for a in (0, s) for b in (0, s)] + _new_points(i0, j0, s)[:4]


def disagree(grid: Any, i0: int, j0: int, s: Any, tol: float) -> bool:
    """True if the cell's known points disagree (the module docstring's rule);
    more points never turn True into False, so arrival order does not matter."""
    pts = [p for p in _cell_points(i0, j0, s) if grid.computed[p]]
    ii, jj = np.array(pts).T
    d = grid.data
    chaotic = d["chaotic"][ii, jj]
    if np.unique(chaotic).size > 1 or np.unique(d["contact"][ii, jj]).size > 1:
        return True
    if chaotic.all():
        return False  # a chaotic sea: drift is noise there
    if np.unique(d["drift"][ii, jj]).size > 1:
        return True
    v = d["drift_velocity"][ii, jj]
    if not np.isfinite(v).all():
        return True
    return bool(v.max() - v.min() > tol * max(V0, np.abs(v).max()))


def _new_points(i0, j0, s):
    h = s // 2
    return [(i0 + h, j0), (i0 + h, j0 + s), (i0, j0 + h), (i0 + s, j0 + h), (i0 + h, j0 + h)]


def _children(i0, j0, s):
    return [(i0 + a, j0 + b) for a in (0, s // 2) for b in (0, s // 2)]


# ---------------------------------------------------------------- partial folder
def _params(sweep, max_level, tol):
    p = {"scene": sweep.values, "kind": sweep.kind, "chaos": sweep.chaos}
    if sweep.stop != "full":
        p["stop"] = sweep.stop
    grid = {k: [float(v) for v in getattr(sweep, k)] for k in ("log_amplitude", "log_mass")}
    return {**p, **grid, "max_level": int(max_level), "drift_tolerance": float(tol)}


def _atomic_write(path, write):
    tmp = f"{path}.tmp-{os.getpid()}"
    with open(tmp, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _batch_digest(arrays):
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode() + str(a.dtype).encode() + str(a.shape).encode() + a.tobytes())
    return h.hexdigest()


class _Partial:
    """`<out>.partial/`: params.json and batch-NNNNNN.npz files."""

    def __init__(self, out, sweep, max_level, tol):
        self.folder = f"{out}.partial"
        self.sweep = sweep
        self.params = _params(sweep, max_level, tol)
        self.next = 0

    def open(self, grid):
        """Check the folder against the command, load its batches into grid;
        the points loaded."""
        path = os.path.join(self.folder, "params.json")
        if not os.path.isdir(self.folder):
            os.makedirs(self.folder)
        if not os.path.exists(path):
            if any(f.startswith("batch-") for f in os.listdir(self.folder)):
                raise StoreMismatch(
                    f"{self.folder} holds batches but no params.json (damaged); delete it and rerun"
                )
            _atomic_write(path, lambda f: f.write(json.dumps(self.params).encode()))
            return 0
        try:
            with open(path, "rb") as f:
                stored = json.loads(f.read().decode())
        except Exception as exc:
            raise StoreMismatch(
                f"{path} cannot be read ({short_reason(exc)}); delete {self.folder} and rerun"
            ) from None
        if not isinstance(stored, dict):
            raise StoreMismatch(f"{path} is not an adaptive sweep's parameters")
        problems = [k for k in self.params if stored.get(k) != self.params[k]]
        if problems:
            raise StoreMismatch(
                f"{self.folder} was made with other parameters (differ: "
                f"{', '.join(problems)}); use another --out or delete it"
            )
        loaded = 0
        names = sorted(f for f in os.listdir(self.folder) if f.startswith("batch-") and f.endswith(".npz"))
        for name in names:
            loaded += self._load(os.path.join(self.folder, name), grid)
            self.next = max(self.next, int(name[6:-4]) + 1)
        return loaded

    def _load(self, path, grid):
        want = ["i", "j", *grid.variables]
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except Exception as exc:
            raise StoreMismatch(
                f"{path} cannot be read ({short_reason(exc)}); delete that file "
                f"and rerun to recompute its points"
            ) from None
        digest = arrays.pop("sha256", None)
        if digest is None or sorted(arrays) != sorted(want) or str(digest) != _batch_digest(arrays):
            raise StoreMismatch(
                f"{path} does not match its digest (damaged or edited); "
                f"delete that file and rerun to recompute its points"
            )
        i, j = arrays["i"], arrays["j"]
        n = i.size
        if (
            i.ndim != 1
            or j.shape != i.shape
            or any(arrays[v].shape != (n,) for v in want)
            or (n and (i.min() < 0 or j.min() < 0 or i.max() >= grid.shape[0] or j.max() >= grid.shape[1]))
        ):
            raise StoreMismatch(f"{path} does not fit the grid (damaged or edited)")
        for k in range(n):
            grid.put(int(i[k]), int(j[k]), {v: arrays[v][k] for v in grid.variables})
        return n

    def write(self, points, grid):
        """One batch: the computed values of `points` [(i, j), ...]."""
        ii = np.array([p[0] for p in points], dtype=np.int64)
        jj = np.array([p[1] for p in points], dtype=np.int64)
        arrays = {"i": ii, "j": jj, **{v: grid.data[v][ii, jj] for v in grid.variables}}
        digest = np.array(_batch_digest(arrays))
        path = os.path.join(self.folder, f"batch-{self.next:06d}.npz")
        self.next += 1
        _atomic_write(path, lambda f: np.savez(f, sha256=digest, **arrays))


# ---------------------------------------------------------------- computing
def _compute_points(values, coords, chaos, stop="full"):
    """A worker task: a few points [(log_a, log_m), ...]."""
    return [compute_point(values, la, lm, chaos, stop) for la, lm in coords]


def _run_points(
    sweep, todo, grid, partial, workers, scheduler, bar, cancel=None, executor=None, on_done=None
):
    """Compute `todo` [(i, j)] into grid, writing batches, on `executor` or a
    pool of `workers` threads; Cancelled between tasks once `cancel` is set;
    on_done() after each task's points are in."""
    la, lm = sweep.log_amplitude, sweep.log_mass
    tasks = [todo[k : k + POINTS_PER_TASK] for k in range(0, len(todo), POINTS_PER_TASK)]
    finished = []

    def done(task, results):
        for p, r in zip(task, results):
            grid.put(p[0], p[1], r)
        finished.extend(task)
        bar.update(len(task))
        if len(finished) >= BATCH_POINTS:
            partial.write(finished, grid)
            finished.clear()
        if on_done is not None:
            on_done()

    def args(task):
        return (sweep.values, [(la[i], lm[j]) for i, j in task], sweep.chaos, sweep.stop)

    if scheduler is not None:
        from dask.distributed import as_completed

        futures = {scheduler.submit(_compute_points, *args(t), pure=False): t for t in tasks}
        for fut in as_completed(futures):
            done(futures[fut], fut.result())
            if _set(cancel):  # the cluster's queued tasks are dropped
                for other in futures:
                    other.cancel()
                break
    else:
        own = executor is None
        pool = ThreadPoolExecutor(max_workers=workers) if own else executor
        try:
            pending: dict = {}
            queue = list(tasks)
            while queue or pending:
                while queue and len(pending) < 2 * workers and not _set(cancel):
                    t = queue.pop(0)
                    pending[pool.submit(_compute_points, *args(t))] = t
                if not pending:  # cancelled: nothing more was started
                    break
                ready, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in ready:
                    done(pending.pop(fut), fut.result())
        finally:
            if own:
                pool.shutdown()
    if finished:
        partial.write(finished, grid)
    if _set(cancel):
        raise Cancelled("map cancelled")


def _set(event):
    return event is not None and event.is_set()


def _refine(sweep, max_level, tol, grid, compute, on_level=None):
    """The level-by-level refinement: compute(points, level, tiling) computes
    a level's missing points (tiling: cells covering the grid, for a
    snapshot), on_level(level, tiling) follows each level.  The leaves
    (unrefined cells) as (i0, j0, size)."""
    top = 2**max_level
    n_a, n_m = grid.shape
    cells = [(i, j) for i in range(0, n_a - 1, top) for j in range(0, n_m - 1, top)]
    coarse = [(i, j, top) for i, j in cells]
    compute(sorted({(i, j) for i in range(0, n_a, top) for j in range(0, n_m, top)}), 0, coarse)
    leaves: list = []
    size = top
    if on_level is not None:
        on_level(0, coarse)
    for _level in range(max_level):
        refined, pending = set(), set(cells)
        # while the level's points come in, each lies in a cell of this size
        tiling = leaves + [(i, j, size) for i, j in cells]
        while pending:  # until no cell of this level changes its verdict
            new = sorted(c for c in pending if disagree(grid, c[0], c[1], size, tol))
            refined.update(new)
            compute(sorted({p for c in new for p in _new_points(c[0], c[1], size)}), _level + 1, tiling)
            pending = set(cells) - refined
            if not new:
                break
        leaves += [(i, j, size) for i, j in cells if (i, j) not in refined]
        cells = sorted({ch for c in refined for ch in _children(c[0], c[1], size)})
        size //= 2
        if on_level is not None:
            on_level(_level + 1, leaves + [(i, j, size) for i, j in cells])
    return leaves  # (cells of size 1 hold no missing points)


def fill(grid: Any, leaves: Any) -> None:
    """Fill every point not computed from the smallest leaf holding it."""
    cont = [v for v in CONTINUOUS if v in grid.data]
    cat = [v for v in CATEGORICAL if v in grid.data]
    for i0, j0, s in sorted(leaves, key=lambda c: -c[2]):  # smallest last: it wins
        u = np.arange(s + 1) / s
        U, W = np.meshgrid(u, u, indexing="ij")
        sl = (slice(i0, i0 + s + 1), slice(j0, j0 + s + 1))
        free = ~grid.computed[sl]
        # nearest corner (ties to the lower index: deterministic)
        ci = np.where(U > 0.5, i0 + s, i0)
        cj = np.where(W > 0.5, j0 + s, j0)
        for v in cat:
            grid.data[v][sl][free] = grid.data[v][ci, cj][free]
        for v in cont:
            a = grid.data[v]
            c00, c01 = a[i0, j0], a[i0, j0 + s]
            c10, c11 = a[i0 + s, j0], a[i0 + s, j0 + s]
            val = c00 * (1 - U) * (1 - W) + c01 * (1 - U) * W + c10 * U * (1 - W) + c11 * U * W
            a[sl][free] = val[free]


def _check_adaptive_store(ds, sweep, max_level, tol, path):
    check_store(ds, sweep, path)
    got = (ds.attrs.get("adaptive_max_level"), ds.attrs.get("adaptive_tolerance"))
    if got != (max_level, tol):
        raise StoreMismatch(
            f"{path} was made with other parameters (adaptive max_level, "
            f"tolerance: store {got}, command {(max_level, tol)}); use "
            f"another --out or delete it"
        )


def run_adaptive(
    sweep: Sweep,
    path: str | os.PathLike[str],
    max_level: int,
    drift_tolerance: Any = DEFAULT_DRIFT_TOLERANCE,
    workers: int | None = None,
    scheduler: Any = None,
    progress: bool = True,
    on_level: Any = None,
    cancel: Any = None,
    executor: str | None = None,
    on_chunk: Any = None,
    chunk_seconds: float = 2.0,
) -> float:
    """Compute the adaptive map of a transport `sweep` (its grid the finest)
    into the Zarr store `path`, resuming from `<path>.partial/`; the fraction
    of points computed.  max_level: K (1..8); drift_tolerance: the spread that
    refines a cell.  on_level(level, snapshot): the map so far (`snapshot`)
    after level 0 and each refinement; on_chunk(level, snapshot): within a
    refinement level, every `chunk_seconds` while points come in.  cancel:
    a threading.Event (Cancelled; the finished points stay for a rerun).
    executor: a concurrent.futures.Executor shared with other maps, holding
    at most 2 x `workers` tasks; else a pool of `workers` threads.
    """
    import xarray as xr

    if sweep.kind != "transport":
        raise InputError(f"adaptive refinement makes drift maps (kind transport), not kind {sweep.kind}")
    check_levels(sweep, max_level)
    max_level = int(max_level)
    tol = check_tolerance(drift_tolerance)
    if os.path.exists(path):
        try:
            existing = xr.open_zarr(path, consolidated=False, chunks=None)
        except Exception as exc:
            raise StoreMismatch(
                f"{path} exists but is not a readable sweep store ({short_reason(exc)})"
            ) from None
        _check_adaptive_store(existing, sweep, max_level, tol, path)
        verify(existing, path)
        if not existing["done"].values.all():
            raise StoreMismatch(f"{path} is an unfinished adaptive store (edited?); delete it")
        # killed between the store's rename and the partial folder's removal
        shutil.rmtree(f"{path}.partial", ignore_errors=True)
        return float(existing["computed"].values.mean())
    workers = workers or os.cpu_count() or 1
    grid = _Grid(sweep)
    partial = _Partial(path, sweep, max_level, tol)
    partial.open(grid)
    warmup()
    bar = progress_bar(None, progress)
    client = None
    if scheduler:
        from dask.distributed import Client

        client = Client(scheduler)
        client.run(warmup)

    last = [time.monotonic()]  # when the last picture was taken

    def compute(points, level, tiling):
        todo = [p for p in points if not grid.computed[p]]
        bar.total = (bar.total or 0) + len(todo)
        bar.refresh()

        def chunk_done():
            if level > 0 and time.monotonic() - last[0] >= chunk_seconds:
                on_chunk(level, snapshot(sweep, grid, tiling))
                last[0] = time.monotonic()

        if todo:
            done = None if on_chunk is None else chunk_done
            _run_points(sweep, todo, grid, partial, workers, client, bar, cancel, executor, done)
        elif _set(cancel):
            raise Cancelled("map cancelled")

    def level_done(level, cells):
        on_level(level, snapshot(sweep, grid, cells))
        last[0] = time.monotonic()

    try:
        leaves = _refine(sweep, max_level, tol, grid, compute, None if on_level is None else level_done)
    finally:
        bar.close()
        if client is not None:
            client.close()
    fill(grid, leaves)
    fraction = float(grid.computed.mean())
    _write_store(sweep, grid, path, max_level, tol, fraction)
    shutil.rmtree(partial.folder, ignore_errors=True)
    return fraction


def snapshot(sweep: Sweep, grid: Any, cells: Any) -> xr.Dataset:
    """The map so far on the finest grid: a copy filled from `cells` (a tiling)."""
    import xarray as xr

    copy = grid.copy()
    fill(copy, cells)
    coords = {"log_amplitude": sweep.log_amplitude, "log_mass": sweep.log_mass}
    dims = ("log_amplitude", "log_mass")
    return xr.Dataset(
        {**{name: (dims, a) for name, a in copy.data.items()}, "computed": (dims, copy.computed)},
        coords=coords,
        attrs={**sweep.attrs(), "computed_fraction": float(copy.computed.mean())},
    )


def _write_store(sweep, grid, path, max_level, tol, fraction):
    """The finest grid as a finished sweep store, written aside and renamed to path."""
    ds = sweep.empty_dataset()
    for name in sweep.variables:
        ds[name].values[...] = grid.data[name]
    ds["computed"] = (
        ("log_amplitude", "log_mass"),
        grid.computed.copy(),
        {"description": COMPUTED["computed"][2]},
    )
    variables = {**sweep.variables, **COMPUTED}
    for k in range(sweep.n_chunks):
        ds["digest"].values[k] = block_digest(ds.isel(log_amplitude=sweep.rows(k)), variables)
    ds["done"].values[:] = True
    ds.attrs.update(adaptive_max_level=max_level, adaptive_tolerance=tol, computed_fraction=fraction)
    tmp = f"{path}.writing"
    shutil.rmtree(tmp, ignore_errors=True)  # a killed run's unfinished copy
    ds.to_zarr(
        tmp,
        mode="w",
        consolidated=False,
        encoding={name: {"chunks": (sweep.chunk_rows, sweep.log_mass.size)} for name in variables},
    )
    os.rename(tmp, path)
