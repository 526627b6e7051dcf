#!/usr/bin/env bash
# Command-line behaviour: help, a bad scan refused before any work with file:line and key, an
# existing result file left untouched, a small good run with its summary and plots, the
# re-analysis of a result file, and every shipped scan file accepted.
source "$(dirname "$0")/common.sh"

"$exe" --help | grep -qE "^ +run +Run a scan file" || fail "--help does not list run"
"$exe" run --help | grep -q -- "--output" || fail "run --help does not list --output"
"$exe" run --help | grep -q "out.h5" || fail "run --help does not say where the output goes by default"
# --version: the version, the commit, the backend and MPI; exit 0.
"$exe" --version | grep -qE "^loosepack [0-9]+\.[0-9]+\.[0-9]+ \(commit " || fail "--version: $("$exe" --version)"
"$exe" --version | grep -q "backend" || fail "--version names no backend"
# Usage errors exit 2 with a message: an unknown subcommand is named, a missing one said.
set +e
msg=$("$exe" runn x.toml 2>&1); rc=$?
[ "$rc" -eq 2 ] && grep -q "unknown subcommand 'runn'" <<< "$msg" || fail "unknown subcommand (exit $rc): $msg"
msg=$("$exe" 2>&1); rc=$?
[ "$rc" -eq 2 ] && grep -q "a subcommand is required" <<< "$msg" || fail "no subcommand (exit $rc): $msg"
msg=$("$exe" run 2>&1); rc=$?
[ "$rc" -eq 2 ] || fail "run without a scan file exited $rc, expected 2"
# Usage errors name the program, as its own messages do.
msg=$("$exe" summary "$dir" 2>&1); rc=$?
[ "$rc" -eq 2 ] && grep -q "^loosepack: file: File is actually a directory" <<< "$msg" ||
  fail "a directory given as the result file (exit $rc): $msg"
msg=$("$exe" run "$repo/examples/default.toml" --checkpoint-every nan --dry-run 2>&1); rc=$?
[ "$rc" -eq 2 ] || fail "--checkpoint-every nan exited $rc, expected 2: $msg"
# A count given as a fraction is called what it is, not out of range.
msg=$("$exe" run "$repo/examples/default.toml" --batch-size 2.0 --dry-run 2>&1); rc=$?
[ "$rc" -eq 2 ] && grep -q "^loosepack: --batch-size: '2.0' is not a whole number" <<< "$msg" ||
  fail "--batch-size 2.0 (exit $rc): $msg"
set -e
# Every scan file the repository ships is valid input.
for scan in "$repo"/examples/*.toml "$repo"/examples/paper/*.toml; do
  msg=$("$exe" run "$scan" -o "$dir/example.h5" --dry-run 2>&1) || fail "$scan: $msg"
done

printf '[system]\nwidth = 20\nfriction = -0.5\n' > "$dir/bad.toml"
echo "previous results" > "$dir/out.h5"
set +e
msg=$("$exe" run "$dir/bad.toml" -o "$dir/out.h5" 2>&1)
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "bad scan exit code $rc, expected 2"
grep -q "bad.toml:3:12: key 'system.friction': mu must be finite and >= 0" <<< "$msg" || fail "message: $msg"
[ "$(cat "$dir/out.h5")" = "previous results" ] || fail "existing output was touched"
ls "$dir" | grep -q tmp && fail "a temporary file was left behind"

# Every default agrees with the others: a scan of a 24 R box and nothing else (protocol A at
# Bo = 1e3, the time step and the observables' lengths from their defaults) runs without a
# warning.
printf '[scan]\nname = "defaults"\n[system]\nwidth = 24\nheight = 24\n' > "$dir/defaults.toml"
msg=$("$exe" run "$dir/defaults.toml" -o "$dir/defaults.h5" 2>&1) || fail "the defaults: $msg"
grep -qi "warning\|exceeds" <<< "$msg" && fail "the defaults warn: $msg"

# A collapse that takes the top below 2 lower_half_from leaves a member's final lower-half band
# empty: the run says so (nu_lower_half and the relative increase not defined), writes its file,
# and the summary says its means leave those members out.
# A ballistic deposit (nu about 0.38) at Bo = 1 compacts towards 0.8, so a 24 R deposit ends below
# 20 R.
cat > "$dir/empty_band.toml" <<'EOF'
[scan]
name = "empty_band"
seeds = 2
protocol = "C"
[system]
width = 12.0
height = 24.0
bond_number = 1.0
[observables]
lower_half_from = 10.0
EOF
msg=$("$exe" run "$dir/empty_band.toml" -o "$dir/empty_band.h5" -q 2>&1) ||
  fail "a collapse below the band: $msg"
want="point 0000: nu_lower_half, nu_initial and dnu/nu_i over 0 of 2 finished members: the others' final band"
grep -qF "warning: $want" <<< "$msg" || fail "no warning of the empty band: $msg"
# nu_initial is a mean over the same members as dnu/nu_i (none here), not over every member.
counts=$(/usr/bin/python3 -c "import h5py; a = h5py.File('$dir/empty_band.h5')['points/0000'].attrs
print(*(int(a[k + '_n']) for k in ('nu_initial', 'nu_final', 'relative_increase')))")
[ "$counts" = "0 0 0" ] || fail "nu_initial, nu_final, dnu/nu_i over $counts members"
"$exe" summary "$dir/empty_band.h5" | grep -qF "# $want" ||
  fail "summary does not say the means leave members out: $("$exe" summary "$dir/empty_band.h5")"

printf '[scan]\nname = "cli"\nprotocol = "B"\nseeds = 2\n[system]\nwidth = 20\nheight = 20\n[observables]\nlower_half_from = 2\n' > "$dir/good.toml"
# --dry-run lists the members with the cost model's estimate and writes nothing.
"$exe" run "$dir/good.toml" -o "$dir/good.h5" --dry-run > "$dir/dry.txt"
grep -qE "^0000 +B .* 2 +[0-9.e+-]+$" "$dir/dry.txt" || fail "--dry-run: $(cat "$dir/dry.txt")"
grep -q "^# expected: about " "$dir/dry.txt" || fail "--dry-run gives no estimate: $(cat "$dir/dry.txt")"
[ ! -e "$dir/good.h5" ] || fail "--dry-run wrote a file"
! grep -q "region_radius" "$dir/dry.txt" || fail "--dry-run of a scan without regions speaks of them"
grep -q "CPU s in all (the cost model" "$dir/dry.txt" || fail "--dry-run spells out a short estimate"
# The run itself announces the dry run's estimate at its start.
want=$(sed -n 's/^# expected: about \([0-9.e+-]*\) CPU s in all.*/\1/p' "$dir/dry.txt")
"$exe" run "$dir/good.toml" -o "$dir/announced.h5" 2>"$dir/announced.log"
[ -n "$want" ] && grep -qF "loosepack: the cost model expects about $want CPU s" "$dir/announced.log" ||
  fail "the run's estimate is not the dry run's ($want s): $(cat "$dir/announced.log")"
