"""app/compat.py: each workaround answers a bug the installed framework
versions show.  The test of each bug runs stock code and fails on the day
a version fixes it: then delete the workaround (docs/UPSTREAM.md)."""
import subprocess
import sys

from vibtrans_explorer import compat

_STOCK_PROBE = ("from vibtrans_explorer import compat; "
                "print(compat.validation_switch_is_process_wide())")


def test_bokeh_validation_switch_is_one_flag_for_the_process():
    """Bug 1 (docs/UPSTREAM.md): Bokeh's `validate(False)` in one thread
    turns validation off in every thread.  Probed in a fresh process:
    stock Bokeh, nothing applied."""
    out = subprocess.run([sys.executable, "-c", _STOCK_PROBE], capture_output=True,
                         text=True, timeout=120, check=True).stdout.split()
    assert out[-1] == "True", ("Bokeh's validation switch no longer leaks across threads: "
                               "delete workaround 1 of app/compat.py")


def test_apply_applies_what_is_shown_and_undo_restores_bokeh():
    was = compat.applied()
    compat.undo()
    try:
        assert compat.validation_switch_is_process_wide()       # stock: the bug
        lines = compat.apply()
        assert compat.applied() == [compat.WORKAROUNDS[0][0]]
        assert "applied" in lines[0]
        assert not compat.validation_switch_is_process_wide()   # answered
        assert compat.apply() == [f"{compat.WORKAROUNDS[0][0]}: applied"]   # idempotent
        compat.undo()
        assert compat.applied() == []
        assert compat.validation_switch_is_process_wide()       # Bokeh's own again
    finally:
        if was:
            compat.apply()


def test_nothing_is_applied_at_import():
    out = subprocess.run([sys.executable, "-c",
                          "import vibtrans_explorer.explorer, vibtrans_explorer.compat as c; "
                          "print(c.applied())"],
                         capture_output=True, text=True, timeout=300, check=True).stdout.split()
    assert out[-1] == "[]"
