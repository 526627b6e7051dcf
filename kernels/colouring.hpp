// Graph colouring of the contacts for parallel Gauss-Seidel: two contacts that share a body
// never get the same colour (the floor is not a body: it takes no velocity). Jones-Plassmann:
// in round r a contact takes colour r when no still-uncoloured contact sharing a body has a
// higher priority. Priorities hash the contact's index within its own system, so the colouring
// (and hence the sweep) of a system does not depend on the batch around it.
#pragma once
#include "kernels/random.hpp"
#include "kernels/state.hpp"

namespace loosepack {

// Holds only the two views it reads: a functor built inside a kernel copies its views, and on
// the Serial backend each copy of a view counts a reference.
struct ColourPriority {
  DView<int> offset;  // sys.offset
  DView<int> system;  // part.system
  KOKKOS_INLINE_FUNCTION unsigned long long operator()(int c) const {
    const int i = c / kSlots;
    const int local = (i - offset(system(i))) * kSlots + c % kSlots;
    // the low bits carry the local index, so priorities within a system are distinct
    return (static_cast<unsigned long long>(splitmix64(static_cast<std::uint64_t>(local))) << 24) |
           static_cast<unsigned long long>(local & 0xFFFFFF);
  }
};

// Reads: con.partner. Writes: con.colour.
struct ColourReset {
  ContactViews con;
  KOKKOS_INLINE_FUNCTION void operator()(int c) const {
    con.colour(c) = con.partner(c) == kNoContact ? -2 : -1;
  }
};

// One Jones-Plassmann round; counts the contacts still uncoloured after it.
// Reads: sys.offset; part.{system, n_incident, incident}; con.partner. Reads and writes:
// con.colour.
struct ColourRound {
  ParticleViews part;
  ContactViews con;
  ColourPriority priority;
  int round;

  KOKKOS_INLINE_FUNCTION ColourRound(const SystemViews& sys, const ParticleViews& part,
                                     const ContactViews& con, int round)
      : part(part), con(con), priority{sys.offset, part.system}, round(round) {}

  KOKKOS_INLINE_FUNCTION bool blocked_by(int body, int c, unsigned long long prio) const {
    const int n = part.n_incident(body);
    for (int a = 0; a < n; ++a) {
      const int o = part.incident(body * kIncident + a);
      if (o == c) continue;
      const int oc = con.colour(o);
      if ((oc == -1 || oc == round) && priority(o) > prio) return true;
    }
    return false;
  }

  KOKKOS_INLINE_FUNCTION void operator()(int c, int& uncoloured) const {
    if (con.colour(c) != -1) return;
    const unsigned long long prio = priority(c);
    const int i = c / kSlots, j = con.partner(c);
    if (blocked_by(i, c, prio) || (j >= 0 && blocked_by(j, c, prio))) {
      ++uncoloured;
      return;
    }
    con.colour(c) = round;
  }
};

}  // namespace loosepack
