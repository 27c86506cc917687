"""Shared fixtures.

served_explorer: one `vibtrans serve` for the whole test session (a real
command line on a free port, so it starts as from a shell: maps checked,
re-executed on the C allocator, kernels compiled in the background), used
by the browser, security and server tests; yields the netutil.Served
(.url, .port, .proc, .text() for its log).

browser: a headless chromium (devtools/chromium.py) for one test module,
closed at its end (tests that launch their own, or the load test's, then
start from a clean state).

assets_folder: point(folder) makes the explorer read its maps from
folder/maps; the shipped ones again at the end, nothing read from the
copies kept (tests/assetsfolder.py)."""

import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest
from budget import factor, usable_cores
from netutil import Served

ROOT = Path(__file__).resolve().parent.parent

# the served explorer's settings: the step cap the browser tests check
# (test_app_browser.test_the_step_cap_is_a_message), websocket origins as
# shipped (localhost only: test_security), the allocator chosen by the server
SERVER_ENV = {"VIBTRANS_MAX_STEPS": "1e8"}
SERVER_ENV_UNSET = ("VIBTRANS_ALLOWED_ORIGINS", "PYTHONMALLOC")


@pytest.fixture(scope="session")
def served_explorer():
    env = {k: v for k, v in os.environ.items() if k not in SERVER_ENV_UNSET}
    # its maps on demand in a folder of its own (none of a previous run's)
    maps = tempfile.mkdtemp(prefix="vibtrans-test-maps-")
    server = Served(env={**env, **SERVER_ENV, "VIBTRANS_MAP_CACHE": maps}, cwd=ROOT)
    try:
        server.wait_page()
        server.wait_kernels()  # runs clicked in the tests start at once
        yield server
    finally:
        server.stop()
        shutil.rmtree(maps, ignore_errors=True)


@pytest.fixture(scope="module")
def browser():
    from devtools.chromium import launched

    with launched() as b:
        yield b


@pytest.fixture
def assets_folder():
    from assetsfolder import point_assets

    from vibtrans_explorer.server import data

    shipped = data.ASSETS
    try:
        yield point_assets
    finally:
        point_assets(shipped)


@pytest.fixture(autouse=True)
def _assets_folder_restored():
    """A test that points the explorer at other maps must point it back (the
    next test in this process would read them): through assets_folder."""
    data = sys.modules.get("vibtrans_explorer.server.data")
    before = data and data.ASSETS
    yield
    data = sys.modules.get("vibtrans_explorer.server.data")
    if data is not None and before is not None:
        assert data.ASSETS == before, f"the test left the explorer's maps at {data.ASSETS}"


def pytest_report_header(config):
    """The scale of every wait's budget this session (tests/budget.py)."""
    return (
        f"test budgets: x{factor():.2f} of an idle machine's "
        f"({usable_cores()} usable cores, load {os.getloadavg()[0]:.1f})"
    )


def pytest_configure(config):
    """On pytest-xdist's controller (`-n`, as `make test` runs it), the kernels
    are compiled into numba's on-disk cache once, before the workers start:
    each then loads them, instead of every worker compiling the same kernels
    at once on a cold cache (vibtrans.core.kernels.jit)."""
    if getattr(config.option, "numprocesses", None) and not hasattr(config, "workerinput"):
        from vibtrans.core.simulate import warmup

        warmup()


# the files of each pass of `make test` that take longest (2-4 min each,
# `pytest --durations`: the browser and server pass's, then the other's):
# run first, so that on pytest-xdist's workers (--dist loadfile
# --no-loadscope-reorder hands out files in the order collected; its
# default order, most tests first, put the one-test random walk last) none
# of them starts last and keeps one worker busy while the other is idle
LONGEST_FIRST = (
    "test_explorer_state_browser.py",
    "test_app_browser.py",
    "test_loadtest.py",
    "test_wheel.py",
    "test_lyapunov.py",
    "test_mapjobs.py",
    "test_export.py",
)


def pytest_collection_modifyitems(items):
    """Every test that uses the served explorer (directly or through a
    fixture) is marked `server`, so `make test-fast` (-m "not server")
    leaves it out without each file having to say so.  The longest files
    first (LONGEST_FIRST), the others in their order."""
    for item in items:
        if "served_explorer" in getattr(item, "fixturenames", ()):
            item.add_marker("server")

    def rank(item):
        name = item.path.name
        return LONGEST_FIRST.index(name) if name in LONGEST_FIRST else len(LONGEST_FIRST)

    items.sort(key=rank)  # stable: the rest keep their order
