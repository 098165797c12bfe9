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

echo "== integration tests"
"$PYTHON" tests/integration/run_integration.py 2>&1 | tee "$tmp/integ.log"
tally "$tmp/integ.log" "integration tests"

echo
if [ "$skipped" -gt 0 ]; then
  echo "$passed passed, $failed failed, $skipped skipped"
else
  echo "$passed passed, $failed failed"
fi
[ "$failed" -eq 0 ]
