#!/usr/bin/env bash
# Gathers what bench/gpu_study.sh needs on a GPU machine that has no build tools or packages of
# this machine's: the CUDA build's loosepack and unit tests, a host build's loosepack, optionally
# an older device binary to compare with, stripped, and the shared libraries they link (but
# glibc's own: the other machine's glibc must be as new as this one's; the driver's libcuda
# comes from that machine).
#
#   bench/gpu_bundle.sh DIR CUDA_BUILD HOST_BUILD [BEFORE_LOOSEPACK]
#     e.g. bench/gpu_bundle.sh .dev build-cuda build-host
#   then, on the GPU machine, in the repository:
#     export LD_LIBRARY_PATH=$PWD/DIR/lib
#     TESTS=DIR/device/loosepack_tests bench/gpu_study.sh OUT DIR/device/loosepack \
#       DIR/host/loosepack [DIR/before/loosepack]
#
# CUDA_BUILD comes from scripts/build-kokkos.sh cuda; HOST_BUILD from
# `cmake -S . -B build-host -DCMAKE_BUILD_TYPE=Release -DLOOSEPACK_MPI=OFF` (no MPI libraries to
# carry). About 40 MB.
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: bench/gpu_bundle.sh DIR CUDA_BUILD HOST_BUILD [BEFORE_LOOSEPACK]" >&2
  exit 2
fi
dir=$1 cuda=$2 host=$3 before=${4:-}
for f in "$cuda/loosepack" "$cuda/tests/loosepack_tests" "$host/loosepack" $before; do
  [ -x "$f" ] || { echo "gpu_bundle.sh: $f is not built" >&2; exit 2; }
done
# DIR is replaced whole: refused unless it is absent, empty or an earlier bundle.
if [ -e "$dir" ] && [ -n "$(ls -A "$dir")" ] && [ ! -f "$dir/device/loosepack" ]; then
  echo "gpu_bundle.sh: $dir holds other files than a bundle's: give a new DIR" >&2
  exit 2
fi
rm -rf "$dir"
mkdir -p "$dir/device" "$dir/host" "$dir/lib"
cp "$cuda/loosepack" "$cuda/tests/loosepack_tests" "$dir/device/"
cp "$host/loosepack" "$dir/host/"
if [ -n "$before" ]; then
  mkdir -p "$dir/before"
  cp "$before" "$dir/before/loosepack"
fi
strip "$dir"/*/loosepack*
for b in "$dir"/*/loosepack*; do ldd "$b" | awk '/=> \// {print $3}'; done | sort -u |
  grep -v -E '/(libc|libm|libdl|libpthread|librt|libresolv|ld-linux[^/]*)\.so' |
  xargs -r -I{} cp -L {} "$dir/lib/"
du -sh "$dir"
