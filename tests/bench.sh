#!/usr/bin/env bash
# `make bench`: prints each benchmark figure as a ratio against a reference measured in the same run.
set -eu
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
"$BUILD"/tests/bench_truth scenes/bunny.json 64
