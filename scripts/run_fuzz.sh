#!/usr/bin/env bash
# Runs every fuzz harness for a bounded time: the libFuzzer ones built in BUILD (make fuzz) and the
# atheris one of the grasps.json reader (Python). Each starts from its committed seed corpus
# (tests/fuzz/corpus/<target>) and regression inputs (tests/fuzz/regressions/<target>); new inputs
# go to BUILD/fuzz-corpus/<target>, never into the source tree. Exits non-zero on the first crash,
# leak, timeout or out-of-memory, printing the reproducer's path (BUILD/fuzz-artifacts/).
#
#   scripts/run_fuzz.sh BUILD SECONDS PYTHON [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:?usage: run_fuzz.sh BUILD SECONDS PYTHON [TARGET...]}
SECONDS_EACH=${2:?seconds per target}
PYTHON=${3:?python}
shift 3
TARGETS=("$@")
if [ "${#TARGETS[@]}" -eq 0 ]; then
  TARGETS=(mesh_stl mesh_obj mesh_ply mesh_dae hand paint grasps)
fi

mkdir -p "$BUILD/fuzz-artifacts" "$BUILD/fuzz-logs"
# Per input: 10 s at most (a hang), 2 GiB at most; the whole run SECONDS_EACH at most. The runs
# are seeded and counted (about what 30 s gives each harness on a loaded 2-core machine), so CI
# replays the inputs already explored here instead of failing on a new find at random; set
# FUZZ_SEED (0: libFuzzer picks one) and FUZZ_RUNS (-1: until SECONDS_EACH) to explore further.
LIMITS=(-timeout=10 -rss_limit_mb=2048)
FLAGS=(-max_total_time="$SECONDS_EACH" "${LIMITS[@]}" -max_len=65536 -print_final_stats=1 -seed="${FUZZ_SEED:-1}")
declare -A RUNS=([mesh_stl]=1500 [mesh_obj]=500 [mesh_ply]=2000 [mesh_dae]=12000 [hand]=7000 [paint]=20000
                 [grasps]=20000)
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

# One bounded run of target $1 from its corpora; its log in $BUILD/fuzz-logs/$1.log.
fuzz_once() {
  local t=$1 work="$BUILD/fuzz-corpus/$1"
  mkdir -p "$work"
  local dirs=("$work" "tests/fuzz/corpus/$t")
  if [ -d "tests/fuzz/regressions/$t" ]; then dirs+=("tests/fuzz/regressions/$t"); fi
  "${cmd[@]}" "${FLAGS[@]}" -runs="${FUZZ_RUNS:-${RUNS[$t]}}" -artifact_prefix="$BUILD/fuzz-artifacts/$t-" \
    "${dirs[@]}" >"$BUILD/fuzz-logs/$t.log" 2>&1
}

# The crash report of a failed run: the log without libFuzzer's progress lines, from its end.
report() {
  grep -av '^#[0-9]' "$1" | tail -n 80
}

status=0
for t in "${TARGETS[@]}"; do
  log="$BUILD/fuzz-logs/$t.log"
  if [ "$t" = grasps ]; then
    cmd=("$PYTHON" tests/fuzz/fuzz_grasps.py)
  else
    cmd=("$BUILD/tests/fuzz/fuzz_$t")
  fi
  start=$(date +%s)
  rm -f "$BUILD/fuzz-artifacts/$t-"*
  ok=1
  if ! fuzz_once "$t"; then
    ok=0
    echo "fuzz $t: FAILED (log $log)"
    report "$log"
    # A parser bug fails again on its reproducer alone. One that does not (the same input passes
    # three times when replayed) was a failure of the run, not of the input: the harness is run
    # once more from scratch and fails the check only if that run fails too.
    repro=$(ls "$BUILD/fuzz-artifacts/$t-"* 2>/dev/null | head -n 1 || true)
    if [ -n "$repro" ] && "${cmd[@]}" -runs=3 "${LIMITS[@]}" "$repro" >"$log.replay" 2>&1; then
      echo "fuzz $t: the reproducer $repro passes when replayed alone; running the harness again"
      mv "$log" "$log.first"
      rm -rf "$BUILD/fuzz-corpus/$t"
      if fuzz_once "$t"; then ok=1; else report "$log"; fi
    fi
  fi
  if [ "$ok" = 1 ]; then
    runs=$(grep -ao 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    cov=$(grep -ao 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
    echo "fuzz $t: ok, $runs inputs in $(( $(date +%s) - start )) s, coverage $cov"
  else
    status=1
    ls "$BUILD/fuzz-artifacts/$t-"* 2>/dev/null | sed 's/^/  reproducer: /' || true
    echo "  add the reproducer to tests/fuzz/regressions/$t/ and fix the parser"
  fi
done
exit $status
