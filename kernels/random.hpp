// Counter-based random numbers: a draw is a pure function of (scan seed, member id, draw index),
// so a member's result does not depend on its batch, thread count or MPI rank.
#pragma once
#include <cstdint>

#include "kernels/compat.hpp"

namespace loosepack {

// SplitMix64 finaliser applied to state + golden ratio (one SplitMix64 step from `state`).
KOKKOS_INLINE_FUNCTION std::uint64_t splitmix64(std::uint64_t state) {
  std::uint64_t z = state + 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Uniform in [0, 1) with 53 random bits.
KOKKOS_INLINE_FUNCTION double uniform01(std::uint64_t seed, std::uint64_t member,
                                        std::uint64_t draw) {
  const std::uint64_t key = splitmix64(seed ^ splitmix64(member + 0x5851F42D4C957F2DULL));
  const std::uint64_t z = splitmix64(key + draw * 0x9E3779B97F4A7C15ULL);
  return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
}

}  // namespace loosepack
