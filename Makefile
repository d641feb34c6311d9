# granalytics — every dependency is installed by this file and pyproject.toml.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
BUILD := build

.PHONY: test test-fast demo bench install clean clean-runs datasets notebooks docs

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

## test: the whole test suite, slow-marked tests included (what CI runs)
test: $(STAMP)
	$(PY) -m pytest -q

## test-fast: without the tests marked slow (> ~20 s each)
test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow"

## demo: the main job on the bundled datasets (made by sim; see datasets/README.md): statistics of lab-cg3,
## then the CG comparison of lab-cg1/2/3, lab-cg2 and lab-cg3 with their replicas (seeds 1, 2) (table and the
## paper's Figs 3-6 in build/demo-cg/)
demo: $(STAMP)
	@mkdir -p $(BUILD)
	$(VENV)/bin/granalytics info datasets/lab-cg3.h5
	$(VENV)/bin/granalytics stats datasets/lab-cg3.h5 --window 3:6 \
		--out $(BUILD)/demo-timeseries.csv --sizes-out $(BUILD)/demo-sizes.csv \
		--plot $(BUILD)/demo-stats.png --overwrite
	$(VENV)/bin/granalytics compare-cg datasets/lab-cg1.h5 \
		datasets/lab-cg2.h5 datasets/lab-cg2-seed1.h5 datasets/lab-cg2-seed2.h5 \
		datasets/lab-cg3.h5 datasets/lab-cg3-seed1.h5 datasets/lab-cg3-seed2.h5 \
		--replicas --window 3:6 --out $(BUILD)/demo-cg --overwrite

## notebooks: run every notebook of docs/notebooks on the bundled data, top to bottom, into
## build/notebooks/NAME.ipynb (with its outputs) and NAME.html (open it in a browser); the
## notebooks' own files are written there too. Installs the `notebooks` extra (nbconvert, ipywidgets).
NB_STAMP := $(VENV)/.installed-notebooks
NOTEBOOKS := $(wildcard docs/notebooks/*.ipynb)
$(NB_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[test,notebooks]'
	touch $(NB_STAMP)

notebooks: $(NB_STAMP)
	@mkdir -p $(BUILD)/notebooks
	cp $(NOTEBOOKS) $(BUILD)/notebooks/
	cd $(BUILD)/notebooks && $(abspath $(PY)) -m jupyter nbconvert --to notebook --execute --inplace \
		--ExecutePreprocessor.timeout=900 $(notdir $(NOTEBOOKS))
	cd $(BUILD)/notebooks && $(abspath $(PY)) -m jupyter nbconvert --to html $(notdir $(NOTEBOOKS))
	@echo "executed notebooks and their HTML in $(BUILD)/notebooks/"

## docs: the documentation site into build/docs/html (open build/docs/html/index.html): Sphinx over
## docs/ (conf.py there), the API reference from the docstrings of every public name, the notebooks
## executed on the bundled data (cached in build/docs/jupyter_cache); warnings are errors.
## Installs the `docs` extra. Offline: nothing is fetched while building.
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): $(STAMP) pyproject.toml
	$(PY) -m pip install --quiet -e '.[test,docs]'
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	$(PY) -m sphinx -b html -W --keep-going -q -j 1 docs $(BUILD)/docs/html
	@echo "documentation in $(BUILD)/docs/html/index.html"

## datasets: regenerate every bundled dataset from its recipe (simulation, then subset; hours for the
## CG1 and paper runs; an interrupted simulation resumes from its checkpoint), DATASET_JOBS at a time
## (default 2). Never downloads.
DATASET_JOBS ?= 2
datasets: $(STAMP)
	$(PY) -m granalytics.datasets make --jobs $(DATASET_JOBS)

## bench: benchmark scripts (print tables)
bench: $(STAMP)
	$(PY) benchmarks/identify.py
	$(PY) benchmarks/sensitivity.py
	$(PY) benchmarks/sim_throughput.py

## clean: build outputs (and the pages make docs writes into docs/api, docs/results) and numba's
## compiled-kernel caches (numba does not notice a change in a
## function that a cached kernel calls from another module; clean after editing sim/ or kernels).
## Keeps the simulations under build/runs and build/sweeps (hours of work that `make datasets`
## resumes from); `make clean-runs` deletes those too.
clean:
	rm -rf .pytest_cache docs/api docs/results $(filter-out $(BUILD)/runs $(BUILD)/sweeps,$(wildcard $(BUILD)/*))
	find granalytics sim tests -name '*.nbi' -o -name '*.nbc' | xargs rm -f

clean-runs: clean
	rm -rf $(BUILD)/runs $(BUILD)/sweeps
