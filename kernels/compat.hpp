// Every spelling that differs between Kokkos versions lives here.
// Kokkos 3.4 (Debian bookworm) keeps math functions in Kokkos::Experimental; 3.7+ has them in
// Kokkos::. Drop the 3.4 branch once the minimum Kokkos is 3.7.
#pragma once
#include <Kokkos_Core.hpp>

namespace loosepack {
namespace kmath {
#if KOKKOS_VERSION >= 30700
using Kokkos::asin;
using Kokkos::fabs;
using Kokkos::floor;
using Kokkos::isfinite;
using Kokkos::sqrt;
#else
using Kokkos::Experimental::asin;
using Kokkos::Experimental::fabs;
using Kokkos::Experimental::floor;
using Kokkos::Experimental::isfinite;
using Kokkos::Experimental::sqrt;
#endif
KOKKOS_INLINE_FUNCTION double min(double a, double b) { return a < b ? a : b; }
KOKKOS_INLINE_FUNCTION double max(double a, double b) { return a > b ? a : b; }
KOKKOS_INLINE_FUNCTION double clamp(double v, double lo, double hi) {
  return v < lo ? lo : (v > hi ? hi : v);
}
KOKKOS_INLINE_FUNCTION int imin(int a, int b) { return a < b ? a : b; }
KOKKOS_INLINE_FUNCTION int imax(int a, int b) { return a > b ? a : b; }
}  // namespace kmath

using ExecSpace = Kokkos::DefaultExecutionSpace;
using MemSpace = ExecSpace::memory_space;
// One iteration per system for kernels whose cost differs from system to system by orders of
// magnitude (a per-system solve: one sweep at rest, thousands in an avalanche): handed out one
// at a time on a multi-threaded CPU backend (static chunks leave threads idle); GPUs ignore it.
using PerSystemPolicy = Kokkos::RangePolicy<ExecSpace, Kokkos::Schedule<Kokkos::Dynamic>>;
template <class T>
using DView = Kokkos::View<T*, MemSpace>;
// The views of the kernels' bundles (kernels/state.hpp): unmanaged, so that a kernel's copy of a
// bundle counts no references. On a host backend each counted copy of a view is an atomic
// increment and decrement, and a step copies the bundles, some 80 views, into 16 kernels: about
// 7 % of the default job's time (docs/PERFORMANCE.md). Their owner keeps their memory
// (Batch::Impl::own).
template <class T>
using KView = Kokkos::View<T*, MemSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>>;
}  // namespace loosepack
