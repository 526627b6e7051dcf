#!/usr/bin/env bash
# Checkpoint and resume: a run killed with SIGKILL and resumed, and ones stopped with SIGTERM
# and SIGINT and resumed, all give output identical to an uninterrupted run (tests/h5_equal.py),
# members finished before the interruption are not computed again, a member interrupted while
# it runs goes on from where it was, the members finished so far can be written without
# computing (--finished-only) and the run then continued, a stop writes the running member's
# snapshot once, and a checkpoint that does not belong to the scan, or is corrupt, is refused.
source "$(dirname "$0")/common.sh"
cd "$dir"

# 8 protocol-C members, one at a time, about 0.4 s each.
printf '[scan]\nname = "resume"\nprotocol = "C"\nseeds = 4\n[system]\nwidth = 24\nheight = 56\nbond_number = [10, 100]\n[observables]\nlower_half_from = 2\n' > s.toml
"$exe" run s.toml -o full.h5 --batch-size 1 -q
total=$("$exe" run s.toml -o again.h5 --batch-size 1 2>&1 | sed -n 's/.* 8\/8 members, \([0-9]*\) disks deposited.*/\1/p')
[ -n "$total" ] || fail "no final progress line"
same full.h5 again.h5

# Wait until the checkpoint holds a member or two, then interrupt with signal $1 (further
# arguments go to the run).
interrupt() {
  local sig=$1 out=$2 log=$3
  "$exe" run s.toml -o "$out" --batch-size 1 --checkpoint-every 0 "${@:4}" >"$log" 2>&1 &
  local pid=$!
  for _ in $(seq 1 600); do
    ls "$out.checkpoint/"*.bin >/dev/null 2>&1 && break
    sleep 0.02
  done
  ls "$out.checkpoint/"*.bin >/dev/null 2>&1 || fail "no checkpoint appeared"
  sleep 0.5
  kill "-$sig" "$pid"
  [ -n "${AGAIN:-}" ] && kill "-$sig" "$pid" 2>/dev/null  # a repeat, as a system may send one
  set +e
  wait "$pid"
  rc=$?
  set -e
}

interrupt KILL k.h5 k.log
[ "$rc" -eq 137 ] || fail "SIGKILL exit code $rc"
[ ! -e k.h5 ] || fail "a killed run left an output file"
# With a checkpoint after every member, each finished member is in a part of its own.
finished_parts=$(ls k.h5.checkpoint | grep -c '^part-1-0-[0-9]*\.bin$' || true)
msg=$("$exe" run s.toml -o k.h5 --batch-size 1 2>&1) && fail "a run over a checkpoint did not refuse"
grep -q "add --resume" <<< "$msg" || fail "message: $msg"
"$exe" run s.toml -o k.h5 --batch-size 1 --resume >resume.log 2>&1
grep -q "resuming from k.h5.checkpoint" resume.log || fail "no resume message: $(cat resume.log)"
done_before=$(sed -n 's/.*: \([0-9]*\) of 8 members finished.*/\1/p' resume.log)
[ "$done_before" -ge 1 ] && [ "$done_before" -lt 8 ] || fail "checkpoint held $done_before members"
[ "$finished_parts" -eq "$done_before" ] ||
  fail "$done_before members finished in $finished_parts parts, not one part each"
# Members in the checkpoint are not computed again: the progress counts every member's disks,
# the whole run's, of which those before the resume took no time here.
again=$(sed -n 's/.* 8\/8 members, \([0-9]*\) disks deposited.*/\1/p' resume.log)
before=$(sed -n 's/.* 8\/8 members, [0-9]* disks deposited (\([0-9]*\) before the resume).*/\1/p' \
  resume.log)
[ "$again" = "$total" ] && [ "${before:-0}" -gt 0 ] && [ "$before" -lt "$total" ] ||
  fail "resumed run: $again disks (${before:-no} before the resume), a whole run $total"
same full.h5 k.h5
[ ! -e k.h5.checkpoint ] || fail "checkpoint left behind after a complete run"

