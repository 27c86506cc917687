"""Verified stamps of the shipped maps (app/server/data.py): a warm server start
checks a stamp instead of reading every map, and a map changed after its
stamp was cached is still verified, and refused, before the start."""

import os
import shutil
from pathlib import Path

import pytest
from assetsfolder import forget_maps

from vibtrans.cli import main
from vibtrans_explorer.server import data

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "assets" / "maps"
VICTIM = ("deformable", 0.1)
VICTIM_NAME = "deformable-mu0.1.zarr"
CHUNK = f"{VICTIM_NAME}/drift_velocity/c/3/0"


@pytest.fixture
def assets(tmp_path, monkeypatch, assets_folder):
    """Copies of two maps and the curve as the assets folder, files dated
    an hour ago (older than data.RACY_NS), stamps in a cache folder of
    their own."""
    maps = tmp_path / "assets" / "maps"
    maps.mkdir(parents=True)
    for name in ("deformable-mu0.3.zarr", VICTIM_NAME):
        shutil.copytree(SHIPPED / name, maps / name)
    shutil.copy(SHIPPED / "vertical.nc", maps / "vertical.nc")
    _age(maps)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(data, "RACY_NS", 0)  # ctime is now (copied); mtime is what we date
    assets_folder(maps.parent)
    return maps


def _age(folder, seconds=3600):
    for dirpath, _, files in os.walk(folder):
        for f in files:
            p = os.path.join(dirpath, f)
            st = os.stat(p)
            os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns - seconds * 10**9))


def _reads(monkeypatch):
    calls = []
    real = data.open_map
    monkeypatch.setattr(data, "open_map", lambda *a, **k: calls.append(a[0]) or real(*a, **k))
    return calls


def test_a_stamped_map_is_checked_without_a_read_and_read_verified_on_use(assets, monkeypatch):
    assert data.problems() == []  # verified, stamped
    assert data._stamps_file().exists()
    forget_maps()  # a new server
    reads = _reads(monkeypatch)
    assert data.problems() == [] and reads == []  # the stamps suffice
    assert data.drift_map(*VICTIM)["done"].values.all()
    assert reads == [str(assets / VICTIM_NAME)]  # first use: read (and verified)


@pytest.mark.parametrize("keep_size_and_mtime", [False, True])
def test_a_map_modified_after_its_stamp_is_still_refused(assets, monkeypatch, capsys, keep_size_and_mtime):
    assert data.problems() == []  # stamped
    forget_maps()
    chunk = assets / CHUNK
    st = os.stat(chunk)
    b = bytearray(chunk.read_bytes())
    b[-9] ^= 0xFF
    chunk.write_bytes(bytes(b))
    if keep_size_and_mtime:  # only the ctime tells
        os.utime(chunk, ns=(st.st_atime_ns, st.st_mtime_ns))
        assert os.stat(chunk).st_size == st.st_size
    problems = data.problems()
    assert len(problems) == 1 and str(assets / VICTIM_NAME) in problems[0], problems
    assert "does not match its digest" in problems[0]
    with pytest.raises(data.MapUnavailable):
        data.drift_map(*VICTIM)
    forget_maps()
    try:  # and the server refuses to start
        code = main(["serve", "--port", "5999"])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    assert "does not match its digest" in capsys.readouterr().err


def test_a_damaged_stamps_file_means_a_full_check(assets, monkeypatch):
    assert data.problems() == []
    data._stamps_file().write_text("{not json")
    forget_maps()
    reads = _reads(monkeypatch)
    assert data.problems() == []
    assert sorted(reads) == sorted(str(assets / n) for n in ("deformable-mu0.3.zarr", VICTIM_NAME))


def test_a_freshly_changed_map_gets_no_stamp(assets, monkeypatch):
    monkeypatch.setattr(data, "RACY_NS", 10**12)  # every file counts as just changed
    assert data.problems() == []
    assert not data._stamps_file().exists()
