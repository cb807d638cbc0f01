# sportfusion: `make test` and `make demo` set up .venv themselves.
SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DELETE_ON_ERROR:

PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO ?= demo-out

SESSIONS ?= sessions
BATCH ?= batch-out

.PHONY: all test test-fast lint format demo images bench fixtures clean batch cluster-batch

all: test

$(STAMP): pyproject.toml setup.py lib/skijump/_ski_c.c lib/estimators/_banded_c.c
	@echo "installing dependencies into $(VENV): 4-6 minutes on a 2-core machine (newest versions pyproject.toml allows)"
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[test,plot,cluster]'
	touch $@

# the report's browser test runs Debian's Chromium and ChromeDriver (installed here when missing)
BROWSER := $(VENV)/.browser
$(BROWSER): | $(STAMP)
	@if ! command -v chromium >/dev/null || ! command -v chromedriver >/dev/null; then \
	  echo "installing Debian's chromium and chromium-driver for the report's browser test, about a minute"; \
	  SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq chromium chromium-driver >/dev/null; \
	fi
	touch $@

test: $(STAMP) $(BROWSER)
	$(BIN)/python -m pytest -q

test-fast: $(STAMP) $(BROWSER)
	$(BIN)/python -m pytest -q -m "not slow"

lint: $(STAMP)
	$(BIN)/ruff check lib tools tests fixtures bench
	$(BIN)/ruff format --check lib tools tests fixtures bench

format: $(STAMP)
	$(BIN)/ruff format lib tools tests fixtures bench
	$(BIN)/ruff check --fix lib tools tests fixtures bench

fixtures: $(STAMP)
	$(BIN)/python fixtures/make_fixtures.py
	$(BIN)/python fixtures/make_skijump.py
	$(BIN)/python fixtures/make_sessions.py

# every sport on the shipped fixtures (fixtures/<sport>/config.mk): results, evaluations, plots, pages.
# It prints the commands a user types (after `source .venv/bin/activate`), then what they give.
demo: $(STAMP)
	@mkdir -p $(DEMO)/plots
	@echo "== 1. A raw recording becomes a session: a phone's phyphox export and a GPS logger's NMEA log on one clock"
	@echo "\$$ ingest fixtures/raw/phyphox_jump.zip fixtures/raw/qstarz_jump.nmea -o $(DEMO)/recording.parquet"
	@$(BIN)/ingest fixtures/raw/phyphox_jump.zip fixtures/raw/qstarz_jump.nmea -o $(DEMO)/recording.parquet
	@echo "\$$ inspect $(DEMO)/recording.parquet --rows 2     # columns [units], sensor rates, metadata, provenance"
	@$(BIN)/inspect $(DEMO)/recording.parquet --rows 2
	@echo
	@echo "== 2. Every sport from its raw files to its results (fixtures/<sport>/config.mk through pipelines/session.mk)"
	@echo "   the exact commands each session ran, with their messages: $(DEMO)/<sport>/log"
	@$(BIN)/plot hill -q --hill oberstdorf_hs106 -o $(DEMO)/plots/hill-oberstdorf_hs106.png
	@$(MAKE) --no-print-directory -f pipelines/batch.mk SESSIONS=fixtures OUT=$(DEMO)
	@for f in $(DEMO)/*/plots/*.png; do s=$${f#$(DEMO)/}; cp "$$f" "$(DEMO)/plots/$${s%%/*}-$$(basename $$f)"; done
	@echo
	@echo "== 3. Errors against the truth of each simulated session (evaluate; RMS rows, whole session;"
	@echo "   position d* [m] and velocity dv* [m/s] in the frame the header names, attitude in degrees)"
	@for f in $(DEMO)/*/evaluation.txt; do echo "-- $$f"; sed -n '2,5p' "$$f"; done
	@echo "-- $(DEMO)/skijump/table7.txt: jump length from the sensors (L_TR) against the landing video (L_VR)"
	@sed -n '2,4p' $(DEMO)/skijump/table7.txt
	@echo
	@echo "== 4. Pages for people (open in a browser, on a phone, or mail them): $(DEMO)/index.html, $(DEMO)/<sport>/report.html"
	@echo "== 5. Plots ($(DEMO)/plots/, each kind explained in docs/plots.md):"
	@ls $(DEMO)/plots | sed 's/^/   /'

