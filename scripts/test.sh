#!/usr/bin/env bash
# From a fresh Debian bookworm machine: install dependencies, build, run the test suite.
#   scripts/test.sh          the suite (ctest), less the tests labelled "long"
#   scripts/test.sh --all    every test, with the long ones: the paper's Gaussian histogram at
#                            40 R x 180 R (reproduction_gaussian, 693 CPU s; CI runs it too)
set -euo pipefail
cd "$(dirname "$0")/.."
select=(-LE long)
[ $# -le 1 ] || set -- usage
case "${1:-}" in
  --all) select=() ;;
  "") ;;
  *) echo "usage: scripts/test.sh [--all]" >&2; exit 2 ;;
esac
bash scripts/install-deps.sh --test
bash scripts/build.sh
cd build
ctest --output-on-failure -j"$(nproc)" "${select[@]}"
