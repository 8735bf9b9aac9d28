# boundid — every target installs what it needs: `make report` and `make test` work on a fresh clone.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
# two workers: the machines have 2 cores; one BLAS/numba thread each, or they oversubscribe them
THREADS := OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1
PYTEST := $(THREADS) $(BIN)/pytest -n 2 -q

.PHONY: install test test-all bench report lint teach campaign test-browser mutation docs clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(PYTEST) -m "not slow and not browser"

test-all: $(STAMP)
	$(PYTEST) -m "not browser"

lint: $(STAMP)
	$(BIN)/ruff check src tests studies/teaching studies/examples

bench: $(STAMP)
	$(BIN)/boundid bench

# mutation testing, not part of `make test`: cosmic-ray over a seeded sample of sets/, estimators/
# and the regression builders (tools/mutation.toml), judged by each module's fast tests on 2 workers; resumes
# an interrupted run; writes reports/benchmarks/mutation.md from the session databases (~40 min on 2 cores)
mutation: $(STAMP)
	$(BIN)/python tools/mutation.py run
	$(BIN)/python tools/mutation.py report

report: $(STAMP)
	$(BIN)/boundid report

# Monte Carlo campaign of the direct-drive study: 20 replicates of each noise scenario (resumable)
campaign: $(STAMP)
	$(BIN)/boundid campaign studies/direct_drive_rls.toml --replicates 20 --workers 2

# docs/study-files.md, every study-file key, generated from the study-file parser (tests/test_docs.py checks it)
docs: $(STAMP)
	$(BIN)/python -m boundid.docs --out docs/study-files.md

# the lessons in studies/teaching, one self-contained handout each in reports/teaching/
teach: $(STAMP)
	$(BIN)/boundid teach

# the browser check on pages with known defects, then every reports/**/index.html in headless Chromium
# at 1400 px: fails on a broken image, a script error, a table wider than its box without a scroll cue,
# a stepper that does not step; screenshots (first screen and whole page) go to build/screenshots/
test-browser: $(STAMP)
	command -v chromium >/dev/null || (apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends chromium)
	$(PYTEST) -m browser tests/test_browser.py
	$(BIN)/python tests/browser_check.py reports --shots build/screenshots

clean:
	rm -rf $(VENV) .pytest_cache build src/*.egg-info
