#!/usr/bin/env bash
# Shards (`loosepack run --shard K/N`, then `loosepack merge`): the scan of three protocols,
# with trajectories and a failed member (injected NaN), run whole and as three shards. Merged in
# any order, the shards give the whole run's file (tests/h5_equal.py: every dataset and
# attribute but the run's times, ranks and the files merged), report the failure once and exit
# with 3; a shard run under mpirun (when the second argument names it) merges as the shard run
# without does; two of the three shards give a file that counts the third's members as missing,
# and that file with the third gives the whole run's again; files of single members (--member N)
# merge beside shards, and a member left out is named. Bad input is refused with exit code 2 and
# nothing written: a shard given twice, a member two files hold, a file of a whole scan, a shard
# of another scan, a damaged shard, an existing output, bad --shard values.
source "$(dirname "$0")/common.sh"
mpirun_cmd=${2:-}
cd "$dir"
mixed_scan s.toml
echo "trajectory_every = 4" >> s.toml  # into [observables], the scan's last table
expect_rc() {  # expect_rc CODE LOG COMMAND...: runs COMMAND, its stderr to LOG
  local want=$1 log=$2
  shift 2
  set +e
  "$@" 2>"$log"
  local rc=$?
  set -e
  [ "$rc" -eq "$want" ] || fail "exit code $rc, expected $want: $* ($(cat "$log"))"
}
expect_rc 3 whole.log env LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml -o whole.h5 --snapshots
failing=0
for k in 0 1 2; do
  set +e
  LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml --shard $k/3 -o p$k.h5 2>p$k.log
  rc=$?
  set -e
  [ -f p$k.h5 ] || fail "shard $k/3 wrote no file: $(cat p$k.log)"
  grep -q "(shard $k/3: [0-9]* of them)" p$k.log || fail "shard $k/3 not announced: $(cat p$k.log)"
  # Exit code 3 from the shard that holds the failed member, 0 from the others.
  if grep -q "failed: non-finite" p$k.log; then
    failing=$((failing + 1))
    [ "$rc" -eq 3 ] || fail "shard $k/3 with the failed member: exit code $rc, expected 3"
  else
    [ "$rc" -eq 0 ] || fail "shard $k/3: exit code $rc, expected 0: $(cat p$k.log)"
  fi
done
[ "$failing" -eq 1 ] || fail "the failed member reported by $failing shards, expected 1"
expect_rc 3 merge.log "$exe" merge p2.h5 p0.h5 p1.h5 -o merged.h5 --snapshots
same whole.h5 merged.h5
[ "$(grep -c "failed: non-finite" merge.log)" -eq 1 ] || fail "merge: $(cat merge.log)"
grep -q "with 9 members from 3 files" merge.log || fail "merge: $(cat merge.log)"
# The comparison can fail: without --snapshots the merged file lacks the whole run's snapshots.
expect_rc 3 plain.log "$exe" merge p0.h5 p1.h5 p2.h5 -o plain.h5
/usr/bin/python3 "$here/h5_equal.py" whole.h5 plain.h5 >/dev/null && fail "h5_equal saw no difference"
# A shard run with --snapshots merges into a file with them, as a resume of such a run writes
# them, and says so.
LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml --shard 0/3 -o ps0.h5 --snapshots 2>ps0.log || true
expect_rc 3 kept.log "$exe" merge ps0.h5 p1.h5 p2.h5 -o kept.h5
same whole.h5 kept.h5
grep -q "the files hold their members' final states (run --snapshots): the merged file holds" \
  kept.log || fail "merge of a shard with snapshots: $(cat kept.log)"
# Two shards of three are refused, naming the one missing; with --partial they give a file that
# counts the third's members as missing, and say so even with -q.
expect_rc 2 two.log "$exe" merge p0.h5 p2.h5 -o two.h5
grep -q "the files leave members out (shard 1/3): merge them all, or add --partial" two.log ||
  fail "two shards of three: $(cat two.log)"
