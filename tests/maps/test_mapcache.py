"""The shared map cache (vibtrans/maps/cache.py): keyed by
the request and the code version, computed once however many ask, verified
on every open (a damaged entry is recomputed, never shown), least recently
used entries evicted beyond the size cap.  Tiny sweeps (6 points, short
runs): the numbers are the sweep's own, compared with a direct run."""

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from asyncutil import wait_until
from budget import budget

from vibtrans.core.errors import InputError
from vibtrans.maps import cache as mapcache
from vibtrans.maps.cache import TEMPORARY, MapCache, request_key
from vibtrans.maps.sweep import Sweep, open_map, parse_range, run_sweep

REQUEST = {
    "model": "deformable",
    "mu": 0.3,
    "periods": 60.0,
    "tau": 10.0,
    "log_amplitude": "0:1:0.5",
    "log_mass": "-1:0:1",
}


def _sweep(request):
    values = {k: v for k, v in request.items() if k not in ("log_amplitude", "log_mass")}
    return Sweep(
        parse_range(request["log_amplitude"], "log_amplitude"),
        parse_range(request["log_mass"], "log_mass"),
        chunk_rows=2,
        **values,
    )


def _builder(request, calls):
    def build(path):
        calls.append(path)
        run_sweep(_sweep(request), path, workers=1, progress=False)

    return build


def _now(fn):  # run the job at once, in this thread
    fn()


def test_the_key_is_the_request_and_the_code_version(monkeypatch):
    key = request_key(REQUEST)
    assert key == request_key(dict(reversed(list(REQUEST.items()))))  # order-free
    assert key != request_key({**REQUEST, "mu": 0.31})
    assert key != request_key({**REQUEST, "log_mass": "-1:0:0.5"})
    monkeypatch.setattr(mapcache, "__version__", "9.9.9")
    assert key != request_key(REQUEST)
    with pytest.raises(InputError, match="numbers, strings"):
        request_key({**REQUEST, "mu": float("nan")})


def test_a_map_is_computed_once_and_then_read(tmp_path):
    cache, calls = MapCache(tmp_path / "cache"), []
    key = request_key(REQUEST)
    first = cache.compute(key, _builder(REQUEST, calls), _now).result()
    again = cache.compute(key, _builder(REQUEST, calls), _now).result()
    assert len(calls) == 1 and cache.entries() == [key]
    run_sweep(_sweep(REQUEST), str(tmp_path / "direct.zarr"), workers=1, progress=False)
    direct = open_map(str(tmp_path / "direct.zarr"))
    for ds in (first, again):
        for name in ("drift_velocity", "drift", "chaotic", "contact"):
            assert np.array_equal(ds[name].values, direct[name].values, equal_nan=True)
    # nothing but the entry is left in the folder
    assert sorted(os.listdir(tmp_path / "cache")) == [key + ".zarr"]


def test_two_sessions_asking_at_once_share_one_computation(tmp_path):
    cache, calls = MapCache(tmp_path), []
    key, release = request_key(REQUEST), threading.Event()
    build = _builder(REQUEST, calls)

    def slow_build(path):
        release.wait(30)
        build(path)

    with ThreadPoolExecutor(2) as pool:
        one = cache.compute(key, slow_build, pool.submit)
        two = cache.compute(key, slow_build, pool.submit)
        assert one is two and not one.done()
        release.set()
        ds = two.result(timeout=budget(120))
    assert len(calls) == 1 and ds["done"].values.all()


def test_a_failed_computation_leaves_nothing_and_is_tried_again(tmp_path):
    cache = MapCache(tmp_path)
    key = request_key(REQUEST)

    def broken(path):
        os.makedirs(path)
        raise RuntimeError("the worker died")

    with pytest.raises(RuntimeError, match="worker died"):
        cache.compute(key, broken, _now).result()
    assert os.listdir(tmp_path) == []
    calls = []
    assert cache.compute(key, _builder(REQUEST, calls), _now).result()["done"].values.all()
    assert len(calls) == 1


@pytest.mark.parametrize("damage", ["chunk", "unfinished"])
def test_a_damaged_or_unfinished_entry_is_recomputed_not_shown(tmp_path, damage):
    cache, calls = MapCache(tmp_path), []
    key = request_key(REQUEST)
    if damage == "chunk":
        cache.compute(key, _builder(REQUEST, calls), _now).result()
        root = tmp_path / (key + ".zarr") / "drift_velocity"
        chunk = sorted(p for p in root.rglob("*") if p.is_file() and not p.name.startswith(("zarr", ".")))[
            0
        ]  # a chunk of data, not metadata
        chunk.write_bytes(chunk.read_bytes()[:-3] + b"\xff\xfe\xfd")
    else:  # a store left half-written under the entry's name
        sweep = _sweep(REQUEST)
        sweep.empty_dataset().to_zarr(str(tmp_path / (key + ".zarr")), mode="w", consolidated=False)
    assert cache.get(key) is None and cache.entries() == []
    before = len(calls)
    ds = cache.compute(key, _builder(REQUEST, calls), _now).result()
    assert len(calls) == before + 1 and ds["done"].values.all()


def _clock_past(path, probe):
    """Wait until the file system's clock has moved past `path`'s time
    stamp: a file touched from now on is stamped later (`probe`: a file to
    touch, no entry)."""

    def later():
        probe.touch()
        return probe.stat().st_mtime_ns > os.stat(path).st_mtime_ns

    wait_until(later, budget(10), "the file system's clock to move on")


def test_least_recently_used_entries_go_beyond_the_cap(tmp_path):
    requests = [{**REQUEST, "mu": mu} for mu in (0.2, 0.3, 0.4)]
    keys = [request_key(r) for r in requests]
    big = MapCache(tmp_path)
    for request, key in zip(requests, keys):
        big.compute(key, _builder(request, []), _now).result()
        _clock_past(big.path(key), tmp_path / "clock")  # distinct time stamps
    size = mapcache._folder_bytes(big.path(keys[0]))
    big.get(keys[0])  # the oldest becomes the most recently used
    assert big.entries() == [keys[1], keys[2], keys[0]]
    small = MapCache(tmp_path, max_bytes=int(2.5 * size))
    assert small.evict() == [keys[1]]
    assert small.entries() == [keys[2], keys[0]]


def test_stale_temporaries_are_removed_young_ones_kept(tmp_path):
    old = tmp_path / f"abc{TEMPORARY}1"
    young = tmp_path / f"abd{TEMPORARY}2"
    old.mkdir()
    young.mkdir()
    past = time.time() - mapcache.STALE_SECONDS - 10
    os.utime(old, (past, past))
    MapCache(tmp_path)
    assert not old.exists() and young.exists()


@pytest.mark.parametrize("max_bytes", [0, -5, 1.5, True, "1G"])
def test_bad_cap_is_refused(tmp_path, max_bytes):
    with pytest.raises(InputError, match="max_bytes must be a positive integer"):
        MapCache(tmp_path, max_bytes=max_bytes)


def test_an_unusable_folder_is_a_message(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(InputError, match="cannot be made"):
        MapCache(blocker / "cache")