# A long estimate also in the unit a reader would use, the largest it fills once: here its seconds
# over a year of 365.25 days, or over a day (the seconds are printed to 3 digits: within 0.5 %).
line=$("$exe" run "$repo/examples/paper/fig06_avalanche_profile_1e3_full.toml" --dry-run | grep "^# expected: ")
secs=$(sed -n 's/^# expected: about \([0-9.e+]*\) CPU s in all.*/\1/p' <<<"$line")
said=$(sed -n 's/.*CPU s in all, \([0-9.]*\) \(years\|days\) of one core (.*/\1 \2/p' <<<"$line")
awk -v s="$secs" -v said="$said" 'BEGIN { split(said, w, " "); y = 365.25 * 86400;
  unit = s >= y ? "years" : "days"; want = s / (unit == "years" ? y : 86400);
  exit !(s >= 86400 && w[2] == unit && w[1] - want <= 0.005 * want + 0.05 &&
         want - w[1] <= 0.005 * want + 0.05) }' ||
  fail "--dry-run: '$line' does not give its $secs s in years or days of one core"
# A scan relaxing in regions is told how the model prices them.
"$exe" run "$repo/examples/paper/fig07_scaled_profiles_tall.toml" -o "$dir/tall.h5" --dry-run |
  grep -q "^# protocol.region_radius is set: the model prices protocol-A members relaxed in" ||
  fail "--dry-run of a region scan does not say what the model prices"
"$exe" run "$dir/good.toml" -o "$dir/out.h5" --dry-run | grep -q "out.h5 exists: the run would be refused without --force" ||
  fail "--dry-run onto an existing file does not say it would be refused"
# An output in a directory that does not exist is refused before any work, and said so; one
# under a regular file names that file as no directory.
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/nodir/x.h5" 2>&1); rc=$?
[ "$rc" -eq 2 ] && grep -q "the directory .*nodir of .*x.h5 does not exist" <<< "$msg" ||
  fail "output in a missing directory (exit $rc): $msg"
msg=$("$exe" run "$dir/good.toml" -o "$dir/good.toml/x.h5" 2>&1); rc=$?
[ "$rc" -eq 2 ] && grep -q "good.toml (of .*x.h5) is not a directory" <<< "$msg" ||
  fail "output under a regular file (exit $rc): $msg"
set -e
# A reader of the messages that goes away (a pipe into head) does not stop the run: it writes its
# file and exits 0 (a run of a few tenths of a second, which writes after head has gone).
printf '[scan]\nseeds = 2\n[system]\nwidth = 16\nheight = 16\nbond_number = 100\n' > "$dir/piped.toml"
set +e
"$exe" run "$dir/piped.toml" -o "$dir/piped.h5" 2>&1 | head -c 10 >/dev/null
rc=${PIPESTATUS[0]}
set -e
[ "$rc" -eq 0 ] && [ -s "$dir/piped.h5" ] || fail "a run whose stderr pipe closed exited $rc"
# Kokkos's own options pass through, as its 3.4 spells them (the help's --kokkos-threads).
"$exe" run "$dir/good.toml" -o "$dir/good.h5" -q --snapshots --kokkos-threads=1
"$exe" --version --kokkos-threads=1 | grep -q " backend, 1 thread(s)" ||
  fail "--kokkos-threads=1 did not reach Kokkos: $("$exe" --version --kokkos-threads=1)"
"$exe" --help | grep -q -- "--kokkos-threads=N" || fail "the help does not name --kokkos-threads"
# One Kokkos cannot read is invalid input (exit 2 with a message), not an abort.
for bad in "--kokkos-threads=abc" "--kokkos-threads=99999999999"; do
  set +e
  msg=$("$exe" run "$dir/good.toml" -o "$dir/never.h5" --dry-run "$bad" 2>&1); rc=$?
  set -e
  [ "$rc" -eq 2 ] && grep -q "a Kokkos option (--kokkos-...) or KOKKOS_ variable could not be read" \
    <<< "$msg" || fail "$bad (exit $rc): $msg"
done
# --timing: every stage of the (staged) step, then the solve's balance. With the team solver's
# solve split over launches of at most 4 sweeps, the first line says so, the slowest system sweeps at most 4
# times a launch, and fewer system steps end in a launch than systems take part in it.
printf '[scan]\nseeds = 2\n[system]\nwidth = 8\nheight = 8\n[solver]\nkind = "%s"\n%s\n%s\n' \
  coloured_accelerated_gauss_seidel "sweeps_per_launch = 4
fused_step = false" "[observables]
lower_half_from = 1" > "$dir/split.toml"
msg=$("$exe" run "$dir/split.toml" -o "$dir/split.h5" --timing 2>&1) || fail "split solve: $msg"
grep -q "coloured_accelerated_gauss_seidel (at most 4 sweeps a launch)" <<< "$msg" ||
  fail "the first line does not name the split: $msg"
for stage in margin grid free_velocity contacts solve integrate status scheduler snapshots; do
  grep -qE "^  $stage +[0-9.]+ s" <<< "$msg" || fail "--timing lists no stage $stage: $msg"
