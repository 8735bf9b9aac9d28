# boundid — every target installs what it needs: `make report` and `make test` work on a fresh clone.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
# the lock for this Python (3.11 or 3.12; Linux x86-64): exact versions with hashes, made by `make lock`
PYV    := $(shell $(PYTHON) -c 'import sys; print("%d%d" % sys.version_info[:2])')
LOCK   := requirements/lock-py$(PYV).txt
UV     := build/uv/bin/uv
# two workers: the machines have 2 cores; one BLAS/numba thread each, or they oversubscribe them
THREADS := OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1
PYTEST := $(THREADS) $(BIN)/pytest -n 2 -q

.PHONY: install lock test test-all test-latest test-platforms platforms-report bench report lint teach campaign test-browser mutation docs clean

# installs exactly the lock (pip refuses a package without its pinned hash), then boundid itself, without dependencies
$(STAMP): pyproject.toml $(LOCK)
	@test -f $(LOCK) || (echo "no lock for Python $(PYV): boundid is locked for 3.11 and 3.12; run with PYTHON=python3.11" && exit 2)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --require-hashes -r $(LOCK)
	$(BIN)/python -m pip install -q --no-deps --no-build-isolation -e .
	touch $(STAMP)

install: $(STAMP)

# regenerate the locks from pyproject.toml's ranges (newest versions they allow, today), with uv pinned here
lock:
	test -x $(UV) || ($(PYTHON) -m venv build/uv && build/uv/bin/python -m pip install -q uv==0.13.8)
	for v in 3.11 3.12; do \
	  $(UV) pip compile pyproject.toml requirements/build.in --extra dev --extra docs --generate-hashes --no-header \
	    --python-version $$v --python-platform x86_64-manylinux_2_28 \
	    -o requirements/lock-py$$(echo $$v | tr -d .).txt || exit 1; \
	done

# the drift check: a separate environment with the newest releases pyproject.toml's ranges allow, the fast suite
test-latest:
	rm -rf .venv-latest && $(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install -q --upgrade -e '.[dev]'
	$(THREADS) .venv-latest/bin/pytest -n 2 -q -p no:cacheprovider -m "not slow and not browser"

test: $(STAMP)
	$(PYTEST) -m "not slow and not browser"

test-all: $(STAMP)
	$(PYTEST) -m "not browser"

# the sets and estimators tests under the OpenBLAS kernels Prescott, Nehalem, Sandybridge, Haswell and SkylakeX
# (a kernel this CPU cannot run is skipped, saying why), then the compiled kernels' tests with numba's JIT off
test-platforms: $(STAMP)
	$(BIN)/python tools/platforms.py test

# every study under two OpenBLAS kernels (Haswell and this CPU's own), results.csv compared: verdicts identical,
# numbers within boundid.report.study_page.PLATFORM_RTOL; writes reports/benchmarks/platforms.md (not in CI)
platforms-report: $(STAMP)
	$(BIN)/python tools/platforms.py compare

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

# docs/study-files.md, every study-file key, generated from the study-file parser (tests/test_docs.py checks it),
# then the documentation site: Sphinx (docs/site/, the `docs` extra of the lock) into reports/docs/, built
# from scratch with every warning an error (a broken reference to a boundid name, a public name without a
# docstring); the API pages' stubs are generated into docs/site/api/generated/ (not in git); the lessons run first
# as notebooks in fresh kernels (fast settings; a cell that raises fails the build) and the site renders them
docs: $(STAMP)
	$(BIN)/python -m boundid.docs --out docs/study-files.md
	rm -rf reports/docs docs/site/api/generated build/docs-doctrees build/docs-lessons docs/site/lessons/notebooks build/docs-site
	$(BIN)/boundid teach --fast --out build/docs-lessons
	mkdir -p docs/site/lessons/notebooks && cp build/docs-lessons/teaching/*/*.ipynb docs/site/lessons/notebooks/
	$(THREADS) $(BIN)/python -m sphinx -b html -E -W --keep-going -q -j 2 -d build/docs-doctrees docs/site build/docs-site/html
	cp -r build/docs-site/html reports/docs  # built beside, not in, reports/: myst-nb writes a jupyter_execute/ next to its output
	$(BIN)/python -c "from boundid.report.html import write_site_index; write_site_index('reports')"  # links the site

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
	rm -rf $(VENV) .venv-latest .pytest_cache build src/*.egg-info
