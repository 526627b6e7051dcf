#!/usr/bin/env bash
# Whole runs for a GPU (or any backend): two small scenes, each solver, one batch of MEMBERS
# members, one JSON line per run on stdout (wall seconds, seconds per member, the summary's
# main observable). Written for the CUDA build's first whole-run measurement of the per-system
# solvers (docs/PERFORMANCE.md, "Building for more cores or a GPU"); the same scenes on one core
# here give the reference.
#
#   bench/gpu_runs.sh LOOSEPACK MEMBERS [SOLVER ...]
#     LOOSEPACK  the binary (build-cuda/loosepack, build/loosepack)
#     MEMBERS    members per scene, all in one batch (the seeds of one scan point) unless
#                BATCH=n sets the batch: then finished members' slots take the next members
#     SOLVER     solver.kind values (default: accelerated_gauss_seidel
#                coloured_accelerated_gauss_seidel)
#   STAGES=1 bench/gpu_runs.sh ...  runs with `--timing` (fenced after every stage, so the wall
#     time is not the plain run's) and adds "stages": per stage of the step its seconds, and its
#     kernel launches and deep copies per step, "steps": the batch's steps timed, and
#     "wall_parts": the run's wall time before its members, running them (the loop, and the
#     batch's set-up and last checkpoint around it) and after them (analysis and file).
#   LIMIT=seconds bench/gpu_runs.sh ...  stops each run after that many seconds (SIGINT: the run
#     checkpoints and prints its timing), for the cost per step of a prefix of a long run; such a
#     run has no summary, so its line has no observable.
#   KEEP=dir bench/gpu_runs.sh ...  keeps each run's standard error (its timing) as
#     dir/SCENE-SOLVER.txt.
#   TEAM_SIZE=n bench/gpu_runs.sh ...  sets solver.team_size (the team solver's threads per
#     system).
#   SWEEPS_PER_LAUNCH=n bench/gpu_runs.sh ...  sets solver.sweeps_per_launch (the team solver's
#     sweeps a launch; a longer solve goes on in the next launch). With STAGES=1 the line adds the
#     solve's balance from --timing: "balance": [systems a launch, their sweeps as % of the
#     launch's slowest system's, the slowest system's sweeps a launch, system steps ended a
#     launch].
#   NEWTON_EVERY=n bench/gpu_runs.sh ...  sets solver.newton_every (accelerated_gauss_seidel's
#     Newton steps; 0: none, which a fused step needs).
#   FUSED=1 (or 0) bench/gpu_runs.sh ...  sets solver.fused_step (every stage of a system's step
#     in its own team, one launch a step; unset: the backend's); with STAGES=1 the balance comes
#     from its one row.
#
# Scenes: "C" the accuracy study's collapse (protocol C, 24 R x 40 R, Bo = 1e3, r_capt = 2,
# h = 0.0028); "A" the default job's cohesive point (protocol A, 24 R x 24 R, Bo = 1e2).
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: bench/gpu_runs.sh LOOSEPACK MEMBERS [SOLVER ...]" >&2
  exit 2
fi
loosepack=$1
members=$2
shift 2
solvers=("$@")
[ ${#solvers[@]} -gt 0 ] || solvers=(accelerated_gauss_seidel coloured_accelerated_gauss_seidel)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

scene() {  # scene NAME SOLVER: the scan file's text
  local head="[scan]
name = \"gpu_$1\"
seed = 2026
seeds = $members
batch_size = ${BATCH:-$members}"
  case "$1" in
    C) printf '%s\nprotocol = "C"\n[system]\nwidth = 24.0\nheight = 40.0\nbond_number = 1000.0\ncapture_radius = 2.0\ntime_step = 0.0028\n' "$head" ;;
    A) printf '%s\nprotocol = "A"\n[system]\nwidth = 24.0\nheight = 24.0\nbond_number = 100.0\n' "$head" ;;
  esac
  printf '[solver]\nkind = "%s"\n' "$2"
  [ -n "${TEAM_SIZE:-}" ] && printf 'team_size = %d\n' "$TEAM_SIZE"  # (older builds lack the key)
  [ -n "${SWEEPS_PER_LAUNCH:-}" ] && printf 'sweeps_per_launch = %d\n' "$SWEEPS_PER_LAUNCH"
  [ -n "${FUSED:-}" ] && printf 'fused_step = %s\n' "$([ "$FUSED" = 1 ] && echo true || echo false)"
  [ -n "${NEWTON_EVERY:-}" ] && printf 'newton_every = %d\n' "$NEWTON_EVERY"
  printf '[observables]\nlower_half_from = 4.0\n'
}