done
read -r systems slowest ended < <(echo "$msg" | awk '$1 == "solve:" && $3 == "systems" { n = $2 }
  $1 == "solve:" && $3 == "sweeps" { w = $2 } $1 == "solve:" && $4 == "steps" { e = $2 }
  END { print n + 0, w + 0, e + 0 }')
awk -v n="$systems" -v w="$slowest" -v e="$ended" 'BEGIN { exit !(w > 0 && w <= 4 && e > 0 && e < n) }' ||
  fail "split solve's balance: $systems systems, $slowest sweeps, $ended ended a launch: $msg"
# The fused step (solver.fused_step): the first line says so, and --timing shows its one launch
# a step (with the solve's balance) and the status's host side, and no other stage of the step.
printf '[scan]\nseeds = 2\n[system]\nwidth = 8\nheight = 8\n[solver]\nkind = "%s"\n%s\n%s\n' \
  coloured_accelerated_gauss_seidel "fused_step = true" "[observables]
lower_half_from = 1" > "$dir/fused.toml"
msg=$("$exe" run "$dir/fused.toml" -o "$dir/fused.h5" --timing 2>&1) || fail "fused step: $msg"
grep -q "coloured_accelerated_gauss_seidel, fused step (one launch a step)" <<< "$msg" ||
  fail "the first line does not name the fused step: $msg"
awk '$NF == "copies" && ($1 == "system_step" || $1 == "status") { rows[$1] = $(NF - 3) }
  $NF == "copies" && $1 ~ /^(margin|grid|free_velocity|contacts|solve|integrate)$/ { other = 1 }
  $1 == "system_step:" && $3 == "disks" { per_disk = $10 }
  END { exit !(rows["system_step"] == 1 && rows["status"] == 0 && !other && per_disk > 0) }' \
  <<< "$msg" || fail "--timing of a fused step: $msg"
# Whole solves of the staged step: the stages' cost per disk of a system step, in all and outside
# the solve.
printf '[scan]\nseeds = 2\n[system]\nwidth = 8\nheight = 8\n[solver]\nfused_step = false\n[observables]\nlower_half_from = 1\n' \
  > "$dir/timed.toml"
msg=$("$exe" run "$dir/timed.toml" -o "$dir/timed.h5" --timing 2>&1) || fail "timed run: $msg"
echo "$msg" | awk '$1 == "solve:" && $3 == "disks" { found = 1; all = $10; rest = $14 }
  END { exit !(found && rest > 0 && rest < all) }' ||
  fail "--timing gives no cost per disk, or one outside the solve that is not less: $msg"
# Its last line, after the file is written: the run's wall time, the parts before, running and
# after the members adding up to it, the loop of the table (its rows' sum) and the rest of running
# them adding up to that part (each rounded to a millisecond).
read -r all before members loop around after < <(grep '^loosepack: wall time' <<< "$msg" |
  grep -oE '[0-9]+\.[0-9]+' | paste -sd' ' -)
rows=$(awk '$NF == "copies" { for (k = 2; $(k + 1) != "s"; ++k); sum += $k } END { print sum }' <<< "$msg")
awk -v a="$all" -v b="$before" -v m="$members" -v l="$loop" -v r="$around" -v f="$after" -v t="$rows" \
  'BEGIN { d = a - b - m - f; e = m - l - r; g = l - t
           exit !(a > 0 && l > 0 && d * d < 4e-6 && e * e < 4e-6 && g * g < 1e-4) }' ||
  fail "--timing's wall time does not add up ($all = $before + $members + $after; $members = $loop + $around; the rows $rows): $msg"
# An existing result file is refused before any work, and replaced with --force.
cp "$dir/good.h5" "$dir/kept.h5"
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/good.h5" -q 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "exists; add --force to replace it" <<< "$msg" || fail "existing output (exit $rc): $msg"
cmp -s "$dir/good.h5" "$dir/kept.h5" || fail "a refused run touched the existing output"
"$exe" run "$dir/good.toml" -o "$dir/good.h5" -q --snapshots --force
# Output paths that cannot take a result file are refused before any work, even with --force:
# a FIFO, a device, a directory, a symbolic link, the scan file itself, an empty path.
mkfifo "$dir/fifo"
mkdir "$dir/adir"
ln -s "$dir/kept.h5" "$dir/link.h5"
cp "$dir/good.toml" "$dir/good.toml.orig"
for bad in "$dir/fifo" /dev/null "$dir/adir" "$dir/link.h5" "$dir/good.toml" ""; do
  set +e
  msg=$("$exe" run "$dir/good.toml" -o "$bad" -q --force 2>&1)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "-o '$bad' exited $rc: $msg"
done
[ -p "$dir/fifo" ] && [ -c /dev/null ] && [ -d "$dir/adir" ] && [ -L "$dir/link.h5" ] ||
  fail "a refused output path was replaced"
