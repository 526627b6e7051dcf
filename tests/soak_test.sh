#!/usr/bin/env bash
# A soak of the scheduler, the checkpoints and MPI: 10 000 tiny members (protocol A without
# cohesion in a 4 R x 4 R box, and ballistic deposits) on 2 ranks with a checkpoint every second.
# The file must equal a serial run's, and the ranks' memory may grow during the run only by what
# the results need: by no more than in the same run without checkpoints.
# Usage: soak_test.sh LOOSEPACK MPIRUN
source "$(dirname "$0")/common.sh"
mpirun=$2
cd "$dir"
cat > soak.toml <<'TOML'
[scan]
name = "soak"
seeds = 5000
[[point]]
protocol = "A"
width = 4
height = 4
bond_number = 0
[[point]]
protocol = "B"
width = 6
height = 6
[observables]
lower_half_from = 0
TOML
"$exe" run soak.toml -o serial.h5 -q

# Prints "N KIB": how many of mpirun and the ranks writing $1 run, and their resident memory summed.
rss_of_ranks() {
  local total=0 count=0 pid kb
  for pid in $(pgrep -f "loosepack run soak.toml -o $1"); do
    kb=$(awk '/^VmRSS/ {print $2}' "/proc/$pid/status" 2>/dev/null) || continue
    [ -n "$kb" ] || continue
    count=$((count + 1))
    total=$((total + kb))
  done
  echo "$count $total"
}
# Runs on 2 ranks into $1 with a checkpoint every $2 seconds; prints how much the memory grew
# from 1 s into the run to its peak, and the peak [KiB]. Only samples with mpirun and both ranks
# alive count: a rank that has not started yet or has already exited would read as growth or as
# shrinkage.
growth_of_run() {
  "$mpirun" -np 2 "$exe" run soak.toml -o "$1" -q --checkpoint-every "$2" &
  local run=$! first=0 peak=0 samples=0 count now
  while kill -0 "$run" 2>/dev/null; do
    sleep 0.5
    read -r count now < <(rss_of_ranks "$1")
    [ "$count" -eq 3 ] || continue
    samples=$((samples + 1))
    [ "$samples" -eq 2 ] && first=$now
    [ "$samples" -ge 2 ] && [ "$now" -gt "$peak" ] && peak=$now
  done
  wait "$run" || fail "the MPI run into $1 failed"
  [ "$samples" -ge 4 ] || fail "the run was too short to sample its memory ($samples samples)"
  echo $((peak - first)) "$peak"
}
run_with=$(growth_of_run mpi.h5 1)  # (a failure inside exits here)
run_without=$(growth_of_run plain.h5 1000000)
read -r with with_peak <<<"$run_with"
read -r without without_peak <<<"$run_without"
same serial.h5 mpi.h5
same serial.h5 plain.h5
[ -d mpi.h5.checkpoint ] && fail "the checkpoint outlived the run"
echo "soak: 10 000 members on 2 ranks; memory grew by $with KiB with a checkpoint every second, $without KiB without checkpoints"
# The growth is the results the ranks gather (the growth without checkpoints); checkpoints may
# add only what one encoding of the members finished since the last one holds while it is
# written (at most as much again) and the allocator's slack (8 MiB). When each checkpoint
# encoded every member finished so far and glibc kept the freed buffers, the runs grew by 14-26
# MiB with checkpoints against 6-18 MiB without; with the buffers handed back (malloc_trim,
# src/main.cpp), about 6 MiB either way (peak against the memory at 1 s). A leak of every
# checkpoint (about 20) fails it. The two runs' peaks are compared, not their growths, and the
# results' size is the file's: on a busy machine a rank may still be starting up at 1 s, which
# reads as growth.
results=$(($(stat -c %s plain.h5) / 1024))
[ "$with_peak" -le $((without_peak + results + 8192)) ] ||
  fail "checkpoints made the memory peak $((with_peak - without_peak)) KiB higher (results: $results KiB)"
echo "soak: ok"
