"""The layout: import layers (import-linter contracts in pyproject.toml, run
by `lint-imports`), the library never loading the explorer or Panel, and
the packaging list in pyproject.toml complete."""

import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

from budget import budget

ROOT = Path(__file__).resolve().parents[2]
LINT = Path(sys.executable).parent / "lint-imports"


def _lint(cwd, *args):
    return subprocess.run(
        [str(LINT), "--no-cache", *args], cwd=cwd, capture_output=True, text=True, timeout=budget(300)
    )


def test_import_contracts_are_kept():
    r = _lint(ROOT)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    assert "0 broken" in r.stdout, r.stdout


def test_lint_imports_fails_on_a_broken_contract(tmp_path):
    # the tool itself, on a package that breaks a layers contract like ours:
    # a low layer importing a high one must fail the run
    pkg = tmp_path / "layered"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "high.py").write_text("from . import low\n")
    (pkg / "low.py").write_text("def f():\n    from . import high\n")
    (tmp_path / ".importlinter").write_text(
        textwrap.dedent("""\
        [importlinter]
        root_package = layered

        [importlinter:contract:layers]
        name = high above low
        type = layers
        layers =
            high
            low
        containers = layered
        """)
    )
    r = _lint(tmp_path, "--config", str(tmp_path / ".importlinter"))
    assert r.returncode != 0, r.stdout
    assert "BROKEN" in r.stdout and "layered.low -> layered.high" in r.stdout, r.stdout


def test_the_library_loads_neither_the_explorer_nor_panel():
    # `import vibtrans`, the command line and a simulation: no Panel, no app
    code = textwrap.dedent("""\
        import sys
        import vibtrans, vibtrans.cli
        assert vibtrans.cli.main(["simulate", "--amplitude", "0.5", "--mass", "1",
                                  "--periods", "2", "--tau", "0.5", "--json"]) == 0
        bad = sorted(m for m in sys.modules
                     if m.split(".")[0] in ("panel", "bokeh", "vibtrans_explorer", "devtools"))
        assert not bad, bad
        """)
    r = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=budget(600)
    )
    assert r.returncode == 0, r.stderr[-3000:]


def test_no_module_imports_the_repository_folder_app():
    # the explorer is installed as vibtrans_explorer; `app` is only a folder
    pattern = re.compile(r"^\s*(from\s+app(\.|\s)|import\s+app\b)", re.M)
    files = [p for d in ("vibtrans", "app", "devtools", "tests") for p in (ROOT / d).rglob("*.py")]
    bad = [str(p.relative_to(ROOT)) for p in files if pattern.search(p.read_text())]
    assert not bad, bad


def test_every_package_is_in_the_wheel_list():
    # pyproject.toml lists the packages (app/ and assets/ are installed under
    # other names): a new subpackage missing from the list would be missing
    # from the wheel
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(conf["packages"])
    dirs = {v: k for k, v in conf["package-dir"].items()}
    found = set()
    for folder in ("vibtrans", "app", "assets"):
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT).parts
            found.add(".".join((dirs.get(rel[0], rel[0]), *rel[1:])))
    assert found == listed, (sorted(found - listed), sorted(listed - found))


def test_each_library_folder_is_small_enough_to_read_at_a_glance():
    # sub-packages a reader can name at a glance, about ten
    # entries at any level (modules and sub-packages, __init__ left out;
    # core holds 12 with the profiles)
    for folder in [
        ROOT / "vibtrans",
        *(p for p in (ROOT / "vibtrans").rglob("*") if p.is_dir() and (p / "__init__.py").exists()),
    ]:
        entries = [
            p.name
            for p in folder.iterdir()
            if p.name != "__init__.py" and (p.suffix == ".py" or (p / "__init__.py").exists())
        ]
        assert len(entries) <= 12, (folder.relative_to(ROOT), sorted(entries))
