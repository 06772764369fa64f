# Two entry points (see README): `make run` and `make test`.  Both create the project's
# virtualenv in .venv on first use (Debian: installs python3-venv if it is missing).
VENV ?= .venv
PYTHON ?= python3
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test bench setup clean-venv

setup: $(STAMP)

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "Python >= 3.11 required, found " + sys.version'
	$(PYTHON) -m venv $(VENV) || { apt-get update && apt-get install -y python3-venv && $(PYTHON) -m venv $(VENV); }
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/python -m pip install -e '.[test]'
	touch $@

# Main job on the default config.
run: $(STAMP)
	$(BIN)/snakemake -c2 regimes

# Whole test suite.  Whole files go to a worker (module fixtures are built once); the order of
# the files is tests/conftest.py's, not xdist's (--no-loadscope-reorder).
test: $(STAMP)
	$(BIN)/python -m pytest -n 2 --dist loadfile --no-loadscope-reorder --durations=15

# Simulator benchmark against its strongest peers (docs/performance.md, <= 5 minutes).  The
# compiled peer numbalsoda builds from source with a Fortran compiler (Debian: gfortran).
BENCH_STAMP := $(VENV)/.bench-installed

$(BENCH_STAMP): $(STAMP)
	command -v gfortran >/dev/null || { apt-get update && apt-get install -y gfortran; }
	$(BIN)/python -m pip install -e '.[bench]'
	touch $@

bench: $(BENCH_STAMP)
	$(BIN)/python benchmarks/simulate.py

clean-venv:
	rm -rf $(VENV)
