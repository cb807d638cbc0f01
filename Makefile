# sportfusion: `make test` and `make demo` set up .venv themselves.
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DELETE_ON_ERROR:

PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO ?= demo-out

.PHONY: all test test-fast lint format demo bench fixtures clean

all: test

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[test,plot]'
	touch $@

test: $(STAMP)
	$(BIN)/python -m pytest -q

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow"

lint: $(STAMP)
	$(BIN)/ruff check lib tools tests fixtures
	$(BIN)/ruff format --check lib tools tests fixtures

format: $(STAMP)
	$(BIN)/ruff format lib tools tests fixtures
	$(BIN)/ruff check --fix lib tools tests fixtures

fixtures: $(STAMP)
	$(BIN)/python fixtures/make_fixtures.py

demo: $(STAMP)
	mkdir -p $(DEMO)
	$(BIN)/ingest fixtures/raw/phyphox_jump.zip fixtures/raw/qstarz_jump.nmea -o $(DEMO)/session.parquet
	$(BIN)/inspect $(DEMO)/session.parquet

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[test,plot,bench]'
	for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python "$$f"; done

clean:
	rm -rf $(VENV) $(DEMO) .pytest_cache .hypothesis *.egg-info

# skijump Table 7 end to end (5 simulated jumps: raw files -> rts-smooth -> jump-metrics vs video-jumplength)
.PHONY: table7
table7: $(STAMP)
	$(BIN)/python bench/bench_table7.py
