"""Adaptive drift maps (vibtrans.maps.adaptive): against a uniform sweep at the
finest step on windows across the jumping boundary and the fundamental
resonance; refusal of bad levels, mismatched parameters and damaged batches
or stores; resumption after a kill.  Preview fidelity, short runs."""

import os
import signal
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from asyncutil import wait_until
from budget import budget

import vibtrans.maps.adaptive as adaptive
from vibtrans.core.errors import InputError, StoreMismatch
from vibtrans.maps.adaptive import run_adaptive
from vibtrans.maps.sweep import Sweep, open_map, parse_range, run_sweep

FAST = dict(periods=250.0, fidelity="preview")

# (log10 A*, log10 m*) windows, 33 x 33 finest points, K = 3:
WINDOWS = {
    # heavy particles: permanent contact below log10 A* ~ -0.3, jumping above
    "jumping-boundary": ("-0.6:0.2:0.025", "0:0.8:0.025"),
    # the fundamental contact resonance m_c* = 0.037 (log10 -1.43), where
    # jumping starts at the lowest amplitudes and drift changes sign
    "resonance": ("-1.6:-0.8:0.025", "-1.8:-1.0:0.025"),
}
STORED = [v for v in Sweep([0.0], [0.0], **FAST).variables if v != "seconds"]


def window_sweep(name, **over):
    la, lm = WINDOWS[name]
    return Sweep(parse_range(la, "log_amplitude"), parse_range(lm, "log_mass"), **{**FAST, **over})


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """Each window's adaptive map (K = 3) and its uniform sweep."""
    out = {}
    for name in WINDOWS:
        folder = tmp_path_factory.mktemp(name)
        sweep = window_sweep(name)
        run_sweep(sweep, str(folder / "uniform.zarr"), progress=False)
        fraction = run_adaptive(sweep, str(folder / "adaptive.zarr"), 3, progress=False)
        out[name] = (
            open_map(str(folder / "adaptive.zarr")),
            open_map(str(folder / "uniform.zarr")),
            fraction,
        )
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", list(WINDOWS))
def test_adaptive_map_equals_uniform_sweep(maps, name):
    ad, un, fraction = maps[name]
    computed = ad["computed"].values
    assert computed.dtype == bool
    # every computed point is the uniform sweep's, bit for bit
    for v in STORED:
        assert np.array_equal(ad[v].values[computed], un[v].values[computed], equal_nan=True), v
    # filled points are marked as not simulated
    assert (ad["steps"].values[~computed] == -1).all()
    assert np.isnan(ad["seconds"].values[~computed]).all()
    steady = un["chaotic"].values == 0
    same = ad["drift"].values == un["drift"].values
    assert same[computed & steady].all()
    filled = ~computed & steady
    agreement = same[filled].mean()
    print(
        f"{name}: computed fraction {fraction:.3f} ({computed.sum()} of {computed.size}), "
        f"drift class agreement at {filled.sum()} filled non-chaotic points {agreement:.4f}"
    )
    assert filled.sum() > computed.size // 4  # a real test of the filling
    assert agreement >= 0.98
    assert fraction == pytest.approx(computed.mean()) and fraction < 0.5
    assert ad.attrs["computed_fraction"] == pytest.approx(fraction)
    assert ad.attrs["adaptive_max_level"] == 3
    # the map changes inside the window: the refinement had work to do
    assert np.unique(un["drift"].values).size > 1 and np.unique(un["contact"].values).size > 1


@pytest.mark.slow
def test_filled_values_come_from_their_cell(maps):
    # A filled point's continuous values lie between its cell's corners
    # (bilinear), so within the range of the computed points.
    ad, _, _ = maps["jumping-boundary"]
    comp = ad["computed"].values
    v = ad["drift_velocity"].values
    assert np.isfinite(v).all()
    assert v[~comp].min() >= v[comp].min() and v[~comp].max() <= v[comp].max()
    assert set(np.unique(ad["drift"].values[~comp])) <= set(np.unique(ad["drift"].values[comp]))


SMALL = ("-0.6:0.2:0.1", "0:0.8:0.1")  # 9 x 9 finest points


def small_sweep(**over):
    return Sweep(
        parse_range(SMALL[0], "log_amplitude"), parse_range(SMALL[1], "log_mass"), **{**FAST, **over}
    )


def test_store_opens_with_xarray_and_open_map(tmp_path):
    path = str(tmp_path / "a.zarr")
    run_adaptive(small_sweep(), path, 2, progress=False)
    raw = xr.open_zarr(path, consolidated=False)
    assert raw["computed"].dtype == bool and raw["computed"].shape == (9, 9)
    for v in ("drift", "drift_velocity", "chaotic", "contact", "pattern"):
        assert raw[v].shape == (9, 9)
    ds = open_map(path)
    assert ds["done"].values.all() and ds["computed"].values[::4, ::4].all()
    assert not os.path.exists(path + ".partial")


@pytest.mark.parametrize(
    "level, match",
    [(0, "max_level"), (9, "max_level"), (2.0, "max_level"), (True, "max_level"), (4, "log_amplitude")],
)
def test_bad_levels_are_refused(tmp_path, level, match):
    with pytest.raises(InputError, match=match):
        run_adaptive(small_sweep(), str(tmp_path / "a.zarr"), level, progress=False)
    assert not os.listdir(tmp_path)  # refused before any file


def test_grid_sizes_must_fit_the_level(tmp_path):
    sweep = Sweep(parse_range("0:0.8:0.1", "a"), parse_range("0:0.9:0.1", "m"), **FAST)
    with pytest.raises(InputError, match=r"log_mass has 10 points.*multiple of 2\^2 = 4"):
        run_adaptive(sweep, str(tmp_path / "a.zarr"), 2, progress=False)


@pytest.mark.parametrize("tol", [0, -1, float("nan"), 1e3, "x"])
def test_bad_tolerance_is_refused(tmp_path, tol):
    with pytest.raises(InputError, match="drift_tolerance"):
        run_adaptive(small_sweep(), str(tmp_path / "a.zarr"), 2, tol, progress=False)


def test_lyapunov_kind_is_refused(tmp_path):
    sweep = Sweep(
        parse_range(SMALL[0], "a"), parse_range(SMALL[1], "m"), kind="lyapunov", model="vertical", **FAST
    )
    with pytest.raises(InputError, match="transport"):
        run_adaptive(sweep, str(tmp_path / "a.zarr"), 2, progress=False)


class Killed(Exception):
    pass


REAL_COMPUTE_POINT = adaptive.compute_point


def counting(monkeypatch, kill_after=None):
    """Count compute_point calls; raise Killed after kill_after of them."""
    calls = []
    real = REAL_COMPUTE_POINT

    def compute(*args, **kw):
        if kill_after is not None and len(calls) >= kill_after:
            raise Killed
        calls.append(args[1:3])
        return real(*args, **kw)

    monkeypatch.setattr(adaptive, "compute_point", compute)
    monkeypatch.setattr(adaptive, "BATCH_POINTS", 8)
    return calls


