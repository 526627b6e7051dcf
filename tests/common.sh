# Sourced by the shell tests: the program's absolute path from $1, the repository $repo, a
# scratch directory $dir removed on exit, fail MESSAGE, and same A.h5 B.h5 (tests/h5_equal.py:
# equal results).
set -euo pipefail
exe=$(realpath "$1")
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
same() { /usr/bin/python3 "$here/h5_equal.py" "$1" "$2" >/dev/null || fail "$1 and $2 differ"; }
