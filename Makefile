# Two commands do the whole set-up on a fresh machine (Python >= 3.10):
#   make reproduce   install everything into .venv and run the main job
#   make test        install everything into .venv and run the tests
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out

.PHONY: install test test-all reproduce bench bench-full clean

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	# The CPU wheel: any other torch spec pulls gigabytes of CUDA packages.
	$(BIN)/python -m pip install -q torch==2.13.0
	$(BIN)/python -m pip install -q -e '.[test]'
	# Compile the altimeter's inner loops into numba's disk cache (about 10 s, once).
	$(BIN)/python -c "from wavealt.altimetry.dispersion import warm_up; warm_up()"
	touch $@

install: $(BIN)/.installed

# One pytest worker per core (pytest-xdist); `pytest -n 0` runs them in one process.
test: $(BIN)/.installed
	$(BIN)/python -m pytest -q -n auto

test-all: $(BIN)/.installed
	$(BIN)/python -m pytest -q -n auto -m "slow or not slow"

reproduce: $(BIN)/.installed
	$(BIN)/wavealt reproduce $(OUT)/reproduce

bench: $(BIN)/.installed
	$(BIN)/python benchmarks/run_all.py

bench-full: $(BIN)/.installed
	$(BIN)/python benchmarks/run_all.py --full

clean:
	rm -rf $(VENV) $(OUT)
