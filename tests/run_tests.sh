#!/usr/bin/env bash
# Runs the whole suite: the unit tests (once, under mpirun with as many
# processes as the largest npes of their @mpitest directives), the tests of
# tests/pf2f90.py, then the integration tests.  Each part ends with a line
# "N passed, N failed[, N skipped]"; this script adds them up and ends with
# the same line for the whole suite, exiting non-zero if anything failed.
set -u
BUILD=${BUILD:-build/release}
PYTHON=${PYTHON:-/usr/bin/python3}
NP_TEST=${NP_TEST:-1 2 3}
UNIT_EXE=${UNIT_EXE:-$BUILD/unit_tests}
UNIT_KIND=${UNIT_KIND:-pf2f90}
UNIT_LABEL=${UNIT_LABEL:-tests/pf2f90.py (pFUnit not found)}
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

# Unit tests, built by pFUnit or translated by tests/pf2f90.py (Makefile):
# every @mpitest instance runs on its own npes processes, a plain @test on
# one, as pFUnit does.  Idle processes yield the cores to the busy ones.
np=$(sed -nE 's/^[[:space:]]*@mpitest[[:space:]]*\([[:space:]]*npes[[:space:]]*=[[:space:]]*\[([0-9, ]*)\].*/\1/Ip' \
       tests/unit/*.pf | tr ', ' '\n\n' | grep -E '^[0-9]+$' | sort -n | tail -n 1)
np=${np:-1}
echo "== unit tests: $UNIT_LABEL, mpirun -np $np"
if [ "$UNIT_KIND" = pfunit ]; then
  # pFUnit lists the tests in a TAP file and closes with "OK (N tests)" or
  # "FAILURES!!! Tests run: N, Failures: F, Errors: E": turned into the
  # "[ OK ] name" lines and the summary line of tests/testing.f90 (pFUnit
  # 4.14 writes an MPI test's "[npes=N]" twice in the TAP file: once here).
  OMPI_MCA_mpi_yield_when_idle=1 mpirun -np "$np" "$UNIT_EXE" -t "$tmp/unit.tap" 2>&1 \
    | tee "$tmp/unit.log"
  sed -nE 's/(\[npes=[0-9]+\])\1 *$/\1/
           s/^ *ok - (.*[^ ]) *$/[ OK ] \1/p; s/^ *not ok - (.*[^ ]) *$/[FAIL] \1/p' \
    "$tmp/unit.tap" > "$tmp/unit.names" 2>/dev/null
  cat "$tmp/unit.names"
  run=$(sed -nE 's/^ *\(([0-9]+) tests?.*/\1/p' "$tmp/unit.log" | tail -n 1)
  bad=$(sed -nE 's/^ *Tests run: ([0-9]+), Failures: ([0-9]+), Errors: ([0-9]+).*/\1 \2 \3/p' \
          "$tmp/unit.log" | tail -n 1)
  if [ -n "$bad" ]; then
    set -- $bad
    echo "$(($1 - $2 - $3)) passed, $(($2 + $3)) failed" | tee -a "$tmp/unit.log"
  elif [ -n "$run" ]; then
    echo "$run passed, 0 failed" | tee -a "$tmp/unit.log"
  fi
else
  OMPI_MCA_mpi_yield_when_idle=1 mpirun -np "$np" "$UNIT_EXE" 2>&1 | tee "$tmp/unit.log"
  grep -E '^\[(FAIL| OK )\] ' "$tmp/unit.log" > "$tmp/unit.names"
fi
tally "$tmp/unit.log" "unit tests"
counts=""
for k in $(seq 1 "$np"); do
  n=$(grep -c "\[npes=$k\]\$" "$tmp/unit.names")
  [ "$k" -eq 1 ] && n=$((n + $(grep -vc '\[npes=[0-9]*\]$' "$tmp/unit.names")))
  counts="$counts${counts:+, }$n on $k"
done
echo "   unit tests by processes: $counts (a plain @test runs on 1)"

echo "== tests of tests/pf2f90.py"
"$PYTHON" tests/test_pf2f90.py 2>&1 | tee "$tmp/pf2f90.log"
tally "$tmp/pf2f90.log" "tests of tests/pf2f90.py"

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
