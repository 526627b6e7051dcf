#!/usr/bin/env bash
# One paper-size protocol-A member (200 R x 800 R, the paper's stop rule), timed end to end across
# as many runs as it takes (docs/PERFORMANCE.md, "Scaling with system size"): the first call
# starts it, every later call resumes it from its checkpoint, and each call appends the run's
# CPU seconds against the disks deposited, once a minute and at its end, to OUT_DIR/progress.tsv
# (a line per run in OUT_DIR/runs.txt: its start, the binary's version and backend, the machine,
# --resume). When the member has finished, the summary (bench/paper_size_member.py) gives its
# total CPU and the exponent of the CPU against the disks deposited.
#
#   bench/paper_size_member.sh OUT_DIR [BOND_NUMBER] [SETTINGS]
#
# BOND_NUMBER: 1e3 (default; h = 0.0028) or 1e2 (h = 0.009), as the paper files set them.
# SETTINGS: "tall" (default: relaxation regions r = 8 checked every 10th disk and
# solver.tolerance = 3e-3, as the tall and wide fig. 7 files) or "defaults" (the program's).
# Stop it with Ctrl-C or SIGTERM: the run writes its checkpoint and the next call goes on.
# FOR_S=N stops the run so after N seconds (bench/gpu_study.sh's PAPER_MEMBER_S). LOOSEPACK names
# the binary (default build/loosepack). TEAM_SIZE=n (n > 0) sets solver.team_size, the team
# solver's threads for the member (a device's default solver; a member of its own, whose name
# says so); 0 or unset: the backend's choice.
set -euo pipefail
out=${1:?usage: paper_size_member.sh OUT_DIR [BOND_NUMBER] [SETTINGS]}
bond=${2:-1e3}
settings=${3:-tall}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/environment.sh"
exe=${LOOSEPACK:-$here/../build/loosepack}
[[ $exe == */* ]] && exe=$(realpath "$exe")  # the run goes on in OUT_DIR (a relative path would not)
case "$bond" in
  1e3) b=1000.0 dt=0.0028 ;;
  1e2) b=100.0 dt=0.009 ;;
  *) echo "paper_size_member.sh: BOND_NUMBER must be 1e3 or 1e2, not '$bond'" >&2; exit 2 ;;
esac
case "$settings" in
  tall | defaults) ;;
  *) echo "paper_size_member.sh: SETTINGS must be tall or defaults, not '$settings'" >&2; exit 2 ;;
esac
mkdir -p "$out"
cd "$out"
team=${TEAM_SIZE:-0}
[[ $team =~ ^[0-9]+$ ]] || { echo "paper_size_member.sh: TEAM_SIZE must be a count, not '$team'" >&2; exit 2; }
name="A_bo${bond}_${settings}"
[ "$team" -gt 0 ] && name="${name}_team$team"
if [ ! -f "$name.toml" ]; then
  {
    printf '[scan]\nname = "%s"\nseed = 2011\nseeds = 1\nbatch_size = 1\nprotocol = "A"\n\n' "$name"
    printf '[system]\nwidth = 200.0\nheight = 800.0\nbond_number = %s\ntime_step = %s\n\n' "$b" "$dt"
    printf '[protocol]\nstop_rule = "no_room"\n'
    if [ "$settings" = tall ]; then
      printf 'region_radius = 8.0\nregion_check_every = 10\n\n[solver]\ntolerance = 3e-3\n'
    else
      printf '\n[solver]\n'
    fi
    if [ "$team" -gt 0 ]; then printf 'team_size = %d\n' "$team"; fi
  } >"$name.toml"
fi
if [ -f "$name.h5" ]; then
  echo "paper_size_member.sh: $out/$name.h5 is finished; summary:" >&2
  exec python3 "$here/paper_size_member.py" progress.tsv
fi
resume=()
[ -d "$name.h5.checkpoint" ] && resume=(--resume)
[ -f progress.tsv ] || printf 'run\tepoch_s\tcpu_s\tdisks\n' >progress.tsv
touch runs.txt  # a line per run
run=$(($(wc -l <runs.txt) + 1))
environment=$(environment_text "$exe")
echo "$run $(date -u +%FT%TZ) $environment ${resume[*]}" >>runs.txt

# In a session of its own, so that a signal to this script's process group (Ctrl-C, timeout, a
# batch system) reaches it once, from the trap below: a second SIGINT would end it unsaved.
setsid "$exe" run "$name.toml" -o "$name.h5" --checkpoint-every 300 "${resume[@]}" \
  2>>"$name.log" &
pid=$!
tick=$(getconf CLK_TCK)
cpu= disks= written=
sample() {  # the run's CPU seconds (utime + stime) and its last progress line's disks
  local c d
  # After the command's name, utime and stime are the 12th and 13th fields.
  c=$(sed 's/^.*) //' "/proc/$pid/stat" 2>/dev/null |
    awk -v t="$tick" '{printf "%.1f", ($12 + $13) / t}') || return 0
  d=$(grep 'disks deposited' "$name.log" | tail -n 1 |
    sed -n 's/.* \([0-9][0-9]*\) disks deposited.*/\1/p') || return 0
  [ -n "$c" ] && [ -n "$d" ] && cpu=$c disks=$d
  return 0
}
record() {  # the last sample as a row of progress.tsv, once
  [ -n "$disks" ] && [ "$cpu $disks" != "$written" ] || return 0
  printf '%s\t%s\t%s\t%s\n' "$run" "$(date +%s)" "$cpu" "$disks" >>progress.tsv
  written="$cpu $disks"
}
trap 'kill -INT $pid 2>/dev/null; wait $pid || true; record; exit 130' INT TERM HUP
stopper=
if [ -n "${FOR_S:-}" ]; then
  { sleep "$FOR_S" && kill -INT "$pid" 2>/dev/null; } &
  stopper=$!
fi
# A sample every 5 s, a row every minute and at the end (the CPU of a run is then complete to
# within 5 s when the next run adds to it).
next=$(($(date +%s) + 60))
while kill -0 "$pid" 2>/dev/null; do
  sleep 5 &
  wait $! || true  # a signal's trap runs at once, not after the sleep
  sample
  [ "$(date +%s)" -ge "$next" ] || continue
  next=$((next + 60))
  record
done
record
rc=0
wait "$pid" || rc=$?
[ -n "$stopper" ] && { kill "$stopper" 2>/dev/null || true; }
if tail -n 1 "$name.log" | grep -q 'interrupted'; then
  tail -n 2 "$name.log" | head -n 1 >&2
elif [ "$rc" -ne 0 ]; then  # refused or failed: say so (the run's line in runs.txt stays)
  echo "paper_size_member.sh: loosepack run exited with $rc: $(tail -n 1 "$name.log")" >&2
  exit "$rc"
fi
[ -f "$name.h5" ] && python3 "$here/paper_size_member.py" progress.tsv
exit 0
