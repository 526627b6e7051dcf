#!/usr/bin/env bash
# Debug build with AddressSanitizer and UndefinedBehaviorSanitizer (LOOSEPACK_SANITIZE=ON), then
# the unit and validation tests that run in reasonable time without optimisation (not the
# statistical comparison of 48 members, Regions.SameObservablesAsTheWholeSystemWithinErrors,
# whose code paths Regions.DepositEndsAtRestCarryingItsWeight covers, nor the histogram shapes'
# calibration over 2 000 synthetic ensembles, Analysis.HistogramShapeChoosesTheGaussianFor...,
# about 9 minutes here, whose code paths the other Analysis.Histogram* tests cover).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
mkdir -p build-asan
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Debug -DLOOSEPACK_SANITIZE=ON \
  -DLOOSEPACK_BUILD_BENCH=OFF >build-asan/configure.log 2>&1 ||
  { cat build-asan/configure.log; echo "cmake configure failed" >&2; exit 1; }
cmake --build build-asan -j"$(nproc)" --target loosepack_tests
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ./build-asan/tests/loosepack_tests \
  --gtest_filter='ContactLaw*:Validation*:Scan*:Output*:Solver*:Guard*:Reproducibility*:Analysis*:Checkpoint*:Failure*:Region*:ColouredSolver*:Newton*:Batch*:Collision*:Backend*-Regions.SameObservablesAsTheWholeSystemWithinErrors:Analysis.HistogramShapeChoosesTheGaussianForAnExponentialAsAkaikeSays'