[ ! -e two.h5 ] || fail "a refused merge wrote its file"
expect_rc 0 two.log "$exe" merge p0.h5 p2.h5 -o two.h5 -q --partial
grep -q "two.h5 leaves out shard 1/3" two.log || fail "partial merge: $(cat two.log)"
members_of() {
  /usr/bin/python3 -c "import h5py, sys
f = h5py.File(sys.argv[1], 'r')
print(sum(int(g.attrs['members']) for g in f['points'].values()), int(f.attrs['members_unfinished']))" "$1"
}
read -r n1 _ <<<"$(members_of p1.h5)"
read -r n02 missing <<<"$(members_of two.h5)"
[ "$missing" -eq "$n1" ] && [ $((n02 + n1)) -eq 9 ] ||
  fail "two shards: $n02 members, $missing missing; shard 1 has $n1"
unmerged="$n1 members not in this file (files not merged, or merged unfinished)"
"$exe" summary two.h5 | head -1 | grep -q "$unmerged" ||
  fail "summary of two shards: $("$exe" summary two.h5 | head -1)"
"$exe" summary p1.h5 | head -1 | grep -q "shard 1 of 3 of the scan" || fail "summary of a shard"
# A partial merge carries its members as a shard does: with the shard it left out, it merges to
# the whole run's file.
expect_rc 3 again.log "$exe" merge two.h5 p1.h5 -o again.h5 --snapshots
same whole.h5 again.h5
# Files of one member each (run --member N) merge as shards do, alone or beside shards: the
# members of shard 1 one by one, with shards 0 and 2, give the whole run's file; without one of
# them the merge names it; a member given twice is refused, naming both files.
ids_of() {  # ids_of FILE: its member ids (point x 3 seeds + seed_index)
  /usr/bin/python3 -c "import h5py, sys
f = h5py.File(sys.argv[1], 'r')
print(' '.join(str(int(p) * 3 + int(k))
               for p in f['points'] for k in f['points'][p]['members/seed_index']))" "$1"
}
ids=($(ids_of p1.h5))
[ "${#ids[@]}" -eq "$n1" ] || fail "shard 1's members: ${ids[*]} (expected $n1)"
singles=()
for id in "${ids[@]}"; do
  rc_of env LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml --member "$id" -o m$id.h5 -q 2>/dev/null
  [ -f m$id.h5 ] || fail "--member $id wrote no file"
  singles+=(m$id.h5)
done
"$exe" summary "${singles[0]}" | head -1 | grep -q "; some of the scan's members" ||
  fail "summary of one member's file: $("$exe" summary "${singles[0]}" | head -1)"
expect_rc 3 singles.log "$exe" merge "${singles[@]}" p0.h5 p2.h5 -o singles.h5 --snapshots
same whole.h5 singles.h5
if [ "$n1" -gt 1 ]; then
  expect_rc 2 short.log "$exe" merge "${singles[@]:1}" p0.h5 p2.h5 -o short.h5
  grep -q "the files leave members out (1 member of shard 1/3)" short.log ||
    fail "a member left out: $(cat short.log)"
fi
expect_rc 2 twice.log "$exe" merge p1.h5 "${singles[0]}" -o twice.h5
grep -q "${singles[0]} and p1.h5 both hold member ${ids[0]}: merge files of disjoint members" \
  twice.log || fail "a member given twice: $(cat twice.log)"
# Without shards, what the files leave out is named by member id.
expect_rc 2 ids.log "$exe" merge "${singles[0]}" -o ids.h5
grep -q "the files leave members out (members " ids.log || fail "members left out: $(cat ids.log)"
# Like every dataset (docs/OUTPUT.md), the shard's members say what they hold.
/usr/bin/python3 -c "import h5py, sys
sys.exit('long_name' not in h5py.File(sys.argv[1], 'r')['members_encoded'].attrs)" p1.h5 ||
  fail "members_encoded has no long_name"
# A point of one member has no standard error: the summary says nan, not a zero.
"$exe" summary p1.h5 | grep -q "^0000 .* +- nan " || fail "summary of one member: $("$exe" summary p1.h5)"
# A shard's file is a result file of its members (one a point here, whose errors are NaN): the
# tools read it.
/usr/bin/python3 "$repo/tools/plot.py" p1.h5 -o fig >plot.log 2>&1 || fail "plot.py: $(cat plot.log)"
set +e
/usr/bin/python3 "$repo/tools/claims.py" p1.h5 >claims.log 2>&1
rc=$?
set -e
# One member a point is no ensemble: every claim is skipped (exit 2, nothing judged), none fails.
[ "$rc" -eq 2 ] && grep -q "^SKIP .*1 member finished: no ensemble to judge" claims.log &&
  ! grep -q "Traceback" claims.log || fail "claims.py on a shard's file (exit $rc): $(tail -3 claims.log)"
