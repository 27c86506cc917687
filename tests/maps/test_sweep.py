"""Sweeps: equality with point-by-point runs, kill-and-resume, Dask, and
refusal of mismatched or damaged stores.  Small grids and short runs."""

import os
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from asyncutil import wait_until
from budget import budget

from vibtrans.core.errors import InputError
from vibtrans.maps.sweep import (
    VARIABLES,
    StoreMismatch,
    Sweep,
    compute_point,
    open_map,
    parse_range,
    run_sweep,
    verify,
)

SMALL = dict(periods=120.0, tau=10.0)
LA = "0:2.5:0.5"  # 6 amplitudes
LM = "-2:1:1"  # 4 masses


def small_sweep(chunk_rows=2, **over):
    return Sweep(parse_range(LA, "a"), parse_range(LM, "m"), chunk_rows=chunk_rows, **{**SMALL, **over})


def same(a, b):
    for name in VARIABLES:
        x, y = a[name].values, b[name].values
        if name == "seconds":
            continue  # wall time differs run to run
        assert np.array_equal(x, y, equal_nan=True), name


def test_sweep_equals_point_by_point(tmp_path):
    # A sweep point is exactly the library's run of that scene (same code path).
    sw = small_sweep()
    run_sweep(sw, str(tmp_path / "s.zarr"), workers=2, progress=False)
    ds = open_map(str(tmp_path / "s.zarr"))
    assert ds["done"].values.all()
    for i in (0, 3, 5):
        for j in (0, 2):
            p = compute_point(sw.values, sw.log_amplitude[i], sw.log_mass[j], sw.chaos)
            for name in sw.variables:
                if name != "seconds":
                    assert ds[name].values[i, j] == p[name] or (
                        np.isnan(p[name]) and np.isnan(ds[name].values[i, j])
                    ), name


@pytest.mark.parametrize(
    "model, la, lm, lyapunov",
    [
        ("deformable", 1.5, -2.0, True),  # jumping, chaotic (paper point 8's region)
        ("deformable", 0.5, 0.5, False),  # jumping, regular
        ("deformable", -1.0, -3.0, False),  # permanent contact
        ("point-mass", 1.5, -2.0, True),  # the impact map's exponent
        ("point-mass", 0.5, 0.5, False),
    ],
)
def test_a_points_arrays_are_its_datasets_and_summarize_alike(model, la, lm, lyapunov):
    """A map point summarizes its run's arrays (trajectory.RunArrays) instead
    of the run's Dataset (`simulate`): the same arrays, attributes and
    summary, bit for bit, whatever the time a run took."""
    from vibtrans.analysis.summary import summarize
    from vibtrans.core.params import Scene
    from vibtrans.core.simulate import run_records, simulate
    from vibtrans.core.trajectory import RunArrays

    scene = Scene(amplitude=10.0**la, mass=10.0**lm, model=model, periods=150.0, tau=10.0, fidelity="preview")
    ds = simulate(scene, lyapunov=lyapunov)
    arrays = RunArrays(*run_records(scene, lyapunov=lyapunov))
    for name in [*ds.data_vars, "time"]:
        assert np.array_equal(arrays[name].values, ds[name].values), name
        assert arrays[name].values.dtype == ds[name].values.dtype, name
    assert arrays.attrs.keys() == ds.attrs.keys()
    assert {k: v for k, v in arrays.attrs.items() if k != "seconds"} == {
        k: v for k, v in ds.attrs.items() if k != "seconds"
    }
    got, want = summarize(arrays)._asdict(), summarize(ds)._asdict()
    for k in ("seconds", "twin_seconds"):
        got.pop(k), want.pop(k)
    assert got.keys() == want.keys()
    for k in got:
        assert got[k] == want[k] or (got[k] != got[k] and want[k] != want[k]), k


def _cli(out, extra=()):
    return [
        sys.executable,
        "-m",
        "vibtrans.cli",
        "sweep",
        "--log-amplitude",
        LA,
        f"--log-mass={LM}",
        "--periods",
        "120",
        "--tau",
        "10",
        "--chunk-rows",
        "1",
        "--workers",
        "1",
        "--out",
        out,
        *extra,
    ]


@pytest.mark.slow
def test_kill_and_resume_is_bit_identical(tmp_path):
    # A real subprocess killed (SIGKILL) mid-sweep, then started again with the
    # same command, ends equal to an uninterrupted run, bit for bit.
    # (2000 periods: a chunk takes ~0.2 s, long enough for the polling below
    # to see the sweep part-way on a loaded machine; at 120 periods it could
    # finish between two polls)
    # (--flush-every 0: each chunk written as it finishes, as a kill can
    # then find the store part-way at every chunk)
    longer = ("--periods", "2000", "--flush-every", "0")
    full = str(tmp_path / "full.zarr")
    subprocess.run(_cli(full, longer), check=True, capture_output=True)
    part = str(tmp_path / "part.zarr")
    # a sweep that ends between two polls (a busy machine can hold the
    # polling process back) is not interrupted: it is started again afresh,
    # a few times; one that fails is a failure
    for _ in range(3):
        shutil.rmtree(part, ignore_errors=True)
        log = tmp_path / "part.log"
        with open(log, "w") as err:
            proc = subprocess.Popen(
                _cli(part, longer), stdout=subprocess.DEVNULL, stderr=err, start_new_session=True
            )

        def part_way():
            if proc.poll() is not None:  # ended before it was seen part-way
                return True
            try:
                done = xr.open_zarr(part, consolidated=False)["done"].values
            except Exception:
                return False
            return 1 <= done.sum() < done.size - 1

        wait_until(part_way, budget(240), "the sweep part-way")
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            break
        assert proc.returncode == 0, log.read_text()
    else:
        pytest.fail("the sweep ended three times before it was seen part-way")
    done_before = xr.open_zarr(part, consolidated=False)["done"].values.copy()
    assert 1 <= done_before.sum() < done_before.size  # really interrupted
    kept = open_map(part)
    subprocess.run(_cli(part, longer), check=True, capture_output=True)
    a, b = open_map(full), open_map(part)
    same(a, b)
    # finished chunks were not recomputed: their wall times are unchanged
    rows = np.flatnonzero(done_before)
    assert np.array_equal(kept["seconds"].values[rows], b["seconds"].values[rows])


