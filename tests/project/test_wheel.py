"""The wheel is the whole product: built from the
repository, installed with pip into a fresh virtual environment (no
access to the repository or to this environment's packages), it runs
`vibtrans simulate`, `vibtrans export heatmap` and `vibtrans serve` (maps
loaded) from an unrelated folder.  Its contents: every shipped map file,
every module, and no generic top-level name (`app`), no development
tools, no tests.

Slow: building, installing the dependencies (from pip's cache or the
package index) and compiling the kernels in the fresh environment."""

import json
import os
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest
from budget import budget
from netutil import Served

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow


def _run(cmd, cwd, env, timeout=900):
    r = subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )
    assert r.returncode == 0, f"{cmd}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


def _tracked(folder):
    out = subprocess.run(["git", "ls-files", folder], cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0:  # not a git checkout: the files on disk
        return sorted(
            str(p.relative_to(ROOT))
            for p in (ROOT / folder).rglob("*")
            if p.is_file() and "__pycache__" not in p.parts
        )
    return out.stdout.split()


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    dist = tmp_path_factory.mktemp("dist")
    _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-cache-dir", ROOT, "-w", dist],
        cwd=dist,
        env=os.environ,
    )
    (path,) = dist.glob("vibtrans-*.whl")
    return path


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory):
    """(bin folder of a fresh venv holding the wheel, environment, an unrelated folder)."""
    home = tmp_path_factory.mktemp("fresh")
    venv.EnvBuilder(with_pip=True, system_site_packages=False).create(home / "venv")
    bin_ = home / "venv" / "bin"
    env = {
        k: v
        for k, v in os.environ.items()
        if k
        not in ("VIBTRANS_ASSETS", "PYTHONPATH", "VIRTUAL_ENV", "PYTHONMALLOC", "VIBTRANS_ALLOWED_ORIGINS")
    }
    env["PATH"] = f"{bin_}{os.pathsep}{env.get('PATH', '')}"
    env["NUMBA_CACHE_DIR"] = str(home / "numba-cache")  # its own, cold, cache
    elsewhere = home / "elsewhere"
    elsewhere.mkdir()
    _run(
        [bin_ / "python", "-m", "pip", "install", "--quiet", wheel],
        cwd=elsewhere,
        env=env,
        timeout=budget(1800),
    )
    return bin_, env, elsewhere


def test_the_wheel_holds_every_map_and_module_and_nothing_else(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    tops = {n.split("/")[0] for n in names if not n.startswith("vibtrans-")}
    assert tops == {"vibtrans", "vibtrans_explorer", "vibtrans_assets"}, tops
    maps = [f for f in _tracked("assets/maps") if not f.endswith(".partial")]
    assert len(maps) > 100 and any(f.endswith("vertical.nc") for f in maps)
    missing = [f for f in maps if "vibtrans_assets/" + f[len("assets/") :] not in names]
    assert not missing, missing[:10]
    for folder, package in (("vibtrans", "vibtrans"), ("app", "vibtrans_explorer")):
        modules = [f for f in _tracked(folder) if f.endswith(".py")]
        absent = [f for f in modules if package + f[len(folder) :] not in names]
        assert not absent, absent
    assert not [n for n in names if n.startswith(("devtools/", "tests/", "app/"))]


def test_installed_wheel_simulates_exports_and_serves_from_any_folder(installed):
    bin_, env, elsewhere = installed
    # the import names: the explorer under its own name, no `app`
    _run(
        [
            bin_ / "python",
            "-c",
            "import vibtrans, vibtrans_explorer, vibtrans_assets, sys\n"
            "assert str(vibtrans.maps_dir()).startswith(sys.prefix), vibtrans.maps_dir()\n"
            "try:\n    import app\nexcept ImportError:\n    pass\n"
            "else:\n    raise SystemExit('a top-level app is importable')",
        ],
        elsewhere,
        env,
    )

    r = _run(
        [
            bin_ / "vibtrans",
            "simulate",
            "--log-amplitude",
            "2.5",
            "--log-mass",
            "0",
            "--periods",
            "20",
            "--tau",
            "2",
            "--json",
            "--out",
            "run.nc",
        ],
        elsewhere,
        env,
    )
    out = json.loads(r.stdout)
    assert out["steps"] > 0 and out["contact"] in ("jumping", "permanent"), out
    assert (elsewhere / "run.nc").stat().st_size > 0

    _run([bin_ / "vibtrans", "export", "heatmap", "--out", "map.png"], elsewhere, env)
    assert (elsewhere / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    server = Served(command=[bin_ / "vibtrans"], env=env, cwd=elsewhere)
    try:
        seconds = server.wait_page(timeout=budget(600))
        log = server.text()
        # the maps it checked are the installed ones
        assert "drift maps and the vertical curve checked in" in log, log
        assert str(bin_.parent) in log.split("checked in", 1)[1].splitlines()[0], log
        print(
            f"installed wheel: first page {seconds:.1f} s after `vibtrans serve` "
            f"(cold kernel cache, compiling in the background)"
        )
    finally:
        server.stop()
