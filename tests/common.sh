# Sourced by the shell tests: the program's absolute path from $1, the repository $repo, a
# scratch directory $dir removed on exit, OpenMPI's environment for mpirun, fail MESSAGE, rc_of CMD, same A.h5 B.h5 (tests/h5_equal.py:
# equal results), and mixed_scan FILE (a small scan of three protocols).
set -euo pipefail
exe=$(realpath "$1")
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
# rc_of CMD...: runs CMD (which may fail) and leaves its exit status in $rc.
rc_of() {
  set +e
  "$@"
  rc=$?
  set -e
}
# OpenMPI as root (CI), and more ranks than cores where a test asks for them.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
same() {  # same A.h5 B.h5 [--except NAME]...: bit for bit but for the run's own records
  local rc=0
  /usr/bin/python3 "$here/h5_equal.py" "$@" >/dev/null || rc=$?
  [ "$rc" -ne 2 ] || fail "h5_equal.py: bad arguments: $*"
  [ "$rc" -eq 0 ] || fail "$1 and $2 differ"
}
# Members of three protocols and two sizes (so MPI shards differ in cost and in count), 3 seeds
# each: with LOOSEPACK_INJECT_NAN=1, member 1 (point 0, seed 1) fails.
mixed_scan() {
  cat > "$1" <<'TOML'
[scan]
name = "mixed"
seeds = 3
[[point]]
protocol = "C"
width = 16
height = 16
bond_number = 30
[[point]]
protocol = "B"
width = 24
height = 24
[[point]]
protocol = "A"
width = 12
height = 10
bond_number = 10
[observables]
lower_half_from = 2
TOML
}