# docs/images (the figures docs/plots.md shows) regenerated from the demo's outputs
images: demo
	docs/make_images.sh $(DEMO)

# a sessions folder (one sub-folder per session with config.mk), N jobs: make batch SESSIONS=dir JOBS=2
JOBS ?= 2
# a missing SESSIONS folder: one line saying what to pass, not make's three error lines
ifneq ($(filter batch,$(MAKECMDGOALS)),)
ifeq ($(wildcard $(SESSIONS)/.),)
$(error no sessions folder '$(SESSIONS)': pass one, make batch SESSIONS=dir (a sub-folder per session, each with a config.mk; e.g. SESSIONS=fixtures))
endif
endif
batch: $(STAMP)
	$(MAKE) --no-print-directory -j $(JOBS) -f pipelines/batch.mk SESSIONS=$(SESSIONS) OUT=$(BATCH)

# the same batch through Snakemake (the `cluster` extra): locally on JOBS cores, or with PROFILE on a
# scheduler (pipelines/profiles/slurm: set your partition and account; checked before anything is submitted);
# RETRY_FAILED=1 also redoes the sessions that failed; UNLOCK=1 first removes the lock that a killed run
# left in BATCH (only when no other run is using BATCH)
PROFILE ?=
RETRY_FAILED ?=
UNLOCK ?=
SNAKEMAKE_BATCH = $(BIN)/snakemake -s pipelines/Snakefile -d $(abspath $(BATCH)) --quiet rules --rerun-incomplete \
	  --config sessions=$(abspath $(SESSIONS)) out=$(abspath $(BATCH)) bin=$(abspath $(BIN))/ \
	  $(if $(PROFILE),--profile $(PROFILE),--cores $(JOBS) --keep-going)
cluster-batch: $(STAMP)
	@test -d "$(SESSIONS)" || { echo "cluster-batch: no sessions folder '$(SESSIONS)': pass SESSIONS=dir (one sub-folder per session with its config.mk) and BATCH=out"; exit 2; }
	@if [ -n "$(UNLOCK)" ]; then $(SNAKEMAKE_BATCH) --unlock > /dev/null && echo "cluster-batch: unlocked $(BATCH)"; \
	elif compgen -G "$(BATCH)/.snakemake/locks/*" > /dev/null; then echo "cluster-batch: $(BATCH) is locked: another run is using it, or a killed run left its lock; if none is running: make cluster-batch UNLOCK=1 SESSIONS=$(SESSIONS) BATCH=$(BATCH)$(if $(PROFILE), PROFILE=$(PROFILE))"; exit 2; fi
	@$(if $(PROFILE),$(BIN)/python -m sportfusion.batch check-profile $(PROFILE))
	@if [ -n "$(RETRY_FAILED)" ]; then for e in $(BATCH)/*/error; do [ -e "$$e" ] && rm -f "$${e%error}.done"; done; true; fi
	$(SNAKEMAKE_BATCH)
	@n=$$(sed -n 's/^.* sessions ok, \([0-9]*\) failed$$/\1/p' $(BATCH)/summary.txt); [ "$${n:-0}" -eq 0 ] || { echo "cluster-batch: $$n session(s) failed, listed in $(BATCH)/summary.txt"; exit 1; }

# cluster-batch on a real single-node SLURM cluster stood up on this machine (root, Debian; see the script)
.PHONY: slurm-test
slurm-test: $(STAMP)
	bash pipelines/slurm/test-slurm.sh

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[test,plot,cluster,bench]'
	$(BIN)/python bench/report.py -o bench-report.md

clean:
	rm -rf $(VENV) $(DEMO) $(BATCH) .pytest_cache .hypothesis *.egg-info

# skijump Table 7 end to end (5 simulated jumps: raw files -> rts-smooth -> jump-metrics vs video-jumplength)
.PHONY: table7
table7: $(STAMP)
	$(BIN)/python bench/bench_table7.py