@pytest.mark.slow
def test_dask_cluster_equals_local(tmp_path):
    from dask.distributed import LocalCluster

    sw = small_sweep()
    run_sweep(sw, str(tmp_path / "local.zarr"), workers=1, progress=False)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        run_sweep(sw, str(tmp_path / "dask.zarr"), scheduler=cluster.scheduler_address, progress=False)
    same(open_map(str(tmp_path / "local.zarr")), open_map(str(tmp_path / "dask.zarr")))


def test_mismatched_store_is_refused(tmp_path):
    path = str(tmp_path / "s.zarr")
    run_sweep(small_sweep(), path, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="mu"):
        run_sweep(small_sweep(mu=0.1), path, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="grid"):
        run_sweep(
            Sweep(parse_range("0:2:0.5", "a"), parse_range(LM, "m"), chunk_rows=2, **SMALL),
            path,
            workers=1,
            progress=False,
        )


def _chunk_files(path, var):
    root = os.path.join(path, var)
    return sorted(
        os.path.join(d, f)
        for d, _, fs in os.walk(root)
        for f in fs
        if not f.startswith("zarr") and not f.startswith(".")
    )


@pytest.mark.parametrize("damage", ["truncate", "flip", "delete-meta"])
def test_damaged_store_is_refused(tmp_path, damage):
    path = str(tmp_path / "s.zarr")
    run_sweep(small_sweep(), path, workers=1, progress=False)
    if damage == "delete-meta":
        os.remove(os.path.join(path, "zarr.json"))
    else:
        target = _chunk_files(path, "drift_velocity")[0]
        data = open(target, "rb").read()
        with open(target, "wb") as f:
            if damage == "truncate":
                f.write(data[: len(data) // 2])
            else:
                f.write(data[:-9] + bytes([data[-9] ^ 0xFF]) + data[-8:])
    with pytest.raises((StoreMismatch, FileNotFoundError)):
        open_map(path)
    with pytest.raises((StoreMismatch, FileNotFoundError)):
        run_sweep(small_sweep(), path, workers=1, progress=False)


def test_foreign_and_missing_stores_are_refused(tmp_path):
    foreign = str(tmp_path / "foreign.zarr")
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_zarr(foreign, consolidated=False)
    with pytest.raises(StoreMismatch, match="not a vibtrans sweep"):
        open_map(foreign)
    with pytest.raises(FileNotFoundError):
        open_map(str(tmp_path / "none.zarr"))
    shutil.rmtree(foreign)


@pytest.mark.parametrize("text", ["1:0:0.1", "0:1:0", "0:1", "a:b:c", "0:nan:0.1"])
def test_bad_ranges(text):
    with pytest.raises(ValueError, match="log_mass"):
        parse_range(text, "log_mass")


def test_chunks_finished_before_a_failure_are_kept(tmp_path, monkeypatch):
    # Finished chunks wait in memory to be written together (FLUSH_EVERY_S);
    # a sweep stopped by an error (or Ctrl-C) still writes them, so the
    # rerun resumes after them.  flush_every=3600: nothing is written before
    # the failure stops the sweep.
    import vibtrans.maps.sweep as S

    sw = small_sweep(chunk_rows=1)
    real = S._compute_row_block
    failing = sw.log_amplitude[3]

    def compute(values, log_as, *args):
        if failing in log_as:
            raise RuntimeError("a point failed")
        return real(values, log_as, *args)

    monkeypatch.setattr(S, "_compute_row_block", compute)
    path = str(tmp_path / "s.zarr")
    with pytest.raises(RuntimeError, match="a point failed"):
        run_sweep(sw, path, workers=1, progress=False, flush_every=3600)
    done = xr.open_zarr(path, consolidated=False)["done"].values
    assert done[:3].all() and not done[3]
    verify(xr.open_zarr(path, consolidated=False), path)  # their digests match
    monkeypatch.setattr(S, "_compute_row_block", real)
    run_sweep(sw, path, workers=1, progress=False)
    ref = str(tmp_path / "ref.zarr")
    run_sweep(sw, ref, workers=1, progress=False, flush_every=0)
    same(open_map(ref), open_map(path))


@pytest.mark.parametrize("bad", [-1, float("nan"), float("inf"), "often", True])
def test_flush_interval_is_validated(tmp_path, bad):
    path = str(tmp_path / "s.zarr")
    with pytest.raises(InputError, match=r"flush_every must be a number of seconds in \[0, 3600\]"):
        run_sweep(small_sweep(), path, workers=1, progress=False, flush_every=bad)
    assert not os.path.exists(path)