interrupt TERM t.h5 t.log
[ "$rc" -eq 143 ] || fail "SIGTERM exit code $rc: $(cat t.log)"
grep -q "continue with: loosepack run s.toml -o t.h5 --resume" t.log || fail "message: $(cat t.log)"
[ ! -e t.h5 ] || fail "an interrupted run wrote an output file"
# Each resume writes its running part under its own generation; the next resume removes an
# earlier one whose every snapshot a later part replaces (a copy of the checkpoint, resumed and
# stopped twice: generation 1's running part goes at the start of generation 3), and the run
# still ends with the uninterrupted run's file.
cp -r t.h5.checkpoint g.h5.checkpoint
[ -e g.h5.checkpoint/part-1-0.bin ] || fail "no running part after a stop: $(ls g.h5.checkpoint)"
interrupt TERM g.h5 g2.log --resume
[ -e g.h5.checkpoint/part-1-0.bin ] || fail "generation 2 removed generation 1's running part"
interrupt TERM g.h5 g3.log --resume
[ "$rc" -eq 143 ] || fail "SIGTERM exit code $rc: $(cat g3.log)"
[ ! -e g.h5.checkpoint/part-1-0.bin ] ||
  fail "generation 1's running part outlived two resumes: $(ls g.h5.checkpoint)"
"$exe" run s.toml -o g.h5 --batch-size 1 --resume -q
same full.h5 g.h5
# A dry run over the checkpoint says the run would be refused; with --resume it plans what is left.
"$exe" run s.toml -o t.h5 --dry-run | grep -q "checkpoint of an interrupted run exists (t.h5.checkpoint): the run would be refused without --resume" ||
  fail "a dry run did not see the checkpoint"
