#!/usr/bin/env bash
# Fuzzes the scan-file parser and validator (fuzz/fuzz_scan.cpp) for a bounded time.
#   scripts/fuzz.sh [seconds]     (default 60)
# Builds only the fuzz target with clang (libFuzzer, ASan, UBSan) in build-fuzz/, runs it in
# one process over a copy of fuzz/corpus/ (the committed corpus is never written to), and exits
# nonzero when it finds a crash, a leak, a timeout or an allocation over the limits, printing
# the reproducer. Replay one: build-fuzz/fuzz/fuzz_scan REPRODUCER
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
build=build-fuzz
bash scripts/install-deps.sh
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DLOOSEPACK_FUZZ=ON -DLOOSEPACK_BUILD_TESTS=OFF -DLOOSEPACK_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$build" -j2 --target fuzz_scan
work="$build/corpus"        # the working corpus: seeds plus what the fuzzer adds
artifacts="$build/artifacts"
rm -rf "$artifacts"
mkdir -p "$work" "$artifacts"
cp fuzz/corpus/* "$work"/
set +e
"$build/fuzz/fuzz_scan" "$work" -dict=fuzz/toml.dict -max_total_time="$seconds" \
  -max_len=4096 -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
  -artifact_prefix="$artifacts/" -print_final_stats=1 2>"$build/fuzz.log"
rc=$?
set -e
tail -n 25 "$build/fuzz.log"
found=$(find "$artifacts" -type f | sort)
if [ "$rc" -ne 0 ] || [ -n "$found" ]; then
  echo "fuzz: FAILED (exit $rc); full log: $build/fuzz.log" >&2
  for f in $found; do echo "fuzz: reproducer: $f (replay: $build/fuzz/fuzz_scan $f)" >&2; done
  exit 1
fi
echo "fuzz: no findings in ${seconds} s"
