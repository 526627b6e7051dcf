#!/usr/bin/env bash
# Fig. 7 at the paper's width (docs/REPRODUCTION.md, "At the paper's width"): protocol A at
# Bo = 1e3 (or another Bond number) and one height, a wide box against a 40 R box, with the
# settings of the tall and wide fig. 7 files (relaxation regions r = 8 checked every 10th disk,
# `solver.tolerance` = 3e-3) and the paper's stop rule at both widths, scan seed 2011; then
# tools/compare.py on the pair.
#
#   bench/paper_width_pair.sh OUT_DIR HEIGHT [WIDTH] [WIDE_MEMBERS] [NARROW_MEMBERS] \
#     [BOND TIME_STEP]
#
# WIDTH of the wide box in R (default 200), WIDE_MEMBERS (default 2) and NARROW_MEMBERS (default
# 16) members; BOND and TIME_STEP another Bond number and its step for both boxes (fig. 11's:
# 100 0.009), the scans then named with _bo and the Bond number. Each scan runs as two shards
# side by side (`run --shard 0/2` and `1/2`, a core each) that write a checkpoint every 5
# minutes, then `loosepack merge` joins them. Stop it with Ctrl-C: the shards save their
# checkpoints, and the next call with the same arguments goes on from them (a shard whose file is
# there is not run again). The comparison is appended to OUT_DIR/comparison.jsonl, labelled with
# the shards' user CPU seconds and the program's version (the test bench_paper_width_pair_tiny
# runs it on boxes 48 R and 40 R wide, 24 R tall, at Bo = 1e3 and 1e2).
# LOOSEPACK names the binary (default build/loosepack); a checkpoint goes on only with the build
# that wrote it.
set -euo pipefail
usage="usage: paper_width_pair.sh OUT_DIR HEIGHT [WIDTH] [WIDE_MEMBERS] [NARROW_MEMBERS]"
usage+=" [BOND TIME_STEP]"
out=${1:?$usage}
height=$(printf '%.1f' "${2:?$usage}")
width=$(printf '%.1f' "${3:-200}")
wide_members=${4:-2}
narrow_members=${5:-16}
bond=${6:-} time_step=${7:-}
[ -z "$bond" ] || [ -n "$time_step" ] || { echo "$usage (BOND needs its TIME_STEP)" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
source "$here/environment.sh"
exe=$(realpath "${LOOSEPACK:-$here/../build/loosepack}")
paper="$here/../examples/paper"
mkdir -p "$out"
cd "$out"

# scan NAME EXAMPLE WIDTH MEMBERS: the example file at this height and width (and Bond number),
# its own name, the paper's stop rule, MEMBERS seeds in batches of one (a shard's members one
# after another).
scan() {
  local bond_edits=()
  [ -z "$bond" ] || bond_edits=(-e "s/^bond_number = .*/bond_number = $(printf '%.1f' "$bond")/"
    -e "s/^time_step = .*/time_step = $time_step/")
  sed -e "s/^name = .*/name = \"$1\"/" -e "s/^seeds = .*/seeds = $4/" \
    -e "s/^batch_size = .*/batch_size = 1/" -e "s/^width = .*/width = $3/" \
    -e "s/^height = .*/height = $height/" -e '/^stop_rule = /d' "${bond_edits[@]}" \
    -e 's/^\[protocol\]$/[protocol]\nstop_rule = "no_room"/' "$paper/$2" >"$1.toml"
  "$exe" run "$1.toml" --dry-run >/dev/null # refuses a file the edits broke, naming the line
}

# The scan file a result file was run from (its stored text), or nothing where it is absent.
stored_scan() {
  [ -e "$1" ] || return 0
  /usr/bin/python3 -c 'import h5py, sys
print(h5py.File(sys.argv[1], "r")["scan_text"][()].decode())' "$1"
}

# shards NAME: runs NAME.toml as two shards side by side, each going on from its checkpoint if
# it left one; merges them into NAME.h5. A result file of the name from another call (other
# members) is refused, not taken for this one.
shards() {
  local pids=() k file
  for file in "$1.h5" "$1-0.h5" "$1-1.h5"; do
    [ ! -e "$file" ] || [ "$(stored_scan "$file")" = "$(cat "$1.toml")" ] || {
      echo "paper_width_pair.sh: $out/$file was run from another scan than this call's" \
        "$1.toml (other members?): move it away, or give another OUT_DIR" >&2
      exit 2
    }
  done
  for k in 0 1; do
    [ -e "$1-$k.h5" ] && continue
    local resume=()
    [ -d "$1-$k.h5.checkpoint" ] && resume=(--resume)
    /usr/bin/time -q -f "%U" -a -o "$1-$k.cpu" \
      "$exe" run "$1.toml" -o "$1-$k.h5" --shard "$k/2" --checkpoint-every 300 "${resume[@]}" \
      2>>"$1-$k.log" &
    pids+=($!)
  done
  local failed=0 pid
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  [ "$failed" -eq 0 ] || {
    echo "paper_width_pair.sh: a shard of $1 stopped (its log: $out/$1-K.log); run again to go on" >&2
    exit 1
  }
  [ -e "$1.h5" ] || "$exe" merge "$1-0.h5" "$1-1.h5" -o "$1.h5" -q
}

# The user CPU seconds of NAME's shards over all their runs.
cpu() { cat "$1"-[01].cpu 2>/dev/null | awk '{s += $1} END {printf "%.0f", s}'; }

tag=${bond:+_bo$bond}
wide="wide${width%.0}_h${height%.0}$tag" narrow="narrow40_h${height%.0}$tag"
scan "$wide" fig07_scaled_profiles_wide.toml "$width" "$wide_members"
scan "$narrow" fig07_scaled_profiles_tall.toml 40.0 "$narrow_members"
shards "$wide"
shards "$narrow"
# compare.py's exit status 1 (some quantity differs) is a result, not a failure of this script.
# The label names the program that ran the members (the files' own commit); a pair compared
# before is not appended again.
commit=$(/usr/bin/python3 -c 'import h5py, sys
print(h5py.File(sys.argv[1], "r").attrs["git_commit"])' "$wide.h5")
if grep -qF "\"a\": \"$wide.h5\", \"b\": \"$narrow.h5\"" comparison.jsonl 2>/dev/null; then
  echo "paper_width_pair.sh: $wide against $narrow is in $out/comparison.jsonl already" >&2
  exit 0
fi
rc=0
/usr/bin/python3 "$here/../tools/compare.py" "$wide.h5" "$narrow.h5" --json comparison.jsonl \
  --label "H = $height: $width R wide, $wide_members members ($(cpu "$wide") CPU s) against 40 R wide, $narrow_members members ($(cpu "$narrow") CPU s); the members' loosepack of commit $commit, compared on $(environment_text "$exe")" ||
  rc=$?
[ "$rc" -le 1 ] || exit "$rc"
