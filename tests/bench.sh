#!/usr/bin/env bash
# `make bench`: prints each benchmark figure as a ratio against a reference measured in the same run.
set -eu
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
"$BUILD"/tests/bench_truth scenes/bunny.json 64
# Bake sampler vs raw Embree on the same rays, bake times at 128^3/256^3, shading cache on/off (~25 s).
"$BUILD"/tests/bench_bake scenes/bunny.json
# vmesh (Brito et al. 2023): bunny bake time at 128^3/256^3 against targets, the paper and alpha; render
# time over alpha's with the cache on and off (medians of 3, ratios per run; ~2 min).
"$BUILD"/tests/bench_vmesh scenes/bunny.json
