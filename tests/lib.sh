# Shell test helpers. Source this; then `check NAME COMMAND...` runs a case that passes when the
# command succeeds, and `check_fails NAME PATTERN COMMAND...` one that passes when the command exits
# non-zero with stderr matching PATTERN. Each prints "ok NAME" or "not ok NAME: why".
set -u
: "${VOXLAB:=$PWD/build/voxlab}"
: "${TEST_TMP:=$(mktemp -d)}"
mkdir -p "$TEST_TMP"
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
failures=0
check() {
  local name=$1; shift
  local out
  if out=$("$@" 2>&1); then
    echo "ok $name"
  else
    echo "not ok $name: command failed: $*"
    printf '%s\n' "$out" | tail -5 | sed 's/^/    /'
    failures=$((failures + 1))
  fi
}
check_fails() {
  local name=$1 pattern=$2; shift 2
  local err rc
  err=$("$@" 2>&1 >/dev/null)
  rc=$?
  if [ $rc -eq 0 ]; then
    echo "not ok $name: expected failure, command succeeded: $*"
    failures=$((failures + 1))
  elif ! printf '%s' "$err" | grep -qE -- "$pattern"; then
    echo "not ok $name: message does not match /$pattern/: $err"
    failures=$((failures + 1))
  else
    echo "ok $name"
  fi
}
finish() { exit $((failures > 0)); }
