#!/usr/bin/env bash
# tests/run_all.sh itself, on fake unit tests in a build folder of their own: its counts, its exit
# status, and that a failing test's "not ok" lines are shown even when its output ends with many
# passing cases (a CI log once showed only the last 40 lines, all "ok", of a test that failed).
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
finish
