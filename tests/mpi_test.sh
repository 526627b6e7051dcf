#!/usr/bin/env bash
# MPI: a scan sharded over K = 1, 2 and 3 ranks (mpirun --oversubscribe) gives output identical
# to a run without mpirun (tests/h5_equal.py: every dataset and attribute but the run's times
# and rank count), with a failed member (injected NaN) among them, and progress and failures
# are printed once; a signal to one rank stops them all, also one that reaches a rank that has
# finished its share while another computes. (The failed member itself:
# tests/failure_test.sh.)
source "$(dirname "$0")/common.sh"
cd "$dir"
mixed_scan s.toml
# With a failed member the file is written and the exit code is 3 (mpirun passes rank 0's on).
set +e
LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml -o serial.h5 --batch-size 2 2>serial.log
rc=$?
set -e
[ "$rc" -eq 3 ] || fail "serial: exit code $rc with a failed member, expected 3"
for k in 1 2 3; do
  set +e
  LOOSEPACK_INJECT_NAN=1 mpirun --oversubscribe -np $k "$exe" run s.toml -o k$k.h5 --batch-size 2 2>k$k.log
  rc=$?
  set -e
  [ "$rc" -eq 3 ] || fail "K=$k: exit code $rc with a failed member, expected 3"
  same serial.h5 k$k.h5
  [ "$(grep -c "failed: non-finite" k$k.log)" -eq 1 ] || fail "K=$k: failure printed $(grep -c "failed: non-finite" k$k.log) times"
  [ "$(grep -c "^loosepack: scan 'mixed'" k$k.log)" -eq 1 ] || fail "K=$k: header not printed once: $(cat k$k.log)"
  [ "$(grep -c "9/9 members" k$k.log)" -eq 1 ] || fail "K=$k: final progress: $(cat k$k.log)"
done
grep -q "3 MPI ranks" k3.log || fail "rank count not reported"
# A signal that reaches one rank only (rank 1, then rank 0) stops the whole run: every rank saves
# its checkpoint and ends with 128 + the signal, rank 0 says how to go on, and the checkpoint
# resumes (no rank waits for the stopped one).
printf '[scan]\nname = "long"\nseeds = 8\nprotocol = "A"\n[system]\nwidth = 30\nheight = 60\nbond_number = 1000\n[observables]\nlower_half_from = 2\n' >long.toml
# stopped_by_sigterm JOB NAME WHAT [SCAN]: the mpirun JOB of SCAN (long.toml) writing NAME.h5
# (log NAME.log) ends within 60 s with 128 + SIGTERM, says how to resume, writes no file, and its
# checkpoint resumes.
stopped_by_sigterm() {
  local job=$1 name=$2 what=$3 scan=${4:-long.toml}
  for _ in $(seq 600); do kill -0 "$job" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$job" 2>/dev/null; then
    kill -KILL "$job"
    fail "$what: the run did not end within 60 s: $(cat "$name.log")"
  fi
  set +e
  wait "$job"
  rc=$?
  set -e
  [ "$rc" -eq 143 ] || fail "$what: exit code $rc: $(cat "$name.log")"
  grep -q "interrupted by SIGTERM: .* continue with: loosepack run $scan -o $name.h5 --resume" \
    "$name.log" || fail "$what: no word of the resume: $(cat "$name.log")"
  [ ! -e "$name.h5" ] || fail "$what: the file was written"
  "$exe" run "$scan" -o "$name.h5" --resume --dry-run >/dev/null ||
    fail "$what: the checkpoint does not resume"
}
for victim in 1 0; do
  mpirun --oversubscribe -np 2 "$exe" run long.toml -o stop$victim.h5 --checkpoint-every 1 \
    2>stop$victim.log &
  job=$!
  for _ in $(seq 300); do grep -q "members," stop$victim.log && break; sleep 0.1; done
  for p in $(pgrep -P $job); do
    tr '\0' '\n' </proc/$p/environ | grep -qx "OMPI_COMM_WORLD_RANK=$victim" && kill -TERM $p
  done
  stopped_by_sigterm $job stop$victim "SIGTERM to rank $victim"
done
# A signal to rank 0 after its own share is done, while rank 1 computes (held by SIGSTOP until
# then), stops the whole run too: rank 1 saves where its members are, and the run ends with
# 128 + the signal and a checkpoint that resumes.
mpirun --oversubscribe -np 2 "$exe" run long.toml -o late.h5 --checkpoint-every 1 2>late.log &
job=$!
for _ in $(seq 300); do grep -q "members," late.log && break; sleep 0.1; done
declare -A rank_pid
for p in $(pgrep -P $job); do
  r=$(tr '\0' '\n' </proc/$p/environ | sed -n 's/^OMPI_COMM_WORLD_RANK=//p')
  rank_pid[$r]=$p
done
kill -STOP "${rank_pid[1]}"
for _ in $(seq 1200); do grep -q "4/8 members" late.log && break; sleep 0.1; done
if ! grep -q "4/8 members" late.log; then
  kill -CONT "${rank_pid[1]}"
  kill -KILL $job
  fail "rank 0's share did not finish: $(cat late.log)"
fi
kill -TERM "${rank_pid[0]}"
sleep 1
kill -CONT "${rank_pid[1]}"
stopped_by_sigterm $job late "SIGTERM to rank 0 after its share"
# A signal to rank 1 after its own share is done (a member 10 R tall against rank 0's 90 R one)
# stops the whole run too.
sed 's/seeds = 8/seeds = 1/; s/height = 60/height = [90.0, 10.0]/' long.toml >uneven.toml
mpirun --oversubscribe -np 2 "$exe" run uneven.toml -o late1.h5 --checkpoint-every 1 2>late1.log &
job=$!
for _ in $(seq 600); do grep -q "1/2 members" late1.log && break; sleep 0.1; done
grep -q "1/2 members" late1.log || fail "rank 1's share did not finish first: $(cat late1.log)"
sleep 2  # past its final message (a progress message may count the member first)
for p in $(pgrep -P $job); do
  tr '\0' '\n' </proc/$p/environ | grep -qx "OMPI_COMM_WORLD_RANK=1" && kill -TERM $p
done
stopped_by_sigterm $job late1 "SIGTERM to rank 1 after its share" uneven.toml
# The comparison itself can fail: another scan seed gives other datasets.
sed 's/name = "mixed"/name = "mixed"\nseed = 2/' s.toml > seed2.toml
"$exe" run seed2.toml -o seed2.h5 -q
/usr/bin/python3 "$here/h5_equal.py" serial.h5 seed2.h5 >/dev/null && fail "h5_equal saw no difference"
echo "mpi: all checks passed"
