# Two commands on a fresh machine (Python 3.11+ and pip): `make run` and `make test`.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
SCENE ?= grid

.PHONY: run test test-all lint bench install clean

$(BIN)/oscillators: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $@

install: $(BIN)/oscillators

# warm: the served scene's kernels and its Physics toggles are compiled before the page
# opens (once per machine, then read from numba's cache); the server compiles the other presets'
# in the background (docs/web.md, "Kernels compiled ahead").
run: install  ## install, then serve the web app on the default scene
	$(BIN)/oscillators warm $(SCENE) --toggles
	$(BIN)/oscillators serve $(SCENE)

# --dist loadfile: a test module's tests run in one worker, so the kernels a module compiles on a
# cold cache are compiled once, not by both workers at the same time.  NUMBA_OPT=1: the default
# suite's time is mostly compiling kernels, which LLVM's level 1 does faster
# (docs/developing.md); its kernels are cached apart (sim/runtime/kernel_cache.py).  test-all runs at the
# level users get.
test: install  ## install, then run the test suite (includes one real-browser test)
	bash scripts/ensure-chromium.sh
	$(BIN)/ruff check sim app tests benchmarks
	NUMBA_OPT=1 $(BIN)/python -m pytest -n auto --dist loadfile --durations=20

test-all: install  ## every test, slow ones included
	bash scripts/ensure-chromium.sh
	$(BIN)/python -m pytest -n auto --dist loadfile -m ''

bench: install
	$(BIN)/oscillators bench

clean:
	rm -rf $(VENV) build *.egg-info
