#!/usr/bin/env bash
# Fuzzes, each for a bounded time, the scan-file parser and validator (fuzz/fuzz_scan.cpp), the
# checkpoint reader (fuzz/fuzz_checkpoint.cpp) and the result-file readers of `summary`,
# `analyse`, `merge` and `export` (fuzz/fuzz_results.cpp).
#   scripts/fuzz.sh [seconds per target] [target...]     (default 60; every target)
# Builds only the fuzz targets with clang (libFuzzer, ASan, UBSan) in build-fuzz/, runs each in
# one process over a copy of its corpus (fuzz/corpus/ for the scan parser, fuzz/corpus-results/
# for the result-file readers; the committed corpora are never written to), and exits nonzero when one finds a crash, a leak, a timeout or an
# allocation over the limits, printing the reproducer. Replay one: build-fuzz/fuzz/TARGET FILE
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
# libFuzzer reads a time that is not a positive number as no limit at all.
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -lt 1 ]; then
  echo "usage: scripts/fuzz.sh [seconds per target, at least 1] [target...]" \
    "(the seconds come first: scripts/fuzz.sh 60 fuzz_scan)" >&2
  exit 2
fi
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_scan fuzz_checkpoint fuzz_results)
build=build-fuzz
bash scripts/install-deps.sh
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DLOOSEPACK_FUZZ=ON -DLOOSEPACK_BUILD_TESTS=OFF -DLOOSEPACK_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$build" -j2 --target "${targets[@]}"
failed=0
for target in "${targets[@]}"; do
  work="$build/corpus-$target"  # the working corpus: seeds plus what the fuzzer adds
  artifacts="$build/artifacts-$target"
  rm -rf "$artifacts"
  mkdir -p "$work" "$artifacts"
  options=()
  if [ "$target" = fuzz_scan ]; then
    cp fuzz/corpus/* "$work"/
    options=(-dict=fuzz/toml.dict -max_len=4096)
  elif [ "$target" = fuzz_results ]; then
    cp fuzz/corpus-results/* "$work"/  # earlier findings, kept as seeds
  fi
  set +e
  "$build/fuzz/$target" "$work" "${options[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -malloc_limit_mb=2048 -artifact_prefix="$artifacts/" \
    -print_final_stats=1 2>"$build/$target.log"
  rc=$?
  set -e
  tail -n 8 "$build/$target.log"
  found=$(find "$artifacts" -type f | sort)
  if [ "$rc" -ne 0 ] || [ -n "$found" ]; then
    echo "fuzz: $target FAILED (exit $rc); full log: $build/$target.log" >&2
    for f in $found; do echo "fuzz: reproducer: $f (replay: $build/fuzz/$target $f)" >&2; done
    failed=1
  else
    echo "fuzz: $target: no findings in ${seconds} s"
  fi
done
exit "$failed"
