"""The library type-checks: mypy over vibtrans/ with the settings of
pyproject.toml ([tool.mypy])."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_mypy_passes():
    done = subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def _public_functions():
    """(name, annotated) of the library's public functions and methods: not
    underscored, in modules that are not; annotated: every argument and the
    return."""
    import ast

    out = []

    def visit(body, where):
        for node in body:
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                visit(node.body, f"{where}.{node.name}")
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not node.name.startswith("_"):
                args = [a for a in node.args.args + node.args.kwonlyargs if a.arg not in ("self", "cls")]
                done = node.returns is not None and all(a.annotation is not None for a in args)
                out.append((f"{where}.{node.name}", done))

    for path in sorted((ROOT / "vibtrans").rglob("*.py")):
        parts = path.relative_to(ROOT).parts
        if any(p.startswith("_") and p != "__init__.py" for p in parts):
            continue
        visit(ast.parse(path.read_text()).body, ".".join(parts)[: -len(".py")])
    return out


def test_nine_in_ten_public_functions_have_type_hints():
    functions = _public_functions()
    missing = [name for name, done in functions if not done]
    share = 1 - len(missing) / len(functions)
    assert share >= 0.9, f"{share:.0%} of {len(functions)} annotated; without: {missing}"
