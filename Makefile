# Set-up contract: on a machine with only python3 and pip,
#   make demo  -> creates .venv, installs pumpid, runs the main job on the bundled example card
#   make test  -> installs the test extras and runs the whole suite (ruff + pytest)
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
TSTAMP := $(VENV)/.installed-test

# pumpid's matrices are small: a multi-threaded BLAS only oversubscribes the cores.
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1

.PHONY: demo test lint bench install clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): $(PY) pyproject.toml
	$(PY) -m pip install --quiet -e .
	touch $(STAMP)

$(TSTAMP): $(STAMP)
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(TSTAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/pumpid demo --out demo-output

lint: $(TSTAMP)
	$(PY) -m ruff check src tests scripts benchmarks

test: $(TSTAMP)
	$(PY) -m ruff check src tests scripts benchmarks
	MPLBACKEND=Agg $(PY) -m pytest -q

bench: $(STAMP)
	$(PY) benchmarks/bench_fit.py

clean:
	rm -rf $(VENV) demo-output build *.egg-info src/*.egg-info
