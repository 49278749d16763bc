# Set-up and checks. `make demo` and `make test` are all a fresh clone needs.
# The ROS wheels exist for Python 3.10-3.12: take python3 if it is one of those, else the first
# of python3.12/3.11/3.10 that runs (version managers install shims that may not).
PYTHON ?= $(shell for p in python3 python3.12 python3.11 python3.10; do \
	$$p -c 'import sys; sys.exit(not (3, 10) <= sys.version_info[:2] <= (3, 12))' >/dev/null 2>&1 \
	&& echo $$p && break; done)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install test lint typecheck unit demo bench bench-bag-memory generate check-generated clean fuzz storm soak scale

$(STAMP): pyproject.toml
	@test -n "$(PYTHON)" || { echo "need python3.10, 3.11 or 3.12 (the ROS 2 Jazzy wheels)"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[ros,dev]'
	touch $(STAMP)

install: $(STAMP)

lint: install
	$(BIN)/ruff check src tests bench examples tools
	$(BIN)/ruff format --check src

typecheck: install
	$(BIN)/mypy

unit: install
	$(BIN)/pytest -q

test: lint typecheck unit

demo: install
	$(BIN)/python -m examples.demo

# Every shared bag read on a local Dask cluster (make test reads a slice of them).
scale: install
	PYCONNECT_SCALE=all $(BIN)/pytest -q tests/record/test_tables_dask.py

bench: install
	$(BIN)/python -m bench

# Peak RSS reading a 2 GB synthetic bag (MCAP, MCAP cut short, db3) beside rosbags and mcap-ros2.
bench-bag-memory: install
	$(BIN)/python -m bench.bag_memory

# Hardening runs (minutes; not in CI): fuzzed wire codecs, signal storms, a 30-minute soak.
fuzz: install
	$(BIN)/python -m tools.fuzz

storm: install
	$(BIN)/python -m tools.storm

soak: install
	$(BIN)/python -m tools.soak

generate: install
	$(BIN)/codecgen build

check-generated: install
	$(BIN)/codecgen check

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache
