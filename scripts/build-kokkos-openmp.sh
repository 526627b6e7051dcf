#!/usr/bin/env bash
# Optional: build Kokkos 3.4.1 with the OpenMP backend from Debian's own trilinos source package
# (Debian ships Kokkos with the Serial backend only), install it under PREFIX (default
# /opt/kokkos-openmp), then build loosepack against it in build-openmp/:
#   ./scripts/build-kokkos-openmp.sh && OMP_NUM_THREADS=2 ./build-openmp/loosepack run ...
# Systems of a batch then run on all cores. Needs the Debian source archive (deb-src); this
# script adds it for bookworm if absent.
set -euo pipefail
cd "$(dirname "$0")/.."
prefix="${PREFIX:-/opt/kokkos-openmp}"
bash scripts/install-deps.sh
if [ ! -f "$prefix/lib/cmake/Kokkos/KokkosConfig.cmake" ]; then
  if ! apt-get source --print-uris trilinos >/dev/null 2>&1; then
    cat > /etc/apt/sources.list.d/loosepack-debsrc.sources <<'SRC'
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
    apt-get update -qq
  fi
  work=$(mktemp -d)
  (cd "$work" && apt-get source --download-only trilinos >/dev/null 2>&1)
  tar -xzf "$work"/trilinos_*.orig.tar.gz -C "$work" --wildcards '*/packages/kokkos/*'
  src=$(echo "$work"/Trilinos-*/packages/kokkos)
  cmake -S "$src" -B "$work/build" -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_BUILD_TYPE=Release \
    -DKokkos_ENABLE_OPENMP=ON -DKokkos_ENABLE_SERIAL=ON -DCMAKE_CXX_STANDARD=17 >/dev/null
  cmake --build "$work/build" -j"$(nproc)"
  cmake --install "$work/build" >/dev/null
  rm -rf "$work"
fi
cmake -S . -B build-openmp -DKokkos_ROOT="$prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build-openmp -j"$(nproc)"
