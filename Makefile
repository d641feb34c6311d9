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

## demo: the main job on demo data. Until the simulator's bundled dataset lands, this is a
## physics-free synthetic run (granalytics.synthetic) generated here, not simulation output.
demo: $(STAMP)
	@mkdir -p $(BUILD)
	$(PY) -m granalytics.synthetic --out $(BUILD)/demo-run.h5 --particles 3000 --revolutions 6
	$(VENV)/bin/granalytics info $(BUILD)/demo-run.h5
	$(VENV)/bin/granalytics stats $(BUILD)/demo-run.h5 --window 3:6 \
		--out $(BUILD)/demo-timeseries.csv --sizes-out $(BUILD)/demo-sizes.csv \
		--plot $(BUILD)/demo-stats.png

## bench: benchmark scripts (print tables)
bench: $(STAMP)
	$(PY) benchmarks/identify.py

clean:
	rm -rf $(BUILD) .pytest_cache
