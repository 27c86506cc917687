"""Corrupted, truncated and foreign stores where the app and the command
line read them: the assets folder of the explorer (app/server/data.py, from
$VIBTRANS_ASSETS) and stores given on the command line (`vibtrans export
--maps`, `vibtrans sweep --out`, `vibtrans serve`).

Every one is refused with one clear message naming the file and the
problem, never read as data, never a traceback.  tests/maps/test_sweep.py covers
open_map/run_sweep on a damaged chunk, a deleted root metadata file and a
foreign store at the API level; here are the other kinds of damage, the
vertical curve, and the app's and the CLI's messages.
"""

import glob
import json
import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from assetsfolder import forget_maps
from budget import budget

from vibtrans.cli import main
from vibtrans.maps.sweep import StoreMismatch, open_map, open_vertical
from vibtrans_explorer.server import data

# ~2 min: every damage through the app and the CLI (make test-fast leaves it out)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "assets" / "maps"
VICTIM = ("deformable", 0.1)  # the map the tests damage (the smallest)
VICTIM_NAME = "deformable-mu0.1.zarr"


def _trunc(path, keep=0.5):
    b = open(path, "rb").read()
    open(path, "wb").write(b[: int(len(b) * keep)])


def _flip(path, at=-9):
    b = bytearray(open(path, "rb").read())
    b[at] ^= 0xFF
    open(path, "wb").write(bytes(b))


def _edit_json(path, change):
    meta = json.load(open(path))
    change(meta)
    json.dump(meta, open(path, "w"))


def _one(pattern):
    return sorted(glob.glob(pattern))[0]


def _pickle_store(d):
    """A Zarr v2 store whose data needs the pickle codec: reading it would
    run code (here: create a marker file).  Zarr 3 refuses the codec."""
    shutil.rmtree(d)
    os.makedirs(f"{d}/drift_velocity")
    json.dump({"zarr_format": 2}, open(f"{d}/.zgroup", "w"))
    json.dump({"chunk_rows": 1}, open(f"{d}/.zattrs", "w"))
    json.dump(
        {
            "zarr_format": 2,
            "shape": [1],
            "chunks": [1],
            "dtype": "|O",
            "compressor": None,
            "filters": [{"id": "pickle", "protocol": 4}],
            "fill_value": None,
            "order": "C",
        },
        open(f"{d}/drift_velocity/.zarray", "w"),
    )
    json.dump({"_ARRAY_DIMENSIONS": ["log_amplitude"]}, open(f"{d}/drift_velocity/.zattrs", "w"))
    open(f"{d}/drift_velocity/0", "wb").write(pickle.dumps(np.array([_Marker(f"{d}.PWNED")], dtype=object)))


class _Marker:
    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return (open, (self.path, "w"))


# damage -> what it does to the store (in place)
DAMAGE = {
    "chunk truncated": lambda d: _trunc(f"{d}/drift_velocity/c/3/0"),
    "chunk emptied": lambda d: open(f"{d}/drift_velocity/c/3/0", "wb").close(),
    "chunk byte flipped": lambda d: _flip(f"{d}/drift_velocity/c/3/0"),
    "chunk deleted": lambda d: os.remove(f"{d}/drift_velocity/c/3/0"),
    "root metadata garbage": lambda d: open(f"{d}/zarr.json", "w").write("{not json"),
    "root metadata truncated": lambda d: _trunc(f"{d}/zarr.json"),
    "variable metadata deleted": lambda d: os.remove(f"{d}/drift_velocity/zarr.json"),
    "variable metadata garbage": lambda d: open(f"{d}/pattern/zarr.json", "w").write("[]"),
    "variable shape edited": lambda d: _edit_json(
        f"{d}/drift_velocity/zarr.json", lambda m: m.update(shape=[10, 10])
    ),
    "variable dtype edited": lambda d: _edit_json(
        f"{d}/drift_velocity/zarr.json", lambda m: m.update(data_type="int8")
    ),
    "variable removed": lambda d: shutil.rmtree(f"{d}/pattern"),
    "done flags garbage": lambda d: open(_one(f"{d}/done/c/*"), "wb").write(b"garbage"),
    "digests truncated": lambda d: _trunc(_one(f"{d}/digest/c/*")),
    "coordinate garbage": lambda d: open(_one(f"{d}/log_amplitude/c/*"), "wb").write(b"xx"),
    "chunk_rows attribute text": lambda d: _edit_json(
        f"{d}/zarr.json", lambda m: m["attributes"].update(chunk_rows="abc")
    ),
    "chunk_rows attribute changed": lambda d: _edit_json(
        f"{d}/zarr.json", lambda m: m["attributes"].update(chunk_rows=3)
    ),
    "empty folder": lambda d: (shutil.rmtree(d), os.mkdir(d)),
    "a plain file": lambda d: (shutil.rmtree(d), open(d, "w").write("not a store")),
    "foreign Zarr store": lambda d: (
        shutil.rmtree(d),
        xr.Dataset({"a": ("x", np.arange(3.0))}).to_zarr(d, consolidated=False),
    ),
    "another map under this name": lambda d: (
        shutil.rmtree(d),
        shutil.copytree(SHIPPED / "deformable-mu0.3.zarr", d),
    ),
    "pickle codec": _pickle_store,
}


