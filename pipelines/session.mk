# One session, raw recordings -> results. Each stage is a file, so `make` redoes only what changed.
#
#   make -f pipelines/session.mk SESSION=fixtures/skijump OUT=out/skijump [results|plots|evaluation|report]
#   make -s -f pipelines/session.mk SESSION=... OUT=... [TARGET=all] outputs    # the files a target makes
#
# SESSION is a folder with a `config.mk` naming the sport and the venue, and the raw files it lists:
#   SPORT   = skijump | skirace | gates | climbing
#   RAW     = files given to `ingest` (relative to SESSION), e.g. raw/phyphox.zip raw/gnss.nmea
#   HILL    = shipped hill name or TOML file        (skijump)
#   ORIGIN  = LAT,LON,H   AZIMUTH = DEG             (skirace: the local course frame)
#   GATES   = gate survey (Parquet, kind gates)      (gates)
#   BODY    = body-model options, e.g. --height 1.8 --mass 78 (gates with several IMUs: adds body-model)
#   HOLDS   = hold map (Parquet, kind holds)         (climbing)
#   TRUTH   = truth table, when the session was simulated (adds evaluation.txt)
#   VIDEO   = landing video, MARKERS = its marker table (skijump: the video reference, Table 7)
# Tools come from BIN (default: this project's .venv/bin/; BIN= uses PATH).

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DELETE_ON_ERROR:
.SUFFIXES:

SF_ROOT := $(abspath $(dir $(lastword $(MAKEFILE_LIST)))/..)
BIN ?= $(SF_ROOT)/.venv/bin/
SESSION ?= $(error SESSION=folder is required)
OUT ?= out/$(notdir $(SESSION))
Q ?= -q

include $(SESSION)/config.mk

S := $(SESSION)
O := $(OUT)
RAWFILES := $(addprefix $(S)/,$(RAW))
TRUTHFILE := $(if $(TRUTH),$(S)/$(TRUTH))
# a RAW that is already a session table (a simulated one) skips ingest
INGEST := $(if $(filter %.parquet,$(RAW)),cat $(RAWFILES),$(BIN)ingest $(Q) $(RAWFILES))

.PHONY: results plots evaluation report all outputs
all: results plots evaluation report

$(O)/.dir:
	mkdir -p $(O)/plots && touch $@

# --------------------------------------------------------------------------- ski jump
ifeq ($(SPORT),skijump)
OUT_RESULTS := $(O)/jumps.parquet $(if $(VIDEO),$(O)/table7.txt)
OUT_PLOTS := $(O)/plots/speed.png $(O)/plots/series.png $(O)/plots/mag.png $(O)/plots/track.png $(if $(TRUTH),$(O)/plots/errors.png)
OUT_EVALUATION := $(if $(TRUTH),$(O)/evaluation.txt $(O)/evaluation.parquet $(O)/evaluation_gnss.txt)
OUT_REPORT := $(O)/report.html

# cheap stages piped: raw files -> one session in the hill frame with take-off/touch-down events
$(O)/events.parquet: $(RAWFILES) $(S)/config.mk | $(O)/.dir
	$(INGEST) | $(BIN)gps2hill $(Q) --hill $(HILL) | $(BIN)detect-events $(Q) --kind jump -o $@
$(O)/smoothed.parquet: $(O)/events.parquet
	$(BIN)rts-smooth $(Q) $< --hill $(HILL) -o $@
$(O)/jumps.parquet: $(O)/smoothed.parquet
	$(BIN)jump-metrics $(Q) $< --hill $(HILL) -o $@
$(O)/video.parquet: $(S)/$(VIDEO) $(S)/$(MARKERS) | $(O)/.dir
	$(BIN)video-jumplength $(Q) $(S)/$(VIDEO) --markers $(S)/$(MARKERS) -o $@
$(O)/table7.txt: $(O)/jumps.parquet $(O)/video.parquet
	$(BIN)evaluate $(Q) $< --video $(O)/video.parquet --format text -o $@
$(O)/evaluation.txt: $(O)/smoothed.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) --format text -o $@
$(O)/evaluation.parquet: $(O)/smoothed.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) -o $@
$(O)/evaluation_gnss.txt: $(O)/events.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) --gnss --format text -o $@
$(O)/report.html: $(O)/smoothed.parquet $(O)/jumps.parquet $(if $(TRUTH),$(O)/evaluation.parquet)
	$(BIN)report $(Q) $< --jumps $(O)/jumps.parquet $(if $(TRUTH),--evaluation $(O)/evaluation.parquet) -o $@
$(O)/plots/speed.png: $(O)/smoothed.parquet
	$(BIN)plot speed $(Q) $< -o $@
$(O)/plots/series.png: $(O)/smoothed.parquet
	$(BIN)plot series $(Q) $< -o $@
$(O)/plots/mag.png: $(O)/smoothed.parquet
	$(BIN)plot mag $(Q) $< -o $@
$(O)/plots/track.png: $(O)/smoothed.parquet
	$(BIN)plot track $(Q) $< -o $@
$(O)/plots/errors.png: $(O)/smoothed.parquet $(TRUTHFILE)
	$(BIN)plot errors $(Q) $< --truth $(TRUTHFILE) -o $@
endif

# --------------------------------------------------------------------------- ski racing, GNSS
ifeq ($(SPORT),skirace)
OUT_RESULTS := $(O)/attitude.parquet
OUT_PLOTS := $(O)/plots/spline.png $(O)/plots/series.png
OUT_EVALUATION := $(if $(TRUTH),$(O)/evaluation.txt $(O)/evaluation.parquet)
OUT_REPORT := $(O)/report.html

