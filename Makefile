# uw3p — all set-up is done here: a fresh machine with Python >= 3.10 needs only `make <target>`.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: install test test-fast test-adversarial reproduce-figures reproduce-one-core-a reproduce-one-core-b real-data dive honesty design-check bench bench-slow docs test-release clean

# each step of reproduce-figures timed into benchmarks/make_times.json (BENCHMARKS.md reads it)
STOPWATCH = $(PY) -m experiments.stopwatch --json benchmarks/make_times.json

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e ".[test]"
	OPENBLAS_NUM_THREADS=1 $(PY) -m uw3p.warm
	@touch $(STAMP)

install: $(STAMP)

# the whole suite (what CI runs), on both cores (pytest-xdist: most tests are single-threaded;
# --dist loadfile keeps each module on one worker, its module fixtures made once; loadgroup's
# xdist_group marks are ignored under pytest 9.2, pytest-xdist issue 1386; --no-loadscope-reorder
# keeps the modules in tests/conftest.py's order, the longest first, where xdist would queue them
# by their number of tests and start the one-item figure run of tests/test_experiments.py late);
# not the tests marked release (make test-release) or adversarial (make test-adversarial)
test: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder -m "not release and not adversarial"

# the packages as users get them: sdist and wheel built, twine-checked, the wheel installed alone
# in a clean venv (no experiments: decision 0082-installed-packages) running uw3p calibrate,
# measure, correct and design (its kernels compiled afresh: 4-5 minutes on 2 shared cores)
test-release: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -m release

# the edit loop: everything but the tests marked slow, on both cores as make test (about a
# minute); one BLAS thread, as in make test (BLAS threads spinning after numpy's small calls
# made the light-field searches of tests/test_wait.py take 30-40 s instead of 4)
test-fast: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n 2 --dist loadfile --no-loadscope-reorder -m "not slow and not release and not adversarial"

# the costly attacks on the dive workflow (tests/test_adversarial_dive.py: photos measured,
# runs interrupted and killed, clusters started; about 10 min on 2 cores)
test-adversarial: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n 2 -m adversarial tests/test_adversarial_dive.py

reproduce-figures: $(STAMP)
	$(STOPWATCH) "reproduce-figures: figures" -- $(VENV)/bin/uw3p figures --out figures --report REPRODUCTION.md
	OPENBLAS_NUM_THREADS=1 $(STOPWATCH) "reproduce-figures: dive_honesty" -- $(PY) -m experiments.dive_honesty
	OPENBLAS_NUM_THREADS=1 $(STOPWATCH) "reproduce-figures: design_check" -- $(PY) -m experiments.design_check
	@$(MAKE) --no-print-directory -j2 reproduce-one-core-a reproduce-one-core-b

# the steps of reproduce-figures that keep one core busy, in two streams side by side
reproduce-one-core-a: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(STOPWATCH) "reproduce-figures: honesty" -- $(PY) -m experiments.honesty

reproduce-one-core-b: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(STOPWATCH) "reproduce-figures: correct_range" -- $(PY) -m experiments.correct_range
	@if [ -d ../shared/realdata ]; then OPENBLAS_NUM_THREADS=1 $(STOPWATCH) "reproduce-figures: real-data" -- $(PY) -m experiments.realwater; \
	else echo "../shared/realdata absent: REALWATER.md not regenerated"; fi
	@if [ -d ../shared/realdata ]; then OPENBLAS_NUM_THREADS=1 $(STOPWATCH) "reproduce-figures: grey_patch" -- $(PY) -m experiments.grey_patch; \
	else echo "../shared/realdata absent: GREYPATCH.md not regenerated"; fi

# REALWATER.md: the physics against real water (NOMAD, COPS casts, G7X photos); needs
# ../shared/realdata beside the repository (exit 2 without it)
real-data: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.realwater

# DIVE.md: the joint estimate of a dive on worlds the independent renderer made, and the
# acceptance dive of whole photographs (metadata CSV, no corners, a chartless frame, rerun,
# Ctrl-C); exit 1 when a criterion fails
dive: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.dive_honesty --strict

# DESIGN.md alone: the designs of `uw3p design` (C to +-30 %, coastal and clear water, and issue
# 47's with a reference shot) rendered by the independent renderer in worlds they did not assume
# (water 0.3-3x the guess, daylight drawn, beam and split paths, a nuisance beyond its budget)
# and fitted jointly; exit 1 when a criterion fails
design-check: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.design_check --strict

# HONESTY.md alone: the estimator on worlds an independent renderer made (exit 1 when an
# acceptance criterion fails; the report says which)
honesty: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.honesty --strict

# one BLAS thread: every fit is tiny, and idle BLAS threads spinning after numpy's small
# matrix calls steal the second core from the batched solver's numba threads
bench: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.benchmark

# the slower studies BENCHMARKS.md reports from the JSON files they write (each names its
# command): the default batch against commit ffa6454 side by side, the first `uw3p measure`
# after a fresh install, the joint fit counted by step; then `make bench`
bench-slow: $(STAMP)
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.compare_commits ffa6454 WORKTREE --workload default --batch 1000,120 --rounds 3 --json benchmarks/compare_default.json
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.cold_start --json benchmarks/cold_start.json
	OPENBLAS_NUM_THREADS=1 $(PY) -m experiments.joint_bench --profile --json benchmarks/joint_profile.json
	$(MAKE) bench

clean:
	rm -rf figures cache .pytest_cache

# the documentation site -> docs/_build/html (warnings are errors): the gallery's figures made
# on the reduced grid first (a minute), unless UW3P_FIGURES names a folder of figures
DOCS_STAMP := $(VENV)/.docs-stamp
$(DOCS_STAMP): $(STAMP)
	$(PY) -m pip install --quiet --disable-pip-version-check -e ".[test,docs]"
	@touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	@if [ -z "$(UW3P_FIGURES)" ]; then OPENBLAS_NUM_THREADS=1 $(VENV)/bin/uw3p figures --grid reduced --setting default --out docs/_build/figures --cache docs/_build/cache; fi
	UW3P_FIGURES=$${UW3P_FIGURES:-docs/_build/figures} $(PY) -m sphinx -W --keep-going -b html docs docs/_build/html