@pytest.fixture
def assets(tmp_path, assets_folder):
    """A copy of the shipped maps (the default one, the victim and the
    vertical curve) as the app's assets folder, as $VIBTRANS_ASSETS sets it."""
    maps = tmp_path / "assets" / "maps"
    maps.mkdir(parents=True)
    for name in ("deformable-mu0.3.zarr", VICTIM_NAME):
        shutil.copytree(SHIPPED / name, maps / name)
    shutil.copy(SHIPPED / "vertical.nc", maps / "vertical.nc")
    assets_folder(maps.parent)
    return maps


def _cli(capsys, argv):
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def _one_line(err):
    lines = [ln for ln in err.splitlines() if ln.strip() and "%|" not in ln]  # no tqdm
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------------------------ the app's loader
def test_intact_copies_have_no_problems(assets):
    assert data.problems() == []
    assert data.drift_map(*VICTIM)["done"].values.all()
    assert data.vertical_curve() is not None


@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_app_refuses_a_damaged_map_with_a_message(assets, damage):
    path = assets / VICTIM_NAME
    DAMAGE[damage](str(path))
    with pytest.raises(data.MapUnavailable) as info:
        data.drift_map(*VICTIM)
    msg = str(info.value)
    assert str(path) in msg and "cannot be used" in msg, msg
    assert "\n" not in msg and len(msg) < 600, msg
    assert isinstance(info.value, KeyError)  # as "not shipped" was
    problems = data.problems()
    assert len(problems) == 1 and str(path) in problems[0], problems
    # the other maps are still served
    assert data.drift_map("deformable", 0.3).sizes["log_amplitude"] > 0
    assert not os.path.exists(f"{path}.PWNED")  # nothing in the store was run


def test_messages_name_the_problem(assets):
    path = assets / VICTIM_NAME
    expected = {
        "chunk truncated": "chunk 3 cannot be read",
        "chunk byte flipped": "does not match its digest",
        "variable removed": "missing: pattern",
        "done flags garbage": "done flags or digests cannot be read",
        "chunk_rows attribute changed": "do not fit its grid",
        "foreign Zarr store": "not a vibtrans sweep store",
        "another map under this name": "was made for model=deformable, mu=0.3",
        "a plain file": "not a readable Zarr store",
    }
    for damage, words in expected.items():
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
        shutil.copytree(SHIPPED / VICTIM_NAME, path)
        DAMAGE[damage](str(path))
        forget_maps()
        with pytest.raises(data.MapUnavailable, match=words):
            data.drift_map(*VICTIM)


def test_a_damaged_map_is_read_once(assets, monkeypatch):
    # the failure is cached like a map: a redraw does not re-read the store
    DAMAGE["chunk byte flipped"](str(assets / VICTIM_NAME))
    calls = []
    real = data.open_map
    monkeypatch.setattr(data, "open_map", lambda *a, **k: calls.append(a) or real(*a, **k))
    for _ in range(3):
        with pytest.raises(data.MapUnavailable):
            data.drift_map(*VICTIM)
    assert len(calls) == 1


VERTICAL_DAMAGE = {
    "truncated": lambda p: _trunc(p, 0.3),
    "emptied": lambda p: open(p, "wb").close(),
    "garbage": lambda p: open(p, "wb").write(b"\x89HDF\r\n\x1a\n" + b"\x00" * 64),
    "foreign netCDF": lambda p: xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(p),
    "decreasing grid": lambda p: _rewrite_vertical(
        p, lambda ds: ds.assign_coords(log_mass=ds["log_mass"].values[::-1].copy())
    ),
    "negative threshold": lambda p: _rewrite_vertical(
        p, lambda ds: ds.assign(threshold_amplitude=-ds["threshold_amplitude"])
    ),
    "a folder": lambda p: (os.remove(p), os.mkdir(p)),
}


def _rewrite_vertical(path, change):
    ds = xr.load_dataset(path)
    os.remove(path)
    change(ds).to_netcdf(path)


