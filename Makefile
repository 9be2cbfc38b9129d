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

.PHONY: all install ros demo test bench clean help

all: test

help:
	@echo "make demo    - install everything into $(VENV) and run the main job on the embedded case"
	@echo "make test    - install everything into $(VENV) and run the tests"
	@echo "make bench   - run the benchmarks (results: BENCHMARKS.md)"

$(BIN)/python:
	$(PYTHON) -c 'import sys; assert sys.version_info[:2] == (3, 11), "bkabem needs CPython 3.11 (ROS 2 Kilted wheels are cp311)"'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): pyproject.toml setup.py bkabem_core/*.c | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $@

ros: $(STAMP)
	bash tools/setup_ros.sh $(VENV)

install: $(STAMP) ros

demo: install
	$(BIN)/bkabem demo

test: install
	$(BIN)/python -m pytest

bench: install
	$(BIN)/python bench/bench_core.py

clean:
	rm -rf build out .pytest_cache
