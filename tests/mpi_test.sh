#!/usr/bin/env bash
# MPI: a scan sharded over K = 1, 2 and 3 ranks (mpirun --oversubscribe) gives output identical
# to a run without mpirun (tests/h5_equal.py: every dataset and attribute but the run's times
# and rank count), with a failed member (injected NaN) among them, and progress and failures
# are printed once. (The failed member itself: tests/failure_test.sh.)
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
# The comparison itself can fail: another scan seed gives other datasets.
sed 's/name = "mixed"/name = "mixed"\nseed = 2/' s.toml > seed2.toml
"$exe" run seed2.toml -o seed2.h5 -q
/usr/bin/python3 "$here/h5_equal.py" serial.h5 seed2.h5 >/dev/null && fail "h5_equal saw no difference"
echo "mpi: all checks passed"
