#!/usr/bin/env bash
# Installs the Debian bookworm packages loosepack needs (with --test: the test suite's too).
# Idempotent; quiet when all are present.
set -euo pipefail
if [ $# -gt 1 ] || { [ $# -eq 1 ] && [ "$1" != "--test" ]; }; then
  echo "usage: scripts/install-deps.sh [--test]" >&2
  exit 2
fi
packages=(
  build-essential cmake git pkg-config clang libclang-rt-dev
  libtrilinos-kokkos-dev libeigen3-dev libsuitesparse-dev libhdf5-dev
  libtomlplusplus-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopenmpi-dev openmpi-bin
  python3-h5py python3-matplotlib python3-numpy python3-pandas python3-scipy python3-xarray
)
# --test: what the test suite needs beyond that (pytest; ParaView's Python and ASE, which read
# the files `loosepack export` writes; venv, setuptools and wheel to pip-install python/ in a
# test; xvfb for rendering with ParaView, tools/render_deposit.py; strace and procps's pgrep,
# with which tests/resume_test.sh counts a run's checkpoint writes; time's /usr/bin/time, with
# which the bench scripts the suite runs measure CPU time).
if [ "${1:-}" = "--test" ]; then
  packages+=(python3-pytest python3-paraview python3-ase python3-venv python3-setuptools
    python3-wheel xvfb xauth strace procps time)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "install-deps: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
