# tzsl developer entry points. Every target installs what it needs into $(VENV) itself.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
SHARED_DATA := $(abspath ../shared/data)
# Point tzsl at the shared real data when it sits beside the checkout.
ifneq ($(wildcard $(SHARED_DATA)),)
export TZSL_DATA_DIR ?= $(SHARED_DATA)
endif
RESULTS ?= results
# output folder of `make evidence` (what goes beyond the papers)
EVIDENCE ?= $(RESULTS)/evidence
# stage-2 output folder of experiments/benchmarks/phac2_accuracy.py (accuracy.csv, grid_summary.csv)
BENCH_RESULTS ?= /tmp/tzsl_accuracy
# output folder of experiments/benchmarks/phac2_search.py (search_summary_*.csv)
SEARCH_RESULTS ?= /tmp/tzsl_search
N_JOBS ?= 2
# pytest-xdist workers of `make test`: the suite is mostly single-threaded, so two workers halve it on CI's 2 cores.
TEST_WORKERS ?= 2

.PHONY: install install-core browser lint lock test test-wide test-last-bit evidence benchmark benchmark-defaults physiclear reproduce-tables readme-results numbers numbers-check docs bench bench-evidence bench-fit bench-predict bench-scale data clean

$(BIN)/activate:
	$(PYTHON) -m venv $(VENV)

# The locked environment (requirements/*.lock.txt, written by `make lock`): every published number is generated
# in it, and its manifest records the versions that ran (docs/user_guide/reproducing.md#the-locked-environment).
CORE_LOCK := requirements/core.lock.txt
DEV_LOCK := requirements/dev.lock.txt
# the lock tool of `make lock`
UV_VERSION := 0.13.8

# Locked installs go through uv (the same wheels as pip, in seconds where pip takes minutes on CI's machine).
# uv reads no pip configuration, so the one pip would use is handed over: its index,
# extra indexes, local wheel folders and constraints (`pip config get`, PIP_FIND_LINKS), every index searched for
# the best version as pip does (--index-strategy unsafe-best-match), certificates from the system's store.
define uv_install
	pipcfg() { $(BIN)/pip config get global.$$1 2>/dev/null || true; }; \
	  index="$$(pipcfg index-url)"; extra="$$(pipcfg extra-index-url)"; links="$$(pipcfg find-links) $${PIP_FIND_LINKS:-}"; \
	  constraint="$$(pipcfg constraint)"; \
	  $(BIN)/uv pip install --quiet --python $(BIN)/python --native-tls --index-strategy unsafe-best-match \
	    $${index:+--index-url "$$index"} $$(for u in $$extra; do echo "--extra-index-url $$u"; done) \
	    $$(for f in $$links; do echo "--find-links $$f"; done) $${constraint:+--constraint "$$constraint"} $(1)
endef

# The core package alone, at the locked versions: all that reproduce-tables, evidence and the number blocks
# need (no torch, no test extras).
$(VENV)/.installed-core: pyproject.toml $(CORE_LOCK) $(BIN)/activate
	$(BIN)/pip install --quiet uv==$(UV_VERSION)
	$(call uv_install,-r $(CORE_LOCK))
	$(call uv_install,--no-deps -e .)
	touch $@

# Everything: the test, Dask, docs and lint extras at the locked versions, and the deep extra (torch, pinned
# exactly in pyproject.toml; torch's own dependencies are not in the lock), for the test suite and the docs.
$(VENV)/.installed: $(VENV)/.installed-core $(DEV_LOCK)
	$(call uv_install,-r $(DEV_LOCK))
	$(call uv_install,-c $(DEV_LOCK) -e '.[deep]')
	touch $@

install-core: $(VENV)/.installed-core

install: $(VENV)/.installed

# Headless Chromium for the report layout test (Debian's package), installed when missing and apt-get
# can be used; without it that test is skipped locally and fails under CI.
browser:
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; } \
	  || echo "make: chromium is not installed; the report layout test needs it"

# Ruff (every Python file) and mypy (the package), configured in pyproject.toml; make test runs it first.
lint: install
	$(BIN)/ruff check .
	$(BIN)/mypy

# --dist loadfile: a file's tests share a worker, so the docs build (tests/test_docs.py) is made once and no
# worker waits for it (the locked pytest and pytest-xdist ignore xdist_group marks).
test: install browser lint
	$(BIN)/pytest -q -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder

