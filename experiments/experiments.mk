# Experiment targets: see experiments/README.md. Included by the top-level Makefile.
#
#   make table1      Tables 1 and 2 (every scene x 128^3, 256^3 x every model)     results/table1/
#   make pareto      error against render time and memory, Pareto fronts            results/pareto/
#   make figures     image grids, view-angle colour, silhouette coverage, DoF       results/figures/
#   make shadows     shadow methods (march, slicemap, slicemap-model, voxel) x every model  results/shadows/
#   make dynamic     moving objects: transform (nearest/split8) vs re-bake per model  results/dynamic/
#                    (DYNAMIC_ARGS="--quick" for a CI-sized run; experiments/dynamic.py --help)
#   make crossover   where voxels pay: every model against the triangles at equal error,    results/crossover/
#                    swept over triangle count and viewing distance (experiments/crossover.json)
#   make regress     the CI subset against results/baseline.json; fails on a regression
#   make dashboard   all of the above, then results/dashboard/index.html (+ screenshot.png)
#   make dashboard-page  only the page, from whatever results exist (seconds)
#   make baseline    store the regress run as the baseline (BASELINE_EXPERIMENTS="regress table1" for both)
#   make experiments-clean-cache   delete results/cache (every cached voxlab job)
#   make test-slurm  the cluster test on a one-node SLURM cluster it brings up on localhost
#
# Variables: EXP_JOBS=2 (untimed jobs at once), FRESH=1 (recompute every job: fresh timings),
# EXP_VOXLAB=path (the binary to run; default build/voxlab; it must be built from this checkout),
# EXP_ARGS_EXTRA (e.g. "--executor dask --scheduler tcp://HOST:PORT", "--executor slurm").
# Every job is cached under results/cache by the hash of what decides its output (scene files,
# options, the sources of its code path: experiments/README.md), so a second run costs seconds and
# a change reruns only the jobs whose code path it touches.

EXP_PY := /usr/bin/python3
EXP_JOBS ?= 2
# EXP_VOXLAB: another binary, e.g. a snapshot in results/cache/bin/<hash>/voxlab, to finish a set of
# results with the binary that started it while build/voxlab is being rebuilt; a sweep refuses a
# binary older than the checkout's sources (the cache keys hash the sources, not the binary).
EXP_VOXLAB ?= $(BUILD)/voxlab
# EXP_ARGS_EXTRA: more options for every script, e.g. "--executor dask --scheduler tcp://node1:8786".
EXP_ARGS = --jobs $(EXP_JOBS) --voxlab $(EXP_VOXLAB) $(if $(filter 1,$(FRESH)),--force) $(EXP_ARGS_EXTRA)
BASELINE_EXPERIMENTS ?= regress

# chromium: tests/test_dashboard.py and the dashboard screenshot (headless); time: GNU time measures
# the ground truth's peak memory (voxlab truth's stats do not report it); python3-distributed: the
# Dask executor (--executor dask) and tests/test_cluster.py's scheduler and workers.
DEPS += chromium time python3-distributed
# python3-jsonschema: declarations are checked against experiments/declaration.schema.json;
# python3-pandas: the row and demo tables (experiments/voxlab_exp/files.py, demo.py).
DEPS += python3-jsonschema python3-pandas
# The dashboard's libraries, copied into results/dashboard/vendor/ (no network at view time):
# jQuery + tablesorter (sortable, filterable tables), Chart.js (trends over commits).
DEPS += libjs-jquery libjs-jquery-tablesorter libjs-chart.js
# Only for `make test-slurm` (and --executor slurm on a machine that is its own cluster): SLURM's
# daemons and clients, and munge for their authentication.
SLURM_DEPS = slurm-wlm munge

.PHONY: dynamic crossover table1 pareto figures shadows regress regress-run dashboard dashboard-page baseline experiments-clean-cache test-slurm

# Every target first makes sure the packages and the binary are there (as `make test` does).
define exp_prepare
	@$(MAKE) --no-print-directory deps
	@$(MAKE) --no-print-directory $(BUILD)/voxlab
endef

table1:
	$(exp_prepare)
	$(EXP_PY) experiments/table1.py $(EXP_ARGS)

# Issue 17: per-frame sequences, run by a focused script (no sweep-engine cache).
DYNAMIC_ARGS ?=
dynamic:
	$(exp_prepare)
	$(EXP_PY) experiments/dynamic.py --voxlab $(EXP_VOXLAB) $(DYNAMIC_ARGS)

pareto:
	$(exp_prepare)
	$(EXP_PY) experiments/pareto.py $(EXP_ARGS)

crossover:
	$(exp_prepare)
	$(EXP_PY) experiments/crossover.py $(EXP_ARGS)

figures:
	$(exp_prepare)
	$(EXP_PY) experiments/figures.py $(EXP_ARGS)

shadows:
	$(exp_prepare)
	$(EXP_PY) experiments/shadows.py $(EXP_ARGS)

regress:
	$(exp_prepare)
	$(EXP_PY) experiments/regress.py $(EXP_ARGS)

# The dashboard shows a regression rather than stopping at it.
regress-run:
	$(exp_prepare)
	-$(EXP_PY) experiments/regress.py $(EXP_ARGS)

dashboard: regress-run table1 figures pareto
	$(EXP_PY) experiments/dashboard.py --voxlab $(EXP_VOXLAB) --screenshot --record-history

dashboard-page:
	$(EXP_PY) experiments/dashboard.py --voxlab $(EXP_VOXLAB) --screenshot

baseline:
	$(exp_prepare)
	@for e in $(BASELINE_EXPERIMENTS); do \
	  $(EXP_PY) experiments/regress.py --experiment experiments/$$e.json --write-baseline $(EXP_ARGS) || exit 1; \
	done

experiments-clean-cache:
	rm -rf results/cache

# A one-node SLURM cluster on localhost (munged, slurmctld, slurmd; config written by the test, torn
# down after) runs the tiny declaration of tests/test_cluster.py; rows must equal the local
# executor's. As root; about a minute. Not part of `make test` (it starts system daemons).
test-slurm:
	@$(MAKE) --no-print-directory deps DEPS="$(SLURM_DEPS)"
	@$(MAKE) --no-print-directory deps
	@$(MAKE) --no-print-directory $(BUILD)/voxlab
	@t=$$(mktemp -d); VOXLAB=$(CURDIR)/$(BUILD)/voxlab TEST_TMP=$$t $(EXP_PY) tests/test_cluster.py --slurm; \
	  rc=$$?; rm -rf $$t; exit $$rc
