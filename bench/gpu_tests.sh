#!/usr/bin/env bash
# Every GoogleTest test of a build, one process each, PARALLEL at a time (default 2), each
# limited to LIMIT seconds (default 60): for a CUDA build on a GPU machine, where the
# one-thread-per-system solvers make some tests take many minutes. Processes on one GPU share it
# by turns: among 48 at a time a test of 2 914 one-disk steps
# (`Validation.FreeFallIsTheDiscreteMotionExactly`, 0.02 s on one core) did not finish in 200 s,
# so run few at a time. Writes to OUT (default
# ./gpu-tests): tests.txt ("name rc seconds"; rc 124: timed out) and failed_tails.txt (the last
# 3 000 bytes of each unfinished test's output); prints the counts.
#
#   bench/gpu_tests.sh build-cuda/tests/loosepack_tests
#   FILTER='TeamColouring.*:Batch.*' bench/gpu_tests.sh ...   only the tests a GoogleTest
#     filter names
#
# A binary built elsewhere runs with its shared libraries beside it: bench/gpu_bundle.sh gathers
# them into a folder for LD_LIBRARY_PATH (docs/PERFORMANCE.md, "Building for more cores or a
# GPU").
set -uo pipefail
if [ $# -ne 1 ]; then
  echo "usage: bench/gpu_tests.sh TEST_BINARY   (LIMIT=seconds PARALLEL=n OUT=dir FILTER=...)" >&2
  exit 2
fi
binary=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
limit=${LIMIT:-60}
OUT=${OUT:-gpu-tests}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
"$binary" --gtest_list_tests --gtest_filter="${FILTER:-*}" 2>"$OUT/list.err" |
  awk '/^[^ ]/ {s=$1} /^  / {print s $1}' >"$OUT/list.txt"
[ -s "$OUT/list.txt" ] || { echo "gpu_tests.sh: $binary lists no tests (see $OUT/list.err)" >&2; exit 1; }
one() {
  local t0 rc log
  log="$OUT/log_${1//\//_}"  # a parametrised test's name holds '/'
  t0=$(date +%s.%N)
  timeout "$limit" "$binary" --gtest_filter="$1" >"$log.txt" 2>&1
  rc=$?
  echo "$1 $rc $(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')"
  [ $rc -eq 0 ] || tail -c 3000 "$log.txt" >"$log.tail"
  rm -f "$log.txt"
}
export -f one
export binary limit OUT
xargs -P "${PARALLEL:-2}" -I{} bash -c 'one {}' <"$OUT/list.txt" >"$OUT/tests.txt"
for f in "$OUT"/log_*.tail; do
  [ -e "$f" ] && { echo "== $f"; cat "$f"; rm -f "$f"; }
done >"$OUT/failed_tails.txt"
awk '{n++; if ($2 == 0) p++; else if ($2 == 124) t++; else f++}
  END {print n, "tests:", p+0, "passed,", t+0, "timed out,", f+0, "failed"}' "$OUT/tests.txt"