for name in C A; do
  for solver in "${solvers[@]}"; do
    scene "$name" "$solver" >"$work/$name.toml"
    start=$(date +%s.%N)
    timing=()
    [ "${STAGES:-0}" = 1 ] && timing=(--timing)
    rm -f "$work/$name.h5"  # the other solver's file of this scene
    rm -rf "$work/$name.h5.checkpoint"
    limit=()
    [ -n "${LIMIT:-}" ] && limit=(timeout -s INT "$LIMIT")
    rc=0
    "${limit[@]}" "$loosepack" run "$work/$name.toml" -o "$work/$name.h5" -q "${timing[@]}" \
      2>"$work/timing.txt" || rc=$?
    wall=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')
    [ -n "${KEEP:-}" ] && cp "$work/timing.txt" "$KEEP/$name-$solver.txt"
    # timeout's 124: stopped at the limit, as asked; any other failure is the run's own.
    if [ -z "${LIMIT:-}" ] || [ $rc -ne 124 ]; then
      [ $rc -eq 0 ] || { cat "$work/timing.txt" >&2; exit $rc; }
      # The summary's table row: nu_lower_half, then (C) dnu/nu_i.
      row=$("$loosepack" summary "$work/$name.h5" |
        awk '$1 == "0000" { print $8, $10, $14, $16; exit }')
      read -r nu nu_err third third_err <<<"$row"
      observable="\"nu_lower_half\": [$nu, $nu_err]"
      [ "$name" = C ] && observable="$observable, \"dnu_over_nu_i\": [$third, $third_err]"
    else
      observable="\"stopped_after_s\": $LIMIT"
    fi
    if [ "${STAGES:-0}" = 1 ]; then  # "  NAME  S s  P %  L launches  C copies" lines
      stages=$(awk '$NF == "copies" { name = $1; for (k = 2; $(k + 1) != "s"; ++k) name = name " " $k
        printf "%s\"%s\": [%s, %s, %s]", sep, name, $k, $(k + 4), $(k + 6); sep = ", " }' "$work/timing.txt")
      steps=$(awk '$1 == "over" { print $2; exit }' "$work/timing.txt")
      # "  solve: N systems a launch, their sweeps P % ...", "  solve: S sweeps a launch by its
      # slowest system", "  solve: E system steps ended a launch" (absent: one launch a step)
      # (with FUSED=1 "  system_step: ...", the one launch's balance)
      balance=$(awk '$1 == "system_step:" { $1 = "solve:" }
        $1 == "solve:" && $3 == "systems" { n = $2; p = $8 }
        $1 == "solve:" && $3 == "sweeps" { w = $2 }
        $1 == "solve:" && $4 == "steps" { e = $2 }
        END { if (n != "") printf "[%s, %s, %s, %s]", n, p, (w == "" ? "null" : w), (e == "" ? n : e) }' \
        "$work/timing.txt")
      observable="$observable, \"steps\": ${steps:-null}, \"stages\": {$stages}"
      [ -n "$balance" ] && observable="$observable, \"balance\": $balance"
      # "loosepack: wall time T s: B s before the members ..., R s running them (the loop above
      # L s, the batch's set-up and the last checkpoint S s), A s after them ..." (absent: stopped)
      parts=$({ grep '^loosepack: wall time' "$work/timing.txt" || true; } |
        grep -oE '[0-9]+\.[0-9]+' | paste -sd' ' - || true)
      if [ -n "$parts" ]; then
        read -r p_all p_before p_members p_loop p_around p_after <<<"$parts"
        observable="$observable, \"wall_parts\": {\"program_s\": $p_all, \"before_s\": $p_before, \"members_s\": $p_members, \"loop_s\": $p_loop, \"around_loop_s\": $p_around, \"after_s\": $p_after}"
      fi
    fi
    printf '{"scene": "%s", "solver": "%s", "members": %d, "batch": %d, "team_size": %d, "sweeps_per_launch": %d, "fused_step": %s, "wall_s": %.2f, "per_member_s": %.4f, %s}\n' \
      "$name" "$solver" "$members" "${BATCH:-$members}" "${TEAM_SIZE:-0}" "${SWEEPS_PER_LAUNCH:-0}" "${FUSED:-null}" "$wall" "$(awk -v w="$wall" -v n="$members" 'BEGIN { print w / n }')" "$observable"
  done
done
