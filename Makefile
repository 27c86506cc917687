# Two commands on a fresh machine (README Quickstart):
#   make serve   set up, then serve the explorer (until it lands: a demo run)
#   make test    set up, then run the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin

.PHONY: setup serve test bench clean-cache

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

serve: setup
	$(BIN)/vibtrans serve

test: setup
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/vibtrans bench

# numba's on-disk cache does not see edits to other modules that a cached
# kernel inlines: clear it after editing kernels.
clean-cache:
	find vibtrans -name '*.nbi' -delete -o -name '*.nbc' -delete
