#!/usr/bin/env bash
# Optional: build Kokkos 3.4.1 with a parallel backend from Debian's own trilinos source package
# (Debian ships Kokkos with the Serial backend only), install it under PREFIX, then build
# loosepack against it:
#
#   scripts/build-kokkos.sh openmp   # -> /opt/kokkos-openmp, build-openmp/
#       OMP_NUM_THREADS=2 ./build-openmp/loosepack run ...
#   scripts/build-kokkos.sh cuda     # -> /opt/kokkos-cuda, build-cuda/ (no MPI)
#       ./build-cuda/loosepack run ...   (on a machine with an NVIDIA GPU)
#
# cuda: installs Debian's nvidia-cuda-toolkit (CUDA 11.8, from the non-free component, added
# for bookworm if absent) and g++-11 (CUDA 11.8's newest host compiler), and builds for the GPU
# named by CUDA_ARCH (default 90, Hopper: H100/H200; 80 and 86 for Ampere, 75 Turing, 70 Volta).
# Kokkos 3.4.1 predates Hopper: for CUDA_ARCH=90 its AMPERE80 option is built with sm_90 code
# (a patch of the extracted source's cmake/kokkos_arch.cmake), which is what its start-up check
# wants on such a device (it refuses sm_80 code JIT-compiled for a 9.0 device).
# The build machine needs no GPU; the tests then run where one is (docs/PERFORMANCE.md,
# "Building for more cores or a GPU").
set -euo pipefail
cd "$(dirname "$0")/.."
backend="${1:-}"
case "$backend" in
  openmp) prefix="${PREFIX:-/opt/kokkos-openmp}" ;;
  cuda) prefix="${PREFIX:-/opt/kokkos-cuda}" ;;
  *)
    echo "usage: scripts/build-kokkos.sh openmp|cuda   (PREFIX=..., CUDA_ARCH=90|86|80|75|70)" >&2
    exit 2
    ;;
esac
bash scripts/install-deps.sh
SUDO=""  # as scripts/install-deps.sh: root writes the sources and /opt, anyone else through sudo
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

add_source() {  # add_source FILE TYPES COMPONENTS: a bookworm entry, unless present
  [ -f "/etc/apt/sources.list.d/$1" ] && return 0
  $SUDO tee "/etc/apt/sources.list.d/$1" >/dev/null <<SRC
Types: $2
URIs: http://deb.debian.org/debian
Suites: bookworm
Components: $3
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
  $SUDO apt-get update -qq
}

kokkos_options=(-DKokkos_ENABLE_SERIAL=ON -DCMAKE_CXX_STANDARD=17)
loosepack_options=()
if [ "$backend" = cuda ]; then
  arch="${CUDA_ARCH:-90}"
  case "$arch" in
    90 | 80) kokkos_arch=AMPERE80 ;;
    86) kokkos_arch=AMPERE86 ;;
    75) kokkos_arch=TURING75 ;;
    70) kokkos_arch=VOLTA70 ;;
    *) echo "build-kokkos.sh: CUDA_ARCH $arch not supported (90, 86, 80, 75, 70)" >&2; exit 2 ;;
  esac
  if [ ! -x /usr/lib/nvidia-cuda-toolkit/bin/nvcc ] || ! command -v g++-11 >/dev/null; then
    add_source loosepack-nonfree.sources deb "contrib non-free"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      nvidia-cuda-toolkit g++-11 >/dev/null
  fi
  # Debian's CUDA first, and its ptxas in /usr/bin (a machine may have another toolkit, whose
  # ptxas knows other GPUs, in /usr/local/cuda on the PATH).
  export PATH="/usr/lib/nvidia-cuda-toolkit/bin:/usr/bin:$PATH" NVCC_WRAPPER_DEFAULT_COMPILER=g++-11
  kokkos_options+=(-DKokkos_ENABLE_CUDA=ON -DKokkos_ENABLE_CUDA_LAMBDA=ON
    "-DKokkos_ARCH_${kokkos_arch}=ON" -DCUDAToolkit_INCLUDE_DIR=/usr/include)
  loosepack_options+=(-DCMAKE_CXX_COMPILER="$prefix/bin/nvcc_wrapper" -DLOOSEPACK_MPI=OFF)
else
  kokkos_options+=(-DKokkos_ENABLE_OPENMP=ON)
fi

# A CUDA install is for one GPU architecture: record it, and refuse to reuse it for another.
stamp="$prefix/loosepack-cuda-arch"
if [ "$backend" = cuda ] && [ -f "$prefix/lib/cmake/Kokkos/KokkosConfig.cmake" ] &&
  [ "$(cat "$stamp" 2>/dev/null || echo unknown)" != "$arch" ]; then
  echo "build-kokkos.sh: $prefix holds Kokkos built for CUDA_ARCH" \
    "$(cat "$stamp" 2>/dev/null || echo '(unrecorded)'), not $arch: set PREFIX to another" \
    "directory or remove $prefix" >&2
  exit 2
fi
if [ ! -f "$prefix/lib/cmake/Kokkos/KokkosConfig.cmake" ]; then
  apt-get source --print-uris trilinos >/dev/null 2>&1 || add_source loosepack-debsrc.sources deb-src main
  work=$(mktemp -d)
  (cd "$work" && apt-get source --download-only trilinos >/dev/null 2>&1)
  tar -xzf "$work"/trilinos_*.orig.tar.gz -C "$work" --wildcards '*/packages/kokkos/*'
  src=$(echo "$work"/Trilinos-*/packages/kokkos)
  if [ "$backend" = cuda ]; then
    kokkos_options+=(-DCMAKE_CXX_COMPILER="$src/bin/nvcc_wrapper")
    if [ "${CUDA_ARCH:-90}" = 90 ]; then
      sed -i 's/CHECK_CUDA_ARCH(AMPERE80  sm_80)/CHECK_CUDA_ARCH(AMPERE80  sm_90)/' \
        "$src/cmake/kokkos_arch.cmake"
      grep -q 'AMPERE80  sm_90' "$src/cmake/kokkos_arch.cmake" ||
        { echo "build-kokkos.sh: could not patch Kokkos for sm_90" >&2; exit 1; }
    fi
  fi
  cmake -S "$src" -B "$work/build" -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_BUILD_TYPE=Release \
    "${kokkos_options[@]}" >"$work/configure.log" 2>&1 ||
    { cat "$work/configure.log"; echo "build-kokkos.sh: Kokkos configure failed" >&2; exit 1; }
  cmake --build "$work/build" -j"$(nproc)"
  $SUDO cmake --install "$work/build" >/dev/null
  if [ "$backend" = cuda ]; then echo "$arch" | $SUDO tee "$stamp" >/dev/null; fi
  rm -rf "$work"
fi
log=$(mktemp)
cmake -S . -B "build-$backend" -DKokkos_ROOT="$prefix" -DCMAKE_BUILD_TYPE=Release \
  "${loosepack_options[@]}" >"$log" 2>&1 ||
  { cat "$log"; echo "build-kokkos.sh: configuring build-$backend failed" >&2; exit 1; }
rm -f "$log"
cmake --build "build-$backend" -j"$(nproc)"
echo "build-kokkos.sh: built build-$backend/ against $prefix"
