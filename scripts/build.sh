#!/usr/bin/env bash
# Configure and build loosepack into build/ (Release). Extra arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
mkdir -p build
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "$@" >build/configure.log 2>&1 ||
  { cat build/configure.log; echo "build.sh: cmake configure failed" >&2; exit 1; }
cmake --build build -j"$(nproc)"
