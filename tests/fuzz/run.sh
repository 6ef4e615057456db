#!/usr/bin/env bash
# `make fuzz FUZZ_SECONDS=N`: runs each libFuzzer harness (tests/fuzz/fuzz_*.c, built into
# $FUZZ_BUILD/fuzz/ by `make fuzz-build`) for N seconds, then the experiment-declaration mutation
# loop (tests/fuzz/fuzz_declaration.py) for N seconds. Seeds come from the shipped scenes and the
# test fixtures (plus small bakes and images made with build/voxlab); what a run discovers is kept
# in build/fuzz/corpus/ for the next. A crash, a sanitizer report, a leak or a timeout fails the run
# and leaves the reproducer in build/fuzz/crashes/ (replay: $FUZZ_BUILD/fuzz/fuzz_NAME FILE).
# Prints one line per harness: seconds, executions, edges covered (cov) and crashes.
# FUZZ_TIMEOUT=S (default 10) is the seconds one input may take: long runs beside other work use more,
# so that a loaded machine is not reported as a hang. Slow units (-report_slow_units) are listed in
# crashes/ by libFuzzer but are not failures: crash-, timeout-, oom- and leak- files are.
# FUZZ_ONLY=name runs one harness (scene, ply, obj, gltf, vox, image, declaration). FUZZ_SEEDED=1 keeps
# the seeds of an earlier run, so that harnesses can run side by side (FUZZ_ONLY each) on one seeding.
set -u
cd "$(dirname "$0")/../.."
REPO=$PWD
N=${FUZZ_SECONDS:-60}
FB=${FUZZ_BUILD:-build-fuzz}
VOXLAB=${VOXLAB:-$REPO/build/voxlab}
OUT=$REPO/build/fuzz
mkdir -p "$OUT/crashes" "$OUT/corpus" "$OUT/seeds" "$OUT/logs"
export VOXLAB_FUZZ_FIXTURES=$REPO/tests/data
export VOXLAB_FUZZ_VOX_SCENE=$REPO/tests/fuzz/vox_scene.json
export VOXLAB_LIBRARY_STDERR=1 # sanitizer reports from inside the image readers must not be swallowed
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}
# Leaks inside system libraries that voxlab cannot fix (see the file); full stacks so they match.
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$REPO/tests/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# ---- seed corpora (rebuilt every run: cheap, and always from the current formats) ----
if [ "${FUZZ_SEEDED:-0}" != 1 ]; then
seed() { # name, files...
  local d=$OUT/seeds/$1; shift
  rm -rf "$d" && mkdir -p "$d"
  for f in "$@"; do [ -f "$f" ] && cp "$f" "$d/"; done
}
seed scene scenes/*.json tests/fuzz/vox_scene.json tests/fuzz/instances_scene.json experiments/*.json
# fuzz_scene skips the height field at its default 512^2 (see there): seed it at 32^2 instead.
sed 's/"generator": "heightfield",/"generator": "heightfield", "params": {"resolution": 32},/' scenes/heightfield.json \
  >"$OUT/seeds/scene/heightfield_32.json"
seed ply tests/data/*.ply
seed obj tests/data/*.obj
seed gltf tests/data/*.gltf tests/data/*.glb
seed declaration experiments/*.json
mkdir -p "$OUT/seeds/vox" "$OUT/seeds/image"
rm -f "$OUT/seeds/vox/"* "$OUT/seeds/image/"*
for m in binary alpha vmesh heitz-neyret; do
  for r in 2 5 8; do
    "$VOXLAB" bake tests/fuzz/vox_scene.json --model "$m" --res $r --rays 8 -o "$OUT/seeds/vox/$m-$r.vox" >/dev/null 2>&1 ||
      echo "fuzz: could not bake a .vox seed ($m, $r) with $VOXLAB" >&2
  done
done
# Image seeds: the first byte picks the extension in fuzz_image.c (0 png, 1 exr, 3 pfm).
tmp=$(mktemp -d)
for sz in 4x4 12x12; do
  "$VOXLAB" truth tests/fuzz/vox_scene.json --spp 1 --size $sz -o "$tmp/a.png" >/dev/null 2>&1 &&
    { printf '\000'; cat "$tmp/a.png"; } >"$OUT/seeds/image/png_$sz"
  "$VOXLAB" truth tests/fuzz/vox_scene.json --spp 1 --size $sz -o "$tmp/a.exr" >/dev/null 2>&1 &&
    { printf '\001'; cat "$tmp/a.exr"; } >"$OUT/seeds/image/exr_$sz"
done
{ printf '\003PF\n2 2\n-1.0\n'; head -c 48 /dev/zero; } >"$OUT/seeds/image/pfm_2x2"
rm -rf "$tmp"
fi

# ---- the harnesses ----
status=0
run_one() { # name, extra libFuzzer flags...
  local name=$1; shift
  case "$name" in *"${FUZZ_ONLY:-}"*) ;; *) return ;; esac
  local bin=$FB/fuzz/fuzz_$name log=$OUT/logs/$name.log
  mkdir -p "$OUT/corpus/$name"
  local before
  before=$(ls "$OUT/crashes" | grep -cE "^$name-(crash|timeout|oom|leak)-")
  local start=$SECONDS
  # -rss_limit_mb/-malloc_limit_mb: an input that makes a loader allocate gigabytes is a finding
  # (the loaders must bound what a file can ask for), as is one that runs past -timeout seconds.
  nice "$bin" "$OUT/corpus/$name" "$OUT/seeds/$name" -max_total_time="$N" -timeout="${FUZZ_TIMEOUT:-10}" -rss_limit_mb=2560 \
    -malloc_limit_mb=2048 -artifact_prefix="$OUT/crashes/$name-" -print_final_stats=1 "$@" >"$log" 2>&1
  local rc=$?
  local execs cov ft crashes
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  crashes=$(($(ls "$OUT/crashes" | grep -cE "^$name-(crash|timeout|oom|leak)-") - before))
  printf 'fuzz %-12s %5ds  %10s execs  cov %6s  ft %6s  crashes %d\n' "$name" $((SECONDS - start)) "${execs:-?}" \
    "${cov:-?}" "${ft:-?}" "$crashes"
  if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    status=1
    echo "fuzz $name FAILED (status $rc); reproducers in $OUT/crashes/$name-*; log $log:"
    grep -E 'ERROR|SUMMARY|runtime error|#[0-9]+ 0x' "$log" | head -30 | sed 's/^/    /'
  fi
}
run_one scene -dict=tests/fuzz/json.dict -max_len=65536
run_one ply -dict=tests/fuzz/ply.dict -max_len=65536
run_one obj -dict=tests/fuzz/obj.dict -max_len=65536
run_one gltf -dict=tests/fuzz/json.dict -max_len=65536
run_one vox -max_len=262144
ASAN_OPTIONS=$ASAN_OPTIONS:fast_unwind_on_malloc=0 run_one image -max_len=65536
case declaration in *"${FUZZ_ONLY:-}"*)
  start=$SECONDS
  /usr/bin/python3 tests/fuzz/fuzz_declaration.py --seconds "$N" --seeds "$OUT/seeds/declaration" \
    --crashes "$OUT/crashes" >"$OUT/logs/declaration.log" 2>&1
  rc=$?
  printf 'fuzz %-12s %5ds  %s\n' declaration $((SECONDS - start)) "$(tail -1 "$OUT/logs/declaration.log")"
  [ "$rc" -eq 0 ] || { status=1; tail -20 "$OUT/logs/declaration.log" | sed 's/^/    /'; }
  ;;
esac
exit $status
