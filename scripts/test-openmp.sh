#!/usr/bin/env bash
# The OpenMP backend, as CI checks it after the Serial suite (.ci/run): builds Kokkos with OpenMP
# and loosepack against it (scripts/build-kokkos.sh openmp -> build-openmp/), then, on 2 threads:
# tests/threads_test.sh (a scan of protocols A, B and C bit-identical on 1, 2 and 4 threads and
# with the Serial build's loosepack, with the host's solver and the team solver), and the unit
# tests but for three statistical ones of 16 to 48 members, whose code paths the others cover and
# which the Serial suite runs (on 2 threads the first took more than 15 minutes beside a one-core
# run). The whole suite on OpenMP (34 minutes on 2 cores beside other work; docs/PERFORMANCE.md,
# "Building for more cores or a GPU"): `cd build-openmp && OMP_NUM_THREADS=2 OMP_PROC_BIND=false
# ctest -LE long`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build-kokkos.sh openmp
bash scripts/build.sh  # the Serial build of the same tree, to compare with
# Without OMP_PROC_BIND Kokkos warns at every start-up.
export OMP_NUM_THREADS=2 OMP_PROC_BIND=false
tests/threads_test.sh build-openmp/loosepack build/loosepack
./build-openmp/tests/loosepack_tests --gtest_filter='-ProtocolA.DensityDecreasesWithHeightAtIntermediateBond:ProtocolA.DenseAndFlatWithoutCohesion:Regions.SameObservablesAsTheWholeSystemWithinErrors'
