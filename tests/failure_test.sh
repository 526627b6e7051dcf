#!/usr/bin/env bash
# A failed member (injected NaN) is reported with its point, seed and Bond number and the
# command that re-runs it, excluded from its point's aggregates, kept as a diagnostic snapshot
# (drawn by tools/plot.py), and re-runs alone with --member. Runs in every build, MPI or not
# (tests/mpi_test.sh runs the same scan under mpirun).
source "$(dirname "$0")/common.sh"
cd "$dir"
mixed_scan s.toml
# The file is written, and the exit code says that members failed (3: docs/OUTPUT.md).
rc_of env LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml -o serial.h5 --batch-size 2 2>serial.log
[ "$rc" -eq 3 ] || fail "a run with a failed member exited $rc, expected 3"
[ -s serial.h5 ] || fail "a run with a failed member wrote no file"
grep -q "member 1 (point 0, seed 1, Bo 30) failed" serial.log || fail "failure not reported: $(cat serial.log)"
grep -q -- "--member 1 -o member-1.h5" serial.log || fail "no re-run command: $(cat serial.log)"
# The failed member: excluded from its point's aggregates, its state kept, re-run alone.
/usr/bin/python3 - <<'PY' || fail "failed member not recorded as such"
import h5py, numpy as np
with h5py.File("serial.h5") as f:
    g = f["points/0000"]
    assert g.attrs["members"] == 3 and g.attrs["failed"] == 1, dict(g.attrs)
    assert list(g["members/failure"][()]) == [0, 1, 0]
    s = g["members/failure_1"]
    assert not np.isfinite(s["vy"][()]).all() and len(s["x"]) == len(s["vx"])
    assert "failure_0" not in g["members"]
PY
"$exe" run s.toml --member 1 -o member-1.h5 -q
/usr/bin/python3 - <<'PY' || fail "re-run member"
import h5py
with h5py.File("member-1.h5") as f:
    assert list(f["points"]) == ["0000"], list(f["points"])
    g = f["points/0000"]
    assert g.attrs["members"] == 1 and g.attrs["failed"] == 0
    assert list(g["members/seed_index"][()]) == [1]
PY
/usr/bin/python3 "$repo/tools/plot.py" serial.h5 -o fig >/dev/null
[ -s fig/structure_0000_failure_1.png ] || fail "plot.py did not draw the failed member"
# A member that ends with disks overlapping beyond 0.25 R fails too (the overlap injected).
rc_of env LOOSEPACK_INJECT_OVERLAP=2 "$exe" run s.toml -o overlap.h5 --batch-size 2 2>overlap.log
[ "$rc" -eq 3 ] || fail "a run with an overlapping member exited $rc, expected 3"
grep -q "member 2 (point 0, seed 2, Bo 30) failed: two disks, or a disk and the floor, ended overlapping by more than 0.25 R" overlap.log ||
  fail "overlap not reported: $(cat overlap.log)"
# A member that ends with a disk above H + 4 R_max (one injected there, fixed) fails, and is
# left out of the aggregates.
rc_of env LOOSEPACK_INJECT_ESCAPE=1 "$exe" run s.toml -o escape.h5 --batch-size 2 2>escape.log
[ "$rc" -eq 3 ] || fail "a run with an escaped disk exited $rc, expected 3"
grep -q "member 1 (point 0, seed 1, Bo 30) failed: a disk ended outside the box" escape.log ||
  fail "escape not reported: $(cat escape.log)"
/usr/bin/python3 - escape.h5 <<'PY' || fail "the escaped member's aggregates: see above"
import sys, h5py
with h5py.File(sys.argv[1], "r") as f:
    g = f["points/0000"]
    failure = list(g["members/failure"][()])
    assert failure.count(5) == 1 and g.attrs["failed"] == 1, (failure, g.attrs["failed"])
    assert g.attrs["nu_lower_half_n"] == g.attrs["members"] - 1
PY
# A solution that blows up (Jacobi without mass splitting diverges on a cohesive deposit: disks
# thrown hundreds of R high) fails its member as soon as a disk moves faster than anything in
# the box can make it (Failure::Runaway) instead of passing its displacements into the
# aggregates; the file is written and the exit code is 3.
printf '[scan]\nseeds = 1\n[system]\nwidth = 12\nheight = 12\nbond_number = 100\n[solver]\nkind = "jacobi"\nmass_splitting = false\n[observables]\nlower_half_from = 2\n' > blow.toml
rc_of "$exe" run blow.toml -o blow.h5 -q 2>blow.log
[ "$rc" -eq 3 ] || fail "a blown-up member: exit code $rc, expected 3: $(cat blow.log)"
grep -q "failed: a disk moved faster than a fall through the box and cohesion can make it" blow.log ||
  fail "blow-up not reported: $(cat blow.log)"