"$exe" run s.toml -o t.h5 --dry-run --resume > plan.txt
finished=$(sed -n 's/^# resuming from t.h5.checkpoint: \([0-9]*\) of 8 members finished, \([0-9]*\) to compute.*/\1 \2/p' plan.txt)
read -r done_ck left <<<"$finished"
[ -n "$done_ck" ] && [ "$done_ck" -ge 1 ] && [ $((done_ck + left)) -eq 8 ] || fail "plan: $(cat plan.txt)"
planned=$(awk '/^[0-9][0-9][0-9][0-9] / {n += $7} END {print n}' plan.txt)
[ "$planned" -eq "$left" ] || fail "the plan lists $planned members, $left are left: $(cat plan.txt)"
# The command the message gives goes on as the run began: over a file it was told to replace
# (--force), writing what it was asked to (--snapshots), run as printed.
echo old > sf.h5
interrupt TERM sf.h5 sf.log --snapshots --force
[ "$rc" -eq 143 ] || fail "SIGTERM exit code $rc: $(cat sf.log)"
hint=$(sed -n 's/.*continue with: \(.*\)$/\1/p' sf.log)
[ "$hint" = "loosepack run s.toml -o sf.h5 --snapshots --resume --force" ] || fail "hint: $hint"
"$exe" ${hint#loosepack } -q --batch-size 1 || fail "the printed command failed"
snapshots_of() {  # snapshots_of FILE: the file holds the final state of each of the 8 members
  /usr/bin/python3 - "$1" <<'PY' || fail "the snapshots of $1: see above"
import sys, h5py
with h5py.File(sys.argv[1], "r") as f:
    snaps = sum(1 for p in f["points"].values() for k in p["members"] if k.startswith("snapshot_"))
    assert snaps == 8, f"{snaps} snapshots of 8 members"
PY
}
snapshots_of sf.h5
# The final states (contact forces included) of the resumed run are the uninterrupted run's.
"$exe" run s.toml -o sfull.h5 --batch-size 1 --snapshots -q
same sfull.h5 sf.h5
# A resume without --snapshots of a run that asked for them writes them too (its checkpoint
# says so), where it used to drop them and then delete the checkpoint that held them.
interrupt TERM sn.h5 sn.log --snapshots
"$exe" run s.toml -o sn.h5 --batch-size 1 --resume 2>sn2.log
grep -q -- "--snapshots: the run that wrote sn.h5.checkpoint asked for the final states" sn2.log ||
  fail "no word of the snapshots kept: $(cat sn2.log)"
snapshots_of sn.h5
# SIGINT (Ctrl-C) likewise, resumed to the same file.
interrupt INT i.h5 i.log
[ "$rc" -eq 130 ] || fail "SIGINT exit code $rc: $(cat i.log)"
grep -q "interrupted by SIGINT" i.log || fail "message: $(cat i.log)"
[ ! -e i.h5 ] || fail "an interrupted run wrote an output file"
"$exe" run s.toml -o i.h5 --batch-size 1 --resume -q
same full.h5 i.h5
# A closed terminal (SIGHUP) saves as an interrupt does; the first signal is acknowledged, and
# a repeat of it (as of SIGXCPU, which the system sends every CPU second past a soft limit) does
# not cut the saving short as a second SIGINT or SIGTERM would.
AGAIN=1 interrupt HUP hup.h5 hup.log
[ "$rc" -eq 129 ] || fail "SIGHUP exit code $rc: $(cat hup.log)"
grep -q "stopping at the end of the step to save the checkpoint" hup.log &&
  grep -q "interrupted by SIGHUP: finished members" hup.log || fail "message: $(cat hup.log)"
"$exe" run s.toml -o hup.h5 --batch-size 1 --resume -q
same full.h5 hup.h5
# At a stop the running member's snapshot is written once, as it is taken, and not again as the
# run ends (a tall deposit's snapshot is megabytes): strace counts the renames onto the running
# part (part-1-0.bin; every part is written to a temporary file and renamed into place).
command -v strace >/dev/null || fail "strace is missing (scripts/install-deps.sh --test installs it)"
strace -f -qq -e trace=rename,renameat,renameat2 -o once.trace \
  "$exe" run s.toml -o once.h5 --batch-size 1 --checkpoint-every 0 >once.log 2>&1 &
tracer=$!
for _ in $(seq 1 600); do
  ls once.h5.checkpoint/*.bin >/dev/null 2>&1 && break
  sleep 0.02
done
sleep 0.5
kill -INT "$(pgrep -P "$tracer" | head -n 1)"
wait "$tracer" || true
grep -q "interrupted by SIGINT" once.log || fail "the traced run was not stopped: $(cat once.log)"
writes=$(grep -c 'rename.*"once\.h5\.checkpoint/part-1-0\.bin"' once.trace || true)
[ "$writes" -eq 1 ] || fail "the running part was written $writes times at a stop: $(cat once.trace)"
# The members finished so far, written without computing anything; the checkpoint stays, and
# the run then goes on from it (over the partial file, with --force) to the same file.
msg=$("$exe" run s.toml -o t.h5 --finished-only 2>&1) && fail "--finished-only without --resume ran"
grep -q "requires --resume" <<< "$msg" || fail "message: $msg"
"$exe" run s.toml -o t.h5 --resume --finished-only 2>fin.log ||
  fail "--finished-only: $(cat fin.log)"
grep -q "members finished so far" fin.log || fail "message: $(cat fin.log)"
[ -d t.h5.checkpoint ] || fail "--finished-only removed the checkpoint"
/usr/bin/python3 - t.h5 <<'PY' || fail "the partial file's members: see above"
import sys, h5py
with h5py.File(sys.argv[1], "r") as f:
    written = sum(int(g.attrs["members"]) for g in f["points"].values())
    unfinished = int(f.attrs["members_unfinished"])
    print(f"{written} members written, {unfinished} unfinished")
    assert written >= 1 and unfinished >= 1 and written + unfinished == 8
PY
"$exe" summary t.h5 | grep -q "an unfinished run" ||
  fail "summary does not say the run is unfinished"
msg=$("$exe" run s.toml -o t.h5 --resume 2>&1) &&
  fail "the partial file was replaced without --force"
grep -q "add --force" <<< "$msg" || fail "message: $msg"
# A checkpoint of another scan is refused (a setting edited), and so is a corrupt one; an edit of
# the scan file's comments and layout leaves its checkpoint usable.
cp s.toml edited.toml
sed -i 's/seeds = 4/seeds = 4 # edited/' edited.toml
cp -r t.h5.checkpoint e.h5.checkpoint
"$exe" run edited.toml -o e.h5 --resume 2>e.log || fail "a comment made the checkpoint unusable"
grep -q "resuming from e.h5.checkpoint: [1-9][0-9]* of 8 members finished" e.log ||
  fail "the commented scan's resume: $(cat e.log)"
# It announces what the plan above priced: the model's seconds of what is left.
want=$(sed -n 's/^# expected: about \([0-9.e+-]*\) CPU s in all.*/\1/p' plan.txt)
[ -n "$want" ] && grep -qF "loosepack: the cost model expects about $want CPU s" e.log ||
  fail "the resume's estimate is not the plan's ($want s): $(cat e.log)"
same full.h5 e.h5 --except scan_text --except scan_file
sed -i 's/seeds = 4 # edited/seeds = 5/' edited.toml
cp -r t.h5.checkpoint e5.h5.checkpoint
msg=$("$exe" run edited.toml -o e5.h5 --resume 2>&1) && fail "a checkpoint of another scan was used"
grep -q "belongs to a scan of other settings.*key 'scan.seeds' is \`4\` in the checkpoint's scan and \`5\` in this one" <<< "$msg" ||
  fail "message: $msg"
# A number written another way is the same setting (24 and 24.0, 100 and 1e2).
sed 's/width = 24/width = 24.0/; s/\[10, 100\]/[1e1, 1e2]/' s.toml > renumbered.toml
cp -r t.h5.checkpoint n.h5.checkpoint
"$exe" run renumbered.toml -o n.h5 --resume -q || fail "24.0 for 24 made the checkpoint unusable"
same full.h5 n.h5 --except scan_text --except scan_file
cp -r t.h5.checkpoint c.h5.checkpoint
part=$(ls c.h5.checkpoint/*.bin | head -1)
truncate -s -9 "$part"
msg=$("$exe" run s.toml -o c.h5 --resume 2>&1) && fail "a truncated checkpoint was used"
grep -q "corrupt or truncated.*delete that part alone to keep the others" <<< "$msg" ||
  fail "message: $msg"
# As the message says, the damaged part deleted alone: its members run again, the others' are kept.
rm "$part"
# A part that cannot be read (here a directory in its place) is named, with exit code 2.
mkdir c.h5.checkpoint/part-9-0.bin
set +e
msg=$("$exe" run s.toml -o c.h5 --resume 2>&1)
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "an unreadable part: exit code $rc, expected 2: $msg"
grep -q "^loosepack: cannot read c.h5.checkpoint/part-9-0.bin: Is a directory" <<< "$msg" ||
  fail "message: $msg"
rmdir c.h5.checkpoint/part-9-0.bin
"$exe" run s.toml -o c.h5 --resume -q
same full.h5 c.h5
"$exe" run s.toml -o t.h5 --batch-size 2 --resume --force -q
same full.h5 t.h5

# A resume may change protocol.max_collapse_time: the checkpoint's collapses that the new cap ends
# the same are kept, the others run again (stopped at the old cap, or past the new one), a running
# collapse goes on under the new cap short of it, and the file is the one a run with the new cap
# writes. At 12 sqrt(R/g) (1 200 steps at Bo = 10, 1 334 at 1e2) two collapses of point 0000 stop
# at the cap; the members run in order, so a checkpoint of 4 finished members holds both.
sed 's/^lower_half_from = 2$/&\n[protocol]\nmax_collapse_time = 12/' s.toml > c12.toml
"$exe" run c12.toml -o c12_full.h5 --batch-size 1 2>c12.log
grep -q "point 0000: the collapse of 2 of 4 finished members was stopped" c12.log ||
  fail "the cap of 12 stopped other collapses than two of point 0000: $(cat c12.log)"
killed_after_four() {  # SIGKILL once the checkpoint holds 4 finished members
  "$exe" run "$1" -o "$2" --batch-size 1 --checkpoint-every 0 >/dev/null 2>&1 &
  local pid=$!
  for _ in $(seq 1 1000); do
    [ -e "$2.checkpoint/part-1-0-4.bin" ] && break
    sleep 0.02
  done
  kill -KILL "$pid"
  wait "$pid" 2>/dev/null || true
  [ -e "$2.checkpoint/part-1-0-4.bin" ] && [ ! -e "$2" ] || fail "$2: no checkpoint of 4 members"
}
again_msg="2 members of %s collapsed otherwise than protocol.max_collapse_time = %s sqrt(R/g)"
killed_after_four s.toml lower.h5
"$exe" run c12.toml -o lower.h5 --resume --dry-run | grep -q "^# $(printf "$again_msg" lower.h5.checkpoint 12)" ||
  fail "--dry-run --resume does not say which members run again"
"$exe" run c12.toml -o lower.h5 --batch-size 1 --resume 2>lower.log
grep -q "$(printf "$again_msg" lower.h5.checkpoint 12)" lower.log || fail "$(cat lower.log)"
same c12_full.h5 lower.h5
killed_after_four c12.toml longer.h5
"$exe" run s.toml -o longer.h5 --batch-size 1 --resume 2>longer.log
grep -q "$(printf "$again_msg" longer.h5.checkpoint 3000)" longer.log || fail "$(cat longer.log)"
same full.h5 longer.h5
interrupt TERM run12.h5 run12.log  # a collapse running at the stop goes on, or runs again
"$exe" run c12.toml -o run12.h5 --batch-size 1 --resume -q
same c12_full.h5 run12.h5
# Members run with two caps are not one run's: merge refuses them.
"$exe" run s.toml -o m0.h5 --member 0 -q
"$exe" run c12.toml -o m1.h5 --member 1 -q
msg=$("$exe" merge m0.h5 m1.h5 -o m01.h5 --partial 2>&1) && fail "members of two caps merged"
grep -q "m1.h5 holds members of another scan than m0.h5: key 'protocol.max_collapse_time'" \
  <<< "$msg" || fail "message: $msg"

# A member stopped while it runs goes on from where it was: one protocol-A member of a few
# seconds, checkpointed every half second, stopped with SIGTERM once a checkpoint holds it and
# resumed, gives the uninterrupted run's file, depositing only the disks it had not.
printf '[scan]\nname = "running"\nprotocol = "A"\nseeds = 1\n[system]\nwidth = 24\nheight = 40\nbond_number = 10\n[observables]\nlower_half_from = 2\n' > r.toml
whole=$("$exe" run r.toml -o r_full.h5 2>&1 | sed -n 's/.* 1\/1 members, \([0-9]*\) disks deposited.*/\1/p')
"$exe" run r.toml -o r.h5 --checkpoint-every 0.5 >r.log 2>&1 &
pid=$!
for _ in $(seq 1 1000); do
  ls r.h5.checkpoint/*.bin >/dev/null 2>&1 && break
  sleep 0.02
done
ls r.h5.checkpoint/*.bin >/dev/null 2>&1 || fail "no checkpoint of the running member appeared"
sleep 0.7
kill -TERM "$pid"
set +e
wait "$pid"
rc=$?
set -e
[ "$rc" -eq 143 ] || fail "SIGTERM exit code $rc: $(cat r.log)"
grep -q "where the running ones were, are saved" r.log || fail "message: $(cat r.log)"
"$exe" run r.toml -o r.h5 --resume >r_resume.log 2>&1
grep -q "0 of 1 members finished, computing the other 1 (1 of them from where they were)" \
  r_resume.log || fail "no resume of the running member: $(cat r_resume.log)"
all=$(sed -n 's/.* 1\/1 members, \([0-9]*\) disks deposited.*/\1/p' r_resume.log)
before=$(sed -n 's/.* 1\/1 members, [0-9]* disks deposited (\([0-9]*\) before the resume).*/\1/p' \
  r_resume.log)
[ -n "$whole" ] && [ "${all:-}" = "$whole" ] && [ "${before:-0}" -gt 0 ] ||
  fail "the resumed member deposited ${all:-?} disks (${before:-?} before the resume)," \
    "a whole run ${whole:-?}"
same r_full.h5 r.h5
echo "resume: all checks passed"
