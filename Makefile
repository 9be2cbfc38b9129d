# bkabem: two commands do all the set-up on a fresh machine.
#   make demo   creates .venv, installs bkabem (+ ROS 2 Kilted wheels, builds bkabem_msgs), runs the main job
#   make test   creates/updates .venv the same way, runs the test suite
# Only python3 (3.11), a C/C++ compiler and cmake are needed on the machine.

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.bkabem-installed
# tiny matrices: one BLAS thread is faster and does not thrash 2-core machines
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: all install ros viewer demo test unit bench screenshots clean help

all: test

help:
	@echo "make demo    - install everything into $(VENV) and run the main job on the embedded case"
	@echo "make test    - install everything into $(VENV) and run the tests (unit, then integration)"
	@echo "make unit    - the fast tier only: tests/unit (no processes, no DDS; about a minute)"
	@echo "make bench   - regenerate BENCHMARKS.md (bench/run_all.py, ~7-20 min; AREAS=core,synthesis for some)"
	@echo "make screenshots - run the demo and a scenario node, regenerate the Rerun viewer screenshots in docs/img"

$(BIN)/python:
	$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "bkabem needs CPython 3.11 (ROS 2 Kilted wheels are cp311)"'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): pyproject.toml setup.py bkabem_core/kernels/*.c bkabem_core/kernels/*.h | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $@

ros: $(STAMP)
	bash tools/setup_ros.sh $(VENV)

# software Vulkan (Mesa lavapipe) for the headless Rerun viewer of the tests and screenshots
viewer:
	bash tools/setup_viewer.sh

install: $(STAMP) ros viewer

demo: install
	$(BIN)/bkabem demo

# the unit tier on up to four worker processes (pytest-xdist; no process or DDS of its own), then the integration
# tier the same way (each worker's ROS processes on a DDS domain range of their own), but for the tests marked
# `serial`: they measure time or lateness that a test running beside them would disturb, and run alone at the end
# (worksteal: an idle worker takes tests queued for a busy one; test durations range from milliseconds to a minute)
XDIST = -n auto --maxprocesses=4 --dist worksteal

test: install
	$(BIN)/python -m pytest -q $(XDIST) tests/unit
	$(BIN)/python -m pytest $(XDIST) -m "not serial" tests/integration
	$(BIN)/python -m pytest -m serial tests/integration

unit: $(STAMP)
	$(BIN)/python -m pytest -q $(XDIST) tests/unit

screenshots: install
	$(BIN)/python -m bkabem_ros.viewer.screenshots --docs docs/img

bench: install
	$(BIN)/python bench/run_all.py $(if $(AREAS),--areas $(AREAS))

clean:
	rm -rf build out .pytest_cache
