# uw3p — all set-up is done here: a fresh machine with Python >= 3.10 needs only `make <target>`.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: install test test-fast reproduce-figures real-data dive honesty bench clean

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e ".[test]"
	OPENBLAS_NUM_THREADS=1 $(PY) -m uw3p.warm
	@touch $(STAMP)

install: $(STAMP)

# the whole suite (what CI runs), on both cores (pytest-xdist: most tests are single-threaded)
test: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n 2

# the edit loop: everything but the tests marked slow (at most a minute on 2 cores)
test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow"

reproduce-figures: $(STAMP)
	$(VENV)/bin/uw3p figures --out figures --report REPRODUCTION.md
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.honesty
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.dive_honesty
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.correct_range
	@if [ -d ../shared/realdata ]; then $(MAKE) real-data; \
	else echo "../shared/realdata absent: REALWATER.md not regenerated"; fi

# REALWATER.md: the physics against real water (NOMAD, COPS casts, G7X photos); needs
# ../shared/realdata beside the repository (exit 2 without it)
real-data: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.realwater

# DIVE.md: the joint estimate of a dive on worlds the independent renderer made, and the
# acceptance dive of whole photographs (metadata CSV, no corners, a chartless frame, rerun,
# Ctrl-C); exit 1 when a criterion fails
dive: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.dive_honesty --strict

# HONESTY.md alone: the estimator on worlds an independent renderer made (exit 1 when an
# acceptance criterion fails; the report says which)
honesty: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.honesty --strict

# one BLAS thread: every fit is tiny, and idle BLAS threads spinning after numpy's small
# matrix calls steal the second core from the batched solver's numba threads
bench: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.benchmark

clean:
	rm -rf figures cache .pytest_cache
