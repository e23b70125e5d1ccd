# fringe: every target installs what it needs into .venv first (Python packages from PyPI).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out
JOBS   ?= 2
# one BLAS thread a process: the tests run JOBS workers, and a multithreaded BLAS in each oversubscribes the cores
# (the small solves of the fits then wait for each other); the bench measures one process alike. --dist loadgroup:
# tests marked xdist_group share a worker (tb/test_engine_rtl.py: one loop calibration for both simulators)
ONE_BLAS_THREAD := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1

SYNTH_STAMP := $(VENV)/.installed-synth

.PHONY: setup demo test test-model test-rtl lint bench synth synth-families formal clean help

help:
	@echo "make demo   - simulate the seed encoder, calibrate, correct, print before/after, write plots ($(OUT)/demo)"
	@echo "make test   - the whole regression: model tests and cocotb RTL tests (Verilator, GHDL)"
	@echo "make lint   - ruff on the Python, verilator -Wall and ghdl -a --std=08 on the RTL"
	@echo "make bench  - accuracy, speed and size (runs make synth, synth-families, formal) into results/bench.json and .md"
	@echo "make synth  - Yosys + nextpnr for iCE40 UP5K and ECP5-25k: LUT, FF, DSP, BRAM, Fmax into results/synth.json"
	@echo "make synth-families - the seed configuration on Gowin GW1NR-9, Lattice Nexus LIFCL-40, GateMate (results/families)"
	@echo "make formal - SymbiYosys proofs of fringe_top's stream, banks and reset (yowasp-sby, yices) into results/formal.json"
	@echo "make setup  - create .venv and install fringe with its test tools"

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $@

setup: $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m fringe.tools.demo $(OUT)/demo

test: $(STAMP)
	$(ONE_BLAS_THREAD) $(BIN)/python -m pytest -n $(JOBS) --dist loadgroup -q --durations=20

test-model: $(STAMP)
	$(ONE_BLAS_THREAD) $(BIN)/python -m pytest -n $(JOBS) --dist loadgroup -q tests

test-rtl: $(STAMP)
	$(ONE_BLAS_THREAD) $(BIN)/python -m pytest -n $(JOBS) --dist loadgroup -q tb

lint: $(STAMP)
	$(BIN)/ruff check model tests tb sim
	$(BIN)/python sim/lint.py
	$(BIN)/python sim/hdlgen.py --check

bench: synth synth-families formal
	$(ONE_BLAS_THREAD) $(BIN)/python -m fringe.tools.bench --out results

$(SYNTH_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[test,synth]'
	touch $@

synth: $(SYNTH_STAMP)
	$(BIN)/python sim/synth.py --out results --configs seed,line1,seed_trim,seed_drift,seed_cancel,seed_compact,seed_compact_trim,seed_compact_drift --devices ice40,ecp5,ecp5-8

# Gowin, Lattice Nexus and GateMate: the seed configuration (their place and route is slow; docs/synthesis.md)
synth-families: $(SYNTH_STAMP)
	$(BIN)/python sim/synth.py --out results/families --configs seed --devices gowin,nexus,gatemate

formal: $(SYNTH_STAMP)
	timeout 900 $(BIN)/python sim/formal/run.py --trim --json results/formal.json

clean:
	rm -rf $(OUT) results sim_build .pytest_cache
