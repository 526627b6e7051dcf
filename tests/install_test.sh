#!/usr/bin/env bash
# `cmake --install` of the build into a scratch prefix, then a project outside loosepack
# (tests/consumer) configured with find_package(loosepack) against it, built and run: it runs
# two small protocol-A members through the installed library; the Python package, installed and
# pip-installed; and the installed tools. Usage: install_test.sh BUILD_DIR
set -euo pipefail
build=$(realpath "$1")
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$dir/prefix" >"$dir/install.log" ||
  { cat "$dir/install.log"; fail "cmake --install"; }
for f in bin/loosepack include/loosepack/scan.hpp lib/cmake/loosepack/loosepackConfig.cmake \
  share/loosepack/python/loosepack/__init__.py share/loosepack/tools/plot.py; do
  [ -e "$dir/prefix/$f" ] || fail "the install lacks $f"
done
"$dir/prefix/bin/loosepack" --version | grep -q "^loosepack " || fail "the installed program"

cmake -S "$here/consumer" -B "$dir/consumer" -DCMAKE_PREFIX_PATH="$dir/prefix" \
  -DCMAKE_BUILD_TYPE=Release >"$dir/configure.log" 2>&1 ||
  { cat "$dir/configure.log"; fail "find_package(loosepack) against the install"; }
cmake --build "$dir/consumer" >"$dir/build.log" 2>&1 ||
  { cat "$dir/build.log"; fail "building the consumer"; }
out=$("$dir/consumer/consumer") || fail "the consumer ended with an error (exit $?)"
echo "$out"
# Two members ran and deposited disks; a cohesionless deposit's bulk density lies between a
# loose random packing and the densest packing of equal disks (pi / (2 sqrt 3) = 0.9069).
read -r _ members _ disks _ nu _ _ <<<"$out"
[ "$members" = 2 ] || fail "members: $members"
[ "$disks" -gt 20 ] || fail "disks: $disks"
awk -v nu="$nu" 'BEGIN { exit !(nu > 0.6 && nu < 0.9069) }' || fail "nu_lower_half $nu"

# The Python package: from the install tree, and installed by pip into a virtual environment
# (which uses Debian's h5py, pandas and xarray), each reading a file of the installed program.
printf '[scan]\nseeds = 2\n[system]\nwidth = 12\nheight = 12\nbond_number = 0\n' >"$dir/s.toml"
"$dir/prefix/bin/loosepack" run "$dir/s.toml" -o "$dir/s.h5" -q || fail "the installed program's run (exit $?)"
check_load='import sys, loosepack; p = loosepack.load(sys.argv[1]).points
assert list(p["members"]) == [2] and p["members"].dtype.kind == "i", p'
PYTHONPATH="$dir/prefix/share/loosepack/python" /usr/bin/python3 -c "$check_load" "$dir/s.h5" ||
  fail "the installed Python package"
# The installed tools, away from the source tree: plot.py finds claims.py beside it.
/usr/bin/python3 "$dir/prefix/share/loosepack/tools/plot.py" "$dir/s.h5" -o "$dir/fig" >/dev/null ||
  fail "the installed plot.py"
[ -s "$dir/fig/density_profiles.png" ] || fail "the installed plot.py drew no density profiles"
/usr/bin/python3 "$dir/prefix/share/loosepack/tools/claims.py" --help >/dev/null ||
  fail "the installed claims.py"
cp -r "$here/../python" "$dir/python"
/usr/bin/python3 -m venv --system-site-packages "$dir/venv" || fail "python3 -m venv (python3-venv)"
"$dir/venv/bin/pip" install -q --no-build-isolation --no-deps --no-index "$dir/python" ||
  fail "pip install python/"
(cd "$dir" && "$dir/venv/bin/python" -c "$check_load" "$dir/s.h5") || fail "the pip-installed package"
echo "install: ok"
