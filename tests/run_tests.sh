#!/usr/bin/env bash
# Runs the whole suite: the unit-test executable under mpirun at each rank
# count in NP_TEST, then the integration tests.  Each part ends with a line
# "N passed, N failed[, N skipped]"; this script adds them up and ends with
# the same line for the whole suite, exiting non-zero if anything failed.
set -u
BUILD=${BUILD:-build/release}
PYTHON=${PYTHON:-/usr/bin/python3}
NP_TEST=${NP_TEST:-1 2 3}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1

passed=0; failed=0; skipped=0
tally() {  # $1: log file, $2: label
  local line
  line=$(grep -E '^[0-9]+ passed, [0-9]+ failed' "$1" | tail -n 1)
  if [ -z "$line" ]; then
    echo "!! $2 ended without a summary line: counted as one failure"
    failed=$((failed + 1)); return
  fi
  local p f s
  p=$(echo "$line" | sed -E 's/^([0-9]+) passed.*/\1/')
  f=$(echo "$line" | sed -E 's/.* ([0-9]+) failed.*/\1/')
  s=$(echo "$line" | sed -nE 's/.* ([0-9]+) skipped.*/\1/p')
  passed=$((passed + p)); failed=$((failed + f)); skipped=$((skipped + ${s:-0}))
}

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

for np in $NP_TEST; do
  echo "== unit tests, mpirun -np $np"
  mpirun -np "$np" "$BUILD/unit_tests" 2>&1 | tee "$tmp/unit_$np.log"
  tally "$tmp/unit_$np.log" "unit tests at np $np"
done

echo "== integration tests (pytest)"
"$PYTHON" -m pytest tests/integration -v -rfEs -p no:cacheprovider --durations=10 2>&1 | tee "$tmp/integ.log"
rc=${PIPESTATUS[0]}
# pytest ends with e.g. "== 36 passed, 1 failed, 1 skipped, 1 error in 201.3s ==":
# restate it as the line tally reads; an error (a fixture's run failed, a
# module did not import) counts as a failure, and so does a non-zero exit
# with nothing failed (no test collected, interrupted)
line=$(grep -E '^=* ?(no tests ran|[0-9]+ [a-z]+.* in [0-9.]+s)' "$tmp/integ.log" | tail -n 1)
if [ -n "$line" ]; then
  count() { echo "$line" | grep -oE "[0-9]+ $1" | head -n 1 | cut -d' ' -f1; }
  p=$(count passed); f=$(count failed); e=$(count 'errors?'); s=$(count skipped)
  f=$(( ${f:-0} + ${e:-0} ))
  [ "$rc" -ne 0 ] && [ "$f" -eq 0 ] && f=1
  echo "${p:-0} passed, $f failed, ${s:-0} skipped" | tee -a "$tmp/integ.log"
fi
tally "$tmp/integ.log" "integration tests"

echo
if [ "$skipped" -gt 0 ]; then
  echo "$passed passed, $failed failed, $skipped skipped"
else
  echo "$passed passed, $failed failed"
fi
[ "$failed" -eq 0 ]
