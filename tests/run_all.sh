#!/usr/bin/env bash
# Runs every test: C unit tests (build/tests/unit_*), shell tests (tests/test_*.sh) and Python tests
# (tests/test_*.py, under /usr/bin/python3 for numpy and scikit-image). Each prints one line per case,
# "ok NAME" or "not ok NAME: why"; this script counts them and ends with "N passed, N failed".
# TESTS=pattern runs only the test files whose name contains the pattern.
#
# TEST_JOBS test files run at once (default: the machine's cores). Why: most test files keep one core
# busy (Python, file I/O, voxlab on small images), so one at a time left half of a 2-core machine idle
# and CI's two passes of the suite took 31 of its 41-45 minutes. Each file has its own TEST_TMP, so
# their order and overlap do not matter, except to a file whose checks compare times it measures
# (test_timing.py: the truth's time rising with spp): such a file holds a line "# run_all: alone" and
# runs with nothing beside it (beside another file, its 4-spp runs once came out slower than its
# 16-spp ones and failed CI).
# A file's line is printed when it ends; the counts and the failing list (sorted) do not depend on the order.
set -u
cd "$(dirname "$0")/.."
export BUILD=${BUILD:-build}
export VOXLAB="$PWD/$BUILD/voxlab"
# One kernel cache for every build flavour: the kernels are the same sources and options whatever
# the host code's build (PoCL keys its cache by both), so the sanitizer pass reuses what the plain
# pass compiled instead of compiling them all again (test_opencl: 126 s -> 59 s under ASan; its own
# cold-cache case uses a fresh directory of its own).
export POCL_CACHE_DIR="$PWD/build/pocl-cache"
tmp_root=$(mktemp -d)
trap 'rm -rf "$tmp_root"' EXIT
passed=0
failed=0
failed_names=()
jobs_max=${TEST_JOBS:-$(nproc 2>/dev/null || echo 1)}
case "$jobs_max" in
  '' | *[!0-9]* | 0) echo "tests/run_all.sh: TEST_JOBS must be a whole number of at least 1, not '$jobs_max'" >&2; exit 2 ;;
esac
declare -A job_name job_start
running=0

# Counts a finished test's log and prints its line (and, when it failed, why).
report_one() {
  local name=$1 rc=$2 seconds=$3
  local log="$tmp_root/$name.log"
  local p f
  p=$(grep -c '^ok ' "$log")
  f=$(grep -c '^not ok ' "$log")
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then
    f=1
    echo "not ok $name: exited with status $rc" >>"$log"
  fi
  if [ "$p" -eq 0 ] && [ "$f" -eq 0 ]; then
    f=1
    echo "not ok $name: reported no test case" >>"$log"
  fi
  passed=$((passed + p))
  failed=$((failed + f))
  printf '%-40s %3d passed %3d failed  %3ds\n' "$name" "$p" "$f" "$seconds"
  if [ "$f" -ne 0 ]; then
    failed_names+=("$name")
    # The failing cases first: a long log's end may not hold them (a CI log once showed 40 lines of
    # "ok" for a test with one failure, and nothing said which).
    grep '^not ok ' "$log" | head -20 | sed 's/^/    /'
    echo "    ... the end of its output:"
    sed 's/^/    /' "$log" | tail -40
  fi
}

# Waits for any running test and reports it.
reap_one() {
  local pid rc
  wait -n -p pid
  rc=$?
  running=$((running - 1))
  report_one "${job_name[$pid]}" "$rc" $((SECONDS - ${job_start[$pid]}))
}

# Starts test `name` (the command after it; its last word is the test's file) once a slot is free,
# or, for a file that runs alone, once every other test has ended, waiting for it to end too.
run_one() {
  local name=$1; shift
  case "$name" in *"${TESTS:-}"*) ;; *) return ;; esac
  local alone=0
  grep -qs '^# run_all: alone' "${@: -1}" && alone=1
  while [ "$running" -ge "$jobs_max" ] || { [ "$alone" -eq 1 ] && [ "$running" -gt 0 ]; }; do
    reap_one
  done
  TEST_TMP="$tmp_root/$name.d" "$@" </dev/null >"$tmp_root/$name.log" 2>&1 &
  job_name[$!]=$name
  job_start[$!]=$SECONDS
  running=$((running + 1))
  [ "$alone" -eq 0 ] || reap_one
}
for t in "$BUILD"/tests/unit_*; do
  [ -x "$t" ] && [ "${t%.o}" = "$t" ] && [ "${t%.d}" = "$t" ] && run_one "$(basename "$t")" "$t"
done
for t in tests/test_*.sh; do
  [ -f "$t" ] && run_one "$(basename "$t")" bash "$t"
done
for t in tests/test_*.py; do
  [ -f "$t" ] && run_one "$(basename "$t")" /usr/bin/python3 "$t"
done
while [ "$running" -gt 0 ]; do
  reap_one
done
echo
# Sorted: the files end in any order, the list does not depend on it.
[ ${#failed_names[@]} -eq 0 ] || echo "failing: $(printf '%s\n' "${failed_names[@]}" | sort | tr '\n' ' ' | sed 's/ $//')"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
