"""`import vibtrans` and its command line load no numerics until a command
needs them (vibtrans/__init__.py): `vibtrans serve` re-executes itself
before the library is imported, so that import is paid once."""

import subprocess
import sys

import vibtrans


def test_the_command_line_imports_no_numerics():
    code = (
        "import sys, vibtrans, vibtrans.cli; "
        "heavy = [m for m in ('numba', 'xarray', 'scipy', 'panel', 'vibtrans.core.params') "
        "if m in sys.modules]; print(heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


def test_public_names_resolve_and_simulate_stays_the_function():
    import importlib

    module = importlib.import_module("vibtrans.core.simulate")
    assert vibtrans.simulate is module.simulate  # not the submodule
    assert vibtrans.Scene.__module__ == "vibtrans.core.params"
    assert callable(vibtrans.warmup) and callable(vibtrans.maps_dir)
    assert set(vibtrans.__all__) <= set(dir(vibtrans))
    try:
        vibtrans.no_such_name  # noqa: B018
    except AttributeError:
        pass
    else:
        raise AssertionError("no AttributeError")