# Resolve the locks again from pyproject.toml (CPython 3.11 on this platform, the versions the index serves
# today); then run reproduce-tables and `make numbers`, and say in CHANGELOG.md what moved.
lock: $(BIN)/activate
	$(BIN)/pip install --quiet uv==$(UV_VERSION)
	$(BIN)/uv pip compile pyproject.toml --python-version 3.11 --upgrade --no-header --annotation-style line \
	  -o $(CORE_LOCK)
	$(BIN)/uv pip compile pyproject.toml --extra test --extra dask --extra docs --extra lint -c $(CORE_LOCK) \
	  --python-version 3.11 --upgrade --no-header --annotation-style line -o $(DEV_LOCK)

# The property tests over their full range (opt-in, many minutes on two cores): the template on datasets of
# 8-100 classes, 3-40 attributes, 1-3 sensors, merged rows and real-data pathologies (the 100 x 40 x 3 corner
# always), and every registered method on lab-like data (constant channels, huge/tiny scales, separable
# attributes, one trial per class, identical rows) with more examples than CI draws.
test-wide: install
	TZSL_WIDE_PROPERTY_TEST=1 $(BIN)/pytest -q -p no:cacheprovider tests/studies/test_zero_shot_study.py \
	  tests/models/test_methods_on_lab_data.py -k "full_range or lab_like"

# The last-bit test over every paper study (tests/studies/test_last_bit.py, which make test skips for CI's time):
# reproduce-tables three times on the real data, several minutes on two cores.
test-last-bit: install
	TZSL_LAST_BIT_ALL=1 $(BIN)/pytest -q -p no:cacheprovider tests/studies/test_last_bit.py

# The papers' data into the data home (or TZSL_DATA_DIR), downloaded and checked against the registry (the
# catalog's public datasets, e.g. biotac-slide, are fetched by name or on first use).
data: install-core
	$(BIN)/tzsl data fetch phac2 fabric gelsight_press

# What the two papers report, with our intervals, chance, baselines and controls, and nothing else
# (the built-in phac2-dap, fabric, hand-simulated): the core package only.
reproduce-tables: install-core
	$(BIN)/tzsl reproduce-tables --out $(RESULTS) --n-jobs $(N_JOBS) --force

# What goes beyond the papers (tzsl.studies.reproduce.EVIDENCE_STUDIES): every method on random and
# challenging splits of every dataset (method_comparison.csv), the generic zero-shot presets, GZSL,
# calibration, active touch and PHAC-2 on 50 random splits. Tens of minutes cold on two cores
# (docs/user_guide/reproducing.md); the fit store makes reruns quick.
evidence: install-core
	$(BIN)/tzsl evidence --out $(EVIDENCE) --n-jobs $(N_JOBS) --force

# The tactile zero-shot benchmark (docs/user_guide/benchmark.md): every registered method on every catalog dataset's
# standard confirmation splits; fetches the public datasets on first use; the study cache makes reruns quick. Exit
# code 1 (every table written; some (split, method) fits could not run, e.g. ESZSL's class-grouped folds on a split
# with 2 distinct training rows: NaN, the reasons in each manifest) goes on; any other error stops.
BENCHMARK ?= $(RESULTS)/benchmark
benchmark: install-core
	$(BIN)/tzsl benchmark --out $(BENCHMARK) --n-jobs $(N_JOBS) --force || [ $$? -eq 1 ]

# The defaults chosen across datasets (docs/user_guide/benchmark.md): the benchmark on the selection splits, then
# on the confirmation splits with the defaults chosen leaving one dataset out and DAP with detector = "auto" beside
# (its only fits beyond make benchmark's, read back from the fit store); the docs' leaderboard reads this folder.
BENCHMARK_SELECT ?= $(RESULTS)/benchmark-select
BENCHMARK_DEFAULTS ?= $(RESULTS)/benchmark-defaults
benchmark-defaults: install-core
	$(BIN)/tzsl benchmark --purpose select --out $(BENCHMARK_SELECT) --n-jobs $(N_JOBS) --force || [ $$? -eq 1 ]
	$(BIN)/tzsl benchmark --defaults $(BENCHMARK_SELECT) --out $(BENCHMARK_DEFAULTS) --n-jobs $(N_JOBS) --force \
	  || [ $$? -eq 1 ]

# The fabric paper's pipeline on PhysiCLeAR's unseen objects (docs/user_guide/dataset_catalog.md): the key-frame
# descriptors with the embedding model's lambda grid, ESZSL, SAE and DAP, and the CNN + LSTM (the deep extra).
PHYSICLEAR ?= $(RESULTS)/physiclear
physiclear: install
	$(BIN)/tzsl run physiclear --out $(PHYSICLEAR)/zero-shot --n-jobs $(N_JOBS) --force
	$(BIN)/tzsl run physiclear-deep --out $(PHYSICLEAR)/deep --force

