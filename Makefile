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

# a simulated jump on Oberstdorf HS106 from the raw files a user would have (fixtures/skijump/raw,
# made by fixtures/make_skijump.py), through the tools, against its truth
demo: $(STAMP)
	mkdir -p $(DEMO)
	$(BIN)/ingest fixtures/skijump/raw/phyphox.zip fixtures/skijump/raw/gnss.nmea -o $(DEMO)/session.parquet
	$(BIN)/inspect $(DEMO)/session.parquet
	$(BIN)/gps2hill $(DEMO)/session.parquet --hill oberstdorf_hs106 -o $(DEMO)/hill.parquet
	$(BIN)/detect-events --kind jump $(DEMO)/hill.parquet -o $(DEMO)/events.parquet
	$(BIN)/plot hill --hill oberstdorf_hs106 -o $(DEMO)/hill.png
	$(BIN)/plot track $(DEMO)/events.parquet -o $(DEMO)/track.png
	$(BIN)/evaluate $(DEMO)/events.parquet --truth fixtures/skijump/truth.parquet --gnss --format text

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[test,plot,bench]'
	for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python "$$f"; done

clean:
	rm -rf $(VENV) $(DEMO) .pytest_cache .hypothesis *.egg-info