if [ -n "$mpirun_cmd" ]; then
  set +e
  LOOSEPACK_INJECT_NAN=1 "$mpirun_cmd" --oversubscribe -np 2 "$exe" run s.toml --shard 0/3 \
    -o mpi0.h5 -q 2>mpi0.log
  set -e
  expect_rc 3 mpimerge.log "$exe" merge mpi0.h5 p1.h5 p2.h5 -o mpimerged.h5 --snapshots
  same whole.h5 mpimerged.h5
fi
# A shard whose file cannot be written keeps its members in its checkpoint and names itself in
# the command that writes the file; that command gives the shard's file, which merges as before.
expect_rc 1 wf.log env LOOSEPACK_INJECT_NAN=1 LOOSEPACK_INJECT_WRITE_FAILURE=1 \
  "$exe" run s.toml --shard 2/3 -o wf.h5
grep -q "write the file with: loosepack run s.toml -o wf.h5 --shard 2/3 --resume" wf.log ||
  fail "the hint after a failed write: $(cat wf.log)"
# Its checkpoint is refused to a resume of another shard (which would drop its members) and to
# one of the whole scan (which would compute every member into the shard's file), and kept.
expect_rc 2 other.log "$exe" run s.toml -o wf.h5 --shard 1/3 --resume
grep -q "wf.h5.checkpoint was written by a run of --shard 2/3, this one selects --shard 1/3" \
  other.log || fail "resume with another shard: $(cat other.log)"
expect_rc 2 all.log "$exe" run s.toml -o wf.h5 --resume
grep -q "written by a run of --shard 2/3, this one selects the whole scan" all.log ||
  fail "resume of the whole scan: $(cat all.log)"
[ "$(cat wf.h5.checkpoint/selection)" = "--shard 2/3" ] ||
  fail "the checkpoint's selection: $(cat wf.h5.checkpoint/selection)"
# A record that names no selection (an empty file) is refused, saying what to do.
mv wf.h5.checkpoint/selection selection.kept
: > wf.h5.checkpoint/selection
expect_rc 2 empty.log "$exe" run s.toml -o wf.h5 --shard 2/3 --resume
grep -q "selection (the --member or --shard of the run that wrote .*) cannot be read or is damaged" \
  empty.log || fail "an empty selection file: $(cat empty.log)"
# A checkpoint without that file (a build's that wrote none) is checked by the members it holds.
rm wf.h5.checkpoint/selection
expect_rc 2 old.log "$exe" run s.toml -o wf.h5 --shard 1/3 --resume
grep -q "wf.h5.checkpoint holds members this run does not select" old.log ||
  fail "resume of a checkpoint without its selection: $(cat old.log)"
mv selection.kept wf.h5.checkpoint/selection
"$exe" run s.toml -o wf.h5 --shard 2/3 --resume -q 2>/dev/null || true
expect_rc 3 wfmerge.log "$exe" merge p0.h5 p1.h5 wf.h5 -o wfmerged.h5 --snapshots
same whole.h5 wfmerged.h5
# The job array example (examples/slurm_shards.sh) as SLURM would run its three tasks, then again
# (every part finished: nothing to do), merges to the whole run's file; task 1 first alone, as
# after a resubmission of one task, and first stopped with its part written --finished-only.
array_task() {  # array_task K
  LOOSEPACK="$exe" SLURM_ARRAY_TASK_ID=$1 SLURM_ARRAY_TASK_COUNT=1 LOOSEPACK_INJECT_NAN=1 \
    bash "$repo/examples/slurm_shards.sh" s.toml array 3 >/dev/null 2>&1 || true
}
mkdir array
LOOSEPACK_INJECT_NAN=1 LOOSEPACK_INJECT_WRITE_FAILURE=1 \
  "$exe" run s.toml --shard 1/3 -o array/part-1.h5 -q 2>/dev/null || true