"$exe" summary blow.h5 | grep -qE " 1\(1\)$" || fail "the blown-up member is not counted as failed"
# A final write that fails (as on a full disk) exits 1 and loses nothing: the results are in the
# checkpoint, and --resume writes the file, identical to a run whose write succeeded.
rc_of env LOOSEPACK_INJECT_NAN=1 LOOSEPACK_INJECT_WRITE_FAILURE=1 "$exe" run s.toml -o w.h5 --batch-size 2 2>w.log
[ "$rc" -eq 1 ] || fail "a failed final write exited $rc, expected 1: $(cat w.log)"
grep -q "the results are kept in w.h5.checkpoint.*--resume" w.log || fail "message: $(cat w.log)"
[ ! -e w.h5 ] && [ -d w.h5.checkpoint ] || fail "after a failed write: no checkpoint, or a file"
# The members the checkpoint holds take no more room: a resume on a nearly full file system
# (its free space injected) is not refused.
rc_of env LOOSEPACK_INJECT_FREE_BYTES=1000 "$exe" run s.toml -o w.h5 --batch-size 2 --resume -q 2>w2.log
[ "$rc" -eq 3 ] || fail "the resumed write exited $rc, expected 3 (a failed member): $(cat w2.log)"
same serial.h5 w.h5
[ ! -e w.h5.checkpoint ] || fail "the checkpoint was left after the resumed write"
# An error the run cannot go on from (injected as a member that cannot start, one at a time so
# that others finish before it) exits 1 and keeps the members finished before it, not saved yet
# at the default checkpoint pace: --resume computes only the others, and the file is the same.
rc_of env LOOSEPACK_INJECT_NAN=1 LOOSEPACK_INJECT_ERROR=8 "$exe" run s.toml -o x.h5 --batch-size 1 2>x.log
[ "$rc" -eq 1 ] || fail "an error while running exited $rc, expected 1: $(cat x.log)"
grep -q "member 8 could not start" x.log || fail "message: $(cat x.log)"
grep -q "the members it had finished are saved in x.h5.checkpoint.*--resume" x.log ||
  fail "message: $(cat x.log)"
rc_of env LOOSEPACK_INJECT_NAN=1 "$exe" run s.toml -o x.h5 --batch-size 2 --resume 2>x2.log
[ "$rc" -eq 3 ] || fail "the run resumed after an error exited $rc, expected 3: $(cat x2.log)"
grep -q "resuming from x.h5.checkpoint: [1-8] of 9 members finished" x2.log ||
  fail "nothing was kept: $(cat x2.log)"
same serial.h5 x.h5
# The commands the program prints work when pasted into a shell, whatever the paths hold (a
# space and a quote here).
mkdir paste
cp s.toml "paste/s p.toml"
(
  cd paste
  rc_of env LOOSEPACK_INJECT_NAN=1 "$exe" run "s p.toml" -o "o'p.h5" --batch-size 2 2>p.log
  rerun=$(sed -n 's/.*re-run it alone with: loosepack //p' p.log)
  [ -n "$rerun" ] || fail "no re-run command: $(cat p.log)"
  eval "\"\$exe\" $rerun -q" || fail "the printed command failed: $rerun"
  [ -s member-1.h5 ] || fail "the printed command wrote no member-1.h5: $rerun"
)

# The same on a file system that is really full: a tmpfs of 100 kB (the checkpoint, 22 kB, fits;
# the result, 180 kB, does not), mounted in a mount namespace of the test's own where it may
# (root). The write fails with its reason and exit 1, not a crash (HDF5 1.10 segfaulted at exit
# after a failed flush), and --resume, once there is room, writes the file.
mkdir full
if unshare -m sh -c 'mount -t tmpfs -o size=100k tmpfs "$1"' sh full 2>/dev/null; then
  unshare -m bash -c '
    mount -t tmpfs -o size=100k tmpfs full
    LOOSEPACK_INJECT_NAN=1 "$1" run s.toml -o full/w.h5 --batch-size 2 2>full.log
    echo $? >full.rc
    cp -r full/w.h5.checkpoint saved.checkpoint' bash "$exe"
  [ "$(cat full.rc)" -eq 1 ] || fail "a write to a full disk exited $(cat full.rc): $(cat full.log)"
  grep -q "No space left on device; the results are kept in full/w.h5.checkpoint" full.log ||
    fail "message of a write to a full disk: $(cat full.log)"
  mv saved.checkpoint full/w.h5.checkpoint  # the tmpfs is gone with its namespace
  rc_of "$exe" run s.toml -o full/w.h5 --batch-size 2 --resume -q 2>/dev/null
  [ "$rc" -eq 3 ] || fail "the write resumed after a full disk exited $rc, expected 3"
  same serial.h5 full/w.h5
else
  echo "failure_test: no tmpfs in a mount namespace here (not root?): the full-disk case is left out"
fi
echo "failure: all checks passed"
