# Set-up contract: on a machine with only python3 and pip,
#   make demo  -> creates .venv, installs pumpid, runs the main job on the bundled example card,
#                 then pumpid batch and pumpid report on a small synthetic field
#   make test  -> installs the test environment from the lock file and runs the whole suite
#
# The lock (requirements/test.lock) pins the exact version of every package the suite
# imports, so a fresh machine tests what the last green CI run tested. pyproject.toml keeps
# open ranges for users. `make lock` refreshes the lock on purpose; `make test-latest` runs
# the suite against the newest releases in a separate environment (.venv-latest).
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
TSTAMP := $(VENV)/.installed-test
LOCK   := requirements/test.lock
LATEST := .venv-latest

# pumpid's matrices are small: a multi-threaded BLAS only oversubscribes the cores.
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1

.PHONY: demo test test-latest lock lint bench install clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip -c $(LOCK)

$(STAMP): $(PY) pyproject.toml $(LOCK)
	$(PY) -m pip install --quiet -c $(LOCK) -e .
	touch $(STAMP)

$(TSTAMP): $(STAMP)
	$(PY) -m pip install --quiet -c $(LOCK) -e ".[test]"
	touch $(TSTAMP)

install: $(STAMP)

# The single-card report, then the fleet job: a small synthetic field (the project's own
# generator, one well that changes), `pumpid batch` over it, the fleet report beside; then
# a small pump field (one well starting to pound, one with a leaking valve) batched with its
# well file, each card's pump identified, and its fleet report.
demo: $(STAMP)
	$(VENV)/bin/pumpid demo --out demo-output
	rm -rf demo-output/fleet
	$(PY) -m pumpid.fleet.demo demo-output/fleet/field
	@# The demo field holds broken cards on purpose: pumpid batch then exits 3 (some cards
	@# not fitted), 5 or 6 (some fitted poorly or determining nothing); the report follows.
	$(VENV)/bin/pumpid batch demo-output/fleet/field --out demo-output/fleet/results --observe u; \
	  code=$$?; case $$code in 0|3|5|6) ;; *) exit $$code ;; esac
	$(VENV)/bin/pumpid report demo-output/fleet/results --out demo-output/fleet
	@# The pump field (four rod-pumped wells, 64 cards, each card's pump identified: about
	@# ten seconds): its own run, since the Kelvin field's wells have no rod string to describe.
	$(PY) -m pumpid.fleet.demo --pumps demo-output/fleet/pumps/field
	$(VENV)/bin/pumpid batch demo-output/fleet/pumps/field --well-file \
	  demo-output/fleet/pumps/wells.json --model msd --out demo-output/fleet/pumps/results; \
	  code=$$?; case $$code in 0|3|5|6) ;; *) exit $$code ;; esac
	$(VENV)/bin/pumpid report demo-output/fleet/pumps/results --out demo-output/fleet/pumps

lint: $(TSTAMP)
	$(PY) -m ruff check src tests scripts benchmarks

test: $(TSTAMP)
	$(PY) -m ruff check src tests scripts benchmarks
	MPLBACKEND=Agg $(PY) -m pytest -q

# The suite against the newest releases of everything (no lock): upstream drift seen on purpose.
test-latest:
	rm -rf $(LATEST)
	$(PYTHON) -m venv $(LATEST)
	$(LATEST)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST)/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager -e ".[test]"
	$(LATEST)/bin/python -m pip freeze --exclude-editable
	$(LATEST)/bin/python -m ruff check src tests scripts benchmarks
	MPLBACKEND=Agg $(LATEST)/bin/python -m pytest -q -p no:cacheprovider

# Rewrite the lock from the newest releases; run `make test` on it before committing it.
lock:
	rm -rf $(LATEST)
	$(PYTHON) -m venv $(LATEST)
	$(LATEST)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST)/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager -e ".[test]"
	{ echo "# Exact versions for 'make test' (pip install -c); refresh with 'make lock'."; \
	  echo "# Made with $$($(LATEST)/bin/python --version) by 'make lock'."; \
	  $(LATEST)/bin/python -m pip freeze --all --exclude-editable | grep -v '^setuptools=='; \
	} > $(LOCK)
	@echo "wrote $(LOCK); now run: rm -f $(TSTAMP) $(STAMP) && make test"

bench: $(STAMP)
	$(PY) benchmarks/bench_main_job.py

clean:
	rm -rf $(VENV) $(LATEST) demo-output build *.egg-info src/*.egg-info
