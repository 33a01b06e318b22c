# Everything runs inside .venv, built from pyproject.toml with a Python >= 3.12.
PYTHON ?= $(shell command -v python3.12 || ls -d $${PYENV_ROOT:-$$HOME/.pyenv}/versions/3.12*/bin/python 2>/dev/null | tail -n 1 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
BENCH_STAMP := $(VENV)/.bench-installed

.PHONY: setup demo reports test test-slow bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 12) else "bayescal needs Python >= 3.12, found " + sys.version.split()[0])'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	@touch $(STAMP)

# The main job: the compensator geometry from the paper's Table I, a Table III campaign
# on the digital twin identified with that geometry posterior, a campaign designed for
# the test pose, the critique of the model on the campaign, and the review page of all.
# Two steps run at once where neither needs the other's files (the plan beside the geometry,
# the critique beside the calibration); each step's output is printed whole when it ends.
DEMO_JOBS ?= 2

demo: $(STAMP)
	@mkdir -p build
	@$(MAKE) --no-print-directory -f $(firstword $(MAKEFILE_LIST)) -j$(DEMO_JOBS) --output-sync=target demo-report

.PHONY: demo-geometry demo-campaign demo-calibration demo-plan demo-critique demo-report

demo-geometry:
	$(BIN)/bayescal geometry data/table1_geometry.csv --posterior build/geometry_posterior.nc

demo-campaign:
	$(BIN)/bayescal simulate --plan data/table3_plan.csv --config data/kr270.toml --repeats 3 --seed 1 -o build/campaign.csv

demo-calibration: demo-geometry demo-campaign
	$(BIN)/bayescal calibrate build/campaign.csv --config data/kr270.toml --geometry build/geometry_posterior.nc --posterior build/elastostatic_posterior.nc

demo-plan:
	$(BIN)/bayescal plan --config data/kr270.toml --model linear --workers 1 -o build/plan.csv --json > build/plan.json

demo-critique: demo-campaign
	$(BIN)/bayescal critique build/campaign.csv --config data/kr270.toml --json > build/critique.json

# The plan first: the longest step needing nothing, started beside the geometry; its starts in one process, since make
# runs the steps two at a time already (the geometry, on the way to the calibration, would wait for a forked start).
demo-report: demo-plan demo-calibration demo-critique
	$(BIN)/bayescal report --geometry build/geometry_posterior.nc --calibration build/elastostatic_posterior.nc \
	    --campaign build/campaign.csv --config data/kr270.toml --plan build/plan.json --critique build/critique.json -o build/report

# Regenerate the committed reports from the code and the data (python -m bayescal_studies reports --help): the
# research package beside bayescal, run in place, never imported by it.
reports: $(STAMP)
	$(BIN)/python -m bayescal_studies reports reports

# One pytest worker per core (pytest-xdist): the tests are independent.  On the 2-core development
# machine two workers spent 115 s of CPU in all against 105 s for one process.
test: $(STAMP)
	$(BIN)/python -m pytest -q -n auto

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

$(BENCH_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[test,bench]'
	@touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	@for script in benchmarks/bench_*.py; do echo "== $$script"; $(BIN)/python $$script || exit 1; done

clean:
	rm -rf $(VENV) .pytest_cache build