def test_killed_run_resumes_without_recomputing(tmp_path, monkeypatch):
    full = str(tmp_path / "full.zarr")
    calls = counting(monkeypatch)
    run_adaptive(small_sweep(), full, 2, workers=1, progress=False)
    total = len(calls)
    assert total == open_map(full)["computed"].values.sum()
    part = str(tmp_path / "part.zarr")
    counting(monkeypatch, kill_after=total // 2)
    with pytest.raises(Killed):
        run_adaptive(small_sweep(), part, 2, workers=1, progress=False)
    assert not os.path.exists(part)
    batches = [f for f in os.listdir(part + ".partial") if f.startswith("batch-")]
    assert batches
    saved = sum(np.load(os.path.join(part + ".partial", f))["i"].size for f in batches)
    assert 0 < saved <= total // 2
    calls = counting(monkeypatch)
    run_adaptive(small_sweep(), part, 2, workers=1, progress=False)
    assert len(calls) == total - saved  # only the missing points
    a, b = open_map(full), open_map(part)
    for v in [*STORED, "computed"]:
        assert np.array_equal(a[v].values, b[v].values, equal_nan=True), v
    calls = counting(monkeypatch)  # finished: nothing to do
    run_adaptive(small_sweep(), part, 2, workers=1, progress=False)
    assert not calls


def _partial_with_batches(tmp_path, monkeypatch):
    part = str(tmp_path / "part.zarr")
    counting(monkeypatch, kill_after=20)
    with pytest.raises(Killed):
        run_adaptive(small_sweep(), part, 2, workers=1, progress=False)
    return part, sorted(f for f in os.listdir(part + ".partial") if f.startswith("batch-"))


@pytest.mark.parametrize("damage", ["truncate", "flip", "empty"])
def test_damaged_batch_is_refused(tmp_path, monkeypatch, damage):
    part, batches = _partial_with_batches(tmp_path, monkeypatch)
    target = os.path.join(part + ".partial", batches[0])
    data = open(target, "rb").read()
    with open(target, "wb") as f:
        if damage == "truncate":
            f.write(data[: len(data) // 2])
        elif damage == "flip":  # a byte inside the stored arrays
            k = data.index(b"drift_velocity.npy") + 200
            f.write(data[:k] + bytes([data[k] ^ 0xFF]) + data[k + 1 :])
    counting(monkeypatch)
    with pytest.raises(StoreMismatch, match=batches[0]):
        run_adaptive(small_sweep(), part, 2, workers=1, progress=False)
    assert not os.path.exists(part)


def test_mismatched_parameters_are_refused(tmp_path, monkeypatch):
    part, _ = _partial_with_batches(tmp_path, monkeypatch)
    counting(monkeypatch)
    with pytest.raises(StoreMismatch, match="scene"):
        run_adaptive(small_sweep(mu=0.1), part, 2, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="drift_tolerance"):
        run_adaptive(small_sweep(), part, 2, 0.3, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="max_level"):
        run_adaptive(small_sweep(), part, 1, workers=1, progress=False)
    # and a finished store
    done = str(tmp_path / "done.zarr")
    run_adaptive(small_sweep(), done, 2, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="mu"):
        run_adaptive(small_sweep(mu=0.1), done, 2, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="adaptive"):
        run_adaptive(small_sweep(), done, 1, workers=1, progress=False)
    uniform = str(tmp_path / "uniform.zarr")  # a uniform sweep is not an adaptive map
    run_sweep(small_sweep(), uniform, workers=1, progress=False)
    with pytest.raises(StoreMismatch, match="adaptive"):
        run_adaptive(small_sweep(), uniform, 2, workers=1, progress=False)


@pytest.mark.parametrize("variable", ["computed", "drift"])
def test_damaged_final_store_is_refused(tmp_path, variable):
    path = str(tmp_path / "a.zarr")
    run_adaptive(small_sweep(), path, 2, workers=1, progress=False)
    ds = xr.open_zarr(path, consolidated=False, chunks=None).load()
    edited = ds[variable].values.copy()
    edited[1, 1] = ~edited[1, 1] if edited.dtype == bool else edited[1, 1] + 1
    # an edit that keeps the store readable: only the digest can tell
    xr.Dataset({variable: (("log_amplitude", "log_mass"), edited)}).to_zarr(
        path, region={"log_amplitude": slice(None), "log_mass": slice(None)}, consolidated=False
    )
    with pytest.raises(StoreMismatch, match="digest"):
        open_map(path)
    with pytest.raises(StoreMismatch, match="digest"):
        run_adaptive(small_sweep(), path, 2, workers=1, progress=False)


def _cli(out, *extra):
    return [
        sys.executable,
        "-m",
        "vibtrans.cli",
        "sweep",
        f"--log-amplitude={SMALL[0]}",
        f"--log-mass={SMALL[1]}",
        "--periods",
        "250",
        "--fidelity",
        "preview",
        "--workers",
        "1",
        "--out",
        out,
        *extra,
    ]


def test_cli_adaptive(tmp_path):
    out = str(tmp_path / "a.zarr")
    r = subprocess.run(
        _cli(out, "--adaptive", "--max-level", "2"), capture_output=True, text=True, timeout=budget(300)
    )
    assert r.returncode == 0, r.stderr
    lines = r.stdout.split("\n")
    assert lines[0] == out
    fraction = float(lines[1].split()[-1])
    assert fraction == pytest.approx(open_map(out)["computed"].values.mean(), abs=1e-4)


@pytest.mark.parametrize(
    "extra, match",
    [
        (("--max-level", "2"), "--adaptive"),
        (("--adaptive",), "--max-level"),
        (("--adaptive", "--max-level", "4"), "log_amplitude has 9 points"),
        (("--adaptive", "--max-level", "2", "--drift-tolerance", "0"), "drift_tolerance"),
        (("--adaptive", "--max-level", "2", "--kind", "lyapunov", "--model", "vertical"), "transport"),
    ],
)
def test_cli_refusals(tmp_path, extra, match):
    out = str(tmp_path / "a.zarr")
    r = subprocess.run(_cli(out, *extra), capture_output=True, text=True, timeout=budget(120))
    assert r.returncode == 2 and match in r.stderr, r.stderr
    assert not os.path.exists(out) and not os.path.exists(out + ".partial")


@pytest.mark.slow
def test_sigkilled_cli_resumes_bit_identical(tmp_path):
    # A real process killed (SIGKILL) after its first batch, then run again
    # with the same command, ends equal to an uninterrupted run (but for the
    # wall times) and keeps the points the killed run saved.
    window = [
        "--log-amplitude=-0.6:0.2:0.05",
        "--log-mass=0:0.8:0.05",
        "--periods",
        "3000",
        "--fidelity",
        "preview",
        "--workers",
        "1",
        "--adaptive",
        "--max-level",
        "2",
    ]
    cmd = [sys.executable, "-m", "vibtrans.cli", "sweep", *window, "--out"]
    full, part = str(tmp_path / "full.zarr"), str(tmp_path / "part.zarr")
    subprocess.run([*cmd, full], check=True, capture_output=True, timeout=budget(600))
    proc = subprocess.Popen(
        [*cmd, part], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    # the first level's points saved (or the process ended: then nothing is tested)
    wait_until(
        lambda: (
            proc.poll() is not None
            or (
                os.path.isdir(part + ".partial")
                and any(f.endswith(".npz") for f in os.listdir(part + ".partial"))
            )
        ),
        budget(300),
        "the first saved points",
    )
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not os.path.exists(part), "finished before the kill: nothing tested"
    saved = {}
    for f in os.listdir(part + ".partial"):
        if f.endswith(".npz"):
            with np.load(os.path.join(part + ".partial", f)) as z:
                saved.update({(int(i), int(j)): s for i, j, s in zip(z["i"], z["j"], z["seconds"])})
    assert saved
    subprocess.run([*cmd, part], check=True, capture_output=True, timeout=budget(600))
    a, b = open_map(full), open_map(part)
    for v in [*STORED, "computed"]:
        assert np.array_equal(a[v].values, b[v].values, equal_nan=True), v
    # the saved points were not recomputed: their wall times are the killed run's
    assert all(b["seconds"].values[p] == s for p, s in saved.items())
    assert not os.path.exists(part + ".partial")


def test_each_level_gives_a_complete_picture_ending_in_the_map(tmp_path):
    """on_level: after the coarse grid and after each refinement, the map so
    far on the finest grid (filled from its cells); the last one is the
    store's map, and the computed points only grow."""
    path = str(tmp_path / "a.zarr")
    seen = []
    run_adaptive(small_sweep(), path, 2, progress=False, on_level=lambda level, ds: seen.append((level, ds)))
    assert [level for level, _ in seen] == [0, 1, 2]
    coarse = seen[0][1]["computed"].values
    assert coarse.sum() == 9 and coarse[::4, ::4].all()  # 3 x 3 coarse points
    for (_, before), (_, after) in zip(seen, seen[1:]):
        assert (after["computed"].values >= before["computed"].values).all()
    final = open_map(path)
    for v in [*STORED, "computed"]:
        assert np.array_equal(seen[-1][1][v].values, final[v].values, equal_nan=True), v
    for _, ds in seen:  # no hole a plot would show as NaN
        assert np.isfinite(ds["drift_velocity"].values).all()


def test_pictures_within_a_level_grow_and_leave_the_map_bit_identical(tmp_path, monkeypatch):
    """on_chunk: a picture each time a task's points of a refinement level
    come in (chunk_seconds 0), finer than a level: the computed points only grow, each picture is
    complete (no NaN) and keeps every point computed as computed; the map
    is bit-identical to one computed without the pictures."""
    monkeypatch.setattr(adaptive, "POINTS_PER_TASK", 2)
    plain, pictured = str(tmp_path / "plain.zarr"), str(tmp_path / "pictured.zarr")
    levels, chunks = [], []
    run_adaptive(
        small_sweep(),
        plain,
        2,
        progress=False,
        workers=1,
        on_level=lambda level, ds: levels.append(int(ds["computed"].values.sum())),
    )
    run_adaptive(
        small_sweep(),
        pictured,
        2,
        progress=False,
        workers=1,
        on_chunk=lambda level, ds: chunks.append((level, ds)),
        chunk_seconds=0.0,
    )
    a, b = open_map(plain), open_map(pictured)
    for v in [*STORED, "computed"]:
        if v != "seconds":
            assert np.array_equal(a[v].values, b[v].values, equal_nan=True), v
    counts = [int(ds["computed"].values.sum()) for _, ds in chunks]
    assert counts == sorted(counts) and len(set(counts)) == len(counts)
    # more pictures than levels: within each level, several
    assert len(chunks) > len(levels) and {level for level, _ in chunks} == {1, 2}
    final = b["computed"].values
    for _, ds in chunks:
        done = ds["computed"].values
        assert np.isfinite(ds["drift_velocity"].values).all()
        assert not (done & ~final).any()
        assert np.array_equal(ds["drift_velocity"].values[done], b["drift_velocity"].values[done])


def test_a_cancelled_map_stops_and_resumes(tmp_path, monkeypatch):
    """cancel: no new point starts once set; Cancelled is raised, the store
    is not written, and the same call later computes only what is missing."""
    import threading

    from vibtrans.core.errors import Cancelled

    path = str(tmp_path / "a.zarr")
    cancel = threading.Event()
    calls = counting(monkeypatch)
    with pytest.raises(Cancelled):
        run_adaptive(
            small_sweep(),
            path,
            2,
            workers=1,
            progress=False,
            cancel=cancel,
            on_level=lambda level, ds: cancel.set(),
        )
    assert not os.path.exists(path) and len(calls) == 9  # the coarse grid only
    calls = counting(monkeypatch)
    run_adaptive(small_sweep(), path, 2, workers=1, progress=False)
    assert 0 < len(calls) == open_map(path)["computed"].values.sum() - 9
