#!/usr/bin/env bash
# Relaxation regions against the whole-system relaxation on the same members (docs/PERFORMANCE.md,
# "Relaxation regions"): protocol A, 40 R wide, Bo = 1e2 and 1e3, 16 members at H = 120 and 8 at
# H = 180, each scene run once with the whole system and once with regions r = 8 checked every
# CHECK-th disk (default 10, as the tall files), then tools/compare.py --paired on each pair (the
# two runs of a scene hold the same members, started from the same drops).
#
#   bench/regions_comparison.sh OUT_DIR [CHECK] [JOBS]
#
# HEIGHTS="120" (default "180 120") runs only the scenes of those heights, BONDS="1e3" (default
# "1e3 1e2") only those Bond numbers, SEED=2028 (default 2027) other members: comparisons of
# several seeds (each in its own OUT_DIR) pool with bench/combine_paired.py.
# Runs JOBS (default 2) scans at a time, the longest first; a scan whose result is already in
# OUT_DIR is not run again. Appends one JSON line per pair to OUT_DIR/comparison.jsonl, with
# each run's user CPU seconds. About 2.5 CPU hours at CHECK = 10 (the whole-system runs at
# Bo = 1e2, H = 180 are half of it).
set -euo pipefail
out=${1:?usage: regions_comparison.sh OUT_DIR [CHECK] [JOBS]}
check=${2:-10}
jobs=${3:-2}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/environment.sh"
exe=$(realpath "${LOOSEPACK:-$here/../build/loosepack}")  # it runs from OUT_DIR
for bo in ${BONDS:-1e3 1e2}; do
  case "$bo" in
    1e3 | 1e2) ;;
    *) echo "regions_comparison.sh: BONDS takes 1e3 and 1e2 (the scenes' time steps), not $bo" >&2
       exit 2 ;;
  esac
done
mkdir -p "$out"
cd "$out"

scan() {  # scan NAME BOND_NUMBER TIME_STEP HEIGHT SEEDS [regions]
  {
    printf '[scan]\nname = "%s"\nseed = %s\nseeds = %s\nprotocol = "A"\n\n' "$1" "${SEED:-2027}" "$5"
    printf '[system]\nwidth = 40.0\nheight = %s\nbond_number = %s\ntime_step = %s\n' "$4" "$2" "$3"
    if [ "${6:-}" = regions ]; then
      printf '\n[protocol]\nregion_radius = 8.0\nregion_check_every = %s\n' "$check"
    fi
  } >"$1.toml"
}
names=()
for h in ${HEIGHTS:-180 120}; do
  seeds=$([ "$h" = 120 ] && echo 16 || echo 8)
  for bo in ${BONDS:-1e3 1e2}; do
    if [ "$bo" = 1e3 ]; then b=1000.0 dt=0.0028; else b=100.0 dt=0.009; fi
    scan "bo${bo}_h${h}_whole" "$b" "$dt" "$h.0" "$seeds"
    scan "bo${bo}_h${h}_regions${check}" "$b" "$dt" "$h.0" "$seeds" regions
    names+=("bo${bo}_h${h}_whole" "bo${bo}_h${h}_regions${check}")
  done
done
# A scan stopped before (its checkpoint beside it) goes on from it; the time file keeps a line
# per run of it.
run_one() {
  local resume=()
  [ -d "$1.h5.checkpoint" ] && resume=(--resume)
  [ -e "$1.h5" ] ||
    /usr/bin/time -a -f "user %U" -o "$1.time" "$2" run "$1.toml" -o "$1.h5" -q "${resume[@]}"
}
export -f run_one
printf '%s\n' "${names[@]}" | xargs -P "$jobs" -I{} bash -c 'run_one "$1" "$2"' _ {} "$exe"
for h in ${HEIGHTS:-180 120}; do
  for bo in ${BONDS:-1e3 1e2}; do
    a="bo${bo}_h${h}_whole" b="bo${bo}_h${h}_regions${check}"
    /usr/bin/python3 "$here/../tools/compare.py" "$a.h5" "$b.h5" --paired --json comparison.jsonl \
      --label "whole system ($(cat "$a.time" 2>/dev/null)) against regions r = 8, region_check_every = ${check} ($(cat "$b.time" 2>/dev/null)); $(environment_text "$exe")" ||
      true
  done
done