@pytest.mark.parametrize("damage", sorted(VERTICAL_DAMAGE))
def test_app_and_cli_refuse_a_damaged_vertical_curve(assets, damage, capsys, tmp_path):
    path = assets / "vertical.nc"
    VERTICAL_DAMAGE[damage](str(path))
    with pytest.raises((StoreMismatch, OSError)) as info:
        open_vertical(str(path))
    assert str(path) in str(info.value)
    # the app: no curve (the map is drawn without it), and a message
    assert data.vertical_curve() is None
    problems = data.problems()
    assert len(problems) == 1 and str(path) in problems[0], problems
    assert data.drift_map("deformable", 0.3) is not None
    # the command line: exit 2, one line naming the file
    code, out, err = _cli(
        capsys, ["export", "vertical", "--maps", str(assets), "--out", str(tmp_path / "v.png")]
    )
    assert code == 2, err
    assert str(path) in _one_line(err)
    assert not (tmp_path / "v.png").exists()


def test_missing_or_empty_assets_folder(tmp_path, assets_folder):
    assets_folder(tmp_path / "nowhere")
    problems = data.problems()
    assert len(problems) == 1 and "no drift maps in" in problems[0], problems
    assert str(tmp_path / "nowhere") in problems[0]
    with pytest.raises(data.MapUnavailable, match="no drift map for model=deformable"):
        data.drift_map("deformable", 0.3)
    assert data.vertical_curve() is None
    # only a non-default map: the default one is reported missing
    maps = tmp_path / "only" / "maps"
    maps.mkdir(parents=True)
    shutil.copytree(SHIPPED / VICTIM_NAME, maps / VICTIM_NAME)
    assets_folder(maps.parent)
    assert data.problems() == [
        f"no drift map for model=deformable, mu=0.3 (the explorer's default) in {maps}"
    ]


# ------------------------------------------------------------------ the command line
@pytest.mark.parametrize(
    "damage",
    [
        "chunk truncated",
        "chunk byte flipped",
        "foreign Zarr store",
        "another map under this name",
        "a plain file",
    ],
)
def test_export_heatmap_refuses_a_damaged_map(assets, damage, capsys, tmp_path):
    path = assets / VICTIM_NAME
    DAMAGE[damage](str(path))
    out = tmp_path / "map.png"
    code, _, err = _cli(
        capsys, ["export", "heatmap", "--maps", str(assets), "--mu", "0.1", "--out", str(out)]
    )
    assert code == 2, err
    line = _one_line(err)
    assert line.startswith("vibtrans export: error:") and str(path) in line, line
    assert not out.exists()


def test_serve_refuses_to_start_on_a_damaged_map(assets, capsys):
    # in-process: the check comes before the JIT warm-up and the server
    DAMAGE["chunk byte flipped"](str(assets / VICTIM_NAME))
    code, _, err = _cli(capsys, ["serve", "--port", "5999"])
    assert code == 2
    line = _one_line(err)
    assert str(assets / VICTIM_NAME) in line and "does not match its digest" in line, line


def test_serve_refuses_a_bad_assets_folder_from_the_environment(tmp_path):
    # a real process, the folder given by $VIBTRANS_ASSETS as in the container
    env = dict(os.environ, VIBTRANS_ASSETS=str(tmp_path / "missing"))
    r = subprocess.run(
        [sys.executable, "-m", "vibtrans.cli", "serve", "--port", "5999"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=budget(120),
    )
    assert r.returncode == 2, r.stderr
    line = _one_line(r.stderr)
    assert f"no drift maps in {tmp_path / 'missing' / 'maps'}" in line, line


@pytest.mark.parametrize("damage", ["chunk byte flipped", "done flags garbage", "chunk_rows attribute text"])
def test_sweep_refuses_to_resume_a_damaged_store(tmp_path, capsys, damage):
    out = str(tmp_path / "s.zarr")
    argv = [
        "sweep",
        "--log-amplitude",
        "0:0.5:0.5",
        "--log-mass=-1:0:1",
        "--periods",
        "20",
        "--tau",
        "5",
        "--chunk-rows",
        "1",
        "--workers",
        "1",
        "--out",
        out,
    ]
    code, _, err = _cli(capsys, argv)
    assert code == 0, err
    assert open_map(out)["done"].values.all()
    if damage == "chunk byte flipped":
        _flip(_one(f"{out}/drift_velocity/c/1/*"))
    else:
        DAMAGE[damage](out)
    code, _, err = _cli(capsys, argv)
    assert code == 2, err
    line = _one_line(err)
    assert line.startswith("vibtrans sweep: error:") and out in line, line


def test_explorer_says_so_at_session_start(assets):
    # The explorer itself: a damaged shipped map is named in the session's
    # message at start, and the session still builds and takes its state.
    from vibtrans_explorer import explorer as E

    path = assets / VICTIM_NAME
    DAMAGE[sorted(DAMAGE)[0]](str(path))
    ex = E.Explorer()
    assert ex.message.visible and str(path) in ex.message.object
    ex.state.param.update(model=VICTIM[0], mu=VICTIM[1])
    assert ex.state.model == VICTIM[0]