"$exe" run s.toml --shard 1/3 -o array/part-1.h5 --resume --finished-only -q 2>/dev/null || true
[ -f array/part-1.h5 ] && [ -d array/part-1.h5.checkpoint ] || fail "no part written --finished-only"
for k in 1 0 1 2 0 2; do array_task $k; done
[ ! -e array/part-1.h5.checkpoint ] || fail "the array's task 1 left its checkpoint"
expect_rc 3 array.log "$exe" merge array/part-0.h5 array/part-1.h5 array/part-2.h5 -o array.h5 \
  --snapshots
same whole.h5 array.h5
expect_rc 2 task.log env SLURM_ARRAY_TASK_ID=3 bash "$repo/examples/slurm_shards.sh" s.toml array 3
grep -q "task 3 of 3 shards: N must be a count above every task's index" task.log ||
  fail "a task beyond the shards: $(cat task.log)"
# Refused, with nothing written.
refused() {  # refused MESSAGE COMMAND...
  local message=$1
  shift
  expect_rc 2 refused.log "$@"
  grep -qF -- "$message" refused.log || fail "message for $*: $(cat refused.log)"
  [ ! -e bad.h5 ] || fail "$* wrote bad.h5"
}
refused "p0.h5 and p0.h5 are both shard 0/3" "$exe" merge p0.h5 p0.h5 -o bad.h5
"$exe" run s.toml --shard 1/2 -o half1.h5 -q 2>/dev/null || true
refused "half1.h5 is shard 1/2, p0.h5 one of 3: merge the shards of one split" \
  "$exe" merge p0.h5 half1.h5 -o bad.h5
refused "whole.h5: holds no encoded members: a file of a whole scan" "$exe" merge p0.h5 whole.h5 \
  -o bad.h5
sed 's/name = "mixed"/name = "mixed"\nseed = 2/' s.toml > other.toml
"$exe" run other.toml --shard 1/3 -o other1.h5 -q 2>/dev/null || true
refused "other1.h5 holds members of another scan than p0.h5: key 'scan.seed' is \`(none)\` in \
p0.h5 and \`2\` in other1.h5" \
  "$exe" merge p0.h5 other1.h5 -o bad.h5
# A shard of the scan file with a comment added, other spacing and the keys of [scan] in another
# order is of the same scan: it merges, and the merged file, given in any order, is the whole
# run's (whose scan text is that of shard 0).
sed -e '/^name = "mixed"$/d' -e 's/^seeds = 3$/seeds=3  # a comment\nname = "mixed"/' s.toml \
  > commented.toml
[ "$(sed -n 2,3p commented.toml)" = "$(printf 'seeds=3  # a comment\nname = "mixed"')" ] ||
  fail "the reordered scan file: $(head -4 commented.toml)"
set +e
LOOSEPACK_INJECT_NAN=1 "$exe" run commented.toml --shard 1/3 -o c1.h5 -q 2>/dev/null
set -e
expect_rc 3 cmerge.log "$exe" merge c1.h5 p2.h5 p0.h5 -o cmerged.h5 --snapshots
same whole.h5 cmerged.h5
cp p1.h5 damaged.h5
/usr/bin/python3 -c "import h5py, sys
with h5py.File(sys.argv[1], 'r+') as f:
    b = f['members_encoded'][()]
    b[len(b) // 2] ^= 0x10
    f['members_encoded'][...] = b" damaged.h5
refused "damaged.h5: members_encoded is corrupt" "$exe" merge p0.h5 damaged.h5 -o bad.h5
echo junk > junk.h5
refused "junk.h5 is not an HDF5 file that can be opened" "$exe" merge p0.h5 junk.h5 -o bad.h5
before=$(md5sum merged.h5)
refused "merged.h5 exists; add --force" "$exe" merge p0.h5 p1.h5 p2.h5 -o merged.h5
[ "$(md5sum merged.h5)" = "$before" ] || fail "an existing output was changed"
for bad in 3/3 1/0 x/3 -1/3; do
  refused "--shard $bad" "$exe" run s.toml --shard "$bad" -o bad.h5
done
refused "give K/N" "$exe" run s.toml --shard "" -o bad.h5
refused "too few for 999999999 shards" "$exe" run s.toml --shard 0/999999999 -o bad.h5 --dry-run
refused "--member excludes --shard" "$exe" run s.toml --shard 0/2 --member 1 -o bad.h5
refused "too few for 12 shards" "$exe" run s.toml --shard 11/12 -o bad.h5
echo "shards: all checks passed"
