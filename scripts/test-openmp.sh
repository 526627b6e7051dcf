#!/usr/bin/env bash
# The OpenMP backend, as CI checks it after the Serial suite (.ci/run): builds Kokkos with OpenMP
# and loosepack against it (scripts/build-kokkos.sh openmp -> build-openmp/), then, on 2 threads,
# the whole suite but the test labelled long (605-673 s on 2 idle cores, 2026-12-06), its test
# `threads` given the Serial build's loosepack too: a scan of protocols A, B and C bit-identical
# on 1, 2 and 4 threads and with the Serial build, with the host's solver and the team solver.
# Run it alone: beside a one-core job, the threads' barriers made a test of 100 s take over 900.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh --test  # the suite's own packages (pytest, ParaView, strace, ...)
bash scripts/build-kokkos.sh openmp
bash scripts/build.sh  # the Serial build of the same tree, to compare with
# Without OMP_PROC_BIND Kokkos warns at every start-up, which the command-line tests take for a
# warning of the run.
export OMP_NUM_THREADS=2 OMP_PROC_BIND=false
(cd build-openmp && ctest --output-on-failure -LE long -E '^threads$')
tests/threads_test.sh build-openmp/loosepack build/loosepack