$(O)/spline.parquet: $(RAWFILES) $(S)/config.mk | $(O)/.dir
	$(INGEST) | $(BIN)gps2hill $(Q) --origin $(ORIGIN) --azimuth $(AZIMUTH) \
	  | $(BIN)spline-smooth $(Q) -o $@
$(O)/attitude.parquet: $(O)/spline.parquet
	$(BIN)dmc-attitude $(Q) $< -o $@
$(O)/evaluation.txt: $(O)/attitude.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) --format text -o $@
$(O)/evaluation.parquet: $(O)/attitude.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) -o $@
$(O)/report.html: $(O)/attitude.parquet $(if $(TRUTH),$(O)/evaluation.parquet)
	$(BIN)report $(Q) $< $(if $(TRUTH),--evaluation $(O)/evaluation.parquet) -o $@
$(O)/plots/spline.png: $(O)/attitude.parquet
	$(BIN)plot spline $(Q) $< $(if $(TRUTH),--truth $(TRUTHFILE)) -o $@
$(O)/plots/series.png: $(O)/attitude.parquet
	$(BIN)plot series $(Q) $< -o $@
endif

# --------------------------------------------------------------------------- ski racing, magnet gates
ifeq ($(SPORT),gates)
OUT_RESULTS := $(O)/anchored.parquet
OUT_PLOTS := $(O)/plots/course.png $(O)/plots/series.png $(if $(BODY),$(O)/plots/body.png)
OUT_EVALUATION := $(if $(TRUTH),$(O)/evaluation.txt $(O)/evaluation.parquet)
OUT_REPORT := $(O)/report.html

$(O)/crossings.parquet: $(RAWFILES) $(S)/config.mk | $(O)/.dir
	$(INGEST) $(if $(BODY),| $(BIN)body-model $(Q) $(BODY)) | $(BIN)detect-events $(Q) --kind gates -o $@
$(O)/anchored.parquet: $(O)/crossings.parquet $(S)/$(GATES)
	$(BIN)gate-anchor $(Q) $< --gates $(S)/$(GATES) -o $@
$(O)/evaluation.txt: $(O)/anchored.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) --format text -o $@
$(O)/evaluation.parquet: $(O)/anchored.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) -o $@
$(O)/report.html: $(O)/anchored.parquet $(S)/$(GATES) $(if $(TRUTH),$(O)/evaluation.parquet)
	$(BIN)report $(Q) $< --gates $(S)/$(GATES) $(if $(TRUTH),--evaluation $(O)/evaluation.parquet) -o $@
$(O)/plots/course.png: $(O)/anchored.parquet $(S)/$(GATES)
	$(BIN)plot gates $(Q) $< --gates $(S)/$(GATES) -o $@
$(O)/plots/body.png: $(O)/anchored.parquet $(S)/$(GATES)
	$(BIN)plot body $(Q) $< --gates $(S)/$(GATES) -o $@
$(O)/plots/series.png: $(O)/anchored.parquet
	$(BIN)plot series $(Q) $< -o $@
endif

# --------------------------------------------------------------------------- climbing
ifeq ($(SPORT),climbing)
OUT_RESULTS := $(O)/holds.parquet
OUT_PLOTS := $(O)/plots/holds.png
OUT_EVALUATION := $(if $(TRUTH),$(O)/evaluation.txt $(O)/evaluation.parquet)
OUT_REPORT := $(O)/report.html

$(O)/grips.parquet: $(RAWFILES) $(S)/config.mk | $(O)/.dir
	$(INGEST) | $(BIN)detect-events $(Q) --kind grips -o $@
$(O)/holds.parquet: $(O)/grips.parquet $(S)/$(HOLDS)
	$(BIN)pf-holds $(Q) $< --holds $(S)/$(HOLDS) -o $@
$(O)/evaluation.txt: $(O)/holds.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) --format text -o $@
$(O)/evaluation.parquet: $(O)/holds.parquet $(TRUTHFILE)
	$(BIN)evaluate $(Q) $< --truth $(TRUTHFILE) -o $@
$(O)/report.html: $(O)/holds.parquet $(S)/$(HOLDS) $(if $(TRUTH),$(O)/evaluation.parquet)
	$(BIN)report $(Q) $< --holds $(S)/$(HOLDS) $(if $(TRUTH),--evaluation $(O)/evaluation.parquet) -o $@
$(O)/plots/holds.png: $(O)/holds.parquet $(S)/$(HOLDS)
	$(BIN)plot holds $(Q) $< --holds $(S)/$(HOLDS) $(if $(TRUTH),--truth $(TRUTHFILE)) -o $@
endif

# each target's files (set by the sport's block above)
results: $(OUT_RESULTS)
plots: $(OUT_PLOTS)
evaluation: $(OUT_EVALUATION)
report: $(OUT_REPORT)

# the files TARGET (default all; several allowed) declares, one a line: a batch's summary calls a session
# ok only when every one of them exists (an interrupted run leaves some out)
OUTPUTS_results = $(OUT_RESULTS)
OUTPUTS_plots = $(OUT_PLOTS)
OUTPUTS_evaluation = $(OUT_EVALUATION)
OUTPUTS_report = $(OUT_REPORT)
OUTPUTS_all = $(foreach t,results plots evaluation report,$(OUTPUTS_$(t)))
outputs:
	@printf '%s\n' $(sort $(foreach t,$(or $(TARGET),all),$(OUTPUTS_$(t))))

ifeq ($(filter $(SPORT),skijump skirace gates climbing),)
$(error $(S)/config.mk: SPORT = '$(SPORT)' is not one of skijump skirace gates climbing)
endif
