#!/usr/bin/env bash
# tests/run_all.sh itself, on fake unit tests in a build folder of their own: its counts, its exit
# status, that TEST_JOBS test files run at once but a file marked "# run_all: alone" by itself, and
# that a failing test's "not ok" lines are shown even when its output ends with many passing cases (a
# CI log once showed only the last 40 lines, all "ok", of a test that failed).
. "$(dirname "$0")/lib.sh"
T=$TEST_TMP
mkdir -p "$T/build/tests"
fake() { # $1 = name, $2 = "fail" to fail its second case
  {
    echo '#!/bin/sh'
    echo 'echo "ok first case"'
    if [ "$2" = fail ]; then
      echo 'echo "not ok the second case: why it failed"'
    else
      echo 'echo "ok the second case"'
    fi
    echo 'i=0; while [ $i -lt 60 ]; do echo "ok later case $i"; i=$((i + 1)); done'
    [ "$2" = fail ] && echo 'exit 1'
  } >"$T/build/tests/$1"
  chmod +x "$T/build/tests/$1"
}
fake unit_fakepass pass
fake unit_fakefail fail

out=$(BUILD="$T/build" TESTS=unit_fakepass bash "$REPO/tests/run_all.sh" 2>&1)
rc=$?
check "a passing test: exit 0 and 62 passed, 0 failed" \
  bash -c '[ "$1" -eq 0 ] && printf "%s\n" "$2" | grep -q "^62 passed, 0 failed$"' _ "$rc" "$out"

out=$(BUILD="$T/build" TESTS=unit_fakefail bash "$REPO/tests/run_all.sh" 2>&1)
rc=$?
check "a failing test: exit non-zero and 61 passed, 1 failed" \
  bash -c '[ "$1" -ne 0 ] && printf "%s\n" "$2" | grep -q "^61 passed, 1 failed$"' _ "$rc" "$out"
check "a failing test: its failing case is shown, though its last 40 lines all pass" \
  bash -c 'printf "%s\n" "$1" | grep -q "^    not ok the second case: why it failed$"' _ "$out"
check "a failing test: named in the failing list" \
  bash -c 'printf "%s\n" "$1" | grep -q "^failing: unit_fakefail$"' _ "$out"
# Two test files at once (TEST_JOBS=2): the first waits for a file that only the second writes, so
# it passes only when they overlap; one at a time (TEST_JOBS=1) it gives up after 3 s and fails.
pair() { # $1 = seconds the waiter waits; $2 = 1: the waiter runs alone ("# run_all: alone")
  {
    echo '#!/bin/sh'
    [ "${2:-0}" -eq 0 ] || echo '# run_all: alone'
    echo "i=0; while [ ! -e '$T/pair.flag' ] && [ \$i -lt $(($1 * 10)) ]; do sleep 0.1; i=\$((i + 1)); done"
    echo "if [ -e '$T/pair.flag' ]; then echo 'ok the other test ran meanwhile'; else echo 'not ok the other test did not run meanwhile'; fi"
  } >"$T/build/tests/unit_fakepair_1wait"
  printf '#!/bin/sh\ntouch %s/pair.flag\necho "ok flag written"\n' "$T" >"$T/build/tests/unit_fakepair_2flag"
  chmod +x "$T/build/tests/unit_fakepair_1wait" "$T/build/tests/unit_fakepair_2flag"
  rm -f "$T/pair.flag"
}
pair 60
out=$(BUILD="$T/build" TESTS=unit_fakepair_ TEST_JOBS=2 bash "$REPO/tests/run_all.sh" 2>&1)
rc=$?
check "TEST_JOBS=2: two test files run at once (2 passed, 0 failed)" \
  bash -c '[ "$1" -eq 0 ] && printf "%s\n" "$2" | grep -q "^2 passed, 0 failed$"' _ "$rc" "$out"
pair 3
out=$(BUILD="$T/build" TESTS=unit_fakepair_ TEST_JOBS=1 bash "$REPO/tests/run_all.sh" 2>&1)
rc=$?
check "TEST_JOBS=1: one test file at a time (the waiter fails: 1 passed, 1 failed)" \
  bash -c '[ "$1" -ne 0 ] && printf "%s\n" "$2" | grep -q "^1 passed, 1 failed$"' _ "$rc" "$out"
pair 3 1
out=$(BUILD="$T/build" TESTS=unit_fakepair_ TEST_JOBS=2 bash "$REPO/tests/run_all.sh" 2>&1)
rc=$?
check "a file marked '# run_all: alone' has nothing beside it, even with TEST_JOBS=2 (the waiter fails: 1 passed, 1 failed)" \
  bash -c '[ "$1" -ne 0 ] && printf "%s\n" "$2" | grep -q "^1 passed, 1 failed$"' _ "$rc" "$out"
out=$(BUILD="$T/build" TESTS=unit_fakepass TEST_JOBS=two bash "$REPO/tests/run_all.sh" 2>&1)
rc=$?
check "TEST_JOBS that is not a whole number >= 1: a clear error, exit 2, no test run" \
  bash -c '[ "$1" -eq 2 ] && printf "%s\n" "$2" | grep -q "TEST_JOBS must be a whole number of at least 1, not .two." && ! printf "%s\n" "$2" | grep -q passed' _ "$rc" "$out"
finish