cmp -s "$dir/good.toml" "$dir/good.toml.orig" || fail "the scan file was overwritten"
# So is a name whose temporary, lock or checkpoint beside it would be longer than the file
# system's names (255 here): refused before any work, where the run would have computed its
# members and then failed to write them.
long=$(printf 'a%.0s' $(seq 1 240)).h5
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/$long" -q 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "is too long: the program writes" <<< "$msg" || fail "long name (exit $rc): $msg"
ls "$dir" | grep -q '^aaaa' && fail "a refused long name left a file"
# ... and one whose own temporary fits but whose checkpoint's, renamed on its way out
# (`<out>.checkpoint.tmp.<host>.<pid>`), would not: a finished run would leave its checkpoint.
host=$(hostname | sed 's/[^A-Za-z0-9_-]/_/g')
fits=$((255 - ${#host} - 13 - 5))  # the name's own temporary 5 characters short of the limit
short=$(printf 'b%.0s' $(seq 1 $((fits - 3)))).h5
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/$short" -q 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "is too long: the program writes $short.checkpoint.tmp." <<< "$msg" ||
  fail "a name whose checkpoint's temporary is too long (exit $rc): $msg"
# An output another run holds (its lock, with the holder's pid in it) is refused, run or
# analyse -o, even with --force; free again once the holder ends.
echo 4242 > "$dir/held.h5.lock"
flock -o "$dir/held.h5.lock" sleep 60 &
holder=$!
for try in 1 2 3 4 5 6 7 8 9 10; do flock -n "$dir/held.h5.lock" true || break; sleep 0.2; done
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/held.h5" -q --force 2>&1); rc=$?
msg2=$("$exe" analyse "$dir/good.h5" -o "$dir/held.h5" --force 2>&1); rc2=$?
set -e
pkill -P "$holder" sleep; wait "$holder" 2>/dev/null || true
[ "$rc" -eq 2 ] && grep -q "being written by another run (pid 4242" <<< "$msg" || fail "held lock (exit $rc): $msg"
[ "$rc2" -eq 2 ] && grep -q "being written by another run" <<< "$msg2" || fail "held lock, analyse (exit $rc2): $msg2"
[ -e "$dir/held.h5" ] && fail "a refused run wrote the held output"
# A file at the lock's path that is not a lock (a result file named so) is not overwritten or
# removed: the run is refused.
cp "$dir/good.h5" "$dir/users.h5.lock"
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/users.h5" -q 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "users.h5.lock is there and is not a lock of this program's" <<< "$msg" ||
  fail "a user's file at the lock's path (exit $rc): $msg"
cmp -s "$dir/good.h5" "$dir/users.h5.lock" || fail "a user's file at the lock's path was changed"
[ -e "$dir/users.h5" ] && fail "a refused run wrote its output beside a user's file at its lock"
rm "$dir/users.h5.lock"
# A temporary left by a run that died while writing on this host is removed by the next run of
# that output (named with the host, and as programs before the host was in the name wrote it);
# another host's, whose process cannot be seen from here, is left alone.
sleep 0 & dead=$!; wait "$dead"
host=$(hostname | sed 's/[^A-Za-z0-9_-]/_/g')
echo "half a file" > "$dir/held.h5.tmp.$dead"
echo "half a file" > "$dir/held.h5.tmp.$host.$dead"
echo "half a file" > "$dir/held.h5.tmp.other-node.$dead"
# A checkpoint a run was removing when it died (renamed to a temporary first). A directory that
# only looks like a temporary of the output (the program writes none) is a user's: left alone.
sleep 0 & gone=$!; wait "$gone"
mkdir "$dir/held.h5.checkpoint.tmp.$host.$dead" "$dir/held.h5.tmp.$gone"
echo "a part" > "$dir/held.h5.checkpoint.tmp.$host.$dead/part-1-0.bin"
echo "data" > "$dir/held.h5.tmp.$gone/keep.txt"
msg=$("$exe" run "$dir/good.toml" -o "$dir/held.h5" -q 2>&1)
for stale in "held.h5.tmp.$dead" "held.h5.tmp.$host.$dead" "held.h5.checkpoint.tmp.$host.$dead"; do
  grep -q "removed .*$stale, left by a run" <<< "$msg" || fail "stale temporary $stale: $msg"
  [ -e "$dir/$stale" ] && fail "the stale temporary $stale is still there"
done
[ -f "$dir/held.h5.tmp.$gone/keep.txt" ] || fail "a user's directory was removed: $msg"
rm -r "$dir/held.h5.tmp.$gone"
[ -e "$dir/held.h5.tmp.other-node.$dead" ] || fail "another host's temporary was removed: $msg"
rm "$dir/held.h5.tmp.other-node.$dead"
[ -e "$dir/held.h5.lock" ] && fail "the lock file outlived its run"
# On a file system without locks (flock fails with ENOLCK: NFS without lockd), the run goes on
# unlocked and says so, where it used to take the error for another run's lock and refuse.
if command -v cc >/dev/null; then
  printf '#include <errno.h>\nint flock(int fd, int op) { (void)fd; (void)op; errno = ENOLCK; return -1; }\n' \
    >"$dir/nolock.c"
  cc -shared -fPIC -o "$dir/nolock.so" "$dir/nolock.c"
  msg=$(LD_PRELOAD="$dir/nolock.so" "$exe" run "$dir/good.toml" -o "$dir/nolock.h5" -q 2>&1) ||
    fail "a run on a file system without locks: $msg"
  grep -q "cannot lock .*nolock.h5.lock (No locks available): a second run" <<< "$msg" ||
    fail "no warning of the missing lock: $msg"
  [ -s "$dir/nolock.h5" ] && [ ! -e "$dir/nolock.h5.lock" ] || fail "no file, or a lock file left"
fi
# A checkpoint that cannot be removed after the file is written (its rename on the way out fails
# with EBUSY) is named, with what to do; the file is complete and the run succeeds.
if command -v cc >/dev/null; then
  cat >"$dir/keepck.c" <<'EOF'
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <string.h>
int rename(const char* from, const char* to) {
  size_t n = strlen(from), k = strlen(".checkpoint");
  if (n >= k && strcmp(from + n - k, ".checkpoint") == 0) { errno = EBUSY; return -1; }
  return ((int (*)(const char*, const char*))dlsym(RTLD_NEXT, "rename"))(from, to);
}
EOF
  cc -shared -fPIC -o "$dir/keepck.so" "$dir/keepck.c" -ldl
  msg=$(LD_PRELOAD="$dir/keepck.so" "$exe" run "$dir/good.toml" -o "$dir/keepck.h5" -q 2>&1) ||
    fail "a run whose checkpoint cannot be removed: $msg"
  grep -q "cannot remove .*keepck.h5.checkpoint: .*the result file is complete" <<< "$msg" ||
    fail "no word of the checkpoint left: $msg"
  "$exe" summary "$dir/keepck.h5" >/dev/null || fail "the file beside the checkpoint left"
  rm -r "$dir/keepck.h5.checkpoint"
fi
# A protocol-C collapse stopped at protocol.max_collapse_time while still moving (0.2 sqrt(R/g),
# a twentieth of a free fall through two thirds of the box) is said at the end of the run and by
# summary.
printf '[scan]\nname = "cut"\nprotocol = "C"\nseeds = 2\n[system]\nwidth = 20\nheight = 30\nbond_number = 1000\ncapture_radius = 2.0\n[protocol]\nmax_collapse_time = 0.2\n[observables]\nlower_half_from = 2\n' >"$dir/cut.toml"
msg=$("$exe" run "$dir/cut.toml" -o "$dir/cut.h5" -q 2>&1) || fail "a run with capped collapses: $msg"
grep -q "warning: point 0000: the collapse of [12] of 2 finished members was stopped at protocol.max_collapse_time while still moving" <<< "$msg" ||
  fail "no warning of the capped collapses: $msg"
"$exe" summary "$dir/cut.h5" | grep -q "^# point 0000: the collapse of [12] of 2 finished members was stopped" ||
  fail "summary does not note the capped collapses: $("$exe" summary "$dir/cut.h5")"
# A file system without room for the run's checkpoint and results is refused before any work.
set +e
msg=$(LOOSEPACK_INJECT_FREE_BYTES=1000 "$exe" run "$dir/good.toml" -o "$dir/full.h5" 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "MiB free; the checkpoint of the members this run computes needs at least" <<< "$msg" ||
  fail "no room (exit $rc): $msg"
# Something at the checkpoint's path that cannot hold it is refused before any work, with
# --resume or without (the run would otherwise compute its members and lose them at its first
# checkpoint); a directory it cannot write into too (checked where not root).
echo "not a directory" > "$dir/ck.h5.checkpoint"
for resume in "" --resume; do
  set +e
  msg=$("$exe" run "$dir/good.toml" -o "$dir/ck.h5" $resume 2>&1); rc=$?
  set -e
  [ "$rc" -eq 2 ] && grep -q "ck.h5.checkpoint is not a directory, where this run keeps" <<< "$msg" ||
    fail "a file at the checkpoint's path ($resume, exit $rc): $msg"
done
"$exe" run "$dir/good.toml" -o "$dir/ck.h5" --dry-run | grep -q "is not a directory.*: the run would be refused" ||
  fail "--dry-run does not say a file at the checkpoint's path refuses the run"
rm "$dir/ck.h5.checkpoint"
if [ "$(id -u)" -ne 0 ]; then
  mkdir "$dir/ck.h5.checkpoint" && chmod 555 "$dir/ck.h5.checkpoint"
  set +e
  msg=$("$exe" run "$dir/good.toml" -o "$dir/ck.h5" --resume 2>&1); rc=$?
  set -e
  rmdir "$dir/ck.h5.checkpoint"
  [ "$rc" -eq 2 ] && grep -q "cannot write into the checkpoint .*ck.h5.checkpoint" <<< "$msg" ||
    fail "a checkpoint it cannot write into (exit $rc): $msg"
fi
# analyse -o '' is refused (it would mean the input itself), not taken as no -o.
set +e
msg=$("$exe" analyse "$dir/good.h5" -o '' 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "an empty path" <<< "$msg" || fail "analyse -o '' (exit $rc): $msg"
# analyse -o onto an existing file (here the scan file) is refused unless --force.
set +e
msg=$("$exe" analyse "$dir/good.h5" -o "$dir/good.toml" 2>&1)
rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "exists; add --force" <<< "$msg" || fail "analyse -o existing (exit $rc): $msg"
cmp -s "$dir/good.toml" "$dir/good.toml.orig" || fail "analyse -o overwrote the scan file"
# --resume where a finished run's file lies and no checkpoint does says so (not "add --force",
# which would not help), and leaves the file as it is.
cp "$dir/good.h5" "$dir/done.h5"
set +e
msg=$("$exe" run "$dir/good.toml" -o "$dir/done.h5" --resume 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "^loosepack: --resume: no checkpoint $dir/done.h5.checkpoint" <<< "$msg" &&
  ! grep -q "add --force" <<< "$msg" || fail "--resume over a finished run's file (exit $rc): $msg"
cmp -s "$dir/good.h5" "$dir/done.h5" || fail "--resume without a checkpoint changed the file"
"$exe" summary "$dir/good.h5" | grep -q "scan 'cli'" || fail "summary header"
"$exe" summary "$dir/good.h5" | grep -qE "^0000 +B " || fail "summary row"
"$exe" summary "$dir/good.h5" | grep -q "L_x" && fail "summary shows a width no point differs in"
# Points that differ in a parameter without a column of its own (the width, the radius) show it.
printf '[scan]\nprotocol = "B"\n[system]\nwidth = [20, 30]\nradius = [1, 2]\nheight = 30\n' \
  > "$dir/widths.toml"
"$exe" run "$dir/widths.toml" -o "$dir/widths.h5" -q
"$exe" summary "$dir/widths.h5" | grep -qE "^point .* mu_r +L_x +R +nu_lower_half" ||
  fail "summary of a scan over widths and radii: $("$exe" summary "$dir/widths.h5")"
"$exe" summary "$dir/widths.h5" | grep -qE "^0003 .* 30 +2 +0\." || fail "summary row of width 30, R 2"
# With a radius other than 1 the root's units say lengths are in the scan file's unit.
/usr/bin/python3 -c 'import h5py, sys; print(h5py.File(sys.argv[1])["/"].attrs["units"])' \
  "$dir/widths.h5" | grep -q "^lengths in the scan file's unit" || fail "units at radius 2"
# Points that differ only in floor_cohesion show it; a value wider than its column (mu_r
# 0.0123457 in 8) keeps a space before the next.
printf '[scan]\nprotocol = "B"\n[system]\nwidth = 12\nheight = 12\nrolling_friction = 0.0123457\n[[point]]\nfloor_cohesion = true\n[[point]]\nfloor_cohesion = false\n' \
  > "$dir/floor.toml"
"$exe" run "$dir/floor.toml" -o "$dir/floor.h5" -q
"$exe" summary "$dir/floor.h5" | grep -qE "^point .* mu_r +floor_coh +nu_lower_half" ||
  fail "summary of points differing in floor_cohesion: $("$exe" summary "$dir/floor.h5")"
"$exe" summary "$dir/floor.h5" | grep -qE "^0001 .* 0\.3 +0\.0123457 0 +0\." ||
  fail "summary row of mu_r 0.0123457, floor_cohesion false: $("$exe" summary "$dir/floor.h5")"
# Points 10000 and above come after 9999 (the groups' names sort otherwise).
printf '[scan]\nprotocol = "B"\n[system]\nwidth = 12\nheight = 12\nfriction = [0.1, 0.2, 0.3]\n' \
  > "$dir/many.toml"
"$exe" run "$dir/many.toml" -o "$dir/many.h5" -q
/usr/bin/python3 -c 'import h5py, sys
with h5py.File(sys.argv[1], "r+") as f:
    f.move("points/0000", "points/10000"); f.move("points/0001", "points/9999")' "$dir/many.h5"
[ "$("$exe" summary "$dir/many.h5" | grep -oE "^[0-9]+ " | tr -d ' ' | tr '\n' ' ')" = \
  "0002 9999 10000 " ] || fail "summary's point order: $("$exe" summary "$dir/many.h5")"
# The time step has a column where points of one Bond number differ in it (an axis), not where it
# follows the Bond number (the default h at Bo = 0 and 1e2: 0.01 and 0.009).
printf '[scan]\nprotocol = "A"\n[system]\nwidth = 12\nheight = 12\nbond_number = [0, 100]\n' \
  > "$dir/steps.toml"
"$exe" run "$dir/steps.toml" -o "$dir/follows.h5" -q
"$exe" summary "$dir/follows.h5" | grep -qE "^point .* mu_r +h " &&
  fail "summary shows a time step that follows the Bond number: $("$exe" summary "$dir/follows.h5")"
printf 'time_step = [0.01, 0.005]\n' >> "$dir/steps.toml"
"$exe" run "$dir/steps.toml" -o "$dir/steps.h5" -q
"$exe" summary "$dir/steps.h5" | grep -qE "^point .* mu_r +h +nu_lower_half" ||
  fail "summary of a scan over time steps: $("$exe" summary "$dir/steps.h5")"
"$exe" summary "$dir/steps.h5" | grep -qE "^0001 .* 0\.005 +0\." || fail "summary row of h = 0.005"
set +e
"$exe" summary "$dir/bad.toml" >/dev/null 2>&1 && fail "summary of a non-HDF5 file succeeded"
# A result file given as the scan file is named as not a text file.
set +e
msg=$("$exe" run "$dir/good.h5" -o "$dir/never.h5" --dry-run 2>&1)
rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "good.h5: not a text file" <<< "$msg" || fail "binary scan file: $msg"
set -e
# Figures from the result file (Debian's python3 with h5py and matplotlib).
/usr/bin/python3 "$repo/tools/plot.py" "$dir/good.h5" -o "$dir/fig" >/dev/null
for f in density_profiles avalanche_profiles abs_dy_histograms deposition_density \
  structure_0000_snapshot_0; do
  [ -s "$dir/fig/$f.png" ] || fail "plot.py did not write $f.png"
done
# Trajectories of a tiny collapse (protocol C) are drawn too.
printf '[scan]\nprotocol = "C"\n[system]\nwidth = 12\nheight = 12\nbond_number = 30\n[observables]\nlower_half_from = 2\ntrajectory_every = 3\ntrajectory_interval = 20\n' > "$dir/traj.toml"
"$exe" run "$dir/traj.toml" -o "$dir/traj.h5" -q
/usr/bin/python3 "$repo/tools/plot.py" "$dir/traj.h5" -o "$dir/fig" >/dev/null
[ -s "$dir/fig/trajectories_0000_trajectory_0.png" ] || fail "plot.py did not draw trajectories"
# A collapse at three heights, 3 seeds each.
printf '[scan]\nprotocol = "C"\nseeds = 3\n[system]\nwidth = 16\nheight = [16, 20, 24]\nbond_number = 30\n[observables]\nlower_half_from = 2\n' > "$dir/an.toml"
"$exe" run "$dir/an.toml" -o "$dir/an.h5" -q
# Three heights of protocol C: the summary ends with the fit of dnu/nu_i against ln H.
"$exe" summary "$dir/an.h5" | grep -A1 "^# fits across points" |
  grep -q "dnu/nu_i = (.*) ln H  \[chi2/dof .*\]  \[points 0000 0001 0002\]" ||
  fail "summary prints no fit across points, or not its points"
# The fit names the points it went through (all three heights).
/usr/bin/python3 -c 'import sys, h5py; f = h5py.File(sys.argv[1], "r")
sys.exit(list(f["analysis/increase_vs_log_height/scan_points"][()]) != [0, 1, 2])' "$dir/an.h5" ||
  fail "analysis/increase_vs_log_height/scan_points is not the three heights"
# A fit tried through points that did not settle (no coefficients) is named, not left out.
cp "$dir/an.h5" "$dir/unsettled.h5"
/usr/bin/python3 -c 'import sys, h5py, numpy as np; f = h5py.File(sys.argv[1], "r+")
g = f["analysis/increase_vs_log_height"]; g.attrs["valid"] = 0.0
for k in ("coef", "error"): del g[k]; g[k] = np.zeros(0)' "$dir/unsettled.h5"
"$exe" summary "$dir/unsettled.h5" | grep -A1 "^# fits across points" |
  grep -q "dnu/nu_i = no fit (did not settle)  \[points 0000 0001 0002\]" ||
  fail "summary does not name a fit across points that did not settle"
# Per point: the identity b' = b/(1+b) and a' = a/(1+b), and the deposition density's power law.
"$exe" summary "$dir/an.h5" > "$dir/an_summary.txt"
grep -q "b' = .*from b/(1+b): .*; a' = .*from a/(1+b): " "$dir/an_summary.txt" ||
  fail "summary prints no coefficient identity: $(cat "$dir/an_summary.txt")"
grep -q "deposition density nu_d = A y_i^p: A = .* +- .*, p = .* +- " "$dir/an_summary.txt" ||
  fail "summary prints no deposition power law: $(cat "$dir/an_summary.txt")"
# claims.py judges that fit too, and exits 1 exactly when it prints a FAIL.
set +e
/usr/bin/python3 "$repo/tools/claims.py" "$dir/an.h5" > "$dir/claims.txt"
rc=$?
set -e
grep -q "C across heights: dnu/nu_i grows with ln H  \[slope against ln H = " "$dir/claims.txt" ||
  fail "claims.py does not judge the fit across heights: $(cat "$dir/claims.txt")"
if grep -q "^FAIL" "$dir/claims.txt"; then [ "$rc" -eq 1 ]; else [ "$rc" -eq 0 ]; fi ||
  fail "claims.py exit code $rc does not match its verdicts"
# Ballistic deposition (A at Bo = inf, as in the default job): nothing moves, so no claim speaks
# about it (the histogram of abs(Delta y) = 0 is no Gaussian), and claims.py says so.
printf '[scan]\nprotocol = "A"\nseeds = 2\n[system]\nwidth = 12\nheight = 12\nbond_number = "inf"\n[observables]\nlower_half_from = 2\n' > "$dir/inf.toml"
"$exe" run "$dir/inf.toml" -o "$dir/inf.h5" -q
set +e
msg=$(/usr/bin/python3 "$repo/tools/claims.py" "$dir/inf.h5" 2>&1 >/dev/null)  # on stderr
rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "no scan point the claims speak about" <<< "$msg" ||
  fail "claims.py on a ballistic deposit (exit code $rc): $msg"
# Protocol A at two heights: the profiles scaled by H (the paper's fig. 7).
printf '[scan]\nprotocol = "A"\nseeds = 2\n[system]\nwidth = 12\nheight = [12, 16]\nbond_number = 50\n[observables]\nlower_half_from = 2\n' > "$dir/ah.toml"
"$exe" run "$dir/ah.toml" -o "$dir/ah.h5" -q
/usr/bin/python3 "$repo/tools/plot.py" "$dir/ah.h5" -o "$dir/fig_ah" >/dev/null
[ -s "$dir/fig_ah/scaled_avalanche_profiles.png" ] || fail "plot.py did not draw scaled_avalanche_profiles.png"
# The same two heights from two files (as tall runs come, a height per file): plot.py draws
# them as one set of points, so the scaled profiles appear, which neither file alone has.
for h in 12 16; do
  printf '[scan]\nprotocol = "A"\nseeds = 2\n[system]\nwidth = 12\nheight = %s\nbond_number = 50\n[observables]\nlower_half_from = 2\n' "$h" > "$dir/ah$h.toml"
  "$exe" run "$dir/ah$h.toml" -o "$dir/ah$h.h5" -q
  /usr/bin/python3 "$repo/tools/plot.py" "$dir/ah$h.h5" -o "$dir/fig_ah$h" >/dev/null
  [ ! -e "$dir/fig_ah$h/scaled_avalanche_profiles.png" ] || fail "plot.py scaled one height"
done
/usr/bin/python3 "$repo/tools/plot.py" "$dir/ah12.h5" "$dir/ah16.h5" -o "$dir/fig_ah2" >/dev/null
[ -s "$dir/fig_ah2/scaled_avalanche_profiles.png" ] ||
  fail "plot.py did not draw the scaled profiles of two files"
# The collapse's relative increase against H and nu_i, with the stored fits.
/usr/bin/python3 "$repo/tools/plot.py" "$dir/an.h5" -o "$dir/fig_an" >/dev/null
[ -s "$dir/fig_an/collapse_increase.png" ] || fail "plot.py did not draw collapse_increase.png"
[ ! -e "$dir/fig_an/scaled_avalanche_profiles.png" ] || fail "plot.py scaled protocol-C profiles"
# `analyse` recomputes the fits from the aggregates the file stores: an unchanged file gets the
# same fits; with the stored Delta y(y_i) means doubled (errors kept) and the old fits removed,
# the line's coefficients double; a non-HDF5 file is refused and left untouched.
"$exe" analyse "$dir/an.h5" -o "$dir/an2.h5"
/usr/bin/python3 "$repo/tests/h5_equal.py" "$dir/an.h5" "$dir/an2.h5" >/dev/null ||
  fail "analyse changed the fits of an unchanged file"
/usr/bin/python3 - "$dir/an2.h5" <<'EOF_PY'
import sys, h5py
with h5py.File(sys.argv[1], "r+") as f:
    g = f["points/0000/avalanche_by_yi"]
    g["mean"][...] = 2 * g["mean"][...]
    del g["fit"], f["analysis"]
EOF_PY
"$exe" analyse "$dir/an2.h5" 2>"$dir/an2.log"
grep -q "wrote the analysis of $dir/an2.h5 into it" "$dir/an2.log" || fail "analyse said: $(cat "$dir/an2.log")"
# -o naming the input by another path is in place too (without --force).
(cd "$dir" && "$exe" analyse an2.h5 -o ./an2.h5 2>"$dir/an2b.log") ||
  fail "analyse FILE -o ./FILE: $(cat "$dir/an2b.log")"
grep -q "wrote the analysis of an2.h5 into it" "$dir/an2b.log" || fail "analyse -o ./FILE said: $(cat "$dir/an2b.log")"
# Another hard link to the input is not in place (the write would replace the link, not the
# input): refused as the input file, even with --force.
ln "$dir/an2.h5" "$dir/an2_link.h5"
set +e
msg=$("$exe" analyse "$dir/an2.h5" -o "$dir/an2_link.h5" --force 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "is the input file" <<< "$msg" || fail "analyse -o a hard link of the input (exit $rc): $msg"
rm "$dir/an2_link.h5"
/usr/bin/python3 - "$dir/an.h5" "$dir/an2.h5" <<'EOF_PY' || fail "analyse did not refit the changed data"
import sys, h5py, numpy as np
fit = "points/0000/avalanche_by_yi/fit"
a, b = (h5py.File(p, "r") for p in sys.argv[1:])
assert a[fit].attrs["valid"] == 1 and b[fit].attrs["valid"] == 1
assert len(a[fit]["coef"]) == 2, a[fit]["coef"][:]
assert np.allclose(b[fit]["coef"][:], 2 * a[fit]["coef"][:], rtol=1e-9, atol=0), (a[fit]["coef"][:], b[fit]["coef"][:])
assert "analysis/increase_vs_log_height" in b
EOF_PY
# A file of a program before the per-member rows of the avalanche profiles: the same
# coefficients (they come from the pooled bin means), errors from the residual scatter.
/usr/bin/python3 - "$dir/an.h5" "$dir/an_old.h5" <<'EOF_PY'
import shutil, sys, h5py
shutil.copy(sys.argv[1], sys.argv[2])
with h5py.File(sys.argv[2], "r+") as f:
    for p in f["points"].values():
        for name in ("avalanche_by_yi", "avalanche_by_ye"):
            for field in ("member_position", "member_mean", "member_count"):
                del p[name][field]
EOF_PY
"$exe" analyse "$dir/an_old.h5"
/usr/bin/python3 - "$dir/an.h5" "$dir/an_old.h5" <<'EOF_PY' || fail "analyse of a file without member rows"
import sys, h5py, numpy as np
a, b = (h5py.File(p, "r") for p in sys.argv[1:])
for name in a["points"]:
    for key in ("avalanche_by_yi/fit", "avalanche_by_ye/fit"):
        fa, fb = a["points"][name][key], b["points"][name][key]
        if not fa.attrs["valid"]:
            continue
        assert np.allclose(fb["coef"][:], fa["coef"][:], rtol=1e-12, atol=1e-15), key
        assert np.all(np.isfinite(fb["error"][:]) & (fb["error"][:] > 0)), key
EOF_PY
cp "$dir/bad.toml" "$dir/bad_copy.toml"
set +e
msg=$("$exe" analyse "$dir/bad_copy.toml" 2>&1)
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "analyse of a non-HDF5 file: exit code $rc"
grep -q "bad_copy.toml is not an HDF5 file" <<< "$msg" || fail "analyse message: $msg"
cmp -s "$dir/bad.toml" "$dir/bad_copy.toml" || fail "analyse touched a file it refused"
# A file in a directory the user cannot write: analyse in place says why and how to write a copy
# (run as the unprivileged user nobody, for whom the permissions hold; root bypasses them; where
# nobody cannot run the program, as in a checkout under a private home, the check is left out).
as_nobody() { setpriv --reuid=nobody --regid=nogroup --clear-groups "$@"; }
if [ "$(id -u)" -eq 0 ] && command -v setpriv >/dev/null && id nobody >/dev/null 2>&1 &&
  as_nobody "$exe" --version >/dev/null 2>&1; then
  ro=$(mktemp -d)
  cp "$dir/good.h5" "$ro/r.h5"
  chmod 755 "$ro" && chmod 644 "$ro/r.h5"
  set +e
  msg=$(as_nobody "$exe" analyse "$ro/r.h5" 2>&1)
  rc=$?
  set -e
  rm -rf "$ro"
  [ "$rc" -eq 2 ] || fail "analyse in a read-only directory: exit code $rc ($msg)"
  grep -q "cannot write into $ro (for $ro/r.h5): Permission denied; .*analyse FILE -o NEW.h5" <<< "$msg" ||
    fail "analyse in a read-only directory: $msg"
fi
# A result file cut short (a copy or a full disk) is invalid input too, for each command.
head -c 5000 "$dir/good.h5" > "$dir/cut.h5"
for cmd in summary analyse export; do
  set +e
  msg=$("$exe" $cmd "$dir/cut.h5" 2>&1)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "$cmd of a truncated file: exit code $rc ($msg)"
  grep -q "cut.h5 is not an HDF5 file that can be opened" <<< "$msg" || fail "$cmd message: $msg"
done
# So is an HDF5 file of another kind (another program's, or an export's contacts file).
/usr/bin/python3 -c 'import h5py, sys; h5py.File(sys.argv[1], "w")["x"] = [1.0]' "$dir/other.h5"
for cmd in summary analyse export; do
  set +e
  msg=$("$exe" $cmd "$dir/other.h5" 2>&1)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] && grep -q "other.h5 is an HDF5 file but not a loosepack result" <<< "$msg" ||
    fail "$cmd of another HDF5 file: exit code $rc ($msg)"
done
# A result file that lacks what a command reads, or holds rows no run writes, is invalid input
# naming the file and the object, for each command that reads it.
/usr/bin/python3 - "$dir/good.h5" "$dir/noattr.h5" "$dir/rows.h5" <<'EOF_PY'
import shutil, sys, h5py
shutil.copy(sys.argv[1], sys.argv[2])
with h5py.File(sys.argv[2], "r+") as f:
    del f["points/0000"].attrs["protocol"]
shutil.copy(sys.argv[1], sys.argv[3])
with h5py.File(sys.argv[3], "r+") as f:
    g = f["points/0000/abs_dy_histogram"]
    rows = g["member_counts"][:1]
    del g["member_counts"]
    g["member_counts"] = rows
EOF_PY
set +e
msg=$("$exe" summary "$dir/noattr.h5" 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "noattr.h5: points/0000: HDF5: cannot open attribute points/0000@protocol" <<< "$msg" ||
  fail "summary of a file without a point's protocol (exit $rc): $msg"
# The summary names the point group whose data it cannot read, and a group under /points that no
# run names so.
/usr/bin/python3 - "$dir/good.h5" "$dir/count.h5" "$dir/extra.h5" <<'EOF_PY'
import shutil, sys, h5py
shutil.copy(sys.argv[1], sys.argv[2])
with h5py.File(sys.argv[2], "r+") as f:
    f["points/0000"].attrs["failed"] = -1.0
shutil.copy(sys.argv[1], sys.argv[3])
with h5py.File(sys.argv[3], "r+") as f:
    f.copy("points/0000", "points/extra")
EOF_PY
for want in "count.h5: points/0000: attribute failed = -1.000000 is not a count" \
            "extra.h5: /points/extra: not a group name the program writes"; do
  file=${want%%:*}
  set +e
  msg=$("$exe" summary "$dir/$file" 2>&1); rc=$?
  set -e
  [ "$rc" -eq 2 ] && grep -qF "$want" <<< "$msg" || fail "summary of $file (exit $rc): $msg"
done
set +e
msg=$("$exe" analyse "$dir/rows.h5" -o "$dir/rows2.h5" 2>&1); rc=$?
set -e
[ "$rc" -eq 2 ] && grep -q "rows.h5: points/0000: abs_dy_histogram/member_counts has 1 rows, one per member of 2" <<< "$msg" ||
  fail "analyse of a file with too few member rows (exit $rc): $msg"
[ ! -e "$dir/rows2.h5" ] || fail "analyse of a damaged file wrote its output"
# A file of the older layout (the scan text a root attribute, before 2026-11-25) is still a result
# file, for the program and the tools alike.
/usr/bin/python3 - "$dir/good.h5" "$dir/older.h5" <<'EOF_PY'
import shutil, sys, h5py
shutil.copy(sys.argv[1], sys.argv[2])
with h5py.File(sys.argv[2], "r+") as f:
    text = f["scan_text"][()]
    del f["scan_text"]
    f.attrs["scan_text"] = text
EOF_PY
"$exe" summary "$dir/older.h5" >/dev/null || fail "summary of a file of the older layout"
/usr/bin/python3 "$repo/tools/compare.py" "$dir/older.h5" "$dir/good.h5" >/dev/null ||
  fail "compare.py of a file of the older layout against its own results"
ls "$dir" | grep -q tmp && fail "analyse left a temporary file behind"
set +e
msg=$(/usr/bin/python3 "$repo/tools/plot.py" "$dir/bad.toml" 2>&1)
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "plot.py of a non-HDF5 file: exit $rc, expected 2"
# A result file lacking a dataset, or an attribute, that a figure needs: plot.py names it, and
# writes no figure (the deposition density is drawn after four other figures).
for what in dataset attribute late; do
  cp "$dir/good.h5" "$dir/lacks_$what.h5"
  /usr/bin/python3 - "$dir/lacks_$what.h5" "$what" <<'EOF_PY'
import sys, h5py
with h5py.File(sys.argv[1], "r+") as f:
    g = f["points/0000"]
    if sys.argv[2] == "dataset":
        del g["nu"]["mean"]
    elif sys.argv[2] == "late":
        del g["nu_deposition"]["mean"]
    else:
        del g.attrs["height"]
EOF_PY
  set +e
  msg=$(/usr/bin/python3 "$repo/tools/plot.py" "$dir/lacks_$what.h5" -o "$dir/fig_lacks_$what" 2>&1)
  rc=$?
  set -e
  [ "$rc" -eq 2 ] || fail "plot.py of a file without a needed $what: exit $rc, expected 2"
  case $what in
    dataset) want="lacks_dataset.h5: '/points/0000/nu/mean' is missing" ;;
    attribute) want="lacks_attribute.h5: attribute 'height' of '/points/0000' is missing" ;;
    late) want="lacks_late.h5: '/points/0000/nu_deposition/mean' is missing" ;;
  esac
  grep -qF "$want" <<< "$msg" || fail "plot.py message for a missing $what: $msg"
  grep -q "Traceback" <<< "$msg" && fail "plot.py crashed on a missing $what: $msg"
  [ ! -e "$dir/fig_lacks_$what" ] || fail "plot.py left a folder or figures of a file it refused"
done
echo "cli: all checks passed"
