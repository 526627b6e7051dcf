#!/usr/bin/env bash
# From a fresh Debian bookworm machine: install dependencies, build, run the default job
# (examples/default.toml) into out/default.h5 and print its summary.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh --program
mkdir -p out
./build/loosepack run examples/default.toml -o out/default.h5 --force
./build/loosepack summary out/default.h5
