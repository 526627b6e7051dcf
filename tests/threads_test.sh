#!/usr/bin/env bash
# A build with Kokkos OpenMP (scripts/build-kokkos.sh openmp): the results do not depend on the
# number of threads. The mixed scan (protocols A, B and C; tests/common.sh) is run on 1, 2 and 4
# threads with the host's solver (accelerated_gauss_seidel, one thread per system) and with the
# coloured solver (one team per system; its team reductions sum in an order fixed by the team
# size, which Kokkos OpenMP keeps at one thread here), and each file must equal the one-thread
# file bit for bit (tests/h5_equal.py). Given a second loosepack, built with another backend
# (scripts/test-openmp.sh gives the Serial build's), each one-thread file must also equal that
# one's file of the same scan, but for the backend's name (the attribute kokkos_execution_space)
# and the commit each was built from (git_commit: a build older by a commit of docs is as good).
# With the staged step (solver.fused_step = false) on 1 and 4 threads, each solver's file equals
# its one-thread file of the host's default, the fused step, but for the setting itself.
source "$(dirname "$0")/common.sh"
other=${2:+$(realpath "$2")}
export OMP_PROC_BIND=false
mixed_scan "$dir/mixed.toml"
# The thread counts take effect (else every run is the same one-thread run).
for threads in 1 2 4; do
  version=$(OMP_NUM_THREADS=$threads "$exe" --version)
  [[ "$version" == *" $threads thread(s)"* ]] || fail "OMP_NUM_THREADS=$threads: $version"
done
for kind in accelerated_gauss_seidel coloured_accelerated_gauss_seidel; do
  sed "s/^\[scan\]$/[solver]\nkind = \"$kind\"\n[scan]/" "$dir/mixed.toml" > "$dir/$kind.toml"
  for threads in 1 2 4; do
    OMP_NUM_THREADS=$threads "$exe" run "$dir/$kind.toml" -o "$dir/$kind-$threads.h5" -q
  done
  same "$dir/$kind-1.h5" "$dir/$kind-2.h5"
  same "$dir/$kind-1.h5" "$dir/$kind-4.h5"
  if [ -n "$other" ]; then
    "$other" run "$dir/$kind.toml" -o "$dir/$kind-other.h5" -q
    same "$dir/$kind-1.h5" "$dir/$kind-other.h5" --except kokkos_execution_space --except git_commit
  fi
  # The staged step (a launch per stage; the host's default is the fused one, a team per
  # system through every stage): the same files, but for the setting and the scan file's name
  # and text.
  sed 's/^\[solver\]$/[solver]\nfused_step = false/' "$dir/$kind.toml" > "$dir/$kind-staged.toml"
  for threads in 1 4; do
    OMP_NUM_THREADS=$threads "$exe" run "$dir/$kind-staged.toml" -o "$dir/$kind-staged-$threads.h5" -q
    same "$dir/$kind-1.h5" "$dir/$kind-staged-$threads.h5" --except solver_fused_step --except scan_text \
      --except scan_file
  done
done
echo "threads_test: bit-identical on 1, 2 and 4 threads${other:+ and with $other}"
