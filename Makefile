# granalytics — every dependency is installed by this file and pyproject.toml.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
BUILD := build

.PHONY: test test-all demo bench install clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

## test: the full fast test suite (what CI runs)
test: $(STAMP)
	$(PY) -m pytest -q -m "not slow"

## test-all: including tests marked slow
test-all: $(STAMP)
	$(PY) -m pytest -q

## demo: the main job on the bundled dataset (datasets/lab-cg3.h5, made by sim; see datasets/README.md)
demo: $(STAMP)
	@mkdir -p $(BUILD)
	$(VENV)/bin/granalytics info datasets/lab-cg3.h5
	$(VENV)/bin/granalytics stats datasets/lab-cg3.h5 --window 3:6 \
		--out $(BUILD)/demo-timeseries.csv --sizes-out $(BUILD)/demo-sizes.csv \
		--plot $(BUILD)/demo-stats.png

## bench: benchmark scripts (print tables)
bench: $(STAMP)
	$(PY) benchmarks/identify.py
	$(PY) benchmarks/sim_throughput.py

clean:
	rm -rf $(BUILD) .pytest_cache
