# Batch reprocessing of a sessions folder: one sub-folder per session (raw files + config.mk, see
# session.mk), each run through its sport's pipeline into OUT/<name>/, then one summary.
#
#   make -f pipelines/batch.mk SESSIONS=sessions OUT=batch-out -j 2
#
# A failing session does not stop the others (its sub-make runs under -k); it is listed with its error
# line at the end, and the whole run then exits non-zero. OUT/summary.{txt,csv,parquet} hold one row
# per session (jump lengths, speeds, errors against the truth where there is one; a session is ok only
# when every file its TARGET declares exists). Re-running redoes only what changed.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.SUFFIXES:

SF_ROOT := $(abspath $(dir $(lastword $(MAKEFILE_LIST)))/..)
BIN ?= $(SF_ROOT)/.venv/bin/
PYTHON ?= $(BIN)python
SESSIONS ?= sessions
OUT ?= batch-out
NAMES := $(notdir $(patsubst %/config.mk,%,$(wildcard $(SESSIONS)/*/config.mk)))
SESSION_MK := $(SF_ROOT)/pipelines/session.mk
TARGET ?= all

.PHONY: all sessions summary $(NAMES:%=session-%)
all:
	@$(MAKE) --no-print-directory -k -f $(firstword $(MAKEFILE_LIST)) sessions || true
	@$(MAKE) --no-print-directory -f $(firstword $(MAKEFILE_LIST)) summary

sessions: $(NAMES:%=session-%)

$(NAMES:%=session-%): session-%:
	@mkdir -p $(OUT)/$*
	@if $(MAKE) --no-print-directory -f $(SESSION_MK) SESSION=$(SESSIONS)/$* OUT=$(OUT)/$* $(TARGET) > $(OUT)/$*/log 2>&1; \
	then rm -f $(OUT)/$*/error; echo "ok      $*"; \
	else { grep -m1 '^Error' $(OUT)/$*/log || tail -n1 $(OUT)/$*/log; } > $(OUT)/$*/error; \
	     echo "FAILED  $*: $$(cat $(OUT)/$*/error)"; exit 1; fi

summary:
	@$(PYTHON) -m sportfusion.batch $(OUT) --sessions $(SESSIONS) --session-mk $(SESSION_MK) --target "$(TARGET)" \
	  --engine "GNU make $(MAKE_VERSION)" --engine-params "target=$(TARGET)"
