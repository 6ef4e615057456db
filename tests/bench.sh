#!/usr/bin/env bash
# `make bench`: prints each benchmark figure as a ratio against a reference measured in the same run.
set -eu
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
# Each benchmark is printed between the machine's load averages (1, 5 and 15 minutes) before and
# after it: the machines are shared, and a figure taken under load must be told apart from a quiet one.
load() { cut -d' ' -f1-3 /proc/loadavg; }
bench() {
  echo "== ${1##*/} ${*:2}: load average $(load) before"
  "$@"
  echo "== ${1##*/}: load average $(load) after"
}
bench "$BUILD"/tests/bench_truth scenes/bunny.json 64
# Bake sampler vs raw Embree on the same rays, bake times at 128^3/256^3, shading cache on/off, every
# model baked in one pass of the sampler over one by one (~40 s).
bench "$BUILD"/tests/bench_bake scenes/bunny.json
# vmesh (Brito et al. 2023): bunny bake time at 128^3/256^3 against targets, the paper and alpha; render
# time over alpha's with the cache on and off (medians of 3, ratios per run; ~2 min).
bench "$BUILD"/tests/bench_vmesh scenes/bunny.json
# heitz-neyret (Heitz & Neyret 2012): bunny render CPU time over alpha's at 256^3 (target <= 1.5x), us per
# pixel per core, and the depth-of-field render over the focused one (interleaved medians of 5; ~1 min).
bench "$BUILD"/tests/bench_hn scenes/bunny.json 256
# OpenCL on PoCL: render time over the C backend's for every model (bunny and spheres, 128^3, 256x256,
# 4 spp; medians of 5 alternating runs, compile time apart; ~1 min).
bench "$BUILD"/tests/bench_opencl scenes/bunny.json
bench "$BUILD"/tests/bench_opencl scenes/spheres.json
# The same at 256^3 on bunny and city, the grids the paper's 37 ms are for (issue 15): on a GPU each
# frame is printed against it, with march and with the shadows precomputed per voxel (~2 min on PoCL).
bench "$BUILD"/tests/bench_opencl scenes/bunny.json 256
bench "$BUILD"/tests/bench_opencl scenes/city.json 256
# Precomputed shadows (issue 18): every model's frame time with slicemap-model over march, same run,
# bunny 256^3, 256x256, 4 spp (medians of 5 interleaved; also without the shading cache; ~5 min).
bench "$BUILD"/tests/bench_shadows scenes/bunny.json 256 256 5
# Frame times (issue 15): every model at bunny 256^3 against 50 ms, binary over the 4-spp truth, growth
# per doubling of the grid up to 1024^3, binary's 2-thread speed-up on city, render --vox's grid from the
# file's cells over voxelising at 1024^3, every model's frame on city and trees at 256^3 over the truth's,
# and the per-voxel models' frames with their shadows precomputed per voxel (--shadows voxel, Brito et
# al.'s protocol) beside (medians; ~4 min).
bench "$BUILD"/tests/bench_frame scenes/bunny.json scenes/city.json 1024 scenes/trees.json
# Moving objects (issue 17): transforming the records of 1 and 256 moving tori (split8) over re-baking
# them as posed, per object, 128^3, every model with transform/combine (medians of 5 frames; ~3 min).
dyn_tmp=$(mktemp -d)
for n in 1 256; do
  /usr/bin/python3 scenes/dynamic.py --objects $n -o "$dyn_tmp/dynamic_$n.json"
  bench "$BUILD"/tests/bench_dynamic "$dyn_tmp/dynamic_$n.json" 128
done
rm -rf "$dyn_tmp"
