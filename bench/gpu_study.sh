#!/usr/bin/env bash
# The GPU measurements of docs/PERFORMANCE.md ("Building for more cores or a GPU") in one
# command on a GPU machine, so that the device and the host's cores are measured side by side:
#
#   1. the same scenes on one host core (bench/gpu_runs.sh, the host's default solver), in the
#      background on the last core while the device runs;
#   2. if a BEFORE binary is given: a step's cost per stage before and after, over the same
#      prefix of the runs (the first PREFIX_S seconds, bench/gpu_runs.sh LIMIT=...);
#   3. if TEAM_SIZES lists team sizes: the first PREFIX_S seconds of a run with each (the team
#      solver's threads per system, solver.team_size; 0 the backend's choice);
#   4. whole runs on the device, all members in one batch, with the cost per stage: one for
#      each value of solver.sweeps_per_launch in SWEEPS_PER_LAUNCHES (default "0": each step's
#      whole solve in one launch; K > 0 splits a step's solve over launches of at most K sweeps,
#      so that a launch does not wait for the slowest system); FENCED=0 runs them as a user
#      does, without --timing's fence after every stage (and without its table); each of them
#      once for each value of solver.fused_step in FUSED_STEPS (default "0"; "0 1" adds the
#      runs whose whole step is one launch, variant "...-fused");
#   5. if PAPER_MEMBER_S is set: one paper-size protocol-A member (bench/paper_size_member.sh:
#      200 R x 800 R, Bo = 1e3, regions) for that many seconds on the device (a batch of one,
#      the backend's defaults) and side by side on one host core: the disks each deposited; on
#      the device once for each team size in PAPER_TEAM_SIZES (default "0", the backend's
#      choice; one system may use a larger team than thousands do);
#   6. if TESTS names a GoogleTest binary: its tests (bench/gpu_tests.sh), in the seconds left
#      of BUDGET_S.
#
#   bench/gpu_study.sh OUT DEVICE_LOOSEPACK HOST_LOOSEPACK [BEFORE_LOOSEPACK]
#     env: MEMBERS (4096) members of a device run, in one batch unless BATCH sets it (finished
#          members' slots then take the next), HOST_MEMBERS (64) of a host run, PREFIX_S (30),
#          SOLVER (coloured_accelerated_gauss_seidel) the device runs' solver, TESTS, TEST_FILTER
#          (*), PARALLEL (2) tests at a time, BUDGET_S (540) the seconds the whole study may
#          take.
#
# Writes OUT/study.log (the machine, the progress), OUT/runs.jsonl (bench/gpu_runs.sh's lines,
# each with "where" and "variant"), OUT/timing.txt (each run's --timing), OUT/member.jsonl (the
# paper-size member's disks on each side), OUT/tests_tests.txt and OUT/tests_failed_tails.txt
# (bench/gpu_tests.sh's results) and OUT/summary.md (the tables, bench/gpu_summary.py): seven
# files in all. Binaries built
# on another machine run with their shared libraries beside them (bench/gpu_bundle.sh gathers
# both).
set -uo pipefail
if [ $# -lt 3 ]; then
  echo "usage: bench/gpu_study.sh OUT DEVICE_LOOSEPACK HOST_LOOSEPACK [BEFORE_LOOSEPACK]" >&2
  exit 2
fi
out=$1 device=$2 host=$3 before=${4:-}
here=$(cd "$(dirname "$0")" && pwd)
# One study an OUT: a second's lines would join the first's in its files and summary.
if [ -d "$out" ] && [ -n "$(ls -A "$out")" ]; then
  echo "gpu_study.sh: $out is not empty (an earlier study?): give a new OUT" >&2
  exit 2
fi
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
t0=$(date +%s)
log() { echo "[$(($(date +%s) - t0)) s] $*" | tee -a "$out/study.log"; }
members=${MEMBERS:-4096}
solver=${SOLVER:-coloured_accelerated_gauss_seidel}
last_core=$(($(nproc) - 1))

{
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>&1
  lscpu | grep -m1 'Model name'
  echo "cores: $(nproc)"
  for b in "$device" "$host" $before; do echo "$b: $("$b" --version 2>&1 | head -1)"; done
} >>"$out/study.log"

# runs WHERE VARIANT CORE gpu_runs.sh-arguments...: its lines tagged, its timings kept
runs() {
  local where=$1 variant=$2 core=$3
  shift 3
  mkdir -p "$work/$where-$variant"
  KEEP="$work/$where-$variant" taskset -c "$core" "$here/gpu_runs.sh" "$@" 2>>"$out/study.log" |
    sed "s/^{/{\"where\": \"$where\", \"variant\": \"$variant\", /" >>"$out/runs.jsonl"
  for f in "$work/$where-$variant"/*.txt; do
    [ -e "$f" ] && { echo "== $where $variant $(basename "$f" .txt)"; cat "$f"; }
  done >>"$out/timing.txt"
}

log "host reference: ${HOST_MEMBERS:-64} members a scene on core $last_core"
BATCH= runs host after "$last_core" "$host" "${HOST_MEMBERS:-64}" accelerated_gauss_seidel &
host_job=$!

if [ -n "$before" ]; then
  for variant in before after; do
    binary=$device
    [ "$variant" = before ] && binary=$before
    log "prefix of ${PREFIX_S:-30} s, $variant, $members members"
    LIMIT=${PREFIX_S:-30} STAGES=1 runs device "$variant-prefix" 0 "$binary" "$members" "$solver"
  done
fi

for size in ${TEAM_SIZES:-}; do
  log "prefix of ${PREFIX_S:-30} s, teams of $size threads, $members members"
  TEAM_SIZE=$size LIMIT=${PREFIX_S:-30} STAGES=1 runs device "team-$size-prefix" 0 "$device" \
    "$members" "$solver"
done

for fused in ${FUSED_STEPS:-0}; do
  for sweeps in ${SWEEPS_PER_LAUNCHES:-0}; do
    variant=after  # (the name of the whole runs before sweeps_per_launch existed)
    [ "$sweeps" = 0 ] || variant=sweeps-$sweeps
    [ "$fused" = 0 ] || variant=$variant-fused
    [ "${FENCED:-1}" = 1 ] || variant=$variant-unfenced
    log "whole runs on the device, sweeps_per_launch $sweeps, fused_step $fused, $members members"
    FUSED=$fused SWEEPS_PER_LAUNCH=$sweeps STAGES=${FENCED:-1} runs device "$variant" 0 "$device" \
      "$members" "$solver"
  done
done
wait "$host_job"
log "host reference done"

if [ -n "${PAPER_MEMBER_S:-}" ]; then
  log "a paper-size member for $PAPER_MEMBER_S s on the device and on host core $last_core"
  LOOSEPACK=$host FOR_S=$PAPER_MEMBER_S taskset -c "$last_core" \
    "$here/paper_size_member.sh" "$work/member-host" 2>>"$out/study.log" &
  member_job=$!
  members=(host)
  for size in ${PAPER_TEAM_SIZES:-0}; do
    where=device
    [ "$size" = 0 ] || where=device-team$size
    members+=("$where")
    LOOSEPACK=$device FOR_S=$PAPER_MEMBER_S TEAM_SIZE=$size "$here/paper_size_member.sh" \
      "$work/member-$where" 2>>"$out/study.log"
  done
  wait "$member_job"
  for where in "${members[@]}"; do  # the last progress line: disks deposited, seconds elapsed
    line=$(grep -h 'disks deposited' "$work/member-$where"/*.log 2>/dev/null | tail -n 1)
    if [ -z "$line" ]; then
      log "the paper-size member on the $where left no progress line; its log ends:"
      tail -n 5 "$work/member-$where"/*.log >>"$out/study.log" 2>&1
      continue
    fi
    sed -n "s/.* \([0-9][0-9]*\) disks deposited.* \([0-9][0-9]*\) s elapsed.*/{\"where\": \"$where\", \"disks\": \1, \"elapsed_s\": \2}/p" <<<"$line" |
      tee -a "$out/study.log" >>"$out/member.jsonl"
  done
fi

if [ -n "${TESTS:-}" ]; then
  left=$((${BUDGET_S:-540} - ($(date +%s) - t0) - 15))
  if [ "$left" -ge 30 ]; then
    # The tests that have not ended when the time is up are missing from tests.txt.
    log "tests ${TEST_FILTER:-*}, ${PARALLEL:-2} at a time, for at most $left s"
    # The tests' logs stay in $work: a device tool may bring back only a few files.
    FILTER=${TEST_FILTER:-*} LIMIT=$left PARALLEL=${PARALLEL:-2} OUT="$work/tests" \
      timeout "$left" "$here/gpu_tests.sh" "$TESTS" >>"$out/study.log" 2>&1
    for f in tests.txt failed_tails.txt; do
      [ -e "$work/tests/$f" ] && cp "$work/tests/$f" "$out/tests_$f"
    done
    awk '{n++; if ($2 == 0) p++; else if ($2 == 124) t++; else f++}
      END {print n + 0, "tests ended:", p + 0, "passed,", t + 0, "timed out,", f + 0, "failed"}' \
      "$out/tests_tests.txt" | tee -a "$out/study.log"
  else
    log "no time left for the tests"
  fi
fi
log "done"
cut -c1-240 "$out/runs.jsonl"
if command -v python3 >/dev/null; then  # the tables of docs/PERFORMANCE.md
  python3 "$here/gpu_summary.py" "$out/runs.jsonl" | tee "$out/summary.md"
fi
