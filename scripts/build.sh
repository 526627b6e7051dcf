#!/usr/bin/env bash
# Configure and build loosepack into build/ (Release): the program, the test suite and the
# benchmarks; with --program first, the program alone (scripts/run-default.sh: a user who runs
# a job waits for neither). Further arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
target=()
if [ "${1:-}" = "--program" ]; then
  target=(--target loosepack)
  shift
fi
bash scripts/install-deps.sh
mkdir -p build
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" >build/configure.log 2>&1 ||
  { cat build/configure.log; echo "build.sh: cmake configure failed" >&2; exit 1; }
cmake --build build -j"$(nproc)" "${target[@]}"