# Every published number is generated between markers from the CSVs of the shipped code, never
# typed (tzsl.reporting.readme_results): each entry is FILE[:BLOCK]=FOLDER, the results folder that
# block (default: every block of the file) reads. The evidence blocks are left as they are (with a
# note) while $(EVIDENCE) does not exist.
NUMBERS := README.md:readme=$(RESULTS) README.md:evidence=$(EVIDENCE) README.md:detectors=$(EVIDENCE) \
	docs/user_guide/reproducing.md:results-evidence=$(EVIDENCE) \
	experiments/benchmarks/README.md=$(BENCH_RESULTS) \
	docs/user_guide/datasets.md:features-axis-benchmark=$(BENCH_RESULTS) \
	docs/user_guide/performance.md=$(SEARCH_RESULTS) \
	docs/user_guide/benchmark.md:leaderboard=$(BENCHMARK_DEFAULTS) \
	docs/user_guide/dataset_catalog.md:physiclear-pipeline=$(PHYSICLEAR)
# readme_results arguments of one NUMBERS entry (in $$pair): FOLDER FILE [--block BLOCK]
NUMBERS_ARGS = $${pair\#*=} $${target%%:*} $$([ "$${target\#*:}" = "$$target" ] || echo --block $${target\#*:})

# The README's papers block alone, from the CSVs of reproduce-tables.
readme-results: install-core
	$(BIN)/python -m tzsl.reporting.readme_results $(RESULTS) README.md --block readme

numbers: install-core
	@for pair in $(NUMBERS); do target=$${pair%%=*}; \
	  $(BIN)/python -m tzsl.reporting.readme_results $(NUMBERS_ARGS) || exit 1; done

# Fails when a generated block drifts from its CSVs or a measured number is typed outside the blocks.
numbers-check: install-core
	@status=0; for pair in $(NUMBERS); do target=$${pair%%=*}; \
	  $(BIN)/python -m tzsl.reporting.readme_results $(NUMBERS_ARGS) --check || status=1; done; \
	$(BIN)/python -m tzsl.reporting.typed_numbers . || status=1; exit $$status

# The documentation site (Sphinx): docs/_build/html, offline; runs every gallery example.
docs: install
	$(BIN)/python -m sphinx -b html -W --keep-going docs docs/_build/html

# Every speed goal of issue 33 beside its measurement (tzsl.benchmarks.goals), in one table printed and
# written to $(BENCH_CSV): reproduce-tables cold (an empty TZSL_CACHE_DIR) and warm (run again), per study
# and stage; the template on a SIMULATED 41-object, 2,549-grasp, 3-finger dataset, cold and warm; tzsl
# predict of one grasp cold and per grasp through tzsl.inference.Recogniser (SIMULATED); every wall time
# also over one PHAC-2 split's attribute fits (tzsl bench --skip-literal) timed in the same run.
# One part: make bench BENCH_ARGS="--only predict" (reproduce, template, predict, evidence; repeatable).
BENCH_CSV ?= bench/bench.csv
BENCH_ARGS ?=
bench: install-core
	$(BIN)/python -m tzsl.benchmarks.bench_goals --n-jobs $(N_JOBS) --out $(BENCH_CSV) --force $(BENCH_ARGS)

bench-predict: install-core
	$(BIN)/python -m tzsl.benchmarks.bench_goals --only predict --out bench/predict_bench.csv --force

# tzsl evidence cold and warm against its goals (tens of minutes cold; not part of make bench).
bench-evidence: install-core
	$(BIN)/python -m tzsl.benchmarks.bench_goals --only evidence --n-jobs $(N_JOBS) --out bench/evidence_bench.csv --force

# One PHAC-2 split's attribute fits (issue 15): the paper's literal recipe vs tzsl; the literal recipe
# takes tens of minutes (BENCH_FIT_ARGS=--skip-literal times tzsl only).
BENCH_FIT_ARGS ?=
bench-fit: install
	$(BIN)/tzsl bench $(BENCH_FIT_ARGS)

# Cost against trials on SIMULATED data (issue 15); e.g. make bench-scale SCALE_SIZES=1000,4000 for a quick run;
# make bench-scale SCALE_SIZES=1000000 BACKEND=dask: a million trials on a local Dask cluster of N_JOBS workers
# (issue 22), with each worker's peak memory.
SCALE_SIZES ?= 1000,4000,16000,64000,100000
BACKEND ?= loky
bench-scale: install
	$(BIN)/python -m tzsl.benchmarks.bench_scale --sizes $(SCALE_SIZES) --n-jobs $(N_JOBS) --backend $(BACKEND) --work bench_scale

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis $(RESULTS) .tzsl_cache bench_scale bench
